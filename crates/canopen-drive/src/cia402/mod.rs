//! CiA 402 drive profile (CiA 402-2).
//!
//! - [`fsa`]: the power drive system state machine, a pure transition function.
//! - [`config`]: what a drive supports (option codes, set-point buffer, tick rate).
//! - [`factor`]: the factor group and polarity (user units ↔ increments).
//! - [`pp`]: profile position mode.
//! - `pv`, `tq`: profile velocity and profile torque mode.
//! - [`hm`]: homing mode.
//! - [`cyclic`]: cyclic synchronous position, velocity and torque modes.
//! - [`ip`]: the input buffer of interpolated position mode (60C0h–60C4h) and its value rules.
//! - [`vl`]: velocity mode (6042h–604Ch): limit, ramp generator and factors of the inverter mode.
//! - [`probe`]: the touch probe function (60B8h–60BDh), latching positions at probe edges.
//! - [`words`]: the controlword and the statusword as typed bit sets.
//! - [`objects`]: the leaf every mode imports: the profile objects' indices, the modes,
//!   [`objects::Rule`] and the constructors of object descriptions.
//! - [`registry`]: above the modes: the table of the profile objects this build has (each
//!   mode declares its own), the modes it runs and the value rules of an SDO write.
//! - [`profile`]: the run-time of one axis: FSA, option-code stops, the active mode, statusword,
//!   actual values and the demand for the power stage.
//!
//! pv, tq, csp, csv and cst are in every build; pp, hm, ip, vl and the touch probe are cargo
//! features (all on by default, see [`PP`] …): a mode left out is missing from
//! [`registry::IMPLEMENTED_MODES`], its objects from [`registry::PROFILE`] and its code from the
//! image (its run-time calls sit behind these constants and fold away).

pub mod config;
pub mod cyclic;
pub mod factor;
pub mod fsa;
pub mod hm;
pub mod ip;
mod memo;
pub mod objects;
pub mod pp;
pub mod probe;
pub mod profile;
mod pv;
pub mod registry;
mod slots;
mod tq;
pub mod vl;
pub mod words;

/// Whether this build runs profile position mode (cargo feature `pp`).
pub const PP: bool = cfg!(feature = "pp");
/// Whether this build runs homing mode (cargo feature `hm`).
pub const HM: bool = cfg!(feature = "hm");
/// Whether this build runs interpolated position mode (cargo feature `ip`).
pub const IP: bool = cfg!(feature = "ip");
/// Whether this build runs velocity mode (cargo feature `vl`).
pub const VL: bool = cfg!(feature = "vl");
/// Whether this build has the touch probe function (cargo feature `touch-probe`).
pub const PROBE: bool = cfg!(feature = "touch-probe");

pub use objects::Axis;

pub use config::{
    DirectMode, MotorSpeedUnit, OptionCodes, ProfileConfig, StatusFlag, TorqueUnit, TravelLimit, Units,
    VelocityUnit,
};

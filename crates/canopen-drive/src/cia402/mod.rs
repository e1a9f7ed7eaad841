//! CiA 402 drive profile (CiA 402-2).
//!
//! - [`fsa`]: the power drive system state machine, a pure transition function.
//! - [`config`]: what a drive supports (option codes, set-point buffer, tick rate).
//! - [`factor`]: the factor group and polarity (user units ↔ increments).
//! - [`pp`]: profile position mode.
//! - [`hm`]: homing mode.
//! - [`cyclic`]: cyclic synchronous position, velocity and torque modes.
//! - [`ip`]: the input buffer of interpolated position mode (60C0h–60C4h) and its value rules.
//! - [`vl`]: velocity mode (6042h–604Ch): limit, ramp generator and factors of the inverter mode.
//! - [`probe`]: the touch probe function (60B8h–60BDh), latching positions at probe edges.
//! - [`objects`]: the profile objects with their defaults and value rules.
//! - [`profile`]: the run-time of one axis: FSA, option-code stops, modes (pv, tq), statusword,
//!   actual values and the demand for the power stage.

pub mod config;
pub mod cyclic;
pub mod factor;
pub mod fsa;
pub mod hm;
pub mod ip;
pub mod objects;
pub mod pp;
pub mod probe;
pub mod profile;
mod slots;
pub mod vl;

pub use config::{
    DirectMode, MotorSpeedUnit, OptionCodes, ProfileConfig, StatusFlag, TorqueUnit, TravelLimit, Units,
    VelocityUnit,
};

//! What a firmware needs to build and run a drive, in one import:
//!
//! ```
//! use canopen_drive::prelude::*;
//!
//! let mut drive = Drive::new(Config::new(5)).unwrap();
//! drive.poll(Instant::ZERO);
//! assert_eq!(drive.pop_tx().map(|f| f.data()[0]), Some(0)); // the boot-up frame
//! ```
//!
//! The configuration (the drive, its identity, its CiA 402 profile and units), the board
//! interface (the sample in, the demand out, frames and time), the firmware's own objects (a
//! table described with [`Object`] and [`Var`], served through [`ObjectHooks`]) and parameter
//! storage over a flash area; and `embedded_can::Frame`'s methods on [`CanFrame`]. The modules
//! themselves hold the rest, for what goes beyond.

pub use crate::cia402::{MotorSpeedUnit, OptionCodes, ProfileConfig, TorqueUnit, Units, VelocityUnit};
pub use crate::drive::{CanState, Config, Drive};
pub use crate::frame::CanFrame;
pub use crate::hal::{Demand, DigitalInputs, FeedForward, HardwareFaults, Sample, Setpoint};
pub use crate::motion::TickRate;
pub use crate::od::{
    layout, AbortCode, Access, DataType, DefaultValue, DeviceInfo, EntryOverride, Object, ObjectHooks,
    PdoMapping, Var,
};
pub use crate::storage::{device_signature, NorFlashArea, Persistence, Storage};
pub use crate::time::{Duration, Instant};
pub use embedded_can::Frame as _;

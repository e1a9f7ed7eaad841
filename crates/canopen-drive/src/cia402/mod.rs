//! CiA 402 drive profile (CiA 402-2).
//!
//! - [`fsa`]: the power drive system state machine, a pure transition function.
//! - [`objects`]: the profile objects with their defaults and value rules.
//! - [`profile`]: the run-time of one axis: FSA, option-code stops, modes (pv, tq), statusword,
//!   actual values and the demand for the power stage.

pub mod fsa;
pub mod objects;
pub mod profile;

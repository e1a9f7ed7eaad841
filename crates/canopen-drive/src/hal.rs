//! What a board gives the core each control-loop tick and gets back from it.
//!
//! This is the minimal shape the communication layer needs; the CiA 402 work fills in the
//! power-stage and feedback details (positions, velocities, switches, hardware faults).

/// One feedback sample, taken by the board at the tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Position actual value in encoder increments.
    pub position: i32,
    /// Velocity actual value in increments per second.
    pub velocity: i32,
    /// Torque actual value in thousandths of the rated torque.
    pub torque: i16,
    /// DC-link voltage in mV.
    pub dc_link_millivolts: u32,
}

/// What the power stage should do until the next tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Demand {
    /// No energy to the motor (power stage off).
    #[default]
    Off,
    /// Torque demand in thousandths of the rated torque.
    Torque(i16),
    /// Velocity demand in increments per second.
    Velocity(i32),
    /// Position demand in increments.
    Position(i32),
}

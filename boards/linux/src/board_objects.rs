//! Manufacturer objects of this board (2100h–2102h) that let a master drive the simulated
//! motor's environment, so a remote test can exercise fault reactions and switches:
//!
//! | index | name | type | meaning |
//! |---|---|---|---|
//! | 2100h | Simulated hardware faults | UNSIGNED32 rw | bits of `HardwareFaults` (0 over-current, 1 over-voltage, 2 under-voltage, 3 over-temperature, 4 encoder); writing 0 clears them |
//! | 2101h | Simulated digital inputs | UNSIGNED32 rw | inputs forced active: bit 0 negative limit, 1 positive limit, 2 home, 3 interlock, 5 quick stop |
//! | 2102h | Simulated load torque | INTEGER16 rw | external load on the shaft, ‰ of rated torque |
//!
//! A write is stored in the dictionary and picked up by the real-time loop at its next
//! iteration ([`BoardHooks::take_changes`]).

use canopen_drive::hal::{DigitalInputs, HardwareFaults};
use canopen_drive::od::{layout, Access, DataType, Object, ObjectHooks, Var};
use canopen_drive_sim::motor::SimMotor;

/// 2100h.
pub const SIMULATED_FAULTS: u16 = 0x2100;
/// 2101h.
pub const SIMULATED_INPUTS: u16 = 0x2101;
/// 2102h.
pub const SIMULATED_LOAD: u16 = 0x2102;

/// The board's objects.
pub static BOARD_OBJECTS: [Object; 3] = layout([
    Object::var(
        SIMULATED_FAULTS,
        "Simulated hardware faults",
        Var::new("Simulated hardware faults", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .limits_unsigned(0, 0x1F),
    ),
    Object::var(
        SIMULATED_INPUTS,
        "Simulated digital inputs",
        Var::new("Simulated digital inputs", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .limits_unsigned(0, 0x3F),
    ),
    Object::var(
        SIMULATED_LOAD,
        "Simulated load torque",
        Var::new("Simulated load torque", DataType::Integer16)
            .access(Access::ReadWrite)
            .limits_signed(-3000, 3000),
    ),
]);

/// A change a master wrote, for the loop to apply to the motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Change {
    /// 2100h.
    Faults(u32),
    /// 2101h.
    Inputs(u32),
    /// 2102h.
    Load(i16),
}

/// Records writes to the board objects.
#[derive(Debug, Default)]
pub struct BoardHooks {
    changes: Vec<Change>,
}

impl BoardHooks {
    /// The changes since the last call.
    pub fn take_changes(&mut self) -> Vec<Change> {
        std::mem::take(&mut self.changes)
    }
}

impl ObjectHooks for BoardHooks {
    fn written(&mut self, index: u16, _sub: u8, data: &[u8]) {
        let raw = data.iter().rev().fold(0u32, |acc, b| (acc << 8) | u32::from(*b));
        match index {
            SIMULATED_FAULTS => self.changes.push(Change::Faults(raw)),
            SIMULATED_INPUTS => self.changes.push(Change::Inputs(raw)),
            SIMULATED_LOAD => self.changes.push(Change::Load(raw as u16 as i16)),
            _ => {}
        }
    }
}

/// Applies a change to the motor.
pub fn apply(change: Change, motor: &mut SimMotor) {
    match change {
        Change::Faults(bits) => {
            motor.clear_faults();
            motor.inject_fault(HardwareFaults::from_bits_truncate(bits));
        }
        Change::Inputs(bits) => {
            let forced = DigitalInputs::from_bits_truncate(bits);
            motor.set_input(DigitalInputs::all(), false);
            motor.set_input(forced, true);
        }
        Change::Load(permille) => motor.set_load_torque(f64::from(permille)),
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    #[test]
    fn writes_reach_the_motor() {
        let mut hooks = BoardHooks::default();
        hooks.written(SIMULATED_FAULTS, 0, &1u32.to_le_bytes());
        hooks.written(SIMULATED_INPUTS, 0, &4u32.to_le_bytes());
        hooks.written(SIMULATED_LOAD, 0, &(-200i16).to_le_bytes());
        let mut motor = SimMotor::new();
        for change in hooks.take_changes() {
            apply(change, &mut motor);
        }
        let sample = motor.sample();
        assert_eq!(sample.faults, HardwareFaults::OVER_CURRENT);
        assert_eq!(sample.inputs & DigitalInputs::HOME, DigitalInputs::HOME);
        assert_eq!(motor.load_torque(), -200.0);
        assert!(hooks.take_changes().is_empty());
    }
}

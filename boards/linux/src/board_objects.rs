//! Manufacturer objects of this board that let a master drive the simulated motor's
//! environment, so a remote test can exercise fault reactions and switches, and the hooks that
//! pass every write of a manufacturer object on to the real-time loop.
//!
//! The three simulation objects sit at 2100h–2102h in the generic drive (whose manufacturer
//! objects come from an EDS: `examples/eds-import`), and at 5E00h–5E02h in the vendor profiles
//! (whose manuals use 2100h–2102h themselves):
//!
//! | index | name | type | meaning |
//! |---|---|---|---|
//! | +0 | Simulated hardware faults | UNSIGNED32 rw | bits of `HardwareFaults` (0 over-current, 1 over-voltage, 2 under-voltage, 3 over-temperature, 4 encoder); writing 0 clears them |
//! | +1 | Simulated digital inputs | UNSIGNED32 rw | inputs forced active: bit 0 negative limit, 1 positive limit, 2 home, 3 interlock, 5 quick stop, 6 touch probe 1, 7 touch probe 2 |
//! | +2 | Simulated load torque | INTEGER16 rw | external load on the shaft, ‰ of rated torque |
//!
//! A write is stored in the dictionary and picked up by the real-time loop at its next
//! iteration ([`BoardHooks::take_changes`]), before the next SDO request is served.

use std::ops::RangeInclusive;

use canopen_drive::hal::{DigitalInputs, HardwareFaults};
use canopen_drive::od::{AbortCode, Access, DataType, Object, ObjectHooks, Var};
use canopen_drive_sim::motor::SimMotor;

/// Index of the first simulation object in the generic drive.
pub const GENERIC_SIMULATION: u16 = 0x2100;
/// Index of the first simulation object in the vendor profiles.
pub const PROFILE_SIMULATION: u16 = 0x5E00;

/// The simulated-faults object at `index` (the first of the three).
pub const fn simulated_faults(index: u16) -> Object {
    Object::var(
        index,
        "Simulated hardware faults",
        Var::new("Simulated hardware faults", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .limits_unsigned(0, 0x1F),
    )
}

/// The simulated-inputs object at `index` (the second).
pub const fn simulated_inputs(index: u16) -> Object {
    Object::var(
        index,
        "Simulated digital inputs",
        Var::new("Simulated digital inputs", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .limits_unsigned(0, 0xFF),
    )
}

/// The simulated-load object at `index` (the third).
pub const fn simulated_load(index: u16) -> Object {
    Object::var(
        index,
        "Simulated load torque",
        Var::new("Simulated load torque", DataType::Integer16)
            .access(Access::ReadWrite)
            .limits_signed(-3000, 3000),
    )
}

/// A value rule of a manufacturer object beyond its type and limits: the only values it takes
/// (a signature, a list of bit rates), and whether it needs parameter storage.
#[derive(Clone, Copy, Debug)]
pub struct ValueRule {
    /// Index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// The values accepted; empty: any value within the limits.
    pub values: &'static [RangeInclusive<u64>],
    /// The abort code of a value not in `values`.
    pub refusal: AbortCode,
    /// The write is a store command, refused with 0x0800_0020 without a storage file.
    pub stores: bool,
}

/// A change a master wrote, for the loop to apply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Change {
    /// Simulated faults (+0) of an axis.
    Faults(u8, u32),
    /// Simulated inputs (+1) of an axis.
    Inputs(u8, u32),
    /// Simulated load (+2) of an axis.
    Load(u8, i16),
    /// Another manufacturer object (2000h–5FFFh), for the profile's firmware.
    Written {
        /// Index.
        index: u16,
        /// Sub-index.
        sub: u8,
        /// The value written (little-endian, up to 8 bytes).
        value: u64,
    },
    /// A store on command (1010h) succeeded for this sub-index (group).
    Stored(u8),
}

/// Records writes to manufacturer objects and checks the profile's value rules.
#[derive(Debug)]
pub struct BoardHooks {
    simulation: u16,
    /// The axes whose simulation objects follow the first's ([`crate::axes`]).
    axes: u8,
    rules: &'static [ValueRule],
    storage: bool,
    changes: Vec<Change>,
}

impl Default for BoardHooks {
    fn default() -> Self {
        BoardHooks::new(GENERIC_SIMULATION, &[], false)
    }
}

impl BoardHooks {
    /// Hooks for simulation objects at `simulation`, with `rules`; `storage`: the board keeps
    /// parameters (a store command can succeed).
    pub fn new(simulation: u16, rules: &'static [ValueRule], storage: bool) -> Self {
        BoardHooks { simulation, axes: 1, rules, storage, changes: Vec::new() }
    }

    /// The hooks of a node of `axes` axes: axis n's simulation objects lie
    /// [`crate::axes::SIMULATION_STRIDE`] × n above the first axis's.
    pub fn with_axes(mut self, axes: u8) -> Self {
        self.axes = axes.max(1);
        self
    }

    /// The changes since the last call.
    pub fn take_changes(&mut self) -> Vec<Change> {
        std::mem::take(&mut self.changes)
    }
}

fn little_endian(data: &[u8]) -> u64 {
    data.iter().take(8).rev().fold(0u64, |acc, b| (acc << 8) | u64::from(*b))
}

impl ObjectHooks for BoardHooks {
    fn validate(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let value = little_endian(data);
        for rule in self.rules.iter().filter(|r| r.index == index && r.sub == sub) {
            if !rule.values.is_empty() && !rule.values.iter().any(|r| r.contains(&value)) {
                return Err(rule.refusal);
            }
            if rule.stores && !self.storage {
                return Err(AbortCode::CannotStore);
            }
        }
        Ok(())
    }

    fn written(&mut self, index: u16, sub: u8, data: &[u8]) {
        let raw = little_endian(data);
        let offset = index.wrapping_sub(self.simulation);
        let (axis, object) =
            (offset / crate::axes::SIMULATION_STRIDE, offset % crate::axes::SIMULATION_STRIDE);
        let axis = u8::try_from(axis).ok().filter(|a| *a < self.axes);
        let change = match (axis, object) {
            (Some(axis), 0) => Change::Faults(axis, raw as u32),
            (Some(axis), 1) => Change::Inputs(axis, raw as u32),
            (Some(axis), 2) => Change::Load(axis, raw as u16 as i16),
            // Manufacturer objects, and the profile's (a firmware may couple standard entries).
            _ if (0x2000..=0x9FFF).contains(&index) => Change::Written { index, sub, value: raw },
            _ => return,
        };
        self.changes.push(change);
    }

    fn stored(&mut self, sub: u8) {
        self.changes.push(Change::Stored(sub));
    }
}

/// Applies a simulation change to the motor of its axis (other changes are the firmware's).
pub fn apply(change: Change, motors: &mut [SimMotor]) {
    let (Change::Faults(axis, _) | Change::Inputs(axis, _) | Change::Load(axis, _)) = change else {
        return;
    };
    let Some(motor) = motors.get_mut(usize::from(axis)) else { return };
    match change {
        Change::Faults(_, bits) => {
            motor.clear_faults();
            motor.inject_fault(HardwareFaults::from_bits_truncate(bits));
        }
        Change::Inputs(_, bits) => {
            let forced = DigitalInputs::from_bits_truncate(bits);
            motor.set_input(DigitalInputs::all(), false);
            motor.set_input(forced, true);
        }
        Change::Load(_, permille) => motor.set_load_torque(f64::from(permille)),
        Change::Written { .. } | Change::Stored(_) => {}
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    /// The generic drive's simulation objects, generated from its EDS, are the ones the vendor
    /// profiles build at 5E00h: same names, types, access and limits.
    #[test]
    fn the_eds_describes_the_simulation_objects() {
        let generated = &canopen_drive_example_eds_import::MANUFACTURER_OBJECTS;
        let expected = [
            simulated_faults(GENERIC_SIMULATION),
            simulated_inputs(GENERIC_SIMULATION + 1),
            simulated_load(GENERIC_SIMULATION + 2),
        ];
        for object in expected {
            let found = generated.iter().find(|o| o.index == object.index).unwrap();
            assert_eq!(found.kind, object.kind, "{:04X}h", object.index);
            assert_eq!(found.name(), object.name());
        }
    }

    #[test]
    fn writes_reach_the_motor() {
        let mut hooks = BoardHooks::default();
        hooks.written(0x2100, 0, &1u32.to_le_bytes());
        hooks.written(0x2101, 0, &4u32.to_le_bytes());
        hooks.written(0x2102, 0, &(-200i16).to_le_bytes());
        let mut motor = SimMotor::new();
        for change in hooks.take_changes() {
            apply(change, std::slice::from_mut(&mut motor));
        }
        let sample = motor.sample();
        assert_eq!(sample.faults, HardwareFaults::OVER_CURRENT);
        assert_eq!(sample.inputs & DigitalInputs::HOME, DigitalInputs::HOME);
        assert_eq!(motor.load_torque(), -200.0);
        assert!(hooks.take_changes().is_empty());
    }

    /// With two axes, 2110h–2112h are the second axis's simulation objects; with one, they are
    /// plain manufacturer objects.
    #[test]
    fn writes_reach_the_motor_of_their_axis() {
        let mut hooks = BoardHooks::default().with_axes(2);
        hooks.written(0x2110, 0, &1u32.to_le_bytes());
        hooks.written(0x2102, 0, &(-200i16).to_le_bytes());
        hooks.written(0x2120, 0, &2u32.to_le_bytes());
        let mut motors = [SimMotor::new(), SimMotor::new()];
        let changes = hooks.take_changes();
        assert_eq!(
            changes,
            [
                Change::Faults(1, 1),
                Change::Load(0, -200),
                Change::Written { index: 0x2120, sub: 0, value: 2 }
            ]
        );
        for change in changes {
            apply(change, &mut motors);
        }
        assert_eq!(motors[0].sample().faults, HardwareFaults::empty());
        assert_eq!(motors[1].sample().faults, HardwareFaults::OVER_CURRENT);
        assert_eq!((motors[0].load_torque(), motors[1].load_torque()), (-200.0, 0.0));
        let mut single = BoardHooks::default();
        single.written(0x2110, 0, &1u32.to_le_bytes());
        assert_eq!(single.take_changes(), [Change::Written { index: 0x2110, sub: 0, value: 1 }]);
    }

    #[test]
    fn rules_and_the_writes_the_firmware_sees() {
        static RULES: [ValueRule; 2] = [
            ValueRule {
                index: 0x2704,
                sub: 0,
                values: &[125..=125, 500..=1000],
                refusal: AbortCode::InvalidValue,
                stores: false,
            },
            ValueRule {
                index: 0x2706,
                sub: 0,
                values: &[0x6576_6173..=0x6576_6173],
                refusal: AbortCode::CannotStore,
                stores: true,
            },
        ];
        let mut hooks = BoardHooks::new(PROFILE_SIMULATION, &RULES, false);
        assert_eq!(hooks.validate(0x2704, 0, &125u16.to_le_bytes()), Ok(()));
        assert_eq!(hooks.validate(0x2704, 0, &126u16.to_le_bytes()), Err(AbortCode::InvalidValue));
        assert_eq!(hooks.validate(0x2704, 0, &800u16.to_le_bytes()), Ok(()));
        assert_eq!(hooks.validate(0x2706, 0, &0x6576_6173u32.to_le_bytes()), Err(AbortCode::CannotStore));
        let mut stored = BoardHooks::new(PROFILE_SIMULATION, &RULES, true);
        assert_eq!(stored.validate(0x2706, 0, &0x6576_6173u32.to_le_bytes()), Ok(()));
        assert_eq!(stored.validate(0x2706, 0, &1u32.to_le_bytes()), Err(AbortCode::CannotStore));
        hooks.written(0x5E01, 0, &4u32.to_le_bytes());
        hooks.written(0x2704, 0, &125u16.to_le_bytes());
        hooks.written(0x1017, 0, &100u16.to_le_bytes()); // communication: not the firmware's
        hooks.written(0x607F, 0, &15u32.to_le_bytes());
        hooks.stored(2);
        assert_eq!(
            hooks.take_changes(),
            [
                Change::Inputs(0, 4),
                Change::Written { index: 0x2704, sub: 0, value: 125 },
                Change::Written { index: 0x607F, sub: 0, value: 15 },
                Change::Stored(2)
            ]
        );
    }
}

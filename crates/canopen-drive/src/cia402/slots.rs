//! The CiA 402 entries the control tick reads and writes, resolved once.
//!
//! A dictionary lookup (binary search per table, then the sub-index) costs a few hundred
//! instructions; the tick touches some fifty entries. [`Slots`] holds each as an
//! [`od::Slot`](crate::od::Slot) (its offset in the value store), so a per-tick access is a bounds
//! check and a byte copy. The profile resolves them with its factors (first tick, and whenever
//! the factors are refreshed); until then every slot falls back to a lookup, so the answers are
//! the same either way. The entries are the profile's axis's ([`Axis::index`]).

use super::objects::*;
use super::probe::{TOUCH_PROBE_FUNCTION, TOUCH_PROBE_STATUS};
use super::Axis;
use crate::od::{Dictionary, IntSlot, Slot};

/// The slot type of an entry: `int` for a signed integer of the entry's own width (an entry a
/// firmware may widen), a scalar type otherwise.
macro_rules! slot_type {
    (int) => { IntSlot };
    ($t:ty) => { Slot<$t> };
}

macro_rules! slot_lookup {
    (int, $index:expr, $sub:expr) => {
        IntSlot::lookup($index, $sub)
    };
    ($t:ty, $index:expr, $sub:expr) => {
        Slot::<$t>::lookup($index, $sub)
    };
}

macro_rules! slot_resolve {
    (int, $od:expr, $index:expr, $sub:expr) => {
        $od.int_slot($index, $sub)
    };
    ($t:ty, $od:expr, $index:expr, $sub:expr) => {
        $od.slot::<$t>($index, $sub)
    };
}

macro_rules! slots {
    ($($field:ident: $t:tt = $index:expr, $sub:expr;)*) => {
        /// The per-tick entries (name: type = index, sub-index).
        #[derive(Clone, Copy, Debug)]
        pub(crate) struct Slots {
            $(pub $field: slot_type!($t),)*
        }

        impl Slots {
            /// Slots of the first axis's entries that look their entry up on every access.
            pub const UNRESOLVED: Slots = Slots { $($field: slot_lookup!($t, $index, $sub),)* };

            /// Every slot of `axis`'s entries resolved in `od`, one by one in place (no second
            /// set of slots, some 0.5 KiB, on the stack of the tick that resolves them).
            pub fn resolve<const B: usize>(&mut self, od: &Dictionary<B>, axis: Axis) {
                $(self.$field = slot_resolve!($t, od, axis.index($index), $sub);)*
            }

            /// Whether every slot resolved to a stored value of its type (a test of the
            /// types written above).
            #[cfg(test)]
            pub fn all_stored(&self) -> bool {
                true $(&& self.$field.is_stored())*
            }
        }
    };
}

slots! {
    // Commands and set-points.
    controlword: u16 = CONTROLWORD, 0;
    modes_of_operation: i8 = MODES_OF_OPERATION, 0;
    target_position: i32 = TARGET_POSITION, 0;
    target_velocity: i32 = TARGET_VELOCITY, 0;
    target_torque: int = TARGET_TORQUE, 0;
    position_offset: i32 = POSITION_OFFSET, 0;
    velocity_offset: i32 = VELOCITY_OFFSET, 0;
    torque_offset: int = TORQUE_OFFSET, 0;
    touch_probe_function: u16 = TOUCH_PROBE_FUNCTION, 0;
    digital_outputs_physical: u32 = DIGITAL_OUTPUTS, 1;
    digital_outputs_mask: u32 = DIGITAL_OUTPUTS, 2;
    // Option codes.
    abort_connection: i16 = ABORT_CONNECTION_OPTION_CODE, 0;
    quick_stop_option: i16 = QUICK_STOP_OPTION_CODE, 0;
    shutdown_option: i16 = SHUTDOWN_OPTION_CODE, 0;
    disable_operation_option: i16 = DISABLE_OPERATION_OPTION_CODE, 0;
    halt_option: i16 = HALT_OPTION_CODE, 0;
    fault_reaction_option: i16 = FAULT_REACTION_OPTION_CODE, 0;
    // pp.
    profile_velocity: u32 = PROFILE_VELOCITY, 0;
    end_velocity: u32 = END_VELOCITY, 0;
    motion_profile_type: i16 = MOTION_PROFILE_TYPE, 0;
    profile_jerk_use: u8 = PROFILE_JERK_USE, 0;
    profile_jerk_1: u32 = PROFILE_JERK, 1;
    profile_jerk_2: u32 = PROFILE_JERK, 2;
    profile_jerk_3: u32 = PROFILE_JERK, 3;
    profile_jerk_4: u32 = PROFILE_JERK, 4;
    positioning_option_code: u16 = POSITIONING_OPTION_CODE, 0;
    position_range_limit_min: i32 = POSITION_RANGE_LIMIT, 1;
    position_range_limit_max: i32 = POSITION_RANGE_LIMIT, 2;
    software_position_limit_min: i32 = SOFTWARE_POSITION_LIMIT, 1;
    software_position_limit_max: i32 = SOFTWARE_POSITION_LIMIT, 2;
    position_window: u32 = POSITION_WINDOW, 0;
    position_window_time: u16 = POSITION_WINDOW_TIME, 0;
    // Limits, ramps, windows.
    max_torque: u16 = MAX_TORQUE, 0;
    max_current: u16 = MAX_CURRENT, 0;
    max_profile_velocity: u32 = MAX_PROFILE_VELOCITY, 0;
    max_motor_speed: u32 = MAX_MOTOR_SPEED, 0;
    max_acceleration: u32 = MAX_ACCELERATION, 0;
    max_deceleration: u32 = MAX_DECELERATION, 0;
    profile_acceleration: u32 = PROFILE_ACCELERATION, 0;
    profile_deceleration: u32 = PROFILE_DECELERATION, 0;
    quick_stop_deceleration: u32 = QUICK_STOP_DECELERATION, 0;
    torque_slope: u32 = TORQUE_SLOPE, 0;
    homing_speed_switch: u32 = HOMING_SPEEDS, 1;
    homing_speed_zero: u32 = HOMING_SPEEDS, 2;
    homing_acceleration: u32 = HOMING_ACCELERATION, 0;
    homing_method: i8 = HOMING_METHOD, 0;
    home_offset: i32 = HOME_OFFSET, 0;
    following_error_window: u32 = FOLLOWING_ERROR_WINDOW, 0;
    following_error_time_out: u16 = FOLLOWING_ERROR_TIME_OUT, 0;
    max_slippage: i32 = MAX_SLIPPAGE, 0;
    velocity_window: u16 = VELOCITY_WINDOW, 0;
    velocity_window_time: u16 = VELOCITY_WINDOW_TIME, 0;
    velocity_threshold: u16 = VELOCITY_THRESHOLD, 0;
    velocity_threshold_time: u16 = VELOCITY_THRESHOLD_TIME, 0;
    interpolation_period_value: u8 = INTERPOLATION_TIME_PERIOD, 1;
    interpolation_period_index: i8 = INTERPOLATION_TIME_PERIOD, 2;
    sync_window: u32 = 0x1007, 0;
    // Actual and demand values.
    statusword: u16 = STATUSWORD, 0;
    error_code: u16 = ERROR_CODE, 0;
    modes_of_operation_display: i8 = MODES_OF_OPERATION_DISPLAY, 0;
    position_actual_internal: i32 = POSITION_ACTUAL_INTERNAL_VALUE, 0;
    position_actual: i32 = POSITION_ACTUAL_VALUE, 0;
    velocity_actual: i32 = VELOCITY_ACTUAL_VALUE, 0;
    torque_actual: int = TORQUE_ACTUAL_VALUE, 0;
    current_actual: int = CURRENT_ACTUAL_VALUE, 0;
    dc_link_voltage: u32 = DC_LINK_VOLTAGE, 0;
    digital_inputs: u32 = DIGITAL_INPUTS, 0;
    touch_probe_status: u16 = TOUCH_PROBE_STATUS, 0;
    position_demand: i32 = POSITION_DEMAND_VALUE, 0;
    position_demand_internal: i32 = POSITION_DEMAND_INTERNAL_VALUE, 0;
    velocity_demand: i32 = VELOCITY_DEMAND_VALUE, 0;
    torque_demand: int = TORQUE_DEMAND, 0;
    following_error_actual: i32 = FOLLOWING_ERROR_ACTUAL_VALUE, 0;
    control_effort: i32 = CONTROL_EFFORT, 0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Config, Drive};

    /// A slot whose type does not match its entry would fall back to a lookup that answers 0:
    /// in the standard dictionary every slot must reach its stored value directly.
    #[test]
    fn every_slot_resolves_to_a_stored_value_of_its_type() {
        let drive = Drive::new(Config::new(5)).unwrap();
        let mut slots = Slots::UNRESOLVED;
        slots.resolve(drive.od(), Axis::FIRST);
        assert!(slots.all_stored(), "{slots:?}");
        let unresolved = Slots::UNRESOLVED;
        assert!(!unresolved.controlword.is_stored());
        assert_eq!(drive.od().load(unresolved.controlword), drive.od().load(slots.controlword));
    }
}

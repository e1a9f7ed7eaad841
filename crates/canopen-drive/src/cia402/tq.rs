//! Profile torque mode (tq, 6060h = 4; CiA 402-2 §15).
//!
//! The torque demand ramps towards the target torque 6071h with the torque slope 6087h, and
//! towards 0 while halt is set. It never exceeds min(6072h, 6073h): a limit lowered below the
//! running torque holds at once. The mode keeps no state of its own; the
//! ramp is the axis's torque demand.

use super::factor::Factors;
use super::slots::Slots;
use crate::od::Dictionary;

/// The torque limit min(6072h, 6073h) (‰ of rated torque; the torque is taken as proportional
/// to the torque-producing current).
pub(crate) fn torque_limit<const B: usize>(od: &Dictionary<B>, slots: &Slots) -> i64 {
    i64::from(od.load(slots.max_torque).min(od.load(slots.max_current)))
}

/// The target torque 6071h within the torque limit (internal units).
pub(crate) fn target<const B: usize>(od: &Dictionary<B>, slots: &Slots, factors: &Factors) -> i64 {
    let max = torque_limit(od, slots);
    factors.torque_to_internal(od.load_int(slots.target_torque)).clamp(-max, max)
}

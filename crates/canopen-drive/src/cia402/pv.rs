//! Profile velocity mode (pv, 6060h = 3; CiA 402-2 §14).
//!
//! The velocity demand ramps towards the target velocity 60FFh, limited to min(607Fh, 6080h):
//! speeding up with min(6083h, 60C5h), slowing down with min(6084h, 60C6h). No velocity towards
//! an active limit switch ([`ProfileConfig::limit_switches_stop`](super::ProfileConfig)). The
//! ramp itself is the axis's velocity demand, which the stop ramps continue; the mode keeps the
//! timers of its status bits:
//!
//! - bit 10, target reached: |60FFh − 606Ch| ≤ 606Dh for 606Eh ms (the timer starts over when
//!   60FFh changes);
//! - bit 12, speed: |606Ch| ≤ 606Fh, or above it for no longer than 6070h ms;
//! - bit 13, max slippage: |606Bh − 606Ch| ≥ 60F8h when 60F8h is positive.

use super::factor::Factors;
use super::slots::Slots;
use crate::od::Dictionary;
use crate::time::{Duration, Instant};

/// The state of pv while it is the active mode: its status timers.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Run {
    /// Since when the actual velocity is within the velocity window of the target.
    in_window_since: Option<Instant>,
    /// Since when |606Ch| is above the velocity threshold.
    above_threshold_since: Option<Instant>,
    /// The target velocity the window timer runs for.
    target: i32,
}

/// What the velocity ramp aims at in this tick.
pub(crate) struct Aim {
    /// The velocity (increments/s).
    pub velocity: i64,
    /// The rate (increments/s²).
    pub rate: u32,
    /// The target velocity before an active limit switch held it at 0 (increments/s).
    pub wanted: i64,
}

impl Run {
    /// pv becomes active: no timer runs.
    pub const fn start() -> Self {
        Run { in_window_since: None, above_threshold_since: None, target: 0 }
    }

    /// Whether a status timer runs (a tick later may change a bit without any new input).
    pub fn timing(&self) -> bool {
        self.above_threshold_since.is_some()
    }

    /// The ramp's aim in this tick, from `current` (the velocity demand, increments/s):
    /// `limit` is the velocity limit, `blocked` the encoder directions (positive, negative) an
    /// active limit switch blocks.
    pub fn aim<const B: usize>(
        od: &Dictionary<B>,
        slots: &Slots,
        factors: &Factors,
        limit: u32,
        blocked: (bool, bool),
        current: i64,
    ) -> Aim {
        let limit = i64::from(limit);
        let target_user = i64::from(od.load(slots.target_velocity)) * factors.velocity_sign();
        let wanted = factors.velocity_to_internal(target_user).clamp(-limit, limit);
        let mut target = wanted;
        let (positive_blocked, negative_blocked) = blocked;
        if (positive_blocked && target > 0) || (negative_blocked && target < 0) {
            // No velocity towards an active limit switch.
            target = 0;
        }
        // Accelerating away from zero uses 6083h, approaching zero 6084h.
        let accelerating = (target - current).signum() == current.signum() || current == 0;
        let rate = if accelerating {
            od.load(slots.profile_acceleration).min(od.load(slots.max_acceleration))
        } else {
            od.load(slots.profile_deceleration).min(od.load(slots.max_deceleration))
        };
        Aim { velocity: target, rate: factors.limit_to_internal(rate), wanted }
    }

    /// Bit 10 in Operation enabled without halt: the actual velocity has been within the
    /// velocity window of the target for the window time.
    pub fn target_reached<const B: usize>(
        &mut self,
        od: &Dictionary<B>,
        slots: &Slots,
        now: Instant,
    ) -> bool {
        let target: i32 = od.load(slots.target_velocity);
        if target != self.target {
            self.target = target;
            self.in_window_since = None;
        }
        let actual: i32 = od.load(slots.velocity_actual);
        let window = i64::from(od.load(slots.velocity_window));
        if (i64::from(target) - i64::from(actual)).abs() <= window {
            let since = *self.in_window_since.get_or_insert(now);
            let time = Duration::from_millis(u64::from(od.load(slots.velocity_window_time)));
            now - since >= time
        } else {
            self.in_window_since = None;
            false
        }
    }

    /// Bit 12: |606Ch| ≤ 606Fh, or above it for no longer than 6070h ms.
    pub fn speed_is_zero<const B: usize>(&mut self, od: &Dictionary<B>, slots: &Slots, now: Instant) -> bool {
        let threshold = i64::from(od.load(slots.velocity_threshold));
        if i64::from(od.load(slots.velocity_actual)).abs() <= threshold {
            self.above_threshold_since = None;
            return true;
        }
        let since = *self.above_threshold_since.get_or_insert(now);
        now - since <= Duration::from_millis(u64::from(od.load(slots.velocity_threshold_time)))
    }

    /// Bit 13: the velocity demand and the actual velocity (user units) differ by the max
    /// slippage 60F8h or more (off while 60F8h ≤ 0).
    pub fn slipping<const B: usize>(od: &Dictionary<B>, slots: &Slots, demand: i64, actual: i64) -> bool {
        let max: i32 = od.load(slots.max_slippage);
        max > 0 && (demand - actual).abs() >= i64::from(max)
    }
}

//! Cyclic synchronous modes: position (csp, 8), velocity (csv, 9), torque (cst, 10)
//! (CiA 402-2 §17–§19), and the interpolation they share with interpolated position mode.
//!
//! # The stream
//!
//! The master sends a target (607Ah, 60FFh or 6071h) in a synchronous RPDO each SYNC. The drive
//! takes it in the first tick after the SYNC and moves the demand linearly from where it is to
//! the new target over one interpolation period 60C2h, at the tick rate — with a 4 kHz tick and
//! a 1 kHz SYNC the demand changes every tick, not every SYNC. That costs one period of delay,
//! which the master's trajectory absorbs; it never jumps.
//!
//! # Loss of the stream
//!
//! A SYNC without a new target (the RPDO was lost) and a SYNC that does not come within the
//! period plus the tolerated jitter (the synchronous window 1007h, at least half a period) are
//! *missed cycles*. Each is bridged as [`CyclicConfig::bridge`] says: hold the last target, or
//! extrapolate it with the last segment's slope. After more than
//! [`CyclicConfig::max_missed_cycles`] missed cycles in a row the profile reacts as for a lost
//! connection (6007h) and sends EMCY 8700h (sync controller); a new target ends the loss.
//!
//! # Limits (every demand within the configured limits)
//!
//! - csp: the demand follows the interpolated target through a limiter with the velocity limit
//!   min(607Fh, 6080h) and the acceleration limits 60C5h/60C6h. A stream within the limits goes
//!   through unchanged; a jump beyond them is chased at the limits (braking so as not to
//!   overshoot) and statusword bit 11 (internal limit active) is 1 while the demand is a whole
//!   increment or more away from the stream. Note that an integer stream's own quantisation
//!   changes its slope by whole increments per period: at 1 kHz that asks for accelerations of
//!   up to 2·10⁶ increments/s² for a period, which a lower 60C5h smooths (and flags once the
//!   demand is an increment off).
//! - csv: the velocity demand is clamped to the velocity limit and ramps at most at 60C5h
//!   (speeding up) / 60C6h (slowing down); bit 11 while it does.
//! - cst: the torque demand is clamped to min(6072h, 6073h); bit 11 while it is.
//!
//! The offsets 60B0h (position, added to 607Ah), 60B1h (velocity feed-forward, added to 60FFh in
//! csv) and 60B2h (torque feed-forward, added to 6071h in cst) are absolute values: each tick
//! uses their present value, so the same value received twice is added once.
//!
//! # Arithmetic
//!
//! The limiter works in increments with 32 fractional bits in `i128`; interpolation is exact
//! (`from + (to − from)·k/N` from integers each tick), so nothing drifts.

use super::objects::mode::{CYCLIC_POSITION, CYCLIC_VELOCITY};
use crate::od::{Access, DataType, DefaultValue, Object, Var};

/// EMCY code when the stream is lost for longer than configured (CiA 402: sync controller).
pub const STREAM_LOST: u16 = 0x8700;

const ONE: i128 = 1 << 32;

/// How a missed cycle is bridged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Bridge {
    /// Keep the last target.
    Hold,
    /// Continue with the slope of the last segment.
    #[default]
    Extrapolate,
}

/// Configuration of the cyclic modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CyclicConfig {
    /// What a missed cycle does.
    pub bridge: Bridge,
    /// Missed cycles in a row that are bridged; one more is a lost stream.
    pub max_missed_cycles: u8,
    /// Index of a manufacturer object (UNSIGNED32, µs, ro; [`sync_phase_object`]) where the
    /// drive reports the phase of the last SYNC against the tick.
    pub sync_phase_object: Option<u16>,
    /// A set-point written by SDO (607Ah, 60FFh, 6071h) feeds the stream as an RPDO does, for
    /// masters that stream by SDO. Default false: the stream is process data (CiA 402), and a
    /// cycle without an RPDO is a missed one.
    pub sdo_set_points: bool,
    /// What starts a cycle of csp/csv/cst (default [`CycleStart::Sync`], CiA 402).
    pub cycle_start: CycleStart,
}

/// What starts a cycle of the cyclic synchronous modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CycleStart {
    /// The SYNC (CiA 402): the set-point received before it is reached over the interpolation
    /// period 60C2h; a SYNC without one is a missed cycle.
    Sync,
    /// A new set-point (written by RPDO, or by SDO with [`CyclicConfig::sdo_set_points`]), for
    /// drives used without SYNC: each is reached over 60C2h from when it arrives; without a
    /// new one the drive holds the last (no missed cycles, no lost stream).
    SetPoint,
}

impl CyclicConfig {
    /// Extrapolate up to 2 missed cycles; no phase object.
    pub const fn new() -> Self {
        CyclicConfig {
            bridge: Bridge::Extrapolate,
            max_missed_cycles: 2,
            sync_phase_object: None,
            sdo_set_points: false,
            cycle_start: CycleStart::Sync,
        }
    }
}

impl Default for CyclicConfig {
    fn default() -> Self {
        CyclicConfig::new()
    }
}

/// The SYNC phase object at `index`: the time from the last tick before a SYNC to the SYNC's
/// reception, in µs (UNSIGNED32, ro, TPDO-mappable). A board steering its PWM timer onto SYNC
/// keeps it constant.
pub const fn sync_phase_object(index: u16) -> Object {
    Object::var(
        index,
        "SYNC phase",
        Var::new("SYNC phase", DataType::Unsigned32)
            .access(Access::ReadOnly)
            .pdo(crate::od::PdoMapping::Tpdo)
            .default(DefaultValue::Zero),
    )
}

/// What the profile hands the cyclic modes at a tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cycle {
    /// A SYNC arrived since the previous tick.
    pub sync: bool,
    /// An RPDO was applied since the previous SYNC (the stream delivered).
    pub fresh: bool,
    /// Ticks per interpolation period (60C2h × tick rate), at least 1.
    pub period_ticks: u32,
    /// Extra ticks a SYNC may be late (jitter), at least half a period.
    pub tolerance_ticks: u32,
}

/// csp, csv or cst as the running mode of a profile ([`crate::cia402::profile`]): the stream
/// of set-points, the position limiter (csp) and a set-point held for the mode. It exists
/// while the mode is active.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// The mode (6060h value: 8, 9 or 10).
    pub mode: i8,
    /// The interpolated stream of set-points.
    pub interpolator: Interpolator,
    /// csp: the demand follows the stream within the limits.
    pub limiter: Limiter,
    /// A set-point arrived while the mode was not running ([`CycleStart::SetPoint`]): it is
    /// the target once the mode runs.
    pub held_set_point: bool,
}

impl Run {
    /// `mode` becomes active, the axis at `actual` (increments) and `velocity` (increments/s).
    pub fn start(mode: i8, actual: i64, velocity: i64) -> Self {
        let mut run = Run {
            mode,
            interpolator: Interpolator::default(),
            limiter: Limiter::default(),
            held_set_point: false,
        };
        run.reset(actual, velocity);
        run
    }

    /// The stream and the limiter start over from the axis as it is.
    pub fn reset(&mut self, actual: i64, velocity: i64) {
        self.limiter.reset(actual);
        let start = match self.mode {
            CYCLIC_POSITION => actual,
            CYCLIC_VELOCITY => velocity,
            _ => 0,
        };
        self.interpolator.reset(start);
    }
}

/// The interpolation of a stream of targets, shared by csp, csv, cst and ip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Interpolator {
    from: i64,
    to: i64,
    /// Slope of the previous segment (to − from), for extrapolation.
    slope: i64,
    ticks: u32,
    k: u32,
    /// The segment's progress `(to − from) × 2³² × k / ticks`, truncated toward zero, kept as
    /// its magnitude's quotient and remainder so that a tick adds instead of dividing.
    progress: Progress,
    since_sync: u32,
    missed: u32,
    started: bool,
}

/// The progress of a segment, `|to − from| × 2³² × k = quotient × ticks + remainder`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Progress {
    /// `|to − from| × 2³² = per_tick × ticks + per_tick_remainder`.
    per_tick: u128,
    per_tick_remainder: u32,
    quotient: u128,
    remainder: u32,
    /// `to < from`: the progress counts down.
    negative: bool,
}

/// What happened to the stream in a tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StreamState {
    /// Consecutive missed cycles.
    pub missed: u32,
    /// A new segment started this tick.
    pub new_segment: bool,
}

impl Interpolator {
    /// Holds `value` until the first target.
    pub fn reset(&mut self, value: i64) {
        *self = Interpolator { from: value, to: value, ticks: 1, k: 1, ..Interpolator::default() };
    }

    /// The interpolated value now.
    pub fn value(&self) -> i64 {
        Self::whole(self.value_fixed())
    }

    /// The whole part of a [`Self::value_fixed`].
    pub fn whole(fixed: i128) -> i64 {
        (fixed >> 32) as i64
    }

    /// The interpolated value now with 32 fractional bits (for the position limiter, so a slow
    /// stream is not quantised into steps): `from + (to − from) × k / ticks`, the fraction
    /// truncated toward zero.
    pub fn value_fixed(&self) -> i128 {
        let part = self.progress.quotient as i128;
        i128::from(self.from) * ONE + if self.progress.negative { -part } else { part }
    }

    /// The change per tick of the present segment (a velocity in units per tick).
    pub fn step(&self) -> i64 {
        if self.k >= self.ticks {
            0
        } else {
            (self.to - self.from) / i64::from(self.ticks.max(1))
        }
    }

    fn segment(&mut self, to: i64, ticks: u32) {
        let here = self.value();
        self.slope = to - here;
        self.from = here;
        self.to = to;
        self.ticks = ticks.max(1);
        self.k = 0;
        // The one division of a segment: the progress of one tick.
        let span = (i128::from(to) - i128::from(here)) * ONE;
        let (per_tick, per_tick_remainder) =
            crate::wide::udivrem(span.unsigned_abs(), u128::from(self.ticks));
        self.progress = Progress {
            per_tick,
            // < ticks ≤ u32::MAX.
            per_tick_remainder: per_tick_remainder as u32,
            quotient: 0,
            remainder: 0,
            negative: span < 0,
        };
    }

    /// `k` moves on by one tick.
    fn advance(&mut self) {
        self.k += 1;
        let progress = &mut self.progress;
        progress.quotient += progress.per_tick;
        // Both below `ticks`, so the sum fits 64 bits and exceeds `ticks` at most once.
        let remainder = u64::from(progress.remainder) + u64::from(progress.per_tick_remainder);
        if remainder >= u64::from(self.ticks) {
            progress.quotient += 1;
            progress.remainder = (remainder - u64::from(self.ticks)) as u32;
        } else {
            progress.remainder = remainder as u32;
        }
    }

    /// One tick: `target` is the stream's value now (read after the SYNC's RPDO was applied).
    pub fn tick(&mut self, cycle: &Cycle, target: i64, bridge: Bridge) -> StreamState {
        let mut state = StreamState::default();
        self.since_sync = self.since_sync.saturating_add(1);
        let late = self.since_sync > cycle.period_ticks.saturating_add(cycle.tolerance_ticks);
        if cycle.sync || (self.started && late) {
            let delivered = cycle.sync && cycle.fresh;
            if cycle.sync {
                self.since_sync = 0;
            } else {
                // A missing SYNC: count it and wait a period for the next one. It was due
                // `tolerance + 1` ticks ago, so the next one is late `period` ticks from now
                // (not `period + 1`: consecutive losses are counted one per period).
                self.since_sync = cycle.tolerance_ticks.saturating_add(1);
            }
            let next = if delivered || !self.started {
                self.missed = 0;
                self.started = true;
                target
            } else {
                self.missed = self.missed.saturating_add(1);
                match bridge {
                    Bridge::Hold => self.to,
                    Bridge::Extrapolate => self.to.saturating_add(self.slope),
                }
            };
            self.segment(next, cycle.period_ticks);
            state.new_segment = true;
        }
        if self.k < self.ticks {
            self.advance();
        }
        state.missed = self.missed;
        state
    }
}

/// Position limiter of csp: follows a target through velocity and acceleration limits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Limiter {
    /// Position, increments × 2³².
    position: i128,
    /// Velocity, increments per tick × 2³².
    velocity: i128,
    /// Target of the previous tick (for the target's own velocity).
    last_target: i128,
    stopping: Option<i128>,
}

/// Per-tick limits of the limiter, increments per tick (× 2³²) and per tick².
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TickLimits {
    velocity: u64,
    acceleration: u64,
    deceleration: u64,
}

impl TickLimits {
    /// From increments/s and increments/s² at `hz` ticks per second.
    #[inline(never)]
    pub fn new(velocity: u32, acceleration: u32, deceleration: u32, hz: u32) -> Self {
        // u32 × 2³² and hz² fit 64 bits: unsigned 64-bit divisions (a 128-bit one is a library
        // call of several hundred instructions on a 32-bit MCU, and this runs every tick).
        let hz = u64::from(hz.max(1));
        let per_tick = |v: u32| ((u64::from(v) << 32) / hz).max(1);
        let per_tick2 = |a: u32| ((u64::from(a) << 32) / (hz * hz)).max(1);
        TickLimits {
            velocity: per_tick(velocity),
            acceleration: per_tick2(acceleration),
            deceleration: per_tick2(deceleration),
        }
    }
}

impl Limiter {
    /// At rest at `position`.
    pub fn reset(&mut self, position: i64) {
        let p = i128::from(position) * ONE;
        *self = Limiter { position: p, velocity: 0, last_target: p, stopping: None };
    }

    /// The demand position (increments).
    pub fn position(&self) -> i64 {
        (self.position >> 32) as i64
    }

    /// The demand velocity in increments/s at `hz`.
    pub fn velocity(&self, hz: u32) -> i64 {
        let Ok(velocity) = i64::try_from(self.velocity) else {
            return Self::velocity_wide(self.velocity, hz);
        };
        // |velocity| × hz / 2³², truncated toward zero as the 128-bit form, in 64-bit products
        // (every tick of csp asks): with |velocity| = high × 2³² + low, it is high × hz plus the
        // whole part of low × hz / 2³², and high < 2³¹.
        let magnitude = velocity.unsigned_abs();
        let (high, low) = (magnitude >> 32, magnitude & 0xffff_ffff);
        let hz = u64::from(hz);
        let whole = (high * hz).saturating_add((low * hz) >> 32).min(i64::MAX as u64) as i64;
        if velocity < 0 {
            -whole
        } else {
            whole
        }
    }

    /// [`Self::velocity`] of any fixed-point velocity.
    fn velocity_wide(velocity: i128, hz: u32) -> i64 {
        let v = velocity * i128::from(hz) / ONE;
        v.clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64
    }

    /// Stops with `deceleration` (increments per tick² × 2³², see [`TickLimits`]).
    pub fn stop(&mut self, limits: &TickLimits) {
        self.stopping = Some(i128::from(limits.deceleration));
    }

    /// Ends a stop (halt released): the limiter chases the target again.
    pub fn resume(&mut self) {
        self.stopping = None;
        self.last_target = self.position;
    }

    /// Whether a stop is running or done.
    pub fn is_stopping(&self) -> bool {
        self.stopping.is_some()
    }

    /// One tick towards `target` (increments); returns whether a limit acted.
    pub fn tick(&mut self, target: i64, limits: &TickLimits) -> bool {
        self.tick_fixed(i128::from(target) * ONE, limits)
    }

    /// One tick towards `target` (increments × 2³²); returns whether a limit acted.
    pub fn tick_fixed(&mut self, target: i128, limits: &TickLimits) -> bool {
        if let Some(deceleration) = self.stopping {
            let v = self.velocity;
            self.velocity = if v.abs() <= deceleration { 0 } else { v - v.signum() * deceleration };
            self.position += self.velocity;
            self.last_target = self.position;
            return false;
        }
        let (velocity_limit, acceleration, deceleration) =
            (i128::from(limits.velocity), i128::from(limits.acceleration), i128::from(limits.deceleration));
        let target_velocity = target - self.last_target;
        self.last_target = target;
        let error = target - self.position;
        // The step that lands on the target now, within the velocity limit.
        let wanted = error.clamp(-velocity_limit, velocity_limit);
        let mut change = wanted - self.velocity;
        // Relative to the target's own motion: brake when the remaining gap is within the
        // stopping distance of the relative velocity.
        let relative = self.velocity - target_velocity;
        if relative != 0 && relative.signum() == error.signum() {
            let stopping = crate::wide::sdiv(relative.saturating_mul(relative), 2 * deceleration.max(1));
            if stopping >= error.abs() {
                change = -relative.signum() * deceleration;
            }
        }
        let speeding_up = (self.velocity + change).abs() > self.velocity.abs();
        let rate = if speeding_up { acceleration } else { deceleration };
        let limited_change = change.clamp(-rate, rate);
        let clipped = limited_change != change || wanted != error;
        self.velocity = (self.velocity + limited_change).clamp(-velocity_limit, velocity_limit);
        self.position += self.velocity;
        // Landed within a rounding step of the target: snap (keeps an in-limit stream exact).
        if !clipped && (target - self.position).abs() < ONE {
            self.position = target;
        }
        // A limit that moved the demand off the stream by less than an increment is the
        // quantisation of an integer stream (its slope changes by whole increments per
        // period), not a target beyond the limits: only a whole increment counts.
        (target - self.position).abs() >= ONE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 64-bit arithmetic of `TickLimits::new` and `value_fixed` gives what 128 bits give.
    #[test]
    fn narrow_arithmetic_agrees_with_128_bits() {
        for v in [0u32, 1, 7, 1000, 123_457, 1 << 31, u32::MAX] {
            for hz in [1u32, 250, 1000, 4000, 16_000, 65_535] {
                let limits = TickLimits::new(v, v, v, hz);
                let hz = i128::from(hz);
                assert_eq!(i128::from(limits.velocity), (i128::from(v) * ONE / hz).max(1), "{v} at {hz} Hz");
                assert_eq!(
                    i128::from(limits.acceleration),
                    (i128::from(v) * ONE / (hz * hz)).max(1),
                    "{v} at {hz} Hz"
                );
            }
        }
        for (from, to) in
            [(0i64, 1000), (5, -7), (-1 << 40, 1 << 40), (i64::from(i32::MIN), i64::from(i32::MAX)), (3, 3)]
        {
            for ticks in [1u32, 3, 4, 16] {
                for k in 0..=ticks {
                    let mut i = Interpolator { from, ..Interpolator::default() };
                    i.segment(to, ticks);
                    for _ in 0..k {
                        i.advance();
                    }
                    let span = (i128::from(to) - i128::from(from)) * ONE;
                    let reference = i128::from(from) * ONE + span * i128::from(k) / i128::from(ticks);
                    assert_eq!(i.value_fixed(), reference, "{from} -> {to}, {k}/{ticks}");
                }
            }
        }
    }

    /// The 64-bit velocity in whole units answers as the 128-bit form.
    #[test]
    fn velocity_in_whole_units_agrees_with_128_bits() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut limiter = Limiter::default();
        for round in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let velocity = (x as i64 >> (x % 63)) as i128;
            let velocity = if round % 3 == 0 { -velocity } else { velocity };
            for velocity in [velocity, i128::from(i64::MIN), i128::from(i64::MAX), 1 << 70, -(1 << 70)] {
                limiter.velocity = velocity;
                for hz in [1u32, 1000, 16_000, 65_535, u32::MAX] {
                    assert_eq!(limiter.velocity(hz), Limiter::velocity_wide(velocity, hz), "{velocity} {hz}");
                }
            }
        }
    }

    fn cycle(sync: bool, fresh: bool) -> Cycle {
        Cycle { sync, fresh, period_ticks: 4, tolerance_ticks: 2 }
    }

    #[test]
    fn interpolates_linearly_over_the_period() {
        let mut i = Interpolator::default();
        i.reset(0);
        i.tick(&cycle(true, true), 400, Bridge::Hold);
        assert_eq!(i.value(), 100);
        let mut values = [0i64; 3];
        for v in values.iter_mut() {
            i.tick(&cycle(false, false), 400, Bridge::Hold);
            *v = i.value();
        }
        assert_eq!(values, [200, 300, 400]);
        assert_eq!(i.step(), 0);
    }

    #[test]
    fn a_lost_rpdo_is_bridged_and_counted() {
        let mut i = Interpolator::default();
        i.reset(0);
        i.tick(&cycle(true, true), 400, Bridge::Extrapolate);
        for _ in 0..3 {
            i.tick(&cycle(false, false), 0, Bridge::Extrapolate);
        }
        // The SYNC comes, the RPDO does not: extrapolated to 800.
        let s = i.tick(&cycle(true, false), 12345, Bridge::Extrapolate);
        assert_eq!(s.missed, 1);
        for _ in 0..3 {
            i.tick(&cycle(false, false), 0, Bridge::Extrapolate);
        }
        assert_eq!(i.value(), 800);
        let s = i.tick(&cycle(true, true), 1200, Bridge::Extrapolate);
        assert_eq!(s.missed, 0);
    }

    #[test]
    fn a_missing_sync_is_a_missed_cycle_after_the_tolerance() {
        let mut i = Interpolator::default();
        i.reset(0);
        i.tick(&cycle(true, true), 400, Bridge::Hold);
        let mut missed = 0;
        for _ in 0..7 {
            missed = i.tick(&cycle(false, false), 0, Bridge::Hold).missed;
        }
        assert_eq!(missed, 1, "more than 4 + 2 ticks without SYNC");
        assert_eq!(i.value(), 400, "held");
    }

    #[test]
    fn consecutive_missing_syncs_are_counted_one_per_period() {
        // Regression: after a missed cycle the next one was counted a tick late (every
        // period + 1 ticks), so three lost SYNCs at 4 ticks per period looked like two.
        let mut i = Interpolator::default();
        i.reset(0);
        i.tick(&cycle(true, true), 400, Bridge::Hold);
        let mut missed = [0u32; 15];
        for m in missed.iter_mut() {
            *m = i.tick(&cycle(false, false), 0, Bridge::Hold).missed;
        }
        // Late after 4 + 2 ticks (tick 7), then every 4 ticks: 11, 15.
        assert_eq!(missed[6], 1);
        assert_eq!(missed[9], 1);
        assert_eq!(missed[10], 2);
        assert_eq!(missed[14], 3);
        // A period of 1 tick, tolerance 0: every tick after the first late one.
        let mut i = Interpolator::default();
        i.reset(0);
        let one = Cycle { sync: true, fresh: true, period_ticks: 1, tolerance_ticks: 0 };
        i.tick(&one, 0, Bridge::Hold);
        let none = Cycle { sync: false, fresh: false, ..one };
        let mut missed = [0u32; 4];
        for m in missed.iter_mut() {
            *m = i.tick(&none, 0, Bridge::Hold).missed;
        }
        assert_eq!(missed, [0, 1, 2, 3]);
    }

    #[test]
    fn limiter_is_transparent_within_the_limits() {
        let limits = TickLimits::new(100_000, 1_000_000, 1_000_000, 1000);
        let mut l = Limiter::default();
        l.reset(0);
        for k in 1..=1000i64 {
            // A parabola with acceleration 20 000 increments/s².
            let target = 10 * k * k / 1000;
            assert!(!l.tick(target, &limits));
            assert_eq!(l.position(), target);
        }
    }

    #[test]
    fn limiter_chases_a_jump_at_the_limits_without_overshoot() {
        let limits = TickLimits::new(10_000, 100_000, 100_000, 1000);
        let mut l = Limiter::default();
        l.reset(0);
        let mut last_v = 0i64;
        let mut flagged = false;
        for _ in 0..2000 {
            flagged |= l.tick(5000, &limits);
            let v = l.velocity(1000);
            assert!(v.abs() <= 10_000);
            assert!((v - last_v).abs() <= 101, "{last_v} → {v}");
            assert!(l.position() <= 5000, "no overshoot: {}", l.position());
            last_v = v;
        }
        assert!(flagged);
        assert_eq!(l.position(), 5000);
        assert!(!l.tick(5000, &limits), "back within the limits");
    }

    #[test]
    fn limiter_stop_decelerates() {
        let limits = TickLimits::new(10_000, 100_000, 50_000, 1000);
        let mut l = Limiter::default();
        l.reset(0);
        // A ramp at 5000 increments/s: caught up with after the acceleration phase.
        for k in 0..400 {
            l.tick(5 * k, &limits);
        }
        assert_eq!(l.velocity(1000), 5000);
        l.stop(&limits);
        l.tick(0, &limits);
        assert_eq!(l.velocity(1000), 4950);
        for _ in 0..200 {
            l.tick(0, &limits);
        }
        assert_eq!(l.velocity(1000), 0);
    }
}

//! Trajectory generation for the profile modes: point-to-point moves (pp, CiA 402-2 §10),
//! velocity ramps (pv, §13) and the halt / quick-stop ramps (§6).
//!
//! This module knows nothing about CANopen: it takes limits in increments and ticks, and it
//! produces one demand sample per control-loop tick. The drive maps 607Ah/6081h/6082h/6083h/
//! 6084h/6085h/6086h/60A3h/60A4h onto [`Limits`] after the factor group.
//!
//! - [`PositionPlanner`]: from any state (position, velocity, acceleration) to a target position
//!   with an end velocity, trapezoidal (6086h = 0) or jerk-limited (6086h = 3); re-plans on the
//!   fly and stops on request ([`PositionPlanner::stop`], halt and quick stop in pp).
//! - [`VelocityRamp`]: ramps the velocity demand towards a target velocity (pv, halt, quick
//!   stop).
//!
//! Both run one bounded generator (`ramps.rs`, `pulse.rs`): no search over ticks, no loop
//! whose length depends on the distance.
//!
//! # Shape
//!
//! A plan is at most five *legs* — `[stop] → to the peak → [cruise] → from the peak → [start]`
//! — each a velocity change over whole ticks. A trapezoid's leg runs at one acceleration; a
//! jerk-limited leg is a *pulse* of the acceleration: up at the jerk, held, and down again as
//! the mirror image of its rise (a pulse's two corners use the smaller of their two jerks, so
//! per-corner jerks A ≠ B or C ≠ D give a slower, never a faster, profile). A plan that starts
//! while the axis accelerates (jerk-limited) first ramps that acceleration out at the jerk that
//! ends a speed change (B, or D while slowing down) — beside the first pulse when the
//! acceleration already points its way, before it otherwise.
//!
//! Both leg kinds share the property the solver rests on: over `n` ticks from `u` to `w` a leg
//! covers exactly `n·(u + w)/2`, however its acceleration is spread over its ticks (a pulse's
//! velocity is point-symmetric about the middle of the leg). So with the tick counts fixed, the
//! distance is affine in the peak velocity, and the peak that lands on the target is one
//! division.
//!
//! # How a plan is made
//!
//! 1. **Layout (`f32`)**: the continuous time-optimal peak. A trapezoid's distance is affine in
//!    `vp·|vp|` between a few break points, so its peak is at most five evaluations and a
//!    square root. A jerk-limited one is searched on the cube root of the peak (bisection
//!    until the bracket is narrow, then regula falsi with the Illinois rule; usually 10 to 20
//!    evaluations of four velocity changes). The leg durations are rounded up to whole ticks.
//! 2. **Rounds (exact)**: the peak by one 128-by-32-bit division; then each leg is checked (a
//!    trapezoid's: its acceleration within the limit; a pulse is fitted: rise, peak and a
//!    one-sixth *bump* that makes its sum exact) and a leg that does not fit is lengthened, at
//!    most 3 rounds (5 jerk-limited).
//! 3. **Fallback**: stop first, move from standstill, and start again for an end velocity.
//!
//! A drive makes its plans over several ticks with [`PositionPlanner::request`]. A trapezoid's:
//! the layout in one tick, a round in each following one (and after a failed round a tick that
//! lengthens its legs for the state where the next one solves), the axis meanwhile under a
//! provisional rule. A jerk-limited one: the limits converted in the tick after the request, a
//! few steps of the search per tick, then the counts, then per round the peak, one leg's fit
//! per tick and the legs completed in a tick of their own, for the state of the request — the
//! axis meanwhile ramps its acceleration out and coasts, which is how every plan from that
//! state begins (its first pulse is delayed until the plan is complete, usually 9 to 16
//! ticks after the request). Halts and quick stops ([`PositionPlanner::request_stop`]): a
//! trapezoid's is one leg, made at once; a jerk-limited one ramps its acceleration out from
//! the tick that asks, its limits are converted in the next and a length of its pulse is tried
//! in each after (usually one), so its deceleration starts three ticks after the request; over
//! the random scenarios it takes a median 3 and at most 4 ticks more than one made at once.
//! pv ramps ([`VelocityRamp`]) are still made at once.
//!
//! Each tick's share of that work is done after the tick's step, for the next one
//! ([`PositionPlanner::follow`], then [`PositionPlanner::plan_ahead`]; [`PositionPlanner::step`]
//! is the two): a drive's tick does the share once its demands are out, so that the stack of
//! the share and the stack of the mode's step are not one on the other. The tick that asks for
//! a plan only begins it, so a plan starts one tick after it would with the share done before
//! the step.
//!
//! # Numeric representation, and why
//!
//! The targets are Cortex-M4F (single-precision FPU) and Cortex-M0 (no FPU). `f64` would be
//! software floating point on both; `f32` cannot hold a position of the i32 range to the
//! increment. So: integers per tick, and `f32` only to choose the layout. The executed state is
//! position, velocity and acceleration in 128-bit fixed point with 64 fractional bits, in
//! per-tick units. A trapezoid keeps twice the position (so `p += v + a/2` is exact for any
//! integer acceleration); a jerk-limited profile keeps the acceleration in sixths (`α = a/6`),
//! for which a tick of constant jerk is exactly `p += v + 2α + α'`, `v += 3·(α + α')`. No tick
//! rounds, so nothing drifts however long the move; the planner knows where each leg ends to the
//! last bit (up to the 5 units a pulse's sum in sixths leaves), and the last sample is set to the
//! target.
//!
//! # Limits: what is guaranteed
//!
//! After any plan, re-plan, stop or ramp, from any state — accelerating, cruising,
//! decelerating, reversing, with an end velocity — every executed tick satisfies, in the
//! fixed-point state itself:
//!
//! - |velocity| ≤ the velocity limit;
//! - |acceleration| ≤ the acceleration limit while the speed rises (or from standstill) and ≤
//!   the deceleration limit while it falls (for the trapezoid, the velocity step of the tick);
//!   across a change of sign of the velocity within a leg, ≤ the smaller of the two;
//! - |jerk| ≤ the largest jerk limit plus 6 units of 2⁻⁶⁴ increment/tick³ (one sixth: a pulse's
//!   bump, or the decay's rounding).
//!
//! The limits are converted to fixed point rounded down, so this holds for the configured
//! limits exactly. The random test (`limit_tests`, 1 200 scenarios, 7 372 plans with lowered
//! and raised limits, both profiles, per-corner jerks, end velocities and stops) checks every
//! tick with these bounds; its worst values are 1.0000000 × the velocity and the jerk limit and
//! 0.9999998 × the acceleration limit, and the largest velocity correction at the end of a plan
//! is 5 units of 2⁻⁶⁴ increment/tick.
//!
//! One exception, by physics: a state that already breaks the limits at the re-plan (limits
//! lowered while moving). Its acceleration is first ramped out (the speed may rise by what that
//! ramp carries), then the speed falls back within the velocity limit and never rises again.
//!
//! # Durations
//!
//! Against the exact time-optimal whole-tick planner this generator replaced (kept as the tests'
//! reference), over the 9 600 plans of the random scenarios (`limit_tests`): trapezoids end a
//! median 0 and at worst 13 ticks (2.4 %) later, 99.99 % within 1 % or 2 ticks. Jerk-limited
//! plans end a median 0 ticks later and 83 % within 1 % or 2 ticks; 39 % are shorter (the old
//! planner kept a margin under the limits), the 90th percentile is 129 ticks later and the worst
//! 4.8 times as long — re-plans whose present acceleration is ramped out before a pulse that
//! turns the other way, and pulses held to the smaller of two corner jerks.
//!
//! # Limits and their edge values
//!
//! - Velocity limit 0, acceleration 0, deceleration 0, or a jerk of 0 with the jerk-limited
//!   profile: planning is refused with a [`MotionError`] and the current motion continues
//!   unchanged (a planner at rest stays at rest). A stop with deceleration 0 is refused too.
//! - Limits up to `u32::MAX` are accepted. Legs shorter than a tick become one tick, so at very
//!   high limits the profile is slower than the limits would allow, never faster.
//! - A plan longer than `u32::MAX` ticks, or whose fixed-point values would overflow, is refused
//!   with [`MotionError::TooLong`].
//! - Targets are `i64`, so relative moves from anywhere in the i32 range do not wrap internally;
//!   targets beyond ±2⁴⁰ increments are refused. [`MotionState::position_demand`] wraps the
//!   position to i32 as a 32-bit position counter does.
//!
//! # Cost on Cortex-M
//!
//! Instructions per call, counted by QEMU's instruction-counting plugin
//! (`benches/mcu-motion/run.sh`; release profile, `opt-level = "s"`, LTO; 4 kHz, 100 000
//! increments/s, 500 000 increments/s², 10⁷ increments/s³):
//!
//! | call | Cortex-M4F (`thumbv7em-none-eabihf`) | no FPU (`thumbv6m-none-eabi`) |
//! |---|---:|---:|
//! | plan, trapezoid, from standstill | 3 414 | 14 752 |
//! | plan, jerk-limited, from standstill | 10 352 | 48 475 |
//! | plan, trapezoid, from standstill, short (no cruise) | 3 272 | 17 171 |
//! | plan, jerk-limited, from standstill, short (no cruise) | 12 006 | 96 646 |
//! | plan, trapezoid, re-plan while accelerating | 3 375 | 15 579 |
//! | plan, jerk-limited, re-plan while accelerating | 11 618 | 58 618 |
//! | plan, trapezoid, re-plan that takes the fallback | 8 965 | 46 208 |
//! | plan, jerk-limited, re-plan that takes the fallback | 16 459 | 210 303 |
//! | step, trapezoid (ramp tick) | 250 | 997 |
//! | step, jerk-limited (jerk tick) | 441 | 1 610 |
//!
//! The M4F runs on QEMU's `mps2-an386`, the v6-M code on `mps2-an385` (a Cortex-M3 running the
//! Cortex-M0 instruction set); counts are instructions, not cycles. The exact planner before it
//! needed 57 500 – 258 600 (M4F) and 127 000 – 1 495 000 (v6-M) per plan. What a drive's tick
//! pays is in `BENCHMARKS.md` (the rows of the ticks that take a set-point).
//!
//! # Example
//!
//! ```
//! use canopen_drive::motion::{Limits, PositionPlanner, ProfileType, TickRate};
//!
//! let rate = TickRate::new(4000).unwrap();
//! let mut planner = PositionPlanner::new(rate, 0);
//! let limits = Limits::new(20_000, 100_000, 100_000).with_jerk(ProfileType::JerkLimited, 2_000_000);
//! let ticks = planner.plan(10_000, 0, &limits).unwrap();
//! let mut last = planner.state();
//! for _ in 0..ticks {
//!     last = planner.step();
//! }
//! assert_eq!(last.position, 10_000);
//! assert!(planner.is_finished());
//! ```

mod fixed;
mod planner;
mod pulse;
mod ramps;

// The exact time-optimal planner that served before the bounded one: the tests' reference for
// move durations (`limit_tests`), not built into the crate.
#[cfg(test)]
#[allow(dead_code)]
mod legs;
#[cfg(test)]
#[allow(dead_code)]
mod shape;
#[cfg(test)]
#[allow(dead_code)]
mod solve;
#[cfg(test)]
#[allow(dead_code)]
mod trajectory;

#[cfg(test)]
mod limit_tests;
#[cfg(test)]
mod tests;

pub use planner::{PositionPlanner, VelocityRamp};

/// Largest target magnitude accepted by [`PositionPlanner::plan`], in increments (2⁴⁰).
pub const POSITION_RANGE: i64 = 1 << 40;

/// The control-loop tick rate the profiles are sampled at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TickRate {
    hz: u32,
    /// `⌊(2⁶⁴ − 1)/hz⌋` and that over `hz` again, twice: a rate in increments/sᵏ times one of
    /// these is the rate per tickᵏ in fixed point, rounded down, without a division at plan
    /// time.
    reciprocals: [u64; 3],
    /// The last two over 6: rates in sixths per tick² and per tick³ (`pulse.rs`).
    sixths: [u64; 2],
}

impl TickRate {
    /// Slowest accepted tick rate, in Hz.
    pub const MIN_HZ: u32 = 100;
    /// Fastest accepted tick rate, in Hz.
    pub const MAX_HZ: u32 = 1_000_000;

    /// A tick rate of `hz` ticks per second; [`MotionError::TickRate`] outside
    /// [`Self::MIN_HZ`]..=[`Self::MAX_HZ`].
    pub const fn new(hz: u32) -> Result<Self, MotionError> {
        if hz < Self::MIN_HZ || hz > Self::MAX_HZ {
            Err(MotionError::TickRate)
        } else {
            Ok(Self::at(hz))
        }
    }

    /// `hz` (at least 1).
    const fn at(hz: u32) -> Self {
        let hz64 = if hz == 0 { 1 } else { hz as u64 };
        let per_tick = u64::MAX / hz64;
        let per_tick2 = per_tick / hz64;
        let per_tick3 = per_tick2 / hz64;
        TickRate { hz, reciprocals: [per_tick, per_tick2, per_tick3], sixths: [per_tick2 / 6, per_tick3 / 6] }
    }

    /// Ticks per second.
    pub const fn hz(self) -> u32 {
        self.hz
    }

    /// `rate` per secondᵏ (k = 1, 2, 3) in fixed-point per-tickᵏ units, at most the exact value
    /// and less than 2⁻³² per-tickᵏ units below it.
    pub(crate) const fn scale(self, rate: u32, k: usize) -> i128 {
        let reciprocal = match k {
            1 => self.reciprocals[0],
            2 => self.reciprocals[1],
            _ => self.reciprocals[2],
        };
        (rate as u128 * reciprocal as u128) as i128
    }

    /// [`Self::scale`] in sixths for k = 2, 3 (rounded down alike).
    pub(crate) const fn sixths(self, rate: u32, k: usize) -> i128 {
        let reciprocal = if k == 2 { self.sixths[0] } else { self.sixths[1] };
        (rate as u128 * reciprocal as u128) as i128
    }

    /// `⌈scale(rate, 3)/6⌉` without a 128-bit division: with `r = 6·q + c` the reciprocal,
    /// `rate·r/6 = rate·q + (rate/6)·c + (rate mod 6)·c/6` (the last part rounded up).
    pub(crate) const fn sixths_up3(self, rate: u32) -> i128 {
        let q = self.sixths[1];
        let c = (self.reciprocals[2] - 6 * q) as u32;
        let (whole, rest) = (rate / 6, rate % 6);
        (rate as u128 * q as u128) as i128 + whole as i128 * c as i128 + (rest * c).div_ceil(6) as i128
    }
}

/// Motion profile type, 6086h (CiA 402-2 §10.5.11). The discriminants are the object's values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(i16)]
pub enum ProfileType {
    /// 0: linear ramp (trapezoidal velocity profile).
    #[default]
    Trapezoidal = 0,
    /// 3: jerk-limited ramp (S-curve), with the jerks of 60A4h.
    JerkLimited = 3,
}

impl ProfileType {
    /// The profile for a 6086h value, `None` for the types this planner does not implement
    /// (1 sin² ramp, 2 jerk-free ramp, reserved and manufacturer-specific values).
    pub const fn from_raw(raw: i16) -> Option<Self> {
        match raw {
            0 => Some(ProfileType::Trapezoidal),
            3 => Some(ProfileType::JerkLimited),
            _ => None,
        }
    }
}

/// The four jerks of a jerk-limited profile, in increments/s³.
///
/// CiA 402-2 §10.5.13 (60A4h) reads A/B as the corners of the acceleration phase (start, end) and
/// C/D as those of the deceleration phase; E/F are not recoverable and not used. Here
/// "acceleration" is any velocity change that increases the speed and "deceleration" any that
/// decreases it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Jerks {
    /// Jerk A: raising the acceleration at the start of a speed-up.
    pub accel_start: u32,
    /// Jerk B: lowering the acceleration at the end of a speed-up.
    pub accel_end: u32,
    /// Jerk C: raising the deceleration at the start of a slow-down.
    pub decel_start: u32,
    /// Jerk D: lowering the deceleration at the end of a slow-down.
    pub decel_end: u32,
}

impl Jerks {
    /// One jerk for all four corners (60A3h = 1).
    pub const fn uniform(jerk: u32) -> Self {
        Jerks { accel_start: jerk, accel_end: jerk, decel_start: jerk, decel_end: jerk }
    }

    /// The jerks selected by 60A3h (profile jerk use: 1, 2 or 4) from the 60A4h sub-indices
    /// 1…4 in `profile_jerk` (CiA 402-2 §10.5.12, 60A3h). `None` for other uses (6 needs the
    /// lost figure) or when a needed sub-index is missing.
    pub fn from_profile_jerk(jerk_use: u8, profile_jerk: &[u32]) -> Option<Self> {
        let sub = |n: usize| profile_jerk.get(n.wrapping_sub(1)).copied();
        match jerk_use {
            1 => Some(Jerks::uniform(sub(1)?)),
            2 => Some(Jerks {
                accel_start: sub(1)?,
                accel_end: sub(1)?,
                decel_start: sub(2)?,
                decel_end: sub(2)?,
            }),
            4 => Some(Jerks {
                accel_start: sub(1)?,
                accel_end: sub(3)?,
                decel_start: sub(2)?,
                decel_end: sub(4)?,
            }),
            _ => None,
        }
    }

    const fn any_zero(&self) -> bool {
        self.accel_start == 0 || self.accel_end == 0 || self.decel_start == 0 || self.decel_end == 0
    }
}

/// Limits of one profile, in increments and seconds (after the factor group).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Limits {
    /// Profile velocity (6081h, already limited by 607Fh/6080h), increments/s, either direction.
    pub velocity: u32,
    /// Profile acceleration (6083h), increments/s², used while the speed increases.
    pub acceleration: u32,
    /// Profile deceleration (6084h), increments/s², used while the speed decreases.
    pub deceleration: u32,
    /// Trapezoidal or jerk-limited (6086h).
    pub profile: ProfileType,
    /// Jerks (60A4h), increments/s³; used only by [`ProfileType::JerkLimited`].
    pub jerk: Jerks,
}

impl Limits {
    /// Trapezoidal limits.
    pub const fn new(velocity: u32, acceleration: u32, deceleration: u32) -> Self {
        Limits {
            velocity,
            acceleration,
            deceleration,
            profile: ProfileType::Trapezoidal,
            jerk: Jerks::uniform(0),
        }
    }

    /// The same limits with `profile` and one jerk for all corners.
    pub const fn with_jerk(self, profile: ProfileType, jerk: u32) -> Self {
        self.with_jerks(profile, Jerks::uniform(jerk))
    }

    /// The same limits with `profile` and per-corner jerks.
    pub const fn with_jerks(self, profile: ProfileType, jerk: Jerks) -> Self {
        Limits { profile, jerk, ..self }
    }

    /// Checks the limits a plan needs (velocity is checked only where the plan moves).
    const fn check_ramps(&self) -> Result<(), MotionError> {
        if self.acceleration == 0 {
            Err(MotionError::ZeroAcceleration)
        } else if self.deceleration == 0 {
            Err(MotionError::ZeroDeceleration)
        } else if matches!(self.profile, ProfileType::JerkLimited) && self.jerk.any_zero() {
            Err(MotionError::ZeroJerk)
        } else {
            Ok(())
        }
    }
}

/// Why a plan was refused. The planner's motion is unchanged after any of these.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MotionError {
    /// The velocity limit is 0: no motion is planned.
    ZeroVelocity,
    /// The acceleration limit is 0.
    ZeroAcceleration,
    /// The deceleration (or stop deceleration) is 0.
    ZeroDeceleration,
    /// A jerk of the jerk-limited profile is 0.
    ZeroJerk,
    /// The tick rate is outside [`TickRate::MIN_HZ`]..=[`TickRate::MAX_HZ`].
    TickRate,
    /// The target is beyond ±[`POSITION_RANGE`].
    OutOfRange,
    /// The plan would last more than `u32::MAX` ticks or overflow the fixed-point range.
    TooLong,
}

impl core::fmt::Display for MotionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            MotionError::ZeroVelocity => "velocity limit is zero",
            MotionError::ZeroAcceleration => "acceleration limit is zero",
            MotionError::ZeroDeceleration => "deceleration limit is zero",
            MotionError::ZeroJerk => "a jerk limit is zero",
            MotionError::TickRate => "tick rate out of range",
            MotionError::OutOfRange => "target out of range",
            MotionError::TooLong => "plan too long for the fixed-point range",
        })
    }
}

impl core::error::Error for MotionError {}

/// The demand of one tick, rounded to whole units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotionState {
    /// Position demand, increments (the planner's unwrapped frame).
    pub position: i64,
    /// Velocity demand, increments/s.
    pub velocity: i64,
    /// Acceleration demand, increments/s².
    pub acceleration: i64,
}

impl MotionState {
    /// The position as a 32-bit position counter shows it (wrapping), e.g. for 60FCh.
    pub const fn position_demand(&self) -> i32 {
        self.position as i32
    }

    /// The velocity clamped to the i32 range, e.g. for 606Bh.
    pub const fn velocity_demand(&self) -> i32 {
        if self.velocity > i32::MAX as i64 {
            i32::MAX
        } else if self.velocity < i32::MIN as i64 {
            i32::MIN
        } else {
            self.velocity as i32
        }
    }
}

//! Trajectory generation for the profile modes: point-to-point moves (pp, `spec/cia402.md` §9),
//! velocity ramps (pv, §13) and the halt / quick-stop ramps (§6).
//!
//! This module knows nothing about CANopen: it takes limits in increments and ticks, and it
//! produces one demand sample per control-loop tick. The drive maps 607Ah/6081h/6082h/6083h/
//! 6084h/6085h/6086h/60A3h/60A4h onto [`Limits`] after the factor group.
//!
//! - [`PositionPlanner`]: from any state (position, velocity, acceleration) to a target position
//!   with an end velocity, trapezoidal (6086h = 0) or jerk-limited (6086h = 3); re-plans on the
//!   fly and stops on request ([`PositionPlanner::stop`], halt and quick stop in pp). A
//!   trapezoid is planned by a bounded solver (`ramps.rs`: an `f32` layout and a few exact
//!   rounds, no search), which a drive runs over several ticks
//!   ([`PositionPlanner::request`]); a jerk-limited profile by the exact planner described
//!   below, at once.
//! - [`VelocityRamp`]: ramps the velocity demand towards a target velocity (pv, halt, quick
//!   stop).
//!
//! # Two rates of work
//!
//! *Planning* (`plan`, `set_target`, `stop`) does a bounded amount of arithmetic that does not
//! depend on the distance (the bound is under [Work per plan](#work-per-plan)). *Stepping*
//! (`step`, once per tick) is O(1): six 128-bit additions and a shift, a comparison for the
//! switch between the two jerks of a segment, and a segment switch every few thousand ticks;
//! then the state is converted to whole units for [`MotionState`].
//!
//! # Profile shape
//!
//! A plan is a velocity change from the current state to a peak velocity `vp`, a cruise at `vp`,
//! and a velocity change from `vp` to the end velocity. A velocity change that crosses zero is
//! split at zero: the part that slows down uses the deceleration (and jerks C/D), the part that
//! speeds up uses the acceleration (and jerks A/B). The peak velocity is found by bisection, so
//! moves that never reach the velocity limit (triangular / reduced S-curves), targets behind
//! the axis, and overshoot that needs a reversal all come out of the same formula. With the
//! jerk-limited profile each velocity change is jerk A (or C), constant acceleration, jerk B (or
//! D); the acceleration starts from the current acceleration, so a re-plan never jumps in
//! position, velocity or acceleration. Where the present acceleration cannot be carried into
//! the first change within the limits, it is first ramped to zero at jerk B (while speeding up)
//! or D (while slowing down). The trapezoidal profile starts from the current position and
//! velocity; its acceleration jumps, as a linear ramp's does.
//!
//! # Numeric representation, and why
//!
//! The targets are Cortex-M4F (single-precision FPU) and Cortex-M0 (no FPU). Three choices were
//! weighed:
//!
//! - **`f64` everywhere** would be simplest, but it is software floating point on both targets
//!   (tens to hundreds of cycles per operation), and a per-tick cubic would cost thousands of
//!   cycles on an M0 at 16 kHz.
//! - **`f32` everywhere** is fast on the M4F, but its 24-bit mantissa cannot hold a position of
//!   the i32 range to the increment (a 2³³-increment move would be off by hundreds of
//!   increments), and summing `f32` increments drifts.
//! - **Integers per tick, floats only to choose the shape** — the choice made here.
//!
//! The executed state is `(position, velocity, acceleration)` in 128-bit fixed point with 64
//! fractional bits, in *per-tick* units (increments, increments/tick, increments/tick²). A
//! segment's jerk is a multiple of 6 units and every acceleration is even (a multiple of 6 with
//! the jerk-limited profile), so one tick of the cubic, `p += v + a/2 + j/6; v += a + j/2; a += j`, is exact in integers: there is
//! no rounding, so there is no drift, however long the move. A segment may run at two jerks one
//! unit (of 6) apart, switching once, so that a jerk phase changes the acceleration by exactly
//! the amount asked: every velocity change ends at exactly zero acceleration. Planning computes
//! each segment's end state from the same closed form, so it knows where the executed profile
//! ends to the last bit.
//!
//! # From the shape to whole ticks
//!
//! The shape (durations, peak velocity) is found in `f32` in SI units; it only chooses the
//! layout of the plan and a first peak velocity. The integer stage (`solve`, `legs`) then:
//!
//! - sizes each velocity change in whole ticks for the largest change it may have to make (a
//!   change starting from zero acceleration: an `f32` estimate of the time-optimal durations,
//!   then lengthened exactly until its fitted peak acceleration and jerks are within the limits
//!   less 2⁻²⁰; the first change carrying an acceleration: a few candidate durations around
//!   the shape's, each fitted and checked, else the ramp above);
//! - fits each change for whole ticks: the rise of the acceleration is solved for the aimed
//!   velocity and rounded so the change ends at or below the aimed speed, never above;
//! - chooses the peak velocity in a *window* `[lo, hi]` (`hi` at most the velocity limit less
//!   2⁻²⁰): with the tick counts fixed, every tick's velocity, acceleration and jerk is affine
//!   in the peak velocity, so if the fits at both ends of the window conform, every peak in
//!   between does. The cruise is the fewest whole ticks that let the window reach the target;
//!   if the window cannot, its bottom is lowered (at most 6 rounds, the last one down to zero,
//!   where the changes into the peak are sized to stop). Then the peak that lands on the target
//!   is interpolated (the distance is affine in it up to the rounding; at most 4 steps,
//!   usually one);
//! - checks the final fit against the exact limits, tick by tick (velocity at the ends and at
//!   the vertex of each segment, acceleration at its ends, jerk), and keeps it.
//!
//! If the rounds run out, or the final check fails, the plan takes the *fallback*: stop first
//! (ramping the acceleration out if it cannot be carried into the stop), move from standstill
//! (all its changes then speed up to the peak or slow down from it, so the window `[0, hi]`
//! always reaches the target), and for an end velocity stop short and start again to pass the
//! target at it. This is slower than the shape's plan (it stops in the middle), and serves only
//! where whole ticks need another shape than the continuous one: a target at exactly the
//! stopping distance (the stop in whole ticks passes it), a state beyond lowered limits, moves
//! of a few ticks — 18 of the 7 372 plans of the random test. The fallback's own final check
//! has not failed in any test; were it to, its plan would still be used.
//!
//! The fitted profile ends within far less than an increment of the target (the search stops
//! at 2⁻²⁸ increment; the tests check 2⁻¹⁰ increment, ½ increment for plans over 10⁶ ticks);
//! the last sample is then set to the target, so the final sample equals the target exactly.
//! A stop inside a plan (the first half of a reversal) is set to standstill exactly at its end;
//! the velocity it corrects is a few hundred million units of 2⁻⁶⁴ increment/tick at most in
//! the tests.
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
//!   across a change of sign of the velocity within a segment, ≤ the smaller of the two;
//! - |jerk| ≤ the largest jerk limit plus 6 units of 2⁻⁶⁴ increment/tick³ (one unit of the
//!   jerk grid; the segment's own corner jerk is used when planning).
//!
//! The limits are converted to fixed point rounded down, so this holds for the configured
//! limits exactly: no tolerance for velocity and acceleration, and a jerk tolerance below
//! 2·10⁻⁶ increment/s³ at 16 kHz. The demand in [`MotionState`] (rounded to whole units) is
//! then never above a limit either. The random test (`limit_tests`, 1 200 scenarios, 7 372
//! plans with lowered and raised limits, both profiles, per-corner jerks, end velocities and
//! stops) checks every tick with these bounds; its worst values are 1.0000000 × the velocity,
//! 0.9999982 × the acceleration and 0.9999926 × the jerk limit.
//!
//! One exception, by physics: a state that already breaks the limits at the re-plan (limits
//! lowered while moving). Its speed may be above the new velocity limit, its acceleration above
//! the new acceleration or deceleration limit, or (jerk-limited) ramping its acceleration to
//! zero at the jerk limit that ends a speed change (B while speeding up, D while slowing down),
//! in whole ticks, `n = ⌈|a|/j⌉`, may carry the speed to `|v + a·n/2|` above the limit. Then
//! the acceleration is ramped towards zero without growing, the speed rises at most to that
//! value, falls back within the velocity limit with the deceleration and never rises again;
//! from then on the limits hold as above. A jerk limit lowered far below what the present
//! acceleration needs makes that ramp long, as it must.
//!
//! # Limits and their edge values
//!
//! - Velocity limit 0, acceleration 0, deceleration 0, or a jerk of 0 with the jerk-limited
//!   profile: planning is refused with a [`MotionError`] and the current motion continues
//!   unchanged (a planner at rest stays at rest). A stop with deceleration 0 is refused too.
//! - Limits up to `u32::MAX` are accepted. Segments shorter than a tick become one tick, so at
//!   very high limits the profile is slower than the limits would allow, never faster.
//! - A plan longer than `u32::MAX` ticks, or whose fixed-point values would overflow, is refused
//!   with [`MotionError::TooLong`].
//! - Targets are `i64`, so relative moves from anywhere in the i32 range do not wrap internally;
//!   targets beyond ±2⁴⁰ increments are refused. [`MotionState::position_demand`] wraps the
//!   position to i32 as a 32-bit position counter does.
//!
//! # Work per plan
//!
//! At most: two shapes in `f32` (each up to 27 evaluations of up to four velocity changes, 24
//! of them only for moves that do not reach the velocity limit), and twice (the shape's layout,
//! then the fallback) up to 6 rounds of sizing and fitting the layout at both window ends
//! (sizing a first change that carries an acceleration fits up to 10 candidates at both ends),
//! 4 interpolation fits and one final fit; a fit is at most 14 segments of 128-bit arithmetic
//! with no loop over ticks. Usually: one shape of one or two evaluations (a move that reaches
//! the velocity limit) and 4 fits (both window ends, one interpolation, the final fit).
//!
//! # Cost on Cortex-M
//!
//! Instructions per call, counted by QEMU's instruction-counting plugin
//! (`benches/mcu-motion/run.sh`; release profile, `opt-level = "s"`, LTO; 4 kHz, 100 000
//! increments/s, 500 000 increments/s², 10⁷ increments/s³):
//!
//! | call | Cortex-M4F (`thumbv7em-none-eabihf`) | no FPU (`thumbv6m-none-eabi`) |
//! |---|---:|---:|
//! | plan, trapezoid, from standstill (`ramps`) | 3 253 | 14 298 |
//! | plan, jerk-limited, from standstill | 98 942 | 250 370 |
//! | plan, trapezoid, from standstill, too short to cruise (`ramps`) | 3 178 | 16 758 |
//! | plan, jerk-limited, from standstill, too short to cruise | 109 221 | 656 761 |
//! | plan, trapezoid, re-plan while accelerating (`ramps`) | 3 213 | 15 122 |
//! | plan, jerk-limited, re-plan while accelerating | 117 585 | 339 469 |
//! | plan, trapezoid, re-plan that takes the fallback (`ramps`) | 8 655 | 45 622 |
//! | plan, jerk-limited, re-plan that takes the fallback | 238 619 | 1 430 492 |
//! | step, trapezoid (`ramps`) | 253 | 995 |
//! | step, jerk-limited | 264¹ | 1 812 |
//!
//! ¹ `run.sh` prints 1 055: its copy of the planner before the call is not cancelled by the
//! base run since the planner holds either executor (780 instructions of `memcpy`, measured
//! per function); the step itself is 264.
//!
//! The M4F runs on QEMU's `mps2-an386`, the v6-M code on `mps2-an385` (a Cortex-M3 running the
//! Cortex-M0 instruction set); counts are instructions, not cycles.
//!
//! - On the M4F the planning is about 0.05–0.25 M instructions (0.3–1.5 ms at 170 MHz); on
//!   the M0 0.1–0.7 M (typical), 1.5 M in the worst case measured (the fallback), i.e. up to
//!   some 30 ms at 48 MHz. Plan outside a fast tick interrupt (when a set-point arrives, in the
//!   communication context), or let the tick absorb the overrun once per set-point.
//! - The `f32` shape search is not what dominates on the M0 for moves that reach the velocity
//!   limit (one or two evaluations, under 10 % of a plan). For shorter moves its 24-step
//!   bisection is about half of a jerk-limited plan on the M0 (about 0.35 M instructions, some
//!   15 000 per evaluation of soft-float); acceptable for a plan per set-point, not per tick.
//!   Otherwise the 128-bit fixed-point fitting dominates: 64-bit multiplication helpers (the
//!   M0 has no 32×32→64 multiply) and 128-bit divisions (done in 32-bit digits, or in 64 bits
//!   when both operands fit; no divide instruction at all on the M0).
//! - A step is about 250 instructions on the M4F and 1 000 on the M0; of these, the stepping
//!   itself is about 125 and 200, the rest converts the state to the whole units of
//!   [`MotionState`] (three 32×32-bit products each for velocity and acceleration, through a
//!   helper on the M0), once per step: [`PositionPlanner::state`] returns that value. At 16 kHz
//!   that is some 3 % of a 170 MHz M4F, and a third of a 48 MHz M0.
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
            let per_tick = u64::MAX / hz as u64;
            let per_tick2 = per_tick / hz as u64;
            let per_tick3 = per_tick2 / hz as u64;
            Ok(TickRate {
                hz,
                reciprocals: [per_tick, per_tick2, per_tick3],
                sixths: [per_tick2 / 6, per_tick3 / 6],
            })
        }
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
}

/// Motion profile type, 6086h (`spec/cia402.md` §9.5). The discriminants are the object's values.
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
/// `spec/cia402.md` §9.5 reads A/B as the corners of the acceleration phase (start, end) and
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
    /// 1…4 in `profile_jerk` (`spec/cia402.md` §9.5 table). `None` for other uses (6 needs the
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

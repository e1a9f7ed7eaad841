//! Trajectory generation for the profile modes: point-to-point moves (pp, `spec/cia402.md` §9),
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
//! # Two rates of work
//!
//! *Planning* (`plan`, `set_target`, `stop`) does a bounded amount of arithmetic that does not
//! depend on the distance: one bisection of 32 steps in `f32` over the peak velocity, then a
//! closing of at most six fits of the integer profile, repeated (at most 24 more times, usually
//! none) when a change has to be lengthened to respect its limit. *Stepping* (`step`, once per tick) is O(1): six 128-bit
//! additions, a shift, and a segment switch every few thousand ticks.
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
//! position, velocity or acceleration. The trapezoidal profile starts from the current position
//! and velocity; its acceleration jumps, as a linear ramp's does.
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
//! fractional bits, in *per-tick* units (increments, increments/tick, increments/tick²); each
//! segment has a constant jerk that is a multiple of 6 units and every acceleration is even, so
//! one tick of the cubic, `p += v + a/2 + j/6; v += a + j/2; a += j`, is exact in integers: there
//! is no rounding, so there is no drift, however long the move. The end state of each segment is
//! computed at plan time from the same closed form, so planning knows where the executed profile
//! will end to the last bit. Per tick that is six 128-bit additions and a shift; nothing is
//! multiplied or divided (an estimate of some 50–100 instructions on an M0; not measured).
//!
//! The shape (segment durations, peak velocity) is found in `f32` in SI units (increments,
//! seconds); its 24-bit precision only decides durations, which are rounded *up* to whole ticks
//! (longer segments only lower the accelerations and jerks needed). Then the integer profile is
//! fitted: with the tick counts fixed, the jerks that end each velocity change at the wanted
//! velocity with zero acceleration are solved exactly, and the peak velocity is corrected by a
//! secant step in integers (the distance is affine in the peak velocity once the tick counts are
//! fixed), so the fitted profile ends within far less than an increment of the target (2⁻¹⁰
//! increment in the tests; ½ increment for plans over 10⁶ ticks, where the rounding of the
//! jerks to whole units grows with the cube of a segment's length). The last sample is then set to the target, so the final sample
//! equals the target exactly. The rounding of the fitted jerks to 6 units may leave an
//! acceleration of a few 2⁻⁶⁴ increments/tick² at the end of a velocity change; it is set to
//! zero there.
//!
//! Planning costs one `f32` bisection (32 steps of a few dozen `f32` operations and a square
//! root — hardware on the M4F, software on the M0) and integer fits with 128-bit
//! multiplications and divisions (software on both; each fit is a few hundred of them). That is
//! done once per set-point, not per tick; a board that plans inside the tick ISR at 16 kHz on an
//! M0 should check the worst case on its hardware (not measured here).
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
//! - Numeric tolerance (what the tests check): from rest, the profile exceeds no velocity,
//!   acceleration or jerk limit by more than one part in 10⁴ plus 2⁻³⁰ of the per-tick unit.
//!   Re-planned from a moving state, the rounding of durations to whole ticks can ask a change
//!   that was shorter than a tick for more than its limit; such changes are lengthened (bounded
//!   rounds), and what is left was measured at most 1.0006 × the velocity, 1.031 × the
//!   acceleration and 1.002 × the jerk limit over 300 random re-plan scenarios.
//! - Known limitation: a jerk-limited re-plan that must first ramp away a large present
//!   acceleration can ramp it with a jerk a few per cent below the limit (the fit solves the
//!   jerk for whole ticks), so the velocity gained meanwhile, `a²/2j`, overshoots a velocity
//!   limit that the axis was already close to: 0.86 % in `examples/pp_profile_plot.rs`
//!   (re-plan at full acceleration 5 000 increments/s below the limit).
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
mod shape;
mod trajectory;

#[cfg(test)]
mod tests;

pub use planner::{PositionPlanner, VelocityRamp};

/// Largest target magnitude accepted by [`PositionPlanner::plan`], in increments (2⁴⁰).
pub const POSITION_RANGE: i64 = 1 << 40;

/// The control-loop tick rate the profiles are sampled at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TickRate(u32);

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
            Ok(TickRate(hz))
        }
    }

    /// Ticks per second.
    pub const fn hz(self) -> u32 {
        self.0
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

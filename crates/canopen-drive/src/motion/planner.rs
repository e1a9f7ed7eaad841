//! [`PositionPlanner`] (pp moves, halt and quick stop in pp) and [`VelocityRamp`] (pv, halt,
//! quick stop).

use super::fixed::{per_tick, round_to_int, to_si, to_whole_si, FRAC, ONE_F32};
use super::shape::{position_shape, velocity_change, Changes, ShapeLimits, VelocityEnd};
use super::trajectory::{Aims, Exact, Fit, TickShape, Trajectory};
use super::{Limits, MotionError, MotionState, ProfileType, TickRate, POSITION_RANGE};

/// Secant corrections of the peak velocity after the first fit.
const CLOSING_STEPS: u32 = 4;

/// Rounds of lengthening velocity changes that the closing pushed over a limit.
const RELAX_ROUNDS: u32 = 24;

fn shape_limits(limits: &Limits) -> ShapeLimits {
    let jerk = match limits.profile {
        ProfileType::Trapezoidal => None,
        ProfileType::JerkLimited => Some([
            limits.jerk.accel_start as f32,
            limits.jerk.accel_end as f32,
            limits.jerk.decel_start as f32,
            limits.jerk.decel_end as f32,
        ]),
    };
    ShapeLimits {
        velocity: limits.velocity as f32,
        acceleration: limits.acceleration as f32,
        deceleration: limits.deceleration as f32,
        jerk,
    }
}

fn state_of(now: &Exact, hz: u32) -> MotionState {
    MotionState {
        position: round_to_int(now.p).clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64,
        velocity: to_whole_si(now.v, hz, 1),
        acceleration: to_whole_si(now.a, hz, 2),
    }
}

/// Plans a velocity change of `trajectory` to `velocity` (fixed point, per tick); the plan
/// ends there exactly.
fn plan_velocity(
    trajectory: &mut Trajectory,
    velocity: i128,
    limits: &Limits,
    hz: u32,
) -> Result<u32, MotionError> {
    limits.check_ramps()?;
    let now = trajectory.now;
    let shape_limits = shape_limits(limits);
    let mut changes = Changes::default();
    velocity_change(
        to_si(now.v, hz, 1),
        to_si(now.a, hz, 2),
        to_si(velocity, hz, 1),
        VelocityEnd::Final,
        &shape_limits,
        &mut changes,
    );
    let jerk_limited = shape_limits.jerk.is_some();
    let len = changes.as_slice().len();
    let mut ticks = TickShape::new(changes.as_slice(), len, 0.0, hz, limits).ok_or(MotionError::TooLong)?;
    let aims = Aims { peak: velocity, last: velocity };
    let mut fit = Fit::build(now, &ticks, &aims, jerk_limited).ok_or(MotionError::TooLong)?;
    for _ in 0..RELAX_ROUNDS {
        if !ticks.relax(&fit).ok_or(MotionError::TooLong)? {
            break;
        }
        fit = Fit::build(now, &ticks, &aims, jerk_limited).ok_or(MotionError::TooLong)?;
    }
    let end = Exact { v: velocity, a: 0, ..fit.end };
    trajectory.start(&fit, end);
    Ok(ticks.total() as u32)
}

/// Fits `ticks` from `start` and corrects the peak velocity so the fit covers `to_go`: with the
/// tick counts fixed the distance is affine in the peak velocity, so a secant step (repeated
/// against rounding) lands on the target.
fn close(
    start: &Exact,
    ticks: &TickShape,
    peak: i128,
    last: i128,
    to_go: i128,
    jerk_limited: bool,
) -> Result<Fit, MotionError> {
    let fit_with = |peak: i128| {
        Fit::build(*start, ticks, &Aims { peak, last }, jerk_limited).ok_or(MotionError::TooLong)
    };
    let mut peak = peak;
    let mut fit = fit_with(peak)?;
    let probe = (peak.unsigned_abs() >> 10).max(1 << 32) as i128;
    let slope = {
        let other = fit_with(peak.saturating_add(probe))?;
        (other.displacement(start) - fit.displacement(start)) as f32 / probe as f32
    };
    if !(slope.is_finite() && slope > 0.0) {
        return Ok(fit);
    }
    for _ in 0..CLOSING_STEPS {
        let miss = to_go.saturating_sub(fit.displacement(start));
        let correction = (miss as f32 / slope) as i128;
        if miss == 0 || correction == 0 {
            break;
        }
        let candidate = fit_with(peak.saturating_add(correction))?;
        if to_go.saturating_sub(candidate.displacement(start)).unsigned_abs() >= miss.unsigned_abs() {
            break;
        }
        peak = peak.saturating_add(correction);
        fit = candidate;
    }
    Ok(fit)
}

/// Point-to-point trajectory generator for profile position mode (`spec/cia402.md` §9).
///
/// Holds the demand state (position, velocity, acceleration) and a plan. [`Self::plan`]
/// replaces the plan from the present state at any moment; [`Self::step`] advances one tick.
/// Positions are `i64` increments; see [`MotionState::position_demand`] for the i32 view.
#[derive(Clone, Debug)]
pub struct PositionPlanner {
    hz: u32,
    trajectory: Trajectory,
    target: i64,
    closing_error: i128,
}

impl PositionPlanner {
    /// A planner at rest at `position`.
    pub const fn new(rate: TickRate, position: i64) -> Self {
        PositionPlanner {
            hz: rate.hz(),
            trajectory: Trajectory::at_rest((position as i128) << FRAC),
            target: position,
            closing_error: 0,
        }
    }

    /// Drops any plan and holds still at `position` (e.g. the actual position when the drive
    /// enters Operation enabled).
    pub fn reset(&mut self, position: i64) {
        self.trajectory = Trajectory::at_rest(i128::from(position) << FRAC);
        self.target = position;
        self.closing_error = 0;
    }

    /// Plans a move from the present state to `target` (increments), passing it at
    /// `end_velocity` (increments/s, 6082h, limited to the velocity limit, in the direction of
    /// the move; 0 for a stop at the target). Returns the number of ticks until the target.
    ///
    /// The present position, velocity and (jerk-limited) acceleration carry over, so
    /// re-planning mid-move is continuous. On error the present motion continues unchanged.
    pub fn plan(&mut self, target: i64, end_velocity: u32, limits: &Limits) -> Result<u32, MotionError> {
        if !(-POSITION_RANGE..=POSITION_RANGE).contains(&target) {
            return Err(MotionError::OutOfRange);
        }
        if limits.velocity == 0 {
            return Err(MotionError::ZeroVelocity);
        }
        limits.check_ramps()?;
        let hz = self.hz;
        let start = self.trajectory.now;
        let target_fixed = i128::from(target) << FRAC;
        let to_go = target_fixed - start.p;
        let end_speed = end_velocity.min(limits.velocity);
        let last = match to_go.signum() {
            0 => 0,
            s => s * per_tick(end_speed, hz, 1),
        };
        if to_go == 0 && start.v == 0 && start.a == 0 && last == 0 {
            self.trajectory = Trajectory::at_rest(target_fixed);
            self.target = target;
            self.closing_error = 0;
            return Ok(0);
        }
        let shape_limits = shape_limits(limits);
        let jerk_limited = shape_limits.jerk.is_some();
        let shape = position_shape(
            to_go as f32 / ONE_F32,
            to_si(start.v, hz, 1),
            to_si(start.a, hz, 2),
            to_si(last, hz, 1),
            &shape_limits,
        )
        .ok_or(MotionError::ZeroVelocity)?;
        let mut ticks = TickShape::new(shape.changes.as_slice(), shape.before, shape.cruise, hz, limits)
            .ok_or(MotionError::TooLong)?;
        let initial_peak = super::fixed::from_si(shape.peak, hz, 1);
        let mut fit = close(&start, &ticks, initial_peak, last, to_go, jerk_limited)?;
        for _ in 0..RELAX_ROUNDS {
            if !ticks.relax(&fit).ok_or(MotionError::TooLong)? {
                break;
            }
            fit = close(&start, &ticks, initial_peak, last, to_go, jerk_limited)?;
        }
        self.closing_error = to_go.saturating_sub(fit.displacement(&start));
        let end = Exact { p: target_fixed, v: last, a: 0 };
        self.trajectory.start(&fit, end);
        self.target = target;
        Ok(ticks.total() as u32)
    }

    /// Stops with `deceleration` (increments/s², e.g. 6084h for halt, 6085h for quick stop),
    /// with the profile and the deceleration jerks (C, D) of `limits`; the target is dropped.
    /// Returns the ticks until standstill. [`MotionError::ZeroDeceleration`] if it is 0.
    pub fn stop(&mut self, deceleration: u32, limits: &Limits) -> Result<u32, MotionError> {
        if deceleration == 0 {
            return Err(MotionError::ZeroDeceleration);
        }
        let stop_limits = Limits { acceleration: deceleration, deceleration, ..*limits };
        let ticks = plan_velocity(&mut self.trajectory, 0, &stop_limits, self.hz)?;
        self.closing_error = 0;
        Ok(ticks)
    }

    /// Advances one tick and returns the new demand.
    pub fn step(&mut self) -> MotionState {
        self.trajectory.step();
        self.state()
    }

    /// The present demand.
    pub fn state(&self) -> MotionState {
        state_of(&self.trajectory.now, self.hz)
    }

    /// True when the plan is complete: the target reached (or the stop complete). With a
    /// non-zero end velocity the demand then moves on at that velocity until the next plan.
    pub fn is_finished(&self) -> bool {
        self.trajectory.is_finished()
    }

    /// Ticks until the plan is complete.
    pub fn remaining_ticks(&self) -> u64 {
        self.trajectory.remaining()
    }

    /// The target of the last plan (or the reset position).
    pub fn target(&self) -> i64 {
        self.target
    }

    /// The fixed-point state (for the tests).
    #[cfg(test)]
    pub(crate) fn exact(&self) -> Exact {
        self.trajectory.now
    }

    /// How far the fitted profile ended from the target before the last sample was set to it,
    /// in 2⁻⁶⁴ increments (for the tests).
    #[cfg(test)]
    pub(crate) fn closing_error(&self) -> i128 {
        self.closing_error
    }
}

/// Velocity ramp for profile velocity mode (`spec/cia402.md` §13) and for halt and quick stop
/// (§6): moves the velocity demand to a target velocity under the acceleration, deceleration
/// and (jerk-limited) jerk limits.
#[derive(Clone, Debug)]
pub struct VelocityRamp {
    hz: u32,
    trajectory: Trajectory,
}

impl VelocityRamp {
    /// A ramp at rest (velocity 0, position 0).
    pub const fn new(rate: TickRate) -> Self {
        VelocityRamp { hz: rate.hz(), trajectory: Trajectory::at_rest(0) }
    }

    /// Ramps from the present velocity (and acceleration) to `velocity` (increments/s, clamped
    /// to ±`limits.velocity`). Call it when the target or the limits change; returns the ticks
    /// until the target velocity. A velocity limit of 0 ramps to standstill.
    pub fn set_target(&mut self, velocity: i32, limits: &Limits) -> Result<u32, MotionError> {
        let speed = velocity.unsigned_abs().min(limits.velocity);
        let fixed = per_tick(speed, self.hz, 1);
        let fixed = if velocity < 0 { -fixed } else { fixed };
        plan_velocity(&mut self.trajectory, fixed, limits, self.hz)
    }

    /// Ramps to standstill with `deceleration` (halt: 6084h, quick stop: 6085h) and the profile
    /// and deceleration jerks of `limits`.
    pub fn stop(&mut self, deceleration: u32, limits: &Limits) -> Result<u32, MotionError> {
        if deceleration == 0 {
            return Err(MotionError::ZeroDeceleration);
        }
        let stop_limits = Limits { acceleration: deceleration, deceleration, ..*limits };
        plan_velocity(&mut self.trajectory, 0, &stop_limits, self.hz)
    }

    /// Advances one tick and returns the new demand (its position is the integral of the
    /// velocity since [`Self::new`]).
    pub fn step(&mut self) -> MotionState {
        self.trajectory.step();
        self.state()
    }

    /// The present demand.
    pub fn state(&self) -> MotionState {
        state_of(&self.trajectory.now, self.hz)
    }

    /// True when the target velocity is reached.
    pub fn is_finished(&self) -> bool {
        self.trajectory.is_finished()
    }

    /// The fixed-point state (for the tests).
    #[cfg(test)]
    pub(crate) fn exact(&self) -> Exact {
        self.trajectory.now
    }
}

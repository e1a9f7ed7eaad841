//! [`PositionPlanner`] (pp moves, halt and quick stop in pp) and [`VelocityRamp`] (pv, halt,
//! quick stop).

use super::fixed::{per_tick, round_to_int, to_whole_si, FRAC};
use super::legs::margin;
use super::ramps::{RampLimits, Ramps};
use super::solve::{plan_move, plan_velocity, Method, Planned};
use super::trajectory::{Exact, Segment, Trajectory, MAX_SEGMENTS};
use super::{Limits, MotionError, MotionState, ProfileType, TickRate, POSITION_RANGE};

fn state_of(now: &Exact, hz: u32) -> MotionState {
    MotionState {
        position: round_to_int(now.p).clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64,
        velocity: to_whole_si(now.v, hz, 1),
        acceleration: to_whole_si(now.a, hz, 2),
    }
}

/// Plans a velocity change of `trajectory` to `velocity` (fixed point, per tick); the plan
/// ends there exactly.
fn ramp_to(
    trajectory: &mut Trajectory,
    velocity: i128,
    limits: &Limits,
    hz: u32,
) -> Result<(u32, Method), MotionError> {
    let mut segments = [Segment::default(); MAX_SEGMENTS];
    let planned = plan_velocity(trajectory.now, velocity, limits, hz, &mut segments)?;
    let ticks = u32::try_from(planned.ticks).map_err(|_| MotionError::TooLong)?;
    let end = Exact { v: velocity, a: 0, ..planned.end };
    trajectory.start(&segments, planned.len, end);
    Ok((ticks, planned.method))
}

/// What executes the present plan: a trapezoid's legs ([`Ramps`], planned in bounded time) or
/// the jerk-limited segments of the exact planner.
///
/// The segments are the larger by some 800 bytes; there is no heap to box them in, and they go
/// when the jerk-limited profile moves to a bounded planner as well.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Engine {
    Ramps(Ramps),
    Segments(Trajectory),
}

impl Engine {
    fn now(&self) -> Exact {
        match self {
            Engine::Ramps(ramps) => ramps.now(),
            Engine::Segments(trajectory) => trajectory.now,
        }
    }

    /// The segment executor, started at the present state if a trapezoid ran (`None` only if
    /// that failed, which it does not).
    fn segments(&mut self) -> Option<&mut Trajectory> {
        if let Engine::Ramps(ramps) = self {
            let now = ramps.now();
            let mut trajectory = Trajectory::at_rest(now.p);
            trajectory.now = now;
            *self = Engine::Segments(trajectory);
        }
        match self {
            Engine::Segments(trajectory) => Some(trajectory),
            Engine::Ramps(_) => None,
        }
    }

    /// The trapezoid executor, started at the present state if segments ran.
    fn ramps(&mut self) -> Option<&mut Ramps> {
        if let Engine::Segments(trajectory) = self {
            *self = Engine::Ramps(Ramps::at(trajectory.now));
        }
        match self {
            Engine::Ramps(ramps) => Some(ramps),
            Engine::Segments(_) => None,
        }
    }

    fn step(&mut self) {
        match self {
            Engine::Ramps(ramps) => {
                ramps.work();
                ramps.step();
            }
            Engine::Segments(trajectory) => trajectory.step(),
        }
    }

    fn is_finished(&self) -> bool {
        match self {
            Engine::Ramps(ramps) => ramps.is_finished(),
            Engine::Segments(trajectory) => trajectory.is_finished(),
        }
    }

    fn remaining(&self) -> u64 {
        match self {
            Engine::Ramps(ramps) => ramps.remaining(),
            Engine::Segments(trajectory) => trajectory.remaining(),
        }
    }
}

/// Point-to-point trajectory generator for profile position mode (`spec/cia402.md` §9).
///
/// Holds the demand state (position, velocity, acceleration) and a plan. [`Self::plan`]
/// replaces the plan from the present state at any moment; [`Self::step`] advances one tick.
/// Positions are `i64` increments; see [`MotionState::position_demand`] for the i32 view.
#[derive(Clone, Debug)]
pub struct PositionPlanner {
    rate: TickRate,
    hz: u32,
    engine: Engine,
    /// The demand in whole units, converted once per change of the state (the profile asks for
    /// it several times a tick).
    state: MotionState,
    target: i64,
    closing_error: i128,
    method: Method,
}

impl PositionPlanner {
    /// A planner at rest at `position`.
    pub const fn new(rate: TickRate, position: i64) -> Self {
        PositionPlanner {
            rate,
            hz: rate.hz(),
            engine: Engine::Ramps(Ramps::at(Exact { p: (position as i128) << FRAC, v: 0, a: 0 })),
            state: MotionState { position, velocity: 0, acceleration: 0 },
            target: position,
            closing_error: 0,
            method: Method::Shape,
        }
    }

    /// Drops any plan and holds still at `position` (e.g. the actual position when the drive
    /// enters Operation enabled).
    pub fn reset(&mut self, position: i64) {
        let p = i128::from(position) << FRAC;
        match &mut self.engine {
            Engine::Segments(trajectory) => trajectory.hold(p),
            Engine::Ramps(ramps) => ramps.hold(p),
        }
        self.state = state_of(&self.engine.now(), self.hz);
        self.target = position;
        self.closing_error = 0;
        self.method = Method::Shape;
    }

    /// Plans a move from the present state to `target` (increments), passing it at
    /// `end_velocity` (increments/s, 6082h, limited to the velocity limit, in the direction of
    /// the move; 0 for a stop at the target). Returns the number of ticks until the target.
    ///
    /// The present position, velocity and (jerk-limited) acceleration carry over, so
    /// re-planning mid-move is continuous. On error the present motion continues unchanged.
    pub fn plan(&mut self, target: i64, end_velocity: u32, limits: &Limits) -> Result<u32, MotionError> {
        let ticks = self.plan_from_here(target, end_velocity, limits, false);
        self.state = state_of(&self.engine.now(), self.hz);
        ticks
    }

    /// [`Self::plan`] in bounded time per tick, as a drive's tick needs it. The request is
    /// checked at once (the same errors; on error the present motion continues). A trapezoid
    /// is then planned by the following [`Self::step`]s, a layout or a round of its solver per
    /// step, none in the step of the tick that asks; meanwhile the axis already moves under a
    /// provisional rule (towards the target at the acceleration while the velocity limit and
    /// the room to slow down allow, else slowing down), and the plan starts, usually in the
    /// third step, from wherever that brought it. [`Self::is_finished`] is false until the plan
    /// is complete. (A jerk-limited plan is still made at once, by the exact planner.)
    pub fn request(&mut self, target: i64, end_velocity: u32, limits: &Limits) -> Result<(), MotionError> {
        let result = self.plan_from_here(target, end_velocity, limits, true);
        if !matches!(limits.profile, ProfileType::Trapezoidal) {
            // A trapezoid's request leaves the state as it is; the exact planner may round it.
            self.state = state_of(&self.engine.now(), self.hz);
        }
        result.map(|_| ())
    }

    /// [`Self::plan`] but for [`Self::state`], which the caller converts after it. (Out of
    /// line: [`Self::plan`] and [`Self::request`] share one copy.)
    #[inline(never)]
    fn plan_from_here(
        &mut self,
        target: i64,
        end_velocity: u32,
        limits: &Limits,
        sliced: bool,
    ) -> Result<u32, MotionError> {
        if !(-POSITION_RANGE..=POSITION_RANGE).contains(&target) {
            return Err(MotionError::OutOfRange);
        }
        if limits.velocity == 0 {
            return Err(MotionError::ZeroVelocity);
        }
        limits.check_ramps()?;
        let hz = self.hz;
        let start = self.engine.now();
        let target_fixed = i128::from(target) << FRAC;
        let to_go = target_fixed - start.p;
        let end_speed = end_velocity.min(limits.velocity);
        if matches!(limits.profile, ProfileType::Trapezoidal) {
            let last = if end_speed == 0 { 0 } else { to_go.signum() * per_tick(end_speed, hz, 1) };
            let ramps = self.engine.ramps().ok_or(MotionError::TooLong)?;
            let limits = RampLimits::new(limits, self.rate);
            let ticks = if sliced {
                ramps.request(target_fixed, last, &limits)?;
                0
            } else {
                ramps.plan(target_fixed, last, &limits)?
            };
            self.target = target;
            return u32::try_from(ticks).map_err(|_| MotionError::TooLong);
        }
        // The peak is fitted a hair under the velocity limit (`legs::margin`): an end velocity at
        // the limit itself (a change-on-set-point pass at the profile velocity) is taken at that
        // hair too, or no peak could reach it.
        let end_fixed = per_tick(end_speed, hz, 1).min(margin(per_tick(limits.velocity, hz, 1)));
        let last = match to_go.signum() {
            0 => 0,
            s => s * end_fixed,
        };
        let trajectory = self.engine.segments().ok_or(MotionError::TooLong)?;
        if to_go == 0 && start.v == 0 && start.a == 0 && last == 0 {
            *trajectory = Trajectory::at_rest(target_fixed);
            self.target = target;
            self.closing_error = 0;
            self.method = Method::Shape;
            return Ok(0);
        }
        let mut segments = [Segment::default(); MAX_SEGMENTS];
        let planned: Planned = plan_move(start, to_go, last, limits, hz, &mut segments)?;
        let ticks = u32::try_from(planned.ticks).map_err(|_| MotionError::TooLong)?;
        self.closing_error = to_go.saturating_sub(planned.end.p.saturating_sub(start.p));
        self.method = planned.method;
        let end = Exact { p: target_fixed, v: last, a: 0 };
        trajectory.start(&segments, planned.len, end);
        self.target = target;
        Ok(ticks)
    }

    /// Stops with `deceleration` (increments/s², e.g. 6084h for halt, 6085h for quick stop),
    /// with the profile and the deceleration jerks (C, D) of `limits`; the target is dropped.
    /// Returns the ticks until standstill. [`MotionError::ZeroDeceleration`] if it is 0.
    pub fn stop(&mut self, deceleration: u32, limits: &Limits) -> Result<u32, MotionError> {
        if deceleration == 0 {
            return Err(MotionError::ZeroDeceleration);
        }
        let ticks = if matches!(limits.profile, ProfileType::Trapezoidal) {
            let ramps = self.engine.ramps().ok_or(MotionError::TooLong)?;
            let ticks = ramps.stop(self.rate.scale(deceleration, 2))?;
            u32::try_from(ticks).map_err(|_| MotionError::TooLong)?
        } else {
            let stop_limits = Limits { acceleration: deceleration, deceleration, ..*limits };
            let trajectory = self.engine.segments().ok_or(MotionError::TooLong)?;
            let (ticks, method) = ramp_to(trajectory, 0, &stop_limits, self.hz)?;
            self.method = method;
            ticks
        };
        self.state = state_of(&self.engine.now(), self.hz);
        self.closing_error = 0;
        Ok(ticks)
    }

    /// Advances one tick and returns the new demand.
    pub fn step(&mut self) -> MotionState {
        self.engine.step();
        self.state = state_of(&self.engine.now(), self.hz);
        self.state
    }

    /// The present demand.
    pub fn state(&self) -> MotionState {
        self.state
    }

    /// True when the plan is complete: the target reached (or the stop complete). With a
    /// non-zero end velocity the demand then moves on at that velocity until the next plan.
    pub fn is_finished(&self) -> bool {
        self.engine.is_finished()
    }

    /// Ticks until the plan is complete.
    pub fn remaining_ticks(&self) -> u64 {
        self.engine.remaining()
    }

    /// The target of the last plan (or the reset position).
    pub fn target(&self) -> i64 {
        self.target
    }

    /// The fixed-point state (for the tests).
    #[cfg(test)]
    pub(crate) fn exact(&self) -> Exact {
        self.engine.now()
    }

    /// True while a requested plan is being made (for the tests).
    #[cfg(test)]
    pub(crate) fn is_planning(&self) -> bool {
        matches!(&self.engine, Engine::Ramps(ramps) if ramps.is_planning())
    }

    /// How the last plan was made (for the tests).
    #[cfg(test)]
    pub(crate) fn method(&self) -> Method {
        match &self.engine {
            Engine::Ramps(ramps) => match ramps.made() {
                super::ramps::Made::Layout => Method::Shape,
                super::ramps::Made::Fallback => Method::Fallback,
            },
            Engine::Segments(_) => self.method,
        }
    }

    /// How far the fitted profile ended from the target before the last sample was set to it,
    /// in 2⁻⁶⁴ increments (for the tests).
    #[cfg(test)]
    pub(crate) fn closing_error(&self) -> i128 {
        match &self.engine {
            Engine::Ramps(ramps) => ramps.closing_error(),
            Engine::Segments(_) => self.closing_error,
        }
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
        ramp_to(&mut self.trajectory, fixed, limits, self.hz).map(|(ticks, _)| ticks)
    }

    /// Ramps to standstill with `deceleration` (halt: 6084h, quick stop: 6085h) and the profile
    /// and deceleration jerks of `limits`.
    pub fn stop(&mut self, deceleration: u32, limits: &Limits) -> Result<u32, MotionError> {
        if deceleration == 0 {
            return Err(MotionError::ZeroDeceleration);
        }
        let stop_limits = Limits { acceleration: deceleration, deceleration, ..*limits };
        ramp_to(&mut self.trajectory, 0, &stop_limits, self.hz).map(|(ticks, _)| ticks)
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

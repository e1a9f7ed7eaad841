//! [`PositionPlanner`] (pp moves, halt and quick stop in pp) and [`VelocityRamp`] (pv, halt,
//! quick stop).

use super::fixed::{per_tick, round_to_int, to_whole_si, FRAC};
use super::ramps::{Exact, RampLimits, Ramps};
#[cfg(test)]
use super::solve::Method;
use super::{Limits, MotionError, MotionState, ProfileType, TickRate, POSITION_RANGE};

fn state_of(now: &Exact, hz: u32) -> MotionState {
    MotionState {
        position: round_to_int(now.p).clamp(i128::from(i64::MIN), i128::from(i64::MAX)) as i64,
        velocity: to_whole_si(now.v, hz, 1),
        acceleration: to_whole_si(now.a, hz, 2),
    }
}

/// Point-to-point trajectory generator for profile position mode (CiA 402-2 §10).
///
/// Holds the demand state (position, velocity, acceleration) and a plan. [`Self::plan`]
/// replaces the plan from the present state at any moment; [`Self::step`] advances one tick.
/// Positions are `i64` increments; see [`MotionState::position_demand`] for the i32 view.
#[derive(Clone, Debug)]
pub struct PositionPlanner {
    rate: TickRate,
    hz: u32,
    ramps: Ramps,
    /// The demand in whole units, converted once per change of the state (the profile asks for
    /// it several times a tick).
    state: MotionState,
    target: i64,
}

impl PositionPlanner {
    /// A planner at rest at `position`.
    pub const fn new(rate: TickRate, position: i64) -> Self {
        PositionPlanner {
            rate,
            hz: rate.hz(),
            ramps: Ramps::at(Exact { p: (position as i128) << FRAC, v: 0, a: 0 }),
            state: MotionState { position, velocity: 0, acceleration: 0 },
            target: position,
        }
    }

    /// Drops any plan and holds still at `position` (e.g. the actual position when the drive
    /// enters Operation enabled).
    pub fn reset(&mut self, position: i64) {
        self.ramps.hold(i128::from(position) << FRAC);
        self.state = state_of(&self.ramps.now(), self.hz);
        self.target = position;
    }

    /// Plans a move from the present state to `target` (increments), passing it at
    /// `end_velocity` (increments/s, 6082h, limited to the velocity limit, in the direction of
    /// the move; 0 for a stop at the target). Returns the number of ticks until the target.
    ///
    /// The present position, velocity and (jerk-limited) acceleration carry over, so
    /// re-planning mid-move is continuous. On error the present motion continues unchanged.
    pub fn plan(&mut self, target: i64, end_velocity: u32, limits: &Limits) -> Result<u32, MotionError> {
        let ticks = self.plan_from_here(target, end_velocity, limits, false);
        self.state = state_of(&self.ramps.now(), self.hz);
        ticks
    }

    /// [`Self::plan`] in bounded time per tick, as a drive's tick needs it. The request is
    /// checked at once (the same errors; on error the present motion continues). The plan is
    /// then made by the shares ([`Self::plan_ahead`]) of the following ticks, none in the tick
    /// that asks (its share only begins it). A trapezoid: a layout or a round of its solver
    /// per share; meanwhile the axis already moves under a provisional rule (towards the
    /// target at the acceleration while the velocity limit and the room to slow down allow,
    /// else slowing down), and the plan starts, usually in the fourth step after the one of
    /// the request, from wherever that brought it. A jerk-limited plan is made for the state
    /// of this tick (a few steps of its search per share, its counts, then per round its peak
    /// and one leg), while the axis ramps its acceleration out and coasts as that plan begins;
    /// it is complete usually 9 to 16 ticks after the request. [`Self::is_finished`] is false
    /// until the plan is complete.
    pub fn request(&mut self, target: i64, end_velocity: u32, limits: &Limits) -> Result<(), MotionError> {
        let result = self.plan_from_here(target, end_velocity, limits, true);
        if !matches!(limits.profile, ProfileType::Trapezoidal) {
            // A trapezoid's request leaves the state as it is; a jerk-limited one keeps the
            // position and the velocity, and its acceleration in sixths (the decay's start).
            self.state.acceleration = to_whole_si(self.ramps.now().a, self.hz, 2);
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
        let (target_fixed, last) = self.problem(target, end_velocity, limits)?;
        let ticks = match limits.profile {
            // Its limits are converted in the next tick.
            ProfileType::JerkLimited if sliced => {
                self.ramps.request_jerk(target_fixed, last, limits, self.rate)?;
                0
            }
            _ => self.ramps_at(target_fixed, last, limits, sliced)?,
        };
        self.target = target;
        u32::try_from(ticks).map_err(|_| MotionError::TooLong)
    }

    /// The target of a plan in fixed point and the velocity to pass it at (per tick, in the
    /// direction of the move), once the request is checked.
    fn problem(&self, target: i64, end_velocity: u32, limits: &Limits) -> Result<(i128, i128), MotionError> {
        if !(-POSITION_RANGE..=POSITION_RANGE).contains(&target) {
            return Err(MotionError::OutOfRange);
        }
        if limits.velocity == 0 {
            return Err(MotionError::ZeroVelocity);
        }
        limits.check_ramps()?;
        let target_fixed = i128::from(target) << FRAC;
        let to_go = target_fixed - self.ramps.now().p;
        let end_speed = end_velocity.min(limits.velocity);
        let last = if end_speed == 0 { 0 } else { to_go.signum() * per_tick(end_speed, self.hz, 1) };
        Ok((target_fixed, last))
    }

    /// [`Self::plan_from_here`] with the limits converted now: a trapezoid's request, or a plan
    /// made at once. Out of line: a jerk-limited request (the tick that takes an S-curve
    /// set-point) does not need its stack.
    #[inline(never)]
    fn ramps_at(
        &mut self,
        target: i128,
        last: i128,
        limits: &Limits,
        sliced: bool,
    ) -> Result<u64, MotionError> {
        let ramp_limits = RampLimits::new(limits, self.rate);
        if sliced {
            self.ramps.request(target, last, &ramp_limits)?;
            Ok(0)
        } else {
            self.ramps.plan(target, last, &ramp_limits)
        }
    }

    /// Stops with `deceleration` (increments/s², e.g. 6084h for halt, 6085h for quick stop),
    /// with the profile and the deceleration jerks (C, D) of `limits`; the target is dropped.
    /// Returns the ticks until standstill. [`MotionError::ZeroDeceleration`] if it is 0.
    pub fn stop(&mut self, deceleration: u32, limits: &Limits) -> Result<u32, MotionError> {
        if deceleration == 0 {
            return Err(MotionError::ZeroDeceleration);
        }
        let stop_limits = Limits { acceleration: deceleration, deceleration, ..*limits };
        let ticks = self.ramps.velocity(0, &RampLimits::new(&stop_limits, self.rate))?;
        self.state = state_of(&self.ramps.now(), self.hz);
        u32::try_from(ticks).map_err(|_| MotionError::TooLong)
    }

    /// [`Self::stop`] in bounded time per tick, as a drive's tick needs it. A trapezoid's stop
    /// is one leg, planned at once; a jerk-limited one is planned over the following
    /// [`Self::step`]s: its present acceleration ramps out from this step on, its limits are
    /// converted in the next, and its pulse is fitted in the one after (usually; the axis
    /// coasts until the pulse starts). [`Self::is_finished`] turns true at standstill.
    pub fn request_stop(&mut self, deceleration: u32, limits: &Limits) -> Result<(), MotionError> {
        if deceleration == 0 {
            return Err(MotionError::ZeroDeceleration);
        }
        let stop_limits = Limits { acceleration: deceleration, deceleration, ..*limits };
        match limits.profile {
            ProfileType::Trapezoidal => {
                self.ramps.velocity_trapezoid(0, &RampLimits::new(&stop_limits, self.rate))?;
            }
            ProfileType::JerkLimited => self.ramps.request_velocity(0, &stop_limits, self.rate)?,
        }
        // The position and the velocity stay (the acceleration of a trapezoid's stop is the
        // next tick's, of a jerk-limited one the decay's start).
        self.state.acceleration = to_whole_si(self.ramps.now().a, self.hz, 2);
        Ok(())
    }

    /// Advances one tick and returns the new demand: [`Self::follow`], then the share of a
    /// plan in progress for the next tick ([`Self::plan_ahead`]).
    pub fn step(&mut self) -> MotionState {
        self.follow();
        self.plan_ahead();
        self.state
    }

    /// Advances one tick without a share of a plan in progress: for a caller that does the
    /// share for the next tick with [`Self::plan_ahead`] after its own work (a drive's tick,
    /// so that the share's stack is not under the mode's).
    pub fn follow(&mut self) -> MotionState {
        self.ramps.step();
        self.state = state_of(&self.ramps.now(), self.hz);
        self.state
    }

    /// The share of a plan in progress for the next [`Self::follow`] (none while no plan is
    /// being made). The share of the tick that asked for a plan only begins it; the work
    /// starts with the next tick's. [`Self::state`] stays as the step left it (while a
    /// trapezoid is made, its acceleration is the provisional one of the tick just stepped,
    /// not yet the next tick's, which the share chooses).
    pub fn plan_ahead(&mut self) {
        if self.ramps.planning() {
            self.ramps.work(self.rate);
        }
    }

    /// The present demand.
    pub fn state(&self) -> MotionState {
        self.state
    }

    /// True when the plan is complete: the target reached (or the stop complete). With a
    /// non-zero end velocity the demand then moves on at that velocity until the next plan.
    pub fn is_finished(&self) -> bool {
        self.ramps.is_finished()
    }

    /// The target of the last plan (or the reset position).
    pub fn target(&self) -> i64 {
        self.target
    }

    /// The fixed-point state (for the tests).
    #[cfg(test)]
    pub(crate) fn exact(&self) -> Exact {
        self.ramps.now()
    }

    /// True while a requested plan is being made (for the tests).
    #[cfg(test)]
    pub(crate) fn is_planning(&self) -> bool {
        self.ramps.is_planning()
    }

    /// How the last plan was made (for the tests).
    #[cfg(test)]
    pub(crate) fn method(&self) -> Method {
        match self.ramps.made() {
            super::ramps::Made::Layout => Method::Shape,
            super::ramps::Made::Fallback => Method::Fallback,
        }
    }

    /// How far the fitted profile ended from the target before the last sample was set to it,
    /// in 2⁻⁶⁴ increments (for the tests).
    #[cfg(test)]
    pub(crate) fn closing_error(&self) -> i128 {
        self.ramps.closing_error()
    }
}

/// Velocity ramp for profile velocity mode (CiA 402-2 §14) and for halt and quick stop
/// (§8.4.5, §8.4.8): moves the velocity demand to a target velocity under the acceleration, deceleration
/// and (jerk-limited) jerk limits.
#[derive(Clone, Debug)]
pub struct VelocityRamp {
    rate: TickRate,
    ramps: Ramps,
}

impl VelocityRamp {
    /// A ramp at rest (velocity 0, position 0).
    pub const fn new(rate: TickRate) -> Self {
        VelocityRamp { rate, ramps: Ramps::at(Exact { p: 0, v: 0, a: 0 }) }
    }

    /// Ramps from the present velocity (and acceleration) to `velocity` (increments/s, clamped
    /// to ±`limits.velocity`). Call it when the target or the limits change; returns the ticks
    /// until the target velocity. A velocity limit of 0 ramps to standstill.
    pub fn set_target(&mut self, velocity: i32, limits: &Limits) -> Result<u32, MotionError> {
        limits.check_ramps()?;
        let speed = velocity.unsigned_abs().min(limits.velocity);
        let fixed = per_tick(speed, self.rate.hz(), 1);
        let fixed = if velocity < 0 { -fixed } else { fixed };
        let ticks = self.ramps.velocity(fixed, &RampLimits::new(limits, self.rate))?;
        u32::try_from(ticks).map_err(|_| MotionError::TooLong)
    }

    /// Ramps to standstill with `deceleration` (halt: 6084h, quick stop: 6085h) and the profile
    /// and deceleration jerks of `limits`.
    pub fn stop(&mut self, deceleration: u32, limits: &Limits) -> Result<u32, MotionError> {
        if deceleration == 0 {
            return Err(MotionError::ZeroDeceleration);
        }
        let stop_limits = Limits { acceleration: deceleration, deceleration, ..*limits };
        stop_limits.check_ramps()?;
        let ticks = self.ramps.velocity(0, &RampLimits::new(&stop_limits, self.rate))?;
        u32::try_from(ticks).map_err(|_| MotionError::TooLong)
    }

    /// Advances one tick and returns the new demand (its position is the integral of the
    /// velocity since [`Self::new`]).
    pub fn step(&mut self) -> MotionState {
        self.ramps.step();
        self.state()
    }

    /// The present demand.
    pub fn state(&self) -> MotionState {
        state_of(&self.ramps.now(), self.rate.hz())
    }

    /// True when the target velocity is reached.
    pub fn is_finished(&self) -> bool {
        self.ramps.is_finished()
    }

    /// The fixed-point state (for the tests).
    #[cfg(test)]
    pub(crate) fn exact(&self) -> Exact {
        self.ramps.now()
    }
}

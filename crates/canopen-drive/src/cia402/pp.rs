//! Profile position mode (pp, 6060h = 1; CiA 402-2 §10, §12).
//!
//! The master writes 607Ah and raises controlword bit 4; the drive takes the set-point,
//! acknowledges it with statusword bit 12 and moves along a trajectory from
//! [`crate::motion::PositionPlanner`]. What is implemented, and the choices where the standard
//! leaves room:
//!
//! - **Edges.** A set-point is taken on a 0→1 edge of bit 4 seen by a tick in Operation enabled
//!   with pp active. The edge is tracked in every state and mode, so a bit 4 already at 1 when
//!   the drive enters Operation enabled or switches to pp starts nothing.
//! - **Single set-point** (bit 5 = 1): re-plans at once from the present position, velocity and
//!   acceleration to the new target; waiting set-points are dropped (60F2h bits 3:2 = 00).
//! - **Set of set-points** (bit 5 = 0): up to [`ProfileConfig::setpoint_buffer`] set-points wait
//!   behind the one being executed and start when it is done. With the buffer full, a new
//!   bit 5 = 0 set-point is not taken (no acknowledge; CiA 402-2 §10.2.3).
//! - **Change on set-point** (bit 9 = 1 with bit 5 = 0): when a set-point waits behind the
//!   executed one, the executed one is re-planned to pass its target at the end velocity 6082h
//!   (or, when 6082h is 0, at the profile velocity 6081h) if the waiting target lies further in
//!   the same direction, and the next positioning starts from that motion without stopping.
//! - **Acknowledge** (bit 12): 1 from the tick that takes a set-point until the master clears
//!   bit 4, and while the buffer is full.
//! - **Relative** (bit 6 = 1): relative to the preceding target (60F2h bits 1:0 = 00), the
//!   position demand value 6062h (01) or the position actual value 6064h (10). Other 60F2h bits
//!   are refused by the SDO server.
//! - **Limits on the target** (user units, before the factor group): the position range limit
//!   607Bh wraps it (period `max − min + 1`), the software limits 607Dh, corrected by the home
//!   offset 607Ch, clamp it; statusword bit 11 is 1 while the executed target was clamped.
//! - **Limits on the motion**: velocity min(6081h, 607Fh, 6080h), acceleration
//!   min(6083h, 60C5h), deceleration min(6084h, 60C6h); 6086h trapezoidal (0) or jerk-limited
//!   (3) with 60A3h/60A4h.
//! - **Halt** (bit 8): stops with the ramp 605Dh selects; releasing it resumes towards the
//!   executed target.
//! - **Target reached** (bit 10): with halt = 0, when no set-point is executed or waiting and
//!   `|target − 6064h| ≤ 6067h` has held for 6068h ms (6067h = FFFF FFFFh: as soon as the
//!   trajectory has arrived); with halt = 1, once the demand has stopped (and the shaft rests,
//!   |606Ch| ≤ 606Fh, with [`ProfileConfig::halt_reached_at_standstill`]).

use super::config::ProfileConfig;
use super::factor::Factors;
use super::objects::Rule;
use super::objects::{
    parameter, setting, END_VELOCITY, MOTION_PROFILE_TYPE, POSITIONING_OPTION_CODE, PROFILE_JERK,
    PROFILE_JERK_USE, PROFILE_VELOCITY,
};
use super::slots::Slots;
use super::words::Controlword;
use crate::motion::{Jerks, Limits, MotionState, PositionPlanner, ProfileType};
use crate::od::Dictionary;
use crate::od::{Access, DataType, DefaultValue, Object, Var};
use crate::time::{Duration, Instant};

/// Largest set-point buffer.
const SLOTS: usize = ProfileConfig::MAX_SETPOINT_BUFFER as usize;

/// One accepted set-point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct SetPoint {
    /// Target in user units after wrap and limits (mirrored by polarity: as the master sees it).
    user: i64,
    /// Target in increments.
    internal: i64,
    /// Clamped by the software limits.
    limited: bool,
    /// Change on set-point (bit 9) was set when it was given.
    blend: bool,
    /// The encoder direction (−1, 0, 1) of the target from the actual position when it was
    /// given, before the target range clamped it.
    heading: i8,
}

/// What the profile hands pp each tick.
pub struct Inputs<'a, const B: usize> {
    /// The dictionary (parameters, 607Ah).
    pub od: &'a Dictionary<B>,
    /// The factor group.
    pub factors: &'a Factors,
    /// The per-tick entries.
    pub(crate) slots: &'a Slots,
    /// The controlword.
    pub controlword: Controlword,
    /// Bit 4 rose since the previous tick (and the drive did not just enter Operation enabled).
    pub new_setpoint: bool,
    /// Actual position, increments (encoder count).
    pub actual: i64,
    /// The encoder count at the user zero (moved by homing).
    pub origin: i64,
    /// The range a target is clamped to (user units): the software position limits 607Dh,
    /// narrowed by an active limit switch; `None`: unlimited.
    pub target_range: Option<(i64, i64)>,
    /// The shaft is at rest as halt needs it: |606Ch| within the velocity threshold 606Fh
    /// ([`ProfileConfig::halt_reached_at_standstill`]; always true without it).
    pub standstill: bool,
    /// Now.
    pub now: Instant,
    /// The profile's motion limits ([`limits`]) and end velocity 6082h, in increments.
    pub(crate) limits: Limits,
    pub(crate) end_velocity: u32,
    /// The velocity limit min(607Fh, 6080h), increments/s.
    pub(crate) velocity_cap: u32,
}

/// The statusword bits pp reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Bit 10.
    pub target_reached: bool,
    /// Bit 11.
    pub internal_limit: bool,
    /// Bit 12.
    pub setpoint_acknowledge: bool,
}

/// Profile position run-time state. The trajectory is the profile's position planner, lent to
/// each call (homing borrows the same one: the two never run at once, and a mode change resets
/// it in place, so a mode change builds no planner on the stack).
#[derive(Clone, Debug)]
pub struct ProfilePosition {
    depth: usize,
    active: Option<SetPoint>,
    queue: [Option<SetPoint>; SLOTS],
    /// The preceding target (user units) for relative moves.
    preceding: i64,
    /// Waiting for the master to clear bit 4.
    acknowledged: bool,
    halted: bool,
    in_window_since: Option<Instant>,
    /// The last target's user value and clamp state (kept after it is reached).
    last: Option<SetPoint>,
    /// The velocity the running plan was made with (increments/s; `u32::MAX`: no plan yet).
    planned_velocity: u32,
    /// The heading of the set-point taken in the last tick (0: none taken).
    heading_taken: i8,
}

/// The objects pp's motion limits come from (CiA 402-2 §10.5), as read from the dictionary: the
/// profile converts them again only when one of them has changed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LimitObjects {
    /// 6081h, 607Fh, 6080h.
    velocities: (u32, u32, u32),
    /// 6083h, 60C5h, 6084h, 60C6h.
    ramps: (u32, u32, u32, u32),
    /// 60A4h subs 1–4.
    jerks: (u32, u32, u32, u32),
    /// 6086h, 60A3h, 6082h.
    kind: (i16, u8, u32),
}

impl LimitObjects {
    /// The objects' present values.
    pub(crate) fn read<const B: usize>(od: &Dictionary<B>, s: &Slots) -> Self {
        LimitObjects {
            velocities: (
                od.load(s.profile_velocity),
                od.load(s.max_profile_velocity),
                od.load(s.max_motor_speed),
            ),
            ramps: (
                od.load(s.profile_acceleration),
                od.load(s.max_acceleration),
                od.load(s.profile_deceleration),
                od.load(s.max_deceleration),
            ),
            jerks: (
                od.load(s.profile_jerk_1),
                od.load(s.profile_jerk_2),
                od.load(s.profile_jerk_3),
                od.load(s.profile_jerk_4),
            ),
            kind: (od.load(s.motion_profile_type), od.load(s.profile_jerk_use), od.load(s.end_velocity)),
        }
    }

    /// The motion limits of pp and of the stops in pp, and the end velocity 6082h, in
    /// increments.
    pub(crate) fn limits(&self, factors: &Factors) -> (Limits, u32) {
        let (profile_velocity, max_profile_velocity, max_motor_speed) = self.velocities;
        let velocity = factors
            .limit_to_internal(profile_velocity.min(max_profile_velocity))
            .min(factors.motor_speed_to_internal(max_motor_speed));
        let (acceleration, max_acceleration, deceleration, max_deceleration) = self.ramps;
        let limits = Limits::new(
            velocity,
            factors.limit_to_internal(acceleration.min(max_acceleration)),
            factors.limit_to_internal(deceleration.min(max_deceleration)),
        );
        let (profile_type, jerk_use, end_velocity) = self.kind;
        let limits = match ProfileType::from_raw(profile_type) {
            Some(ProfileType::JerkLimited) => {
                let (j1, j2, j3, j4) = self.jerks;
                let subs = [j1, j2, j3, j4].map(|jerk| factors.limit_to_internal(jerk));
                let jerks = Jerks::from_profile_jerk(jerk_use, &subs).unwrap_or(Jerks::uniform(subs[0]));
                limits.with_jerks(ProfileType::JerkLimited, jerks)
            }
            _ => limits,
        };
        (limits, factors.limit_to_internal(end_velocity))
    }
}

impl ProfilePosition {
    /// No set-point; the planner is reset by the caller.
    pub fn new(config: &ProfileConfig) -> Self {
        ProfilePosition {
            depth: usize::from(config.setpoint_buffer).clamp(1, SLOTS),
            active: None,
            queue: [None; SLOTS],
            preceding: 0,
            acknowledged: false,
            halted: false,
            in_window_since: None,
            last: None,
            planned_velocity: u32::MAX,
            heading_taken: 0,
        }
    }

    /// Drops every set-point and holds `planner` at `position` (transition 4, a mode switch to
    /// pp, or the end of a stop). The preceding target for relative moves becomes `user`.
    pub fn reset(&mut self, planner: &mut PositionPlanner, position: i64, user: i64) {
        planner.reset(position);
        self.active = None;
        self.queue = [None; SLOTS];
        self.preceding = user;
        self.halted = false;
        self.in_window_since = None;
        self.last = None;
    }

    /// The encoder direction (−1, 0, 1) from the actual position to the target of the set-point
    /// taken in the last tick, before the target range clamped it; 0 when none was taken.
    pub fn heading_taken(&self) -> i8 {
        self.heading_taken
    }

    /// Stops `planner` with `deceleration` (increments/s²) under `limits`, dropping the
    /// set-points (quick stop, fault reaction, disable operation / shutdown ramps). The
    /// planner's steps then follow the stop ([`PositionPlanner::step`]).
    pub fn stop(&mut self, planner: &mut PositionPlanner, deceleration: u32, limits: &Limits) {
        self.active = None;
        self.queue = [None; SLOTS];
        // A refused stop (deceleration 0) keeps the motion; the caller's limits never give 0
        // because the FSA stops use non-zero ramps or coast.
        let _ = planner.request_stop(deceleration.max(1), limits);
    }

    fn queued(&self) -> usize {
        self.queue.iter().filter(|s| s.is_some()).count()
    }

    fn push(&mut self, setpoint: SetPoint) -> bool {
        match self.queue.iter_mut().take(self.depth).find(|s| s.is_none()) {
            Some(slot) => {
                *slot = Some(setpoint);
                true
            }
            None => false,
        }
    }

    fn pop(&mut self) -> Option<SetPoint> {
        let first = self.queue.first().copied().flatten();
        self.queue.rotate_left(1);
        if let Some(last) = self.queue.last_mut() {
            *last = None;
        }
        first
    }

    /// The target of a new set-point, from 607Ah and the controlword (CiA 402-2 §10.5.1, §12.3).
    fn setpoint<const B: usize>(&self, here: i64, input: &Inputs<'_, B>) -> SetPoint {
        let od = input.od;
        let sign = input.factors.position_sign();
        let raw = i64::from(od.load(input.slots.target_position));
        let mut user = if input.controlword.contains(Controlword::RELATIVE) {
            let base = match od.load(input.slots.positioning_option_code) & 0x3 {
                0b01 => input.factors.to_user(here.saturating_sub(input.origin)) * sign,
                0b10 => input.factors.to_user(input.actual.saturating_sub(input.origin)) * sign,
                _ => self.preceding,
            };
            base.saturating_add(raw)
        } else {
            raw
        };
        let (min, max) =
            (od.load(input.slots.position_range_limit_min), od.load(input.slots.position_range_limit_max));
        if min < max {
            let period = i64::from(max) - i64::from(min) + 1;
            user = i64::from(min) + user.saturating_sub(i64::from(min)).rem_euclid(period);
        }
        // Where the target lies from the axis (in encoder counts' direction), before an active
        // limit switch narrows the range to the actual position.
        let here = input.factors.to_user(input.actual.saturating_sub(input.origin)) * sign;
        let heading = (user.saturating_sub(here).signum() * sign) as i8;
        let mut limited = false;
        if let Some((low, high)) = input.target_range {
            if !(low..=high).contains(&user) {
                user = user.clamp(low, high);
                limited = true;
            }
        }
        let internal = input.factors.to_internal(user.saturating_mul(sign)).saturating_add(input.origin);
        SetPoint {
            user,
            internal,
            limited,
            blend: input.controlword.contains(Controlword::CHANGE_ON_SET_POINT),
            heading,
        }
    }

    /// Plans the executed set-point from the present state; with a waiting set-point of change
    /// on set-point beyond it in the same direction, passes the target at speed.
    fn plan_active(&mut self, planner: &mut PositionPlanner, limits: &Limits, end_velocity: u32) -> bool {
        let Some(active) = self.active else { return true };
        let next = self.queue.first().copied().flatten();
        self.plan(planner, active, next, limits, end_velocity)
    }

    /// Plans `active` from the present state, passing its target at speed where `next`, a
    /// set-point of change on set-point, lies beyond it in the same direction.
    fn plan(
        &mut self,
        planner: &mut PositionPlanner,
        active: SetPoint,
        next: Option<SetPoint>,
        limits: &Limits,
        end_velocity: u32,
    ) -> bool {
        let here = planner.state().position;
        let end = match next {
            Some(next) if active.blend => {
                let same_direction =
                    (active.internal - here).signum() == (next.internal - active.internal).signum();
                if same_direction && active.internal != here {
                    if end_velocity != 0 {
                        end_velocity
                    } else {
                        limits.velocity
                    }
                } else {
                    0
                }
            }
            _ => 0,
        };
        let planned = planner.request(active.internal, end, limits).is_ok();
        if planned {
            self.planned_velocity = limits.velocity;
        }
        planned
    }

    /// One tick of pp in Operation enabled (no FSA stop running), moving `planner`.
    pub fn tick<const B: usize>(
        &mut self,
        planner: &mut PositionPlanner,
        input: &Inputs<'_, B>,
        halt_deceleration: u32,
    ) -> MotionState {
        let (limits, end_velocity) = (input.limits, input.end_velocity);
        self.heading_taken = 0;
        if input.new_setpoint {
            let setpoint = self.setpoint(planner.state().position, input);
            let immediate = input.controlword.contains(Controlword::CHANGE_SET_IMMEDIATELY);
            let accepted = if immediate || self.active.is_none() {
                // Planned before it replaces the set-points (a plan refused keeps them).
                let planned = self.halted || self.plan(planner, setpoint, None, &limits, end_velocity);
                if planned {
                    self.queue = [None; SLOTS];
                    self.active = Some(setpoint);
                }
                planned
            } else if self.push(setpoint) {
                // Change on set-point: the executed positioning now passes its target.
                let _ = self.plan_active(planner, &limits, end_velocity);
                true
            } else {
                false
            };
            if accepted {
                self.heading_taken = setpoint.heading;
                self.acknowledged = true;
                self.preceding = setpoint.user;
                if self.last.is_some_and(|last| last.internal != setpoint.internal) || self.last.is_none() {
                    self.in_window_since = None;
                }
            }
        }
        if !input.controlword.contains(Controlword::NEW_SET_POINT) {
            self.acknowledged = false;
        }
        // A velocity limit (607Fh, 6080h) lowered below the running plan's velocity holds at
        // once: the set-point is re-planned from the present state (a lower 6081h alone waits
        // for the next set-point, as CiA 402 has it).
        let cap = input.velocity_cap;
        if !self.halted && self.active.is_some() && cap < self.planned_velocity {
            // Once per lowering, even when no plan fits (the old one then runs on).
            let _ = self.plan_active(planner, &limits, end_velocity);
            self.planned_velocity = self.planned_velocity.min(limits.velocity);
        }

        let halt = input.controlword.contains(Controlword::HALT);
        if halt && !self.halted {
            self.halted = true;
            let _ = planner.request_stop(halt_deceleration.max(1), &limits);
        } else if !halt && self.halted {
            self.halted = false;
            let _ = self.plan_active(planner, &limits, end_velocity);
        }

        let state = planner.follow();
        if !self.halted && planner.is_finished() {
            if let Some(done) = self.active.take() {
                self.last = Some(done);
                self.active = self.pop();
                let _ = self.plan_active(planner, &limits, end_velocity);
            }
        }
        state
    }

    /// The statusword bits of pp (bit 10 evaluated with the position window), `planner` its
    /// trajectory.
    pub fn status<const B: usize>(&mut self, planner: &PositionPlanner, input: &Inputs<'_, B>) -> Status {
        let od = input.od;
        let halt = input.controlword.contains(Controlword::HALT);
        let idle = self.active.is_none() && self.queued() == 0;
        let target_reached = if halt {
            // Decelerated to zero velocity: the demand and the shaft.
            planner.state().velocity == 0 && input.standstill
        } else if !idle {
            self.in_window_since = None;
            false
        } else {
            let target = self.last.map_or(self.preceding, |last| last.user);
            // (Positions scaled by an extreme factor group come near the ends of the 64-bit
            // range: their distance saturates.)
            let actual = input.factors.to_user(input.actual.saturating_sub(input.origin))
                * input.factors.position_sign();
            let window = od.load(input.slots.position_window);
            if window == u32::MAX || target.abs_diff(actual) <= u64::from(window) {
                let since = *self.in_window_since.get_or_insert(input.now);
                let time = Duration::from_millis(u64::from(od.load(input.slots.position_window_time)));
                window == u32::MAX || input.now - since >= time
            } else {
                self.in_window_since = None;
                false
            }
        };
        let executed = self.active.or(self.last);
        Status {
            target_reached,
            internal_limit: executed.is_some_and(|s| s.limited),
            setpoint_acknowledge: self.acknowledged || self.queued() >= self.depth,
        }
    }
}
/// pp's objects (6081h, 6082h, 6086h, 60A3h, 60A4h, 60F2h) with their CiA 402 defaults, in
/// [`super::registry::PROFILE`] when the build runs pp (cargo feature `pp`).
pub(crate) const OBJECTS: [Object; 6] = [
    setting(PROFILE_VELOCITY, "Profile velocity", DataType::Unsigned32, DefaultValue::Unsigned(10_000)),
    setting(END_VELOCITY, "End velocity", DataType::Unsigned32, DefaultValue::Zero),
    parameter(MOTION_PROFILE_TYPE, "Motion profile type", DataType::Integer16, DefaultValue::Zero),
    parameter(PROFILE_JERK_USE, "Profile jerk use", DataType::Unsigned8, DefaultValue::Unsigned(1)),
    Object::array(
        PROFILE_JERK,
        "Profile jerk",
        4,
        &Var::new("Profile jerk", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(1_000_000)),
    ),
    parameter(POSITIONING_OPTION_CODE, "Positioning option code", DataType::Unsigned16, DefaultValue::Zero),
];

/// The value rule of pp's object `index` ([`super::registry::rule`]).
pub(crate) fn rule(index: u16) -> Option<Rule> {
    match index {
        MOTION_PROFILE_TYPE if super::PP => Some(Rule::MotionProfileType),
        PROFILE_JERK_USE if super::PP => Some(Rule::JerkUse),
        POSITIONING_OPTION_CODE if super::PP => Some(Rule::PositioningOption),
        _ => None,
    }
}

/// Whether `raw` is a value pp takes under `rule`: the motion profile types of
/// [`ProfileType`] (trapezoidal, jerk-limited), jerk use 1, 2 or 4, the relative options
/// 00/01/10 of 60F2h (change-immediately and request-response options are not implemented).
pub(crate) fn check(rule: Rule, raw: u32) -> bool {
    match rule {
        Rule::MotionProfileType => ProfileType::from_raw(raw as u16 as i16).is_some(),
        Rule::JerkUse => matches!(raw, 1 | 2 | 4),
        Rule::PositioningOption => raw & !0x0003 == 0 && raw & 0x0003 != 0x0003,
        _ => true,
    }
}

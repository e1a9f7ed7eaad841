//! The integer profile: velocity changes ("legs") of whole ticks fitted exactly in fixed point,
//! the tick counts that keep a leg within its limits, and the check of every executed tick of
//! a segment against the limits.
//!
//! A leg changes the velocity from the present state to an aimed velocity and ends with zero
//! acceleration: jerk, hold, jerk (S-curve) or one constant acceleration (trapezoid). With the
//! tick counts fixed, the rise of the acceleration is solved for the aim and rounded to a
//! multiple of 6 units; each jerk phase then runs at two jerks one unit of 6 apart
//! ([`Segment::ramp`]), which changes the acceleration by exactly that amount, so every leg
//! ends at exactly zero acceleration. The rounding, and which of the two jerks comes first, keep
//! the end speed at most the aimed speed: a leg aimed at or below the velocity limit does not
//! end above it. A stop ends at standstill exactly: the little velocity the rounding leaves on
//! the side it came from (a few hundred million units of 2⁻⁶⁴ at most in the tests) is set to
//! zero.
//!
//! [`Builder`] appends legs and checks each segment exactly: the velocity at every tick (the
//! ends, and the ticks next to the vertex where the acceleration changes sign), the
//! acceleration at the ends and the split (it is monotone in between), and the jerk.

use super::fixed::{ceil_ticks, div_ceil, div_floor, mul_small, per_tick, sqrt, to_si};
use super::shape::scurve_pieces;
use super::trajectory::{Exact, Segment, MAX_SEGMENTS};
use super::{Limits, ProfileType};

/// How far the rounding of a segment's jerk may go beyond its limit, in fixed-point units
/// (2⁻⁶⁴ increments/tick³).
pub(crate) const JERK_ROUNDING: i128 = 6;

/// A limit less a small margin (2⁻²⁰ of it and 4096 units, never below half of it). Tick
/// counts are chosen for the margined limits, so the rounding of the final fit (which lies
/// between two checked fits) stays within the exact ones.
#[inline(never)]
pub(crate) fn margin(limit: i128) -> i128 {
    (limit - (limit >> 20) - 4096).max(limit / 2)
}

/// Whether a leg raises the speed (acceleration, jerks A and B) or lowers it (deceleration,
/// jerks C and D).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mode {
    SpeedUp,
    SlowDown,
}

impl Mode {
    /// The mode of a change from velocity `from` to `to` (on one side of zero).
    pub(crate) fn of(from: i128, to: i128) -> Mode {
        if to.unsigned_abs() > from.unsigned_abs() {
            Mode::SpeedUp
        } else {
            Mode::SlowDown
        }
    }
}

/// The limits in fixed-point per-tick units. Each is rounded down, so a value within it is
/// within the configured limit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TickLimits {
    pub(crate) hz: u32,
    pub(crate) velocity: i128,
    pub(crate) acceleration: i128,
    pub(crate) deceleration: i128,
    /// Jerks A, B, C, D.
    pub(crate) jerk: [i128; 4],
    pub(crate) jerk_limited: bool,
}

impl TickLimits {
    pub(crate) fn new(limits: &Limits, hz: u32) -> Self {
        let j = limits.jerk;
        TickLimits {
            hz,
            velocity: per_tick(limits.velocity, hz, 1),
            acceleration: per_tick(limits.acceleration, hz, 2),
            deceleration: per_tick(limits.deceleration, hz, 2),
            jerk: [j.accel_start, j.accel_end, j.decel_start, j.decel_end].map(|x| per_tick(x, hz, 3)),
            jerk_limited: matches!(limits.profile, ProfileType::JerkLimited),
        }
    }

    /// Peak acceleration, jerk towards it and jerk back to zero of a leg in `mode`.
    pub(crate) fn of(&self, mode: Mode) -> (i128, i128, i128) {
        let [a, b, c, d] = self.jerk;
        match mode {
            Mode::SpeedUp => (self.acceleration, a, b),
            Mode::SlowDown => (self.deceleration, c, d),
        }
    }

    /// The jerk that ramps an acceleration `a` at velocity `v` to zero: B at the end of a
    /// speed-up (or from standstill), D at the end of a slow-down.
    pub(crate) fn ramp_jerk(&self, a: i128, v: i128) -> i128 {
        let [_, b, _, d] = self.jerk;
        if a.signum() * v.signum() < 0 {
            d
        } else {
            b
        }
    }
}

/// Room for a state that already breaks the limits when a plan starts (the limits were lowered
/// while moving). The legs up to the end of the first velocity change may reach `speed`; the
/// first segment may start from `acceleration`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Allowance {
    pub(crate) speed: i128,
    pub(crate) acceleration: i128,
}

impl Allowance {
    /// The physical minimum: the present speed, and (jerk-limited) the speed reached when the
    /// present acceleration is ramped to zero at its jerk limit in whole ticks (the
    /// [`ramp_ticks`]), if either is more than the velocity limit; the present acceleration.
    pub(crate) fn of(start: &Exact, limits: &TickLimits) -> Self {
        let speed = start.v.checked_abs().unwrap_or(i128::MAX);
        let mut allowed = limits.velocity.max(speed);
        let mut acceleration = 0;
        if limits.jerk_limited && start.a != 0 {
            acceleration = start.a.checked_abs().unwrap_or(i128::MAX);
            let ticks = i128::from(ramp_ticks(start, limits).unwrap_or(u32::MAX));
            // The ramp's velocity change is a·n/2 (its two jerks are placed to change less).
            let reached = start.v.saturating_add(crate::wide::saturating_mul(start.a / 2, ticks));
            let reached = reached.checked_abs().unwrap_or(i128::MAX);
            if reached > limits.velocity {
                allowed = allowed.max(reached.saturating_add(64));
            }
        }
        Allowance { speed: allowed, acceleration }
    }
}

/// Ticks that ramp the acceleration of `state` to zero at its [`TickLimits::ramp_jerk`].
pub(crate) fn ramp_ticks(state: &Exact, limits: &TickLimits) -> Option<u32> {
    let jerk = limits.ramp_jerk(state.a, state.v).max(1);
    u32::try_from(div_ceil(state.a.checked_abs()?, jerk)).ok()
}

/// Appends legs from a start state and checks every segment against the limits.
pub(crate) struct Builder<'s> {
    limits: &'s TickLimits,
    allowance: Allowance,
    /// Exact limits (the final fit) or the margined ones (the fits a window is judged by).
    strict: bool,
    store: Option<&'s mut [Segment; MAX_SEGMENTS]>,
    /// Segments appended.
    pub(crate) len: usize,
    /// State after the last segment.
    pub(crate) end: Exact,
    /// False once a segment broke a limit.
    pub(crate) conforms: bool,
    /// The velocity at the cruise.
    pub(crate) cruise_velocity: i128,
    /// True until the first velocity change is complete (the allowance covers it).
    opening: bool,
}

impl<'s> Builder<'s> {
    /// A builder at `start`; writes the segments to `store` if given.
    pub(crate) fn new(
        start: Exact,
        limits: &'s TickLimits,
        allowance: Allowance,
        strict: bool,
        store: Option<&'s mut [Segment; MAX_SEGMENTS]>,
    ) -> Self {
        // Accelerations are multiples of 6 (so a/2 is exact and a ramp can end exactly at
        // zero; only a trapezoid's leaves another); a trapezoid starts each ramp afresh.
        let a = if limits.jerk_limited { start.a - crate::wide::srem(start.a, 6) } else { 0 };
        Builder {
            limits,
            allowance,
            strict,
            store,
            len: 0,
            end: Exact { a, ..start },
            conforms: true,
            cruise_velocity: start.v,
            opening: true,
        }
    }

    /// Appends `segment` (which starts at the present end), whose jerk limit is `jerk_bound`.
    fn push(&mut self, segment: Option<Segment>, jerk_bound: i128) -> Option<()> {
        self.push_checked(segment, jerk_bound, self.strict)
    }

    /// [`Self::push`], checked against the exact limits if `strict`.
    fn push_checked(&mut self, segment: Option<Segment>, jerk_bound: i128, strict: bool) -> Option<()> {
        let Some(segment) = segment.filter(|s| s.ticks > 0) else {
            return Some(());
        };
        let (middle, end) = segment.states()?;
        if !self.conforming(&segment, &middle, &end, jerk_bound, strict) {
            self.conforms = false;
        }
        if let Some(store) = self.store.as_deref_mut() {
            *store.get_mut(self.len)? = segment;
        }
        if self.len >= MAX_SEGMENTS {
            return None;
        }
        self.len += 1;
        self.end = end;
        Some(())
    }

    /// Checks one segment: jerk, velocity at every tick, acceleration at its ends and split.
    fn conforming(
        &self,
        segment: &Segment,
        middle: &Exact,
        end: &Exact,
        jerk_bound: i128,
        strict: bool,
    ) -> bool {
        let limits = self.limits;
        let room = |limit: i128| if strict { limit } else { margin(limit) };
        let jerk = segment.jerk6.unsigned_abs().max(segment.late_jerk6().unsigned_abs());
        let Some(jerk) = i128::try_from(jerk).ok().and_then(|j| j.checked_mul(6)) else {
            return false;
        };
        if jerk > room(jerk_bound).saturating_add(JERK_ROUNDING) {
            return false;
        }
        let split = segment.split.min(segment.ticks);
        let (Some(first), Some(second)) = (
            velocity_range(&segment.start, middle, split, segment.jerk6),
            velocity_range(middle, end, segment.ticks - split, segment.late_jerk6()),
        ) else {
            return false;
        };
        let (low, high) = (first.0.min(second.0), first.1.max(second.1));
        // The allowance is the state's own speed (or what it cannot avoid): no margin on it.
        let allowed = if self.opening { self.allowance.speed } else { 0 };
        let speed = room(limits.velocity).max(allowed);
        if low < -speed || high > speed {
            return false;
        }
        // The acceleration is monotone in the segment (its two jerks are one unit apart), so
        // its extremes on each side of zero are at the ends. It is judged against the
        // acceleration limit while it raises the speed (or from standstill) and against the
        // deceleration limit while it lowers it; a segment whose velocity changes sign is held
        // to the smaller.
        let crosses = low < 0 && high > 0;
        let side = if high > 0 {
            1
        } else if low < 0 {
            -1
        } else {
            0
        };
        let limit_of = |a: i128| {
            if crosses {
                limits.acceleration.min(limits.deceleration)
            } else if a.signum() * side < 0 {
                limits.deceleration
            } else {
                limits.acceleration
            }
        };
        let start_allowed = if self.len == 0 { self.allowance.acceleration } else { 0 };
        let within =
            |a: i128, allowed: i128| a.checked_abs().is_some_and(|m| m <= room(limit_of(a)).max(allowed));
        within(segment.start.a, start_allowed) && within(end.a, 0)
    }

    /// Ramps the present acceleration to zero over `ticks` (the first leg of a plan whose
    /// acceleration could not be carried into its first velocity change).
    pub(crate) fn ramp(&mut self, ticks: u32) -> Option<()> {
        let Exact { v, a, .. } = self.end;
        // Of the two jerks, the larger comes where it gains the least speed. The ramp does not
        // depend on the peak velocity, so it is held to the exact limits.
        let segment = Segment::ramp(self.end, ticks, crate::wide::sdiv(-a, 6), a > 0);
        self.push_checked(segment, self.limits.ramp_jerk(a, v), true)?;
        self.end.a = 0;
        Some(())
    }

    /// Changes the velocity to `aim` (or just short of it) with zero acceleration at the end.
    ///
    /// The rounding keeps the end speed at most the aimed speed (a leg aimed at or below the
    /// velocity limit ends there or below); a stop ends on the side it came from and is then
    /// set to standstill exactly.
    pub(crate) fn change(&mut self, ticks: [u32; 3], aim: i128) -> Option<()> {
        let Exact { v, a, .. } = self.end;
        // Round the velocity change down (towards lower velocities) or up.
        let down = if aim == 0 { v < 0 } else { aim > 0 };
        let (_, jerk_up, jerk_down) = self.limits.of(Mode::of(v, aim));
        if self.limits.jerk_limited {
            let [n1, n2, n3] = ticks;
            if n1 == 0 || n3 == 0 {
                // An empty change: only right if there is nothing to change.
                if a != 0 {
                    self.conforms = false;
                }
            } else {
                let (n1, n2, n3) = (i128::from(n1), i128::from(n2), i128::from(n3));
                // With a uniform jerk j over n1 ticks the change ends at
                // v + (a·(2n1 + 2n2 + n3) + j·n1·(n1 + 2n2 + n3)) / 2: the acceleration rises
                // by j·n1 = 6·p, p solved here and rounded.
                let span = n1.checked_mul(2)?.checked_add(n2.checked_mul(2)?)?.checked_add(n3)?;
                let a_span = match u32::try_from(span) {
                    Ok(span) => mul_small(a, span)?,
                    Err(_) => crate::wide::mul(a, span)?,
                };
                let num = aim.checked_sub(v)?.checked_mul(2)?.checked_sub(a_span)?;
                let den = span.checked_sub(n1)?.checked_mul(6)?;
                let rise6 = if down { div_floor(num, den) } else { div_ceil(num, den) };
                self.push(Segment::ramp(self.end, ticks[0], rise6, down), jerk_up)?;
                self.push(Some(Segment::uniform(self.end, ticks[1], 0)), 0)?;
                let fall6 = crate::wide::sdiv(self.end.a.checked_neg()?, 6);
                self.push(Segment::ramp(self.end, ticks[2], fall6, down), jerk_down)?;
            }
        } else if ticks[0] > 0 {
            // Even, so a/2 is exact.
            let den = i128::from(ticks[0]).checked_mul(2)?;
            let change = aim.checked_sub(v)?;
            let half = if down { div_floor(change, den) } else { div_ceil(change, den) };
            self.end.a = half.checked_mul(2)?;
            self.push(Some(Segment::uniform(self.end, ticks[0], 0)), 0)?;
        }
        self.end.a = 0;
        if aim == 0 {
            // A stop ends exactly at standstill (the rounding left a little velocity on the
            // side it came from), so the next leg starts on one side of zero.
            self.end.v = 0;
        }
        self.opening = false;
        Some(())
    }

    /// Holds the present velocity for `ticks`.
    pub(crate) fn cruise(&mut self, ticks: u32) -> Option<()> {
        self.end.a = 0;
        self.cruise_velocity = self.end.v;
        self.push(Some(Segment::uniform(self.end, ticks, 0)), 0)
    }
}

/// Lowest and highest velocity at the ticks of a constant-jerk piece of `ticks` from `start`
/// to `end`: its ends, and the ticks next to the vertex if the acceleration changes sign
/// inside (otherwise the velocity is monotone). `None` on overflow.
fn velocity_range(start: &Exact, end: &Exact, ticks: u32, jerk6: i128) -> Option<(i128, i128)> {
    let (mut low, mut high) = (start.v.min(end.v), start.v.max(end.v));
    if start.a.signum() * end.a.signum() < 0 {
        // v(k) = v + k·a + j·k²/2 with j = 6·jerk6, extreme near k = −a/j.
        let den = jerk6.checked_mul(6)?;
        let vertex = div_floor(start.a.checked_neg()?.checked_mul(den.signum())?, den.checked_abs()?);
        for k in [vertex, vertex.saturating_add(1)] {
            if k > 0 && k < i128::from(ticks) {
                let v = start
                    .v
                    .checked_add(crate::wide::mul(k, start.a)?)?
                    .checked_add(crate::wide::mul(jerk6.checked_mul(3)?, crate::wide::mul(k, k)?)?)?;
                low = low.min(v);
                high = high.max(v);
            }
        }
    }
    Some((low, high))
}

/// Shortest whole-tick durations of a leg that changes the velocity by `dv` from zero
/// acceleration in `mode`, within the margined limits. `None` if longer than `u32::MAX` ticks.
///
/// The durations are estimated in `f32` and then made sufficient exactly: with zero
/// acceleration at the start the fitted peak acceleration is at most `2·dv / (n1 + 2·n2 + n3)`,
/// the jerk up at most that over `n1`, the jerk down at most the peak over `n3` plus six units;
/// each only falls when a segment is lengthened, so one pass of lengthening suffices.
pub(crate) fn flat_ticks(dv: i128, mode: Mode, limits: &TickLimits) -> Option<[u32; 3]> {
    let dv = dv.checked_abs()?;
    if dv == 0 {
        return Some([0; 3]);
    }
    let (acceleration, jerk_up, jerk_down) = limits.of(mode);
    let acceleration = margin(acceleration).max(1);
    if !limits.jerk_limited {
        return Some([u32::try_from(div_ceil(dv, acceleration)).ok()?, 0, 0]);
    }
    // Each jerk phase runs at two jerks one unit of 6 apart: up to 6 units above the mean.
    let jerk_up = (margin(jerk_up) - JERK_ROUNDING).max(1);
    let jerk_down = (margin(jerk_down) - JERK_ROUNDING).max(1);
    // Estimate, in ticks: the time-optimal change with these limits.
    let unit = |x: i128| to_si(x, 1, 0);
    let (dvf, af, j1, j3) = (unit(dv), unit(acceleration), unit(jerk_up), unit(jerk_down));
    let full = af * af * (0.5 / j1 + 0.5 / j3);
    let (peak, hold) =
        if dvf >= full { (af, (dvf - full) / af) } else { (sqrt(2.0 * dvf * j1 * j3 / (j1 + j3)), 0.0) };
    let mut n1 = i128::from(ceil_ticks(peak / j1)?.max(1));
    let mut n2 = i128::from(ceil_ticks(hold)?);
    let mut n3 = i128::from(ceil_ticks(peak / j3)?.max(1));
    let two_dv = dv.checked_mul(2)?;
    let sum = |n1: i128, n2: i128, n3: i128| n1 + 2 * n2 + n3;
    let needed = div_ceil(two_dv, acceleration);
    if sum(n1, n2, n3) < needed {
        n2 += div_ceil(needed - sum(n1, n2, n3), 2);
    }
    let needed = div_ceil(two_dv, jerk_up);
    if crate::wide::mul(n1, sum(n1, n2, n3))? < needed {
        n1 = div_ceil(needed, sum(n1, n2, n3));
    }
    n3 = n3.max(div_ceil(div_ceil(two_dv, sum(n1, n2, n3)), jerk_down));
    Some([u32::try_from(n1).ok()?, u32::try_from(n2).ok()?, u32::try_from(n3).ok()?])
}

/// Candidate durations for a jerk-limited leg from `state` (with its acceleration) to each of
/// `aims`: the shape's durations for either aim rounded up, and neighbours that move the hold
/// or a tick between the segments. The caller keeps the shortest that checks out.
pub(crate) fn carried_candidates(
    state: &Exact,
    aims: [i128; 2],
    limits: &TickLimits,
) -> Option<[[u32; 3]; 10]> {
    let hz = limits.hz;
    let mut base = [0u32; 3];
    for aim in aims {
        let (acceleration, jerk_up, jerk_down) = limits.of(Mode::of(state.v, aim));
        let pieces = scurve_pieces(
            to_si(state.v, hz, 1),
            to_si(state.a, hz, 2),
            to_si(aim, hz, 1),
            to_si(margin(acceleration), hz, 2),
            to_si(margin(jerk_up), hz, 3),
            to_si(margin(jerk_down) - JERK_ROUNDING, hz, 3),
        );
        for (slot, (_, t)) in base.iter_mut().zip(pieces) {
            *slot = (*slot).max(ceil_ticks(t * hz as f32)?);
        }
    }
    let [c1, c2, c3] = [base[0].max(1), base[1], base[2].max(1)];
    let all = c1.checked_add(c2)?.checked_add(c3)?;
    Some([
        [c1, c2, c3],
        [c1 + c2, 0, c3],
        [c1, c2, c3 + 1],
        [c1 + 1, c2, c3],
        [c1, c2 + 1, c3],
        [c1 + c2 + 1, 0, c3],
        [c1 + 1, c2, c3 + 1],
        [all - 1, 0, 1],
        [all, 0, 1],
        [all - 1, 0, 2],
    ])
}

#[cfg(test)]
mod unit_tests {
    use super::*;
    use crate::motion::{Jerks, Limits, ProfileType};

    #[test]
    fn flat_ticks_conform_and_are_near_the_shortest() {
        let jerks = Jerks {
            accel_start: 3_000_000,
            accel_end: 1_000_000,
            decel_start: 5_000_000,
            decel_end: 2_000_000,
        };
        for &hz in &[1000, 16_000] {
            for profile in [ProfileType::Trapezoidal, ProfileType::JerkLimited] {
                let limits =
                    TickLimits::new(&Limits::new(100_000, 200_000, 300_000).with_jerks(profile, jerks), hz);
                for &speed in &[1u32, 999, 5_000, 40_000, 100_000] {
                    let dv = per_tick(speed, hz, 1);
                    for (mode, from, to) in
                        [(Mode::SpeedUp, 0, dv), (Mode::SlowDown, dv, 0), (Mode::SpeedUp, 0, -dv)]
                    {
                        let ticks = flat_ticks(to - from, mode, &limits).unwrap();
                        let start = Exact { p: 0, v: from, a: 0 };
                        let mut builder =
                            Builder::new(start, &limits, Allowance::of(&start, &limits), true, None);
                        builder.change(ticks, to).unwrap();
                        assert!(builder.conforms, "{hz} {profile:?} {speed} {mode:?} {ticks:?}");
                        assert!(
                            (builder.end.v - to).abs() <= (to - from).abs() / 1000 + 64 && builder.end.a == 0
                        );
                        // Within a few ticks of the continuous time-optimal change.
                        let (a, j1, j3) = match (profile, mode) {
                            (ProfileType::Trapezoidal, Mode::SpeedUp) => {
                                (200_000.0, f64::INFINITY, f64::INFINITY)
                            }
                            (ProfileType::Trapezoidal, Mode::SlowDown) => {
                                (300_000.0, f64::INFINITY, f64::INFINITY)
                            }
                            (_, Mode::SpeedUp) => (200_000.0, 3e6, 1e6),
                            (_, Mode::SlowDown) => (300_000.0, 5e6, 2e6),
                        };
                        let v = f64::from(speed);
                        let full = a * a * (0.5 / j1 + 0.5 / j3);
                        let seconds = if v >= full {
                            v / a + 0.5 * a / j1 + 0.5 * a / j3
                        } else {
                            let peak = (2.0 * v * j1 * j3 / (j1 + j3)).sqrt();
                            peak / j1 + peak / j3
                        };
                        let total: u32 = ticks.iter().sum();
                        assert!(
                            f64::from(total) <= seconds * f64::from(hz) * 1.001 + 3.0,
                            "{hz} {profile:?} {speed} {ticks:?} {seconds}"
                        );
                    }
                }
            }
        }
    }
}

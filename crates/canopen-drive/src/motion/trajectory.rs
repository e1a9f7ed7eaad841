//! The executed profile: constant-jerk segments of whole ticks in 128-bit fixed point (64
//! fractional bits, per-tick units), fitted exactly to a shape and stepped by integer additions.
//!
//! Invariants that make one tick exact: every segment's jerk is `6·jerk6` and every
//! acceleration is even, so `a/2` and `j/6` and `j/2` are integers.

use super::fixed::{ceil_ticks, div_round, per_tick};
use super::shape::{Change, VelocityEnd};
use super::{Limits, ProfileType};

/// Segments of the longest plan: two S-curve velocity changes per phase (3 segments each) and
/// the cruise.
const MAX_SEGMENTS: usize = 13;

/// Position, velocity and acceleration in fixed point, per-tick units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Exact {
    pub(crate) p: i128,
    pub(crate) v: i128,
    pub(crate) a: i128,
}

impl Exact {
    /// The state `ticks` ticks later under jerk `6·jerk6`, `None` on overflow.
    fn after(&self, ticks: u32, jerk6: i128) -> Option<Exact> {
        let n = i128::from(ticks);
        let n2 = n.checked_mul(n)?;
        let n3 = n2.checked_mul(n)?;
        let p = self
            .p
            .checked_add(n.checked_mul(self.v)?)?
            .checked_add(n2.checked_mul(self.a >> 1)?)?
            .checked_add(n3.checked_mul(jerk6)?)?;
        let v = self
            .v
            .checked_add(n.checked_mul(self.a)?)?
            .checked_add(n2.checked_mul(jerk6.checked_mul(3)?)?)?;
        let a = self.a.checked_add(n.checked_mul(jerk6.checked_mul(6)?)?)?;
        Some(Exact { p, v, a })
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Segment {
    start: Exact,
    ticks: u32,
    jerk6: i128,
}

/// Exact velocities the fit aims the velocity changes at.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Aims {
    pub(crate) peak: i128,
    pub(crate) last: i128,
}

impl Aims {
    fn velocity(&self, end: VelocityEnd) -> i128 {
        match end {
            VelocityEnd::Zero => 0,
            VelocityEnd::Peak => self.peak,
            VelocityEnd::Final => self.last,
        }
    }
}

/// The limits of one velocity change in fixed point: acceleration, jerk towards it, jerk back.
#[derive(Clone, Copy, Debug, Default)]
struct ChangeLimits {
    acceleration: i128,
    jerk_up: i128,
    jerk_down: i128,
}

/// Whole-tick durations of a shape.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct TickShape {
    changes: [([u32; 3], VelocityEnd); 4],
    limits: [ChangeLimits; 4],
    jerk_limited: bool,
    len: usize,
    before: usize,
    cruise: u32,
    total: u64,
}

impl TickShape {
    /// Rounds the shape's durations up to whole ticks at `hz`; `None` if too long.
    pub(crate) fn new(
        changes: &[Change],
        before: usize,
        cruise: f32,
        hz: u32,
        limits: &Limits,
    ) -> Option<Self> {
        let jerk_limited = matches!(limits.profile, ProfileType::JerkLimited);
        let hz_f32 = hz as f32;
        let mut shape = TickShape { before, jerk_limited, ..TickShape::default() };
        for ((slot, change_limits), change) in
            shape.changes.iter_mut().zip(shape.limits.iter_mut()).zip(changes)
        {
            let (acceleration, jerk_up, jerk_down) = if change.speed_up {
                (limits.acceleration, limits.jerk.accel_start, limits.jerk.accel_end)
            } else {
                (limits.deceleration, limits.jerk.decel_start, limits.jerk.decel_end)
            };
            *change_limits = ChangeLimits {
                acceleration: per_tick(acceleration, hz, 2),
                jerk_up: per_tick(jerk_up, hz, 3),
                jerk_down: per_tick(jerk_down, hz, 3),
            };
            let mut ticks = [0u32; 3];
            for (n, t) in ticks.iter_mut().zip(change.times) {
                *n = ceil_ticks(t * hz_f32)?;
            }
            if jerk_limited && ticks != [0, 0, 0] {
                // Both jerk corners get at least one tick, so the fit always has a free jerk.
                ticks[0] = ticks[0].max(1);
                ticks[2] = ticks[2].max(1);
            }
            shape.total += ticks.iter().map(|&n| u64::from(n)).sum::<u64>();
            *slot = (ticks, change.end);
            shape.len += 1;
        }
        shape.cruise = ceil_ticks(cruise * hz_f32)?;
        shape.total += u64::from(shape.cruise);
        if shape.total > u64::from(u32::MAX) {
            return None;
        }
        Some(shape)
    }

    /// Lengthens the velocity changes whose fitted acceleration or jerk exceeded its limit
    /// (the closing correction can ask a change that was shorter than a tick for more than the
    /// limit). Returns false if nothing needed lengthening.
    pub(crate) fn relax(&mut self, fit: &Fit) -> Option<bool> {
        let mut added: u32 = 0;
        for ((ticks, _), needed) in self.changes.iter_mut().zip(fit.needed.iter()) {
            for (n, extra) in ticks.iter_mut().zip(needed) {
                *n = n.checked_add(*extra)?;
                added = added.checked_add(*extra)?;
            }
        }
        // Half the time comes out of the cruise where there is one (a lengthened change covers
        // about half its extra time at the peak velocity), so the peak velocity need not drop
        // much (which would ask the changes for more again) nor rise above the limit.
        // (Trapezoid only: with S-curves the lift of the peak velocity was measured larger than
        // the gain.)
        let taken = if self.jerk_limited { 0 } else { (added / 2).min(self.cruise) };
        self.cruise -= taken;
        self.total = self.total.checked_add(u64::from(added - taken))?;
        let changed = added > 0;
        if self.total > u64::from(u32::MAX) {
            return None;
        }
        Some(changed)
    }

    /// Ticks of the whole shape.
    pub(crate) fn total(&self) -> u64 {
        self.total
    }
}

/// A fitted plan, ready to be stepped.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fit {
    segments: [Segment; MAX_SEGMENTS],
    len: usize,
    /// State after the last segment.
    pub(crate) end: Exact,
    /// Extra ticks each velocity change needs to stay within its limits.
    needed: [[u32; 3]; 4],
}

impl Fit {
    fn new(start: Exact) -> Self {
        Fit { segments: [Segment::default(); MAX_SEGMENTS], len: 0, end: start, needed: [[0; 3]; 4] }
    }

    /// Appends `ticks` of jerk `6·jerk6` from the current end state.
    fn push(&mut self, ticks: u32, jerk6: i128) -> Option<()> {
        if ticks == 0 {
            return Some(());
        }
        let slot = self.segments.get_mut(self.len)?;
        *slot = Segment { start: self.end, ticks, jerk6 };
        self.end = self.end.after(ticks, jerk6)?;
        self.len += 1;
        Some(())
    }

    /// Fits `shape` from `start`: solves each velocity change's jerks (S-curve) or acceleration
    /// (trapezoid) for its whole-tick durations so that it ends at its aimed velocity with zero
    /// acceleration. `None` on overflow.
    pub(crate) fn build(start: Exact, shape: &TickShape, aims: &Aims, jerk_limited: bool) -> Option<Self> {
        let mut fit = Fit::new(Exact { a: start.a & !1, ..start });
        let changes = shape.changes.iter().zip(shape.limits.iter()).take(shape.len);
        let mut needed = [[0u32; 3]; 4];
        for (index, (&(ticks, end), limits)) in changes.enumerate() {
            if index == shape.before {
                fit.cruise(shape.cruise)?;
            }
            let aim = aims.velocity(end);
            let last = index + 1 == shape.len;
            let extra = if jerk_limited {
                fit.scurve(ticks, aim, limits)?
            } else {
                fit.ramp(ticks[0], aim, limits, last)?
            };
            if let Some(slot) = needed.get_mut(index) {
                *slot = extra;
            }
        }
        fit.needed = needed;
        if shape.before >= shape.len {
            fit.cruise(shape.cruise)?;
        }
        Some(fit)
    }

    fn cruise(&mut self, ticks: u32) -> Option<()> {
        self.end.a = 0;
        self.push(ticks, 0)
    }

    /// A constant-acceleration ramp; returns the extra ticks it needs to respect the limit.
    ///
    /// A ramp that is not the last one is also clamped to the limit (it then ends short of
    /// its aim, and the closing makes up the distance); the last one must end at its aim.
    fn ramp(&mut self, ticks: u32, aim: i128, limits: &ChangeLimits, last: bool) -> Option<[u32; 3]> {
        if ticks == 0 {
            return Some([0; 3]);
        }
        let n = i128::from(ticks);
        let change = aim.checked_sub(self.end.v)?;
        let a = div_round(change, n.checked_mul(2)?).checked_mul(2)?;
        let _ = last;
        self.end.a = a;
        let extra = extra_ticks(change.unsigned_abs(), limits.acceleration, ticks);
        self.push(ticks, 0)?;
        self.end.a = 0;
        Some([extra, 0, 0])
    }

    /// A jerk-limited velocity change; returns the extra ticks (per segment) it needs to
    /// respect the limits.
    fn scurve(&mut self, [n1, n2, n3]: [u32; 3], aim: i128, limits: &ChangeLimits) -> Option<[u32; 3]> {
        if n1 == 0 || n3 == 0 {
            // An empty change (the shape needed none).
            return Some([0; 3]);
        }
        let (n1i, n2i, n3i) = (i128::from(n1), i128::from(n2), i128::from(n3));
        let Exact { v, a, .. } = self.end;
        // v_end = v + a·(n1 + n2 + n3/2) + j·n1·(n1/2 + n2 + n3/2), doubled to stay integral.
        let span = n1i.checked_mul(2)?.checked_add(n2i.checked_mul(2)?)?.checked_add(n3i)?;
        let num = aim.checked_sub(v)?.checked_mul(2)?.checked_sub(a.checked_mul(span)?)?;
        let den = n1i.checked_mul(n1i.checked_add(n2i.checked_mul(2)?)?.checked_add(n3i)?)?;
        let jerk6_up = div_round(num, den.checked_mul(6)?);
        let start_a = self.end.a;
        self.push(n1, jerk6_up)?;
        let peak = self.end.a;
        self.push(n2, 0)?;
        let jerk6_down = div_round(self.end.a.checked_neg()?, n3i.checked_mul(6)?);
        self.push(n3, jerk6_down)?;
        // What the rounding of the jerks left (a few units) is dropped here.
        self.end.a = 0;
        // Too much acceleration: a longer constant part; too much jerk: longer corners.
        let over_peak = peak
            .unsigned_abs()
            .saturating_sub(start_a.unsigned_abs().max(limits.acceleration.unsigned_abs()));
        let hold = extra_ticks(
            over_peak.saturating_mul(u128::from(n1) + u128::from(n2) + u128::from(n3)),
            limits.acceleration,
            0,
        );
        let up = extra_ticks(peak.abs_diff(start_a), limits.jerk_up, n1);
        let down = extra_ticks(peak.unsigned_abs(), limits.jerk_down, n3);
        Some([up, hold, down])
    }

    /// Distance from `start` to the end of the fit.
    pub(crate) fn displacement(&self, start: &Exact) -> i128 {
        self.end.p.saturating_sub(start.p)
    }
}

/// Ticks beyond `ticks` needed to change a value by `change` at most `rate` per tick (with a
/// margin of 10⁻⁶ so rounding noise does not lengthen anything); 0 if `ticks` suffice.
fn extra_ticks(change: u128, rate: i128, ticks: u32) -> u32 {
    let rate = rate.unsigned_abs().max(1);
    let allowed = rate.saturating_add(rate / 1_000_000).saturating_mul(u128::from(ticks));
    if change <= allowed {
        return 0;
    }
    let needed = change.div_ceil(rate);
    u32::try_from(needed.saturating_sub(u128::from(ticks))).unwrap_or(u32::MAX)
}

/// Steps a [`Fit`] one tick at a time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Trajectory {
    segments: [Segment; MAX_SEGMENTS],
    len: usize,
    next: usize,
    /// The state at the present tick.
    pub(crate) now: Exact,
    jerk: i128,
    jerk_half: i128,
    jerk_sixth: i128,
    left: u32,
    remaining: u64,
    end: Exact,
}

impl Trajectory {
    /// At rest at `p`.
    pub(crate) const fn at_rest(p: i128) -> Self {
        let now = Exact { p, v: 0, a: 0 };
        Trajectory {
            segments: [Segment { start: now, ticks: 0, jerk6: 0 }; MAX_SEGMENTS],
            len: 0,
            next: 0,
            now,
            jerk: 0,
            jerk_half: 0,
            jerk_sixth: 0,
            left: 0,
            remaining: 0,
            end: now,
        }
    }

    /// Starts executing `fit`, which ends in `end` (the fit's end, possibly with the position
    /// or velocity set exactly).
    pub(crate) fn start(&mut self, fit: &Fit, end: Exact) {
        self.segments = fit.segments;
        self.len = fit.len;
        self.next = 0;
        self.end = end;
        self.remaining = fit.segments.iter().take(fit.len).map(|s| u64::from(s.ticks)).sum();
        self.enter_next();
    }

    fn enter_next(&mut self) {
        match self.segments.get(self.next).filter(|_| self.next < self.len) {
            Some(segment) => {
                self.now = segment.start;
                self.jerk_sixth = segment.jerk6;
                self.jerk_half = segment.jerk6.wrapping_mul(3);
                self.jerk = segment.jerk6.wrapping_mul(6);
                self.left = segment.ticks;
                self.next += 1;
            }
            None => {
                self.now = self.end;
                self.left = 0;
                self.jerk = 0;
                self.jerk_half = 0;
                self.jerk_sixth = 0;
            }
        }
    }

    /// Advances one tick. After the plan the state moves on at its end velocity (zero for a
    /// stop or a move with end velocity 0).
    pub(crate) fn step(&mut self) {
        if self.left == 0 {
            self.now.p = self.now.p.saturating_add(self.now.v);
            return;
        }
        // Exact: a is even, the jerk is a multiple of 6; the fit bounded every value.
        let Exact { p, v, a } = self.now;
        self.now.p = p.wrapping_add(v).wrapping_add(a >> 1).wrapping_add(self.jerk_sixth);
        self.now.v = v.wrapping_add(a).wrapping_add(self.jerk_half);
        self.now.a = a.wrapping_add(self.jerk);
        self.left -= 1;
        self.remaining = self.remaining.saturating_sub(1);
        if self.left == 0 {
            self.enter_next();
        }
    }

    /// True when every segment has been stepped.
    pub(crate) fn is_finished(&self) -> bool {
        self.left == 0
    }

    /// Ticks until the plan is finished.
    pub(crate) fn remaining(&self) -> u64 {
        self.remaining
    }
}

//! From a shape to checked fixed-point segments: the tick counts of every leg, the cruise, and
//! the peak velocity that lands the move exactly on its target within the limits.
//!
//! # The peak velocity's window
//!
//! With the tick counts fixed, a plan is affine in its peak velocity `u` (in the direction of
//! the peak): the distance grows with `u`, and every tick's velocity, acceleration and jerk is
//! affine in `u`, so the peaks a plan respects its limits at form an interval. The legs next to
//! the peak are therefore sized for a *window* `[lo, hi]` of peaks (each leg for the larger
//! velocity change at either end), both ends are fitted and checked, and any peak in between
//! conforms as well. The cruise count is then the least that lets the distance be reached at a
//! peak `≤ hi`; the window must be wide enough that it is still `≥ lo`. If it is not, or the
//! target needs a peak below the window, `lo` is lowered (which may lengthen a leg that slows
//! down to the peak) and the round is repeated. Within the window an interpolation finds the
//! peak that lands on the target, and the final fit is checked against the exact limits.
//!
//! # The fallback
//!
//! If the rounds run out (the whole-tick plan needs a different shape than the `f32` one), the
//! plan first stops (ramping the present acceleration to zero if it cannot be carried into the
//! stop), moves from standstill to the target, and, for an end velocity, starts again from
//! standstill early enough to pass the target at it. Every leg then starts from zero
//! acceleration, all legs next to the peak speed up to it or slow down from it, and the window
//! `[0, hi]` always holds the answer, so this plan conforms. (Its final check has not failed
//! in any test; if it did, the plan would still be used, and [`Method::Unchecked`] tells the
//! tests.)

use super::fixed::{div_ceil, from_si, to_si, ONE_F32};
use super::legs::{carried_candidates, flat_ticks, margin, ramp_ticks, Allowance, Builder, Mode, TickLimits};
use super::shape::{position_shape, velocity_change, Changes, ShapeLimits, VelocityEnd};
use super::trajectory::{Exact, Segment, MAX_SEGMENTS};
use super::{Limits, MotionError, ProfileType};

/// Rounds of widening the peak velocity's window before the fallback.
const WINDOW_ROUNDS: u32 = 6;

/// Interpolation steps on the peak velocity within the window.
const CLOSING_STEPS: u32 = 4;

/// A miss small enough to stop the search (fixed-point units: 2⁻²⁸ increment); the last
/// sample is set to the target anyway.
const CLOSE_ENOUGH: i128 = 1 << 36;

/// Legs of the longest layout: a ramp of the acceleration, a stop, the change to the peak, the
/// change from it through zero, and the change to the end velocity.
const MAX_LEGS: usize = 6;

pub(crate) fn shape_limits(limits: &Limits) -> ShapeLimits {
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

/// The velocity a leg aims at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Aim {
    Zero,
    Peak,
    Final,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Leg {
    /// The present acceleration ramped to zero over these ticks.
    Ramp(u32),
    /// A velocity change with these durations.
    Change([u32; 3], Aim),
}

/// The legs of a plan and where its cruise runs.
#[derive(Clone, Copy, Debug)]
struct Layout {
    legs: [Leg; MAX_LEGS],
    len: usize,
    /// The cruise runs before `legs[cruise_at]`, or after all legs if that is `len`.
    cruise_at: usize,
    cruise: u32,
}

impl Layout {
    fn new() -> Self {
        Layout { legs: [Leg::Ramp(0); MAX_LEGS], len: 0, cruise_at: 0, cruise: 0 }
    }

    fn push(&mut self, aim: Aim) -> Option<()> {
        *self.legs.get_mut(self.len)? = Leg::Change([0; 3], aim);
        self.len += 1;
        Some(())
    }

    fn insert(&mut self, at: usize, leg: Leg) -> Option<()> {
        if self.len >= MAX_LEGS || at > self.len {
            return None;
        }
        let mut index = self.len;
        while index > at {
            let previous = *self.legs.get(index - 1)?;
            *self.legs.get_mut(index)? = previous;
            index -= 1;
        }
        *self.legs.get_mut(at)? = leg;
        self.len += 1;
        if self.cruise_at > at || (self.cruise_at == at && at > 0) {
            self.cruise_at += 1;
        }
        Some(())
    }

    fn from_ends(ends: &[super::shape::Change], before: usize) -> Option<Self> {
        let mut layout = Layout::new();
        for change in ends {
            layout.push(match change.end {
                VelocityEnd::Zero => Aim::Zero,
                VelocityEnd::Peak => Aim::Peak,
                VelocityEnd::Final => Aim::Final,
            })?;
        }
        layout.cruise_at = before.min(layout.len);
        Some(layout)
    }
}

/// The outcome of fitting a layout.
#[derive(Clone, Copy, Debug)]
struct Run {
    end: Exact,
    cruise_velocity: i128,
    conforms: bool,
    len: usize,
}

/// How a plan was made (for the tests).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum Method {
    /// The shape's layout, conforming.
    #[default]
    Shape,
    /// The stop-first fallback, conforming.
    Fallback,
    /// Nothing conformed (not expected; the fallback is used).
    Unchecked,
}

/// A fitted plan written to the caller's segments.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Planned {
    pub(crate) len: usize,
    pub(crate) end: Exact,
    pub(crate) ticks: u64,
    pub(crate) method: Method,
}

struct Problem<'a> {
    start: Exact,
    limits: &'a TickLimits,
    allowance: Allowance,
    /// End velocity (fixed point, signed).
    last: i128,
    /// Direction of the peak velocity: 1 or -1.
    sign: i128,
}

impl Problem<'_> {
    /// `x` along the peak's direction (`x·sign`, the sign being ±1).
    fn signed(&self, x: i128) -> i128 {
        if self.sign < 0 {
            x.wrapping_neg()
        } else {
            x
        }
    }

    /// [`Self::signed`], `None` on overflow.
    fn checked_signed(&self, x: i128) -> Option<i128> {
        if self.sign < 0 {
            x.checked_neg()
        } else {
            Some(x)
        }
    }

    /// [`Self::signed`], saturating.
    fn saturating_signed(&self, x: i128) -> i128 {
        if self.sign < 0 {
            x.saturating_neg()
        } else {
            x
        }
    }

    fn aim(&self, aim: Aim, peak: i128) -> i128 {
        match aim {
            Aim::Zero => 0,
            Aim::Peak => peak,
            Aim::Final => self.last,
        }
    }

    /// Fits `layout` with the signed peak velocity `peak`.
    fn run(
        &self,
        layout: &Layout,
        peak: i128,
        strict: bool,
        store: Option<&mut [Segment; MAX_SEGMENTS]>,
    ) -> Option<Run> {
        let mut builder = Builder::new(self.start, self.limits, self.allowance, strict, store);
        for (index, leg) in layout.legs.iter().take(layout.len).enumerate() {
            if index == layout.cruise_at {
                builder.cruise(layout.cruise)?;
            }
            match *leg {
                Leg::Ramp(ticks) => builder.ramp(ticks)?,
                Leg::Change(ticks, aim) => builder.change(ticks, self.aim(aim, peak))?,
            }
        }
        if layout.cruise_at >= layout.len {
            builder.cruise(layout.cruise)?;
        }
        Some(Run {
            end: builder.end,
            cruise_velocity: builder.cruise_velocity,
            conforms: builder.conforms,
            len: builder.len,
        })
    }

    /// The signed displacement of a run along the peak's direction.
    fn along(&self, run: &Run) -> Option<i128> {
        self.checked_signed(run.end.p.checked_sub(self.start.p)?)
    }

    /// Sizes every leg of `layout` for the signed peaks `peaks` (the window's ends). The first
    /// leg carries the present acceleration (jerk-limited) if one of its candidate durations
    /// conforms at both ends; otherwise a ramp of the acceleration is put before it.
    fn size(&self, layout: &mut Layout, peaks: [i128; 2]) -> Option<()> {
        let limits = self.limits;
        let mut velocity = [self.start.v; 2];
        let mut acceleration =
            if limits.jerk_limited { self.start.a - crate::wide::srem(self.start.a, 6) } else { 0 };
        let mut index = 0;
        while index < layout.len {
            match *layout.legs.get(index)? {
                Leg::Ramp(ticks) => {
                    let mut builder = Builder::new(self.start, limits, self.allowance, false, None);
                    builder.ramp(ticks)?;
                    velocity = [builder.end.v; 2];
                    acceleration = 0;
                }
                Leg::Change(_, aim) => {
                    let aims = [self.aim(aim, peaks[0]), self.aim(aim, peaks[1])];
                    let ticks = if acceleration != 0 {
                        match self.carried(aims) {
                            Some(ticks) => ticks,
                            None => {
                                self.split_off_ramp(layout, index, aims)?;
                                continue;
                            }
                        }
                    } else {
                        let mut ticks = [0u32; 3];
                        for (&from, to) in velocity.iter().zip(aims) {
                            let needed = flat_ticks(to.checked_sub(from)?, Mode::of(from, to), limits)?;
                            for (slot, n) in ticks.iter_mut().zip(needed) {
                                *slot = (*slot).max(n);
                            }
                        }
                        ticks
                    };
                    *layout.legs.get_mut(index)? = Leg::Change(ticks, aim);
                    velocity = aims;
                    acceleration = 0;
                }
            }
            index += 1;
        }
        Some(())
    }

    /// The shortest candidate durations of a first leg that carries the present acceleration to
    /// `aims` and conforms (with the margins) at both.
    fn carried(&self, aims: [i128; 2]) -> Option<[u32; 3]> {
        // Shortest first; among equals, in the order given (the shape's own durations first).
        let candidates = carried_candidates(&self.start, aims, self.limits)?;
        let mut order: [(u64, usize); 10] = core::array::from_fn(|index| {
            let total =
                candidates.get(index).map_or(u64::MAX, |ticks| ticks.iter().map(|&n| u64::from(n)).sum());
            (total, index)
        });
        order.sort_unstable();
        order.iter().filter_map(|&(_, index)| candidates.get(index).copied()).find(|&ticks| {
            aims.iter().all(|&aim| {
                let mut builder = Builder::new(self.start, self.limits, self.allowance, false, None);
                builder.change(ticks, aim).is_some() && builder.conforms
            })
        })
    }

    /// Puts a ramp of the present acceleration before the first leg (at `index`), and a stop
    /// after the ramp if the ramp leaves the velocity on the other side of zero from `aims`.
    fn split_off_ramp(&self, layout: &mut Layout, index: usize, aims: [i128; 2]) -> Option<()> {
        let ticks = ramp_ticks(&self.start, self.limits)?;
        let mut builder = Builder::new(self.start, self.limits, self.allowance, false, None);
        builder.ramp(ticks)?;
        let after = builder.end.v;
        layout.insert(index, Leg::Ramp(ticks))?;
        if aims.iter().any(|&aim| aim.signum() * after.signum() < 0) {
            layout.insert(index + 1, Leg::Change([0; 3], Aim::Zero))?;
        }
        Some(())
    }

    /// Finds the cruise and the peak velocity in the window `[low, high]` (speeds along the
    /// peak's direction) that land `to_go` from the start; sizes `layout` on the way. `None`
    /// when the rounds run out.
    fn solve(&self, layout: &mut Layout, to_go: i128, high: i128, mut low: i128) -> Option<i128> {
        let x = self.checked_signed(to_go)?;
        let mut previous_miss = i128::MAX;
        for round in 0..WINDOW_ROUNDS {
            layout.cruise = 0;
            self.size(layout, [self.signed(low), self.signed(high)])?;
            let run_low = self.run(layout, self.signed(low), false, None)?;
            let run_high = self.run(layout, self.signed(high), false, None)?;
            if !(run_low.conforms && run_high.conforms) {
                return None;
            }
            let (d_low, d_high) = (self.along(&run_low)?, self.along(&run_high)?);
            let (c_low, c_high) =
                (self.signed(run_low.cruise_velocity), self.signed(run_high.cruise_velocity));
            let cruise = if x > d_high {
                if c_high <= 0 {
                    return None;
                }
                div_ceil(x - d_high, c_high)
            } else {
                0
            };
            let miss_low = d_low.checked_add(crate::wide::mul(cruise, c_low)?)?.checked_sub(x)?;
            let miss_high = d_high.checked_add(crate::wide::mul(cruise, c_high)?)?.checked_sub(x)?;
            if miss_low > CLOSE_ENOUGH {
                // The window does not reach down to the target: lower its bottom by twice what
                // an affine model asks (and at least by the window's width), or down to zero,
                // where the legs into the peak are sized to stop: a target beyond the stopping
                // point is then always within reach.
                if low == 0 {
                    return None;
                }
                let width = high - low;
                let step = if miss_high > miss_low && width > 0 {
                    (miss_low as f32 / (miss_high - miss_low) as f32 * width as f32) as i128
                } else {
                    high
                };
                low = if miss_low < previous_miss && round + 2 < WINDOW_ROUNDS {
                    low.saturating_sub(step.saturating_mul(2).max(width).max(1)).max(0)
                } else {
                    // Lowering did not help (the legs into the peak grew faster than the
                    // peak fell), or the last round: down to zero.
                    0
                };
                previous_miss = miss_low;
                continue;
            }
            layout.cruise = u32::try_from(cruise).ok()?;
            return Some(self.close(layout, x, (low, miss_low), (high, miss_high)));
        }
        None
    }

    /// Regula falsi for the peak speed in `[low, high]` (misses `≤ 0` and `≥ 0`) that lands
    /// `x`: the distance is affine in the peak up to the rounding, so one interpolation lands
    /// within that rounding and a second one, if needed, removes what is left.
    fn close(
        &self,
        layout: &Layout,
        x: i128,
        (mut low, mut miss_low): (i128, i128),
        (mut high, mut miss_high): (i128, i128),
    ) -> i128 {
        let mut best = if miss_low.unsigned_abs() <= miss_high.unsigned_abs() {
            (low, miss_low)
        } else {
            (high, miss_high)
        };
        for _ in 0..CLOSING_STEPS {
            if best.1.unsigned_abs() <= CLOSE_ENOUGH.unsigned_abs() {
                break;
            }
            let u = interpolate(low, high, miss_low, miss_high);
            if u <= low || u >= high {
                break;
            }
            let Some(miss) = self
                .run(layout, self.signed(u), false, None)
                .and_then(|run| self.along(&run))
                .and_then(|d| d.checked_sub(x))
            else {
                break;
            };
            if miss <= 0 {
                (low, miss_low) = (u, miss);
            } else {
                (high, miss_high) = (u, miss);
            }
            if miss.unsigned_abs() < best.1.unsigned_abs() {
                best = (u, miss);
            }
        }
        best.0
    }

    /// The fallback layout: stop, move from standstill, and start again for the end velocity.
    /// Returns the layout (sized) and the signed peak.
    fn fallback(&mut self, to_go: i128, limits: &Limits) -> Option<(Layout, i128)> {
        let mut layout = Layout::new();
        if self.start.v != 0 || (self.limits.jerk_limited && crate::wide::srem(self.start.a, 6) != 0) {
            layout.push(Aim::Zero)?;
        }
        layout.push(Aim::Peak)?;
        layout.cruise_at = layout.len;
        if self.last != 0 {
            layout.push(Aim::Zero)?;
        }
        layout.push(Aim::Final)?;
        // What the stop and the start to the end velocity cover alone.
        self.size(&mut layout, [0, 0])?;
        let fixed = self.run(&layout, 0, false, None)?;
        let rest = to_go.checked_sub(fixed.end.p.checked_sub(self.start.p)?)?;
        self.sign = if rest < 0 { -1 } else { 1 };
        let shape =
            position_shape(rest.unsigned_abs() as f32 / ONE_F32, 0.0, 0.0, 0.0, &shape_limits(limits))?;
        let high = from_si(shape.peak, self.limits.hz, 1).clamp(0, margin(self.limits.velocity));
        let peak = self.solve(&mut layout, to_go, high, 0)?;
        Some((layout, self.signed(peak)))
    }
}

/// `low + (high − low)·t` with `t = −miss_low / (miss_high − miss_low)` (in [0, 1] for
/// `miss_low ≤ 0 ≤ miss_high`), to 62 bits.
fn interpolate(low: i128, high: i128, miss_low: i128, miss_high: i128) -> i128 {
    let (mut num, mut den) = (miss_low.unsigned_abs(), miss_high.abs_diff(miss_low));
    let excess = (128 - den.leading_zeros()).saturating_sub(64);
    num >>= excess;
    den >>= excess;
    if den == 0 || num > den {
        return low;
    }
    // num ≤ den < 2⁶⁴, so the shifted numerator fits; t ≤ 2⁶².
    let t = crate::wide::udiv(num << 62, den);
    let width = high.abs_diff(low);
    let mask = (1u128 << 62) - 1;
    let part = (width >> 62).saturating_mul(t).saturating_add(((width & mask) * t) >> 62);
    low.saturating_add(i128::try_from(part).unwrap_or(i128::MAX)).min(high)
}

/// Fits `layout` with `peak` into `segments` with the exact check.
fn store(
    problem: &Problem,
    layout: &Layout,
    peak: i128,
    segments: &mut [Segment; MAX_SEGMENTS],
) -> Option<Run> {
    problem.run(layout, peak, true, Some(segments))
}

fn planned(run: Run, segments: &[Segment; MAX_SEGMENTS], method: Method) -> Planned {
    let ticks = segments.iter().take(run.len).map(|s| u64::from(s.ticks)).sum();
    Planned { len: run.len, end: run.end, ticks, method }
}

/// Plans a move of `to_go` (fixed point) from `start` that passes the target at `last`.
pub(crate) fn plan_move(
    start: Exact,
    to_go: i128,
    last: i128,
    limits: &Limits,
    hz: u32,
    segments: &mut [Segment; MAX_SEGMENTS],
) -> Result<Planned, MotionError> {
    let tick_limits = TickLimits::new(limits, hz);
    let allowance = Allowance::of(&start, &tick_limits);
    let shape = position_shape(
        to_go as f32 / ONE_F32,
        to_si(start.v, hz, 1),
        to_si(start.a, hz, 2),
        to_si(last, hz, 1),
        &shape_limits(limits),
    )
    .ok_or(MotionError::ZeroVelocity)?;
    let sign = if shape.peak < 0.0 || (shape.peak == 0.0 && to_go < 0) { -1 } else { 1 };
    let mut problem = Problem { start, limits: &tick_limits, allowance, last, sign };
    if let Some(mut layout) = Layout::from_ends(shape.changes.as_slice(), shape.before) {
        let high = from_si(shape.peak.abs(), hz, 1).clamp(0, margin(tick_limits.velocity));
        let low = initial_low(&problem, &layout, high, &shape, hz);
        if let Some(peak) = problem.solve(&mut layout, to_go, high, low) {
            if let Some(run) = store(&problem, &layout, problem.signed(peak), segments) {
                if run.conforms {
                    return Ok(planned(run, segments, Method::Shape));
                }
            }
        }
    }
    let (layout, peak) = problem.fallback(to_go, limits).ok_or(MotionError::TooLong)?;
    let run = store(&problem, &layout, peak, segments).ok_or(MotionError::TooLong)?;
    let method = if run.conforms { Method::Fallback } else { Method::Unchecked };
    Ok(planned(run, segments, method))
}

/// The window's first bottom: the lowest peak speed the legs next to the peak reach without
/// more ticks than at `high` (the start speed of a speed-up into the peak, the end speed of a
/// slow-down out of it); where a leg would need more, a little below `high`.
fn initial_low(
    problem: &Problem,
    layout: &Layout,
    high: i128,
    shape: &super::shape::PositionShape,
    hz: u32,
) -> i128 {
    let peak_index = layout.cruise_at.saturating_sub(1);
    let start = &problem.start;
    // Into the peak from the start: where the present acceleration, ramped to zero, leaves the
    // velocity (it cannot end lower).
    let entry = problem.saturating_signed(if peak_index > 0 {
        0
    } else if problem.limits.jerk_limited && start.a != 0 {
        let ticks = ramp_ticks(start, problem.limits).map_or(0, i128::from);
        start.v.saturating_add(crate::wide::saturating_mul(start.a / 2, ticks))
    } else {
        start.v
    });
    let exit = match layout.legs.get(layout.cruise_at) {
        Some(Leg::Change(_, Aim::Final)) => problem.signed(problem.last),
        _ => 0,
    };
    let changes = shape.changes.as_slice();
    let seconds: f32 = changes.iter().map(|c| c.times.iter().sum::<f32>()).sum::<f32>() + shape.cruise;
    let ticks = (seconds * hz as f32).max(1.0);
    let narrow = high - ((high as f32 * 2.0 / ticks) as i128).max(high >> 16);
    let mut low = 0;
    for speed in [entry, exit] {
        low = low.max(if speed <= high { speed } else { narrow });
    }
    low.clamp(0, high)
}

/// Plans a velocity change of `start` to `velocity` (fixed point, per tick).
pub(crate) fn plan_velocity(
    start: Exact,
    velocity: i128,
    limits: &Limits,
    hz: u32,
    segments: &mut [Segment; MAX_SEGMENTS],
) -> Result<Planned, MotionError> {
    limits.check_ramps()?;
    let tick_limits = TickLimits::new(limits, hz);
    let allowance = Allowance::of(&start, &tick_limits);
    let mut changes = Changes::default();
    velocity_change(
        to_si(start.v, hz, 1),
        to_si(start.a, hz, 2),
        to_si(velocity, hz, 1),
        VelocityEnd::Final,
        &shape_limits(limits),
        &mut changes,
    );
    let problem = Problem { start, limits: &tick_limits, allowance, last: velocity, sign: 1 };
    let mut layout =
        Layout::from_ends(changes.as_slice(), changes.as_slice().len()).ok_or(MotionError::TooLong)?;
    problem.size(&mut layout, [0, 0]).ok_or(MotionError::TooLong)?;
    let run = store(&problem, &layout, 0, segments).ok_or(MotionError::TooLong)?;
    let method = if run.conforms { Method::Shape } else { Method::Unchecked };
    Ok(planned(run, segments, method))
}

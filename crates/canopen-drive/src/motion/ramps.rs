//! Plans of bounded cost, trapezoidal (6086h = 0) and jerk-limited (6086h = 3): a plan is a
//! layout in `f32` and a few rounds of exact integer operations, without a search over ticks;
//! a drive makes its plans over several ticks while the axis already moves. A jerk-limited leg
//! is a pulse of the acceleration (`pulse.rs`); what follows describes the trapezoid, and the
//! jerk-limited plan differs where said: its layout is a search on the cube root of the peak,
//! the first leg carries the decay of the present acceleration, its rounds fit pulses instead
//! of checking an acceleration, and over several ticks ([`Ramps::request_jerk`]) it is made for
//! the state of the request, its first pulse delayed until the plan is complete (the axis
//! meanwhile ramps its acceleration out and coasts, the start of that very plan).
//!
//! # Shape
//!
//! A plan is at most five *legs*, each a velocity change of whole ticks at one acceleration:
//!
//! ```text
//! [stop to 0] → to the peak vp → [cruise at vp] → from vp to ve (or to 0) → [0 to ve]
//! ```
//!
//! The first leg stops the axis when the peak lies on the other side of zero from the present
//! velocity (a reversal), the last one starts it again when the end velocity 6082h lies on the
//! other side of zero from the peak. A leg that raises the speed runs at the acceleration, one
//! that lowers it at the deceleration; a leg whose velocity changes sign at the smaller of the
//! two.
//!
//! # How a plan is made
//!
//! 1. **Layout, in `f32`.** The continuous time-optimal profile: the distance covered without a
//!    cruise is non-decreasing in the peak `vp` and, between the velocities where a leg changes
//!    kind (0, the present velocity, the end velocity), affine in `vp·|vp|`; so the peak follows
//!    from at most five evaluations and one square root. The leg durations are rounded up to
//!    whole ticks.
//! 2. **Peak, exact.** With the tick counts fixed, a leg from `u` to `w` over `n` ticks covers
//!    exactly `n·(u + w)/2` however its acceleration is spread over its ticks, so the distance
//!    is affine in `vp` and one integer division gives the peak that lands on the target. If a
//!    leg then needs more than its limit (the rounding moved the peak), that leg is lengthened to
//!    what the peak needs and the peak solved again (at most [`ROUNDS`] times); where a cruise at
//!    the velocity limit is needed, its length is the least that keeps the peak within it.
//! 3. **Fallback.** If the rounds run out, the plan stops first and moves from standstill (and
//!    for an end velocity, starts again to pass the target at it): its legs all end or start at
//!    zero, so lengthening a leg can only lower the peak, and it conforms.
//!
//! # Over several ticks ([`Ramps::request`])
//!
//! A drive asks for its plans this way, so that no tick makes a whole plan: the tick that asks
//! checks the request and does nothing more (it has the set-point's own work), the next one
//! makes the layout, each following one a round; the fallback's layout and rounds follow the
//! same way. Each tick's share of the work ([`Ramps::work`]) runs after its step, for the next
//! tick: a drive does it once the tick's demands are out, outside the frames of the mode's
//! step (the two stacks do not add up). The plan starts in the tick after the round that
//! completes it, from the state that round saw: usually the fourth tick after the request.
//! Meanwhile the axis follows a *provisional rule*,
//! a trapezoid made online one tick at a time: towards the target at the acceleration while
//! the velocity limit and the room to slow down to the end velocity allow, otherwise slowing
//! down at the deceleration (to standstill exactly when it moves away from the target). So the
//! axis answers a set-point in the tick after it (CiA 402's single set-point re-plans "at
//! once"), keeps every limit, and each round solves from the state of its own tick; after a
//! round that fails, the next tick lengthens the legs for the state of the tick after it,
//! where the next round solves (a round and that together were the dearest tick of a homing
//! run). Over the random scenarios of the tests a requested plan ends at most 16 ticks later
//! than one made at once.
//!
//! A stop or a velocity ramp ([`Ramps::velocity`]) is one leg. A jerk-limited one ([`Ramp`])
//! is made over several ticks too ([`Ramps::request_velocity`]): the present acceleration
//! ramps out from the tick that asks (its decay needs one jerk converted), the limits are
//! converted in the next tick, and one length of the pulse is tried in each tick after (the
//! shortest first, then, where the pulse may run beside the decay, lengths and later starts
//! until the pulse's rise outlasts the decay; beside only where that is shorter than after
//! the decay); the axis coasts until the pulse starts.
//!
//! # Cost
//!
//! Cortex-M4 instructions (`benches/mcu-motion`, `scripts/bench.sh`): a plan made at once
//! some 3 200 (8 700 when it takes the fallback; the exact planner: 57 500 to 127 500); the
//! tick that takes a pp set-point 4 596 (S-curve 4 563), the one that starts homing 4 687, a
//! halt 3 654 and a quick stop 3 960 (S-curve), the worst tick of a whole S-curve move 4 874,
//! of a halt 4 824 and of a homing run 4 867, where a steady pp tick costs 2 660 – 2 880; on
//! v6-M every one of these ticks is within 15 000 (the worst, 14 869, in an S-curve move). The
//! layout is a few dozen `f32` operations; a round four 128-by-32-bit products and one
//! 128-by-32-bit division in 16-bit half-digits.
//!
//! # Execution, exact
//!
//! State: twice the position (2⁻⁶⁵ increments, so `p += v + a/2` is exact for any integer
//! acceleration), the velocity and the next tick's acceleration, in 2⁻⁶⁴ per-tick units. A leg is
//! entered with one division: its velocity change `Δ = q·n + m` runs `n − m` ticks at `q` and `m`
//! ticks at `q + 1`, half of them at its start and half at its end, so the velocity ends on the
//! aim exactly and the position within `n` units of 2⁻⁶⁵ increment of `n·(u + w)/2`. The
//! acceleration of every tick is then at most the limit the leg was checked against: `|Δ| ≤ n·r`
//! with an integer `r` gives `q + 1 ≤ r` (and `|q| ≤ r` going down). The last tick's position is
//! set to the target: the correction is the division's remainder and the legs' spreading, a few
//! units of 2⁻⁶⁴ increment per tick of the plan.

use super::fixed::{abs, cbrt, ceil_ticks, div_floor, exact_ticks, mul_small, real, sqrt};
use super::pulse::{Decay, Pulse};
use super::{Limits, MotionError, ProfileType, TickRate};

/// Position, velocity and acceleration in fixed point, per-tick units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Exact {
    pub(crate) p: i128,
    pub(crate) v: i128,
    pub(crate) a: i128,
}

/// Legs of the longest plan (see the module docs).
const MAX_LEGS: usize = 5;

/// Times a leg is lengthened and the peak solved again before the fallback: a trapezoid's,
/// and a jerk-limited plan's (whose whole-tick pulses more often need a tick more than the
/// layout's continuous durations).
const ROUNDS: u32 = 3;
const JERK_ROUNDS: u32 = 5;

/// The limits of a plan in fixed-point per-tick units, each rounded down.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct RampLimits {
    velocity: i128,
    acceleration: i128,
    deceleration: i128,
    /// The jerk-limited profile's limits, `None` for a trapezoid.
    jerk: Option<JerkLimits>,
}

/// A jerk-limited profile's limits in sixths of 2⁻⁶⁴ increments per tick² and per tick³
/// (`pulse.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct JerkLimits {
    /// The jerk of a pulse that raises the speed (the smaller of A and B: a pulse's rise and
    /// fall are mirror images) and of one that lowers it (C, D), rounded down.
    speed_up: i128,
    slow_down: i128,
    /// The jerk that ramps a present acceleration out: B while the speed rises, D while it
    /// falls (rounded up: within the one sixth a jerk may exceed its limit).
    end_up: i128,
    end_down: i128,
    /// The acceleration and deceleration, rounded down.
    acceleration: i128,
    deceleration: i128,
}

impl RampLimits {
    /// `limits` at the tick `rate` (each at most the exact conversion and less than 2⁻³²
    /// per-tick units below it; no division).
    #[inline(always)]
    pub(crate) fn new(limits: &Limits, rate: TickRate) -> Self {
        let acceleration = rate.scale(limits.acceleration, 2).max(1);
        let deceleration = rate.scale(limits.deceleration, 2).max(1);
        let jerk = match limits.profile {
            ProfileType::Trapezoidal => None,
            ProfileType::JerkLimited => Some(JerkLimits::new(limits, rate)),
        };
        RampLimits { velocity: rate.scale(limits.velocity, 1), acceleration, deceleration, jerk }
    }

    /// The rate of a leg from `u` to `w`: the acceleration if the speed rises (or from
    /// standstill), the deceleration if it falls, the smaller if the velocity changes sign.
    fn rate(&self, u: i128, w: i128) -> i128 {
        Change::of(u, w).pick(self.acceleration, self.deceleration)
    }
}

/// What a velocity change does to the speed, which chooses its limits: those of a rising
/// speed (or from standstill), of a falling one, or the smaller of both across zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Change {
    Crosses,
    Rises,
    Falls,
}

impl Change {
    /// The change from `u` to `w`.
    fn of(u: i128, w: i128) -> Self {
        if u.signum() * w.signum() < 0 {
            Change::Crosses
        } else if w.unsigned_abs() >= u.unsigned_abs() {
            Change::Rises
        } else {
            Change::Falls
        }
    }

    /// [`Self::of`] for `f32` velocities (the layouts).
    fn of_real(u: f32, w: f32) -> Self {
        if u * w < 0.0 {
            Change::Crosses
        } else if abs(w) >= abs(u) {
            Change::Rises
        } else {
            Change::Falls
        }
    }

    /// The limit of this change from the one for a rising and a falling speed.
    fn pick<T: PartialOrd>(self, rising: T, falling: T) -> T {
        match self {
            Change::Crosses if falling < rising => falling,
            Change::Crosses | Change::Rises => rising,
            Change::Falls => falling,
        }
    }
}

impl RampLimits {
    /// The rounds before the fallback.
    fn rounds(&self) -> u32 {
        if self.jerk.is_some() {
            JERK_ROUNDS
        } else {
            ROUNDS
        }
    }
}

impl JerkLimits {
    /// `limits` at the tick `rate` in sixths (out of line: a trapezoid's plan does not need it).
    #[inline(never)]
    fn new(limits: &Limits, rate: TickRate) -> Self {
        let j = limits.jerk;
        // Out of line, each one copy (inlined six times they were a kilobyte of flash).
        #[inline(never)]
        fn down(rate: TickRate, k: usize, a: u32, b: u32) -> i128 {
            rate.sixths(a.min(b), k).max(1)
        }
        // Rounded up: ⌈scale/6⌉.
        #[inline(never)]
        fn up(rate: TickRate, jerk: u32) -> i128 {
            rate.sixths_up3(jerk).max(1)
        }
        let sixths = |k: usize, a: u32, b: u32| down(rate, k, a, b);
        let up = |jerk: u32| up(rate, jerk);
        JerkLimits {
            speed_up: sixths(3, j.accel_start, j.accel_end),
            slow_down: sixths(3, j.decel_start, j.decel_end),
            end_up: up(j.accel_end),
            end_down: up(j.decel_end),
            acceleration: sixths(2, limits.acceleration, limits.acceleration),
            deceleration: sixths(2, limits.deceleration, limits.deceleration),
        }
    }

    /// The jerk and the acceleration (sixths) of a pulse from `u` to `w`, chosen as
    /// [`RampLimits::rate`] chooses.
    fn pulse(&self, u: i128, w: i128) -> (i128, i128) {
        let change = Change::of(u, w);
        (change.pick(self.speed_up, self.slow_down), change.pick(self.acceleration, self.deceleration))
    }

    /// The decay of the acceleration `a0` at velocity `v`: ramped out at B while it raises the
    /// speed, at D while it lowers it.
    /// The decay of the acceleration `alpha0` (sixths) at velocity `v`: ramped out at B while
    /// it raises the speed, at D while it lowers it.
    fn decay(&self, v: i128, alpha0: i128) -> Option<Decay> {
        let jerk = if lowers_speed(v, alpha0) { self.end_down } else { self.end_up };
        Decay::new(alpha0, jerk)
    }

    /// [`Self::decay`] from the limits as asked for (only its jerk converted).
    fn decay_of(limits: &Limits, rate: TickRate, v: i128, alpha0: i128) -> Option<Decay> {
        let j = &limits.jerk;
        let jerk = if lowers_speed(v, alpha0) { j.decel_end } else { j.accel_end };
        Decay::new(alpha0, rate.sixths_up3(jerk).max(1))
    }
}

/// The acceleration `alpha0` lowers the speed of velocity `v`.
fn lowers_speed(v: i128, alpha0: i128) -> bool {
    alpha0.signum() * v.signum() < 0
}

/// A plan's legs: leg `i` runs `ticks[i]` ticks and ends at `aims[i]`, a trapezoid's at one
/// acceleration (spread in whole units), a jerk-limited one's as `pulses[i]`, the first one
/// with the `decay` of the acceleration the plan started with, its pulse from tick `offset`
/// (beside the decay when that is before the decay's end, else after it)
/// its pulse).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Legs {
    ticks: [u32; MAX_LEGS],
    aims: [i128; MAX_LEGS],
    pulses: [Pulse; MAX_LEGS],
    decay: Decay,
    offset: u32,
    len: usize,
    /// Jerk-limited: twice the distance the legs cover, as planned (for the tests).
    #[cfg(test)]
    covered2: i128,
}

impl Legs {
    /// A trapezoid's leg (its pulse is left as it is: a trapezoid never reads it, and writing
    /// one is some 80 bytes).
    fn push(&mut self, ticks: u32, aim: i128) -> Option<()> {
        if ticks > 0 {
            *self.ticks.get_mut(self.len)? = ticks;
            *self.aims.get_mut(self.len)? = aim;
            self.len += 1;
        }
        Some(())
    }

    /// A jerk-limited leg.
    fn push_pulse(&mut self, ticks: u32, aim: i128, pulse: Pulse) -> Option<()> {
        if ticks > 0 {
            *self.pulses.get_mut(self.len)? = pulse;
        }
        self.push(ticks, aim)
    }

    fn get(&self, index: usize) -> Option<(u32, i128)> {
        if index >= self.len {
            return None;
        }
        Some((*self.ticks.get(index)?, *self.aims.get(index)?))
    }

    fn total(&self) -> u64 {
        self.ticks.iter().take(self.len).map(|&n| u64::from(n)).sum()
    }
}

/// How a plan was made (for the tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Made {
    /// The time-optimal layout.
    Layout,
    /// The stop-first fallback.
    Fallback,
}

/// The continuous time-optimal peak velocity `vp` (per-tick units, signed) of a move over
/// `distance` from velocity `u0` to `ue`, and whether it cruises at the velocity limit `vmax`.
#[inline(never)]
fn layout_peak(distance: f32, u0: f32, ue: f32, vmax: f32, acc: f32, dec: f32) -> (f32, bool) {
    // Distance of one change from u to w (split at zero).
    let (up, down) = (0.5 / acc, 0.5 / dec);
    let change = |u: f32, w: f32| {
        let (su, sw) = (u * abs(u), w * abs(w));
        if u * w < 0.0 {
            su * down + sw * up
        } else if abs(w) >= abs(u) {
            (sw - su) * up
        } else {
            (su - sw) * down
        }
    };
    let covered = |vp: f32| change(u0, vp) + change(vp, ue);
    if covered(vmax) <= distance {
        return (vmax, true);
    }
    if covered(-vmax) >= distance {
        return (-vmax, true);
    }
    // Between the velocities where a change switches kind, the distance is affine in vp·|vp|:
    // the tightest bracket of the distance among them.
    let (mut low, mut high) = (-vmax, vmax);
    let (mut f_low, mut f_high) = (covered(low), covered(high));
    for point in [0.0, u0.max(-vmax).min(vmax), ue.max(-vmax).min(vmax)] {
        if point <= low || point >= high {
            continue;
        }
        let f = covered(point);
        if f < distance && point > low {
            (low, f_low) = (point, f);
        } else if f >= distance && point < high {
            (high, f_high) = (point, f);
        }
    }
    if f_high <= f_low {
        return (high, false);
    }
    // From the nearer end (the other one may be far off, and its difference would cancel).
    let (s_low, s_high) = (low * abs(low), high * abs(high));
    let slope = (s_high - s_low) / (f_high - f_low);
    let s = if distance - f_low <= f_high - distance {
        s_low + (distance - f_low) * slope
    } else {
        s_high + (distance - f_high) * slope
    };
    let vp = if s < 0.0 { -sqrt(-s) } else { sqrt(s) };
    (vp.max(low).min(high), false)
}

/// Whole ticks for a velocity change of `dv` at `rate` (both `f32` per-tick units).
fn ticks_for(dv: f32, rate: f32) -> Option<u32> {
    // A hair more than the estimate: a duration of (nearly) whole ticks, rounded up exactly,
    // would otherwise often miss by the last bit and cost a round.
    ceil_ticks(abs(dv) / rate * (1.0 + 1.0 / 1_048_576.0))
}

/// `|dv| ≤ n·rate`.
fn within(dv: i128, ticks: u32, rate: i128) -> bool {
    match (dv.checked_abs(), mul_small(rate, ticks)) {
        (Some(dv), Some(reach)) => dv <= reach,
        (Some(_), None) => true,
        (None, _) => false,
    }
}

/// `⌊num / den⌋` for a tick count `den > 0` that may exceed 32 bits.
fn div_ticks(num: i128, den: u64) -> i128 {
    match u32::try_from(den) {
        Ok(small) => div_floor(num, i128::from(small)),
        Err(_) => div_floor(num, i128::from(den)),
    }
}

/// The continuous jerk-limited shape in `f32` per-tick units (for the layout): a velocity
/// change is one mirror-image pulse at the limits [`JerkLimits::pulse`] chooses.
struct Shape {
    acceleration: f32,
    deceleration: f32,
    speed_up: f32,
    slow_down: f32,
}

impl Shape {
    fn new(limits: &RampLimits, jerk: &JerkLimits) -> Self {
        Shape {
            acceleration: real(limits.acceleration),
            deceleration: real(limits.deceleration),
            speed_up: real(jerk.speed_up) * 6.0,
            slow_down: real(jerk.slow_down) * 6.0,
        }
    }

    /// The duration of a change from `u` to `w` in one pulse.
    fn duration(&self, u: f32, w: f32) -> f32 {
        let change = Change::of_real(u, w);
        let (a, j) =
            (change.pick(self.acceleration, self.deceleration), change.pick(self.speed_up, self.slow_down));
        let dv = abs(w - u);
        // Up to the acceleration limit and down again, with a hold at it if there is time.
        if dv / a >= a / j {
            dv / a + a / j
        } else {
            2.0 * sqrt(dv / j)
        }
    }

    /// Whole ticks for a change from `u` to `w`.
    fn ticks(&self, u: f32, w: f32) -> Option<u32> {
        ceil_ticks(self.duration(u, w) * (1.0 + 1.0 / 1_048_576.0))
    }

    /// The distance of a change from `u` to `w`, split at zero as the legs are.
    fn change(&self, u: f32, w: f32) -> f32 {
        if u * w < 0.0 {
            (self.duration(u, 0.0) * u + self.duration(0.0, w) * w) * 0.5
        } else {
            self.duration(u, w) * (u + w) * 0.5
        }
    }

    /// The search for the peak velocity of a move over `distance` from `u0` to `ue`, set up:
    /// done at once if the peak is the velocity limit `vmax` (with a cruise).
    fn search(&self, distance: f32, u0: f32, ue: f32, vmax: f32) -> PeakSearch {
        PeakSearch { distance, u0, ue, vmax, set_up: true, ..PeakSearch::NEW }
    }

    /// The bracket's ends, one evaluation per step (on a Cortex-M0 an evaluation is a step's
    /// work): the distance at −vmax, then at +vmax and the cube root (found already if the
    /// peak is the velocity limit).
    fn prime(&self, search: &mut PeakSearch) {
        let vmax = search.vmax;
        if search.primed == 0 {
            search.f_low = self.covered(search, -vmax);
            search.primed = 1;
            return;
        }
        search.f_high = self.covered(search, vmax);
        search.primed = 2;
        if search.f_high <= 0.0 {
            search.found = Some((vmax, true));
        } else if search.f_low >= 0.0 {
            search.found = Some((-vmax, true));
        }
        let top = cbrt(vmax);
        (search.low, search.high) = (-top, top);
    }

    /// The distance covered at the peak `vp`, less the distance to cover.
    fn covered(&self, search: &PeakSearch, vp: f32) -> f32 {
        self.change(search.u0, vp) + self.change(vp, search.ue) - search.distance
    }

    /// At most `steps` steps of the search (none once it is done).
    ///
    /// On the cube root of the peak (as fine relative to a small peak as to a large one):
    /// bisection while the bracket is wide or straddles zero, regula falsi with the Illinois
    /// rule once it is narrow (superlinear where the distance is smooth). The distance need not
    /// be monotone in the peak (a slow deceleration to the end velocity), so the bracket's ends
    /// keep their signs and the result is the end nearer the root.
    fn advance(&self, search: &mut PeakSearch, steps: u32) {
        let cube = |t: f32| t * t * t;
        for _ in 0..steps {
            if search.found.is_some() {
                return;
            }
            if search.primed < 2 {
                self.prime(search);
                continue;
            }
            let (low, high) = (search.low, search.high);
            let width = high - low;
            if width <= abs(low).max(abs(high)) * (1.0 / 1_048_576.0) || search.steps >= PEAK_STEPS {
                let t = if -search.f_low < search.f_high { low } else { high };
                search.found = Some((cube(t).max(-search.vmax).min(search.vmax), false));
                return;
            }
            search.steps += 1;
            let narrow = (low > 0.0 || high < 0.0) && width * 8.0 <= abs(low).min(abs(high));
            let mut t = (low + high) * 0.5;
            if narrow && search.f_high > search.f_low {
                let secant = (low * search.f_high - high * search.f_low) / (search.f_high - search.f_low);
                if secant > low && secant < high {
                    t = secant;
                }
            }
            let f = self.covered(search, cube(t));
            if f < 0.0 {
                (search.low, search.f_low) = (t, f);
                if search.kept == -1 && narrow {
                    search.f_high *= 0.5;
                }
                search.kept = -1;
            } else {
                (search.high, search.f_high) = (t, f);
                if search.kept == 1 && narrow {
                    search.f_low *= 0.5;
                }
                search.kept = 1;
            }
        }
    }
}

/// The jerk-limited layout's search for the peak velocity (`f32` per-tick units), resumable:
/// a plan made over several ticks runs a few steps per tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct PeakSearch {
    /// The continuous problem: cover `distance` from `u0` to `ue` within `vmax`.
    distance: f32,
    u0: f32,
    ue: f32,
    vmax: f32,
    /// The bracket on the peak's cube root, and the distance missed at its ends.
    low: f32,
    high: f32,
    f_low: f32,
    f_high: f32,
    /// The end the last step kept (Illinois), and the steps so far.
    kept: i8,
    steps: u32,
    /// Set up ([`Shape::search`]), and how many of the bracket's ends are evaluated.
    set_up: bool,
    primed: u8,
    /// The peak and whether it cruises at the limit, once found.
    found: Option<(f32, bool)>,
    /// The fallback's stop and start (it stops first and starts again).
    stop_first: Option<(u32, u32)>,
}

impl PeakSearch {
    /// A search not yet set up.
    const NEW: PeakSearch = PeakSearch {
        distance: 0.0,
        u0: 0.0,
        ue: 0.0,
        vmax: 0.0,
        low: 0.0,
        high: 0.0,
        f_low: 0.0,
        f_high: 0.0,
        kept: 0,
        steps: 0,
        set_up: false,
        primed: 0,
        found: None,
        stop_first: None,
    };
}

/// Most steps of the jerk-limited layout's search for the peak (bisection and Illinois steps on
/// its cube root, to 2⁻²⁰ of it; usually 10 to 20).
const PEAK_STEPS: u32 = 40;

/// Steps of that search per tick in a plan made over several ticks: three where `f32` is in
/// hardware, one on a core without it (a step is some 5 000 instructions of software floating
/// point on a Cortex-M0). Cores without 32-bit atomics stand for ARMv6-M, as in
/// `fixed::wide_product`.
#[cfg(target_has_atomic = "32")]
const SEARCH_STEPS_PER_TICK: u32 = 3;
#[cfg(not(target_has_atomic = "32"))]
const SEARCH_STEPS_PER_TICK: u32 = 1;

/// The problem a plan solves: from velocity `u0`, cover `distance2 / 2` (fixed point) and end
/// at `ue`.
struct Move<'a> {
    distance2: i128,
    u0: i128,
    /// The present acceleration in sixths, rounded away from zero (a jerk-limited plan ramps
    /// it out on its first leg).
    alpha0: i128,
    /// Jerk-limited: the first tick of the plan at which its first pulse may start (the ticks
    /// a plan made over several ticks takes; 0 for one made at once).
    delay: u32,
    ue: i128,
    limits: &'a RampLimits,
}

/// The tick counts of a plan's legs, refined round by round (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Counts {
    /// Ticks of the stop before the peak and of the start after it (0: none).
    stop: u32,
    start: u32,
    /// Ticks of the legs into and out of the peak, and of the cruise.
    to: u32,
    from: u32,
    cruise: u32,
    /// The peak is held by a cruise at the velocity limit.
    cruising: bool,
    /// Jerk-limited: the first leg's pulse runs beside the decay of the present acceleration
    /// (else after it).
    overlap: bool,
    /// Jerk-limited: the delay of the first pulse the counts were made for.
    delay: u32,
}

impl Counts {
    const NONE: Counts =
        Counts { stop: 0, start: 0, to: 0, from: 0, cruise: 0, cruising: false, overlap: false, delay: 0 };

    /// The ticks of the legs (stop, to the peak, cruise, from the peak, start).
    fn ticks(&self) -> [u32; MAX_LEGS] {
        [self.stop, self.to, self.cruise, self.from, self.start]
    }

    /// Leg `index`'s place among the legs that run (those of a non-zero count).
    fn position(&self, index: usize) -> usize {
        self.ticks().iter().take(index).filter(|&&ticks| ticks > 0).count()
    }

    /// The ticks of leg `index` (stop, to the peak, cruise, from the peak, start).
    fn slot(&mut self, index: usize) -> Option<&mut u32> {
        match index {
            0 => Some(&mut self.stop),
            1 => Some(&mut self.to),
            2 => Some(&mut self.cruise),
            3 => Some(&mut self.from),
            4 => Some(&mut self.start),
            _ => None,
        }
    }
}

/// A jerk-limited round after its peak: the legs fitted one after the other (over several
/// ticks when the plan is made so).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Fitting {
    peak: i128,
    /// Where the legs fitted so far end, and where they were planned to end.
    v: i128,
    nominal: i128,
    /// The next leg to fit.
    next: usize,
    /// The first leg, its decay (and the velocity it adds), and the first pulse's start.
    first: usize,
    decay: Decay,
    dv: i128,
    offset: u32,
    /// Every leg so far fits; the first pulse can run beside the decay.
    fits: bool,
    beside: bool,
    /// Twice the first leg's distance, `fixed + coefficient·w` (for the tests).
    fixed: i128,
    coefficient: u32,
}

impl Fitting {
    const NONE: Fitting = Fitting {
        peak: 0,
        v: 0,
        nominal: 0,
        next: 0,
        first: 0,
        decay: Decay::NONE,
        dv: 0,
        offset: 0,
        fits: false,
        beside: false,
        fixed: 0,
        coefficient: 0,
    };
}

impl Move<'_> {
    /// The layout's tick counts (or, with `stop_first`, the fallback's), from the `f32` shape.
    #[inline(never)]
    fn layout(&self, stop_first: bool) -> Option<Counts> {
        if let Some(jerk) = &self.limits.jerk {
            return self.layout_jerk(jerk, stop_first);
        }
        let (mut counts, peak) = self.layout_head(stop_first)?;
        self.layout_legs(&mut counts, peak, stop_first)?;
        Some(counts)
    }

    /// A trapezoid's layout, its first part: the peak (`f32`), whether it cruises, and the
    /// ticks of the stop and of the start (the legs at the peak are left at 0).
    #[inline(never)]
    fn layout_head(&self, stop_first: bool) -> Option<(Counts, f32)> {
        let limits = self.limits;
        let (u0, ue) = (self.u0, self.ue);
        let (vmax, acc, dec) = (real(limits.velocity), real(limits.acceleration), real(limits.deceleration));
        let (peak, cruising, stop, start) = if stop_first {
            let (stop, start) = (self.stop_ticks(true)?, self.start_ticks(true)?);
            let fixed = mul_small(u0, stop)?.checked_add(mul_small(ue, start)?)?;
            let rest = real(self.distance2.checked_sub(fixed)?) * 0.5;
            let (peak, cruising) = layout_peak(rest, 0.0, 0.0, vmax, acc, dec);
            (peak, cruising, stop, start)
        } else {
            // The stop and the start follow from the peak, in the next part.
            let distance = real(self.distance2) * 0.5;
            let (peak, cruising) = layout_peak(distance, real(u0), real(ue), vmax, acc, dec);
            (peak, cruising, 0, 0)
        };
        let counts = Counts { stop, start, to: 0, from: 0, cruise: 0, cruising, overlap: false, delay: 0 };
        Some((counts, peak))
    }

    /// A stop before the peak, if `stop`: its ticks at the deceleration.
    fn stop_ticks(&self, stop: bool) -> Option<u32> {
        if stop && self.u0 != 0 {
            exact_ticks(self.u0, self.limits.deceleration)
        } else {
            Some(0)
        }
    }

    /// A start after the peak, if `start`: its ticks at the acceleration.
    fn start_ticks(&self, start: bool) -> Option<u32> {
        if start && self.ue != 0 {
            exact_ticks(self.ue, self.limits.acceleration)
        } else {
            Some(0)
        }
    }

    /// A trapezoid's layout, its second part: the stop and the start where the peak lies on
    /// the other side of zero (the layout's, not the fallback's: it has them), and the ticks of
    /// the legs into and out of `peak`.
    #[inline(never)]
    fn layout_legs(&self, counts: &mut Counts, peak: f32, stop_first: bool) -> Option<()> {
        let limits = self.limits;
        if !stop_first {
            let opposite = |x: i128| (x > 0 && peak < 0.0) || (x < 0 && peak > 0.0);
            (counts.stop, counts.start) =
                (self.stop_ticks(opposite(self.u0))?, self.start_ticks(opposite(self.ue))?);
        }
        let (acc, dec) = (real(limits.acceleration), real(limits.deceleration));
        let from = if counts.stop > 0 { 0.0 } else { real(self.u0) };
        let to = if counts.start > 0 { 0.0 } else { real(self.ue) };
        let rate = |u: f32, w: f32| Change::of_real(u, w).pick(acc, dec);
        counts.to = ticks_for(peak - from, rate(from, peak))?;
        counts.from = ticks_for(to - peak, rate(peak, to))?;
        Some(())
    }

    /// One round: the peak for `counts` from the present state. `Some(true)` when every leg
    /// conforms (the legs are then in `legs`), `Some(false)` when a leg was lengthened (a plan
    /// made over several ticks then lengthens the legs for the state of the tick where its
    /// next round solves, in a tick of its own).
    #[inline(never)]
    fn round(&self, counts: &mut Counts, legs: &mut Legs) -> Option<bool> {
        self.attempt(counts, Some(legs))
    }

    /// [`Self::round`], writing the legs to `legs` if given.
    fn attempt(&self, counts: &mut Counts, legs: Option<&mut Legs>) -> Option<bool> {
        match &self.limits.jerk {
            Some(jerk) => self.attempt_jerk(jerk, counts, legs),
            None => self.attempt_trapezoid(counts, legs),
        }
    }

    /// [`Self::attempt`] for a trapezoid (the jerk of the limits is not used; a plan made over
    /// several ticks is one, and calls this directly).
    fn attempt_trapezoid(&self, counts: &mut Counts, legs: Option<&mut Legs>) -> Option<bool> {
        let distance2 = self.distance2;
        let limits = self.limits;
        let (u0, ue) = (self.u0, self.ue);
        if counts.stop > 0 && !within(u0, counts.stop, limits.deceleration) {
            // The velocity grew since the layout (a plan made over several ticks).
            counts.stop = exact_ticks(u0, limits.deceleration)?;
            return Some(false);
        }
        let from = if counts.stop > 0 { 0 } else { u0 };
        let to = if counts.start > 0 { 0 } else { ue };
        // 2·distance = u0·stop + n_to·(from + vp) + 2·n_cruise·vp + n_from·(vp + to) + ue·start.
        let num = distance2
            .checked_sub(mul_small(u0, counts.stop)?)?
            .checked_sub(mul_small(ue, counts.start)?)?
            .checked_sub(mul_small(from, counts.to)?)?
            .checked_sub(mul_small(to, counts.from)?)?;
        let sides = u64::from(counts.to) + u64::from(counts.from);
        self.cruise_for(counts, num, sides)?;
        let den = sides + 2 * u64::from(counts.cruise);
        if den == 0 {
            if num == 0 && from == to {
                if let Some(legs) = legs {
                    legs.len = 0;
                    legs.push(counts.stop, 0)?;
                    legs.push(counts.start, ue)?;
                    return Some(true);
                }
                return Some(false);
            }
            counts.to = 1;
            return Some(false);
        }
        let peak = div_ticks(num, den);
        if peak.checked_abs()? > limits.velocity {
            counts.cruising = true;
            return Some(false);
        }
        let (dv_to, dv_from) = (peak.checked_sub(from)?, to.checked_sub(peak)?);
        let (rate_to, rate_from) = (limits.rate(from, peak), limits.rate(peak, to));
        let ok_to = within(dv_to, counts.to, rate_to);
        let ok_from = within(dv_from, counts.from, rate_from);
        if !ok_to {
            counts.to = exact_ticks(dv_to, rate_to)?;
        }
        if !ok_from {
            counts.from = exact_ticks(dv_from, rate_from)?;
        }
        let Some(legs) = legs.filter(|_| ok_to && ok_from) else {
            return Some(false);
        };
        legs.len = 0;
        legs.push(counts.stop, 0)?;
        legs.push(counts.to, peak)?;
        legs.push(counts.cruise, peak)?;
        legs.push(counts.from, to)?;
        legs.push(counts.start, ue)?;
        Some(true)
    }

    /// With a cruise at the velocity limit, its length: the least that keeps the peak within
    /// the limit, for twice the distance `num` left to the legs at the peak, whose ticks add up
    /// to `sides`.
    fn cruise_for(&self, counts: &mut Counts, num: i128, sides: u64) -> Option<()> {
        if counts.cruising {
            let velocity = self.limits.velocity;
            let needed = num.checked_abs()?;
            let reach = |cruise: u32| {
                let den = u32::try_from(sides + 2 * u64::from(cruise)).ok()?;
                mul_small(velocity, den)
            };
            let estimate = (real(needed) / real(velocity) - sides as f32) * 0.5;
            counts.cruise = ceil_ticks(estimate.max(0.0))?;
            while reach(counts.cruise).is_some_and(|r| r < needed) {
                counts.cruise = counts.cruise.checked_add(1)?;
            }
        }
        Some(())
    }

    /// [`Self::layout`] for the jerk-limited profile: the decay of the present acceleration
    /// on the first leg, then the continuous time-optimal peak of mirror-image pulses (a search
    /// in `f32`) from the velocity the decay leaves.
    #[inline(never)]
    fn layout_jerk(&self, jerk: &JerkLimits, stop_first: bool) -> Option<Counts> {
        let mut search = self.search_jerk(jerk, stop_first)?;
        // Two more than the most: the bracket's ends; one more: the last one takes the result.
        Shape::new(self.limits, jerk).advance(&mut search, PEAK_STEPS + 3);
        self.counts_jerk(jerk, &search)
    }

    /// The decay of the present acceleration: it, its velocity change and distance.
    fn decay(&self, jerk: &JerkLimits) -> Option<(Decay, i128, i128)> {
        let decay = jerk.decay(self.u0, self.alpha0)?;
        let (dv, dp) = decay.change()?;
        Some((decay, dv, dp))
    }

    /// The layout's search for the peak, set up (and finished if the peak is the velocity
    /// limit): the continuous problem from where the decay (and a coast until the delay) leave
    /// the axis.
    fn search_jerk(&self, jerk: &JerkLimits, stop_first: bool) -> Option<PeakSearch> {
        let (decay, dv, dp) = self.decay(jerk)?;
        let m = decay.ticks();
        let (u0, ue) = (self.u0.checked_add(dv)?, self.ue);
        let coast = self.delay.saturating_sub(m);
        let rest2 = self
            .distance2
            .checked_sub(mul_small(self.u0, m)?.checked_add(dp)?.checked_mul(2)?)?
            .checked_sub(mul_small(u0, coast)?.checked_mul(2)?)?;
        let shape = Shape::new(self.limits, jerk);
        let vmax = real(self.limits.velocity);
        Some(if stop_first {
            let stop = if u0 != 0 { shape.ticks(real(u0), 0.0)? } else { 0 };
            let start = if ue != 0 { shape.ticks(0.0, real(ue))? } else { 0 };
            let fixed = mul_small(u0, stop)?.checked_add(mul_small(ue, start)?)?;
            let mut search = shape.search(real(rest2.checked_sub(fixed)?) * 0.5, 0.0, 0.0, vmax);
            search.stop_first = Some((stop, start));
            search
        } else {
            shape.search(real(rest2) * 0.5, real(u0), real(ue), vmax)
        })
    }

    /// The tick counts of the layout from its peak (`search` done).
    fn counts_jerk(&self, jerk: &JerkLimits, search: &PeakSearch) -> Option<Counts> {
        let (decay, dv, _) = self.decay(jerk)?;
        let m = decay.ticks();
        let shape = Shape::new(self.limits, jerk);
        let (fu0, fue) = (real(self.u0.checked_add(dv)?), real(self.ue));
        let (peak, cruising) = search.found?;
        let (stop, start) = match search.stop_first {
            Some(ticks) => ticks,
            None => {
                let opposite = |x: f32| (x > 0.0 && peak < 0.0) || (x < 0.0 && peak > 0.0);
                let stop = if opposite(fu0) { shape.ticks(fu0, 0.0)? } else { 0 };
                let start = if opposite(fue) { shape.ticks(0.0, fue)? } else { 0 };
                (stop, start)
            }
        };
        let from = if stop > 0 { 0.0 } else { fu0 };
        let to = if start > 0 { 0.0 } else { fue };
        let delay = self.delay;
        let mut counts = Counts {
            stop,
            start,
            to: shape.ticks(from, peak)?,
            from: shape.ticks(peak, to)?,
            cruise: 0,
            cruising,
            overlap: false,
            delay,
        };
        if m > 0 || delay > 0 {
            // Beside the first pulse where the acceleration already points its way and is
            // within its limit; else before it.
            let (aim, first) = if stop > 0 { (0.0, &mut counts.stop) } else { (peak, &mut counts.to) };
            let accel = Change::of_real(fu0, aim).pick(jerk.acceleration, jerk.deceleration);
            let rising = if aim > fu0 { 1 } else { -1 };
            counts.overlap = m > delay && decay.start().signum() == rising && decay.start().abs() <= accel;
            *first = if counts.overlap {
                (*first).max(2 * (m - delay)).checked_add(delay)?
            } else {
                first.checked_add(m.max(delay))?
            };
        }
        Some(counts)
    }

    /// [`Self::attempt`] for the jerk-limited profile: the peak from the affine distance of
    /// the legs' pulses (and of the first leg's decay), then each leg's pulse fitted from the
    /// velocity the one before it really ends at. (Out of line: its five pulses, some 0.5 KiB
    /// of stack, would take their room in a trapezoid's round too.)
    #[inline(never)]
    fn attempt_jerk(&self, jerk: &JerkLimits, counts: &mut Counts, legs: Option<&mut Legs>) -> Option<bool> {
        let Some(mut fitting) = self.peak_jerk(jerk, counts)? else {
            return Some(false);
        };
        let mut pulses = [Pulse::NONE; MAX_LEGS];
        while fitting.next < MAX_LEGS {
            self.fit_jerk(jerk, counts, &mut fitting, &mut pulses)?;
        }
        self.finish_jerk(counts, &fitting, Some(&pulses), legs)
    }

    /// The first part of a jerk-limited round: the peak for `counts`, `None` inside if a count
    /// had to change first (the round failed).
    fn peak_jerk(&self, jerk: &JerkLimits, counts: &mut Counts) -> Option<Option<Fitting>> {
        let limits = self.limits;
        let (u0, ue) = (self.u0, self.ue);
        let (decay, dv, dp) = self.decay(jerk)?;
        let m = decay.ticks();
        let on_stop = counts.stop > 0;
        let delay = self.delay;
        {
            // Laid out for another delay: the first leg as much longer (or shorter), its pulse
            // as long.
            let first = if on_stop { &mut counts.stop } else { &mut counts.to };
            if *first > 0 {
                *first = first.checked_add(delay)?.saturating_sub(counts.delay).max(1);
            }
            counts.delay = delay;
        }
        // The first pulse's start: beside the decay from the delay, or after both.
        let overlap = counts.overlap && m > delay;
        let offset = if overlap { delay } else { m.max(delay) };
        let first = if on_stop { counts.stop } else { counts.to };
        if offset > 0 && first <= offset {
            let first = if on_stop { &mut counts.stop } else { &mut counts.to };
            *first = offset.checked_add(2)?;
            return Some(None);
        }
        // Twice the first leg's distance, `fixed + coefficient·w` for its end velocity w:
        // u0·(N + s) + (N − s)·w + 2·dp + dv·(N − 2m + s) for its pulse from tick s (the decay
        // m ticks long, beside the pulse or before it and a coast).
        let (n, mi, si) = (i128::from(first), i128::from(m), i128::from(offset));
        let fixed = mul_small(u0, first.checked_add(offset)?)?
            .checked_add(dp.checked_mul(2)?)?
            .checked_add(dv.checked_mul(n - 2 * mi + si)?)?;
        let coefficient = first - offset;
        let to = if counts.start > 0 { 0 } else { ue };
        let num = self
            .distance2
            .checked_sub(fixed)?
            .checked_sub(mul_small(to, counts.from)?)?
            .checked_sub(mul_small(ue, counts.start)?)?;
        let sides = u64::from(if on_stop { counts.to } else { coefficient }) + u64::from(counts.from);
        self.cruise_for(counts, num, sides)?;
        let den = sides + 2 * u64::from(counts.cruise);
        if den == 0 && num != 0 {
            // No leg holds the peak, and the stop and the start alone do not land.
            counts.to = 1;
            return Some(None);
        }
        let peak = if den == 0 { 0 } else { div_ticks(num, den) };
        if peak.checked_abs()? > limits.velocity {
            counts.cruising = true;
            return Some(None);
        }
        Some(Some(Fitting {
            peak,
            v: u0,
            nominal: u0,
            next: 0,
            first: if on_stop { 0 } else { 1 },
            decay,
            dv,
            offset,
            fits: true,
            beside: true,
            fixed,
            coefficient,
        }))
    }

    /// Fits the next leg of a jerk-limited round (in the order stop, to the peak, cruise, from
    /// the peak, start), from the velocity the legs before it really end at.
    fn fit_jerk(
        &self,
        jerk: &JerkLimits,
        counts: &mut Counts,
        fitting: &mut Fitting,
        pulses: &mut [Pulse; MAX_LEGS],
    ) -> Option<()> {
        let index = fitting.next;
        fitting.next += 1;
        let to = if counts.start > 0 { 0 } else { self.ue };
        let aim = *[0, fitting.peak, fitting.peak, to, self.ue].get(index)?;
        let count = counts.slot(index)?;
        if *count == 0 {
            if index == 0 || index == MAX_LEGS - 1 {
                // No stop or start: the legs at the peak start or end the move.
                return Some(());
            }
            // No leg: the velocity must already be there (to the sixth).
            let (jerk_limit, accel) = jerk.pulse(fitting.nominal, aim);
            fitting.nominal = aim;
            let sigma = sixths(aim.checked_sub(fitting.v)?)?;
            if sigma != 0 {
                fitting.fits = false;
                *count = Pulse::shortest(sigma, jerk_limit, accel)?.ticks();
                fitting.v = aim;
            }
            return Some(());
        }
        let first = index == fitting.first;
        let (offset, carry, min_rise) = match first {
            true => (fitting.offset, fitting.dv, fitting.decay.ticks().saturating_sub(fitting.offset)),
            false => (0, 0, 0),
        };
        let start = fitting.v.checked_add(carry)?;
        // Limits chosen by where the leg starts as planned (the first from the state, the
        // others from the aim before them): a start a few units off zero does not make a leg
        // from a stop one that changes sign.
        let (jerk_limit, accel) = jerk.pulse(if first { start } else { fitting.nominal }, aim);
        fitting.nominal = aim;
        let sigma = sixths(aim.checked_sub(start)?)?;
        let length = *count - offset;
        let sign = fitting.decay.start().signum();
        let fitted = Pulse::fit(sigma, length, jerk_limit, accel, min_rise)
            .filter(|pulse| min_rise == 0 || (pulse.rise_end() >= min_rise && sigma.signum() == sign));
        if let Some(pulse) = fitted {
            // Where the leg will be among the legs that run (the empty ones are left out), so
            // that the legs are complete without moving a pulse.
            *pulses.get_mut(counts.position(index))? = pulse;
            fitting.v = start.checked_add(sigma.checked_mul(6)?)?;
            return Some(());
        }
        fitting.fits = false;
        if min_rise > 0 && Pulse::fit(sigma, length, jerk_limit, accel, 0).is_some() {
            // Long enough, but the pulse cannot run beside the decay: the round ends here.
            fitting.beside = false;
            fitting.next = MAX_LEGS;
            return Some(());
        }
        let shortest = Pulse::shortest(sigma, jerk_limit, accel)?.ticks().max(2 * min_rise);
        *count = offset.checked_add(shortest.max(length + 1))?;
        fitting.v = aim;
        Some(())
    }

    /// The end of a jerk-limited round: `Some(true)` with the legs in `legs` if every leg fits.
    /// `pulses` by leg, or `None` if they are in `legs` by leg already.
    fn finish_jerk(
        &self,
        counts: &mut Counts,
        fitting: &Fitting,
        pulses: Option<&[Pulse; MAX_LEGS]>,
        legs: Option<&mut Legs>,
    ) -> Option<bool> {
        if !fitting.beside {
            // After the decay instead: the first leg as much longer.
            counts.overlap = false;
            let m = fitting.decay.ticks();
            let first = counts.slot(fitting.first)?;
            *first = first.checked_add(m.saturating_sub(self.delay))?;
            return Some(false);
        }
        let Some(legs) = legs.filter(|_| fitting.fits) else {
            return Some(false);
        };
        let to = if counts.start > 0 { 0 } else { self.ue };
        let ticks = counts.ticks();
        let aims = [0, fitting.peak, fitting.peak, to, self.ue];
        legs.len = 0;
        legs.decay = fitting.decay;
        legs.offset = fitting.offset;
        for (&count, &aim) in ticks.iter().zip(&aims) {
            // The pulses are at their legs' places already ([`Counts::position`]).
            if let (Some(pulses), true) = (pulses, count > 0) {
                *legs.pulses.get_mut(legs.len)? = *pulses.get(legs.len)?;
            }
            legs.push(count, aim)?;
        }
        #[cfg(test)]
        {
            // The first leg as solved (`fixed + coefficient·w`), the others L·(u + w), from
            // the velocities the pulses reach.
            let mut v = self.u0;
            legs.covered2 = 0;
            // The legs' sums, by leg (the pushed pulses are compacted).
            let mut sigmas = [0i128; MAX_LEGS];
            let mut pushed = 0;
            for (index, &count) in ticks.iter().enumerate() {
                if count > 0 {
                    sigmas[index] = legs.pulses[pushed].sigma();
                    pushed += 1;
                }
            }
            for (index, &count) in ticks.iter().enumerate() {
                if count == 0 {
                    continue;
                }
                let carry = if index == fitting.first { fitting.dv } else { 0 };
                let end = v + carry + 6 * sigmas[index];
                legs.covered2 += if index == fitting.first {
                    fitting.fixed + i128::from(fitting.coefficient) * end
                } else {
                    i128::from(count) * (v + end)
                };
                v = end;
            }
        }
        Some(true)
    }

    /// The legs of the layout (or, with `stop_first`, of the fallback) at once, `None` if no
    /// peak conforms within the rounds.
    fn solve(&self, stop_first: bool, legs: &mut Legs) -> Option<()> {
        let mut counts = self.layout(stop_first)?;
        for _ in 0..self.limits.rounds() {
            if self.round(&mut counts, legs)? {
                return Some(());
            }
        }
        None
    }
}

/// A velocity change in sixths of a pulse's sum, rounded toward zero (the leg then ends at most
/// 5 units of 2⁻⁶⁴ increment/tick short of its aim). A 128-bit division by a constant is a
/// bit-by-bit loop on a Cortex-M; this is four 64-by-32-bit steps.
fn sixths(change: i128) -> Option<i128> {
    let magnitude = div_floor(change.checked_abs()?, 6);
    Some(if change < 0 { -magnitude } else { magnitude })
}

/// A jerk-limited velocity change from a state to an aim, wherever it ends (a stop, a halt, a
/// pv ramp): the decay of the present acceleration, and one pulse beside it where the
/// acceleration already points the pulse's way (and is within its limit), else after it.
/// Fitted one length per try ([`Self::try_fit`]), so that a drive can spread the tries over
/// its ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Ramp {
    /// The request's velocity and the aim.
    v: i128,
    aim: i128,
    /// The decay, the velocity it adds and its distance.
    decay: Decay,
    dv: i128,
    dp: i128,
    /// The pulse's sum, jerk and acceleration limits (sixths).
    sigma: i128,
    jerk: i128,
    accel: i128,
    /// The pulse may run beside the decay; the shortest pulse has been found (its length).
    beside: bool,
    found: bool,
    shortest: u32,
    /// Beside the decay: the earliest tick the pulse may start at.
    skip: u32,
    /// The pulse's length to try next (beside the decay: the leg's), and the tries so far
    /// (of this kind).
    length: u32,
    tries: u32,
}

impl Ramp {
    const NONE: Ramp = Ramp {
        v: 0,
        aim: 0,
        decay: Decay::NONE,
        dv: 0,
        dp: 0,
        sigma: 0,
        jerk: 1,
        accel: 1,
        beside: false,
        found: false,
        shortest: 0,
        skip: 0,
        length: 0,
        tries: 0,
    };

    /// The ramp from velocity `v` at acceleration `alpha0` (sixths) to `aim`.
    fn new(jerk: &JerkLimits, v: i128, alpha0: i128, aim: i128) -> Option<Ramp> {
        let decay = jerk.decay(v, alpha0)?;
        let (dv, dp) = decay.change()?;
        let start = v.checked_add(dv)?;
        let sigma = sixths(aim.checked_sub(start)?)?;
        let (jerk, accel) = jerk.pulse(start, aim);
        let beside =
            decay.ticks() > 0 && decay.start().signum() == sigma.signum() && decay.start().abs() <= accel;
        let length = if sigma == 0 { 0 } else { Pulse::estimate(sigma, jerk, accel)? };
        let found = sigma == 0;
        Some(Ramp {
            v,
            aim,
            decay,
            dv,
            dp,
            sigma,
            jerk,
            accel,
            beside,
            found,
            shortest: length,
            skip: 0,
            length,
            tries: 0,
        })
    }

    /// One try, for a pulse that starts no earlier than tick `delay`: first the shortest
    /// pulse (after the decay; the estimate lengthened as [`Pulse::shortest`] does), then,
    /// where it may run beside the decay, one long enough to rise past the decay's end
    /// (lengthened by 1/64 per try, three tries, else after the decay as the shortest). The
    /// leg's ticks, the pulse, the tick it starts at and twice the distance covered; `None`
    /// inside when this try did not fit.
    fn try_fit(&mut self, delay: u32) -> Option<Option<(u32, Pulse, u32, i128)>> {
        let m = self.decay.ticks();
        let may_overlap = self.beside && delay.max(self.skip) < m;
        // Beside only where it can be shorter than after the decay: its rise must outlast
        // the decay, so the leg is at least `offset + 2·(m − offset)`, against `m + shortest`.
        let beside = self.found && may_overlap && m - delay.max(self.skip) < self.shortest;
        let offset = if beside { delay.max(self.skip) } else { delay.max(m) };
        let min_rise = m.saturating_sub(offset);
        // Beside, `length` is the leg's (the pulse from `offset` to its end).
        let length = if beside {
            self.length.saturating_sub(offset).max(2 * min_rise).max(self.shortest)
        } else {
            self.length
        };
        let fitted = if self.sigma == 0 {
            Some(Pulse::NONE)
        } else {
            Pulse::fit(self.sigma, length, self.jerk, self.accel, min_rise)
                .filter(|p| p.rise_end() >= min_rise)
        };
        self.tries += 1;
        match fitted {
            None if beside => {
                // The bump (`pulse.rs`) cut into the rise: a longer leg, and a later start
                // (a third of the way to the decay's end) that leaves the rise less to cover.
                let leg = offset.checked_add(length)?;
                self.length = leg.checked_add(1 + leg / 64)?;
                self.skip = offset + (m - offset).div_ceil(4);
                if self.tries >= BESIDE_TRIES {
                    (self.beside, self.length, self.tries) = (false, self.shortest, 0);
                }
            }
            None if self.tries >= Pulse::TRIES => return None,
            None => self.length = Pulse::longer(length)?,
            Some(_) if !self.found && may_overlap => {
                (self.found, self.shortest, self.tries) = (true, length, 0);
            }
            Some(pulse) => {
                // u·(N + s) + (N − s)·w + 2·dp + dv·(N − 2m + s) for the pulse from tick s.
                let ticks = offset.checked_add(length)?;
                let end = self.v.checked_add(self.dv)?.checked_add(self.sigma.checked_mul(6)?)?;
                let spans = i128::from(ticks) - 2 * i128::from(m) + i128::from(offset);
                let covered = mul_small(self.v, ticks.checked_add(offset)?)?
                    .checked_add(mul_small(end, length)?)?
                    .checked_add(self.dp.checked_mul(2)?)?
                    .checked_add(self.dv.checked_mul(spans)?)?;
                return Some(Some((ticks, pulse, offset, covered)));
            }
        }
        Some(None)
    }

    /// [`Self::try_fit`] until it fits, for a pulse that may start at once.
    fn fit_at_once(&mut self) -> Option<(u32, Pulse, u32, i128)> {
        for _ in 0..RAMP_TRIES {
            if let Some(fit) = self.try_fit(0)? {
                return Some(fit);
            }
        }
        None
    }
}

/// Tries of a [`Ramp`]'s pulse beside the decay: the bump (`pulse.rs`) may cut into the rise
/// (it depends on the remainder), so a few lengths and starts are tried.
const BESIDE_TRIES: u32 = 8;

/// The most tries of a [`Ramp`]: the shortest pulse's, those beside the decay, and the
/// shortest's again after it.
const RAMP_TRIES: u32 = 2 * Pulse::TRIES + BESIDE_TRIES;

/// Where a plan made over several ticks has got to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// Asked for in this tick: the work starts in the next (the tick that takes a set-point
    /// has work enough of its own).
    Asked,
    /// Next: the layout's peak (the fallback's with `true`), then its legs.
    Layout(bool),
    Legs(bool),
    /// Next: round `round` of the layout (or of the fallback).
    Round {
        fallback: bool,
        round: u32,
    },
    /// Next: after a failed round, the legs lengthened for the state of the tick after (where
    /// round `round` solves).
    Lengthen {
        fallback: bool,
        round: u32,
    },
}

/// A plan made over several ticks while the present motion continues ([`Ramps::request`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Job {
    target2: i128,
    last: i128,
    /// A trapezoid's limits (only trapezoids are planned over several ticks: their jerk-limited
    /// limits would be some 100 bytes more to copy).
    velocity: i128,
    acceleration: i128,
    deceleration: i128,
    /// For the provisional rule: the end velocity squared and 1 / deceleration (`f32`).
    end_squared: f32,
    per_deceleration: f32,
    stage: Stage,
    counts: Counts,
    /// The layout's peak (`f32`), between its two ticks.
    peak: f32,
}

/// Where a jerk-limited plan made over several ticks has got to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum JerkStage {
    /// No plan is being made.
    Idle,
    /// Asked for in this tick (a velocity ramp with `true`): the work starts in the next.
    Asked(bool),
    /// Next: the limits converted (a velocity ramp's first try estimated).
    Convert(bool),
    /// Next: a velocity ramp's try.
    Ramp,
    /// Next: steps of the layout's search (the fallback's with `true`).
    Search(bool),
    /// Next: the layout's tick counts from its peak.
    Counts(bool),
    /// Next: the peak of round `round`, or the fitting of its next leg.
    Peak {
        fallback: bool,
        round: u32,
    },
    Fit {
        fallback: bool,
        round: u32,
    },
}

/// A jerk-limited plan made over several ticks ([`Ramps::request_jerk`]). It is made for the
/// state of the request while the axis runs the first stretch of its first leg — the decay of
/// its acceleration, then a coast at the velocity that leaves — which every plan made for that
/// state begins with: its first pulse starts no earlier than the tick that completes it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct JerkJob {
    /// The request's state: twice the position, the velocity, the acceleration.
    p2: i128,
    v: i128,
    alpha0: i128,
    /// The target (twice) and the velocity it is passed at, or a velocity ramp's aim.
    target2: i128,
    last: i128,
    /// The limits as asked for, converted in the tick after the request (at the rate
    /// [`Ramps::work`] is given: the planner's).
    asked: Limits,
    limits: RampLimits,
    /// The delay of the first pulse the layout is made for.
    delay: u32,
    stage: JerkStage,
    search: PeakSearch,
    counts: Counts,
    fitting: Fitting,
    ramp: Ramp,
}

impl JerkJob {
    const IDLE: JerkJob = JerkJob {
        p2: 0,
        v: 0,
        alpha0: 0,
        target2: 0,
        last: 0,
        asked: Limits::new(0, 0, 0),
        limits: RampLimits { velocity: 0, acceleration: 0, deceleration: 0, jerk: None },
        delay: 0,
        stage: JerkStage::Idle,
        search: PeakSearch::NEW,
        counts: Counts::NONE,
        fitting: Fitting::NONE,
        ramp: Ramp::NONE,
    };

    /// The stage `Convert`: the limits asked for converted, and for a velocity ramp (`ramp`)
    /// the ramp set up; false if it cannot be. Out of line: the other stages need less stack.
    #[inline(never)]
    fn convert(&mut self, rate: TickRate, ramp: bool) -> bool {
        self.limits = RampLimits::new(&self.asked, rate);
        if !ramp {
            self.stage = JerkStage::Search(false);
            return true;
        }
        match self.limits.jerk.as_ref().and_then(|jerk| Ramp::new(jerk, self.v, self.alpha0, self.last)) {
            Some(ramp) => {
                (self.ramp, self.stage) = (ramp, JerkStage::Ramp);
                true
            }
            None => false,
        }
    }
}

/// Ticks a jerk-limited plan made over several ticks lays out for: about the ticks it takes.
const JERK_LAYOUT_DELAY: u32 = 12;

impl Job {
    #[inline(always)]
    fn limits(&self) -> RampLimits {
        RampLimits {
            velocity: self.velocity,
            acceleration: self.acceleration,
            deceleration: self.deceleration,
            jerk: None,
        }
    }
}

/// Executes trapezoidal and jerk-limited plans (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ramps {
    legs: Legs,
    /// A plan being made over several ticks.
    job: Option<Job>,
    /// A jerk-limited plan being made over several ticks (in place: it is some 500 bytes).
    jerk_job: JerkJob,
    next: usize,
    /// Twice the position (2⁻⁶⁵ increments).
    p2: i128,
    v: i128,
    /// The acceleration of the next tick (trapezoid).
    a: i128,
    /// Jerk-limited: the acceleration now, in sixths (`pulse.rs`).
    alpha: i128,
    /// The plan in progress is jerk-limited.
    jerk_limited: bool,
    /// The leg in progress: its length, the ticks left, its base acceleration, and how many of
    /// its first and last ticks run one unit above it.
    ticks: u32,
    left: u32,
    base: i128,
    early: u32,
    late: u32,
    remaining: u64,
    /// The state the plan ends in (twice the position, the velocity).
    end_p2: i128,
    end_v: i128,
    /// How the plan was made (for the tests).
    #[cfg(test)]
    made: Made,
    /// The state the last plan started from (twice the position, the velocity).
    #[cfg(test)]
    planned_from: (i128, i128),
}

impl Ramps {
    /// At `state` (its acceleration is dropped: a trapezoid's acceleration jumps).
    pub(crate) const fn at(state: Exact) -> Self {
        Ramps {
            legs: Legs {
                ticks: [0; MAX_LEGS],
                aims: [0; MAX_LEGS],
                pulses: [Pulse::NONE; MAX_LEGS],
                decay: Decay::NONE,
                offset: 0,
                len: 0,
                #[cfg(test)]
                covered2: 0,
            },
            job: None,
            jerk_job: JerkJob::IDLE,
            next: 0,
            p2: state.p.wrapping_mul(2),
            v: state.v,
            a: 0,
            alpha: 0,
            jerk_limited: false,
            ticks: 0,
            left: 0,
            base: 0,
            early: 0,
            late: 0,
            remaining: 0,
            end_p2: state.p.wrapping_mul(2),
            end_v: state.v,
            #[cfg(test)]
            made: Made::Layout,
            #[cfg(test)]
            planned_from: (0, 0),
        }
    }

    /// Drops any plan and holds still at `p` (as [`Self::at`], in place).
    pub(crate) fn hold(&mut self, p: i128) {
        self.legs.len = 0;
        self.job = None;
        self.jerk_job.stage = JerkStage::Idle;
        self.next = 0;
        self.p2 = p.wrapping_mul(2);
        self.v = 0;
        self.a = 0;
        self.alpha = 0;
        self.left = 0;
        self.remaining = 0;
        self.end_p2 = self.p2;
        self.end_v = 0;
    }

    /// The present state.
    pub(crate) fn now(&self) -> Exact {
        Exact { p: self.p2 >> 1, v: self.v, a: self.acceleration() }
    }

    /// The present acceleration in sixths, rounded away from zero (exact for a jerk-limited
    /// plan's state; a trapezoid's is divided).
    fn alpha_now(&self) -> Option<i128> {
        if self.jerk_limited {
            Some(self.alpha)
        } else {
            Decay::sixths(self.a)
        }
    }

    /// The present acceleration: a trapezoid's of the next tick, a jerk-limited one's now.
    fn acceleration(&self) -> i128 {
        if self.jerk_limited {
            self.alpha.wrapping_mul(6)
        } else {
            self.a
        }
    }

    /// Plans a move to `target` (fixed point) that passes it at `last` (signed, fixed point).
    /// Returns the ticks until the target; on error the present motion continues.
    pub(crate) fn plan(&mut self, target: i128, last: i128, limits: &RampLimits) -> Result<u64, MotionError> {
        let end_p2 = target.checked_mul(2).ok_or(MotionError::OutOfRange)?;
        let problem = Move {
            distance2: end_p2.checked_sub(self.p2).ok_or(MotionError::OutOfRange)?,
            u0: self.v,
            alpha0: self.alpha_now().ok_or(MotionError::TooLong)?,
            delay: 0,
            ue: last,
            limits,
        };
        // A round writes the legs only when it completes the plan: on error the legs in
        // progress stay.
        self.job = None;
        self.jerk_job.stage = JerkStage::Idle;
        let legs = &mut self.legs;
        if problem.distance2 == 0 && problem.u0 == 0 && problem.alpha0 == 0 && last == 0 {
            // Already there, at rest.
            legs.len = 0;
            #[cfg(test)]
            {
                legs.covered2 = 0;
            }
            self.jerk_limited = limits.jerk.is_some();
            self.start(end_p2, 0, Made::Layout);
            return Ok(0);
        }
        let made = match problem.solve(false, legs) {
            Some(()) => Made::Layout,
            None => {
                problem.solve(true, legs).ok_or(MotionError::TooLong)?;
                Made::Fallback
            }
        };
        self.jerk_limited = limits.jerk.is_some();
        self.start(end_p2, last, made);
        Ok(self.remaining)
    }

    /// Ramps the velocity to `aim` (fixed point per tick) within `limits`, wherever that ends
    /// (a stop, a pv ramp): one leg, a trapezoid's at the rate [`RampLimits::rate`] chooses,
    /// a jerk-limited one's a pulse after (or beside) the decay of the present acceleration.
    /// Returns the ticks until the velocity is reached.
    pub(crate) fn velocity(&mut self, aim: i128, limits: &RampLimits) -> Result<u64, MotionError> {
        match &limits.jerk {
            None => self.velocity_trapezoid(aim, limits),
            Some(jerk) => self.velocity_jerk(jerk, aim),
        }
    }

    /// [`Self::velocity`] for a trapezoid (the jerk of `limits` is not used): a leg at the
    /// ramp's rate, made at once.
    pub(crate) fn velocity_trapezoid(&mut self, aim: i128, limits: &RampLimits) -> Result<u64, MotionError> {
        let ticks = exact_ticks(aim.wrapping_sub(self.v), limits.rate(self.v, aim));
        let covered = ticks.and_then(|n| mul_small(self.v.checked_add(aim)?, n));
        let (ticks, covered) = ticks.zip(covered).ok_or(MotionError::TooLong)?;
        self.lay_ramp(aim, ticks, &Pulse::NONE, (0, Decay::NONE), covered, false)
    }

    /// [`Self::velocity`]'s jerk-limited ramp, made at once. Out of line: a trapezoid's ramp
    /// (a quick stop in a tick) does not need its stack.
    #[inline(never)]
    fn velocity_jerk(&mut self, jerk: &JerkLimits, aim: i128) -> Result<u64, MotionError> {
        let alpha0 = self.alpha_now().ok_or(MotionError::TooLong)?;
        let mut ramp = Ramp::new(jerk, self.v, alpha0, aim).ok_or(MotionError::TooLong)?;
        let (ticks, pulse, offset, covered) = ramp.fit_at_once().ok_or(MotionError::TooLong)?;
        self.lay_ramp(aim, ticks, &pulse, (offset, ramp.decay), covered, true)
    }

    /// The legs of a velocity ramp to `aim`: one, of `ticks` and `pulse` (the `decay` of the
    /// present acceleration beside or before it, `offset` ticks in), covering `covered`
    /// (doubled); a trapezoid's with [`Pulse::NONE`] and not `jerk_limited`.
    fn lay_ramp(
        &mut self,
        aim: i128,
        ticks: u32,
        pulse: &Pulse,
        (offset, decay): (u32, Decay),
        covered: i128,
        jerk_limited: bool,
    ) -> Result<u64, MotionError> {
        let end_p2 = self.p2.checked_add(covered).ok_or(MotionError::TooLong)?;
        self.job = None;
        self.jerk_job.stage = JerkStage::Idle;
        self.a = 0;
        self.legs.len = 0;
        self.legs.decay = decay;
        self.legs.offset = offset;
        self.legs.push_pulse(ticks, aim, *pulse).ok_or(MotionError::TooLong)?;
        #[cfg(test)]
        {
            self.legs.covered2 = covered;
        }
        self.jerk_limited = jerk_limited;
        self.start(end_p2, aim, Made::Layout);
        Ok(self.remaining)
    }

    /// Asks for a move to `target` that passes it at `last` (as [`Self::plan`]), planned over
    /// the next ticks by [`Self::work`]: nothing in the tick that asks, then the layout, then
    /// a round per tick (see the module docs). The axis holds its velocity in the tick that
    /// asks and follows the provisional rule ([`Self::provisional`]) from the next; the plan
    /// starts in the tick after the share that completes it, from the state that share saw
    /// (usually the fourth tick after the request).
    pub(crate) fn request(
        &mut self,
        target: i128,
        last: i128,
        limits: &RampLimits,
    ) -> Result<(), MotionError> {
        let target2 = target.checked_mul(2).ok_or(MotionError::OutOfRange)?;
        target2.checked_sub(self.p2).ok_or(MotionError::OutOfRange)?;
        // Meanwhile the axis follows the provisional rule (a trapezoid's acceleration may
        // jump); each round solves from the state of its tick, and lengthens what it must for
        // the state of the next.
        self.legs.len = 0;
        self.left = 0;
        self.a = 0;
        self.remaining = 0;
        self.job = Some(Job {
            target2,
            last,
            velocity: limits.velocity,
            acceleration: limits.acceleration,
            deceleration: limits.deceleration,
            end_squared: real(last) * real(last),
            per_deceleration: 1.0 / real(limits.deceleration),
            stage: Stage::Asked,
            counts: Counts::default(),
            peak: 0.0,
        });
        // This tick holds the velocity; the provisional rule takes over from the next one.
        self.a = 0;
        Ok(())
    }

    /// [`Self::request`] for the jerk-limited profile: the plan is made over the next ticks
    /// ([`Self::work`]: the limits converted, a few steps of the layout's search per tick,
    /// then its counts, then per round the peak and one leg's fit per tick) for the state of
    /// this tick, while the axis ramps its acceleration out and coasts — the start of every
    /// plan from this state. The plan is complete usually 9 to 16 ticks after the request.
    pub(crate) fn request_jerk(
        &mut self,
        target: i128,
        last: i128,
        limits: &Limits,
        rate: TickRate,
    ) -> Result<(), MotionError> {
        let target2 = target.checked_mul(2).ok_or(MotionError::OutOfRange)?;
        target2.checked_sub(self.p2).ok_or(MotionError::OutOfRange)?;
        self.ask_jerk(target2, last, limits, rate, false)
    }

    /// [`Self::velocity`] for the jerk-limited profile over the next ticks (a drive's stops):
    /// the acceleration ramps out at once, the limits are converted in the next tick, and from
    /// the one after, a length of the pulse is tried per tick ([`Ramp::try_fit`]), usually
    /// one; the pulse starts in the tick whose try fits (the axis coasts until then).
    pub(crate) fn request_velocity(
        &mut self,
        aim: i128,
        limits: &Limits,
        rate: TickRate,
    ) -> Result<(), MotionError> {
        self.ask_jerk(0, aim, limits, rate, true)
    }

    /// The request of [`Self::request_jerk`] (`target2`, `last`) or [`Self::request_velocity`]
    /// (`last`, the aim): the first leg's start as the axis runs it meanwhile (the decay of
    /// the present acceleration, then a coast), and the job.
    fn ask_jerk(
        &mut self,
        target2: i128,
        last: i128,
        limits: &Limits,
        rate: TickRate,
        ramp: bool,
    ) -> Result<(), MotionError> {
        let alpha0 = self.alpha_now().ok_or(MotionError::TooLong)?;
        let decay = JerkLimits::decay_of(limits, rate, self.v, alpha0).ok_or(MotionError::TooLong)?;
        self.job = None;
        self.legs.len = 0;
        self.legs.push_pulse(u32::MAX, 0, Pulse::NONE).ok_or(MotionError::TooLong)?;
        self.legs.decay = decay;
        self.legs.offset = u32::MAX;
        self.jerk_limited = true;
        self.next = 1;
        self.ticks = u32::MAX;
        self.left = u32::MAX;
        self.a = 0;
        // The decay starts from the present acceleration (`decay.alpha(0)`).
        self.alpha = alpha0;
        self.remaining = 0;
        // Written in place, field by field.
        let job = &mut self.jerk_job;
        (job.p2, job.v, job.alpha0, job.target2, job.last) = (self.p2, self.v, alpha0, target2, last);
        job.asked = *limits;
        job.stage = JerkStage::Asked(ramp);
        job.search.set_up = false;
        Ok(())
    }

    /// One tick's share of a velocity ramp (a stop) [`Self::request_velocity`] asked for:
    /// the stages `Asked`, `Convert` and `Ramp`. False when it gives up (the caller stops at
    /// once, out of this frame).
    #[inline(never)]
    fn work_ramp(&mut self, rate: TickRate) -> bool {
        // Ticks since the request: the axis is that far into the first leg.
        let done = self.ticks.wrapping_sub(self.left);
        let job = &mut self.jerk_job;
        match job.stage {
            // (Begun by [`Self::begin`].)
            JerkStage::Asked(_) => {}
            JerkStage::Convert(ramp) => return job.convert(rate, ramp),
            JerkStage::Ramp => match job.ramp.try_fit(done) {
                Some(None) => {}
                Some(Some((ticks, pulse, offset, covered))) => {
                    let (aim, end_p2) = (job.last, job.p2.checked_add(covered));
                    job.stage = JerkStage::Idle;
                    let legs = &mut self.legs;
                    legs.len = 0;
                    legs.offset = offset;
                    #[cfg(test)]
                    {
                        legs.covered2 = covered;
                    }
                    match (end_p2, legs.push_pulse(ticks, aim, pulse)) {
                        (Some(end_p2), Some(())) => self.resume(done, end_p2, aim, Made::Layout),
                        _ => return false,
                    }
                }
                None => return false,
            },
            _ => {}
        }
        true
    }

    /// One tick's share of a jerk-limited plan [`Self::request_jerk`] asked for: the stages
    /// from `Search` to `Fit`. False when it gives up (the caller stops at once, out of this
    /// frame).
    #[inline(never)]
    fn work_jerk(&mut self) -> bool {
        // Ticks since the request: the axis is that far into the first leg.
        let done = self.ticks.wrapping_sub(self.left);
        // The job's parts borrowed apart (the limits stay put while the counts change).
        let JerkJob { p2, v, alpha0, target2, last, limits, delay, stage, search, counts, fitting, .. } =
            &mut self.jerk_job;
        let Some(jerk) = limits.jerk.as_ref() else { return true };
        let limits = &*limits;
        let problem = |delay: u32| {
            Some(Move {
                distance2: target2.checked_sub(*p2)?,
                u0: *v,
                alpha0: *alpha0,
                delay,
                ue: *last,
                limits,
            })
        };
        let legs = &mut self.legs;
        let outcome = (|| -> Option<Option<bool>> {
            match *stage {
                JerkStage::Idle | JerkStage::Asked(_) | JerkStage::Convert(_) | JerkStage::Ramp => {}
                JerkStage::Search(fallback) => {
                    let mut steps = SEARCH_STEPS_PER_TICK;
                    if !search.set_up {
                        // The set-up (the decay and the continuous problem) takes a step's place.
                        *delay = done.checked_add(JERK_LAYOUT_DELAY)?;
                        *search = problem(*delay)?.search_jerk(jerk, fallback)?;
                        steps -= 1;
                    }
                    Shape::new(limits, jerk).advance(search, steps);
                    if search.found.is_some() {
                        *stage = JerkStage::Counts(fallback);
                    }
                }
                JerkStage::Counts(fallback) => {
                    *counts = problem(*delay)?.counts_jerk(jerk, search)?;
                    *stage = JerkStage::Peak { fallback, round: 0 };
                }
                JerkStage::Peak { fallback, round } => {
                    // The first pulse after the ticks the fitting takes (one per leg): the
                    // delay so far if it leaves them, else room for two rounds more (a delay
                    // moved every round moves the problem every round).
                    let fitting_ticks = MAX_LEGS as u32 + 1;
                    if *delay < done.checked_add(fitting_ticks)? {
                        *delay = done.checked_add(2 * fitting_ticks)?;
                    }
                    match problem(*delay)?.peak_jerk(jerk, counts)? {
                        Some(peak) => {
                            *fitting = peak;
                            *stage = JerkStage::Fit { fallback, round };
                        }
                        None => return Some(Some(false)),
                    }
                }
                JerkStage::Fit { .. } => {
                    let problem = problem(*delay)?;
                    if fitting.next >= MAX_LEGS || !fitting.beside {
                        // In a tick of its own (after the last leg's fit, the dearest tick of
                        // a plan): the pulses are in the legs already, at their places.
                        return Some(Some(problem.finish_jerk(counts, fitting, None, Some(legs))?));
                    }
                    // One leg (and the empty stop or start around it, which cost nothing).
                    loop {
                        let index = fitting.next;
                        let empty = (index == 0 || index == MAX_LEGS - 1)
                            && counts.slot(index).is_some_and(|ticks| *ticks == 0);
                        problem.fit_jerk(jerk, counts, fitting, &mut legs.pulses)?;
                        if !empty || fitting.next >= MAX_LEGS {
                            break;
                        }
                    }
                    if fitting.next == MAX_LEGS - 1 && counts.start == 0 {
                        fitting.next += 1;
                    }
                }
            }
            Some(None)
        })();
        let job = &mut self.jerk_job;
        match outcome {
            Some(None) => {}
            Some(Some(true)) => {
                let fallback = matches!(job.stage, JerkStage::Fit { fallback: true, .. });
                let (end_p2, end_v) = (job.target2, job.last);
                job.stage = JerkStage::Idle;
                self.resume(done, end_p2, end_v, if fallback { Made::Fallback } else { Made::Layout });
            }
            Some(Some(false)) => {
                // The round failed: the next one, or the fallback's layout, or a stop.
                job.stage = match job.stage {
                    JerkStage::Peak { fallback, round } | JerkStage::Fit { fallback, round }
                        if round + 1 < JERK_ROUNDS =>
                    {
                        JerkStage::Peak { fallback, round: round + 1 }
                    }
                    JerkStage::Peak { fallback: false, .. } | JerkStage::Fit { fallback: false, .. } => {
                        job.search.set_up = false;
                        JerkStage::Search(true)
                    }
                    _ => JerkStage::Idle,
                };
                if job.stage == JerkStage::Idle {
                    return false;
                }
            }
            // Out of range (not seen in the tests): stop instead.
            None => return false,
        }
        true
    }

    /// A jerk-limited plan made over several ticks that found nothing (not seen in the
    /// tests: every request has found one): a stop at once instead, in a frame of its own.
    #[inline(never)]
    fn give_up(&mut self) {
        self.jerk_job.stage = JerkStage::Idle;
        let limits = self.jerk_job.limits;
        let _ = self.velocity(0, &limits);
    }

    /// Starts the legs a plan made over several ticks completed, `done` ticks into its first
    /// leg (which the axis ran meanwhile).
    fn resume(&mut self, done: u32, end_p2: i128, end_v: i128, made: Made) {
        #[cfg(test)]
        {
            self.planned_from = (self.jerk_job.p2, self.jerk_job.v);
        }
        self.end_p2 = end_p2;
        self.end_v = end_v;
        self.next = 1;
        self.ticks = self.legs.ticks[0];
        self.left = self.ticks.saturating_sub(done).max(1);
        self.remaining = self.legs.total().saturating_sub(u64::from(done));
        #[cfg(test)]
        {
            self.made = made;
        }
        #[cfg(not(test))]
        let _ = made;
    }

    /// A plan asked for in this tick moves to its first stage, and its work starts in the
    /// next tick (the tick that takes a set-point has work enough of its own). True if there
    /// was one.
    fn begin(&mut self) -> bool {
        if let JerkStage::Asked(ramp) = self.jerk_job.stage {
            self.jerk_job.stage = JerkStage::Convert(ramp);
            return true;
        }
        match self.job.as_mut() {
            Some(job) if job.stage == Stage::Asked => {
                job.stage = Stage::Layout(false);
                true
            }
            _ => false,
        }
    }

    /// One tick's share of the plan [`Self::request`] asked for: a layout or a round. When a
    /// round completes the plan, its legs start from the present state.
    pub(crate) fn work(&mut self, rate: TickRate) {
        if self.begin() {
            return;
        }
        let going = match self.jerk_job.stage {
            JerkStage::Idle => {
                if self.job.is_some() {
                    self.work_trapezoid();
                }
                true
            }
            JerkStage::Asked(_) | JerkStage::Convert(_) | JerkStage::Ramp => self.work_ramp(rate),
            _ => self.work_jerk(),
        };
        if !going {
            self.give_up();
        }
    }

    /// [`Self::work`] for a trapezoid (out of line: its frame, some 500 bytes of stack, only
    /// while it plans).
    #[inline(never)]
    fn work_trapezoid(&mut self) {
        let made = |fallback: bool| if fallback { Made::Fallback } else { Made::Layout };
        // The acceleration of the tick this share is for: the provisional rule's. A round
        // solves from the present state, and a round that completes the plan needs none.
        let round = matches!(self.job.as_ref().map(|job| job.stage), Some(Stage::Round { .. }));
        if !round {
            self.a = self.provisional();
        }
        // Worked on in place (a job and the legs are some 200 bytes to copy).
        let (p2, v, a) = (self.p2, self.v, self.a);
        let Some(job) = self.job.as_mut() else { return };
        let limits = job.limits();
        let outcome = job.target2.checked_sub(p2).and_then(|distance2| {
            let problem = Move { distance2, u0: v, alpha0: 0, delay: 0, ue: job.last, limits: &limits };
            // The state after the tick this share is for, at its provisional acceleration `a`.
            let next = Move {
                distance2: distance2.checked_sub(v.checked_mul(2)?.checked_add(a)?)?,
                u0: v.checked_add(a)?,
                ..problem
            };
            match job.stage {
                // (Begun by [`Ramps::begin`].)
                Stage::Asked => Some(None),
                // For the next tick (the peak, then the legs: two ticks on a core without
                // floating point in hardware), where the first round solves.
                Stage::Layout(fallback) => {
                    (job.counts, job.peak) = next.layout_head(fallback)?;
                    job.stage = Stage::Legs(fallback);
                    Some(None)
                }
                Stage::Legs(fallback) => {
                    next.layout_legs(&mut job.counts, job.peak, fallback)?;
                    job.stage = Stage::Round { fallback, round: 0 };
                    Some(None)
                }
                Stage::Round { fallback, round } => {
                    match problem.attempt_trapezoid(&mut job.counts, Some(&mut self.legs))? {
                        true => Some(Some((job.target2, job.last, made(fallback)))),
                        false if round + 1 < limits.rounds() => {
                            job.stage = Stage::Lengthen { fallback, round: round + 1 };
                            Some(None)
                        }
                        false if !fallback => {
                            job.stage = Stage::Layout(true);
                            Some(None)
                        }
                        false => None,
                    }
                }
                // A tick of its own: a round and this together were the dearest tick of a
                // plan.
                Stage::Lengthen { fallback, round } => {
                    next.attempt_trapezoid(&mut job.counts, None)?;
                    job.stage = Stage::Round { fallback, round };
                    Some(None)
                }
            }
        });
        match outcome {
            // A round that did not complete the plan: the provisional rule meanwhile.
            Some(None) if round => self.a = self.provisional(),
            Some(None) => {}
            Some(Some((end_p2, end_v, made))) => {
                self.job = None;
                self.jerk_job.stage = JerkStage::Idle;
                self.start(end_p2, end_v, made);
            }
            // No plan conformed (not seen in the tests; the fallback always has): stop instead.
            None => {
                let _ = self.velocity(0, &limits);
            }
        }
    }

    /// The acceleration of the next tick while a requested plan is being made: the simple rule
    /// of a trapezoid made online, so the axis answers the request at once. Towards the target
    /// at the acceleration while the velocity limit and the room to slow down to the end
    /// velocity allow; otherwise slowing down at the deceleration (to standstill exactly when
    /// the axis moves away from the target), or holding the velocity where it is at or below
    /// the end velocity (a target within a tick's travel is not passed and come back to). The rule keeps every limit; the plan then starts
    /// from wherever it has brought the axis.
    fn provisional(&self) -> i128 {
        let Some(job) = self.job.as_ref() else { return 0 };
        let limits = &job.limits();
        let distance2 = job.target2.saturating_sub(self.p2);
        // Along the target's direction (a sign is applied by negation: a 128-bit product by
        // ±1 is a long call on a Cortex-M).
        let toward_negative = distance2 < 0 || (distance2 == 0 && self.v > 0);
        let along = |x: i128| if toward_negative { x.saturating_neg() } else { x };
        let v = along(self.v);
        let slow_down = |by: i128| along(by.min(limits.deceleration).saturating_neg());
        if v < 0 {
            // Away from the target: slow down, to standstill exactly on the last tick.
            return along((-v).min(limits.deceleration));
        }
        if v > limits.velocity {
            return slow_down(v - limits.velocity);
        }
        // Room to slow down to the end velocity from the next tick's velocity, in twice the
        // distance (f32: only the choice depends on it).
        let speed = real(v.saturating_add(limits.acceleration));
        let stopping = (speed * speed - job.end_squared) * job.per_deceleration;
        let room = real(along(distance2)) - 2.0 * speed;
        if stopping >= room {
            // No room for the acceleration: slow down to the end velocity, or, at it or below
            // (e.g. a target closer than a tick's travel), hold the velocity (accelerating
            // would pass the target and come back).
            if v > job.last.saturating_abs() {
                slow_down(v - job.last.saturating_abs())
            } else {
                0
            }
        } else if distance2 == 0 {
            0
        } else {
            along(limits.acceleration.min(limits.velocity - v))
        }
    }

    /// True while a requested plan is being made (for the tests).
    #[cfg(test)]
    pub(crate) fn is_planning(&self) -> bool {
        self.job.is_some() || self.jerk_job.stage != JerkStage::Idle
    }

    fn start(&mut self, end_p2: i128, end_v: i128, made: Made) {
        self.next = 0;
        self.end_p2 = end_p2;
        self.end_v = end_v;
        self.remaining = self.legs.total();
        #[cfg(test)]
        {
            self.made = made;
            self.planned_from = (self.p2, self.v);
        }
        #[cfg(not(test))]
        let _ = made;
        self.left = 0;
        self.enter_next();
    }

    fn accel(&self) -> i128 {
        let done = self.ticks - self.left;
        if done < self.early || self.left <= self.late {
            self.base + 1
        } else {
            self.base
        }
    }

    /// Jerk-limited: the acceleration in sixths at tick `t` of the leg in progress (its pulse,
    /// and on the first leg the decay of the acceleration the plan started with).
    fn alpha_at(&self, t: u32) -> i128 {
        let leg = self.next.wrapping_sub(1);
        let pulse = self.legs.pulses.get(leg).unwrap_or(&Pulse::NONE);
        if leg != 0 {
            return pulse.alpha(t);
        }
        let decay = &self.legs.decay;
        let offset = self.legs.offset;
        let pulse = if t >= offset { pulse.alpha(t - offset) } else { 0 };
        decay.alpha(t).wrapping_add(pulse)
    }

    fn enter_next(&mut self) {
        match self.legs.get(self.next) {
            Some((ticks, _)) if self.jerk_limited => {
                self.next += 1;
                self.ticks = ticks;
                self.left = ticks;
                self.a = 0;
                self.alpha = self.alpha_at(0);
            }
            Some((ticks, aim)) => {
                self.next += 1;
                let change = aim.wrapping_sub(self.v);
                let base = div_floor(change, i128::from(ticks));
                let extra = change.wrapping_sub(base.wrapping_mul(i128::from(ticks)));
                let extra = u32::try_from(extra).unwrap_or(0);
                self.ticks = ticks;
                self.left = ticks;
                self.base = base;
                self.early = extra / 2;
                self.late = extra - extra / 2;
                self.a = self.accel();
            }
            None => {
                self.p2 = self.end_p2;
                self.v = self.end_v;
                self.a = 0;
                self.alpha = 0;
                self.left = 0;
            }
        }
    }

    /// Advances one tick. After the plan the state moves on at its end velocity.
    pub(crate) fn step(&mut self) {
        if self.left == 0 {
            // After a plan: on at its end velocity. While one is made: the provisional rule,
            // whose acceleration each share of the plan sets ([`Self::work`]) but for the
            // tick that asked (its share only begins the plan).
            // (Additions: a 128-bit product, even by 2, is a long library call on a Cortex-M0.)
            self.p2 = self.p2.saturating_add(self.v).saturating_add(self.v).saturating_add(self.a);
            self.v = self.v.saturating_add(self.a);
            if matches!(self.job.as_ref().map(|job| job.stage), Some(Stage::Asked)) {
                self.a = self.provisional();
            }
            return;
        }
        if self.jerk_limited {
            self.step_jerk();
            return;
        }
        self.p2 = self.p2.wrapping_add(self.v.wrapping_mul(2)).wrapping_add(self.a);
        self.v = self.v.wrapping_add(self.a);
        self.left -= 1;
        self.remaining = self.remaining.saturating_sub(1);
        if self.left == 0 {
            self.enter_next();
        } else {
            self.a = self.accel();
        }
    }

    /// A jerk-limited plan's tick (out of line: a trapezoid's tick does not need it): the
    /// acceleration `6α` now and `6α'` after, `p += v + 2α + α'`, `v += 3·(α + α')`.
    #[inline(never)]
    fn step_jerk(&mut self) {
        let next = self.alpha_at(self.ticks - self.left + 1);
        let (alpha, v) = (self.alpha, self.v);
        let step = v.wrapping_add(alpha.wrapping_mul(2)).wrapping_add(next);
        self.p2 = self.p2.wrapping_add(step.wrapping_mul(2));
        self.v = v.wrapping_add(alpha.wrapping_add(next).wrapping_mul(3));
        self.alpha = next;
        self.left -= 1;
        self.remaining = self.remaining.saturating_sub(1);
        if self.left == 0 {
            self.enter_next();
        }
    }

    /// True when every leg has been stepped and no plan is being made.
    pub(crate) fn is_finished(&self) -> bool {
        self.left == 0 && !self.planning()
    }

    /// A plan asked for is being made ([`Self::work`] has work).
    #[inline]
    pub(crate) fn planning(&self) -> bool {
        self.job.is_some() || self.jerk_job.stage != JerkStage::Idle
    }

    /// How the last plan was made (for the tests).
    #[cfg(test)]
    pub(crate) fn made(&self) -> Made {
        self.made
    }

    /// How far the last plan ends from its target before its last sample is set to it, in
    /// 2⁻⁶⁴ increments (for the tests): from the state the plan started in, each leg covers
    /// `n·(u + w)` (twice the distance) and its spreading `(early − late)·(n − extra)`.
    #[cfg(test)]
    pub(crate) fn closing_error(&self) -> i128 {
        if self.jerk_limited {
            return (self.end_p2 - self.planned_from.0 - self.legs.covered2) / 2;
        }
        let (mut p2, mut v) = self.planned_from;
        for (ticks, aim) in (0..self.legs.len).filter_map(|index| self.legs.get(index)) {
            let n = i128::from(ticks);
            let change = aim - v;
            let extra = change - div_floor(change, n) * n;
            let (early, late) = (extra / 2, extra - extra / 2);
            p2 += n * (v + aim) + (early - late) * (n - extra);
            v = aim;
        }
        (self.end_p2 - p2) / 2
    }
}

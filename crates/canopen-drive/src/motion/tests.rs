//! Property tests of the planners: a grid of distances and limits from rest, random re-plans in
//! mid-move, stops and velocity ramps. The checks work on the exact fixed-point state.
//!
//! Tolerances (fixed-point units are 2⁻⁶⁴ of the per-tick unit): velocity and acceleration at
//! most 10⁻⁴ relative plus 2⁻³⁰ per-tick units above the limit; jerk per tick at most 10⁻⁴
//! relative above the largest jerk plus 2⁻³⁰; the fitted profile ends within 2⁻¹⁰ increment of
//! the target (½ increment for plans over 10⁶ ticks) before the last sample is set to it.
//! The strict checks (every tick exactly within the limits, after any re-plan and with lowered
//! limits) are in `limit_tests`.

extern crate std;

use std::format;

use super::fixed::{per_tick, FRAC};
use super::ramps::Exact;
use super::*;

const TOLERANCE_UNITS: f64 = 17_179_869_184.0; // 2^34 units = 2^-30 per-tick units

pub(super) use crate::testing::Rng;

impl Rng {
    /// Uniform in [0, 1).
    pub(super) fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub(super) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    pub(super) fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }
}

/// Checks every tick against the limits and for jumps.
struct Checker {
    v_max: f64,
    a_max: f64,
    j_max: Option<f64>,
    /// Largest jerk seen, as a multiple of the limit.
    worst_jerk: f64,
    /// Largest velocity seen, as a multiple of the limit.
    worst_velocity: f64,
    /// Largest acceleration seen, as a multiple of the limit.
    worst_accel: f64,
    previous: Exact,
}

impl Checker {
    fn new(limits: &Limits, hz: u32, start: Exact) -> Self {
        let jerk = limits.jerk;
        let j = jerk.accel_start.max(jerk.accel_end).max(jerk.decel_start).max(jerk.decel_end);
        Checker {
            v_max: per_tick(limits.velocity, hz, 1) as f64,
            a_max: per_tick(limits.acceleration.max(limits.deceleration), hz, 2) as f64,
            j_max: match limits.profile {
                ProfileType::JerkLimited => Some(per_tick(j, hz, 3) as f64),
                ProfileType::Trapezoidal => None,
            },
            worst_jerk: 0.0,
            worst_velocity: 0.0,
            worst_accel: 0.0,
            previous: start,
        }
    }

    fn bound(limit: f64) -> f64 {
        limit * 1.0001 + TOLERANCE_UNITS
    }

    fn check(&mut self, now: Exact, context: &str) {
        let prev = self.previous;
        let (v, a) = (now.v as f64, now.a as f64);
        self.worst_velocity = self.worst_velocity.max(v.abs() / self.v_max);
        assert!(v.abs() <= Self::bound(self.v_max), "{context}: velocity {v} > {}", self.v_max);
        self.worst_accel = self.worst_accel.max(a.abs() / self.a_max);
        assert!(a.abs() <= Self::bound(self.a_max), "{context}: acceleration {a} > {}", self.a_max);
        // No jump in velocity: at most one tick of the largest acceleration.
        let dv = (now.v - prev.v) as f64;
        assert!(
            dv.abs() <= Self::bound(self.a_max),
            "{context}: velocity jump {dv} {prev:?} {now:?} amax {}",
            self.a_max
        );
        // No jump in position: the step is the mean velocity up to one tick of acceleration.
        let dp = (now.p - prev.p) as f64;
        let mean = (now.v as f64 + prev.v as f64) / 2.0;
        assert!((dp - mean).abs() <= Self::bound(self.a_max), "{context}: position jump {dp} vs {mean}");
        if let Some(j_max) = self.j_max {
            let da = (now.a - prev.a) as f64;
            self.worst_jerk = self.worst_jerk.max(da.abs() / j_max);
            assert!(da.abs() <= Self::bound(j_max), "{context}: jerk {da} > {j_max} {prev:?} {now:?}");
        }
        self.previous = now;
    }
}

fn fixed(position: i64) -> i128 {
    i128::from(position) << FRAC
}

/// Time-optimal rest-to-rest duration in seconds (trapezoid with A and D; S-curve with A = D
/// and one jerk), computed independently of the planner in f64.
fn optimal_duration(distance: f64, limits: &Limits) -> Option<f64> {
    let d = distance.abs();
    let (v, a, dcc) = (limits.velocity as f64, limits.acceleration as f64, limits.deceleration as f64);
    match limits.profile {
        ProfileType::Trapezoidal => {
            let full = v * v / (2.0 * a) + v * v / (2.0 * dcc);
            if d >= full {
                Some(v / a + v / dcc + (d - full) / v)
            } else {
                let vp = (2.0 * d * a * dcc / (a + dcc)).sqrt();
                Some(vp / a + vp / dcc)
            }
        }
        ProfileType::JerkLimited => {
            if limits.acceleration != limits.deceleration
                || limits.jerk != Jerks::uniform(limits.jerk.accel_start)
            {
                return None;
            }
            let j = limits.jerk.accel_start as f64;
            let ramp = |vp: f64| if vp >= a * a / j { vp / a + a / j } else { 2.0 * (vp / j).sqrt() };
            if v * ramp(v) <= d {
                return Some(2.0 * ramp(v) + (d - v * ramp(v)) / v);
            }
            let (mut lo, mut hi) = (0.0, v);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid * ramp(mid) < d {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            Some(2.0 * ramp(0.5 * (lo + hi)))
        }
    }
}

/// Most ticks a test steps through one plan; longer plans are checked at their fitted end.
const SIMULATED_TICKS: u32 = 300_000;

fn run_from_rest(start: i64, target: i64, limits: &Limits, hz: u32, context: &str) {
    let mut planner = PositionPlanner::new(TickRate::new(hz).unwrap(), start);
    let ticks = match planner.plan(target, 0, limits) {
        Ok(ticks) => ticks,
        Err(MotionError::TooLong) => {
            // Refused only when the optimal duration is long as well.
            if let Some(t) = optimal_duration((target - start) as f64, limits) {
                assert!(t * hz as f64 > 1.0e9, "{context}: refused a {t} s move");
            }
            return;
        }
        Err(e) => panic!("{context}: {e:?}"),
    };
    // Jerk rounding noise grows with the cube of a segment's length: below 2^-10 increment
    // for plans up to 10^6 ticks, below half an increment beyond.
    let closing = planner.closing_error().unsigned_abs();
    let allowed: u128 = if ticks <= 1_000_000 { 1 << 54 } else { 1 << 63 };
    assert!(closing <= allowed, "{context}: fitted end misses by {closing} units");
    if let Some(t) = optimal_duration((target - start) as f64, limits) {
        let optimal = t * hz as f64;
        assert!(f64::from(ticks) >= optimal * 0.999 - 1.0, "{context}: {ticks} ticks, optimal {optimal}");
        assert!(f64::from(ticks) <= optimal * 1.001 + 10.0, "{context}: {ticks} ticks, optimal {optimal}");
    }
    if ticks > SIMULATED_TICKS {
        return;
    }
    let mut checker = Checker::new(limits, hz, planner.exact());
    for tick in 0..ticks {
        assert!(!planner.is_finished(), "{context}: finished early at {tick}");
        let state = planner.step();
        checker.check(planner.exact(), context);
        if tick + 1 == ticks {
            assert_eq!(state.position, target, "{context}");
        }
    }
    assert!(planner.is_finished(), "{context}");
    assert_eq!(planner.exact(), Exact { p: fixed(target), v: 0, a: 0 }, "{context}");
    // And it stays there.
    planner.step();
    assert_eq!(planner.exact(), Exact { p: fixed(target), v: 0, a: 0 }, "{context}");
}

#[test]
fn grid_from_rest_reaches_the_target_exactly() {
    let moves: [(i64, i64); 10] = [
        (0, 0),
        (0, 1),
        (0, -1),
        (5, 12),
        (1000, -2345),
        (-7, 123_457),
        (i64::from(i32::MIN), i64::from(i32::MAX)),
        (i64::from(i32::MAX), i64::from(i32::MIN)),
        (i64::from(i32::MAX) - 3, i64::from(i32::MAX) + 100_000),
        (0, 40_000_000),
    ];
    let velocities = [1u32, 1000, 1_000_000, u32::MAX];
    let ramps = [1u32, 1000, 3_000_000, u32::MAX];
    let jerks = [1u32, 100_000, 1_000_000_000, u32::MAX];
    for &(start, target) in &moves {
        for &velocity in &velocities {
            for &acceleration in &ramps {
                for &deceleration in &[acceleration, acceleration / 3 + 1] {
                    let trapezoid = Limits::new(velocity, acceleration, deceleration);
                    let context = format!("{start}->{target} {trapezoid:?}");
                    run_from_rest(start, target, &trapezoid, 1000, &context);
                    for &jerk in &jerks {
                        let scurve = trapezoid.with_jerk(ProfileType::JerkLimited, jerk);
                        let context = format!("{start}->{target} {scurve:?}");
                        run_from_rest(start, target, &scurve, 1000, &context);
                    }
                }
            }
        }
    }
}

#[test]
fn per_corner_jerks_and_fast_ticks() {
    let jerks =
        Jerks { accel_start: 2_000_000, accel_end: 500_000, decel_start: 8_000_000, decel_end: 1_000_000 };
    let limits = Limits::new(50_000, 400_000, 900_000).with_jerks(ProfileType::JerkLimited, jerks);
    for &hz in &[1000, 16_000] {
        for &target in &[1, 17, 3_000, -60_000, 250_000] {
            run_from_rest(100, target, &limits, hz, &format!("{hz} Hz to {target}"));
        }
    }
}

fn random_limits(rng: &mut Rng, profile: ProfileType) -> Limits {
    let velocity = rng.log_range(10.0, 2.0e6);
    let acceleration = velocity * rng.log_range(1.0, 200.0);
    let deceleration = velocity * rng.log_range(1.0, 200.0);
    let limits = Limits::new(velocity as u32, acceleration as u32, deceleration as u32);
    let jerk = acceleration.max(deceleration) * rng.log_range(1.0, 500.0);
    match profile {
        ProfileType::Trapezoidal => limits,
        ProfileType::JerkLimited => limits.with_jerk(profile, jerk.min(4.0e9) as u32),
    }
}

#[test]
fn random_replans_are_continuous_and_land_exactly() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut worst_jerk: f64 = 0.0;
    let mut worst_accel: f64 = 0.0;
    let mut worst_velocity: f64 = 0.0;
    for scenario in 0..300 {
        let profile = if scenario % 2 == 0 { ProfileType::Trapezoidal } else { ProfileType::JerkLimited };
        let limits = random_limits(&mut rng, profile);
        let hz = if scenario % 3 == 0 { 16_000 } else { 2000 };
        let start = (rng.range(-2.0e9, 2.0e9)) as i64;
        let mut planner = PositionPlanner::new(TickRate::new(hz).unwrap(), start);
        let mut checker = Checker::new(&limits, hz, planner.exact());
        // Same limits throughout, so no state ever exceeds them: the plain tolerance holds
        // (the exact per-tick guarantee, with lowered limits too, is in `limit_tests`).
        let mut target = start;
        for replan in 0..6 {
            // Targets within a few seconds of travel; sometimes behind, sometimes the same.
            let span = f64::from(limits.velocity) * rng.range(0.0, 3.0);
            target = match rng.next() % 5 {
                0 => target,
                1 => planner.state().position,
                _ => planner.state().position + rng.range(-span, span) as i64,
            };
            let context = format!("scenario {scenario} replan {replan} {limits:?} {hz} Hz to {target}");
            let ticks = planner.plan(target, 0, &limits).unwrap_or_else(|e| panic!("{context}: {e:?}"));
            assert!(ticks < 2_000_000, "{context}: {ticks} ticks");
            assert!(
                planner.closing_error().unsigned_abs() <= 1 << 54,
                "{context}: {}",
                planner.closing_error()
            );
            let run = if replan == 5 { ticks } else { (rng.unit() * f64::from(ticks) * 1.2) as u32 };
            for _ in 0..run {
                planner.step();
                checker.check(planner.exact(), &context);
            }
        }
        assert!(planner.is_finished(), "scenario {scenario}");
        assert_eq!(planner.exact(), Exact { p: fixed(target), v: 0, a: 0 }, "scenario {scenario}");
        worst_jerk = worst_jerk.max(checker.worst_jerk);
        worst_accel = worst_accel.max(checker.worst_accel);
        worst_velocity = worst_velocity.max(checker.worst_velocity);
    }
    std::eprintln!(
        "worst after re-plans: velocity {worst_velocity:.5}, acceleration {worst_accel:.4}, jerk {worst_jerk:.3} × the limit"
    );
}

#[test]
fn end_velocity_passes_the_target_moving() {
    let limits = Limits::new(10_000, 50_000, 50_000).with_jerk(ProfileType::JerkLimited, 1_000_000);
    let mut planner = PositionPlanner::new(TickRate::new(1000).unwrap(), 0);
    let ticks = planner.plan(20_000, 4_000, &limits).unwrap();
    for _ in 0..ticks {
        planner.step();
    }
    assert_eq!(planner.exact(), Exact { p: fixed(20_000), v: per_tick(4_000, 1000, 1), a: 0 });
    // Moves on at the end velocity until the next set-point, then continues smoothly.
    assert_eq!(planner.step().position, 20_004);
    let mut checker = Checker::new(&limits, 1000, planner.exact());
    let ticks = planner.plan(30_000, 0, &limits).unwrap();
    for _ in 0..ticks {
        planner.step();
        checker.check(planner.exact(), "continue");
    }
    assert_eq!(planner.state().position, 30_000);
}

#[test]
fn stop_in_mid_move_and_resume() {
    for profile in [ProfileType::Trapezoidal, ProfileType::JerkLimited] {
        let limits = Limits::new(100_000, 200_000, 300_000).with_jerk(profile, 5_000_000);
        let mut planner = PositionPlanner::new(TickRate::new(4000).unwrap(), 0);
        planner.plan(1_000_000, 0, &limits).unwrap();
        let mut checker = Checker::new(&limits, 4000, planner.exact());
        for _ in 0..2000 {
            planner.step();
            checker.check(planner.exact(), "move");
        }
        let quick_stop = 1_000_000;
        let ticks = planner.stop(quick_stop, &limits).unwrap();
        let stop_limits = Limits { acceleration: quick_stop, deceleration: quick_stop, ..limits };
        let mut checker = Checker::new(&stop_limits, 4000, planner.exact());
        let mut last = planner.state().position;
        for _ in 0..ticks {
            let state = planner.step();
            checker.check(planner.exact(), "stop");
            assert!(state.position >= last, "a stop never reverses");
            last = state.position;
        }
        assert!(planner.is_finished());
        assert_eq!(planner.exact().v, 0);
        assert_eq!(planner.exact().a, 0);
        // Halt released: the positioning continues to the same target.
        let ticks = planner.plan(1_000_000, 0, &limits).unwrap();
        for _ in 0..ticks {
            planner.step();
        }
        assert_eq!(planner.state().position, 1_000_000);
    }
}

#[test]
fn velocity_ramp_reaches_each_target_exactly() {
    let mut rng = Rng(42);
    for profile in [ProfileType::Trapezoidal, ProfileType::JerkLimited] {
        let limits = Limits::new(3_000_000, 1_000_000, 2_000_000).with_jerk(profile, 20_000_000);
        let mut ramp = VelocityRamp::new(TickRate::new(8000).unwrap());
        let mut checker = Checker::new(&limits, 8000, ramp.exact());
        for step in 0..40 {
            let target = rng.range(-3.5e6, 3.5e6) as i32;
            let ticks = ramp.set_target(target, &limits).unwrap();
            let run = if step % 4 == 3 { ticks } else { (rng.unit() * f64::from(ticks)) as u32 };
            for _ in 0..run {
                ramp.step();
                let exact = ramp.exact();
                // Position is not limited here; only velocity and acceleration.
                checker.check(
                    Exact { p: checker.previous.p + (checker.previous.v + exact.v) / 2, ..exact },
                    "ramp",
                );
            }
            if run == ticks {
                let clamped = target.clamp(-3_000_000, 3_000_000);
                assert_eq!(
                    ramp.exact().v,
                    per_tick(clamped.unsigned_abs(), 8000, 1) * i128::from(clamped.signum())
                );
                assert_eq!(ramp.state().velocity, i64::from(clamped));
                assert!(ramp.is_finished());
            }
        }
        let ticks = ramp.stop(5_000_000, &limits).unwrap();
        for _ in 0..ticks {
            ramp.step();
        }
        assert_eq!(ramp.exact().v, 0);
    }
}

#[test]
fn edge_limits_are_refused_not_panicking() {
    let rate = TickRate::new(1000).unwrap();
    let mut planner = PositionPlanner::new(rate, 0);
    let good = Limits::new(1000, 1000, 1000).with_jerk(ProfileType::JerkLimited, 1000);
    assert_eq!(planner.plan(10, 0, &Limits { velocity: 0, ..good }), Err(MotionError::ZeroVelocity));
    assert_eq!(planner.plan(10, 0, &Limits { acceleration: 0, ..good }), Err(MotionError::ZeroAcceleration));
    assert_eq!(planner.plan(10, 0, &Limits { deceleration: 0, ..good }), Err(MotionError::ZeroDeceleration));
    assert_eq!(planner.plan(10, 0, &good.with_jerk(ProfileType::JerkLimited, 0)), Err(MotionError::ZeroJerk));
    assert_eq!(planner.plan(POSITION_RANGE + 1, 0, &good), Err(MotionError::OutOfRange));
    assert_eq!(planner.stop(0, &good), Err(MotionError::ZeroDeceleration));
    assert_eq!(TickRate::new(0), Err(MotionError::TickRate));
    assert_eq!(TickRate::new(2_000_000), Err(MotionError::TickRate));
    // A trapezoid ignores the jerk.
    assert!(planner.plan(10, 0, &good.with_jerk(ProfileType::Trapezoidal, 0)).is_ok());
    // Nothing moved after the refusals but the last plan.
    assert_eq!(planner.state().velocity, 0);
    // A plan lasting longer than u32::MAX ticks.
    let slow = Limits::new(1, 1, 1);
    assert_eq!(planner.plan(POSITION_RANGE, 0, &slow), Err(MotionError::TooLong));
    // A ramp with every maximal limit.
    let mut ramp = VelocityRamp::new(TickRate::new(1_000_000).unwrap());
    let max = Limits::new(u32::MAX, u32::MAX, u32::MAX).with_jerk(ProfileType::JerkLimited, u32::MAX);
    let ticks = ramp.set_target(i32::MIN, &max).unwrap();
    for _ in 0..ticks {
        ramp.step();
    }
    assert_eq!(ramp.state().velocity, i64::from(i32::MIN));
}

#[test]
fn profile_objects() {
    assert_eq!(ProfileType::from_raw(0), Some(ProfileType::Trapezoidal));
    assert_eq!(ProfileType::from_raw(3), Some(ProfileType::JerkLimited));
    assert_eq!(ProfileType::from_raw(1), None);
    let jerks = Jerks::from_profile_jerk(4, &[1, 2, 3, 4]).unwrap();
    assert_eq!(jerks, Jerks { accel_start: 1, accel_end: 3, decel_start: 2, decel_end: 4 });
    assert_eq!(
        Jerks::from_profile_jerk(2, &[1, 2]),
        Some(Jerks { accel_start: 1, accel_end: 1, decel_start: 2, decel_end: 2 })
    );
    assert_eq!(Jerks::from_profile_jerk(4, &[1, 2]), None);
    assert_eq!(Jerks::from_profile_jerk(6, &[1, 2, 3, 4, 5, 6]), None);
    let state = MotionState { position: i64::from(i32::MAX) + 1, velocity: 1 << 40, acceleration: 0 };
    assert_eq!(state.position_demand(), i32::MIN);
    assert_eq!(state.velocity_demand(), i32::MAX);
}

#[test]
fn end_velocity_at_the_velocity_limit_is_planned() {
    // Change on set-point passes intermediate targets at the profile velocity itself.
    let rate = TickRate::new(1000).unwrap();
    for limits in [
        Limits::new(20_000, 200_000, 200_000),
        Limits::new(20_000, 200_000, 200_000).with_jerk(ProfileType::JerkLimited, 10_000_000),
    ] {
        for pre in [0, 3, 50] {
            let mut planner = PositionPlanner::new(rate, 0);
            planner.plan(5000, 0, &limits).unwrap();
            for _ in 0..pre {
                planner.step();
            }
            assert!(planner.plan(5000, 20_000, &limits).is_ok(), "{limits:?} after {pre} ticks");
            let mut passing = None;
            for _ in 0..2000 {
                let s = planner.step();
                assert!(s.velocity <= 20_000);
                if s.position >= 5000 {
                    passing = Some(s.velocity);
                    break;
                }
            }
            let v = passing.unwrap();
            assert!(v >= 19_990, "passes the target at the limit: {v}");
        }
    }
}

#[test]
fn requested_plans_land_like_immediate_ones() {
    // A plan made over several ticks (`request`) holds the velocity meanwhile, stays within
    // the limits tick by tick, lands exactly, and takes at most a few ticks more than the plan
    // made at once.
    let worst = requested_plans(ProfileType::Trapezoidal, 2000);
    std::eprintln!("a requested trapezoid takes at most {worst} ticks more than one made at once");
}

#[test]
fn requested_jerk_limited_plans_land_like_immediate_ones() {
    // The same for the jerk-limited profile: the plan is made for the state of the request
    // while the axis ramps its acceleration out and coasts (the start of that plan), so the
    // checker runs from the request on.
    let worst = requested_plans(ProfileType::JerkLimited, 1000);
    std::eprintln!("a requested jerk-limited plan takes at most {worst} ticks more than one made at once");
}

/// Requests over random scenarios of `profile`, each checked tick by tick and landing exactly;
/// returns the most ticks one took beyond the plan made at once.
fn requested_plans(profile: ProfileType, scenarios: usize) -> i64 {
    let trapezoid = matches!(profile, ProfileType::Trapezoidal);
    let mut rng = Rng(0x0A11_5EED);
    let mut worst_extra = 0i64;
    for scenario in 0..scenarios {
        let limits = random_limits(&mut rng, profile);
        let hz = [1000, 4000, 16_000][scenario % 3];
        let mut planner = PositionPlanner::new(TickRate::new(hz).unwrap(), 0);
        let first = (f64::from(limits.velocity) * rng.range(-2.0, 2.0)) as i64;
        planner.plan(first, 0, &limits).unwrap();
        let run = (rng.unit() * 3.0 * f64::from(hz)) as u32;
        for _ in 0..run {
            planner.step();
        }
        let target = planner.state().position + (f64::from(limits.velocity) * rng.range(-2.0, 2.0)) as i64;
        let before = planner.exact();
        let context = format!("scenario {scenario}: {limits:?} at {hz} Hz from {before:?} to {target}");
        let at_once = planner.clone().plan(target, 0, &limits).unwrap();
        planner.request(target, 0, &limits).unwrap_or_else(|e| panic!("{context}: {e:?}"));
        let mut checker = super::limit_tests::Strict::new(&limits, hz, before);
        let mut ticks = 0u32;
        while !planner.is_finished() {
            let planning = planner.is_planning();
            let previous = planner.exact();
            planner.step();
            if trapezoid && planning && !planner.is_planning() {
                // The plan starts in this tick: a re-plan from the held state, checked as one.
                checker = super::limit_tests::Strict::new(&limits, hz, previous);
            }
            checker.check(planner.exact()).unwrap_or_else(|e| panic!("{context} at tick {ticks}: {e}"));
            ticks += 1;
            assert!(ticks < 50_000_000, "{context}: never finished");
        }
        assert_eq!(
            planner.exact(),
            Exact { p: fixed(target), v: 0, a: 0 },
            "{context} ({:?})",
            planner.method()
        );
        worst_extra = worst_extra.max(i64::from(ticks) - i64::from(at_once));
    }
    worst_extra
}

#[test]
fn requested_stops_land_like_immediate_ones() {
    // A stop made over several ticks (`request_stop`, as a drive's halt and quick stop): from
    // any point of a move, within the stop's limits tick by tick from the request on, never
    // reversing, at standstill with no acceleration when finished, and at most a few ticks
    // longer than the stop made at once (the coast while its pulse is fitted).
    let mut rng = Rng(0x57_0915);
    let mut worst_extra = [0i64; 2];
    let mut extras = std::vec::Vec::<i64>::new();
    for scenario in 0..1200 {
        let jerk_limited = scenario % 2 == 1;
        let profile = if jerk_limited { ProfileType::JerkLimited } else { ProfileType::Trapezoidal };
        let limits = random_limits(&mut rng, profile);
        let hz = [1000, 4000, 16_000][scenario % 3];
        let mut planner = PositionPlanner::new(TickRate::new(hz).unwrap(), 0);
        let target = (f64::from(limits.velocity) * rng.range(-2.0, 2.0)) as i64;
        let ticks = planner.plan(target, 0, &limits).unwrap();
        for _ in 0..(rng.unit() * f64::from(ticks)) as u32 {
            planner.step();
        }
        let deceleration = (f64::from(limits.deceleration) * rng.range(0.5, 2.0)) as u32 + 1;
        let before = planner.exact();
        let context = format!(
            "scenario {scenario}: {limits:?} at {hz} Hz from {before:?}, deceleration {deceleration}"
        );
        let at_once = planner.clone().stop(deceleration, &limits).unwrap();
        planner.request_stop(deceleration, &limits).unwrap_or_else(|e| panic!("{context}: {e:?}"));
        let stop_limits = Limits { acceleration: deceleration, deceleration, ..limits };
        let mut checker = super::limit_tests::Strict::new(&stop_limits, hz, before);
        let direction = before.v.signum();
        let mut ticks = 0u32;
        while !planner.is_finished() {
            let previous = planner.exact();
            planner.step();
            let now = planner.exact();
            checker.check(now).unwrap_or_else(|e| panic!("{context} at tick {ticks}: {e}"));
            assert!(
                (now.p - previous.p) * direction >= 0,
                "{context} at tick {ticks}: a stop never reverses"
            );
            ticks += 1;
            assert!(ticks < 50_000_000, "{context}: never finished");
        }
        assert_eq!((planner.exact().v, planner.exact().a), (0, 0), "{context}");
        if jerk_limited {
            extras.push(i64::from(ticks) - i64::from(at_once));
        }
        let extra = &mut worst_extra[usize::from(jerk_limited)];
        *extra = (*extra).max(i64::from(ticks) - i64::from(at_once));
    }
    extras.sort_unstable();
    let share = |q: usize| extras.get(extras.len() * q / 100).copied().unwrap_or(0);
    std::eprintln!(
        "a requested stop takes at most {} ticks (trapezoid) and {} ticks (jerk-limited) more than one made at once; jerk-limited: median {}, 90 % {}, 99 % {}",
        worst_extra[0],
        worst_extra[1],
        share(50),
        share(90),
        share(99)
    );
    assert!(worst_extra[0] <= 0, "a trapezoid's stop is made at once");
    assert!(worst_extra[1] <= 8, "{} ticks more", worst_extra[1]);
}

#[test]
fn a_requested_move_shorter_than_a_ticks_travel_does_not_pass_its_target() {
    // While the plan is made, the provisional rule holds where accelerating would carry the axis
    // past the target (it came back from there: a move of 2 increments went 4 past it, then
    // back towards the start at the full acceleration). From rest, every demand lies between
    // the start and the target.
    for (hz, acceleration) in [(1000, 4_000_000), (1000, 40_000), (4000, 4_000_000), (16_000, 1_000_000)] {
        let limits =
            Limits { velocity: 400_000, acceleration, deceleration: acceleration, ..Limits::default() };
        for target in -40i64..=40 {
            let mut planner = PositionPlanner::new(TickRate::new(hz).unwrap(), 0);
            planner.request(target, 0, &limits).unwrap();
            let mut ticks = 0;
            while !planner.is_finished() {
                let position = planner.step().position;
                assert!(
                    (target.min(0)..=target.max(0)).contains(&position),
                    "{hz} Hz, {acceleration} increments/s², target {target}: demand at {position}"
                );
                ticks += 1;
                assert!(ticks < 10_000, "never finished");
            }
            assert_eq!(planner.state().position, target);
        }
    }
}

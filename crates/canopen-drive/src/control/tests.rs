//! Closed-loop tests of the cascade against a simulated axis, anti-windup, bumpless transfer,
//! and a randomised sweep of extreme inputs.
//!
//! The simulated axis is a rigid inertia with viscous friction and a constant load torque
//! (gravity-like), integrated in `f64` with ten sub-steps per tick. Its sensors are ideal but
//! quantised: the position is the floor of the true position in whole increments (plus an
//! offset, to put the 32-bit counter's wrap inside a move), the velocity is rounded to
//! increments/s.

extern crate std;

use std::vec::Vec;

use super::parameters::{MAX_TORQUE_LIMIT, MAX_VELOCITY_LIMIT};
use super::*;

const HZ: u32 = 10_000;

/// Acceleration of the axis per ‰ of rated torque, increments/s² (4096 increments per turn:
/// the rated torque accelerates the motor by some 240 turns/s²).
const ACCELERATION_PER_MILLE: f64 = 1000.0;

/// Tuning for the simulated axis: velocity loop crossover Kp_vel · K ≈ 500 rad/s, Tn = 4/ω,
/// position loop a fifth of the velocity loop.
const TUNED: Parameters = Parameters {
    position_gain: 100 << 16,
    velocity_gain: 1 << 23, // 0.5 ‰ per increment/s
    integral_time_us: 8_000,
    velocity_limit: 200_000,
    torque_limit: 3000,
};

struct Axis {
    /// True position relative to `origin`, increments.
    position: f64,
    /// True velocity, increments/s.
    velocity: f64,
    /// Viscous friction, ‰ per increment/s.
    friction: f64,
    /// Constant load torque, ‰ (positive pulls towards negative positions).
    load: f64,
    /// Counter value at true position 0.
    origin: i32,
}

impl Axis {
    fn new(origin: i32) -> Self {
        Axis { position: 0.0, velocity: 0.0, friction: 0.002, load: 150.0, origin }
    }

    fn actual(&self) -> Actual {
        Actual {
            position: self.origin.wrapping_add(self.position.floor() as i32),
            velocity: self.velocity.round() as i32,
        }
    }

    fn advance(&mut self, torque: i16) {
        let dt = 1.0 / f64::from(HZ) / 10.0;
        for _ in 0..10 {
            let net = f64::from(torque) - self.load - self.friction * self.velocity;
            self.velocity += net * ACCELERATION_PER_MILLE * dt;
            self.position += self.velocity * dt;
        }
    }

    /// Counter value of a position relative to the origin.
    fn counter(&self, relative: i64) -> i32 {
        self.origin.wrapping_add(relative as i32)
    }
}

/// Runs the position cascade for `ticks`, with the demand (relative position, velocity
/// feed-forward) given per tick index; returns the position error (demand − true position, at
/// the sampling instant) and the output of each tick.
fn run(
    cascade: &mut Cascade,
    axis: &mut Axis,
    ticks: usize,
    demand: impl Fn(usize) -> (i64, i32),
) -> Vec<(f64, Output)> {
    let mut trace = Vec::with_capacity(ticks);
    for n in 0..ticks {
        let (position, velocity) = demand(n);
        let reference = Reference { position: axis.counter(position), velocity, torque: 0 };
        let error = position as f64 - axis.position;
        let out = cascade.step(reference, axis.actual());
        assert!(out.torque.unsigned_abs() <= cascade.torque_limit());
        assert!(out.velocity.unsigned_abs() <= cascade.velocity_limit());
        axis.advance(out.torque);
        trace.push((error, out));
    }
    trace
}

fn tuned() -> Cascade {
    Cascade::new(HZ, TUNED).unwrap()
}

/// Holds the axis at its origin for 200 ms (the integrator learns the load), then steps the
/// demand by `step`; returns the error trace of the step.
fn step_response(cascade: &mut Cascade, axis: &mut Axis, step: i64, ticks: usize) -> Vec<(f64, Output)> {
    let hold = run(cascade, axis, 2000, |_| (0, 0));
    assert!(hold.last().unwrap().0.abs() < 1.0);
    assert!((i32::from(cascade.integral()) - 150).abs() <= 2, "integral {}", cascade.integral());
    run(cascade, axis, ticks, |_| (step, 0))
}

fn overshoot(trace: &[(f64, Output)]) -> f64 {
    trace.iter().map(|(e, _)| -e).fold(0.0, f64::max)
}

fn worst_error(trace: &[(f64, Output)]) -> f64 {
    trace.iter().map(|(e, _)| e.abs()).fold(0.0, f64::max)
}

#[test]
fn position_step_settles_without_steady_state_error() {
    // Across the counter's wrap and away from it.
    for origin in [0, i32::MAX - 100, i32::MIN + 5] {
        // A short step: the torque demand saturates at first.
        let mut cascade = tuned();
        let mut axis = Axis::new(origin);
        let step = 200;
        let trace = step_response(&mut cascade, &mut axis, step, 5000);
        assert!(trace.iter().take(20).all(|(_, out)| out.torque_limited), "the step saturates");
        assert!(overshoot(&trace) < 1.0, "overshoot {} increments", overshoot(&trace));
        // Settled within 70 ms (ln 200 position-loop time constants of 10 ms, plus the
        // saturated start) to the quantisation of the encoder, and stays there.
        let worst = worst_error(&trace[700..]);
        assert!(worst <= 1.0, "error {worst} increments after 70 ms");
        // No steady-state error: the counter reads the demand, the mean error is below one
        // increment (the encoder's floor puts the true position up to one increment above).
        let error = axis.counter(step).wrapping_sub(axis.actual().position);
        assert!(error.abs() <= 1, "counter error {error}");
        let tail = &trace[4000..];
        let mean = tail.iter().map(|(e, _)| e).sum::<f64>() / tail.len() as f64;
        assert!(mean.abs() <= 1.0, "mean error {mean}");
    }
}

#[test]
fn long_saturated_move_lands_without_overshoot() {
    // The velocity limit is chosen so that the position loop never asks for more deceleration
    // than the torque limit gives (Kp_pos · v_max = 2.5·10⁶ increments/s² < 3·10⁶): a linear
    // position loop cannot do better than that on its own; the profile's ramps do the rest.
    let mut cascade = tuned();
    cascade.set_limits(25_000, 3000);
    let mut axis = Axis::new(i32::MAX - 50_000); // wraps half-way
    let step = 100_000;
    let trace = step_response(&mut cascade, &mut axis, step, 60_000);
    assert!(trace.iter().take(50).any(|(_, out)| out.torque_limited), "the start saturates the torque");
    let at_limit = trace.iter().filter(|(_, out)| out.velocity_limited).count();
    assert!(at_limit > 35_000, "the move cruises at the velocity limit ({at_limit} ticks)");
    assert!(overshoot(&trace) < 1.0, "overshoot {} increments", overshoot(&trace));
    // 4 s at 25 000 increments/s, then some 60 ms to land.
    let landed = worst_error(&trace[40_700..]);
    assert!(landed <= 1.0, "error {landed} increments after landing");
}

#[test]
fn ramp_is_tracked_with_velocity_feed_forward() {
    let speed: i64 = 20_000; // increments/s
    let ramp = move |n: usize| speed * n as i64 / i64::from(HZ);
    let mut errors = [0.0; 2];
    for (with_feed_forward, worst) in [true, false].into_iter().zip(errors.iter_mut()) {
        let mut cascade = tuned();
        let mut axis = Axis::new(i32::MAX - 5000); // the ramp crosses the wrap
        run(&mut cascade, &mut axis, 2000, |_| (0, 0));
        let feed_forward = if with_feed_forward { speed as i32 } else { 0 };
        let trace = run(&mut cascade, &mut axis, 5000, |n| (ramp(n), feed_forward));
        // After 100 ms the start-up transient has died out.
        *worst = trace[1000..].iter().map(|(e, _)| e.abs()).fold(0.0, f64::max);
    }
    let [with, without] = errors;
    assert!(with <= 1.0, "error with feed-forward {with} increments");
    // Without feed-forward the position loop needs an error of v / Kp_pos = 200 increments.
    assert!((190.0..=210.0).contains(&without), "error without feed-forward {without}");
}

#[test]
fn anti_windup_releases_the_limit_at_once() {
    let parameters = Parameters { velocity_gain: 1 << 20, torque_limit: 500, ..TUNED }; // 1/16 ‰ per inc/s
    let mut cascade = Cascade::new(HZ, parameters).unwrap();
    // A blocked rotor: the demand asks for 1600 increments/s, the axis does not move, for
    // 10 s. The proportional part alone is 100 ‰; the integral part takes the demand to the
    // 500 ‰ limit within a few integral times and the demand stays there.
    for n in 0..100_000 {
        let out = cascade.step_velocity(1600, 0, 0);
        assert_eq!(out.torque_limited, n >= 320, "tick {n}: {out:?}");
    }
    // 400 ‰ (limit − P) plus at most the one increment of the tick that reached the limit.
    assert!(cascade.integral() <= 402, "integral {} wound up", cascade.integral());
    // The error reverses: the demand leaves the limit on the very first tick (P = −100 ‰).
    let out = cascade.step_velocity(-1600, 0, 0);
    assert!(!out.torque_limited);
    assert!(out.torque <= 302, "torque {} after reversal", out.torque);
    // And it reaches the opposite limit within a few integral times, not after 10 s.
    let ticks = (0..10_000).position(|_| cascade.step_velocity(-1600, 0, 0).torque == -500).unwrap();
    assert!(ticks < 1000, "{ticks} ticks to the opposite limit");
}

#[test]
fn integrator_holds_while_the_feed_forward_saturates() {
    let mut cascade = tuned();
    for _ in 0..10_000 {
        let out = cascade.step_velocity(10, 3000, 0);
        assert_eq!(out.torque, 3000);
    }
    assert_eq!(cascade.integral(), 0);
    // Winding in the other direction is allowed: it brings the demand back inside.
    for _ in 0..100 {
        cascade.step_velocity(-10, 3000, 0);
    }
    assert!(cascade.integral() < 0);
}

#[test]
fn reset_is_bumpless() {
    let mut cascade = tuned();
    for _ in 0..1000 {
        cascade.step_velocity(100, 0, 0);
    }
    assert!(cascade.integral() > 100);
    let here = Actual { position: -7, velocity: 0 };
    let still = Reference { position: -7, velocity: 0, torque: 0 };
    cascade.reset(0);
    assert_eq!(cascade.step(still, here).torque, 0);
    cascade.reset(250);
    assert_eq!(cascade.step(still, here).torque, 250);
    cascade.reset(i16::MIN);
    assert_eq!(cascade.integral(), -3000);
    assert_eq!(cascade.step(still, here).torque, -3000);
}

#[test]
fn switching_loops_and_retuning_keep_the_torque() {
    let mut cascade = tuned();
    let mut axis = Axis::new(12345);
    run(&mut cascade, &mut axis, 3000, |_| (0, 0));
    let holding = cascade.integral();
    assert!((holding - 150).abs() <= 2);
    // Velocity loop alone, at standstill: the same holding torque.
    let out = cascade.step_velocity(0, 0, 0);
    assert_eq!(out.torque, holding);
    // New gains: the integrator keeps the learnt load.
    cascade.set_parameters(Parameters { velocity_gain: 1 << 22, integral_time_us: 20_000, ..TUNED }).unwrap();
    assert_eq!(cascade.step_velocity(0, 0, 0).torque, holding);
    // Refused parameters leave everything as it was.
    let before = cascade.clone();
    assert_eq!(
        cascade.set_parameters(Parameters { integral_time_us: 50, ..TUNED }),
        Err(ParameterError::IntegralTimeBelowTick)
    );
    assert_eq!(cascade, before);
}

#[test]
fn outside_limits_apply_at_once() {
    let mut cascade = tuned();
    cascade.reset(2500);
    cascade.set_limits(1000, 100);
    assert_eq!((cascade.velocity_limit(), cascade.torque_limit()), (1000, 100));
    assert_eq!(cascade.integral(), 100, "the integrator is cut to the new limit");
    let out = cascade.step(Reference { position: 1_000_000, velocity: 0, torque: 0 }, Actual::default());
    assert_eq!((out.velocity, out.torque), (1000, 100));
    assert!(out.velocity_limited && out.torque_limited);
    // The parameters' own limits still bound larger outside limits; 0 holds the output at 0.
    cascade.set_limits(u32::MAX, u16::MAX);
    assert_eq!((cascade.velocity_limit(), cascade.torque_limit()), (200_000, 3000));
    cascade.set_limits(0, 0);
    let out = cascade
        .step(Reference { position: i32::MAX, velocity: i32::MAX, torque: i16::MAX }, Actual::default());
    assert_eq!((out.velocity, out.torque), (0, 0));
    assert_eq!(cascade.integral(), 0);
}

#[test]
fn new_refuses_invalid_parameters() {
    assert_eq!(Cascade::new(0, TUNED).err(), Some(ParameterError::TickRateZero));
    assert_eq!(
        Cascade::new(HZ, Parameters { torque_limit: 0, ..TUNED }).err(),
        Some(ParameterError::TorqueLimitZero)
    );
    let cascade = Cascade::new(HZ, Parameters::DEFAULT).unwrap();
    assert_eq!(cascade.tick_hz(), HZ);
    assert_eq!(cascade.parameters(), &Parameters::DEFAULT);
    // Ki per tick = Kp · T / Tn = 0.01 · 100 µs / 20 ms.
    let expected = 0.01 * 100.0 / 20_000.0;
    assert!((cascade.integral_gain_value() / expected - 1.0).abs() < 1e-6);
}

use crate::testing::Rng;

impl Rng {
    /// An edge value half of the time, any value otherwise.
    fn u32(&mut self, edges: &[u32]) -> u32 {
        let raw = self.next();
        match (raw >> 40) as usize % (2 * edges.len()) {
            i if i < edges.len() => edges[i],
            _ => raw as u32,
        }
    }

    fn i32(&mut self) -> i32 {
        self.u32(&[0, 1, u32::MAX, i32::MAX as u32, i32::MIN as u32, i32::MIN as u32 + 1]) as i32
    }

    fn i16(&mut self) -> i16 {
        self.u32(&[0, 1, u32::MAX, 0x7FFF, 0xFFFF_8000]) as i16
    }
}

fn random_parameters(rng: &mut Rng) -> (u32, Parameters) {
    let hz = rng.u32(&[1, 1000, 16_000, u32::MAX]).max(1);
    let parameters = Parameters {
        position_gain: rng.u32(&[1, u32::MAX, 1 << 16]).max(1),
        velocity_gain: rng.u32(&[1, u32::MAX, 1 << 24]).max(1),
        integral_time_us: rng.u32(&[0, u32::MAX, 1_000_000_u32.div_ceil(hz)]).max(1_000_000_u32.div_ceil(hz)),
        velocity_limit: rng.u32(&[1, MAX_VELOCITY_LIMIT]).clamp(1, MAX_VELOCITY_LIMIT),
        torque_limit: (rng.u32(&[1, 0x7FFF]) as u16).clamp(1, MAX_TORQUE_LIMIT),
    };
    (hz, parameters)
}

#[test]
fn extreme_inputs_never_escape_the_limits() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    for _ in 0..400 {
        let (hz, parameters) = random_parameters(&mut rng);
        let mut cascade =
            Cascade::new(hz, parameters).unwrap_or_else(|e| panic!("{parameters:?} @ {hz}: {e:?}"));
        for n in 0..500 {
            if n % 97 == 0 {
                cascade.set_limits(rng.u32(&[0, u32::MAX]), rng.i16() as u16);
            }
            if n % 131 == 0 {
                cascade.reset(rng.i16());
            }
            let reference = Reference { position: rng.i32(), velocity: rng.i32(), torque: rng.i16() };
            let actual = Actual { position: rng.i32(), velocity: rng.i32() };
            let out = if n % 3 == 0 {
                cascade.step_velocity(reference.velocity, reference.torque, actual.velocity)
            } else {
                cascade.step(reference, actual)
            };
            let (velocity_limit, torque_limit) = (cascade.velocity_limit(), cascade.torque_limit());
            assert!(velocity_limit <= parameters.velocity_limit && torque_limit <= parameters.torque_limit);
            assert!(out.velocity.unsigned_abs() <= velocity_limit, "{out:?}");
            assert!(out.torque.unsigned_abs() <= torque_limit, "{out:?}");
            assert!(cascade.integral().unsigned_abs() <= torque_limit);
        }
    }
}

#[test]
fn outputs_do_not_depend_on_where_the_counter_wraps() {
    let mut rng = Rng(42);
    for _ in 0..200 {
        let (hz, parameters) = random_parameters(&mut rng);
        let mut here = Cascade::new(hz, parameters).unwrap();
        let mut there = here.clone();
        let offset = rng.i32();
        for _ in 0..200 {
            let reference =
                Reference { position: rng.i32(), velocity: rng.i32() >> 8, torque: rng.i16() >> 4 };
            let actual = Actual { position: rng.i32(), velocity: rng.i32() >> 8 };
            let shifted = Reference { position: reference.position.wrapping_add(offset), ..reference };
            let shifted_actual = Actual { position: actual.position.wrapping_add(offset), ..actual };
            assert_eq!(here.step(reference, actual), there.step(shifted, shifted_actual));
        }
        assert_eq!(here, there);
    }
}

#[test]
fn position_error_is_taken_the_short_way_round_the_counter() {
    let mut cascade = tuned();
    // Demand 10 past i32::MAX, actual 10 before it: 20 increments ahead, not 2³² − 20 behind.
    let (before, after) = (i32::MAX - 10, i32::MAX.wrapping_add(10));
    let out = cascade.step(
        Reference { position: after, velocity: 0, torque: 0 },
        Actual { position: before, velocity: 0 },
    );
    assert_eq!(out.velocity, 2000); // 20 increments · 100/s
    let out = cascade.step(
        Reference { position: before, velocity: 0, torque: 0 },
        Actual { position: after, velocity: 0 },
    );
    assert_eq!(out.velocity, -2000);
}

//! A simulated motor: turns the drive's [`Demand`] into the next feedback [`Sample`].
//!
//! A placeholder plant, kept deliberately small (a later issue adds switches, an encoder
//! model, current limits and faults). Model, in encoder increments and seconds:
//!
//! ```text
//! torque τ (‰ of rated)  ──▶  a = gain·τ − viscous·v − coulomb·sign(v)  ──▶  v  ──▶  x
//! ```
//!
//! - drive function disabled, or [`Setpoint::None`]: no torque; the motor coasts down under
//!   friction until it stops.
//! - [`Setpoint::Torque`]: the demanded torque, clamped to ±[`MotorParams::max_torque`].
//! - [`Setpoint::Velocity`] / [`Setpoint::Position`]: an ideal inner loop of the power stage
//!   (P on velocity, PD on position) computes the torque, with the same clamp.
//!
//! [`SimMotor::step`] integrates with semi-implicit Euler in sub-steps of at most
//! [`MotorParams::max_step`], so a long `dt` stays stable.

use canopen_drive::hal::{Demand, Sample, Setpoint};
use canopen_drive::Duration;

/// Constants of the simulated motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorParams {
    /// Acceleration per ‰ of rated torque, in increments/s² (inertia folded in).
    pub gain: f64,
    /// Viscous friction: deceleration per increment/s of velocity, in 1/s.
    pub viscous: f64,
    /// Coulomb friction: constant deceleration while moving, in increments/s².
    pub coulomb: f64,
    /// Torque limit of the power stage, in ‰ of rated torque.
    pub max_torque: f64,
    /// Velocity loop gain of the power stage, in ‰ per increment/s.
    pub velocity_gain: f64,
    /// Position loop gains of the power stage: ‰ per increment, and ‰ per increment/s.
    pub position_gains: (f64, f64),
    /// DC-link voltage reported in every sample, in mV.
    pub dc_link_millivolts: u32,
    /// Longest integration sub-step.
    pub max_step: Duration,
}

impl Default for MotorParams {
    fn default() -> Self {
        MotorParams {
            gain: 1000.0,
            viscous: 0.5,
            coulomb: 200.0,
            max_torque: 3000.0,
            // Velocity loop bandwidth gain·kv = 100 /s.
            velocity_gain: 0.1,
            // Position loop: ωn = 30 rad/s, ζ = 1.
            position_gains: (0.9, 0.06),
            dc_link_millivolts: 48_000,
            max_step: Duration::from_micros(250),
        }
    }
}

/// The simulated motor (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimMotor {
    params: MotorParams,
    /// Increments.
    position: f64,
    /// Increments per second.
    velocity: f64,
    /// ‰ of rated torque applied during the last step.
    torque: f64,
}

impl Default for SimMotor {
    fn default() -> Self {
        SimMotor::new()
    }
}

impl SimMotor {
    /// A motor at rest at position 0 with the default [`MotorParams`].
    pub fn new() -> Self {
        SimMotor::with_params(MotorParams::default())
    }

    /// A motor at rest at position 0.
    pub fn with_params(params: MotorParams) -> Self {
        SimMotor { params, position: 0.0, velocity: 0.0, torque: 0.0 }
    }

    /// The motor's constants.
    pub fn params(&self) -> &MotorParams {
        &self.params
    }

    /// Feedback as the board would sample it now.
    pub fn sample(&self) -> Sample {
        Sample {
            // `as` saturates at the integer limits.
            position: self.position.round() as i32,
            velocity: self.velocity.round() as i32,
            torque: self.torque.round() as i16,
            dc_link_millivolts: self.params.dc_link_millivolts,
            ..Sample::default()
        }
    }

    /// Applies `demand` for `dt`.
    pub fn step(&mut self, demand: &Demand, dt: Duration) {
        let max_step = self.params.max_step.as_micros().max(1);
        let mut left = dt.as_micros();
        while left > 0 {
            let h = left.min(max_step);
            self.integrate(demand, h as f64 * 1e-6);
            left -= h;
        }
    }

    fn integrate(&mut self, demand: &Demand, h: f64) {
        let p = &self.params;
        let setpoint = if demand.drive_enabled { demand.setpoint } else { Setpoint::None };
        let torque = match setpoint {
            Setpoint::None => 0.0,
            Setpoint::Torque(t) => f64::from(t),
            Setpoint::Velocity(v) => p.velocity_gain * (f64::from(v) - self.velocity),
            Setpoint::Position(x) => {
                let (kp, kd) = p.position_gains;
                kp * (f64::from(x) - self.position) - kd * self.velocity
            }
        };
        let torque = torque.clamp(-p.max_torque, p.max_torque);
        let drive = p.gain * torque - p.viscous * self.velocity;
        let mut velocity = self.velocity + drive * h;
        // Coulomb friction opposes motion but never reverses it by itself.
        let friction = p.coulomb * h;
        if velocity.abs() <= friction && (drive * h).abs() <= friction {
            velocity = 0.0;
        } else {
            velocity -= friction * velocity.signum();
        }
        self.velocity = velocity;
        self.position += velocity * h;
        self.torque = torque;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn on(setpoint: Setpoint) -> Demand {
        Demand { high_voltage: true, drive_enabled: true, brake_released: true, setpoint }
    }

    fn run(motor: &mut SimMotor, demand: Demand, millis: u64) {
        for _ in 0..millis {
            motor.step(&demand, Duration::from_millis(1));
        }
    }

    #[test]
    fn starts_at_rest() {
        let m = SimMotor::new();
        assert_eq!(
            m.sample(),
            Sample { position: 0, velocity: 0, torque: 0, dc_link_millivolts: 48_000, ..Sample::default() }
        );
        let mut m = SimMotor::new();
        run(&mut m, Demand::OFF, 100);
        assert_eq!(m.sample().position, 0);
    }

    #[test]
    fn torque_accelerates_and_off_coasts_to_a_stop() {
        let mut m = SimMotor::new();
        run(&mut m, on(Setpoint::Torque(500)), 100);
        let s = m.sample();
        assert_eq!(s.torque, 500);
        // About 500 000 inc/s² for 0.1 s, less friction.
        assert!((45_000..50_000).contains(&s.velocity), "{s:?}");
        assert!(s.position > 2000);
        let coasting_from = s.position;
        run(&mut m, Demand::OFF, 1000);
        let mid = m.sample();
        assert_eq!(mid.torque, 0);
        assert!(mid.velocity < s.velocity && mid.velocity > 0);
        assert!(mid.position > coasting_from);
        run(&mut m, Demand::OFF, 60_000);
        assert_eq!(m.sample().velocity, 0);
        let stopped = m.sample().position;
        run(&mut m, Demand::OFF, 100);
        assert_eq!(m.sample().position, stopped);
    }

    #[test]
    fn negative_torque_moves_backwards() {
        let mut m = SimMotor::new();
        run(&mut m, on(Setpoint::Torque(-200)), 50);
        assert!(m.sample().velocity < 0 && m.sample().position < 0);
    }

    #[test]
    fn velocity_demand_is_reached() {
        let mut m = SimMotor::new();
        run(&mut m, on(Setpoint::Velocity(10_000)), 200);
        let v = m.sample().velocity;
        assert!((9_000..=10_100).contains(&v), "{v}");
    }

    #[test]
    fn position_demand_is_reached() {
        let mut m = SimMotor::new();
        run(&mut m, on(Setpoint::Position(5_000)), 1000);
        let s = m.sample();
        assert!((s.position - 5_000).abs() < 50, "{s:?}");
        assert!(s.velocity.abs() < 100, "{s:?}");
    }

    #[test]
    fn one_long_step_equals_many_short_ones() {
        let mut a = SimMotor::new();
        let mut b = SimMotor::new();
        a.step(&on(Setpoint::Torque(100)), Duration::from_millis(10));
        for _ in 0..40 {
            b.step(&on(Setpoint::Torque(100)), Duration::from_micros(250));
        }
        assert_eq!(a.sample(), b.sample());
        let before = a.sample();
        a.step(&on(Setpoint::Torque(100)), Duration::ZERO);
        assert_eq!(a.sample(), before);
    }

    #[test]
    fn torque_is_clamped() {
        let mut m = SimMotor::new();
        m.step(&on(Setpoint::Torque(i16::MAX)), Duration::from_millis(1));
        assert_eq!(m.sample().torque, 3000);
    }
}

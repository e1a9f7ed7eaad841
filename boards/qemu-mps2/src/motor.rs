//! A small motor for the firmware, in `f32` (soft-float on thumbv6m): one rigid shaft with
//! inertia and friction, driven by a power stage that closes its own velocity (PI) and
//! position (P) loops, integrated in fixed sub-steps at every tick.
//!
//! ```text
//! acceleration = (τ_motor + τ_load − viscous·v − coulomb·sign(v)) · rated_acceleration / 1000 ‰
//! ```
//!
//! Units as in the core's [`Sample`]: positions in increments, velocities in increments/s,
//! torques in ‰ of the rated torque. Coulomb friction is static friction: a shaft at rest
//! stays at rest while |τ| ≤ coulomb. The stage is energised only while the demand has both
//! `drive_enabled` and `high_voltage`; otherwise the shaft coasts.
//!
//! `canopen-drive-sim` has the full model (switches, encoder index, brake, end stops) for host
//! tests; this one is what fits a firmware image and is enough for a profile position move.

use canopen_drive::hal::{Demand, Sample, Setpoint};

/// The motor's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorParams {
    /// Acceleration of the free shaft at rated torque (increments/s² per 1000 ‰).
    pub rated_acceleration: f32,
    /// Viscous friction (‰ per increment/s).
    pub viscous_friction: f32,
    /// Coulomb (static) friction (‰).
    pub coulomb_friction: f32,
    /// Torque limit of the stage (‰).
    pub max_torque: f32,
    /// Velocity loop: proportional gain (‰ per increment/s).
    pub velocity_kp: f32,
    /// Velocity loop: integral gain (‰ per increment).
    pub velocity_ki: f32,
    /// Position loop gain (1/s).
    pub position_gain: f32,
    /// Integration sub-step (s).
    pub max_step: f32,
    /// DC link voltage reported (mV).
    pub dc_link_millivolts: u32,
}

impl MotorParams {
    /// 10⁶ increments/s² at rated torque, velocity loop bandwidth 100/s with its PI zero at
    /// 20/s, position loop 20/s, 250 µs sub-steps: the same behaviour as the host simulation's
    /// default motor.
    pub const DEFAULT: MotorParams = MotorParams {
        rated_acceleration: 1.0e6,
        viscous_friction: 0.0005,
        coulomb_friction: 5.0,
        max_torque: 3000.0,
        velocity_kp: 0.1,
        velocity_ki: 2.0,
        position_gain: 20.0,
        max_step: 250.0e-6,
        dc_link_millivolts: 48_000,
    };
}

impl Default for MotorParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Which loop the stage closed in the last step (the integrator restarts when it changes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Loop {
    Off,
    Torque,
    Velocity,
    Position,
}

/// The motor's state.
#[derive(Clone, Copy, Debug)]
pub struct Motor {
    params: MotorParams,
    position: f32,
    velocity: f32,
    torque: f32,
    load: f32,
    integral: f32,
    active: Loop,
}

impl Motor {
    /// A motor at rest at position 0.
    pub const fn new(params: MotorParams) -> Self {
        Motor {
            params,
            position: 0.0,
            velocity: 0.0,
            torque: 0.0,
            load: 0.0,
            integral: 0.0,
            active: Loop::Off,
        }
    }

    /// The feedback the drive samples.
    pub fn sample(&self) -> Sample {
        Sample {
            position: round(self.position),
            velocity: round(self.velocity),
            torque: round(self.torque).clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16,
            dc_link_millivolts: self.params.dc_link_millivolts,
            ..Sample::default()
        }
    }

    /// An external load torque (‰), positive in the positive direction.
    pub fn set_load(&mut self, permille: i16) {
        self.load = f32::from(permille);
    }

    /// Applies `demand` for `dt_seconds`.
    pub fn step(&mut self, demand: &Demand, dt_seconds: f32) {
        let energised = demand.drive_enabled && demand.high_voltage;
        let wanted = match (energised, demand.setpoint) {
            (false, _) | (true, Setpoint::None) => Loop::Off,
            (true, Setpoint::Torque(_)) => Loop::Torque,
            (true, Setpoint::Velocity(_)) => Loop::Velocity,
            (true, Setpoint::Position(_)) => Loop::Position,
        };
        if wanted != self.active {
            self.integral = 0.0;
            self.active = wanted;
        }
        let mut left = dt_seconds.max(0.0);
        while left > 0.0 {
            let h = left.min(self.params.max_step);
            left -= h;
            self.torque = self.stage_torque(demand, h);
            self.integrate(h);
        }
    }

    fn stage_torque(&mut self, demand: &Demand, h: f32) -> f32 {
        let p = self.params;
        let velocity_target = match demand.setpoint {
            _ if self.active == Loop::Off => return 0.0,
            Setpoint::None => return 0.0,
            Setpoint::Torque(t) => return clamp(f32::from(t), p.max_torque),
            Setpoint::Velocity(v) => v as f32,
            Setpoint::Position(x) => {
                // The position error modulo 2³², like the encoder count.
                let error = x.wrapping_sub(round(self.position)) as f32;
                p.position_gain * error + demand.feed_forward.velocity as f32
            }
        };
        let error = velocity_target - self.velocity;
        let unclamped = p.velocity_kp * error + self.integral + f32::from(demand.feed_forward.torque);
        let torque = clamp(unclamped, p.max_torque);
        // Anti-windup: integrate only while the output is not saturated in the error's direction.
        if torque == unclamped || (unclamped > torque) != (error > 0.0) {
            self.integral = clamp(self.integral + p.velocity_ki * error * h, p.max_torque);
        }
        torque
    }

    fn integrate(&mut self, h: f32) {
        let p = self.params;
        let drive = self.torque + self.load;
        let moving = self.velocity != 0.0;
        if !moving && drive.abs() <= p.coulomb_friction {
            return;
        }
        let friction =
            if moving { p.coulomb_friction * sign(self.velocity) } else { p.coulomb_friction * sign(drive) };
        let acceleration =
            (drive - p.viscous_friction * self.velocity - friction) * p.rated_acceleration / 1000.0;
        let next = self.velocity + acceleration * h;
        // Friction stops the shaft but never reverses it.
        self.velocity = if moving && sign(next) != sign(self.velocity) && drive.abs() <= p.coulomb_friction {
            0.0
        } else {
            next
        };
        self.position += self.velocity * h;
    }
}

fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn clamp(x: f32, limit: f32) -> f32 {
    x.clamp(-limit, limit)
}

/// Rounds to the nearest integer, saturating (no `libm` needed).
fn round(x: f32) -> i32 {
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    r as i32
}

#[cfg(test)]
mod tests {
    use super::*;
    use canopen_drive::hal::FeedForward;

    fn enabled(setpoint: Setpoint) -> Demand {
        Demand {
            high_voltage: true,
            drive_enabled: true,
            brake_released: true,
            dynamic_brake: false,
            setpoint,
            feed_forward: FeedForward::NONE,
        }
    }

    #[test]
    fn rests_without_energy() {
        let mut m = Motor::new(MotorParams::DEFAULT);
        for _ in 0..100 {
            m.step(&Demand::OFF, 0.001);
        }
        assert_eq!(m.sample().position, 0);
        assert_eq!(m.sample().velocity, 0);
    }

    #[test]
    fn holds_a_position_setpoint() {
        let mut m = Motor::new(MotorParams::DEFAULT);
        for _ in 0..2000 {
            m.step(&enabled(Setpoint::Position(5000)), 0.001);
        }
        let s = m.sample();
        assert!((s.position - 5000).abs() <= 1, "{s:?}");
        assert!(s.velocity.abs() <= 5, "{s:?}");
    }

    #[test]
    fn follows_a_velocity_setpoint_against_a_load() {
        let mut m = Motor::new(MotorParams::DEFAULT);
        m.set_load(-200);
        for _ in 0..500 {
            m.step(&enabled(Setpoint::Velocity(10_000)), 0.001);
        }
        let s = m.sample();
        assert!((s.velocity - 10_000).abs() < 50, "{s:?}");
        assert!(s.torque > 150, "the loop carries the load: {s:?}");
    }

    #[test]
    fn a_torque_setpoint_accelerates_and_friction_stops() {
        let mut m = Motor::new(MotorParams::DEFAULT);
        m.step(&enabled(Setpoint::Torque(100)), 0.01);
        let v = m.sample().velocity;
        // (100 - 5) ‰ · 1000 increments/s² per ‰ for 10 ms ≈ 950 increments/s.
        assert!((900..1000).contains(&v), "{v}");
        for _ in 0..1000 {
            m.step(&Demand::OFF, 0.001);
        }
        assert_eq!(m.sample().velocity, 0);
    }
}

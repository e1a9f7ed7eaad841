//! A simulated axis that gives the drive its feedback: integer arithmetic only, so a run is the
//! same on every target and every time.
//!
//! A position demand is reached exactly in one tick, a velocity demand is the new velocity, and
//! a torque demand accelerates the axis by 1000 increments/s² per ‰ of rated torque (a light
//! load on the motor shaft; the cascade controller's gains of the scenarios are tuned for it).
//! It may have a negative limit switch ([`Axis::with_negative_limit`]), for homing.

use canopen_drive::hal::{Demand, DigitalInputs, Sample, Setpoint};

/// Acceleration per ‰ of rated torque, increments/s².
const ACCELERATION_PER_PERMILLE: i64 = 1000;

/// The axis; positions in increments, velocities in increments/s.
#[derive(Clone, Copy, Debug)]
pub struct Axis {
    hz: i64,
    position: i64,
    /// Increments·hz not yet whole increments.
    position_rest: i64,
    velocity: i64,
    /// (increments/s)·hz not yet whole increments/s.
    velocity_rest: i64,
    torque: i16,
    /// The negative limit switch is active at and below this position.
    negative_limit: Option<i64>,
}

impl Axis {
    /// An axis at rest at position 0, sampled `hz` times a second.
    pub fn new(hz: u32) -> Self {
        Axis {
            hz: i64::from(hz.max(1)),
            position: 0,
            position_rest: 0,
            velocity: 0,
            velocity_rest: 0,
            torque: 0,
            negative_limit: None,
        }
    }

    /// The same axis with a negative limit switch, active at and below `position`.
    pub fn with_negative_limit(self, position: i64) -> Self {
        Axis { negative_limit: Some(position), ..self }
    }

    /// What the board's sensors read now.
    pub fn sample(&self) -> Sample {
        Sample {
            position: self.position as i32,
            velocity: self.velocity.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32,
            torque: self.torque,
            dc_link_millivolts: 48_000,
            inputs: match self.negative_limit {
                Some(limit) if self.position <= limit => DigitalInputs::NEGATIVE_LIMIT,
                _ => DigitalInputs::empty(),
            },
            ..Sample::default()
        }
    }

    /// Moves the axis through one tick under `demand`.
    pub fn follow(&mut self, demand: &Demand) {
        let setpoint = if demand.drive_enabled { demand.setpoint } else { Setpoint::None };
        self.torque = 0;
        match setpoint {
            Setpoint::None => {
                self.velocity = 0;
                self.velocity_rest = 0;
            }
            Setpoint::Position(target) => {
                let step = i64::from(target.wrapping_sub(self.position as i32));
                self.velocity = step * self.hz;
                self.position += step;
                self.position_rest = 0;
            }
            Setpoint::Velocity(velocity) => {
                self.velocity = i64::from(velocity);
                self.advance();
            }
            Setpoint::Torque(torque) => {
                self.torque = torque;
                self.velocity_rest += i64::from(torque) * ACCELERATION_PER_PERMILLE;
                self.velocity += self.velocity_rest.div_euclid(self.hz);
                self.velocity_rest = self.velocity_rest.rem_euclid(self.hz);
                self.advance();
            }
        }
    }

    fn advance(&mut self) {
        self.position_rest += self.velocity;
        self.position += self.position_rest.div_euclid(self.hz);
        self.position_rest = self.position_rest.rem_euclid(self.hz);
    }
}

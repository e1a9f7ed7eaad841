//! A simulated motor: turns the drive's [`Demand`] into the next feedback [`Sample`].
//!
//! One rigid shaft with friction, a holding brake, an external load, a power stage with its own
//! torque/velocity/position loops, an incremental encoder with an index track, limit and home
//! switches, mechanical end stops, a DC link, two local inputs and injectable hardware faults.
//! Everything is deterministic: time only passes in [`SimMotor::step`], nothing is random.
//!
//! # Units
//!
//! | quantity | unit |
//! |---|---|
//! | torque (motor, load, friction, brake, limits) | ‰ of the rated torque, like [`Setpoint::Torque`] |
//! | shaft angle / velocity inside the model | revolutions, revolutions per second |
//! | position, velocity in a [`Sample`] or a set-point | encoder increments, increments per second |
//! | axis geometry (switches, end stops, index) | encoder increments (encoder zero = shaft angle 0) |
//! | DC link | mV |
//!
//! # Mechanics
//!
//! ```text
//!                      τ_motor + τ_load − viscous·ω − (coulomb + brake)·sign(ω)
//! angular acceleration = ───────────────────────────────────────────────────────── · rated_acceleration
//!                                                  1000 ‰
//! ```
//!
//! - [`MotorParams::rated_acceleration`] folds the inertia in: the acceleration the rated
//!   torque gives the free shaft.
//! - Coulomb friction and the engaged brake are static friction: a shaft at rest stays at rest
//!   while `|τ_motor + τ_load| ≤ coulomb (+ brake)`; a moving shaft is slowed by them, and they
//!   stop it but never reverse it.
//! - The holding brake is engaged whenever [`Demand::brake_released`] is false. It holds the
//!   shaft (velocity 0) against up to [`MotorParams::brake_holding_torque`]; more than that
//!   makes it slip (and it then brakes with that torque). Engaging it on a moving shaft stops
//!   the shaft.
//! - The external load ([`SimMotor::set_load_torque`]) is a constant torque, positive in the
//!   positive direction, as from a hanging mass. It acts whether the drive is enabled or not.
//! - Hard stops ([`MotorParams::negative_hard_stop`], [`MotorParams::positive_hard_stop`]) are
//!   perfectly inelastic: the shaft cannot pass them; reaching one sets the velocity to 0.
//!   Pushing into one keeps the shaft there at velocity 0 while the motor torque is whatever
//!   the power stage demands — with a velocity or position set-point beyond the stop the
//!   integrator of the velocity loop winds up until the torque saturates at
//!   [`MotorParams::max_torque`]. This is what hard-stop homing detects.
//!
//! # Power stage
//!
//! The stage is energised only while [`Demand::drive_enabled`] and [`Demand::high_voltage`]
//! are both set and the DC link is above 0 V; otherwise the motor torque is 0 and the shaft
//! coasts (or is held by the brake). While energised:
//!
//! - [`Setpoint::None`]: no torque.
//! - [`Setpoint::Torque`]: that torque.
//! - [`Setpoint::Velocity`]: a PI velocity loop
//!   (`τ = kp·(v* − v) + ki·∫(v* − v)`).
//! - [`Setpoint::Position`]: a P position loop giving the velocity set-point of the same PI
//!   loop (`v* = position_gain·(x* − x)`); the position error is taken modulo 2³², like the
//!   encoder count.
//!
//! The torque is always clamped to ±[`MotorParams::max_torque`]. The integrator stops
//! integrating while the output saturates in the direction of the error (anti-windup), is
//! limited to ±`max_torque`, and is reset when the set-point kind changes or the stage is
//! de-energised. The torque in a [`Sample`] is the motor torque of the last sub-step (what the
//! board would measure as current), not the torque on the shaft.
//!
//! # Encoder
//!
//! [`MotorParams::increments_per_revolution`] increments per revolution; the position in a
//! [`Sample`] is the shaft angle in increments, rounded to the nearest increment and wrapping
//! at the `i32` limits like a 32-bit counter. The velocity is the exact shaft velocity in
//! increments per second, rounded. The index track has one mark per revolution, at encoder
//! positions [`MotorParams::index_position`] + k · increments per revolution.
//! [`DigitalInputs::INDEX`] is set in the samples taken after a [`SimMotor::step`] during which
//! the shaft crossed a mark (either direction); the next `step` clears it. With the usual cycle
//! sample → tick → step that is exactly "seen since the previous sample", and taking a sample
//! never changes the motor.
//!
//! # Inputs
//!
//! - negative limit switch: active while the shaft is below
//!   [`MotorParams::negative_limit_switch`]; positive limit switch: active while above
//!   [`MotorParams::positive_limit_switch`];
//! - home switch: active while the shaft is inside [`MotorParams::home_switch`], a [`Zone`];
//! - any input can also be forced active at run time with [`SimMotor::set_input`] (pressing a
//!   switch by hand); the local quick-stop and interlock inputs only come from there.
//!
//! The inputs, the DC link voltage and injected faults ([`SimMotor::inject_fault`]) are only
//! reported: reacting to them is the drive's business, and the power stage keeps following
//! the demand.
//!
//! # Numerics
//!
//! [`SimMotor::step`] integrates with semi-implicit Euler in sub-steps of at most
//! [`MotorParams::max_step`], so a long `dt` stays stable and one long step equals the same
//! time in short steps.

use canopen_drive::hal::{Demand, DigitalInputs, Feedback, HardwareFaults, PowerStage, Sample, Setpoint};
use canopen_drive::Duration;

/// A range of positions in encoder increments, ends included; an open end is `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Zone {
    /// Lowest position inside the zone (`None`: no lower end).
    pub from: Option<i32>,
    /// Highest position inside the zone (`None`: no upper end).
    pub to: Option<i32>,
}

impl Zone {
    /// Positions at and above `position`.
    pub const fn above(position: i32) -> Self {
        Zone { from: Some(position), to: None }
    }

    /// Positions at and below `position`.
    pub const fn below(position: i32) -> Self {
        Zone { from: None, to: Some(position) }
    }

    /// Positions from `from` to `to`, both included.
    pub const fn between(from: i32, to: i32) -> Self {
        Zone { from: Some(from), to: Some(to) }
    }

    /// Whether `position` (increments, fractional) lies in the zone.
    pub fn contains(&self, position: f64) -> bool {
        self.from.is_none_or(|from| position >= f64::from(from))
            && self.to.is_none_or(|to| position <= f64::from(to))
    }
}

/// Constants of the simulated motor and its axis (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorParams {
    /// Acceleration of the free shaft at rated torque (1000 ‰), in revolutions/s².
    pub rated_acceleration: f64,
    /// Viscous friction, in ‰ per revolution/s.
    pub viscous_friction: f64,
    /// Coulomb (static and sliding) friction, in ‰.
    pub coulomb_friction: f64,
    /// Torque the engaged holding brake holds, in ‰.
    pub brake_holding_torque: f64,
    /// Torque limit of the power stage, in ‰.
    pub max_torque: f64,
    /// Proportional gain of the velocity loop, in ‰ per revolution/s.
    pub velocity_proportional_gain: f64,
    /// Integral gain of the velocity loop, in ‰ per revolution (of velocity error integrated).
    pub velocity_integral_gain: f64,
    /// Gain of the position loop, in 1/s (revolutions/s of velocity set-point per revolution).
    pub position_gain: f64,
    /// Encoder resolution, in increments per revolution (0 counts as 1).
    pub increments_per_revolution: u32,
    /// Encoder position of an index mark, in increments; the others follow every revolution.
    pub index_position: i32,
    /// Negative limit switch: active below this position (increments); `None`: no switch.
    pub negative_limit_switch: Option<i32>,
    /// Positive limit switch: active above this position (increments); `None`: no switch.
    pub positive_limit_switch: Option<i32>,
    /// Home switch: active inside this zone; `None`: no switch.
    pub home_switch: Option<Zone>,
    /// Mechanical end stop the shaft cannot go below (increments); `None`: none.
    pub negative_hard_stop: Option<i32>,
    /// Mechanical end stop the shaft cannot go above (increments); `None`: none.
    pub positive_hard_stop: Option<i32>,
    /// DC-link voltage at start, in mV (change it with [`SimMotor::set_dc_link_millivolts`]).
    pub dc_link_millivolts: u32,
    /// Longest integration sub-step.
    pub max_step: Duration,
}

impl Default for MotorParams {
    /// A 10 000-increment encoder, index at 0, no switches, no end stops, 48 V DC link; rated
    /// torque accelerates the shaft at 100 rev/s² (10⁶ increments/s²); velocity loop bandwidth
    /// 100/s, position loop 20/s.
    fn default() -> Self {
        MotorParams {
            rated_acceleration: 100.0,
            viscous_friction: 5.0,
            coulomb_friction: 5.0,
            brake_holding_torque: 4000.0,
            max_torque: 3000.0,
            // rated_acceleration/1000 · kp = 100/s; PI zero at 20/s.
            velocity_proportional_gain: 1000.0,
            velocity_integral_gain: 20_000.0,
            position_gain: 20.0,
            increments_per_revolution: 10_000,
            index_position: 0,
            negative_limit_switch: None,
            positive_limit_switch: None,
            home_switch: None,
            negative_hard_stop: None,
            positive_hard_stop: None,
            dc_link_millivolts: 48_000,
            max_step: Duration::from_micros(250),
        }
    }
}

/// Which loop the power stage closed in the last sub-step (for resetting the integrator).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Loop {
    Off,
    Torque,
    Velocity,
    Position,
}

/// The simulated motor (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimMotor {
    params: MotorParams,
    /// The demand the power stage follows.
    demand: Demand,
    /// Shaft angle, revolutions.
    angle: f64,
    /// Revolutions per second.
    velocity: f64,
    /// Motor torque of the last sub-step, ‰.
    torque: f64,
    /// Velocity-loop integrator, ‰.
    integral: f64,
    active_loop: Loop,
    /// External load torque, ‰.
    load_torque: f64,
    dc_link_millivolts: u32,
    forced_inputs: DigitalInputs,
    faults: HardwareFaults,
    warnings: HardwareFaults,
    local_control: bool,
    /// An index mark was crossed during the last step.
    index_seen: bool,
    index_pulses: u64,
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

    /// A motor at rest at position 0 (or at the nearer hard stop if 0 lies beyond one), brake
    /// engaged, power stage off, no load, no forced inputs, no faults.
    pub fn with_params(params: MotorParams) -> Self {
        let mut motor = SimMotor {
            params,
            demand: Demand::OFF,
            angle: 0.0,
            velocity: 0.0,
            torque: 0.0,
            integral: 0.0,
            active_loop: Loop::Off,
            load_torque: 0.0,
            dc_link_millivolts: params.dc_link_millivolts,
            forced_inputs: DigitalInputs::empty(),
            faults: HardwareFaults::empty(),
            warnings: HardwareFaults::empty(),
            local_control: false,
            index_seen: false,
            index_pulses: 0,
        };
        motor.set_position(0);
        motor
    }

    /// The motor's constants.
    pub fn params(&self) -> &MotorParams {
        &self.params
    }

    /// Feedback as the board would sample it now. Taking a sample does not change the motor.
    pub fn sample(&self) -> Sample {
        let position = self.position();
        let mut inputs = self.forced_inputs;
        let p = &self.params;
        if p.negative_limit_switch.is_some_and(|limit| position < f64::from(limit)) {
            inputs |= DigitalInputs::NEGATIVE_LIMIT;
        }
        if p.positive_limit_switch.is_some_and(|limit| position > f64::from(limit)) {
            inputs |= DigitalInputs::POSITIVE_LIMIT;
        }
        if p.home_switch.is_some_and(|zone| zone.contains(position)) {
            inputs |= DigitalInputs::HOME;
        }
        if self.index_seen {
            inputs |= DigitalInputs::INDEX;
        }
        Sample {
            position: self.count(),
            // `as` saturates at the integer limits.
            velocity: (self.velocity * self.resolution()).round() as i32,
            torque: self.torque.round() as i16,
            dc_link_millivolts: self.dc_link_millivolts,
            inputs,
            faults: self.faults,
            warnings: self.warnings,
            local_control: self.local_control,
        }
    }

    /// Applies `demand` for `dt`: the power stage follows it from now on (see
    /// [`SimMotor::advance`]).
    pub fn step(&mut self, demand: &Demand, dt: Duration) {
        self.demand = *demand;
        self.advance(dt);
    }

    /// Lets `dt` pass with the demand last given to [`SimMotor::step`] or through
    /// [`PowerStage`]. Clears the index latch first.
    pub fn advance(&mut self, dt: Duration) {
        self.index_seen = false;
        let max_step = self.params.max_step.as_micros().max(1);
        let mut left = dt.as_micros();
        while left > 0 {
            let h = left.min(max_step);
            self.integrate(h as f64 * 1e-6);
            left -= h;
        }
    }

    /// The demand the power stage follows.
    pub fn demand(&self) -> &Demand {
        &self.demand
    }

    /// Puts the shaft at `position` (increments, clamped to the hard stops), at rest. Does not
    /// count as crossing an index mark.
    pub fn set_position(&mut self, position: i32) {
        self.angle = f64::from(position) / self.resolution();
        self.velocity = 0.0;
        self.integral = 0.0;
        self.index_seen = false;
        self.stop_at_hard_stops();
    }

    /// Exact shaft position in increments (not rounded, not wrapped).
    pub fn position(&self) -> f64 {
        self.angle * self.resolution()
    }

    /// Shaft angle in revolutions.
    pub fn angle(&self) -> f64 {
        self.angle
    }

    /// Index marks crossed since the motor was made, both directions counted.
    pub fn index_pulses(&self) -> u64 {
        self.index_pulses
    }

    /// Sets the external load torque, in ‰ of rated torque (positive pushes positive).
    pub fn set_load_torque(&mut self, permille: f64) {
        self.load_torque = permille;
    }

    /// The external load torque, in ‰.
    pub fn load_torque(&self) -> f64 {
        self.load_torque
    }

    /// Sets the DC-link voltage, in mV. At 0 V the power stage gives no torque.
    pub fn set_dc_link_millivolts(&mut self, millivolts: u32) {
        self.dc_link_millivolts = millivolts;
    }

    /// Forces `inputs` active (`true`) or stops forcing them (`false`). Forced inputs are in
    /// every sample, on top of the switches the shaft position activates.
    pub fn set_input(&mut self, inputs: DigitalInputs, active: bool) {
        self.forced_inputs.set(inputs, active);
    }

    /// The inputs forced active with [`SimMotor::set_input`].
    pub fn forced_inputs(&self) -> DigitalInputs {
        self.forced_inputs
    }

    /// Adds `faults` to the hardware faults reported in every sample until cleared.
    pub fn inject_fault(&mut self, faults: HardwareFaults) {
        self.faults |= faults;
    }

    /// Clears all injected hardware faults.
    pub fn clear_faults(&mut self) {
        self.faults = HardwareFaults::empty();
    }

    /// Reports `warnings` (statusword bit 7) until changed again.
    pub fn set_warnings(&mut self, warnings: HardwareFaults) {
        self.warnings = warnings;
    }

    /// Hands the drive to the board's local control (`true`) or back to the bus.
    pub fn set_local_control(&mut self, local: bool) {
        self.local_control = local;
    }

    /// Faults the power stage reports.
    pub fn faults(&self) -> HardwareFaults {
        self.faults
    }

    /// Increments per revolution as a float, at least 1.
    fn resolution(&self) -> f64 {
        f64::from(self.params.increments_per_revolution.max(1))
    }

    /// The encoder count: rounded, wrapping like a 32-bit counter.
    fn count(&self) -> i32 {
        // f64 → i64 saturates; i64 → i32 keeps the low 32 bits.
        self.position().round() as i64 as i32
    }

    /// Number of the index interval the shaft is in (changes by one at every mark).
    fn index_interval(&self) -> f64 {
        (self.angle - f64::from(self.params.index_position) / self.resolution()).floor()
    }

    /// One sub-step of `h` seconds.
    fn integrate(&mut self, h: f64) {
        let torque = self.motor_torque(h);
        let p = &self.params;
        let driving = torque + self.load_torque;
        let holding = p.coulomb_friction.max(0.0)
            + if self.demand.brake_released { 0.0 } else { p.brake_holding_torque.max(0.0) };
        let gain = p.rated_acceleration / 1000.0;
        let velocity = if self.velocity == 0.0 {
            if driving.abs() <= holding {
                0.0
            } else {
                gain * (driving - holding * driving.signum()) * h
            }
        } else {
            let net = driving - p.viscous_friction * self.velocity - holding * self.velocity.signum();
            let velocity = self.velocity + gain * net * h;
            // Friction and brake stop the shaft but never reverse it by themselves.
            if velocity.signum() == self.velocity.signum() {
                velocity
            } else {
                0.0
            }
        };
        let interval = self.index_interval();
        self.velocity = velocity;
        self.angle += velocity * h;
        self.stop_at_hard_stops();
        let crossed = (self.index_interval() - interval).abs();
        if crossed >= 1.0 {
            self.index_seen = true;
            self.index_pulses = self.index_pulses.saturating_add(crossed as u64);
        }
        self.torque = torque;
    }

    /// Keeps the shaft between the hard stops; hitting one stops it.
    fn stop_at_hard_stops(&mut self) {
        let resolution = self.resolution();
        if let Some(stop) = self.params.negative_hard_stop {
            let stop = f64::from(stop) / resolution;
            if self.angle <= stop {
                self.angle = stop;
                self.velocity = self.velocity.max(0.0);
            }
        }
        if let Some(stop) = self.params.positive_hard_stop {
            let stop = f64::from(stop) / resolution;
            if self.angle >= stop {
                self.angle = stop;
                self.velocity = self.velocity.min(0.0);
            }
        }
    }

    /// The torque the power stage puts out in a sub-step of `h` seconds, in ‰.
    fn motor_torque(&mut self, h: f64) -> f64 {
        let energised = self.demand.drive_enabled && self.demand.high_voltage && self.dc_link_millivolts > 0;
        let setpoint = if energised { self.demand.setpoint } else { Setpoint::None };
        let active_loop = match setpoint {
            Setpoint::None => Loop::Off,
            Setpoint::Torque(_) => Loop::Torque,
            Setpoint::Velocity(_) => Loop::Velocity,
            Setpoint::Position(_) => Loop::Position,
        };
        if active_loop != self.active_loop {
            self.active_loop = active_loop;
            self.integral = 0.0;
        }
        let p = &self.params;
        let max = p.max_torque.max(0.0);
        let resolution = self.resolution();
        let velocity_setpoint = match setpoint {
            Setpoint::None => return 0.0,
            Setpoint::Torque(torque) => return f64::from(torque).clamp(-max, max),
            Setpoint::Velocity(velocity) => f64::from(velocity) / resolution,
            Setpoint::Position(target) => {
                // Modulo 2³², like the count: whole increments from the count, plus the
                // fraction the count rounded away.
                let position = self.position();
                let error = f64::from(target.wrapping_sub(self.count())) - (position - position.round());
                p.position_gain * error / resolution
            }
        };
        let error = velocity_setpoint - self.velocity;
        let unlimited = p.velocity_proportional_gain * error + self.integral;
        let torque = unlimited.clamp(-max, max);
        let winding_up = (unlimited > max && error > 0.0) || (unlimited < -max && error < 0.0);
        if !winding_up {
            self.integral = (self.integral + p.velocity_integral_gain * error * h).clamp(-max, max);
        }
        torque
    }
}

/// Sampling the simulated sensors; same as [`SimMotor::sample`].
impl Feedback for SimMotor {
    fn sample(&mut self) -> Sample {
        SimMotor::sample(self)
    }
}

/// Setting the demand piece by piece; it takes effect in the next [`SimMotor::advance`] (or is
/// replaced by the next [`SimMotor::step`]).
impl PowerStage for SimMotor {
    fn set_high_voltage(&mut self, on: bool) {
        self.demand.high_voltage = on;
    }

    fn set_drive_enabled(&mut self, enabled: bool) {
        self.demand.drive_enabled = enabled;
    }

    fn set_brake_released(&mut self, released: bool) {
        self.demand.brake_released = released;
    }

    fn apply(&mut self, setpoint: Setpoint) {
        self.demand.setpoint = setpoint;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn on(setpoint: Setpoint) -> Demand {
        Demand { high_voltage: true, drive_enabled: true, brake_released: true, setpoint }
    }

    /// Brake released, stage off.
    const FREE: Demand =
        Demand { high_voltage: true, drive_enabled: false, brake_released: true, setpoint: Setpoint::None };

    fn run(motor: &mut SimMotor, demand: Demand, millis: u64) {
        for _ in 0..millis {
            motor.step(&demand, Duration::from_millis(1));
        }
    }

    /// Runs `millis` 1 ms ticks and returns the samples taken after each.
    fn record(motor: &mut SimMotor, demand: Demand, millis: u64) -> Vec<Sample> {
        (0..millis)
            .map(|_| {
                motor.step(&demand, Duration::from_millis(1));
                motor.sample()
            })
            .collect()
    }

    fn axis(params: MotorParams) -> SimMotor {
        SimMotor::with_params(params)
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
        run(&mut m, FREE, 500);
        let mid = m.sample();
        assert_eq!(mid.torque, 0);
        assert!(mid.velocity < s.velocity && mid.velocity > 0, "{mid:?}");
        assert!(mid.position > coasting_from);
        run(&mut m, FREE, 10_000);
        assert_eq!(m.sample().velocity, 0);
        let stopped = m.sample().position;
        run(&mut m, FREE, 100);
        assert_eq!(m.sample().position, stopped);
    }

    #[test]
    fn negative_torque_moves_backwards() {
        let mut m = SimMotor::new();
        run(&mut m, on(Setpoint::Torque(-200)), 50);
        assert!(m.sample().velocity < 0 && m.sample().position < 0);
    }

    #[test]
    fn torque_is_clamped() {
        let mut m = SimMotor::new();
        m.step(&on(Setpoint::Torque(i16::MAX)), Duration::from_millis(1));
        assert_eq!(m.sample().torque, 3000);
        m.step(&on(Setpoint::Torque(i16::MIN)), Duration::from_millis(1));
        assert_eq!(m.sample().torque, -3000);
        // The velocity loop is clamped too.
        m.step(&on(Setpoint::Velocity(i32::MAX)), Duration::from_millis(1));
        assert_eq!(m.sample().torque, 3000);
        let limited = MotorParams { max_torque: 700.0, ..MotorParams::default() };
        let mut m = axis(limited);
        run(&mut m, on(Setpoint::Torque(1000)), 10);
        assert_eq!(m.sample().torque, 700);
        // 700 ‰ → 70 rev/s² → 700 000 inc/s² for 10 ms, less friction.
        assert!((6_800..=7_000).contains(&m.sample().velocity), "{:?}", m.sample());
    }

    #[test]
    fn no_torque_unless_enabled_with_high_voltage_and_dc_link() {
        let push = Setpoint::Torque(1000);
        let cases = [
            Demand { high_voltage: true, drive_enabled: false, brake_released: true, setpoint: push },
            Demand { high_voltage: false, drive_enabled: true, brake_released: true, setpoint: push },
            Demand { high_voltage: false, drive_enabled: false, brake_released: true, setpoint: push },
        ];
        for demand in cases {
            let mut m = SimMotor::new();
            run(&mut m, demand, 100);
            let s = m.sample();
            assert_eq!((s.torque, s.velocity, s.position), (0, 0, 0), "{demand:?}");
        }
        let mut m = SimMotor::new();
        m.set_dc_link_millivolts(0);
        run(&mut m, on(push), 100);
        assert_eq!(m.sample().torque, 0);
        assert_eq!(m.sample().dc_link_millivolts, 0);
        m.set_dc_link_millivolts(24_000);
        run(&mut m, on(push), 1);
        assert_eq!(m.sample().torque, 1000);
        assert_eq!(m.sample().dc_link_millivolts, 24_000);
        // Disabling mid-motion: torque 0 at once, the shaft coasts.
        run(&mut m, FREE, 1);
        assert_eq!(m.sample().torque, 0);
        assert!(m.sample().velocity > 0);
    }

    #[test]
    fn brake_holds_against_load_and_motor() {
        let mut m = SimMotor::new();
        m.set_load_torque(-2500.0);
        // Brake engaged, stage off: held.
        run(&mut m, Demand::OFF, 500);
        assert_eq!((m.sample().position, m.sample().velocity), (0, 0));
        // Brake engaged, motor pushing the other way as hard as it can: still held.
        let braked = Demand { brake_released: false, ..on(Setpoint::Torque(3000)) };
        run(&mut m, braked, 500);
        assert_eq!((m.sample().position, m.sample().velocity, m.sample().torque), (0, 0, 3000));
        // Released: the load pulls the shaft down.
        run(&mut m, FREE, 100);
        assert!(m.sample().velocity < 0 && m.sample().position < 0, "{:?}", m.sample());
        // Engaged again while moving at 25 rev/s: (4000 − 2500) ‰ stop it within 170 ms, and
        // then it holds.
        run(&mut m, Demand::OFF, 180);
        let held = m.sample();
        assert_eq!(held.velocity, 0);
        run(&mut m, Demand::OFF, 500);
        assert_eq!(m.sample().position, held.position);
    }

    #[test]
    fn brake_slips_above_its_holding_torque() {
        let mut m = axis(MotorParams { brake_holding_torque: 1000.0, ..MotorParams::default() });
        m.set_load_torque(900.0);
        run(&mut m, Demand::OFF, 100);
        assert_eq!(m.sample().position, 0);
        m.set_load_torque(1500.0);
        run(&mut m, Demand::OFF, 100);
        // (1500 − 1000 − 5) ‰ → about 49.5 rev/s² for 0.1 s.
        assert!(m.sample().velocity > 40_000, "{:?}", m.sample());
    }

    #[test]
    fn load_moves_a_free_shaft_and_velocity_loop_holds_against_it() {
        let mut m = SimMotor::new();
        m.set_load_torque(300.0);
        assert_eq!(m.load_torque(), 300.0);
        run(&mut m, FREE, 100);
        assert!(m.sample().velocity > 0);
        // Velocity 0 with a load: the integrator takes the load over.
        run(&mut m, on(Setpoint::Velocity(0)), 1000);
        let s = m.sample();
        assert_eq!(s.velocity, 0, "{s:?}");
        assert!((-305..=-295).contains(&s.torque), "{s:?}");
    }

    #[test]
    fn velocity_set_point_converges() {
        for target in [10_000, -25_000, 100] {
            let mut m = SimMotor::new();
            run(&mut m, on(Setpoint::Velocity(target)), 300);
            let v = m.sample().velocity;
            assert!((v - target).abs() <= target.abs() / 100 + 1, "{target}: {v}");
        }
        // Also against a load.
        let mut m = SimMotor::new();
        m.set_load_torque(-500.0);
        run(&mut m, on(Setpoint::Velocity(20_000)), 500);
        let s = m.sample();
        assert!((s.velocity - 20_000).abs() <= 20, "{s:?}");
    }

    #[test]
    fn position_set_point_converges() {
        for target in [5_000, -123_456, 7] {
            let mut m = SimMotor::new();
            run(&mut m, on(Setpoint::Position(target)), 1500);
            let s = m.sample();
            assert!((s.position - target).abs() <= 1, "{target}: {s:?}");
            assert!(s.velocity.abs() < 10, "{target}: {s:?}");
        }
        let mut m = SimMotor::new();
        m.set_load_torque(800.0);
        run(&mut m, on(Setpoint::Position(-4_000)), 1500);
        let s = m.sample();
        assert!((s.position + 4_000).abs() <= 1, "{s:?}");
    }

    #[test]
    fn position_loop_works_across_the_counter_wrap() {
        let mut m = SimMotor::new();
        m.set_position(i32::MAX - 1000);
        run(&mut m, on(Setpoint::Position(i32::MIN.wrapping_add(1000))), 1500);
        let s = m.sample();
        assert_eq!(s.position, i32::MIN + 1000, "{s:?}");
        assert!(m.position() > f64::from(i32::MAX));
    }

    #[test]
    fn integrator_is_reset_when_the_loop_changes() {
        let mut m = SimMotor::new();
        m.set_load_torque(-500.0);
        run(&mut m, on(Setpoint::Velocity(0)), 1000);
        assert!(m.sample().torque > 450);
        // Torque mode, then back: the velocity loop starts from an empty integrator.
        run(&mut m, on(Setpoint::Torque(0)), 1);
        assert_eq!(m.sample().torque, 0);
        run(&mut m, on(Setpoint::Velocity(0)), 1);
        assert!(m.sample().torque < 100, "{:?}", m.sample());
    }

    #[test]
    fn one_long_step_equals_many_short_ones() {
        let mut a = SimMotor::new();
        let mut b = SimMotor::new();
        a.step(&on(Setpoint::Velocity(3_000)), Duration::from_millis(10));
        for _ in 0..40 {
            b.step(&on(Setpoint::Velocity(3_000)), Duration::from_micros(250));
        }
        assert_eq!(a.sample(), b.sample());
        let before = a.sample();
        a.step(&on(Setpoint::Velocity(3_000)), Duration::ZERO);
        assert_eq!(a.sample(), before);
    }

    #[test]
    fn is_deterministic() {
        let script = |m: &mut SimMotor| {
            m.set_load_torque(123.0);
            let mut samples = record(m, on(Setpoint::Position(77_777)), 300);
            samples.extend(record(m, FREE, 300));
            samples
        };
        assert_eq!(script(&mut SimMotor::new()), script(&mut SimMotor::new()));
    }

    #[test]
    fn encoder_resolution_scales_position_and_velocity() {
        let mut angles = Vec::new();
        for resolution in [1000_u32, 4096, 10_000] {
            let mut m = axis(MotorParams { increments_per_revolution: resolution, ..MotorParams::default() });
            // One revolution per second, in each encoder's increments.
            let one_rev_per_s = resolution as i32;
            run(&mut m, on(Setpoint::Velocity(one_rev_per_s)), 2000);
            let s = m.sample();
            assert!((s.velocity - one_rev_per_s).abs() <= 1, "{resolution}: {s:?}");
            assert_eq!(s.position, (m.angle() * f64::from(resolution)).round() as i32);
            angles.push(m.angle());
        }
        // The shaft turned the same whatever the encoder (a bit under 2 revolutions).
        assert!(angles.iter().all(|a| (a - angles[0]).abs() < 1e-9 && (1.9..2.0).contains(a)), "{angles:?}");
        // Quantisation: the count only moves by whole increments.
        let mut coarse = axis(MotorParams { increments_per_revolution: 4, ..MotorParams::default() });
        run(&mut coarse, on(Setpoint::Torque(200)), 20);
        let angle = coarse.angle();
        assert!(angle > 0.0);
        assert_eq!(coarse.sample().position, (angle * 4.0).round() as i32);
    }

    #[test]
    fn encoder_count_wraps_like_a_32_bit_counter() {
        let mut m = SimMotor::new();
        m.set_position(i32::MAX - 10);
        run(&mut m, on(Setpoint::Velocity(20_000)), 100);
        let s = m.sample();
        assert!(s.position < 0 && s.position > i32::MIN + 1000, "{s:?}");
    }

    /// Encoder with 1000 increments per revolution and an index mark at 150 + k·1000.
    fn index_axis() -> SimMotor {
        axis(MotorParams { increments_per_revolution: 1000, index_position: 150, ..MotorParams::default() })
    }

    #[test]
    fn index_pulse_once_per_revolution_moving_positive() {
        let mut m = index_axis();
        // 2 rev/s for 2 s, after a short ramp: the marks at 150, 1150, 2150 and 3150.
        let samples = record(&mut m, on(Setpoint::Velocity(2000)), 2000);
        let end = m.sample().position;
        assert!((3_900..=4_000).contains(&end), "{end}");
        let at: Vec<i32> =
            samples.iter().filter(|s| s.inputs.contains(DigitalInputs::INDEX)).map(|s| s.position).collect();
        assert_eq!(at.len(), 4, "{at:?}");
        for (k, position) in (0..).zip(&at) {
            let mark = 150 + 1000 * k;
            // Seen in the first sample after the mark: at most one tick (2 increments) past it.
            assert!((mark..=mark + 3).contains(position), "{at:?}");
        }
        assert_eq!(m.index_pulses(), 4);
        // The pulse is not repeated: one more step clears it.
        run(&mut m, FREE, 1);
        assert!(!m.sample().inputs.contains(DigitalInputs::INDEX));
    }

    #[test]
    fn index_pulse_once_per_revolution_moving_negative() {
        let mut m = index_axis();
        m.set_position(5_500);
        assert!(!m.sample().inputs.contains(DigitalInputs::INDEX));
        let samples = record(&mut m, on(Setpoint::Velocity(-1000)), 2500);
        let end = m.sample().position;
        assert!((3_000..3_100).contains(&end), "{end}");
        let at: Vec<i32> =
            samples.iter().filter(|s| s.inputs.contains(DigitalInputs::INDEX)).map(|s| s.position).collect();
        // Marks 5150, 4150, 3150, met going down.
        assert_eq!(at.len(), 3, "{at:?}");
        for (k, position) in (0..).zip(&at) {
            let mark = 5150 - 1000 * k;
            assert!((mark - 2..mark).contains(position), "{at:?}");
        }
        assert_eq!(m.index_pulses(), 3);
    }

    #[test]
    fn index_pulse_in_a_long_step_and_not_at_rest() {
        let mut m = index_axis();
        run(&mut m, Demand::OFF, 100);
        assert!(!m.sample().inputs.contains(DigitalInputs::INDEX));
        m.step(&on(Setpoint::Velocity(1000)), Duration::from_millis(500));
        // 150 passed within the step.
        assert!(m.sample().position > 160);
        assert!(m.sample().inputs.contains(DigitalInputs::INDEX));
        m.step(&on(Setpoint::Velocity(1000)), Duration::from_millis(1));
        assert!(!m.sample().inputs.contains(DigitalInputs::INDEX));
    }

    #[test]
    fn limit_and_home_switches_follow_the_position() {
        let mut m = axis(MotorParams {
            negative_limit_switch: Some(-1000),
            positive_limit_switch: Some(1000),
            home_switch: Some(Zone::above(200)),
            ..MotorParams::default()
        });
        let inputs_at = |m: &mut SimMotor, position: i32| {
            m.set_position(position);
            m.sample().inputs
        };
        assert_eq!(inputs_at(&mut m, 0), DigitalInputs::empty());
        assert_eq!(inputs_at(&mut m, -1000), DigitalInputs::empty());
        assert_eq!(inputs_at(&mut m, -1001), DigitalInputs::NEGATIVE_LIMIT);
        assert_eq!(inputs_at(&mut m, -50_000), DigitalInputs::NEGATIVE_LIMIT);
        assert_eq!(inputs_at(&mut m, 199), DigitalInputs::empty());
        assert_eq!(inputs_at(&mut m, 200), DigitalInputs::HOME);
        assert_eq!(inputs_at(&mut m, 1000), DigitalInputs::HOME);
        assert_eq!(inputs_at(&mut m, 1001), DigitalInputs::HOME | DigitalInputs::POSITIVE_LIMIT);

        // Driving across: the home switch turns on at its edge, the limit switch beyond 1000.
        m.set_position(0);
        let samples = record(&mut m, on(Setpoint::Velocity(1000)), 1500);
        let first = |input| samples.iter().find(|s| s.inputs.contains(input)).map(|s| s.position);
        assert!(first(DigitalInputs::HOME).is_some_and(|p| (200..=201).contains(&p)));
        // (The switch acts on the exact shaft position, the count is rounded.)
        assert!(first(DigitalInputs::POSITIVE_LIMIT).is_some_and(|p| (1000..=1002).contains(&p)));
    }

    #[test]
    fn home_switch_zones() {
        assert!(Zone::below(-5).contains(-5.0) && !Zone::below(-5).contains(-4.9));
        assert!(Zone::above(7).contains(7.0) && !Zone::above(7).contains(6.9));
        let zone = Zone::between(10, 20);
        assert!(!zone.contains(9.9) && zone.contains(10.0) && zone.contains(20.0) && !zone.contains(20.1));
        assert!(Zone::default().contains(f64::MAX));
        let mut m =
            axis(MotorParams { home_switch: Some(Zone::between(-100, 100)), ..MotorParams::default() });
        assert_eq!(m.sample().inputs, DigitalInputs::HOME);
        m.set_position(101);
        assert_eq!(m.sample().inputs, DigitalInputs::empty());
    }

    #[test]
    fn inputs_can_be_forced() {
        let mut m = axis(MotorParams { home_switch: Some(Zone::above(0)), ..MotorParams::default() });
        m.set_position(-10);
        m.set_input(DigitalInputs::QUICK_STOP | DigitalInputs::INTERLOCK, true);
        m.set_input(DigitalInputs::HOME, true);
        assert_eq!(
            m.sample().inputs,
            DigitalInputs::QUICK_STOP | DigitalInputs::INTERLOCK | DigitalInputs::HOME
        );
        m.set_input(DigitalInputs::INTERLOCK | DigitalInputs::HOME, false);
        assert_eq!(m.forced_inputs(), DigitalInputs::QUICK_STOP);
        assert_eq!(m.sample().inputs, DigitalInputs::QUICK_STOP);
        // Releasing a forced switch leaves the one the position activates.
        m.set_position(10);
        m.set_input(DigitalInputs::HOME, true);
        m.set_input(DigitalInputs::HOME, false);
        assert!(m.sample().inputs.contains(DigitalInputs::HOME));
        // Inputs do not act on the power stage by themselves.
        run(&mut m, on(Setpoint::Torque(100)), 10);
        assert_eq!(m.sample().torque, 100);
    }

    #[test]
    fn hard_stop_stops_the_shaft_and_saturates_the_torque() {
        let stops = MotorParams {
            negative_hard_stop: Some(-2000),
            positive_hard_stop: Some(3000),
            ..MotorParams::default()
        };
        let mut m = axis(stops);
        // Velocity mode into the negative stop: stopped there, the velocity loop winds up.
        let samples = record(&mut m, on(Setpoint::Velocity(-2000)), 3000);
        let s = m.sample();
        assert_eq!((s.position, s.velocity, s.torque), (-2000, 0, -3000), "{s:?}");
        assert!(samples.iter().all(|s| s.position >= -2000));
        // It stays there.
        run(&mut m, on(Setpoint::Velocity(-2000)), 100);
        assert_eq!(m.sample(), s);
        // Backing off: once the wound-up integrator has unwound (≈ 0.7 s).
        run(&mut m, on(Setpoint::Velocity(2000)), 1000);
        assert!(m.sample().position > -2000 && m.sample().velocity > 0);

        // A position set-point beyond the positive stop, at full speed.
        run(&mut m, on(Setpoint::Position(10_000)), 3000);
        let s = m.sample();
        assert_eq!((s.position, s.velocity, s.torque), (3000, 0, 3000), "{s:?}");
        assert_eq!(m.position(), 3000.0);

        // Torque mode: the demanded torque, no motion.
        run(&mut m, on(Setpoint::Torque(400)), 100);
        let s = m.sample();
        assert_eq!((s.position, s.velocity, s.torque), (3000, 0, 400), "{s:?}");
        // A load alone also rests against the stop.
        m.set_load_torque(-1000.0);
        run(&mut m, FREE, 3000);
        assert_eq!((m.sample().position, m.sample().velocity), (-2000, 0));
        // Placing the shaft beyond a stop puts it at the stop.
        m.set_position(-5000);
        assert_eq!(m.sample().position, -2000);
    }

    #[test]
    fn injected_faults_appear_in_the_sample_until_cleared() {
        let mut m = SimMotor::new();
        assert_eq!(m.sample().faults, HardwareFaults::empty());
        m.inject_fault(HardwareFaults::OVER_CURRENT);
        m.inject_fault(HardwareFaults::ENCODER | HardwareFaults::UNDER_VOLTAGE);
        let all = HardwareFaults::OVER_CURRENT | HardwareFaults::ENCODER | HardwareFaults::UNDER_VOLTAGE;
        assert_eq!(m.sample().faults, all);
        assert_eq!(m.faults(), all);
        run(&mut m, on(Setpoint::Torque(100)), 10);
        assert_eq!(m.sample().faults, all);
        // Reported only: the stage still follows the demand.
        assert_eq!(m.sample().torque, 100);
        m.clear_faults();
        assert_eq!(m.sample().faults, HardwareFaults::empty());
    }

    #[test]
    fn feedback_and_power_stage_traits() {
        let mut m = SimMotor::new();
        PowerStage::apply_demand(&mut m, &on(Setpoint::Velocity(5000)));
        assert_eq!(*m.demand(), on(Setpoint::Velocity(5000)));
        m.advance(Duration::from_millis(300));
        let mut n = SimMotor::new();
        n.step(&on(Setpoint::Velocity(5000)), Duration::from_millis(300));
        assert_eq!(Feedback::sample(&mut m), n.sample());
        PowerStage::apply_demand(&mut m, &Demand::OFF);
        assert_eq!(*m.demand(), Demand::OFF);
    }
}

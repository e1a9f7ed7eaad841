//! A simulated motor: turns the drive's [`Demand`] into the next feedback [`Sample`].
//!
//! One rigid shaft with friction, a holding brake, an external load, a power stage with its own
//! torque/velocity/position loops, an incremental encoder with an index track, limit and home
//! switches, two touch-probe inputs, mechanical end stops (rigid or elastic), a DC link, two
//! local inputs and injectable hardware faults. Everything is deterministic: time only passes
//! in [`SimMotor::step`], nothing is random.
//!
//! # Units
//!
//! | quantity | unit |
//! |---|---|
//! | torque (motor, load, friction, brake, limits, end-stop reaction) | ‰ of the rated torque, like [`Setpoint::Torque`] |
//! | shaft angle / velocity inside the model | revolutions, revolutions per second |
//! | position, velocity in a [`Sample`] or a set-point | encoder increments, increments per second |
//! | axis geometry (switches, hysteresis, end stops, penetration, index) | encoder increments (encoder zero = shaft angle 0) |
//! | end-stop stiffness / damping | ‰ per increment / ‰ per increment/s |
//! | DC link | mV |
//!
//! # Mechanics
//!
//! ```text
//!                      τ_motor + τ_load + τ_stop − viscous·ω − (coulomb + brake)·sign(ω)
//! angular acceleration = ──────────────────────────────────────────────────────────────── · rated_acceleration
//!                                                     1000 ‰
//! ```
//!
//! - [`MotorParams::rated_acceleration`] folds the inertia in: the acceleration the rated
//!   torque gives the free shaft.
//! - Coulomb friction and the engaged brake are static friction: a shaft at rest stays at rest
//!   while `|τ_motor + τ_load + τ_stop| ≤ coulomb (+ brake)`; a moving shaft is slowed by them,
//!   and they stop it but never reverse it.
//! - The holding brake is engaged whenever [`Demand::brake_released`] is false. It holds the
//!   shaft (velocity 0) against up to [`MotorParams::brake_holding_torque`]; more than that
//!   makes it slip (and it then brakes with that torque). Engaging it on a moving shaft stops
//!   the shaft.
//! - The external load ([`SimMotor::set_load_torque`]) is a constant torque, positive in the
//!   positive direction, as from a hanging mass. It acts whether the drive is enabled or not.
//!
//! ## Hard stops
//!
//! [`MotorParams::negative_hard_stop`] and [`MotorParams::positive_hard_stop`] are mechanical
//! end stops. What they do depends on [`MotorParams::hard_stop_stiffness`]:
//!
//! - **Rigid** (stiffness 0, the default): perfectly inelastic. The shaft cannot pass a stop;
//!   reaching one sets the velocity to 0. Pushing into one keeps the shaft exactly there at
//!   velocity 0.
//! - **Elastic** (stiffness > 0): a stiff one-sided spring with damping. Beyond a stop by a
//!   penetration `p` (increments) moving at `v` (increments/s), the stop pushes the shaft back
//!   with `τ_stop = stiffness·p + damping·ṗ` (never pulling: a negative sum counts as 0). The
//!   encoder sees the shaft where it is, so the position in a [`Sample`] goes a few increments
//!   beyond the stop. At rest against a stop the penetration is about
//!   `|τ_motor + τ_load| / stiffness` (less the friction band), at most
//!   `(max_torque + |load|) / stiffness` (3 increments for the default torque limit and a
//!   stiffness of 1000 ‰/increment); hitting the stop at speed `v` adds at most about
//!   `v / √(stiffness · acceleration per ‰ in increments/s²)` of overshoot.
//!   The integration sub-step is shortened where needed so that the spring stays stable (see
//!   [Numerics](#numerics)).
//!
//! Either way the motor torque is whatever the power stage demands: with a velocity or
//! position set-point beyond the stop the integrator of the velocity loop winds up until the
//! torque (the [`Sample::torque`]) saturates at [`MotorParams::max_torque`]. This is what
//! hard-stop homing detects. To check that a drive never drove through a stop, use
//! [`SimMotor::max_hard_stop_penetration`] (0 for rigid stops) and
//! [`SimMotor::position_range`].
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
//!   loop (`v* = position_gain·(x* − x) + v_ff`); the position error is taken modulo 2³², like
//!   the encoder count.
//! - The demand's [`canopen_drive::hal::FeedForward`]: its velocity is added to the velocity
//!   set-point of the position loop, its torque to the output of the velocity loop.
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
//! increments per second, rounded.
//!
//! The index track has marks at the encoder positions
//! [`MotorParams::index_position`] + k · [`MotorParams::index_period`] for every integer k:
//! by default one per revolution; `Some(n)` puts one every `n` increments (as on a linear
//! scale with distance-coded or periodic reference marks), `Some(0)` removes the track (an
//! encoder without index channel). [`DigitalInputs::INDEX`] is set in the samples taken after
//! a [`SimMotor::step`] during which the shaft crossed a mark (either direction), however
//! long the step; the next `step` clears it. With the usual cycle sample → tick → step that is
//! exactly "seen since the previous sample", and taking a sample never changes the motor.
//!
//! # Inputs
//!
//! | input | active | configured by | hysteresis |
//! |---|---|---|---|
//! | [`DigitalInputs::NEGATIVE_LIMIT`] | below the switching point | [`MotorParams::negative_limit_switch`] | [`MotorParams::limit_switch_hysteresis`] |
//! | [`DigitalInputs::POSITIVE_LIMIT`] | above the switching point | [`MotorParams::positive_limit_switch`] | [`MotorParams::limit_switch_hysteresis`] |
//! | [`DigitalInputs::HOME`] | inside a [`Zone`] | [`MotorParams::home_switch`] | [`MotorParams::home_switch_hysteresis`] |
//! | [`DigitalInputs::TOUCH_PROBE_1`] | inside a [`Zone`] | [`MotorParams::touch_probe_1`] | [`MotorParams::touch_probe_hysteresis`] |
//! | [`DigitalInputs::TOUCH_PROBE_2`] | inside a [`Zone`] | [`MotorParams::touch_probe_2`] | [`MotorParams::touch_probe_hysteresis`] |
//! | [`DigitalInputs::INDEX`] | see [Encoder](#encoder) | [`MotorParams::index_position`], [`MotorParams::index_period`] | – |
//! | [`DigitalInputs::QUICK_STOP`], [`DigitalInputs::INTERLOCK`] | only when forced | [`SimMotor::set_input`] | – |
//!
//! Every input can also be forced active at run time with [`SimMotor::set_input`] (pressing a
//! switch by hand); a forced input is active whatever the position.
//!
//! The switches act on the exact shaft position, not on the rounded count. A limit switch at
//! `x` is active strictly beyond `x` (the switching point itself is outside); a zone includes
//! its ends.
//!
//! ## Home switch kinds
//!
//! A [`Zone`] with open ends gives all three kinds of CiA 402 home switch:
//!
//! | kind | homing methods | `home_switch` |
//! |---|---|---|
//! | positive home switch: inactive below `x`, active from `x` on | 3, 4, 19, 20 | `Some(Zone::above(x))` |
//! | negative home switch: active up to `x`, inactive above | 5, 6, 21, 22 | `Some(Zone::below(x))` |
//! | home switch zone (cam) with a left and a right edge | 7–14, 23–30 | `Some(Zone::between(left, right))` |
//!
//! Touch-probe inputs are configured the same way.
//!
//! ## Hysteresis
//!
//! A switch with hysteresis `h` becomes active where it does without hysteresis (on entering
//! its zone, or on passing its switching point) and becomes inactive only where it would
//! without hysteresis if its zone were `h` increments wider at each end. So the edge a drive
//! sees depends on the direction of travel, as on a real cam switch: a positive limit switch
//! at 1000 with `h` = 20 turns on above 1000 moving positive and off at or below 980 moving
//! back; a home switch `Zone::between(100, 200)` with `h` = 10 turns on at 100 and off above
//! 210 moving positive, on at 200 and off below 90 moving negative. Between those points the
//! state depends on the history;
//! [`SimMotor::set_position`] (and making the motor) chooses the state the shaft would have if
//! it had come from outside the zone: active only inside the zone itself. 0 (the default)
//! gives switches without hysteresis.
//!
//! ## Edges inside one step
//!
//! The switches are followed along the path of every integration sub-step, so an edge is never
//! missed, however far the shaft moves in one [`SimMotor::step`]. A sample shows the state at
//! the end of the step, except that an input that changed state and came back during the step
//! (the shaft ran across a narrow zone, or reversed just past a switching point) is reported
//! with the state it had in between, for that one sample: the drive sees both edges, one
//! sample apart. The limitation: at most one such pulse per input and step is shown; an input
//! that changed state three or more times in one step shows only its final state, or one
//! pulse.
//!
//! The inputs, the DC link voltage and injected faults ([`SimMotor::inject_fault`]) are only
//! reported: reacting to them is the drive's business, and the power stage keeps following
//! the demand.
//!
//! # Homing scenes
//!
//! [`MotorParams::homing_axis`] lays out an axis for every CiA 402 homing method (positions in
//! increments, index every 1000 from 150):
//!
//! ```text
//!  hard stop    NLS                   home switch zone                  PLS     hard stop
//!    −2000   active < 0               9000 ..= 11 000               active > 20 000   22 000
//!      |#########|                    |###############|                  |#########|
//! ```
//!
//! | method | succeeds (on `homing_axis`), home at | must fail with |
//! |---|---|---|
//! | 1 / 17 | 150 / 0 (NLS released at 0) | `negative_limit_switch: None` (the axis meets the hard stop); for 1: `index_period: Some(0)` |
//! | 2 / 18 | 19 150 / 20 000 | `positive_limit_switch: None`; for 2: `index_period: Some(0)` |
//! | 3, 4 / 19, 20 | `home_switch: Some(Zone::above(10_000))`: 9150, 10 150 / 10 000 | `home_switch: None` or beyond a stop (`Zone::above(30_000)`); for 3–6: `index_period: Some(0)` |
//! | 5, 6 / 21, 22 | `home_switch: Some(Zone::below(10_000))`: 10 150, 9150 / 10 000 | as 3–6 |
//! | 7–14 / 23–30 | left edge 9000 (index left 8150, right 9150), right edge 11 000 (10 150, 11 150) | `home_switch: None` (the axis meets both limit switches); for 7–14: `index_period: Some(0)` |
//! | 33 / 34 | from 5500: 5150 / 6150 | `index_period: Some(0)` |
//! | 35, 37 | anywhere, no motion | – |
//! | touch probe (36) | `touch_probe_1: Some(Zone::above(x))` | `touch_probe_1: None` |
//! | hard stop (manufacturer-specific) | without limit switches (`negative_limit_switch: None, positive_limit_switch: None`): negative stop −2000 (first index after it: −1850), positive 22 000 (21 150), middle 10 000 | `homing_axis` as is (the limit switch comes first), or no stop either (the torque never rises, the axis runs on) |
//!
//! Any method must also fail when both limit switches are active at once
//! (`set_input(NEGATIVE_LIMIT | POSITIVE_LIMIT, true)`), and no method may drive through a
//! hard stop: assert [`SimMotor::max_hard_stop_penetration`] stays within the static
//! penetration (3 increments plus the impact overshoot on `homing_axis`).
//!
//! # Numerics
//!
//! [`SimMotor::step`] integrates with semi-implicit Euler in sub-steps of at most
//! [`MotorParams::max_step`], so a long `dt` stays stable and one long step equals the same
//! time in short steps (whole multiples of `max_step`). Elastic hard stops split each sub-step
//! further, into equal parts short enough for the spring and the damper (`h·ω ≤ 0.5`), up to
//! 1000 parts: with the default `max_step` keep
//! `stiffness · rated_acceleration · increments_per_revolution / 1000` below about 4·10¹² /s²
//! (far stiffer than any stop a test needs).

use canopen_drive::hal::{Demand, DigitalInputs, Feedback, HardwareFaults, PowerStage, Sample, Setpoint};
use canopen_drive::Duration;

/// A range of positions in encoder increments, ends included; an open end is `None`.
///
/// As a home switch or touch-probe input, a zone open at one end is a switch with a single
/// switching point: [`Zone::above`] is a CiA 402 "positive home switch", [`Zone::below`] a
/// "negative home switch"; a zone with both ends is a cam with a left and a right edge (see
/// the [module docs](self#home-switch-kinds)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Zone {
    /// Lowest position inside the zone (`None`: no lower end).
    pub from: Option<i32>,
    /// Highest position inside the zone (`None`: no upper end).
    pub to: Option<i32>,
}

impl Zone {
    /// Positions at and above `position` (a positive home switch switching at `position`).
    pub const fn above(position: i32) -> Self {
        Zone { from: Some(position), to: None }
    }

    /// Positions at and below `position` (a negative home switch switching at `position`).
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
    /// Braking torque of the short-circuited windings ([`Demand::dynamic_brake`]), in ‰ per
    /// revolution/s (at most the maximum torque).
    pub dynamic_brake_torque: f64,
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
    /// Encoder position of an index mark, in increments; the others follow every
    /// [`MotorParams::index_period`].
    pub index_position: i32,
    /// Distance between index marks, in increments: `None` (the default) one mark per
    /// revolution, `Some(n)` one every `n` increments, `Some(0)` no index track at all.
    pub index_period: Option<u32>,
    /// Negative limit switch: active below this position (increments); `None`: no switch.
    pub negative_limit_switch: Option<i32>,
    /// Positive limit switch: active above this position (increments); `None`: no switch.
    pub positive_limit_switch: Option<i32>,
    /// Hysteresis of both limit switches, in increments (0: none).
    pub limit_switch_hysteresis: u32,
    /// Home switch: active inside this zone; `None`: no switch. [`Zone::above`] gives a
    /// positive home switch, [`Zone::below`] a negative one, [`Zone::between`] a zone.
    pub home_switch: Option<Zone>,
    /// Hysteresis of the home switch, in increments (0: none).
    pub home_switch_hysteresis: u32,
    /// Touch-probe input 1 ([`DigitalInputs::TOUCH_PROBE_1`]): active inside this zone;
    /// `None`: only when forced.
    pub touch_probe_1: Option<Zone>,
    /// Touch-probe input 2 ([`DigitalInputs::TOUCH_PROBE_2`]): active inside this zone;
    /// `None`: only when forced.
    pub touch_probe_2: Option<Zone>,
    /// Hysteresis of both touch-probe inputs, in increments (0: none).
    pub touch_probe_hysteresis: u32,
    /// Mechanical end stop the shaft cannot go below (increments); `None`: none.
    pub negative_hard_stop: Option<i32>,
    /// Mechanical end stop the shaft cannot go above (increments); `None`: none.
    pub positive_hard_stop: Option<i32>,
    /// Stiffness of both hard stops, in ‰ of reaction torque per increment of penetration;
    /// 0 (or less): rigid stops the shaft cannot enter at all.
    pub hard_stop_stiffness: f64,
    /// Damping of elastic hard stops, in ‰ per increment/s of penetration speed (critical
    /// damping: `2·√(stiffness / (rated_acceleration · increments_per_revolution / 1000))`).
    pub hard_stop_damping: f64,
    /// DC-link voltage at start, in mV (change it with [`SimMotor::set_dc_link_millivolts`]).
    pub dc_link_millivolts: u32,
    /// Longest integration sub-step.
    pub max_step: Duration,
}

impl Default for MotorParams {
    /// A 10 000-increment encoder, index at 0 once per revolution, no switches, no end stops
    /// (rigid if added), no hysteresis, 48 V DC link; rated torque accelerates the shaft at
    /// 100 rev/s² (10⁶ increments/s²); velocity loop bandwidth 100/s, position loop 20/s.
    fn default() -> Self {
        MotorParams {
            rated_acceleration: 100.0,
            viscous_friction: 5.0,
            dynamic_brake_torque: 200.0,
            coulomb_friction: 5.0,
            brake_holding_torque: 4000.0,
            max_torque: 3000.0,
            // rated_acceleration/1000 · kp = 100/s; PI zero at 20/s.
            velocity_proportional_gain: 1000.0,
            velocity_integral_gain: 20_000.0,
            position_gain: 20.0,
            increments_per_revolution: 10_000,
            index_position: 0,
            index_period: None,
            negative_limit_switch: None,
            positive_limit_switch: None,
            limit_switch_hysteresis: 0,
            home_switch: None,
            home_switch_hysteresis: 0,
            touch_probe_1: None,
            touch_probe_2: None,
            touch_probe_hysteresis: 0,
            negative_hard_stop: None,
            positive_hard_stop: None,
            hard_stop_stiffness: 0.0,
            hard_stop_damping: 0.0,
            dc_link_millivolts: 48_000,
            max_step: Duration::from_micros(250),
        }
    }
}

impl MotorParams {
    /// The default motor on a linear axis laid out for homing (see
    /// [Homing scenes](self#homing-scenes)): index marks every 1000 increments from 150,
    /// negative limit switch active below 0, positive limit switch active above 20 000, home
    /// switch zone 9000 ..= 11 000, elastic hard stops at −2000 and 22 000 (1000 ‰ per
    /// increment, critically damped: 3 increments deep at full torque). No hysteresis.
    pub fn homing_axis() -> Self {
        MotorParams {
            index_position: 150,
            index_period: Some(1000),
            negative_limit_switch: Some(0),
            positive_limit_switch: Some(20_000),
            home_switch: Some(Zone::between(9_000, 11_000)),
            negative_hard_stop: Some(-2_000),
            positive_hard_stop: Some(22_000),
            hard_stop_stiffness: 1000.0,
            // 2·√(1000 / 1000).
            hard_stop_damping: 2.0,
            ..MotorParams::default()
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

/// One end of the range where a switch is active, in increments.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bound {
    at: f64,
    /// The switching point itself lies outside the range.
    strict: bool,
}

/// The positions where a switch is active: above a lower and below an upper bound.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Range {
    lower: Option<Bound>,
    upper: Option<Bound>,
}

impl Range {
    fn zone(zone: Zone) -> Self {
        let bound = |at: i32| Bound { at: f64::from(at), strict: false };
        Range { lower: zone.from.map(bound), upper: zone.to.map(bound) }
    }

    /// Strictly above `point` (a positive limit switch).
    fn above(point: i32) -> Self {
        Range { lower: Some(Bound { at: f64::from(point), strict: true }), upper: None }
    }

    /// Strictly below `point` (a negative limit switch).
    fn below(point: i32) -> Self {
        Range { lower: None, upper: Some(Bound { at: f64::from(point), strict: true }) }
    }

    /// The range grown by `by` increments at both ends.
    fn widened(self, by: f64) -> Self {
        Range {
            lower: self.lower.map(|b| Bound { at: b.at - by, ..b }),
            upper: self.upper.map(|b| Bound { at: b.at + by, ..b }),
        }
    }

    fn above_lower(&self, x: f64) -> bool {
        self.lower.is_none_or(|b| if b.strict { x > b.at } else { x >= b.at })
    }

    fn below_upper(&self, x: f64) -> bool {
        self.upper.is_none_or(|b| if b.strict { x < b.at } else { x <= b.at })
    }

    fn contains(&self, x: f64) -> bool {
        self.above_lower(x) && self.below_upper(x)
    }

    fn is_empty(&self) -> bool {
        match (self.lower, self.upper) {
            (Some(lower), Some(upper)) => {
                lower.at > upper.at || (lower.at == upper.at && (lower.strict || upper.strict))
            }
            _ => false,
        }
    }

    /// Whether the straight path from `a` to `b` (either direction) touches the range.
    fn meets(&self, a: f64, b: f64) -> bool {
        !self.is_empty() && self.above_lower(a.max(b)) && self.below_upper(a.min(b))
    }
}

/// A position-driven input: its range, hysteresis and state.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Switch {
    input: DigitalInputs,
    /// `None`: no such switch (the input is only ever forced).
    range: Option<Range>,
    /// Increments.
    hysteresis: f64,
    active: bool,
    active_at_step_start: bool,
    /// State changes since the start of the step.
    changes: u32,
}

impl Switch {
    fn new(input: DigitalInputs, range: Option<Range>, hysteresis: u32) -> Self {
        Switch {
            input,
            range,
            hysteresis: f64::from(hysteresis),
            active: false,
            active_at_step_start: false,
            changes: 0,
        }
    }

    /// Puts the shaft at `x` as if it had come from outside the range.
    fn place(&mut self, x: f64) {
        self.active = self.range.is_some_and(|range| range.contains(x));
        self.start_step();
    }

    fn start_step(&mut self) {
        self.active_at_step_start = self.active;
        self.changes = 0;
    }

    /// Follows the shaft along a straight path from `from` to `to`. On such a path a switch
    /// changes at most twice: on when it enters the range, off when it leaves the widened
    /// range (which contains the range, so the path cannot enter the range again).
    fn travel(&mut self, from: f64, to: f64) {
        let Some(range) = self.range else { return };
        if !self.active && range.meets(from, to) {
            self.active = true;
            self.changes = self.changes.saturating_add(1);
        }
        if self.active && !range.widened(self.hysteresis).contains(to) {
            self.active = false;
            self.changes = self.changes.saturating_add(1);
        }
    }

    /// The state a sample shows: the current one, or the inverse after a pulse within the step.
    fn reported(&self) -> bool {
        let pulse = self.changes >= 2 && self.active == self.active_at_step_start;
        self.active != pulse
    }
}

/// The position-driven inputs of `params`.
fn switches(params: &MotorParams) -> [Switch; 5] {
    [
        Switch::new(
            DigitalInputs::NEGATIVE_LIMIT,
            params.negative_limit_switch.map(Range::below),
            params.limit_switch_hysteresis,
        ),
        Switch::new(
            DigitalInputs::POSITIVE_LIMIT,
            params.positive_limit_switch.map(Range::above),
            params.limit_switch_hysteresis,
        ),
        Switch::new(DigitalInputs::HOME, params.home_switch.map(Range::zone), params.home_switch_hysteresis),
        Switch::new(
            DigitalInputs::TOUCH_PROBE_1,
            params.touch_probe_1.map(Range::zone),
            params.touch_probe_hysteresis,
        ),
        Switch::new(
            DigitalInputs::TOUCH_PROBE_2,
            params.touch_probe_2.map(Range::zone),
            params.touch_probe_hysteresis,
        ),
    ]
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
    /// Limit switches, home switch, touch probes.
    switches: [Switch; 5],
    /// Lowest and highest exact position since the last placement, increments.
    lowest: f64,
    highest: f64,
    /// Deepest penetration into a hard stop since the last placement, increments.
    max_penetration: f64,
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
            switches: switches(&params),
            lowest: 0.0,
            highest: 0.0,
            max_penetration: 0.0,
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
        let mut inputs = self.forced_inputs;
        for switch in &self.switches {
            if switch.reported() {
                inputs |= switch.input;
            }
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
            // No capture hardware: the drive takes edges at the sampled position.
            ..Sample::default()
        }
    }

    /// Applies `demand` for `dt`: the power stage follows it from now on (see
    /// [`SimMotor::advance`]).
    pub fn step(&mut self, demand: &Demand, dt: Duration) {
        self.demand = *demand;
        self.advance(dt);
    }

    /// Lets `dt` pass with the demand last given to [`SimMotor::step`] or through
    /// [`PowerStage`]. Clears the index latch and the switch pulses of the previous step first.
    pub fn advance(&mut self, dt: Duration) {
        self.index_seen = false;
        for switch in &mut self.switches {
            switch.start_step();
        }
        let max_step = self.params.max_step.as_micros().max(1);
        let mut left = dt.as_micros();
        while left > 0 {
            let chunk = left.min(max_step);
            let seconds = chunk as f64 * 1e-6;
            let parts = self.parts(seconds);
            let h = seconds / f64::from(parts);
            for _ in 0..parts {
                self.integrate(h);
            }
            left -= chunk;
        }
    }

    /// The demand the power stage follows.
    pub fn demand(&self) -> &Demand {
        &self.demand
    }

    /// Puts the shaft at `position` (increments, clamped to the hard stops), at rest. Does not
    /// count as crossing an index mark or a switch edge: the switches take the state they would
    /// have if the shaft had come from outside their zones. Restarts
    /// [`SimMotor::position_range`] and [`SimMotor::max_hard_stop_penetration`].
    pub fn set_position(&mut self, position: i32) {
        self.angle = f64::from(position) / self.resolution();
        self.velocity = 0.0;
        self.integral = 0.0;
        self.index_seen = false;
        self.clamp_to_hard_stops();
        let position = self.position();
        for switch in &mut self.switches {
            switch.place(position);
        }
        self.lowest = position;
        self.highest = position;
        self.max_penetration = 0.0;
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

    /// The lowest and the highest exact position (increments) the shaft has reached since
    /// the last [`SimMotor::set_position`] (or since the motor was made), sub-step by
    /// sub-step: "the axis never went beyond x" is `position_range().1 <= x`.
    pub fn position_range(&self) -> (f64, f64) {
        (self.lowest, self.highest)
    }

    /// How far the shaft is beyond a hard stop now, in increments (0 when not touching one;
    /// always 0 for rigid stops).
    pub fn hard_stop_penetration(&self) -> f64 {
        let (below, above) = self.hard_stop_depths();
        below.max(above).max(0.0)
    }

    /// The deepest the shaft has gone beyond a hard stop since the last
    /// [`SimMotor::set_position`] (or since the motor was made), in increments: 0 for rigid
    /// stops, a few increments for elastic ones. "The motor never passed a hard stop" is
    /// `max_hard_stop_penetration() <= tolerance`.
    pub fn max_hard_stop_penetration(&self) -> f64 {
        self.max_penetration
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

    /// Number of the index interval the shaft is in (changes by one at every mark); `None`
    /// without an index track.
    fn index_interval(&self) -> Option<f64> {
        let period = match self.params.index_period {
            None => self.resolution(),
            Some(0) => return None,
            Some(period) => f64::from(period),
        };
        Some(((self.position() - f64::from(self.params.index_position)) / period).floor())
    }

    /// Whether the hard stops are elastic.
    fn elastic_stops(&self) -> bool {
        self.params.hard_stop_stiffness > 0.0
    }

    /// Into how many equal parts a sub-step of `seconds` is split so that elastic hard stops
    /// stay stable (1 for rigid ones).
    fn parts(&self, seconds: f64) -> u32 {
        let p = &self.params;
        let no_stops = p.negative_hard_stop.is_none() && p.positive_hard_stop.is_none();
        if !self.elastic_stops() || no_stops {
            return 1;
        }
        // Acceleration per ‰, in increments/s².
        let gain = (p.rated_acceleration / 1000.0 * self.resolution()).max(0.0);
        let spring = (p.hard_stop_stiffness * gain).sqrt();
        let damper = p.hard_stop_damping.max(0.0) * gain;
        let parts = (seconds * spring.max(damper) / 0.5).ceil();
        // `as` saturates (and maps NaN to 0).
        (parts as u32).clamp(1, 1000)
    }

    /// How far the shaft is beyond the negative and beyond the positive hard stop, in
    /// increments (negative: not beyond; `-inf` without that stop). Computed on the angle so
    /// that a shaft clamped to a rigid stop is exactly 0 deep.
    fn hard_stop_depths(&self) -> (f64, f64) {
        let resolution = self.resolution();
        let below = self
            .params
            .negative_hard_stop
            .map_or(f64::NEG_INFINITY, |stop| (f64::from(stop) / resolution - self.angle) * resolution);
        let above = self
            .params
            .positive_hard_stop
            .map_or(f64::NEG_INFINITY, |stop| (self.angle - f64::from(stop) / resolution) * resolution);
        (below, above)
    }

    /// Torque of elastic hard stops on the shaft, in ‰ (positive pushes positive).
    fn hard_stop_torque(&self) -> f64 {
        if !self.elastic_stops() {
            return 0.0;
        }
        let p = &self.params;
        let damping = p.hard_stop_damping.max(0.0);
        let velocity = self.velocity * self.resolution();
        let (below, above) = self.hard_stop_depths();
        let mut torque = 0.0;
        if below > 0.0 {
            // Penetration grows while moving negative; the stop only pushes.
            torque += (p.hard_stop_stiffness * below - damping * velocity).max(0.0);
        }
        if above > 0.0 {
            torque -= (p.hard_stop_stiffness * above + damping * velocity).max(0.0);
        }
        torque
    }

    /// One sub-step of `h` seconds.
    fn integrate(&mut self, h: f64) {
        let torque = self.motor_torque(h);
        let stop_torque = self.hard_stop_torque();
        let p = &self.params;
        let driving = torque + self.load_torque + stop_torque;
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
            // Friction and brake stop the shaft but never reverse it by themselves (an elastic
            // stop that turns the shaft round lets it go from rest in the next sub-step).
            if velocity.signum() == self.velocity.signum() {
                velocity
            } else {
                0.0
            }
        };
        let interval = self.index_interval();
        let from = self.position();
        self.velocity = velocity;
        self.angle += velocity * h;
        if !self.elastic_stops() {
            self.clamp_to_hard_stops();
        }
        let to = self.position();
        if let (Some(before), Some(after)) = (interval, self.index_interval()) {
            let crossed = (after - before).abs();
            if crossed >= 1.0 {
                self.index_seen = true;
                self.index_pulses = self.index_pulses.saturating_add(crossed as u64);
            }
        }
        for switch in &mut self.switches {
            switch.travel(from, to);
        }
        self.lowest = self.lowest.min(to);
        self.highest = self.highest.max(to);
        self.max_penetration = self.max_penetration.max(self.hard_stop_penetration());
        self.torque = torque;
    }

    /// Keeps the shaft between the hard stops; hitting one stops it.
    fn clamp_to_hard_stops(&mut self) {
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
        if !energised && self.demand.dynamic_brake {
            // Shorted windings: a torque against the motion, proportional to the speed.
            let max = self.params.max_torque.max(0.0);
            return (-self.params.dynamic_brake_torque * self.velocity).clamp(-max, max);
        }
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
        let feed_forward = self.demand.feed_forward;
        let velocity_setpoint = match setpoint {
            Setpoint::None => return 0.0,
            Setpoint::Torque(torque) => return f64::from(torque).clamp(-max, max),
            Setpoint::Velocity(velocity) => f64::from(velocity) / resolution,
            Setpoint::Position(target) => {
                // Modulo 2³², like the count: whole increments from the count, plus the
                // fraction the count rounded away.
                let position = self.position();
                let error = f64::from(target.wrapping_sub(self.count())) - (position - position.round());
                (p.position_gain * error + f64::from(feed_forward.velocity)) / resolution
            }
        };
        let error = velocity_setpoint - self.velocity;
        let unlimited = p.velocity_proportional_gain * error + self.integral + f64::from(feed_forward.torque);
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
        Demand { high_voltage: true, drive_enabled: true, brake_released: true, setpoint, ..Demand::OFF }
    }

    /// Brake released, stage off.
    const FREE: Demand =
        Demand { high_voltage: true, drive_enabled: false, brake_released: true, ..Demand::OFF };

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
            Demand {
                high_voltage: true,
                drive_enabled: false,
                brake_released: true,
                setpoint: push,
                ..Demand::OFF
            },
            Demand {
                high_voltage: false,
                drive_enabled: true,
                brake_released: true,
                setpoint: push,
                ..Demand::OFF
            },
            Demand {
                high_voltage: false,
                drive_enabled: false,
                brake_released: true,
                setpoint: push,
                ..Demand::OFF
            },
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

    /// Runs `millis` 1 ms ticks and returns the exact position and the new state each time
    /// `input` changes from one sample to the next.
    fn transitions(
        motor: &mut SimMotor,
        demand: Demand,
        millis: u64,
        input: DigitalInputs,
    ) -> Vec<(f64, bool)> {
        let mut state = motor.sample().inputs.contains(input);
        let mut seen = Vec::new();
        for _ in 0..millis {
            motor.step(&demand, Duration::from_millis(1));
            let now = motor.sample().inputs.contains(input);
            if now != state {
                seen.push((motor.position(), now));
                state = now;
            }
        }
        seen
    }

    /// One transition to `active` within `tolerance` increments past `at`, in the direction
    /// of travel.
    fn assert_one_edge(seen: &[(f64, bool)], at: f64, past: f64, active: bool) {
        assert_eq!(seen.len(), 1, "{seen:?}");
        let (position, state) = seen[0];
        assert_eq!(state, active, "{seen:?}");
        let (low, high) = if past >= 0.0 { (at, at + past) } else { (at + past, at) };
        assert!((low..=high).contains(&position), "edge at {position}, expected {at} + {past}: {seen:?}");
    }

    #[test]
    fn limit_switch_hysteresis_both_directions() {
        for hysteresis in [0_u32, 20] {
            let h = f64::from(hysteresis);
            let mut m = axis(MotorParams {
                negative_limit_switch: Some(-1000),
                positive_limit_switch: Some(1000),
                limit_switch_hysteresis: hysteresis,
                ..MotorParams::default()
            });
            // Positive switch: on just above 1000 going up, off only at 1000 − h coming back.
            m.set_position(900);
            let up = transitions(&mut m, on(Setpoint::Velocity(1000)), 300, DigitalInputs::POSITIVE_LIMIT);
            assert_one_edge(&up, 1000.0, 2.0, true);
            let down = transitions(&mut m, on(Setpoint::Velocity(-1000)), 400, DigitalInputs::POSITIVE_LIMIT);
            assert_one_edge(&down, 1000.0 - h, -2.0, false);
            // Negative switch, mirrored.
            m.set_position(-900);
            let down = transitions(&mut m, on(Setpoint::Velocity(-1000)), 300, DigitalInputs::NEGATIVE_LIMIT);
            assert_one_edge(&down, -1000.0, -2.0, true);
            let up = transitions(&mut m, on(Setpoint::Velocity(1000)), 400, DigitalInputs::NEGATIVE_LIMIT);
            assert_one_edge(&up, -1000.0 + h, 2.0, false);
        }
        // Inside the hysteresis band the state depends on the way the shaft came; placing it
        // there counts as coming from outside.
        let mut m = axis(MotorParams {
            positive_limit_switch: Some(1000),
            limit_switch_hysteresis: 20,
            ..MotorParams::default()
        });
        m.set_position(990);
        assert!(!m.sample().inputs.contains(DigitalInputs::POSITIVE_LIMIT));
        m.set_position(1001);
        assert!(m.sample().inputs.contains(DigitalInputs::POSITIVE_LIMIT));
    }

    #[test]
    fn home_switch_zone_hysteresis_both_directions() {
        let mut m = axis(MotorParams {
            home_switch: Some(Zone::between(100, 200)),
            home_switch_hysteresis: 10,
            ..MotorParams::default()
        });
        // Going up: on at the left edge, off 10 past the right edge.
        let up = transitions(&mut m, on(Setpoint::Velocity(1000)), 400, DigitalInputs::HOME);
        assert_eq!(up.len(), 2, "{up:?}");
        assert_one_edge(&up[..1], 100.0, 2.0, true);
        assert_one_edge(&up[1..], 210.0, 2.0, false);
        // Coming back: on at the right edge, off 10 below the left edge.
        let down = transitions(&mut m, on(Setpoint::Velocity(-1000)), 500, DigitalInputs::HOME);
        assert_eq!(down.len(), 2, "{down:?}");
        assert_one_edge(&down[..1], 200.0, -2.0, true);
        assert_one_edge(&down[1..], 90.0, -2.0, false);
        // Turning round inside the band keeps the switch on.
        m.set_position(150);
        run(&mut m, on(Setpoint::Position(205)), 500);
        assert!(m.sample().inputs.contains(DigitalInputs::HOME), "{:?}", m.sample());
        run(&mut m, on(Setpoint::Position(195)), 500);
        assert!(m.sample().inputs.contains(DigitalInputs::HOME));
    }

    #[test]
    fn positive_and_negative_home_switch() {
        // Positive home switch (methods 3, 4): inactive below 500, active from 500 on.
        let mut m = axis(MotorParams { home_switch: Some(Zone::above(500)), ..MotorParams::default() });
        assert!(!m.sample().inputs.contains(DigitalInputs::HOME));
        m.set_position(100_000);
        assert!(m.sample().inputs.contains(DigitalInputs::HOME));
        m.set_position(300);
        let up = transitions(&mut m, on(Setpoint::Velocity(1000)), 400, DigitalInputs::HOME);
        assert_one_edge(&up, 500.0, 2.0, true);
        let down = transitions(&mut m, on(Setpoint::Velocity(-1000)), 400, DigitalInputs::HOME);
        assert_one_edge(&down, 500.0, -2.0, false);

        // Negative home switch (methods 5, 6): active up to 500, inactive above.
        let mut m = axis(MotorParams {
            home_switch: Some(Zone::below(500)),
            home_switch_hysteresis: 5,
            ..MotorParams::default()
        });
        assert!(m.sample().inputs.contains(DigitalInputs::HOME));
        m.set_position(-100_000);
        assert!(m.sample().inputs.contains(DigitalInputs::HOME));
        m.set_position(300);
        let up = transitions(&mut m, on(Setpoint::Velocity(1000)), 400, DigitalInputs::HOME);
        assert_one_edge(&up, 505.0, 2.0, false);
        let down = transitions(&mut m, on(Setpoint::Velocity(-1000)), 400, DigitalInputs::HOME);
        assert_one_edge(&down, 500.0, -2.0, true);
    }

    /// Exact positions at which the samples show an index pulse.
    fn index_positions(motor: &mut SimMotor, demand: Demand, millis: u64) -> Vec<f64> {
        (0..millis)
            .filter_map(|_| {
                motor.step(&demand, Duration::from_millis(1));
                motor.sample().inputs.contains(DigitalInputs::INDEX).then(|| motor.position())
            })
            .collect()
    }

    #[test]
    fn index_period_and_offset() {
        // 10 000 increments per revolution, a mark every 250 from 30: …, −470, −220, 30, 280, …
        let params = MotorParams { index_period: Some(250), index_position: 30, ..MotorParams::default() };
        let mut m = axis(params);
        m.set_position(-600);
        let up = index_positions(&mut m, on(Setpoint::Velocity(1000)), 1000);
        let marks = [-470.0, -220.0, 30.0, 280.0];
        assert_eq!(up.len(), marks.len(), "{up:?}");
        for (seen, mark) in up.iter().zip(marks) {
            assert!((mark..mark + 2.0).contains(seen), "{up:?}");
        }
        assert_eq!(m.index_pulses(), 4);
        // Going down through the same marks.
        let down = index_positions(&mut m, on(Setpoint::Velocity(-1000)), 1000);
        assert_eq!(down.len(), 4, "{down:?}");
        for (seen, mark) in down.iter().zip(marks.iter().rev()) {
            assert!((mark - 2.0..*mark).contains(seen), "{down:?}");
        }
        // One long step over several marks: one pulse in the sample, every mark counted.
        let mut m = axis(params);
        m.step(&on(Setpoint::Velocity(2000)), Duration::from_millis(700));
        assert!((1_100.0..1_400.0).contains(&m.position()), "{}", m.position());
        assert!(m.sample().inputs.contains(DigitalInputs::INDEX));
        // Marks 30, 280, … up to the position.
        assert_eq!(m.index_pulses(), ((m.position() - 30.0) / 250.0).floor() as u64 + 1);
        assert!(m.index_pulses() >= 5);
        // The default is one mark per revolution.
        let mut m = SimMotor::new();
        m.set_position(-100);
        assert_eq!(index_positions(&mut m, on(Setpoint::Velocity(20_000)), 1000).len(), 2);
        // No index track at all.
        let mut m = axis(MotorParams { index_period: Some(0), ..MotorParams::default() });
        m.set_position(-100);
        assert!(index_positions(&mut m, on(Setpoint::Velocity(20_000)), 1000).is_empty());
        assert_eq!(m.index_pulses(), 0);
        assert!(m.position() > 10_000.0);
    }

    /// Elastic stops at −2000 and 3000, 1000 ‰ per increment, critically damped.
    fn elastic_stops() -> MotorParams {
        MotorParams {
            negative_hard_stop: Some(-2000),
            positive_hard_stop: Some(3000),
            hard_stop_stiffness: 1000.0,
            hard_stop_damping: 2.0,
            ..MotorParams::default()
        }
    }

    #[test]
    fn elastic_hard_stop_torque_rises_and_penetration_is_bounded() {
        let mut m = axis(elastic_stops());
        let samples = record(&mut m, on(Setpoint::Velocity(-2000)), 3000);
        let s = m.sample();
        // Against the stop at full torque: (3000 − 5) ‰ / 1000 ‰ per increment deep.
        assert_eq!((s.position, s.velocity, s.torque), (-2003, 0, -3000), "{s:?}");
        assert!((2.98..3.0).contains(&m.hard_stop_penetration()), "{}", m.hard_stop_penetration());
        // The impact at 2000 increments/s went at most a little deeper.
        let deepest = m.max_hard_stop_penetration();
        assert!((2.99..4.0).contains(&deepest), "{deepest}");
        assert!(samples.iter().all(|s| s.position >= -2004));
        assert!((m.position_range().0 - (-2000.0 - deepest)).abs() < 1e-9);
        // The torque rises to the limit while the shaft stands in the stop: what hard-stop
        // homing detects (torque above a threshold for a while).
        let contact = samples.iter().position(|s| s.position <= -2000).unwrap();
        let saturated = samples.iter().position(|s| s.torque == -3000).unwrap();
        assert!(samples[..contact].iter().all(|s| s.torque.abs() < 1000), "{:?}", &samples[..contact]);
        assert!(saturated > contact + 100, "{contact} {saturated}");
        assert!(samples[saturated..]
            .iter()
            .all(|s| s.torque == -3000 && (-2004..=-2002).contains(&s.position)));
        let rising = &samples[contact + 20..saturated];
        assert!(rising.windows(2).all(|w| w[1].torque <= w[0].torque), "{rising:?}");
        // Backing off: out of the stop, penetration 0, the deepest point remembered.
        run(&mut m, on(Setpoint::Velocity(2000)), 1500);
        assert!(m.position() > -1500.0);
        assert_eq!(m.hard_stop_penetration(), 0.0);
        assert_eq!(m.max_hard_stop_penetration(), deepest);

        // A position set-point beyond the positive stop at full speed: a deeper impact, still
        // bounded, and the same rest point.
        run(&mut m, on(Setpoint::Position(100_000)), 3000);
        let s = m.sample();
        assert_eq!((s.position, s.velocity, s.torque), (3003, 0, 3000), "{s:?}");
        let deepest = m.max_hard_stop_penetration();
        assert!((3.0..60.0).contains(&deepest), "{deepest}");
        assert!((m.position_range().1 - (3000.0 + deepest)).abs() < 1e-9);
        // A light push only goes in a little; a load alone rests against the stop.
        run(&mut m, on(Setpoint::Torque(500)), 500);
        assert!((0.49..0.51).contains(&m.hard_stop_penetration()), "{}", m.hard_stop_penetration());
        m.set_load_torque(-1000.0);
        run(&mut m, FREE, 3000);
        assert_eq!((m.sample().position, m.sample().velocity), (-2001, 0));
        // Placing the shaft beyond a stop puts it at the stop and restarts the records.
        m.set_position(-5000);
        assert_eq!(m.position(), -2000.0);
        assert_eq!((m.max_hard_stop_penetration(), m.position_range()), (0.0, (-2000.0, -2000.0)));
    }

    #[test]
    fn stiff_and_undamped_stops_stay_stable() {
        // (stiffness, damping): critically damped, under-damped, undamped, and very stiff ones
        // (these split the sub-step up to 1000 times).
        let cases = [(1000.0, 2.0), (1000.0, 0.5), (1000.0, 0.0), (1e6, 63.0), (1e9, 2000.0), (1e9, 0.0)];
        for (stiffness, damping) in cases {
            let mut m = axis(MotorParams {
                hard_stop_stiffness: stiffness,
                hard_stop_damping: damping,
                ..elastic_stops()
            });
            // Hit the stop at 50 000 increments/s (5 rev/s) with full torque behind it.
            let samples = record(&mut m, on(Setpoint::Velocity(50_000)), 1000);
            // Energy bound: full torque F plus the impact, p ≤ 2·F/stiffness + v/ω with
            // ω = √(stiffness · 1000 increments/s² per ‰), and 20 % for the integration
            // (h·ω ≤ 0.5) and a velocity loop overshooting a little.
            let static_depth = 3000.0 / stiffness;
            let bound = 1.2 * (2.0 * static_depth + 50_000.0 / (stiffness * 1000.0_f64).sqrt());
            let deepest = m.max_hard_stop_penetration();
            assert!(deepest.is_finite() && deepest <= bound, "{stiffness} {damping}: {deepest} > {bound}");
            assert!(samples.iter().all(|s| f64::from(s.position) <= 3000.0 + bound + 0.5));
            assert!(m.position_range().1 <= 3000.0 + bound);
            assert_eq!(m.sample().torque, 3000);
            if damping > 0.0 {
                // Settled against the stop at the static depth.
                let s = m.sample();
                assert_eq!(s.velocity, 0, "{stiffness} {damping}: {s:?}");
                let depth = m.hard_stop_penetration();
                assert!((depth - static_depth).abs() <= 0.01 * static_depth + 1e-9, "{stiffness}: {depth}");
            }
        }
    }

    #[test]
    fn rigid_hard_stops_are_never_entered() {
        let mut m = axis(MotorParams { negative_hard_stop: Some(-2000), ..MotorParams::default() });
        run(&mut m, on(Setpoint::Velocity(-50_000)), 1000);
        assert_eq!(m.position(), -2000.0);
        assert_eq!((m.hard_stop_penetration(), m.max_hard_stop_penetration()), (0.0, 0.0));
        assert_eq!(m.position_range(), (-2000.0, 0.0));
        assert_eq!(m.sample().torque, -3000);
    }

    #[test]
    fn touch_probe_zones() {
        let mut m = axis(MotorParams {
            touch_probe_1: Some(Zone::between(300, 310)),
            touch_probe_2: Some(Zone::below(-50)),
            touch_probe_hysteresis: 3,
            ..MotorParams::default()
        });
        assert_eq!(m.sample().inputs, DigitalInputs::empty());
        let up = transitions(&mut m, on(Setpoint::Velocity(1000)), 500, DigitalInputs::TOUCH_PROBE_1);
        assert_eq!(up.len(), 2, "{up:?}");
        assert_one_edge(&up[..1], 300.0, 2.0, true);
        assert_one_edge(&up[1..], 313.0, 2.0, false);
        m.set_position(0);
        let down = transitions(&mut m, on(Setpoint::Velocity(-1000)), 300, DigitalInputs::TOUCH_PROBE_2);
        assert_one_edge(&down, -50.0, -2.0, true);
        let up = transitions(&mut m, on(Setpoint::Velocity(1000)), 300, DigitalInputs::TOUCH_PROBE_2);
        assert_one_edge(&up, -47.0, 2.0, false);
        // Still forceable, on top of the position.
        m.set_position(305);
        assert_eq!(m.sample().inputs, DigitalInputs::TOUCH_PROBE_1);
        m.set_input(DigitalInputs::TOUCH_PROBE_2, true);
        assert_eq!(m.sample().inputs, DigitalInputs::TOUCH_PROBE_1 | DigitalInputs::TOUCH_PROBE_2);
        m.set_input(DigitalInputs::TOUCH_PROBE_2, false);
        m.set_position(0);
        m.set_input(DigitalInputs::TOUCH_PROBE_1, true);
        assert_eq!(m.sample().inputs, DigitalInputs::TOUCH_PROBE_1);
    }

    #[test]
    fn switch_pulse_within_one_step_is_reported_once() {
        // A home cam 5 increments wide, run across in one long step.
        let cam = MotorParams { home_switch: Some(Zone::between(100, 105)), ..MotorParams::default() };
        let mut m = axis(cam);
        m.step(&on(Setpoint::Velocity(1000)), Duration::from_millis(500));
        assert!(m.position() > 300.0);
        assert!(m.sample().inputs.contains(DigitalInputs::HOME));
        m.step(&on(Setpoint::Velocity(1000)), Duration::from_millis(1));
        assert!(!m.sample().inputs.contains(DigitalInputs::HOME));
        // A single point crossed at speed in 1 ms ticks (20 increments per tick) is seen too.
        let point = MotorParams { touch_probe_1: Some(Zone::between(1234, 1234)), ..MotorParams::default() };
        let mut m = axis(point);
        let up = transitions(&mut m, on(Setpoint::Velocity(20_000)), 200, DigitalInputs::TOUCH_PROBE_1);
        assert_eq!(up.len(), 2, "{up:?}");
        assert!(up[0].1 && (1234.0..1260.0).contains(&up[0].0), "{up:?}");
        // Off for one sample: a negative home switch left and re-entered within one step.
        let mut m = axis(MotorParams { home_switch: Some(Zone::below(0)), ..MotorParams::default() });
        m.set_position(-20);
        m.step(&on(Setpoint::Torque(3000)), Duration::from_millis(3));
        assert!(m.position() < 0.0 && m.sample().inputs.contains(DigitalInputs::HOME));
        m.step(&on(Setpoint::Torque(-3000)), Duration::from_millis(10));
        assert!(m.position_range().1 > 0.0 && m.position() < 0.0, "{:?}", m.position_range());
        assert!(!m.sample().inputs.contains(DigitalInputs::HOME));
        m.step(&on(Setpoint::Torque(0)), Duration::from_millis(1));
        assert!(m.sample().inputs.contains(DigitalInputs::HOME));
    }

    #[test]
    fn homing_axis_layout() {
        let params = MotorParams::homing_axis();
        let mut m = axis(params);
        let inputs_at = |m: &mut SimMotor, position: i32| {
            m.set_position(position);
            m.sample().inputs
        };
        assert_eq!(inputs_at(&mut m, 0), DigitalInputs::empty());
        assert_eq!(inputs_at(&mut m, -1), DigitalInputs::NEGATIVE_LIMIT);
        assert_eq!(inputs_at(&mut m, 9_000), DigitalInputs::HOME);
        assert_eq!(inputs_at(&mut m, 11_001), DigitalInputs::empty());
        assert_eq!(inputs_at(&mut m, 20_001), DigitalInputs::POSITIVE_LIMIT);
        assert_eq!(m.params().hard_stop_stiffness, 1000.0);
        m.set_position(-10_000);
        assert_eq!(m.position(), -2000.0);
        // Method 33 from 5500: the first index moving negative is 5150.
        m.set_position(5500);
        let marks = index_positions(&mut m, on(Setpoint::Velocity(-1000)), 400);
        assert!(marks.first().is_some_and(|p| (5148.0..5150.0).contains(p)), "{marks:?}");
        // Method 1 by hand: down to the NLS, back up, the first index after its release is 150.
        m.set_position(500);
        let down = transitions(&mut m, on(Setpoint::Velocity(-2000)), 400, DigitalInputs::NEGATIVE_LIMIT);
        assert_one_edge(&down, 0.0, -3.0, true);
        let mut released = false;
        let mut home = None;
        for _ in 0..1000 {
            m.step(&on(Setpoint::Velocity(1000)), Duration::from_millis(1));
            let s = m.sample();
            released |= !s.inputs.contains(DigitalInputs::NEGATIVE_LIMIT);
            if released && s.inputs.contains(DigitalInputs::INDEX) {
                home = Some(m.position());
                break;
            }
        }
        assert!(home.is_some_and(|p| (150.0..152.0).contains(&p)), "{home:?}");
        // No switch drove the axis into a stop.
        assert_eq!(m.max_hard_stop_penetration(), 0.0);

        // Hard-stop homing scene: no limit switches. The torque saturates against the stop, the
        // shaft a few increments in; backing off, the first index is at −1850.
        let mut m = axis(MotorParams {
            negative_limit_switch: None,
            positive_limit_switch: None,
            ..MotorParams::homing_axis()
        });
        m.set_position(1000);
        run(&mut m, on(Setpoint::Velocity(-5000)), 2000);
        let s = m.sample();
        assert_eq!((s.position, s.velocity, s.torque), (-2003, 0, -3000), "{s:?}");
        assert!(m.max_hard_stop_penetration() < 4.0, "{}", m.max_hard_stop_penetration());
        let marks = index_positions(&mut m, on(Setpoint::Velocity(1000)), 2000);
        assert!(marks.first().is_some_and(|p| (-1850.0..-1848.0).contains(p)), "{marks:?}");
        // Its failing scene: no stop either. The axis runs on and the torque stays low.
        let mut m = axis(MotorParams {
            negative_limit_switch: None,
            negative_hard_stop: None,
            ..MotorParams::homing_axis()
        });
        let samples = record(&mut m, on(Setpoint::Velocity(-5000)), 2000);
        assert!(samples[100..].iter().all(|s| s.torque.abs() < 100), "{:?}", &samples[100..110]);
        assert!(m.position() < -9000.0);
    }
}

//! What a board gives the core each control-loop tick, and what it gets back.
//!
//! The board samples its sensors into a [`Sample`], calls [`crate::Drive::tick`], and hands the
//! returned [`Demand`] to its power stage. The traits [`Feedback`] and [`PowerStage`] name these
//! two sides for boards that want them as types; the core itself only sees the values.
//!
//! Invariant: [`Demand::drive_enabled`] — energy to the motor — is true only in the
//! CiA 402 states Operation enabled, Quick stop active and Fault reaction active.

use bitflags::bitflags;

bitflags! {
    /// Digital inputs the drive profile uses (and reports in 60FDh).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct DigitalInputs: u32 {
        /// Negative limit switch (active).
        const NEGATIVE_LIMIT = 1 << 0;
        /// Positive limit switch (active).
        const POSITIVE_LIMIT = 1 << 1;
        /// Home switch (active).
        const HOME = 1 << 2;
        /// Interlock (active: the drive must not be enabled).
        const INTERLOCK = 1 << 3;
        /// Encoder index pulse seen since the previous sample.
        const INDEX = 1 << 4;
        /// Local quick-stop input (active).
        const QUICK_STOP = 1 << 5;
        /// Touch probe 1 input (active).
        const TOUCH_PROBE_1 = 1 << 6;
        /// Touch probe 2 input (active).
        const TOUCH_PROBE_2 = 1 << 7;
    }
}

bitflags! {
    /// Faults the board's hardware detected.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct HardwareFaults: u32 {
        /// Over-current (short circuit, earth leakage).
        const OVER_CURRENT = 1 << 0;
        /// DC-link over-voltage.
        const OVER_VOLTAGE = 1 << 1;
        /// DC-link under-voltage.
        const UNDER_VOLTAGE = 1 << 2;
        /// Power stage or motor over-temperature.
        const OVER_TEMPERATURE = 1 << 3;
        /// Encoder or position sensor fault.
        const ENCODER = 1 << 4;
    }
}

/// One feedback sample, taken by the board at the tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// Position actual value in encoder increments.
    pub position: i32,
    /// Velocity actual value in increments per second.
    pub velocity: i32,
    /// Torque actual value in thousandths of the rated torque.
    pub torque: i16,
    /// DC-link voltage in mV.
    pub dc_link_millivolts: u32,
    /// Digital inputs.
    pub inputs: DigitalInputs,
    /// Faults detected by the hardware.
    pub faults: HardwareFaults,
    /// Conditions close to a fault (e.g. a temperature near its limit): statusword bit 7
    /// (warning), no change of state.
    pub warnings: HardwareFaults,
    /// The board's local control owns the drive (e.g. a service switch): the controlword is not
    /// processed and statusword bit 9 (remote) is 0; SDO access and actual values go on.
    pub local_control: bool,
    /// Where the board's capture hardware (if any) saw the edges of this sample: touch probe
    /// inputs and the index pulse. Default: edges are taken at the sampled position.
    pub captures: Capture,
}

/// The set-point for the loops the board closes itself.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Setpoint {
    /// No set-point (drive function disabled, or a stop without a loop).
    #[default]
    None,
    /// Torque in thousandths of the rated torque.
    Torque(i16),
    /// Velocity in increments per second.
    Velocity(i32),
    /// Position in increments.
    Position(i32),
}

/// What the power stage should do until the next tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Demand {
    /// High-level power (DC link / mains contactor) on.
    pub high_voltage: bool,
    /// Drive function enabled: the power stage may put energy into the motor (PWM on).
    pub drive_enabled: bool,
    /// Holding brake released.
    pub brake_released: bool,
    /// Brake the motor by short-circuiting its windings (e.g. every low-side switch of the
    /// bridge on) while the drive function is off: a stop of option code −1
    /// ([`StopKind::DynamicBrake`](crate::cia402::fsa::StopKind)). False otherwise.
    pub dynamic_brake: bool,
    /// The set-point, meaningful while `drive_enabled`.
    pub setpoint: Setpoint,
    /// Feed-forward for the loops under the set-point (trajectory velocity, 60B1h/60B2h).
    pub feed_forward: FeedForward,
}

/// Feed-forward values that come with a position or velocity set-point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FeedForward {
    /// Velocity in increments per second (with a position set-point).
    pub velocity: i32,
    /// Torque in thousandths of the rated torque (with a position or velocity set-point).
    pub torque: i16,
}

impl FeedForward {
    /// No feed-forward.
    pub const NONE: FeedForward = FeedForward { velocity: 0, torque: 0 };
}

impl Demand {
    /// Everything off: no power, brake engaged, no set-point.
    pub const OFF: Demand = Demand {
        high_voltage: false,
        drive_enabled: false,
        brake_released: false,
        dynamic_brake: false,
        setpoint: Setpoint::None,
        feed_forward: FeedForward::NONE,
    };
}

/// The sensors of a board.
pub trait Feedback {
    /// Samples position, velocity, torque, DC link, inputs and hardware faults now.
    fn sample(&mut self) -> Sample;
}

/// The power stage of a board.
pub trait PowerStage {
    /// Switches high-level power.
    fn set_high_voltage(&mut self, on: bool);
    /// Enables or disables the drive function (PWM).
    fn set_drive_enabled(&mut self, enabled: bool);
    /// Releases (true) or engages (false) the holding brake. Boards without a brake ignore it.
    fn set_brake_released(&mut self, released: bool) {
        let _ = released;
    }
    /// Applies a set-point while the drive function is enabled.
    fn apply(&mut self, setpoint: Setpoint);

    /// Applies a whole [`Demand`] in a safe order: energy off before the brake engages, the
    /// set-point before energy is switched on.
    fn apply_demand(&mut self, demand: &Demand) {
        if demand.drive_enabled {
            self.set_high_voltage(demand.high_voltage);
            self.set_brake_released(demand.brake_released);
            self.apply(demand.setpoint);
            self.set_drive_enabled(true);
        } else {
            self.set_drive_enabled(false);
            self.apply(Setpoint::None);
            self.set_brake_released(demand.brake_released);
            self.set_high_voltage(demand.high_voltage);
        }
    }
}

/// What the board knows about the instant of an edge on one trigger signal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EdgeCapture {
    /// Nothing better than the tick: the edge is taken at the actual position of the sample.
    #[default]
    AtSample,
    /// The position (increments) a hardware capture unit latched at the edge; taken as is.
    Position(i32),
    /// The edge came this many µs before the sample. The position at the edge is interpolated
    /// as `position − velocity · micros / 10⁶` with [`Capture::velocity`], rounded to the
    /// nearest increment (halves away from zero) and saturated to the i32 range.
    Before {
        /// Time from the edge to the sample, µs.
        micros: u32,
    },
}

/// The board's more precise view of the edges of this tick, per trigger signal (the board needs
/// not know which probe uses which signal). Only read when an edge of that signal is seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Capture {
    /// Velocity actual value in increments per second, for [`EdgeCapture::Before`].
    pub velocity: i32,
    /// The edge of the touch probe 1 input.
    pub probe_1: EdgeCapture,
    /// The edge of the touch probe 2 input.
    pub probe_2: EdgeCapture,
    /// The encoder index pulse.
    pub index: EdgeCapture,
}

impl Capture {
    /// No capture hardware: every edge is taken at the sample.
    pub const NONE: Capture = Capture {
        velocity: 0,
        probe_1: EdgeCapture::AtSample,
        probe_2: EdgeCapture::AtSample,
        index: EdgeCapture::AtSample,
    };

    /// The position at an edge described by `edge`, for the actual `position` of the sample.
    pub(crate) fn position_at(&self, edge: EdgeCapture, position: i32) -> i32 {
        match edge {
            EdgeCapture::AtSample => position,
            EdgeCapture::Position(latched) => latched,
            EdgeCapture::Before { micros } => {
                // |velocity · micros| ≤ 2³¹ · (2³² − 1) < 2⁶³ − 2³¹: the product and the rounding
                // term fit in i64, and so does the difference below.
                let travel = i64::from(self.velocity) * i64::from(micros);
                let half = if travel < 0 { -500_000 } else { 500_000 };
                let delta = (travel + half) / 1_000_000;
                let at = i64::from(position) - delta;
                crate::wide::saturate_i32(at)
            }
        }
    }
}

// `defmt::Format` of the bitflags types: their raw bits (a bitflags type cannot derive it).
#[cfg(feature = "defmt")]
impl defmt::Format for DigitalInputs {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "DigitalInputs({=u32:#x})", self.bits());
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for HardwareFaults {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "HardwareFaults({=u32:#x})", self.bits());
    }
}

//! What a drive built on this crate supports of the profile: its configuration, fixed when the
//! firmware creates the [`crate::Drive`]. The defaults are the CiA 402 ones (every option code
//! value the standard defines, transition 16 allowed); a vendor narrows them to what its
//! product does, and the SDO server then refuses the rest with 0x0609_0030.
//!
//! The supported modes are [`crate::od::DeviceInfo::drive_modes`] (they are also the value of
//! 6502h).

use super::cyclic::CyclicConfig;
use super::hm::HomingConfig;
use crate::motion::TickRate;
use crate::time::Duration;

/// Which values of each option-code object are accepted: bit `n` set = value `n` supported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OptionCodes {
    /// 6007h abort connection option code (standard values 0–3).
    pub abort_connection: u16,
    /// 605Ah quick stop option code (0–8).
    pub quick_stop: u16,
    /// 605Bh shutdown option code (0–1).
    pub shutdown: u16,
    /// 605Ch disable operation option code (0–1).
    pub disable_operation: u16,
    /// 605Dh halt option code (1–4).
    pub halt: u16,
    /// 605Eh fault reaction option code (0–4).
    pub fault_reaction: u16,
}

impl OptionCodes {
    /// Every value CiA 402 defines.
    pub const ALL: OptionCodes = OptionCodes {
        abort_connection: 0b1111,
        quick_stop: 0b1_1111_1111,
        shutdown: 0b11,
        disable_operation: 0b11,
        halt: 0b1_1110,
        fault_reaction: 0b1_1111,
    };

    /// Bit of a mask for the manufacturer-specific value −1, dynamic brake
    /// ([`StopKind::DynamicBrake`](super::fsa::StopKind)); no CiA 402 value reaches bit 15.
    pub const DYNAMIC_BRAKE: u16 = 1 << 15;

    /// Whether `value` is supported by the mask `mask` (bit n: value n; bit 15: −1).
    pub const fn allows(mask: u16, value: i16) -> bool {
        match value {
            -1 => mask & Self::DYNAMIC_BRAKE != 0,
            0..=14 => mask & (1 << value) != 0,
            _ => false,
        }
    }
}

impl Default for OptionCodes {
    fn default() -> Self {
        OptionCodes::ALL
    }
}

/// What a manufacturer-specific statusword bit (14 or 15; CiA 402 leaves them to the
/// manufacturer) shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StatusFlag {
    /// Always 0 (the default).
    Off,
    /// 1 while the axis moves: the velocity demand is not 0 (in the torque modes, which have
    /// none: the velocity actual is beyond the velocity threshold 606Fh).
    Moving,
    /// 1 while the axis moves in the negative direction (as [`StatusFlag::Moving`], below 0).
    Negative,
    /// 1 while the drive is getting ready to move or coming to a stop: the holding brake is
    /// still opening after the drive function was enabled, or a quick stop is still ramping.
    Transition,
}

/// The unit of the torque and current objects 6071h (target torque), 6074h (torque demand),
/// 6077h (torque actual value), 6078h (current actual value) and 60B2h (torque offset). The
/// limits 6072h/6073h and the slope 6087h stay in ‰ whatever the unit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TorqueUnit {
    /// ‰ of the rated torque (6078h: of the rated current): CiA 402, the default.
    #[default]
    PerMilleOfRated,
    /// mA of motor current. The core takes the torque as proportional to the current, rated
    /// torque at the motor rated current 6075h (mA), so `mA = ‰ × 6075h / 1000`. While 6075h is
    /// 0 (not known) a commanded torque is 0 and the actual values read 0.
    MilliAmps,
}

/// The unit of the velocity objects (60FFh, 606Bh, 606Ch, 6081h, 6082h, 607Fh, 6099h, 60B1h,
/// 60FAh, 60F8h) and with it of the accelerations (6083h–6085h, 609Ah, 60C5h, 60C6h: per
/// second) and jerks (60A4h: per second²). 6080h has its own unit ([`MotorSpeedUnit`]); velocity mode
/// (6042h–604Ch) has its own units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum VelocityUnit {
    /// Position units (the factor group's user units) per second: CiA 402, the default.
    #[default]
    PositionUnitsPerSecond,
    /// Revolutions of the motor per minute, through the position encoder resolution 608Fh
    /// (`increments/s = rpm × 608Fh.1 / (60 × 608Fh.2)`), whatever the gear and feed.
    MotorRpm,
}

/// The unit of the maximum motor speed 6080h.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MotorSpeedUnit {
    /// Revolutions of the motor per minute, through 608Fh: CiA 402, the default.
    #[default]
    Rpm,
    /// The velocity unit of 607Fh ([`VelocityUnit`]), for drives documenting 6080h in counts
    /// (or position units) per second.
    VelocityUnit,
}

/// The units of the profile's physical objects ([`ProfileConfig::units`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Units {
    /// Torques and currents.
    pub torque: TorqueUnit,
    /// Velocities, accelerations and jerks.
    pub velocity: VelocityUnit,
    /// The maximum motor speed 6080h.
    pub motor_speed: MotorSpeedUnit,
}

impl Units {
    /// The units of CiA 402: ‰ of rated torque, position units per second.
    pub const CIA_402: Units = Units {
        torque: TorqueUnit::PerMilleOfRated,
        velocity: VelocityUnit::PositionUnitsPerSecond,
        motor_speed: MotorSpeedUnit::Rpm,
    };
}

// Evaluated by the compiler: it can only fail the build, never run.
#[allow(clippy::panic)]
const ONE_KHZ: TickRate = match TickRate::new(1000) {
    Ok(rate) => rate,
    Err(_) => panic!("1 kHz is a valid tick rate"),
};

/// The drive profile's configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProfileConfig {
    /// The rate at which the board calls [`crate::Drive::tick`]. The trajectory generator
    /// advances one tick per call, so this must match the board's timer.
    pub tick_rate: TickRate,
    /// Supported option-code values.
    pub option_codes: OptionCodes,
    /// Transition 16 (Quick stop active → Operation enabled with 605Ah = 5–8).
    pub transition_16: bool,
    /// Profile position: how many set-points may wait behind the one being executed (set of
    /// set-points, CiA 402-2 §10.2.3), 1..=[`ProfileConfig::MAX_SETPOINT_BUFFER`].
    pub setpoint_buffer: u8,
    /// A following error (6065h/6066h) is also a fault (8611h, reaction 605Eh); the standard
    /// only requires statusword bit 13.
    pub following_error_fault: bool,
    /// Profile position supports change on set-point (controlword bit 9). Without it, a
    /// master that sets bit 9 in pp gets an EMCY 6320h (parameter error) until it clears the
    /// bit, and the bit is treated as 0 (CiA 402-2 §8.4.1: a function that is not available).
    pub change_on_setpoint: bool,
    /// Close the position and velocity loops in the core ([`crate::control::Cascade`]) with
    /// the parameters of the manufacturer RECORD at this index (put
    /// [`crate::control::object`] there in [`crate::Config::manufacturer_objects`]): every
    /// position or velocity demand then leaves the tick as a torque demand, for boards whose
    /// power stage closes only a current loop. `None`: the board closes the loops it needs.
    pub cascade: Option<u16>,
    /// Time the holding brake needs to open: after the drive function is enabled the demand
    /// holds the axis still this long before a mode may move it.
    pub brake_release_delay: Duration,
    /// Time the holding brake needs to close: a ramped stop that ends with the drive function
    /// disabled (605Ah/605Bh/605Ch/605Eh) engages the brake at standstill and keeps the motor
    /// energised, holding, this long before the state changes.
    pub brake_engage_delay: Duration,
    /// Homing methods beyond the standard ones, and the homing time limit.
    pub homing: HomingConfig,
    /// Cyclic synchronous modes: bridging of a lost stream, the SYNC phase object.
    pub cyclic: CyclicConfig,
    /// Velocity mode: whether controlword bits 4–6 (ramp enable, unlock, reference) count.
    pub vl: super::vl::Config,
    /// NMT Stopped puts an axis in Operation enabled into Fault (code 8100h), whatever 6007h
    /// says. Default false: only 6007h decides (CiA 402).
    pub nmt_stopped_fault: bool,
    /// What statusword bit 14 shows (default [`StatusFlag::Off`]).
    pub statusword_bit_14: StatusFlag,
    /// What statusword bit 15 shows (default [`StatusFlag::Off`]).
    pub statusword_bit_15: StatusFlag,
    /// A new mode may be written in Operation enabled (CiA 402; the default). When false, a
    /// write of another value to 6060h in Operation enabled is refused with 0x0800_0022 (and a
    /// mode that arrives by RPDO waits until the drive function is disabled).
    pub mode_change_in_operation: bool,
    /// A following error window 6065h of 0 switches the following error check off (as
    /// FFFF FFFFh does). Default false: 0 is a window of 0 (CiA 402).
    pub zero_following_error_window_off: bool,
    /// The units of the torque, current and velocity objects (default [`Units::CIA_402`]).
    pub units: Units,
    /// Error codes the drive reports instead of the crate's: pairs (the crate's code, the
    /// drive's code), applied to every EMCY, the error history 1003h and 603Fh (default none:
    /// the codes of CiA 301/402, e.g. 3220h for under-voltage where a manual documents a
    /// manufacturer-specific FFxxh).
    pub error_codes: &'static [(u16, u16)],
    /// An EMCY (this code, manufacturer-specific register bit) while the axis is at a travel
    /// limit outside homing, with the limit in byte 1 of the manufacturer field
    /// ([`TravelLimit`]); the "error reset" EMCY when it leaves it. A limit switch already
    /// active is touched again by each motion commanded into it — a pp set-point taken whose
    /// target lies beyond the actual position on the switch's side, a pv target velocity that
    /// turns towards it — and each such touch sends the EMCY once more (motion away from the
    /// switch sends none). Default none: CiA 402 reports travel limits in the statusword only.
    pub travel_limit_emcy: Option<u16>,
    /// Manufacturer-specific modes (negative 6060h values) the drive runs as direct set-point
    /// modes: (value, mode). Default none: 6060h accepts the modes of 6502h only.
    pub manufacturer_modes: &'static [(i8, DirectMode)],
    /// Statusword bit 7 shows warnings (the board's, an ip buffer overflow): CiA 402, the
    /// default. False for a drive that documents the bit as reserved (always 0).
    pub warning_bit: bool,
    /// The software position limits 607Dh act only once the axis is homed (a drive whose
    /// documentation says homing validates them). Default false: they act from power-on.
    pub software_limits_after_homing: bool,
    /// An active limit switch stops motion towards it outside homing: pp clamps a new target
    /// to the present position and stops a move running into the switch (quick-stop ramp), pv
    /// holds a target velocity towards it at 0; statusword bit 11 (internal limit) is 1 in pp
    /// and pv while a switch is active. Motion away from the switch stays possible. The cyclic
    /// modes follow the master's stream as before (the master sees the switch in 60FDh).
    /// Default false: CiA 402 leaves the reaction to a limit switch to the manufacturer.
    pub limit_switches_stop: bool,
    /// Under halt, statusword bit 10 waits until the shaft rests as well as the demand:
    /// "decelerated to zero velocity" read as the axis's velocity. The shaft rests once
    /// |606Ch| ≤ 606Fh has held for longer than the velocity threshold time 6070h (with 6070h
    /// = 0: on two ticks in a row, so that a shaft passing through 0 does not count). Default
    /// false: bit 10 follows the velocity demand reaching 0.
    pub halt_reached_at_standstill: bool,
}

/// A direct set-point mode: the target object goes to the loops at every tick, within the
/// limits of the cyclic synchronous mode of the same quantity (csp, csv, cst) but without SYNC
/// or interpolation — a vendor's "direct position / velocity / torque" mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DirectMode {
    /// 607Ah (+ 60B0h) as the position demand.
    Position,
    /// 60FFh (+ 60B1h) as the velocity demand.
    Velocity,
    /// 6071h (+ 60B2h) as the torque demand.
    Torque,
}

impl DirectMode {
    /// The cyclic synchronous mode whose limits and statusword bits the direct mode has.
    pub const fn cyclic_mode(self) -> i8 {
        match self {
            DirectMode::Position => super::objects::mode::CYCLIC_POSITION,
            DirectMode::Velocity => super::objects::mode::CYCLIC_VELOCITY,
            DirectMode::Torque => super::objects::mode::CYCLIC_TORQUE,
        }
    }
}

/// Which travel limit the axis is at (byte 1 of the [`ProfileConfig::travel_limit_emcy`] EMCY).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
#[non_exhaustive]
pub enum TravelLimit {
    /// 6064h above the positive software limit 607Dh sub 2.
    PositiveSoftware = 1,
    /// 6064h below the negative software limit 607Dh sub 1.
    NegativeSoftware = 2,
    /// The positive limit switch is active (outside homing).
    PositiveSwitch = 3,
    /// The negative limit switch is active (outside homing).
    NegativeSwitch = 4,
}

impl ProfileConfig {
    /// Largest [`ProfileConfig::setpoint_buffer`].
    pub const MAX_SETPOINT_BUFFER: u8 = 4;

    /// The CiA 402 defaults at a 1 kHz tick.
    pub const fn new() -> Self {
        ProfileConfig {
            tick_rate: ONE_KHZ,
            option_codes: OptionCodes::ALL,
            transition_16: true,
            setpoint_buffer: 1,
            following_error_fault: false,
            change_on_setpoint: true,
            cascade: None,
            brake_release_delay: Duration::ZERO,
            brake_engage_delay: Duration::ZERO,
            homing: HomingConfig::new(),
            cyclic: CyclicConfig::new(),
            vl: super::vl::Config::new(),
            nmt_stopped_fault: false,
            statusword_bit_14: StatusFlag::Off,
            statusword_bit_15: StatusFlag::Off,
            mode_change_in_operation: true,
            zero_following_error_window_off: false,
            units: Units::CIA_402,
            error_codes: &[],
            travel_limit_emcy: None,
            manufacturer_modes: &[],
            warning_bit: true,
            software_limits_after_homing: false,
            limit_switches_stop: false,
            halt_reached_at_standstill: false,
        }
    }

    /// The direct mode a manufacturer-specific 6060h value runs as ([`Self::manufacturer_modes`]).
    pub fn manufacturer_mode(&self, value: i8) -> Option<DirectMode> {
        self.manufacturer_modes.iter().find(|(v, _)| *v == value).map(|(_, mode)| *mode)
    }

    /// The code the drive reports for the crate's error `code` ([`Self::error_codes`]).
    pub fn reported_code(&self, code: u16) -> u16 {
        self.error_codes.iter().find(|(own, _)| *own == code).map_or(code, |(_, reported)| *reported)
    }

    /// The same configuration at another tick rate.
    pub const fn with_tick_rate(self, tick_rate: TickRate) -> Self {
        ProfileConfig { tick_rate, ..self }
    }
}

impl Default for ProfileConfig {
    fn default() -> Self {
        ProfileConfig::new()
    }
}

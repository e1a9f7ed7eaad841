//! The leaf of the profile's modules (CiA 402-2 §6–§20): the indices of the profile objects,
//! the modes and their 6502h bits, [`Rule`] (the value rules beyond type and limits), and the
//! constructors the modes describe their objects with. It imports no other module of
//! `cia402`; the table of the objects and the rules' checks are in [`super::registry`], above
//! the modes.

use crate::od::{Access, DataType, DefaultValue, Object, PdoMapping, Var, COPY_STRIDE};

/// The profile area of the first logical device (CiA 402: 6000h–67FFh): objects the drive
/// profile rules ([`super::registry::rule`]) wherever their descriptions come from.
pub const PROFILE_AREA: core::ops::RangeInclusive<u16> = 0x6000..=0x67FF;

/// One logical device (axis) of a CiA 402 node. Axis n (0–7) has the objects of the profile
/// area at `6000h + n × 800h … 67FFh + n × 800h` (n × [`COPY_STRIDE`]): the same description,
/// shifted. The constants of this module name the first axis's objects; [`Axis::index`] gives
/// another axis's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Axis(u8);

impl Axis {
    /// The first axis (objects at 6000h–67FFh), the only one of a single-axis drive.
    pub const FIRST: Axis = Axis(0);
    /// How many axes a node may have.
    pub const MAX: u8 = 8;

    /// Axis `n` (0–7); `None` beyond the eighth.
    pub const fn new(n: u8) -> Option<Axis> {
        if n < Self::MAX {
            Some(Axis(n))
        } else {
            None
        }
    }

    /// The axis number, 0–7.
    pub const fn number(self) -> u8 {
        self.0
    }

    /// This axis's index of `index`, an index of the first axis's profile area; an index outside
    /// that area (communication, manufacturer-specific) is the same for every axis.
    pub const fn index(self, index: u16) -> u16 {
        if index >= *PROFILE_AREA.start() && index <= *PROFILE_AREA.end() {
            index + self.0 as u16 * COPY_STRIDE
        } else {
            index
        }
    }

    /// The axis whose profile area holds `index` (6000h–9FFFh), or `None` for an index outside
    /// them.
    pub const fn containing(index: u16) -> Option<Axis> {
        match index.checked_sub(*PROFILE_AREA.start()) {
            Some(offset) => Axis::new((offset / COPY_STRIDE) as u8),
            None => None,
        }
    }

    /// The first axis's index of `index` when it is an index of this axis's profile area.
    pub const fn relative(self, index: u16) -> Option<u16> {
        let start = *PROFILE_AREA.start() + self.0 as u16 * COPY_STRIDE;
        if index >= start && index - start <= *PROFILE_AREA.end() - *PROFILE_AREA.start() {
            Some(index - self.0 as u16 * COPY_STRIDE)
        } else {
            None
        }
    }
}

/// 6007h abort connection option code.
pub const ABORT_CONNECTION_OPTION_CODE: u16 = 0x6007;
/// 603Fh error code.
pub const ERROR_CODE: u16 = 0x603F;
/// 6040h controlword.
pub const CONTROLWORD: u16 = 0x6040;
/// vl target velocity (vl, 6042h).
pub const VL_TARGET_VELOCITY: u16 = 0x6042;
/// 6041h statusword.
pub const STATUSWORD: u16 = 0x6041;
/// 605Ah quick stop option code.
pub const QUICK_STOP_OPTION_CODE: u16 = 0x605A;
/// 605Bh shutdown option code.
pub const SHUTDOWN_OPTION_CODE: u16 = 0x605B;
/// 605Ch disable operation option code.
pub const DISABLE_OPERATION_OPTION_CODE: u16 = 0x605C;
/// 605Dh halt option code.
pub const HALT_OPTION_CODE: u16 = 0x605D;
/// 605Eh fault reaction option code.
pub const FAULT_REACTION_OPTION_CODE: u16 = 0x605E;
/// 6060h modes of operation.
pub const MODES_OF_OPERATION: u16 = 0x6060;
/// 6061h modes of operation display.
pub const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
/// 6062h position demand value (user units).
pub const POSITION_DEMAND_VALUE: u16 = 0x6062;
/// 6063h position actual internal value (increments).
pub const POSITION_ACTUAL_INTERNAL_VALUE: u16 = 0x6063;
/// 6064h position actual value.
pub const POSITION_ACTUAL_VALUE: u16 = 0x6064;
/// 6065h following error window.
pub const FOLLOWING_ERROR_WINDOW: u16 = 0x6065;
/// 6066h following error time out (ms).
pub const FOLLOWING_ERROR_TIME_OUT: u16 = 0x6066;
/// 6067h position window.
pub const POSITION_WINDOW: u16 = 0x6067;
/// 6068h position window time (ms).
pub const POSITION_WINDOW_TIME: u16 = 0x6068;
/// 606Ah sensor selection code: where the velocity actual value comes from (0 = the position
/// encoder, 1 = a velocity encoder, negative values manufacturer-specific). The board reads it
/// and fills [`Sample::velocity`](crate::hal::Sample) accordingly; the core only stores it.
pub const SENSOR_SELECTION_CODE: u16 = 0x606A;
/// 606Bh velocity demand value.
pub const VELOCITY_DEMAND_VALUE: u16 = 0x606B;
/// 606Ch velocity actual value.
pub const VELOCITY_ACTUAL_VALUE: u16 = 0x606C;
/// 606Dh velocity window.
pub const VELOCITY_WINDOW: u16 = 0x606D;
/// 606Eh velocity window time (ms).
pub const VELOCITY_WINDOW_TIME: u16 = 0x606E;
/// 606Fh velocity threshold.
pub const VELOCITY_THRESHOLD: u16 = 0x606F;
/// 6070h velocity threshold time (ms).
pub const VELOCITY_THRESHOLD_TIME: u16 = 0x6070;
/// 6071h target torque (‰ of rated torque).
pub const TARGET_TORQUE: u16 = 0x6071;
/// 6072h max torque (‰ of rated torque).
pub const MAX_TORQUE: u16 = 0x6072;
/// 6073h max current (‰ of rated current).
pub const MAX_CURRENT: u16 = 0x6073;
/// 6074h torque demand (‰ of rated torque).
pub const TORQUE_DEMAND: u16 = 0x6074;
/// 6077h torque actual value (‰ of rated torque).
pub const TORQUE_ACTUAL_VALUE: u16 = 0x6077;
/// 6078h current actual value (‰ of rated current).
pub const CURRENT_ACTUAL_VALUE: u16 = 0x6078;
/// 6079h DC link circuit voltage (mV).
pub const DC_LINK_VOLTAGE: u16 = 0x6079;
/// 607Ah target position.
pub const TARGET_POSITION: u16 = 0x607A;
/// 607Bh position range limit (sub 1 min, sub 2 max).
pub const POSITION_RANGE_LIMIT: u16 = 0x607B;
/// 607Ch home offset.
pub const HOME_OFFSET: u16 = 0x607C;
/// 607Dh software position limit (sub 1 min, sub 2 max).
pub const SOFTWARE_POSITION_LIMIT: u16 = 0x607D;
/// 607Eh polarity.
pub const POLARITY: u16 = 0x607E;
/// 607Fh max profile velocity.
pub const MAX_PROFILE_VELOCITY: u16 = 0x607F;
/// 6080h max motor speed (rpm).
pub const MAX_MOTOR_SPEED: u16 = 0x6080;
/// 6081h profile velocity.
pub const PROFILE_VELOCITY: u16 = 0x6081;
/// 6082h end velocity.
pub const END_VELOCITY: u16 = 0x6082;
/// 6083h profile acceleration.
pub const PROFILE_ACCELERATION: u16 = 0x6083;
/// 6084h profile deceleration.
pub const PROFILE_DECELERATION: u16 = 0x6084;
/// 6085h quick stop deceleration.
pub const QUICK_STOP_DECELERATION: u16 = 0x6085;
/// 6087h torque slope (‰ of rated torque per second).
pub const TORQUE_SLOPE: u16 = 0x6087;
/// 6086h motion profile type.
pub const MOTION_PROFILE_TYPE: u16 = 0x6086;
/// 6088h torque profile type.
pub const TORQUE_PROFILE_TYPE: u16 = 0x6088;
/// 608Fh position encoder resolution (sub 1 increments, sub 2 motor revolutions).
pub const POSITION_ENCODER_RESOLUTION: u16 = 0x608F;
/// 6090h velocity encoder resolution.
pub const VELOCITY_ENCODER_RESOLUTION: u16 = 0x6090;
/// 6091h gear ratio (sub 1 motor revolutions, sub 2 shaft revolutions).
pub const GEAR_RATIO: u16 = 0x6091;
/// 6092h feed constant (sub 1 feed, sub 2 shaft revolutions).
pub const FEED_CONSTANT: u16 = 0x6092;
/// 6098h homing method.
pub const HOMING_METHOD: u16 = 0x6098;
/// 6099h homing speeds (sub 1 switch search, sub 2 zero search).
pub const HOMING_SPEEDS: u16 = 0x6099;
/// 609Ah homing acceleration.
pub const HOMING_ACCELERATION: u16 = 0x609A;
/// 60A3h profile jerk use.
pub const PROFILE_JERK_USE: u16 = 0x60A3;
/// 60A4h profile jerk (subs 1–4).
pub const PROFILE_JERK: u16 = 0x60A4;
/// 60B0h position offset.
pub const POSITION_OFFSET: u16 = 0x60B0;
/// 60B1h velocity offset.
pub const VELOCITY_OFFSET: u16 = 0x60B1;
/// 60B2h torque offset.
pub const TORQUE_OFFSET: u16 = 0x60B2;
/// 60C2h interpolation time period (sub 1 value, sub 2 index: value × 10^index s).
pub const INTERPOLATION_TIME_PERIOD: u16 = 0x60C2;
/// 60C5h max acceleration.
pub const MAX_ACCELERATION: u16 = 0x60C5;
/// 60C6h max deceleration.
pub const MAX_DECELERATION: u16 = 0x60C6;
/// 60E3h supported homing methods (ARRAY of INTEGER8, constant: the methods 6098h accepts,
/// from [`super::hm::HomingConfig`], ascending).
pub const SUPPORTED_HOMING_METHODS: u16 = 0x60E3;
/// 60F2h positioning option code.
pub const POSITIONING_OPTION_CODE: u16 = 0x60F2;
/// 60F4h following error actual value.
pub const FOLLOWING_ERROR_ACTUAL_VALUE: u16 = 0x60F4;
/// 60F8h max slippage.
pub const MAX_SLIPPAGE: u16 = 0x60F8;
/// 60FAh control effort.
pub const CONTROL_EFFORT: u16 = 0x60FA;
/// 60FCh position demand internal value (increments).
pub const POSITION_DEMAND_INTERNAL_VALUE: u16 = 0x60FC;
/// 60FDh digital inputs.
pub const DIGITAL_INPUTS: u16 = 0x60FD;
/// 60FEh digital outputs (sub 1 physical outputs, sub 2 bit mask).
pub const DIGITAL_OUTPUTS: u16 = 0x60FE;

/// Whether the first axis's object `index` is process data: a set-point or a command a master
/// writes while the axis runs (controlword, modes of operation, targets, offsets, digital
/// outputs, the velocity mode's target). Writing one changes nothing the profile derives from
/// its configuration (the factor group, the limits, the cascade's gains).
pub const fn is_process_data(index: u16) -> bool {
    matches!(
        index,
        CONTROLWORD
            | MODES_OF_OPERATION
            | VL_TARGET_VELOCITY
            | TARGET_TORQUE
            | TARGET_POSITION
            | POSITION_OFFSET
            | VELOCITY_OFFSET
            | TORQUE_OFFSET
            | DIGITAL_OUTPUTS
            | TARGET_VELOCITY
    )
}
/// 60FFh target velocity.
pub const TARGET_VELOCITY: u16 = 0x60FF;
/// 6402h motor type.
pub const MOTOR_TYPE: u16 = 0x6402;
/// 6502h supported drive modes.
pub const SUPPORTED_DRIVE_MODES: u16 = 0x6502;

/// Modes of operation (6060h values, CiA 402-2 §8.4.10).
pub mod mode {
    /// Profile position.
    pub const PROFILE_POSITION: i8 = 1;
    /// Profile velocity.
    pub const PROFILE_VELOCITY: i8 = 3;
    /// Profile torque.
    pub const PROFILE_TORQUE: i8 = 4;
    /// Homing.
    pub const HOMING: i8 = 6;
    /// Interpolated position.
    pub const INTERPOLATED_POSITION: i8 = 7;
    /// Cyclic synchronous position.
    pub const CYCLIC_POSITION: i8 = 8;
    /// Cyclic synchronous velocity.
    pub const CYCLIC_VELOCITY: i8 = 9;
    /// Cyclic synchronous torque.
    pub const CYCLIC_TORQUE: i8 = 10;
}

/// 6502h bits (CiA 402-2 §8.4.12) of each mode.
pub mod mode_bit {
    /// Profile position.
    pub const PROFILE_POSITION: u32 = 1 << 0;
    /// Profile velocity.
    pub const PROFILE_VELOCITY: u32 = 1 << 2;
    /// Profile torque.
    pub const PROFILE_TORQUE: u32 = 1 << 3;
    /// Homing.
    pub const HOMING: u32 = 1 << 5;
    /// Interpolated position.
    pub const INTERPOLATED_POSITION: u32 = 1 << 6;
    /// Cyclic synchronous position.
    pub const CYCLIC_POSITION: u32 = 1 << 7;
    /// Cyclic synchronous velocity.
    pub const CYCLIC_VELOCITY: u32 = 1 << 8;
    /// Cyclic synchronous torque.
    pub const CYCLIC_TORQUE: u32 = 1 << 9;
}

/// The mode bits of 6502h that CiA 402 assigns (bits 0–9; the others are reserved or the
/// manufacturer's).
pub const STANDARD_MODES: u32 = 0x03FF;

/// A value the master commands (rw, RPDO-mappable).
pub(super) const fn command(index: u16, name: &'static str, data_type: DataType) -> Object {
    Object::var(index, name, Var::new(name, data_type).access(Access::ReadWrite).pdo(PdoMapping::Rpdo))
}

/// A value the drive reports (ro, TPDO-mappable).
pub(super) const fn actual(index: u16, name: &'static str, data_type: DataType) -> Object {
    Object::var(index, name, Var::new(name, data_type).pdo(PdoMapping::Tpdo))
}

/// A torque value (INTEGER16, ‰ of rated or the torque unit) that a firmware may widen to
/// INTEGER32 ([`Var::capacity`](crate::od::Var#structfield.capacity): 4 bytes of storage), as
/// drives with torques in mA do: a set-point the master commands (rw, RPDO-mappable) or a
/// value the drive reports (ro, TPDO-mappable).
pub(super) const fn torque(index: u16, name: &'static str, command: bool) -> Object {
    let var = Var::new(name, DataType::Integer16).capacity(4);
    let var =
        if command { var.access(Access::ReadWrite).pdo(PdoMapping::Rpdo) } else { var.pdo(PdoMapping::Tpdo) };
    Object::var(index, name, var)
}

/// A parameter the master may also map into an RPDO (rw), with its default.
pub(super) const fn setting(
    index: u16,
    name: &'static str,
    data_type: DataType,
    default: DefaultValue,
) -> Object {
    Object::var(
        index,
        name,
        Var::new(name, data_type).access(Access::ReadWrite).pdo(PdoMapping::Rpdo).default(default),
    )
}

/// A parameter (rw, not mappable) with its default.
pub(super) const fn parameter(
    index: u16,
    name: &'static str,
    data_type: DataType,
    default: DefaultValue,
) -> Object {
    Object::var(index, name, Var::new(name, data_type).access(Access::ReadWrite).default(default))
}

pub(super) const fn option_code(index: u16, name: &'static str, default: i64) -> Object {
    parameter(index, name, DataType::Integer16, DefaultValue::Signed(default))
}

pub(super) const fn text(index: u16, name: &'static str) -> Object {
    Object::var(index, name, Var::new(name, DataType::VisibleString).access(Access::ReadWrite).capacity(32))
}

pub(super) const fn highest_sub(n: u64) -> Var {
    Var::new("Highest sub-index supported", DataType::Unsigned8)
        .access(Access::Const)
        .default(DefaultValue::Unsigned(n))
}

pub(super) const fn bound(name: &'static str, default: i32) -> Var {
    Var::new(name, DataType::Integer32)
        .access(Access::ReadWrite)
        .default(DefaultValue::Signed(default as i64))
}

/// The value rule of a profile object beyond type and limits (CiA 402-2 §8.4–§10), decided from the
/// index once: per SDO write, or once when a PDO mapping is validated (an RPDO's entries without
/// a rule are then plain copies).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Rule {
    /// 6007h: the option codes the configuration supports.
    AbortConnectionOption = 1,
    /// 605Ah.
    QuickStopOption,
    /// 605Bh.
    ShutdownOption,
    /// 605Ch.
    DisableOperationOption,
    /// 605Dh.
    HaltOption,
    /// 605Eh.
    FaultReactionOption,
    /// 6060h: 0, a mode 6502h lists and this build runs, or a manufacturer mode; with
    /// `mode_change_in_operation` off, no other mode in Operation enabled.
    Mode,
    /// 6086h: the motion profile types of `motion::ProfileType`.
    MotionProfileType,
    /// 6088h: linear only.
    TorqueProfileType,
    /// 60A4h sub 0 … (jerk use): 1, 2 or 4.
    JerkUse,
    /// 6098h: the methods the configuration supports.
    HomingMethod,
    /// 60B8h.
    TouchProbe,
    /// 60F2h: relative options 00/01/10 only.
    PositioningOption,
    /// The vl factors and ramps: no zeros where a ratio or a slope needs them.
    Velocity,
    /// The factor group: no zero in a ratio, no reserved polarity bit.
    Factor,
    /// 60C0h, 60C2h: the ip sub-mode and the interpolation time period.
    Interpolation,
    /// 60C1h by SDO: refused while the ip buffer is disabled or full.
    InterpolationRecord,
    /// 60C1h as process data: taken; a full or disabled buffer drops it and reports it in the
    /// statusword (bit 7), as the profile documents for RPDOs.
    InterpolationRecordPdo,
    /// 60C4h: the buffer configuration.
    InterpolationConfiguration,
    /// The cascade's parameter record (`ProfileConfig::cascade`).
    Cascade,
}

impl Rule {
    /// Every rule, by its `u8` value minus one ([`Rule::from_raw`]).
    const ALL: [Rule; 20] = [
        Rule::AbortConnectionOption,
        Rule::QuickStopOption,
        Rule::ShutdownOption,
        Rule::DisableOperationOption,
        Rule::HaltOption,
        Rule::FaultReactionOption,
        Rule::Mode,
        Rule::MotionProfileType,
        Rule::TorqueProfileType,
        Rule::JerkUse,
        Rule::HomingMethod,
        Rule::TouchProbe,
        Rule::PositioningOption,
        Rule::Velocity,
        Rule::Factor,
        Rule::Interpolation,
        Rule::InterpolationRecord,
        Rule::InterpolationRecordPdo,
        Rule::InterpolationConfiguration,
        Rule::Cascade,
    ];

    /// The rule whose `u8` value is `raw` (a PDO mapping keeps its entries' rules as bytes).
    pub fn from_raw(raw: u8) -> Option<Rule> {
        Rule::ALL.get(usize::from(raw).checked_sub(1)?).copied()
    }

    /// Whether the profile reacts to a value written under this rule (the ip buffer takes it;
    /// the option codes the tick keeps are read again).
    pub fn reacts(self) -> bool {
        self.is_option_code()
            || matches!(
                self,
                Rule::InterpolationRecord | Rule::InterpolationRecordPdo | Rule::InterpolationConfiguration
            )
    }

    /// An option code the state machine takes (605Ah–605Eh).
    pub(crate) fn is_option_code(self) -> bool {
        matches!(
            self,
            Rule::QuickStopOption
                | Rule::ShutdownOption
                | Rule::DisableOperationOption
                | Rule::HaltOption
                | Rule::FaultReactionOption
        )
    }
}

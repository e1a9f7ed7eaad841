//! Objects of the CiA 402 profile area (6000h–67FFh) this build implements (digest
//! `cia402-objects.csv`), with their CiA 402 defaults, and the value rules SDO writes must obey.

use crate::od::{layout, AbortCode, Access, DataType, DefaultValue, Object, PdoMapping, Var};

/// 6007h abort connection option code.
pub const ABORT_CONNECTION_OPTION_CODE: u16 = 0x6007;
/// 603Fh error code.
pub const ERROR_CODE: u16 = 0x603F;
/// 6040h controlword.
pub const CONTROLWORD: u16 = 0x6040;
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
/// 6064h position actual value.
pub const POSITION_ACTUAL_VALUE: u16 = 0x6064;
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
/// 6074h torque demand (‰ of rated torque).
pub const TORQUE_DEMAND: u16 = 0x6074;
/// 6077h torque actual value (‰ of rated torque).
pub const TORQUE_ACTUAL_VALUE: u16 = 0x6077;
/// 6079h DC link circuit voltage (mV).
pub const DC_LINK_VOLTAGE: u16 = 0x6079;
/// 607Ah target position.
pub const TARGET_POSITION: u16 = 0x607A;
/// 6083h profile acceleration.
pub const PROFILE_ACCELERATION: u16 = 0x6083;
/// 6084h profile deceleration.
pub const PROFILE_DECELERATION: u16 = 0x6084;
/// 6085h quick stop deceleration.
pub const QUICK_STOP_DECELERATION: u16 = 0x6085;
/// 6087h torque slope (‰ of rated torque per second).
pub const TORQUE_SLOPE: u16 = 0x6087;
/// 60C6h max deceleration.
pub const MAX_DECELERATION: u16 = 0x60C6;
/// 60FDh digital inputs.
pub const DIGITAL_INPUTS: u16 = 0x60FD;
/// 60FEh digital outputs (sub 1 physical outputs, sub 2 bit mask).
pub const DIGITAL_OUTPUTS: u16 = 0x60FE;
/// 60FFh target velocity.
pub const TARGET_VELOCITY: u16 = 0x60FF;
/// 6402h motor type.
pub const MOTOR_TYPE: u16 = 0x6402;
/// 6502h supported drive modes.
pub const SUPPORTED_DRIVE_MODES: u16 = 0x6502;

/// Modes of operation (6060h values, digest §7.1).
pub mod mode {
    /// Profile position.
    pub const PROFILE_POSITION: i8 = 1;
    /// Profile velocity.
    pub const PROFILE_VELOCITY: i8 = 3;
    /// Profile torque.
    pub const PROFILE_TORQUE: i8 = 4;
}

/// 6502h bits of the modes this build runs: pv (bit 2) and tq (bit 3).
pub const SUPPORTED_MODES: u32 = (1 << 2) | (1 << 3);

/// A value the master commands (rw, RPDO-mappable).
const fn command(index: u16, name: &'static str, data_type: DataType) -> Object {
    Object::var(index, name, Var::new(name, data_type).access(Access::ReadWrite).pdo(PdoMapping::Rpdo))
}

/// A value the drive reports (ro, TPDO-mappable).
const fn actual(index: u16, name: &'static str, data_type: DataType) -> Object {
    Object::var(index, name, Var::new(name, data_type).pdo(PdoMapping::Tpdo))
}

/// A parameter (rw, not mappable) with its default.
const fn parameter(index: u16, name: &'static str, data_type: DataType, default: DefaultValue) -> Object {
    Object::var(index, name, Var::new(name, data_type).access(Access::ReadWrite).default(default))
}

const fn option_code(index: u16, name: &'static str, default: i64) -> Object {
    parameter(index, name, DataType::Integer16, DefaultValue::Signed(default))
}

const fn text(index: u16, name: &'static str) -> Object {
    Object::var(index, name, Var::new(name, DataType::VisibleString).access(Access::ReadWrite).capacity(32))
}

const DIGITAL_OUTPUT_SUBS: [(u8, Var); 3] = [
    (
        0,
        Var::new("Highest sub-index supported", DataType::Unsigned8)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(2)),
    ),
    (1, Var::new("Physical outputs", DataType::Unsigned32).access(Access::ReadWrite).pdo(PdoMapping::Rpdo)),
    (2, Var::new("Bit mask", DataType::Unsigned32).access(Access::ReadWrite)),
];

/// The profile objects, ascending.
pub static PROFILE: [Object; 41] = layout([
    option_code(ABORT_CONNECTION_OPTION_CODE, "Abort connection option code", 1),
    actual(ERROR_CODE, "Error code", DataType::Unsigned16),
    command(CONTROLWORD, "Controlword", DataType::Unsigned16),
    actual(STATUSWORD, "Statusword", DataType::Unsigned16),
    option_code(QUICK_STOP_OPTION_CODE, "Quick stop option code", 2),
    option_code(SHUTDOWN_OPTION_CODE, "Shutdown option code", 0),
    option_code(DISABLE_OPERATION_OPTION_CODE, "Disable operation option code", 1),
    option_code(HALT_OPTION_CODE, "Halt option code", 1),
    option_code(FAULT_REACTION_OPTION_CODE, "Fault reaction option code", 2),
    command(MODES_OF_OPERATION, "Modes of operation", DataType::Integer8),
    actual(MODES_OF_OPERATION_DISPLAY, "Modes of operation display", DataType::Integer8),
    actual(POSITION_ACTUAL_VALUE, "Position actual value", DataType::Integer32),
    actual(VELOCITY_DEMAND_VALUE, "Velocity demand value", DataType::Integer32),
    actual(VELOCITY_ACTUAL_VALUE, "Velocity actual value", DataType::Integer32),
    parameter(VELOCITY_WINDOW, "Velocity window", DataType::Unsigned16, DefaultValue::Zero),
    parameter(VELOCITY_WINDOW_TIME, "Velocity window time", DataType::Unsigned16, DefaultValue::Zero),
    parameter(VELOCITY_THRESHOLD, "Velocity threshold", DataType::Unsigned16, DefaultValue::Zero),
    parameter(VELOCITY_THRESHOLD_TIME, "Velocity threshold time", DataType::Unsigned16, DefaultValue::Zero),
    command(TARGET_TORQUE, "Target torque", DataType::Integer16),
    parameter(MAX_TORQUE, "Max torque", DataType::Unsigned16, DefaultValue::Unsigned(3000)),
    actual(TORQUE_DEMAND, "Torque demand", DataType::Integer16),
    actual(TORQUE_ACTUAL_VALUE, "Torque actual value", DataType::Integer16),
    actual(DC_LINK_VOLTAGE, "DC link circuit voltage", DataType::Unsigned32),
    command(TARGET_POSITION, "Target position", DataType::Integer32),
    parameter(
        PROFILE_ACCELERATION,
        "Profile acceleration",
        DataType::Unsigned32,
        DefaultValue::Unsigned(10_000),
    ),
    parameter(
        PROFILE_DECELERATION,
        "Profile deceleration",
        DataType::Unsigned32,
        DefaultValue::Unsigned(10_000),
    ),
    parameter(
        QUICK_STOP_DECELERATION,
        "Quick stop deceleration",
        DataType::Unsigned32,
        DefaultValue::Unsigned(50_000),
    ),
    parameter(TORQUE_SLOPE, "Torque slope", DataType::Unsigned32, DefaultValue::Unsigned(10_000)),
    parameter(MAX_DECELERATION, "Max deceleration", DataType::Unsigned32, DefaultValue::Unsigned(100_000)),
    actual(DIGITAL_INPUTS, "Digital inputs", DataType::Unsigned32),
    Object::record(DIGITAL_OUTPUTS, "Digital outputs", &DIGITAL_OUTPUT_SUBS),
    command(TARGET_VELOCITY, "Target velocity", DataType::Integer32),
    // Identification (digest §20.2): not assigned until the firmware or the master sets them.
    parameter(MOTOR_TYPE, "Motor type", DataType::Unsigned16, DefaultValue::Unsigned(0x7FFF)),
    text(0x6403, "Motor catalogue number"),
    text(0x6404, "Motor manufacturer"),
    text(0x6405, "http motor catalogue address"),
    parameter(0x6406, "Motor calibration date", DataType::TimeOfDay, DefaultValue::Zero),
    parameter(0x6407, "Motor service period", DataType::Unsigned32, DefaultValue::Zero),
    Object::var(
        SUPPORTED_DRIVE_MODES,
        "Supported drive modes",
        Var::new("Supported drive modes", DataType::Unsigned32)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(SUPPORTED_MODES as u64)),
    ),
    text(0x6503, "Drive catalogue number"),
    text(0x6505, "http drive catalogue address"),
]);

/// Value rules of the profile objects beyond type and limits (digest §6, §7): reserved option
/// codes and unsupported modes are refused with 0x0609_0030.
pub fn check_write(index: u16, data: &[u8]) -> Result<(), AbortCode> {
    let value = i16::from_le_bytes([data.first().copied().unwrap_or(0), data.get(1).copied().unwrap_or(0)]);
    let valid = match index {
        ABORT_CONNECTION_OPTION_CODE => (0..=3).contains(&value),
        QUICK_STOP_OPTION_CODE => (0..=8).contains(&value),
        SHUTDOWN_OPTION_CODE | DISABLE_OPERATION_OPTION_CODE => (0..=1).contains(&value),
        HALT_OPTION_CODE => (1..=4).contains(&value),
        FAULT_REACTION_OPTION_CODE => (0..=4).contains(&value),
        MODES_OF_OPERATION => {
            let mode = data.first().map_or(0, |b| *b as i8);
            mode == 0 || (1..=10).contains(&mode) && SUPPORTED_MODES & (1 << (mode - 1)) != 0
        }
        _ => true,
    };
    if valid {
        Ok(())
    } else {
        Err(AbortCode::InvalidValue)
    }
}

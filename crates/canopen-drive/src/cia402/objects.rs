//! Objects of the CiA 402 profile area (6000h–67FFh) that the default PDO mapping carries
//! (digest `cia402-objects.csv`).

use crate::od::{layout, Access, DataType, Object, PdoMapping, Var};

/// 6040h controlword.
pub const CONTROLWORD: u16 = 0x6040;
/// 6041h statusword.
pub const STATUSWORD: u16 = 0x6041;
/// 6060h modes of operation.
pub const MODES_OF_OPERATION: u16 = 0x6060;
/// 6061h modes of operation display.
pub const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
/// 6064h position actual value.
pub const POSITION_ACTUAL_VALUE: u16 = 0x6064;
/// 606Ch velocity actual value.
pub const VELOCITY_ACTUAL_VALUE: u16 = 0x606C;
/// 607Ah target position.
pub const TARGET_POSITION: u16 = 0x607A;
/// 60FFh target velocity.
pub const TARGET_VELOCITY: u16 = 0x60FF;

/// A value the master commands (rw, RPDO-mappable).
const fn command(index: u16, name: &'static str, data_type: DataType) -> Object {
    Object::var(index, name, Var::new(name, data_type).access(Access::ReadWrite).pdo(PdoMapping::Rpdo))
}

/// A value the drive reports (ro, TPDO-mappable).
const fn actual(index: u16, name: &'static str, data_type: DataType) -> Object {
    Object::var(index, name, Var::new(name, data_type).pdo(PdoMapping::Tpdo))
}

/// The process-data objects, ascending.
pub static PROCESS_DATA: [Object; 8] = layout([
    command(CONTROLWORD, "Controlword", DataType::Unsigned16),
    actual(STATUSWORD, "Statusword", DataType::Unsigned16),
    command(MODES_OF_OPERATION, "Modes of operation", DataType::Integer8),
    actual(MODES_OF_OPERATION_DISPLAY, "Modes of operation display", DataType::Integer8),
    actual(POSITION_ACTUAL_VALUE, "Position actual value", DataType::Integer32),
    actual(VELOCITY_ACTUAL_VALUE, "Velocity actual value", DataType::Integer32),
    command(TARGET_POSITION, "Target position", DataType::Integer32),
    command(TARGET_VELOCITY, "Target velocity", DataType::Integer32),
]);

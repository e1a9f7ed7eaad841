//! The profile's registry (above the modes): the table of the profile objects this build
//! implements, assembled from the objects no single mode owns and each mode's own (CiA 402-2
//! §6–§20, with their CiA 402 defaults), the modes this build runs, and the value rules an SDO
//! write must obey, each mode asked for the rules of its own objects.
//!
//! [`super::objects`] is the leaf every mode imports (indices, [`Rule`], the constructors); this
//! module imports the modes, so that no module of `cia402` imports one that imports it back.

use super::config::{OptionCodes, ProfileConfig};
use super::objects::*;
use crate::od::{
    first_level, layout, AbortCode, Access, DataType, DefaultValue, DeviceField, DeviceInfo, Dictionary,
    FirstLevel, Object, PdoMapping, Var,
};

/// The modes this build runs (the default of [`crate::od::DeviceInfo::drive_modes`], and the
/// most it may list): pv, tq, csp, csv and cst always; pp, vl, hm and ip with their cargo
/// features (all of CiA 402's modes by default).
pub const IMPLEMENTED_MODES: u32 = mode_bit::PROFILE_VELOCITY
    | mode_bit::PROFILE_TORQUE
    | mode_bit::CYCLIC_POSITION
    | mode_bit::CYCLIC_VELOCITY
    | mode_bit::CYCLIC_TORQUE
    | if super::PP { mode_bit::PROFILE_POSITION } else { 0 }
    | if super::VL { super::vl::MODE_BIT } else { 0 }
    | if super::HM { mode_bit::HOMING } else { 0 }
    | if super::IP { mode_bit::INTERPOLATED_POSITION } else { 0 };

// The CiA 402 defaults of the identity live with the modes they list (the dictionary layer
// below does not know which modes this build runs).
impl DeviceInfo {
    /// A CiA 402 servo drive (device type 0x0002_0192) with empty identity.
    pub const fn servo_drive() -> Self {
        DeviceInfo {
            device_type: 0x0002_0192,
            vendor_id: 0,
            product_code: 0,
            revision_number: 0,
            serial_number: 0,
            device_name: "canopen-drive",
            hardware_version: "",
            software_version: env!("CARGO_PKG_VERSION"),
            vendor_name: "",
            eds: &[],
            drive_modes: IMPLEMENTED_MODES,
        }
    }
}

impl Default for DeviceInfo {
    fn default() -> Self {
        Self::servo_drive()
    }
}

/// 607Bh: no wrap within the i32 range by default.
const POSITION_RANGE_SUBS: [(u8, Var); 3] = [
    (0, highest_sub(2)),
    (1, bound("Min position range limit", i32::MIN)),
    (2, bound("Max position range limit", i32::MAX)),
];
/// 607Dh: no limit within the i32 range by default.
const SOFTWARE_LIMIT_SUBS: [(u8, Var); 3] = [
    (0, highest_sub(2)),
    (1, bound("Min position limit", i32::MIN)),
    (2, bound("Max position limit", i32::MAX)),
];

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

/// The objects every build has that no single mode owns: the state machine's words and option
/// codes, the modes, the actual and demand values, the limits, windows and ramps several modes
/// share, the identification. The modes' own objects are in their modules (`OBJECTS` of
/// [`super::pp`], [`super::hm`], [`super::ip`], [`super::vl`], [`super::probe`],
/// [`super::factor`]).
const COMMON: [Object; 67] = [
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
    actual(POSITION_DEMAND_VALUE, "Position demand value", DataType::Integer32),
    actual(POSITION_ACTUAL_INTERNAL_VALUE, "Position actual internal value", DataType::Integer32),
    actual(POSITION_ACTUAL_VALUE, "Position actual value", DataType::Integer32),
    parameter(
        FOLLOWING_ERROR_WINDOW,
        "Following error window",
        DataType::Unsigned32,
        DefaultValue::Unsigned(10_000),
    ),
    parameter(
        FOLLOWING_ERROR_TIME_OUT,
        "Following error time out",
        DataType::Unsigned16,
        DefaultValue::Unsigned(100),
    ),
    parameter(POSITION_WINDOW, "Position window", DataType::Unsigned32, DefaultValue::Unsigned(100)),
    parameter(POSITION_WINDOW_TIME, "Position window time", DataType::Unsigned16, DefaultValue::Unsigned(10)),
    parameter(SENSOR_SELECTION_CODE, "Sensor selection code", DataType::Integer16, DefaultValue::Zero),
    actual(VELOCITY_DEMAND_VALUE, "Velocity demand value", DataType::Integer32),
    actual(VELOCITY_ACTUAL_VALUE, "Velocity actual value", DataType::Integer32),
    parameter(VELOCITY_WINDOW, "Velocity window", DataType::Unsigned16, DefaultValue::Zero),
    parameter(VELOCITY_WINDOW_TIME, "Velocity window time", DataType::Unsigned16, DefaultValue::Zero),
    parameter(VELOCITY_THRESHOLD, "Velocity threshold", DataType::Unsigned16, DefaultValue::Zero),
    parameter(VELOCITY_THRESHOLD_TIME, "Velocity threshold time", DataType::Unsigned16, DefaultValue::Zero),
    torque(TARGET_TORQUE, "Target torque", true),
    setting(MAX_TORQUE, "Max torque", DataType::Unsigned16, DefaultValue::Unsigned(3000)),
    setting(MAX_CURRENT, "Max current", DataType::Unsigned16, DefaultValue::Unsigned(3000)),
    torque(TORQUE_DEMAND, "Torque demand", false),
    parameter(0x6075, "Motor rated current", DataType::Unsigned32, DefaultValue::Zero),
    parameter(0x6076, "Motor rated torque", DataType::Unsigned32, DefaultValue::Zero),
    torque(TORQUE_ACTUAL_VALUE, "Torque actual value", false),
    torque(CURRENT_ACTUAL_VALUE, "Current actual value", false),
    actual(DC_LINK_VOLTAGE, "DC link circuit voltage", DataType::Unsigned32),
    command(TARGET_POSITION, "Target position", DataType::Integer32),
    Object::record(POSITION_RANGE_LIMIT, "Position range limit", &POSITION_RANGE_SUBS),
    parameter(HOME_OFFSET, "Home offset", DataType::Integer32, DefaultValue::Zero),
    Object::record(SOFTWARE_POSITION_LIMIT, "Software position limit", &SOFTWARE_LIMIT_SUBS),
    setting(
        MAX_PROFILE_VELOCITY,
        "Max profile velocity",
        DataType::Unsigned32,
        DefaultValue::Unsigned(u32::MAX as u64),
    ),
    parameter(
        MAX_MOTOR_SPEED,
        "Max motor speed",
        DataType::Unsigned32,
        DefaultValue::Unsigned(u32::MAX as u64),
    ),
    setting(
        PROFILE_ACCELERATION,
        "Profile acceleration",
        DataType::Unsigned32,
        DefaultValue::Unsigned(10_000),
    ),
    setting(
        PROFILE_DECELERATION,
        "Profile deceleration",
        DataType::Unsigned32,
        DefaultValue::Unsigned(10_000),
    ),
    setting(
        QUICK_STOP_DECELERATION,
        "Quick stop deceleration",
        DataType::Unsigned32,
        DefaultValue::Unsigned(50_000),
    ),
    setting(TORQUE_SLOPE, "Torque slope", DataType::Unsigned32, DefaultValue::Unsigned(10_000)),
    parameter(TORQUE_PROFILE_TYPE, "Torque profile type", DataType::Integer16, DefaultValue::Zero),
    command(0x60B0, "Position offset", DataType::Integer32),
    command(0x60B1, "Velocity offset", DataType::Integer32),
    torque(TORQUE_OFFSET, "Torque offset", true),
    super::ip::TIME_PERIOD_OBJECT,
    setting(MAX_ACCELERATION, "Max acceleration", DataType::Unsigned32, DefaultValue::Unsigned(100_000)),
    setting(MAX_DECELERATION, "Max deceleration", DataType::Unsigned32, DefaultValue::Unsigned(100_000)),
    actual(FOLLOWING_ERROR_ACTUAL_VALUE, "Following error actual value", DataType::Integer32),
    parameter(MAX_SLIPPAGE, "Max slippage", DataType::Integer32, DefaultValue::Zero),
    actual(CONTROL_EFFORT, "Control effort", DataType::Integer32),
    actual(POSITION_DEMAND_INTERNAL_VALUE, "Position demand internal value", DataType::Integer32),
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
            .default(DefaultValue::Device(DeviceField::DriveModes)),
    ),
    text(0x6503, "Drive catalogue number"),
    text(0x6505, "http drive catalogue address"),
];

/// How many objects [`PROFILE`] has in this build (104 with every mode, 72 with none of the
/// optional ones).
pub const PROFILE_LEN: usize =
    COMMON.len() + super::factor::OBJECTS.len() + PP.len() + HM.len() + IP.len() + VL.len() + PROBE.len();

// A mode's objects are in the table when the build runs the mode.
const PP: &[Object] = if super::PP { &super::pp::OBJECTS } else { &[] };
const HM: &[Object] = if super::HM { &super::hm::OBJECTS } else { &[] };
const IP: &[Object] = if super::IP { &super::ip::OBJECTS } else { &[] };
const VL: &[Object] = if super::VL { &super::vl::OBJECTS } else { &[] };
const PROBE: &[Object] = if super::PROBE { &super::probe::OBJECTS } else { &[] };

/// The profile objects, ascending: the common ones and those of the modes this build runs
/// (cargo features `pp`, `hm`, `ip`, `vl`, `touch-probe`), each declared by its module.
pub static PROFILE: [Object; PROFILE_LEN] =
    layout(merged(&[&COMMON, &super::factor::OBJECTS, PP, HM, IP, VL, PROBE]));

/// [`PROFILE`]'s first level of look-up (its objects grouped by index).
pub(crate) static PROFILE_FIRST_LEVEL: FirstLevel = first_level(&PROFILE);

/// 67FFh: the device type of one logical device (axis) of a node with several (CiA 402 §4.2:
/// each axis at 67FFh + n × 800h; 1000h then carries the multi-device marker).
pub const LOGICAL_DEVICE_TYPE: u16 = 0x67FF;

const DEVICE_TYPE_OF_AXIS: [Object; 1] = [Object::var(
    LOGICAL_DEVICE_TYPE,
    "Device type",
    Var::new("Device type", DataType::Unsigned32)
        .access(Access::Const)
        .default(DefaultValue::Device(DeviceField::LogicalDeviceType)),
)];

/// The profile objects of one axis of a multi-axis node: [`PROFILE`] and 67FFh
/// ([`LOGICAL_DEVICE_TYPE`]). One description, which the dictionary attaches once per axis
/// ([`Dictionary::attach_copies`]); a single-axis drive links [`PROFILE`] only.
pub static AXIS_PROFILE: [Object; PROFILE_LEN + 1] =
    layout(merged(&[&COMMON, &super::factor::OBJECTS, PP, HM, IP, VL, PROBE, &DEVICE_TYPE_OF_AXIS]));

/// [`AXIS_PROFILE`]'s first level of look-up.
pub(crate) static AXIS_PROFILE_FIRST_LEVEL: FirstLevel = first_level(&AXIS_PROFILE);

/// The objects of `parts` in one table ascending by index (at compile time). `N` must be
/// their number, and no index may come twice.
// Evaluated at compile time only (`PROFILE`): a `while` over the lengths (a const fn has no
// iterators); an index beyond `N` or a failed assertion fails the build.
#[allow(clippy::indexing_slicing)]
const fn merged<const N: usize>(parts: &[&[Object]]) -> [Object; N] {
    let mut out = [Object::var(0, "", Var::new("", DataType::Unsigned8)); N];
    let mut n = 0;
    let mut p = 0;
    while p < parts.len() {
        let part = parts[p];
        let mut k = 0;
        while k < part.len() {
            let object = part[k];
            // Insertion: the objects above it move up one place.
            let mut at = n;
            while at > 0 && out[at - 1].index > object.index {
                out[at] = out[at - 1];
                at -= 1;
            }
            assert!(at == 0 || out[at - 1].index != object.index, "an object declared twice");
            out[at] = object;
            n += 1;
            k += 1;
        }
        p += 1;
    }
    assert!(n == N, "N is not the number of objects");
    out
}

/// The rule of `index`/`sub` (an object of the profile's tables, or the cascade's record);
/// `pdo`: as an RPDO writes it. `None`: type, access and limits are all there is to check.
/// The state machine's and the modes' common objects are ruled here; each mode rules its own
/// objects (`rule` of [`super::pp`], [`super::hm`], [`super::probe`], [`super::vl`],
/// [`super::factor`], [`super::ip`]).
pub fn rule(config: &ProfileConfig, index: u16, sub: u8, pdo: bool) -> Option<Rule> {
    let common = match index {
        ABORT_CONNECTION_OPTION_CODE => Some(Rule::AbortConnectionOption),
        QUICK_STOP_OPTION_CODE => Some(Rule::QuickStopOption),
        SHUTDOWN_OPTION_CODE => Some(Rule::ShutdownOption),
        DISABLE_OPERATION_OPTION_CODE => Some(Rule::DisableOperationOption),
        HALT_OPTION_CODE => Some(Rule::HaltOption),
        FAULT_REACTION_OPTION_CODE => Some(Rule::FaultReactionOption),
        MODES_OF_OPERATION => Some(Rule::Mode),
        TORQUE_PROFILE_TYPE => Some(Rule::TorqueProfileType),
        _ => None,
    };
    common
        .or_else(|| super::pp::rule(index))
        .or_else(|| super::hm::rule(index))
        .or_else(|| super::probe::rule(index))
        .or_else(|| super::vl::rule(index))
        .or_else(|| super::factor::rule(index))
        .or_else(|| super::ip::rule(index, sub, pdo))
        .or_else(|| (config.cascade == Some(index)).then_some(Rule::Cascade))
}

/// Checks `data` against the rules of the configuration (the option codes it supports, the modes
/// 6502h lists, the homing methods, …): every [`Rule`] but those that also need the drive's
/// state ([`Rule::Mode`] in Operation enabled, the ip buffer, the cascade), which the profile
/// checks (`Profile::check`) and which pass here.
/// `supported_modes` is 6502h.
pub fn check(
    rule: Rule,
    config: &ProfileConfig,
    supported_modes: u32,
    index: u16,
    sub: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    let raw = data.iter().take(4).rev().fold(0u32, |acc, b| (acc << 8) | u32::from(*b));
    let value = raw as u16 as i16;
    let codes = &config.option_codes;
    let valid = match rule {
        Rule::AbortConnectionOption => OptionCodes::allows(codes.abort_connection, value),
        Rule::QuickStopOption => OptionCodes::allows(codes.quick_stop, value),
        Rule::ShutdownOption => OptionCodes::allows(codes.shutdown, value),
        Rule::DisableOperationOption => OptionCodes::allows(codes.disable_operation, value),
        Rule::HaltOption => OptionCodes::allows(codes.halt, value),
        Rule::FaultReactionOption => OptionCodes::allows(codes.fault_reaction, value),
        Rule::Mode => {
            let mode = raw as u8 as i8;
            mode == 0
                || (1..=10).contains(&mode) && supported_modes & IMPLEMENTED_MODES & (1 << (mode - 1)) != 0
                || config.manufacturer_mode(mode).is_some()
        }
        Rule::TorqueProfileType => value == 0,
        Rule::MotionProfileType | Rule::JerkUse | Rule::PositioningOption => super::pp::check(rule, raw),
        Rule::HomingMethod => config.homing.supports(raw as u8 as i8),
        Rule::TouchProbe => return super::probe::check_write(raw as u16),
        Rule::Velocity => return super::vl::check_write(index, sub, data),
        Rule::Factor => return super::factor::check_write(index, sub, raw),
        Rule::Interpolation
        | Rule::InterpolationRecord
        | Rule::InterpolationRecordPdo
        | Rule::InterpolationConfiguration
        | Rule::Cascade => true,
    };
    if valid {
        Ok(())
    } else {
        Err(AbortCode::InvalidValue)
    }
}

/// Value rules of the profile objects beyond type and limits that the configuration decides
/// ([`rule`] and [`check`] of an SDO write, for values at rest).
pub fn check_write<const B: usize>(
    od: &Dictionary<B>,
    config: &ProfileConfig,
    index: u16,
    sub: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    let Some(rule) = rule(config, index, sub, false) else { return Ok(()) };
    let supported_modes = od.get::<u32>(SUPPORTED_DRIVE_MODES, 0).unwrap_or(0);
    check(rule, config, supported_modes, index, sub, data)
}

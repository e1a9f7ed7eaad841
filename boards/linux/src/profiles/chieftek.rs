//! A Chieftek (cpc) servo drive as its DS402 manual (revision 1.0, December 2017) describes
//! it, rebuilt on the core. The manual covers the drive profile only: no communication objects,
//! identity or PDO defaults, so those are the library's. Section numbers are the manual's.
//!
//! # Drive profile
//!
//! Modes pp, pv, tq, hm, csp, csv, cst (6502h = 3ADh, §3.2). Option codes (§4.3.3–4.3.7):
//! 605Ah 0–4, 605Bh 0–1, 605Ch 0–1, 605Dh 1–4, 605Eh 0–4, 6007h 0–3, with the manual's defaults
//! (605Ch 0, 605Eh 0, 6007h 0). Documented deviations, as configuration of the core: modes
//! change only outside Operation enabled (§5.1: a write of another mode in Operation enabled is
//! refused with 0800 0022h); statusword bit 14 is 1 while the drive is getting ready to move or
//! a quick stop runs (§4.3.2.1); a following error is a fault (§7.2, 6066h); one buffered
//! set-point (§6.3.3). The manual's defaults of the motion objects (607Fh/6080h 1 500 000,
//! 6081h 2 000 000, 6083h/6084h 1 000 000, 6085h 100 000 000, 6087h 100 000, 6098h 35,
//! 6099h 20 000, 609Ah 20 000, 60B8h 1), and its zeros of 6065h–6068h and 6073h: until a
//! master commissions those (following error and position windows, peak current), a move
//! faults with a following error and no torque reaches the motor, as on the real drive. Units:
//! counts, counts/s, 0.1 % (the core's).
//!
//! Also configuration of the core: 607Ch is the position value of the home position (§8.3:
//! 6064h reads +607Ch at home, `HomeOffset::HomeValue`; the software limits 607Dh are then
//! position values as 6064h reads them); the software limits act only once the axis is homed
//! (§6.4, `ProfileConfig::software_limits_after_homing`); with halt, target reached waits
//! until the shaft rests (§6.2.2, `ProfileConfig::halt_reached_at_standstill`); 6072h, 6086h,
//! 608Fh, 6091h, 60C1h and 60C5h, which the manual does not list, do not exist ([`ABSENT`]).
//!
//! The touch probe edge counters 60D5h–60D8h (§9.2) and the supported homing methods 60E3h
//! (§8.3: the 44 methods below, cpc methods first) are the core's.
//!
//! Homing (§8): the standard methods 1–14, 17–30, 33–35 and 37 (= 35), and the cpc methods
//! −1…−12: −1/−2 the positive/negative hard stop, −3/−4 the index pulse after it, −5/−6 the
//! middle between the hard stops (positive / negative first), −7/−8 the middle between the
//! limit switches, −9…−12 the middle of the home switch (positive / negative first). A hard
//! stop is a current above 3293h × the peak current 6073h for longer than 3294h ms.
//!
//! The simulated axis is the generic one (10 000 counts per revolution, limit switches beyond
//! ±100 000, home switch 20 000..30 000, elastic hard stops at ±120 000).
//!
//! # Manufacturer objects
//!
//! 3293h hard stop current (REAL32, a fraction of the peak current, 0.01–0.9) and 3294h hard
//! stop period (ms) work: the firmware turns them into the core's hard-stop parameters, kept in
//! the board's record at 5E10h (next to the simulation objects 5E00h–5E02h).
//!
//! 6080h is in count/s as 607Fh (`Units::motor_speed`), and the two are one value: a write of
//! either sets both (the firmware's `written`). The manufacturer modes −4/−3/−2 (direct
//! position, velocity, torque) run as the core's direct set-point modes
//! (`ProfileConfig::manufacturer_modes`).
//!
//! The manual's PDO mappability of the standard entries (its table in §2.3) is the core's
//! descriptions overridden ([`DESCRIPTIONS`]); 6502h, a constant, stays unmappable.
//!
//! # Not reproduced
//!
//! The manufacturer modes −1 (direct voltage: the power stage's) and −5/−6 ("for cpc internal
//! use only").
//!
//! The option codes take −1, dynamic brake (`OptionCodes::DYNAMIC_BRAKE`: the windings are
//! shorted until the shaft is at rest, `Demand::dynamic_brake`), and 605Dh 0 (the drive function
//! off while halted). Statusword bit 7 is reserved, as the manual says (`ProfileConfig::warning_bit`); 60FEh has
//! no bit mask (§15); methods −11/−12 turn at a hard stop (`VendorMethod::
//! MidpointOfHomeSwitchHardStop`).
//!
//! The manual's types of 6071h (UNSIGNED16) and 60E3h sub 0 (INTEGER8) are the core's entry
//! descriptions overridden ([`DESCRIPTIONS`]); 67FEh (version number, §16) is an object of this
//! profile after the core's profile objects ([`PROFILE_OBJECTS`]).

use canopen_drive::cia402::fsa::State;
use canopen_drive::cia402::hm::{hard_stop_object, HomeOffset, HomingConfig, VendorMethod};
use canopen_drive::cia402::objects::mode_bit;
use canopen_drive::cia402::{DirectMode, MotorSpeedUnit, OptionCodes, ProfileConfig, StatusFlag};
use canopen_drive::hal::Sample;
use canopen_drive::od::eds::EdsInfo;
use canopen_drive::od::{
    layout, Access, Bound, DataType, DefaultOverride, DefaultValue, DeviceInfo, EntryOverride, Object,
    PdoMapping, Var,
};

use super::trinamic::method_mask;
use super::{
    default_of, profile_entry, rw, s, u, value_of, var, BoardDictionary, BoardProfile, Environment, Firmware,
    ProfileName, Update, TEMPLATE_NODE_ID,
};
use crate::board_objects::{simulated_faults, simulated_inputs, simulated_load, PROFILE_SIMULATION};
use canopen_drive::Config;

/// 3293h hard stop current (fraction of the peak current).
pub const HARD_STOP_CURRENT: u16 = 0x3293;
/// 3294h hard stop period (ms).
pub const HARD_STOP_PERIOD: u16 = 0x3294;
/// The board's record of the core's hard-stop parameters.
pub const HARD_STOP_RECORD: u16 = 0x5E10;

/// 3293h at start-up: half the peak current.
const HARD_STOP_FRACTION: f64 = 0.5;
/// 3294h at start-up (ms).
const HARD_STOP_MS: u64 = 250;
/// 6073h at start-up: 0 until the drive is commissioned (see [`DEFAULTS`]).
const PEAK_CURRENT: u64 = 0;

/// The core's hard-stop torque threshold (5E10h sub 1, ‰ of rated torque) for the fraction
/// `fraction` (3293h) of the peak current `peak` (6073h, ‰), rounded.
const fn hard_stop_threshold(fraction: f64, peak: u64) -> u64 {
    let threshold = fraction * peak as f64 + 0.5;
    if threshold < 1.0 {
        0
    } else if threshold >= u16::MAX as f64 {
        u16::MAX as u64
    } else {
        threshold as u64
    }
}

/// 3293h, 3294h, then the simulation objects and the hard-stop record of this board.
pub static OBJECTS: [Object; 6] = layout([
    var(
        HARD_STOP_CURRENT,
        rw("Hard stop current", DataType::Real32)
            .default(DefaultValue::Real(HARD_STOP_FRACTION))
            .limits(Bound::Real(0.01), Bound::Real(0.9)),
    ),
    var(
        HARD_STOP_PERIOD,
        rw("Hard stop period", DataType::Unsigned16).default(DefaultValue::Unsigned(HARD_STOP_MS)),
    ),
    simulated_faults(PROFILE_SIMULATION),
    simulated_inputs(PROFILE_SIMULATION + 1),
    simulated_load(PROFILE_SIMULATION + 2),
    hard_stop_object(HARD_STOP_RECORD),
]);

/// The cpc homing methods (§8.6).
pub static CPC_METHODS: [(i8, VendorMethod); 12] = [
    (-1, VendorMethod::HardStop { positive: true, index: false }),
    (-2, VendorMethod::HardStop { positive: false, index: false }),
    (-3, VendorMethod::HardStop { positive: true, index: true }),
    (-4, VendorMethod::HardStop { positive: false, index: true }),
    (-5, VendorMethod::MidpointOfHardStopsPositiveFirst),
    (-6, VendorMethod::MidpointOfHardStops),
    (-7, VendorMethod::MidpointOfLimitSwitchesPositiveFirst),
    (-8, VendorMethod::MidpointOfLimitSwitches),
    (-9, VendorMethod::MidpointOfHomeSwitch { positive: true }),
    (-10, VendorMethod::MidpointOfHomeSwitch { positive: false }),
    (-11, VendorMethod::MidpointOfHomeSwitchHardStop { positive: true }),
    (-12, VendorMethod::MidpointOfHomeSwitchHardStop { positive: false }),
];

/// The standard methods of 60E3h (§8.3): 1–14, 17–30, 33–35, 37.
pub const STANDARD_METHODS: [i8; 32] = [
    1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30,
    33, 34, 35, 37,
];

/// The manual's defaults (§2.3) where they differ from the core's, and the start values of the
/// hard-stop record the firmware derives from 3293h, 3294h and 6073h.
pub static DEFAULTS: [DefaultOverride; 26] = [
    default_of(0x6007, 0, s(0)),
    default_of(0x605C, 0, s(0)),
    default_of(0x605E, 0, s(0)),
    default_of(0x607F, 0, u(1_500_000)),
    default_of(0x6080, 0, u(1_500_000)),
    default_of(0x6081, 0, u(2_000_000)),
    default_of(0x6083, 0, u(1_000_000)),
    default_of(0x6084, 0, u(1_000_000)),
    default_of(0x6085, 0, u(100_000_000)),
    default_of(0x6087, 0, u(100_000)),
    default_of(0x6098, 0, s(35)),
    default_of(0x6099, 1, u(20_000)),
    default_of(0x6099, 2, u(20_000)),
    default_of(0x609A, 0, u(20_000)),
    default_of(0x60B8, 0, u(1)),
    // The axis's resolution and a feed of as many counts per revolution: positions stay counts.
    default_of(0x608F, 1, u(10_000)),
    default_of(0x6092, 1, u(10_000)),
    // The drive has no max acceleration/deceleration objects: the core's are set high.
    default_of(0x60C5, 0, u(100_000_000)),
    default_of(0x60C6, 0, u(100_000_000)),
    // Zero until the drive is commissioned: a following error window of 0 faults at the first
    // move (FFFF FFFFh switches it off), a position window of 0 needs the exact position, a
    // peak current of 0 allows no torque. A master sets them first, as on the real drive.
    default_of(0x6065, 0, u(0)),
    default_of(0x6066, 0, u(0)),
    default_of(0x6067, 0, u(0)),
    default_of(0x6068, 0, u(0)),
    default_of(0x6073, 0, u(PEAK_CURRENT)),
    // What the firmware keeps the hard-stop record at (`Cpc::after_tick`).
    default_of(HARD_STOP_RECORD, 1, u(hard_stop_threshold(HARD_STOP_FRACTION, PEAK_CURRENT))),
    default_of(HARD_STOP_RECORD, 2, u(HARD_STOP_MS)),
];

/// The manual's descriptions of standard entries where they differ from CiA 301/402's (same
/// sizes): the target torque 6071h UNSIGNED16 (§11.3), the count of supported homing methods,
/// 60E3h sub 0, INTEGER8 (§8.3), and the PDO mappability of its table in §2.3.
pub static DESCRIPTIONS: [EntryOverride; 19] = [
    // §15: 60FEh has the physical outputs only (sub 0 = 1): no bit mask.
    profile_entry(0x60FE, 0).default(u(1)),
    profile_entry(0x6071, 0).data_type(DataType::Unsigned16),
    profile_entry(0x60E3, 0).data_type(DataType::Integer8),
    // Mappable in the manual: windows, times, thresholds, home offset, max motor speed, the
    // touch probe function.
    profile_entry(0x6065, 0).pdo(PdoMapping::Both),
    profile_entry(0x6066, 0).pdo(PdoMapping::Both),
    profile_entry(0x6067, 0).pdo(PdoMapping::Both),
    profile_entry(0x6068, 0).pdo(PdoMapping::Both),
    profile_entry(0x606D, 0).pdo(PdoMapping::Both),
    profile_entry(0x606E, 0).pdo(PdoMapping::Both),
    profile_entry(0x606F, 0).pdo(PdoMapping::Both),
    profile_entry(0x6070, 0).pdo(PdoMapping::Both),
    profile_entry(0x607C, 0).pdo(PdoMapping::Both),
    profile_entry(0x6080, 0).pdo(PdoMapping::Both),
    profile_entry(0x60B8, 0).pdo(PdoMapping::Both),
    // Not mappable in the manual.
    profile_entry(0x6079, 0).pdo(PdoMapping::No),
    profile_entry(0x6083, 0).pdo(PdoMapping::No),
    profile_entry(0x6099, 1).pdo(PdoMapping::No),
    profile_entry(0x6099, 2).pdo(PdoMapping::No),
    profile_entry(0x60FE, 1).pdo(PdoMapping::No),
];

/// 67FEh version number (§16): the CiA 402 version the drive implements. The value is the
/// manual's default, 3 (its bit layout would put 3.0.0 at 030000h; the table gives 3).
pub const VERSION_NUMBER: u16 = 0x67FE;

/// Objects of the profile area the core does not have (CiA 402-2 v3.0 defines no 67FEh).
pub static PROFILE_OBJECTS: [Object; 1] = layout([var(
    VERSION_NUMBER,
    Var::new("Version number", DataType::Unsigned32).access(Access::Const).default(DefaultValue::Unsigned(3)),
)]);

/// The core's drive-profile configuration of this drive.
pub fn profile_config() -> ProfileConfig {
    let mut config = ProfileConfig::new();
    // §4.3.3–4.3.7: each option code from −1 (dynamic brake); the halt option code 0 disables
    // the drive function.
    let brake = OptionCodes::DYNAMIC_BRAKE;
    config.option_codes = OptionCodes {
        abort_connection: 0b1111,
        quick_stop: brake | 0b1_1111,
        shutdown: brake | 0b11,
        disable_operation: brake | 0b11,
        halt: brake | 0b1_1111,
        fault_reaction: brake | 0b1_1111,
    };
    config.homing = HomingConfig {
        method_37: true,
        standard_methods: method_mask(&STANDARD_METHODS),
        vendor_methods: &CPC_METHODS,
        hard_stop_object: Some(HARD_STOP_RECORD),
        // "Unconditionally until the hard stop is found" (§8.6.1).
        hard_stop_passes_limit_switches: true,
        // §8.3: 607Ch is set as the position value of the home position.
        home_offset: HomeOffset::HomeValue,
        ..HomingConfig::new()
    };
    // §6.4 (607Dh): homing is required to validate the software position limits.
    config.software_limits_after_homing = true;
    // §6.2.2: with halt, target reached means decelerated to zero velocity.
    config.halt_reached_at_standstill = true;
    config.mode_change_in_operation = false;
    config.following_error_fault = true;
    config.statusword_bit_14 = StatusFlag::Transition;
    // §6.3: 6080h in count/s, as 607Fh.
    config.units.motor_speed = MotorSpeedUnit::VelocityUnit;
    // §5: the direct modes −4…−2 (−1 direct voltage and −5/−6 are not reproduced).
    // §4.3.2: statusword bit 7 (warning in CiA 402) is reserved.
    config.warning_bit = false;
    config.manufacturer_modes =
        &[(-4, DirectMode::Position), (-3, DirectMode::Velocity), (-2, DirectMode::Torque)];
    config
}

/// Identity: the manual gives none; 6502h as §3.2. The product code ("CPC" in ASCII) is this
/// program's, distinct from the generic drive's 0: stored parameters are signed with 1018h's
/// vendor-ID and product code, so each profile loads only its own.
pub fn device_info() -> DeviceInfo {
    DeviceInfo {
        product_code: 0x0043_5043,
        device_name: "cpc servo drive",
        hardware_version: "simulated",
        software_version: "DS402 1.0",
        vendor_name: "Chieftek Precision (simulated)",
        drive_modes: mode_bit::PROFILE_POSITION
            | mode_bit::PROFILE_VELOCITY
            | mode_bit::PROFILE_TORQUE
            | mode_bit::HOMING
            | mode_bit::CYCLIC_POSITION
            | mode_bit::CYCLIC_VELOCITY
            | mode_bit::CYCLIC_TORQUE,
        ..DeviceInfo::servo_drive()
    }
}

/// The core's CiA 402 objects the manual's object list (§2.3) does not have: the bus gets
/// 0602 0000h for them, as from the real drive, and the behaviour they carry keeps its defaults
/// (trapezoidal profiles, no torque or acceleration limit beyond the defaults, a 1:1 factor
/// group, no interpolated position data).
pub static ABSENT: [u16; 6] = [0x6072, 0x6086, 0x608F, 0x6091, 0x60C1, 0x60C5];

/// The profile.
pub fn profile() -> BoardProfile {
    BoardProfile {
        axes: 1,
        name: ProfileName::Chieftek,
        config: Config {
            device: device_info(),
            manufacturer_objects: &OBJECTS,
            profile: profile_config(),
            default_overrides: &DEFAULTS,
            entry_overrides: &DESCRIPTIONS,
            extra_profile_objects: &PROFILE_OBJECTS,
            absent_objects: &ABSENT,
            ..Config::new(TEMPLATE_NODE_ID)
        },
        eds: EdsInfo {
            file_name: "chieftek.eds",
            description: "cpc DS402 servo drive interface rebuilt on canopen-drive (simulated)",
            ..EdsInfo::default()
        },
        simulation: PROFILE_SIMULATION,
        rules: &[],
        axis: super::generic::axis(),
        firmware: || Box::new(Cpc),
    }
}

/// The behaviour of 3293h/3294h.
#[derive(Debug, Default)]
pub struct Cpc;

impl Firmware for Cpc {
    /// §6.3: 607Fh and 6080h are one value internally: a write of either sets both.
    fn written(
        &mut self,
        index: u16,
        sub: u8,
        value: u64,
        _od: &BoardDictionary,
        _env: &Environment<'_>,
        updates: &mut Vec<Update>,
    ) {
        match (index, sub) {
            (0x607F, 0) => updates.push(Update { index: 0x6080, sub: 0, value }),
            (0x6080, 0) => updates.push(Update { index: 0x607F, sub: 0, value }),
            _ => {}
        }
    }

    fn after_tick(
        &mut self,
        od: &BoardDictionary,
        _sample: &Sample,
        _state: State,
        updates: &mut Vec<Update>,
    ) {
        // The threshold in ‰ of rated torque: the fraction of the peak current 6073h (‰).
        let fraction = f64::from(f32::from_bits(value_of(od, HARD_STOP_CURRENT, 0) as u32));
        let threshold = hard_stop_threshold(fraction, value_of(od, 0x6073, 0));
        updates.push(Update { index: HARD_STOP_RECORD, sub: 1, value: threshold });
        updates.push(Update { index: HARD_STOP_RECORD, sub: 2, value: value_of(od, HARD_STOP_PERIOD, 0) });
    }
}

//! The Trinamic PD57/60-1378 stepper module (CANopen firmware manual V3.23, document revision
//! V1.00), rebuilt on the core. Section numbers below are the manual's.
//!
//! # Identity and communication (§3)
//!
//! 1000h FFFC0192h, 1008h "PD57/60-1378", vendor-ID 286h, product code 1378. Four RPDOs and
//! four TPDOs with the manual's defaults (§3.1.17–3.1.20): RPDO communication records with
//! sub-indices 0–2 only, TPDO records 0–5 (sub 4 the read-only compatibility entry), at most
//! **three** mapping entries per PDO (the mapping records have subs 1–3, sub 0 is 0..3).
//! Transmission types: RPDOs 0, FEh, FFh; TPDOs 0, 1, FEh, FFh (others: 0609 0030h).
//! 1029h: the manual's values, 0 = enter Stopped (the default), 1 = stay.
//!
//! # Drive profile (§5–§11)
//!
//! Modes pp, pv, hm, csp, csv, cst (6502h = 3A5h). Option codes: 605Ah 1/2/5/6, 605Bh 0,
//! 605Ch 1, 605Dh 1, 605Eh 2. Homing methods 1, 2, 3, 5, 17, 18, 19, 21, 33, 34, 35.
//! Documented deviations, as configuration of the core: NMT Stopped faults an enabled axis
//! (§2.2); statusword bit 14 = motor moving, bit 15 = direction (negative) (§6.1.2); a
//! following error stops the axis with an EMCY and 6065h = 0 switches the check off (§6.1.6);
//! no change on set-point (controlword bit 9, §6.1.1). Defaults the manual gives for standard
//! objects (6065h 0, 6067h FFFF FFFFh, 6081h/6083h/6084h 0, 6085h 51 200, 6099h/609Ah 0, …).
//!
//! Torques in mA (§11.1.6–11.1.7): the core's [`TorqueUnit::MilliAmps`] with the rated current
//! 6075h kept at the run current of 2003h (255 = 3 A, so the default 128 is 1506 mA), so 6071h,
//! 60B2h, 6074h, 6077h and 6078h are mA of motor current; the limits 6072h/6073h stay ‰.
//!
//! Positions are microsteps: the simulated axis has 51 200 per revolution (256 microsteps of
//! a 200-step motor), index pulse once per revolution, limit switches beyond ±1 000 000,
//! home switch 100 000..150 000, elastic hard stops at ±1 100 000.
//!
//! # Manufacturer objects (§4)
//!
//! Working on the simulated axis: 2005h limit-switch configuration (deactivate / invert the
//! left, right and home switches; writable only in Switch on disabled), 200Fh encoder N-channel
//! latch, 2000h/2107h microstep resolution and its display, 208Ch/208Eh unit indices, 2100h
//! home offset display, 2101h load value (from the torque), 2102h driver error flags (from the
//! simulated faults), 210Bh step counter, 2020h/2120h closed-loop mode and its initialisation
//! flag, 2701h manufacturer-specific mode (make/kill signatures), 2702h inputs IN0–IN2 (this
//! board wires the left limit, right limit and home switch to them), 2704h/2705h/2706h bit
//! rate and node-ID with their store command (into the LSS file of `--storage`; active after a
//! restart or NMT reset node), 2707h/2708h the active bit rate and node-ID, 5FFFh bootloader
//! (takes the magic number, reads 0).
//!
//! Present, readable and writable within their ranges, without an effect on the simulated
//! axis (they tune a real stepper power stage): 2001h–2004h, 200Ah–200Ch, 2010h–2015h,
//! 2021h–2036h, 204Eh, 2089h, 2092h–20A5h, 2700h (TMCL mode is not entered), 2703h, 270Eh.
//!
//! 606Ah (sensor selection code, −1 "no encoder" by default) is stored within the manual's range
//! 0/−1; the simulated axis has one sensor, so the value changes nothing.
//!
//! # Not reproduced
//!
//! The rule that the same mode may not be written twice to 6060h (the manual forbids it without
//! saying how the drive answers; the core accepts the repeated value, which changes nothing).
//!
//! 1029h has the manual's two error classes: sub 2 (application error) is the drive entering
//! Fault (CiA 402-2 §7.2), by default 1 (the NMT state stays). Under-voltage is reported as the manual's FF00h (`ProfileConfig::error_codes`), the travel
//! limits as its FF01h with bytes 1–4 (`ProfileConfig::travel_limit_emcy`; again at each move
//! commanded into a limit switch already active), the TPDO inhibit
//! time in ms (`Config::tpdo_inhibit_unit`). (SDO block
//! transfer, which the manual does not list, is switched off: `Config::sdo_block_transfer`.)
//!
//! Also configuration of the core, from the manual: the manufacturer bytes of its EMCY table
//! (§12: `00 FF 00 00 00` for the communication errors, `Config::emcy_additional_bytes`); an
//! RPDO with too many bytes is not processed (`LongRpdo::DiscardAndReport`); a limit switch in
//! use stops motion towards it and a move further into an active one is not made (§4.2.6,
//! FF01h/3–4: `ProfileConfig::limit_switches_stop`); method 35 sets 6062h, 6063h and 6064h to
//! zero (`HomingConfig::rebase_internal_position`); 2701h "make" lets a valid PDO's mapping
//! change (§4.2.62, `Drive::set_remap_while_valid`); a node-ID and bit rate stored with 2706h
//! take effect at the next reset of the module, NMT reset node included (§4.2.65/66); the
//! standard objects the manual does not list (1003h, 603Fh, 6007h, 6072h, 607Fh, 6091h, 60B8h,
//! 60F4h) do not exist ([`ABSENT`]); 2100h follows a write of 607Ch at once.
//!
//! The manual's types of 605Bh–605Eh (UNSIGNED16), 6081h–6084h (SIGNED32) and 6086h
//! (UNSIGNED16), 1016h with one entry and 1018h without sub 4 are the core's entry descriptions
//! overridden ([`DESCRIPTIONS`]).

use std::ops::RangeInclusive;

use canopen_drive::cia402::fsa::State;
use canopen_drive::cia402::hm::HomingConfig;
use canopen_drive::cia402::objects::mode_bit;
use canopen_drive::cia402::{OptionCodes, ProfileConfig, StatusFlag, TorqueUnit};
use canopen_drive::comm::error_control::ErrorBehaviour;
use canopen_drive::comm::pdo::LongRpdo;
use canopen_drive::hal::{DigitalInputs, HardwareFaults, Sample};
use canopen_drive::od::eds::EdsInfo;
use canopen_drive::od::{
    layout, AbortCode, Access, DataType, DefaultOverride, DefaultValue, DeviceInfo, EntryOverride, Object,
    PdoMapping, Var, WriteRule,
};
use canopen_drive::wire::lss::BitRate::{Kbit1000, Kbit125, Kbit20, Kbit250, Kbit50, Kbit500, Kbit800};
use canopen_drive::wire::lss::BitTiming;
use canopen_drive_sim::motor::{MotorParams, Zone};

use super::{
    bit_timing_index, communication_emcy_bytes, communication_entry, default_of, highest, pdo_records,
    profile_entry, ro, rpdo_communication, rw, stored_bit_rate, tpdo_communication, u, value_of, var, Action,
    BoardDictionary, BoardProfile, Environment, Firmware, ProfileName, Update, CIA402_RPDO_MAPPING,
    CIA402_TPDO_MAPPING, TEMPLATE_NODE_ID,
};
use crate::board_objects::{
    simulated_faults, simulated_inputs, simulated_load, ValueRule, PROFILE_SIMULATION,
};
use canopen_drive::Config;

use DataType::{Integer32, Integer8, Unsigned16, Unsigned32, Unsigned64, Unsigned8};

/// 2005h limit switches.
pub const LIMIT_SWITCHES: u16 = 0x2005;
/// 2704h CAN bit rate (kbit/s).
pub const CAN_BIT_RATE: u16 = 0x2704;
/// 2705h node-ID.
pub const NODE_ID: u16 = 0x2705;
/// 2706h store (2704h/2705h).
pub const STORE: u16 = 0x2706;
/// "save" (1010h's signature).
pub const SAVE: u64 = 0x6576_6173;
/// "make".
pub const MAKE: u64 = 0x656B_616D;
/// "kill".
pub const KILL: u64 = 0x6C6C_696B;
/// 5FFFh's magic number.
pub const BOOTLOADER_MAGIC: u64 = 0x1234_5678;

const SWITCH_ON_DISABLED: WriteRule = WriteRule::SwitchOnDisabled;

const fn up_to(name: &'static str, data_type: DataType, high: u64, default: u64) -> Var {
    rw(name, data_type).limits_unsigned(0, high).default(DefaultValue::Unsigned(default))
}

const BRAKE_DELAY_SUBS: [(u8, Var); 3] = [
    highest("Highest sub-index supported", 2),
    (1, up_to("Time between applying brake / disabling power stage", Unsigned16, 65_535, 0)),
    (
        2,
        up_to(
            "Time between releasing brake / switching the state machine to operational",
            Unsigned16,
            65_535,
            0,
        ),
    ),
];

const ENCODER_SUBS: [(u8, Var); 4] = [
    highest("Highest sub-index supported", 3),
    (1, up_to("Null channel polarity", Unsigned8, 1, 0).rule(SWITCH_ON_DISABLED)),
    (2, up_to("Direction of rotation", Unsigned8, 1, 0).rule(SWITCH_ON_DISABLED)),
    (3, up_to("Initialize position", Unsigned8, 1, 1).rule(SWITCH_ON_DISABLED)),
];

const BRAKE_CURRENT_SUBS: [(u8, Var); 3] = [
    highest("Highest sub-index supported", 2),
    (1, up_to("Apply current", Unsigned8, 255, 0).rule(SWITCH_ON_DISABLED)),
    (2, up_to("Release current", Unsigned8, 255, 0).rule(SWITCH_ON_DISABLED)),
];

const LATCH_SUBS: [(u8, Var); 4] = [
    highest("Highest sub-index supported", 3),
    (1, up_to("Mode", Unsigned8, 1, 0)),
    (2, ro("Latched internal position", Integer32)),
    (3, ro("Latched encoder position", Integer32)),
];

const STEP_COUNTER_SUBS: [(u8, Var); 4] = [
    highest("Highest sub-index supported", 3),
    (1, ro("Lower 32 Bits", Unsigned32)),
    (2, ro("Higher 32 Bits", Unsigned32)),
    (3, ro("64 Bit Value", Unsigned64)),
];

const OUTPUT_SUBS: [(u8, Var); 3] = [
    highest("Highest sub-index supported", 2),
    (1, rw("Physical outputs", Unsigned32).pdo(canopen_drive::od::PdoMapping::Both)),
    (2, rw("Output mask", Unsigned32).pdo(canopen_drive::od::PdoMapping::Both)),
];

const ANALOG_SUBS: [(u8, Var); 2] = [
    highest("Highest sub-index supported", 1),
    (1, ro("Analog input 0", Unsigned32).pdo(canopen_drive::od::PdoMapping::Tpdo).limits_unsigned(0, 4095)),
];

/// The manufacturer objects of §4, then the simulation objects at 5E00h, then 5FFFh.
pub static OBJECTS: [Object; 74] = layout([
    var(0x2000, up_to("Microstep Resolution", Unsigned8, 8, 8)),
    var(0x2001, up_to("Motor full step resolution", Unsigned16, 65_535, 200)),
    Object::record(0x2002, "Brake delay times", &BRAKE_DELAY_SUBS),
    var(0x2003, up_to("Maximum current", Unsigned8, 255, 128)),
    var(0x2004, up_to("Standby current", Unsigned8, 255, 8)),
    var(LIMIT_SWITCHES, up_to("Limit switches", Unsigned32, 63, 0).rule(SWITCH_ON_DISABLED)),
    var(0x200A, up_to("Enable drive delay time", Unsigned16, 65_535, 0)),
    Object::record(0x200B, "Encoder parameters", &ENCODER_SUBS),
    Object::record(0x200C, "Brake current feed", &BRAKE_CURRENT_SUBS),
    Object::record(0x200F, "Encoder N Channel Latch", &LATCH_SUBS),
    var(0x2010, up_to("Profile Start Velocity", Unsigned32, 268_435_455, 0)),
    var(0x2011, up_to("Profile A1", Unsigned32, 16_777_215, 0)),
    var(0x2012, up_to("Profile V1", Unsigned32, 16_777_215, 0)),
    var(0x2013, up_to("Profile D1", Unsigned32, 16_777_215, 0)),
    var(0x2014, rw("Profile stop deceleration", Unsigned32)),
    var(
        0x2015,
        rw("Bow scaling factor", Unsigned8).limits_unsigned(1, 255).default(DefaultValue::Unsigned(1)),
    ),
    var(0x2020, rw("Closed-loop mode", Unsigned8)),
    var(0x2021, up_to("Correction position P", Unsigned32, 16_777_215, 0)),
    var(0x2022, up_to("Maximum correction tolerance", Unsigned8, 255, 0)),
    var(0x2027, up_to("Closed loop beta", Unsigned16, 511, 255)),
    var(0x2028, rw("Closed-loop offset", Integer32)),
    var(0x2029, up_to("Current scaler minimum", Unsigned8, 255, 0)),
    var(0x202A, up_to("Current scaler maximum", Unsigned8, 255, 0)),
    var(0x202B, up_to("Correction velocity P", Unsigned32, 16_777_215, 0)),
    var(0x202C, up_to("Correction velocity I", Unsigned32, 16_777_215, 0)),
    var(0x202D, up_to("Correction velocity I clipping", Unsigned16, 32_767, 0)),
    var(0x202E, up_to("Correction velocity DV clock", Unsigned16, 32_767, 0)),
    var(
        0x202F,
        rw("Correction velocity DV clipping", Unsigned32).default(DefaultValue::Unsigned(2_147_483_647)),
    ),
    var(0x2030, up_to("Upscale delay", Unsigned32, 16_777_215, 0)),
    var(0x2031, up_to("Downscale delay", Unsigned32, 16_777_215, 0)),
    var(0x2033, ro("Actual scaling factor", Unsigned8)),
    var(0x2034, up_to("Field weakening minimum velocity", Unsigned32, 16_777_215, 0)),
    var(0x2035, up_to("Field weakening maximum velocity", Unsigned32, 16_777_215, 0)),
    var(0x2036, up_to("Field weakening", Unsigned8, 255, 0)),
    var(0x204E, up_to("Boost current", Unsigned8, 255, 0)),
    var(0x2089, up_to("Setting delay", Unsigned16, 65_535, 200)),
    var(
        0x208C,
        rw("Velocity dimension index", Unsigned8)
            .default(DefaultValue::Unsigned(181))
            .rule(SWITCH_ON_DISABLED),
    ),
    var(0x208E, ro("Acceleration dimension index", Unsigned8).default(DefaultValue::Unsigned(179))),
    var(0x2092, up_to("Chopper blank time", Unsigned8, 3, 2)),
    var(0x2093, up_to("Chopper mode", Unsigned8, 1, 0)),
    var(0x2094, up_to("Chopper hysteresis decrement", Unsigned8, 3, 0)),
    var(0x2095, rw("Chopper hysteresis end", Integer8).limits_signed(-3, 12)),
    var(0x2096, up_to("Chopper hysteresis start", Unsigned8, 8, 3)),
    var(0x2097, up_to("Chopper off time", Unsigned8, 15, 5)),
    var(0x2098, up_to("Smart energy current minimum", Unsigned8, 1, 0)),
    var(0x2099, up_to("Smart energy current down step", Unsigned8, 3, 0)),
    var(0x209A, up_to("Smart energy hysteresis", Unsigned8, 15, 0)),
    var(0x209B, up_to("Smart energy current up step", Unsigned8, 3, 0)),
    var(0x209C, up_to("Smart energy hysteresis start", Unsigned8, 15, 0)),
    var(0x209D, up_to("Smart energy filter enable", Unsigned8, 1, 0)),
    var(0x209E, rw("StallGuard2 threshold", Integer8).limits_signed(-63, 63)),
    var(0x20A1, up_to("Short protection disable", Unsigned8, 1, 0)),
    var(0x20A4, up_to("Stop on stall", Unsigned32, 2_147_483_647, 0)),
    var(0x20A5, up_to("Smart energy threshold speed", Unsigned32, 2_147_483_647, 0)),
    var(0x2100, ro("Home offset display", Integer32)),
    var(0x2101, ro("Actual load value", Unsigned16).limits_unsigned(0, 1023)),
    var(0x2102, ro("Driver error flags", Unsigned8)),
    var(0x2107, ro("Microstep resolution display", Unsigned8).default(DefaultValue::Unsigned(8))),
    Object::record(0x210B, "Step counter", &STEP_COUNTER_SUBS),
    var(0x2120, ro("Closed loop initialization flag", Unsigned8)),
    var(0x2700, rw("TMCL direct communication", Unsigned32)),
    var(0x2701, rw("Manufacturer specific mode", Unsigned32)),
    var(0x2702, ro("Device digital inputs", Unsigned32).pdo(canopen_drive::od::PdoMapping::Tpdo)),
    Object::record(0x2703, "Device digital outputs", &OUTPUT_SUBS),
    var(CAN_BIT_RATE, rw("CAN bit rate", Unsigned16).default(DefaultValue::Unsigned(1000))),
    var(NODE_ID, rw("Node ID", Unsigned8).limits_unsigned(1, 127).default(DefaultValue::NodeIdPlus(0))),
    var(STORE, rw("Store", Unsigned32).default(DefaultValue::Unsigned(1))),
    var(0x2707, ro("CAN bit rate load", Unsigned16).default(DefaultValue::Unsigned(1000))),
    var(0x2708, ro("Node ID load", Unsigned8).default(DefaultValue::NodeIdPlus(0))),
    Object::record(0x270E, "Device analog inputs", &ANALOG_SUBS),
    simulated_faults(PROFILE_SIMULATION),
    simulated_inputs(PROFILE_SIMULATION + 1),
    simulated_load(PROFILE_SIMULATION + 2),
    var(0x5FFF, rw("Bootloader mode", Unsigned32)),
]);

// --- PDOs (§3.1.17–3.1.20) --------------------------------------------------------------

static RPDO_COMMUNICATION: [[(u8, Var); 3]; 4] = [
    rpdo_communication(0x200, 0xFF),
    rpdo_communication(0x300, 0xFF),
    rpdo_communication(0x400, 0xFF),
    rpdo_communication(0x500, 0xFE),
];
static TPDO_COMMUNICATION: [[(u8, Var); 6]; 4] = [
    tpdo_communication(0x180, 0xFF),
    tpdo_communication(0x280, 0xFF),
    tpdo_communication(0x380, 0x01),
    tpdo_communication(0x480, 0x01),
];

/// The PDO records: 1400h–1403h, 1600h–1603h, 1800h–1803h, 1A00h–1A03h.
pub static PDOS: [Object; 16] =
    layout(pdo_records(&RPDO_COMMUNICATION, &CIA402_RPDO_MAPPING, &TPDO_COMMUNICATION, &CIA402_TPDO_MAPPING));

// --- Value rules, defaults, configuration -----------------------------------------------

const RPDO_TYPES: &[RangeInclusive<u64>] = &[0x00..=0x00, 0xFE..=0xFF];
const TPDO_TYPES: &[RangeInclusive<u64>] = &[0x00..=0x01, 0xFE..=0xFF];

/// The bit rates of §4.2.65, kbit/s.
const KBITS: [RangeInclusive<u64>; 8] =
    [20..=20, 50..=50, 100..=100, 125..=125, 250..=250, 500..=500, 800..=800, 1000..=1000];

const fn only(index: u16, sub: u8, values: &'static [RangeInclusive<u64>]) -> ValueRule {
    ValueRule { index, sub, values, refusal: AbortCode::InvalidValue, stores: false }
}

/// Signatures, value lists and transmission types the manual allows.
pub static RULES: [ValueRule; 15] = [
    only(0x1400, 2, RPDO_TYPES),
    only(0x1401, 2, RPDO_TYPES),
    only(0x1402, 2, RPDO_TYPES),
    only(0x1403, 2, RPDO_TYPES),
    only(0x1800, 2, TPDO_TYPES),
    only(0x1801, 2, TPDO_TYPES),
    only(0x1802, 2, TPDO_TYPES),
    only(0x1803, 2, TPDO_TYPES),
    only(0x208C, 0, &[0..=0, 181..=181]),
    only(0x2097, 0, &[0..=0, 2..=15]),
    only(0x2700, 0, &[MAKE..=MAKE]),
    only(0x2701, 0, &[MAKE..=MAKE, KILL..=KILL]),
    only(CAN_BIT_RATE, 0, &KBITS),
    ValueRule { index: STORE, sub: 0, values: &[SAVE..=SAVE], refusal: AbortCode::CannotStore, stores: true },
    only(0x5FFF, 0, &[BOOTLOADER_MAGIC..=BOOTLOADER_MAGIC]),
];

/// The manual's defaults of standard objects where they differ from the core's.
pub static DEFAULTS: [DefaultOverride; 19] = [
    // §3.1.16: two error classes; the application error (the drive's Fault) keeps the state.
    default_of(0x1029, 0, u(2)),
    default_of(0x1029, 2, u(1)),
    default_of(0x6065, 0, u(0)),
    default_of(0x6067, 0, u(0xFFFF_FFFF)),
    default_of(0x6068, 0, u(0)),
    default_of(0x6081, 0, u(0)),
    default_of(0x6083, 0, u(0)),
    default_of(0x6084, 0, u(0)),
    default_of(0x6085, 0, u(51_200)),
    default_of(0x6099, 1, u(0)),
    default_of(0x6099, 2, u(0)),
    default_of(0x609A, 0, u(0)),
    default_of(0x60A4, 1, u(0)),
    default_of(0x60A4, 2, u(0)),
    default_of(0x60A4, 3, u(0)),
    default_of(0x60A4, 4, u(0)),
    // The module has no max acceleration/deceleration objects: the core's are set high.
    default_of(0x60C5, 0, u(100_000_000)),
    default_of(0x60C6, 0, u(100_000_000)),
    // The run current 2003h (128 of 255) as the rated current of the torques in mA.
    default_of(0x6075, 0, u(run_current_milliamps(128))),
];

/// The manual's descriptions of standard objects where they differ from CiA 301/402's: 1016h
/// and 1018h with fewer entries; types of the same sizes (the bytes on the bus are the same):
/// the option codes 605Bh–605Eh UNSIGNED16 (§5.1.2–5.1.5), the profile velocities and
/// accelerations 6081h–6084h SIGNED32 (§6.1.12–6.1.15; the core takes them as magnitudes, so
/// negative values are refused), 6086h UNSIGNED16 (§6.1.17); and the PDO mappability the manual
/// denies: 1001h and the motion settings 6081h–6085h, 6098h–609Ah (SDO only).
pub static DESCRIPTIONS: [EntryOverride; 19] = [
    // One heartbeat consumer entry (§3.1.13), an identity without a serial number (§3.1.15).
    communication_entry(0x1016, 0).default(u(1)),
    communication_entry(0x1018, 0).default(u(3)),
    communication_entry(0x1001, 0).pdo(PdoMapping::No),
    profile_entry(0x605B, 0).data_type(Unsigned16),
    profile_entry(0x605C, 0).data_type(Unsigned16),
    profile_entry(0x605D, 0).data_type(Unsigned16),
    profile_entry(0x605E, 0).data_type(Unsigned16),
    profile_entry(0x6081, 0).data_type(Integer32).limits_signed(0, i32::MAX as i64).pdo(PdoMapping::No),
    profile_entry(0x6082, 0).data_type(Integer32).limits_signed(0, i32::MAX as i64).pdo(PdoMapping::No),
    profile_entry(0x6083, 0).data_type(Integer32).limits_signed(0, i32::MAX as i64).pdo(PdoMapping::No),
    profile_entry(0x6084, 0).data_type(Integer32).limits_signed(0, i32::MAX as i64).pdo(PdoMapping::No),
    profile_entry(0x6085, 0).pdo(PdoMapping::No),
    profile_entry(0x6086, 0).data_type(Unsigned16),
    profile_entry(0x6098, 0).pdo(PdoMapping::No),
    profile_entry(0x6099, 1).pdo(PdoMapping::No),
    profile_entry(0x6099, 2).pdo(PdoMapping::No),
    profile_entry(0x609A, 0).pdo(PdoMapping::No),
    // 608Fh sub 2 (motor revolutions) is read-only in the manual (§5.1.9).
    profile_entry(0x608F, 2).access(Access::ReadOnly),
    // §5.1.8: 0 encoder used, −1 no encoder (the default).
    profile_entry(0x606A, 0).limits_signed(-1, 0).default(DefaultValue::Signed(-1)),
];

/// The module's current at 2003h = 255 (§1.5: 85 is 1 A), mA.
pub const MODULE_MAX_MILLIAMPS: u64 = 3000;

/// The run current of a 2003h setting, mA (rounded): the core's rated current 6075h, through
/// which the torques 6071h, 6077h (and 6074h, 6078h, 60B2h) are in mA.
pub const fn run_current_milliamps(setting: u64) -> u64 {
    (setting * MODULE_MAX_MILLIAMPS + 127) / 255
}

/// 1029h sub 1: 0 = Stopped, 1 = stay (§3.1.16).
pub static ERROR_BEHAVIOUR: [(u8, ErrorBehaviour); 2] =
    [(0, ErrorBehaviour::Stopped), (1, ErrorBehaviour::NoChange)];

/// Homing methods of table 311 (besides 0).
pub const HOMING_METHODS: [i8; 11] = [1, 2, 3, 5, 17, 18, 19, 21, 33, 34, 35];

/// The [`HomingConfig::standard_methods`] mask of `methods` (1..=63).
pub const fn method_mask(methods: &[i8]) -> u64 {
    let mut mask = 0u64;
    let mut rest = methods;
    while let [first, tail @ ..] = rest {
        mask |= 1u64 << (*first as u32 & 63);
        rest = tail;
    }
    mask
}

/// The core's drive-profile configuration of this drive.
pub fn profile_config() -> ProfileConfig {
    let mut config = ProfileConfig::new();
    config.option_codes = OptionCodes {
        quick_stop: (1 << 1) | (1 << 2) | (1 << 5) | (1 << 6),
        shutdown: 1 << 0,
        disable_operation: 1 << 1,
        halt: 1 << 1,
        fault_reaction: 1 << 2,
        ..OptionCodes::ALL
    };
    config.homing = HomingConfig {
        standard_methods: method_mask(&HOMING_METHODS),
        // §8.2 method 35: 6062h, 6063h and 6064h are all set to zero (6063h = 6064h, §6.1.5).
        rebase_internal_position: true,
        ..HomingConfig::new()
    };
    config.change_on_setpoint = false;
    config.following_error_fault = true;
    config.zero_following_error_window_off = true;
    config.nmt_stopped_fault = true;
    config.statusword_bit_14 = StatusFlag::Moving;
    config.statusword_bit_15 = StatusFlag::Negative;
    // §11.1.6/11.1.7: target and actual torque in mA.
    config.units.torque = TorqueUnit::MilliAmps;
    // The EMCY table of the manual (§ error messages): under-voltage is FF00h, not 3220h.
    config.error_codes = &[(0x3220, 0xFF00)];
    // The same table: FF01h while at a software limit (byte 1 = 1/2) or a limit switch outside
    // homing (3/4), and again for each move commanded into a switch already active (a touch).
    config.travel_limit_emcy = Some(0xFF01);
    // FF01h/3-4: a limit switch touched outside homing stops the motor; moves further into it
    // are not carried out (2005h: "if limit switches are not connected, deactivate them").
    config.limit_switches_stop = true;
    config
}

/// The manufacturer-specific bytes of the manual's EMCY table (§12) for the codes the core
/// raises.
pub static EMCY_BYTES: [(u16, [u8; 5]); 9] = communication_emcy_bytes((0x4310, [2, 0, 0, 0, 0]));

/// The core's standard objects the manual's object list does not have: 0602 0000h from the
/// bus, not in the EDS; the behaviour they carry keeps its defaults.
pub static ABSENT: [u16; 8] = [0x1003, 0x603F, 0x6007, 0x6072, 0x607F, 0x6091, 0x60B8, 0x60F4];

/// Identity (§3.1.1, §3.1.4–3.1.6, §3.1.15) and modes (§5.1.11).
pub fn device_info() -> DeviceInfo {
    DeviceInfo {
        device_type: 0xFFFC_0192,
        vendor_id: 0x0286,
        product_code: 1378,
        revision_number: 0x0003_0017,
        device_name: "PD57/60-1378",
        hardware_version: "1.0",
        software_version: "3.23",
        vendor_name: "TRINAMIC Motion Control (simulated)",
        drive_modes: mode_bit::PROFILE_POSITION
            | mode_bit::PROFILE_VELOCITY
            | mode_bit::HOMING
            | mode_bit::CYCLIC_POSITION
            | mode_bit::CYCLIC_VELOCITY
            | mode_bit::CYCLIC_TORQUE,
        ..DeviceInfo::servo_drive()
    }
}

/// Microsteps per revolution of the simulated motor.
pub const MICROSTEPS_PER_REVOLUTION: u32 = 51_200;

/// The simulated axis in microsteps.
pub fn axis() -> MotorParams {
    MotorParams {
        increments_per_revolution: MICROSTEPS_PER_REVOLUTION,
        negative_limit_switch: Some(-1_000_000),
        positive_limit_switch: Some(1_000_000),
        home_switch: Some(Zone::between(100_000, 150_000)),
        negative_hard_stop: Some(-1_100_000),
        positive_hard_stop: Some(1_100_000),
        hard_stop_stiffness: 1000.0,
        hard_stop_damping: 2.0,
        ..MotorParams::default()
    }
}

/// The profile.
pub fn profile() -> BoardProfile {
    BoardProfile {
        axes: 1,
        name: ProfileName::TrinamicPd57,
        config: Config {
            device: device_info(),
            manufacturer_objects: &OBJECTS,
            pdo_objects: &PDOS,
            profile: profile_config(),
            default_overrides: &DEFAULTS,
            entry_overrides: &DESCRIPTIONS,
            error_behaviour_values: &ERROR_BEHAVIOUR,
            sdo_block_transfer: false,
            // §3.2: the TPDO inhibit time is given in milliseconds.
            tpdo_inhibit_unit: canopen_drive::Duration::from_millis(1),
            // §12 8220h: a PDO with too many bytes "could not be processed".
            long_rpdo: LongRpdo::DiscardAndReport,
            emcy_additional_bytes: &EMCY_BYTES,
            absent_objects: &ABSENT,
            // §4.2.65 (2704h) without 100 kbit/s: CiA 306 has no key for it, and CiA 305 v3
            // reserves its LSS table index 5.
            bit_rates: &[Kbit20, Kbit50, Kbit125, Kbit250, Kbit500, Kbit800, Kbit1000],
            ..Config::new(TEMPLATE_NODE_ID)
        },
        eds: EdsInfo {
            file_name: "trinamic-pd57.eds",
            description: "PD57/60-1378 CANopen interface rebuilt on canopen-drive (simulated motor)",
            ..EdsInfo::default()
        },
        simulation: PROFILE_SIMULATION,
        rules: &RULES,
        axis: axis(),
        firmware: || Box::new(Pd57::default()),
    }
}

// --- The firmware ------------------------------------------------------------------------

/// The behaviour of the manufacturer objects on the simulated axis.
#[derive(Debug, Default)]
pub struct Pd57 {
    /// Microsteps moved since power-on (210Bh).
    steps: u64,
    last_position: Option<i32>,
    /// 200Fh sub 1 = 1: waiting for the next index pulse.
    latch_armed: bool,
    /// How long the axis has been in Operation enabled with closed loop requested (ms ticks).
    closed_loop_ticks: u32,
    /// What the firmware does to the drive (2701h, 2706h).
    actions: Vec<Action>,
}

impl Pd57 {
    /// The switch inputs after 2005h: bits 0/1 switch the left/right limit switch off, 2/3
    /// invert them, 4 switches the home switch off, 5 inverts it.
    pub fn configured_inputs(config: u64, inputs: DigitalInputs) -> DigitalInputs {
        let mut out =
            inputs - (DigitalInputs::NEGATIVE_LIMIT | DigitalInputs::POSITIVE_LIMIT | DigitalInputs::HOME);
        let switches = [
            (DigitalInputs::NEGATIVE_LIMIT, 1 << 0, 1 << 2),
            (DigitalInputs::POSITIVE_LIMIT, 1 << 1, 1 << 3),
            (DigitalInputs::HOME, 1 << 4, 1 << 5),
        ];
        for (input, off, invert) in switches {
            let active = inputs.contains(input) != (config & invert != 0);
            if active && config & off == 0 {
                out |= input;
            }
        }
        out
    }
}

impl Firmware for Pd57 {
    fn start(&mut self, od: &BoardDictionary, env: &Environment<'_>, updates: &mut Vec<Update>) {
        updates.push(Update { index: 0x2707, sub: 0, value: u64::from(env.bit_rate_kbit) });
        // §4.2.65: 2704h shows the bit rate of the next start, at start-up the one it runs at.
        updates.push(Update { index: CAN_BIT_RATE, sub: 0, value: u64::from(env.bit_rate_kbit) });
        updates.push(Update { index: 0x2100, sub: 0, value: value_of(od, 0x607C, 0) });
        updates.push(Update { index: 0x2107, sub: 0, value: value_of(od, 0x2000, 0) });
        updates.push(Update { index: 0x6075, sub: 0, value: run_current_milliamps(value_of(od, 0x2003, 0)) });
        let velocity_units = value_of(od, 0x208C, 0);
        updates.push(Update { index: 0x208E, sub: 0, value: if velocity_units == 181 { 179 } else { 0 } });
    }

    fn inputs(&mut self, od: &BoardDictionary, sample: &mut Sample) {
        sample.inputs = Pd57::configured_inputs(value_of(od, LIMIT_SWITCHES, 0), sample.inputs);
    }

    fn written(
        &mut self,
        index: u16,
        sub: u8,
        value: u64,
        od: &BoardDictionary,
        env: &Environment<'_>,
        updates: &mut Vec<Update>,
    ) {
        match (index, sub) {
            (0x2000, 0) => updates.push(Update { index: 0x2107, sub: 0, value }),
            (0x2003, 0) => {
                updates.push(Update { index: 0x6075, sub: 0, value: run_current_milliamps(value) })
            }
            (0x200F, 1) => self.latch_armed = value == 1,
            (0x208C, 0) => {
                updates.push(Update { index: 0x208E, sub: 0, value: if value == 181 { 179 } else { 0 } })
            }
            (0x2700, 0) => {
                log!("2700h: TMCL mode is not simulated; the drive stays a CANopen drive");
                updates.push(Update { index, sub, value: 0 });
            }
            (0x2701, 0) => {
                updates.push(Update { index, sub, value: u64::from(value == MAKE) });
                // §4.2.62: PDOs need not be disabled to change their mapping.
                self.actions.push(Action::RemapWhileValid(value == MAKE));
            }
            // 2100h shows 607Ch at once.
            (0x607C, 0) => updates.push(Update { index: 0x2100, sub: 0, value }),
            (STORE, 0) => {
                let node_id = u8::try_from(value_of(od, NODE_ID, 0)).unwrap_or(1);
                // §4.2.65/66: active after the next reset of the module (NMT reset node too).
                self.actions.push(Action::ConfigureNodeId(node_id));
                let timing = bit_timing_index(value_of(od, CAN_BIT_RATE, 0))
                    .map(|table_index| BitTiming { table_selector: 0, table_index });
                if let Some(path) = env.lss_file {
                    if let Err(e) = crate::lss_store::save(path, node_id, timing) {
                        log!("2706h: cannot store node-ID and bit rate in {}: {e}", path.display());
                    }
                }
                updates.push(Update { index, sub, value: 1 });
            }
            (0x5FFF, 0) => {
                log!("5FFFh: the bootloader is not simulated");
                updates.push(Update { index, sub, value: 0 });
            }
            _ => {}
        }
    }

    fn reset(&mut self, od: &BoardDictionary, env: &Environment<'_>, updates: &mut Vec<Update>) {
        // The module was reset: the stored bit rate is now the active one (the node-ID took
        // effect in the core, and 2705h/2708h show it).
        let rate = stored_bit_rate(env).unwrap_or(env.bit_rate_kbit);
        for index in [CAN_BIT_RATE, 0x2707] {
            updates.push(Update { index, sub: 0, value: u64::from(rate) });
        }
        // The manufacturer-specific mode ends with the reset.
        self.actions.push(Action::RemapWhileValid(false));
        updates.push(Update { index: 0x2100, sub: 0, value: value_of(od, 0x607C, 0) });
        updates.push(Update { index: 0x2107, sub: 0, value: value_of(od, 0x2000, 0) });
    }

    fn take_actions(&mut self) -> Vec<Action> {
        core::mem::take(&mut self.actions)
    }

    fn after_tick(&mut self, od: &BoardDictionary, sample: &Sample, state: State, updates: &mut Vec<Update>) {
        // 2101h: the load value falls from 1023 (no load) to 0 at the torque limit.
        let torque = u64::from(sample.torque.unsigned_abs());
        updates.push(Update {
            index: 0x2101,
            sub: 0,
            value: 1023u64.saturating_sub(torque.min(3000) * 1023 / 3000),
        });
        // 2102h: OT (bit 7), UV (bit 5), OCHS (bit 4).
        let flags = [
            (HardwareFaults::OVER_TEMPERATURE, 1 << 7),
            (HardwareFaults::UNDER_VOLTAGE, 1 << 5),
            (HardwareFaults::OVER_CURRENT, 1 << 4),
        ];
        let bits = flags.iter().filter(|(f, _)| sample.faults.contains(*f)).fold(0u64, |acc, (_, b)| acc | b);
        updates.push(Update { index: 0x2102, sub: 0, value: bits });
        // 210Bh: microsteps moved.
        if let Some(last) = self.last_position.replace(sample.position) {
            self.steps = self.steps.wrapping_add(u64::from(sample.position.abs_diff(last)));
        }
        updates.push(Update { index: 0x210B, sub: 1, value: self.steps & 0xFFFF_FFFF });
        updates.push(Update { index: 0x210B, sub: 2, value: self.steps >> 32 });
        updates.push(Update { index: 0x210B, sub: 3, value: self.steps });
        // 200Fh: the next index pulse latches the internal and the encoder position.
        if self.latch_armed && sample.inputs.contains(DigitalInputs::INDEX) {
            self.latch_armed = false;
            let position = u64::from(sample.position as u32);
            updates.push(Update { index: 0x200F, sub: 2, value: position });
            updates.push(Update { index: 0x200F, sub: 3, value: position });
            updates.push(Update { index: 0x200F, sub: 1, value: 0 });
        }
        // 2120h: closed loop is initialised 100 ms after it was switched on in Operation enabled.
        let requested = value_of(od, 0x2020, 0) == 1;
        if requested && matches!(state, State::OperationEnabled { .. }) {
            self.closed_loop_ticks = self.closed_loop_ticks.saturating_add(1);
        } else if !requested {
            self.closed_loop_ticks = 0;
        }
        updates.push(Update { index: 0x2120, sub: 0, value: u64::from(self.closed_loop_ticks >= 100) });
        // 2702h: IN0..IN2 (bits 16..18) are the left limit, right limit and home inputs.
        let pins = [DigitalInputs::NEGATIVE_LIMIT, DigitalInputs::POSITIVE_LIMIT, DigitalInputs::HOME];
        let inputs = pins
            .iter()
            .enumerate()
            .filter(|(_, p)| sample.inputs.contains(**p))
            .fold(0u64, |acc, (i, _)| acc | (1 << (16 + i)));
        updates.push(Update { index: 0x2702, sub: 0, value: inputs });
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    #[test]
    fn the_limit_switch_configuration_deactivates_and_inverts() {
        let left = DigitalInputs::NEGATIVE_LIMIT;
        let home = DigitalInputs::HOME;
        assert_eq!(Pd57::configured_inputs(0, left | home), left | home);
        assert_eq!(Pd57::configured_inputs(1, left | home), home);
        assert_eq!(Pd57::configured_inputs(3, left), DigitalInputs::empty());
        assert_eq!(Pd57::configured_inputs(4, DigitalInputs::empty()), left);
        assert_eq!(Pd57::configured_inputs(4 | 1, DigitalInputs::empty()), DigitalInputs::empty());
        assert_eq!(Pd57::configured_inputs(0x10, home), DigitalInputs::empty());
        assert_eq!(Pd57::configured_inputs(0x20, DigitalInputs::empty()), home);
        assert_eq!(Pd57::configured_inputs(0x3F, DigitalInputs::INDEX), DigitalInputs::INDEX);
    }
}

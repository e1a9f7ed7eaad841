//! A Harmonic Drive LLC integrated servo actuator (CANopen firmware manual), rebuilt on the
//! core as an RSF-5B-30 (motor encoder 16 384 steps per revolution, peak current 3252 mA,
//! 10 000 rpm). Section numbers below are the manual's.
//!
//! # Identity and communication (§3)
//!
//! 1000h 00420192h, vendor-ID 443h. Four RPDOs and four TPDOs with the manual's defaults: the
//! COB-IDs carry bit 30 (40000200h + node-ID, …), RPDO records with subs 0–2, TPDO records 0–5,
//! at most three mapping entries per PDO; transmission types FEh, FFh and 1–240 only.
//! 1029h: 0 = enter Stopped (the default), 1 = stay.
//!
//! # Drive profile (§5–§11)
//!
//! Modes pp, pv, hm, csp, csv, cst (6502h = 3A5h); option codes 605Ah 1/2/5/6, 605Bh 0,
//! 605Ch 1, 605Dh 1, 605Eh 2; homing methods 17, 18, 35 and the hard-stop methods −1…−6 with
//! the parameters of 2025h (current threshold sub 4, back-off sub 2 from the positive (CW)
//! stop, sub 3 from the negative one): −1/−2 home on the backed-off position and set the
//! software limit on that side to it, −3/−4 (and −5/−6) run both stops and set 607Dh to the
//! range. Deviations as configuration: NMT Stopped faults an enabled axis (§2.2), statusword
//! bit 14 motor moving, bit 15 direction (§6.1.2), mode changes, no change on set-point.
//!
//! Units as configuration of the core: torques in mA ([`TorqueUnit::MilliAmps`] through the
//! rated current 6075h, 1000 mA for the simulated actuator: 6071h, 6074h, 6077h, 60B2h), velocities
//! in motor rpm and accelerations in rpm/s ([`VelocityUnit::MotorRpm`] through 608Fh: 60FFh,
//! 606Bh, 606Ch, 6081h, 6082h, 6083h–6085h, 6099h, 609Ah; 2020h sub 2/3 go to 6080h/60C5h/60C6h
//! unchanged). The hard-stop threshold 2025h sub 4 and the limits 6072h/6073h are the core's ‰,
//! which at 1000 mA rated read as mA.
//!
//! # Manufacturer objects (§4)
//!
//! Working: 2005h limit switches (deactivate/invert, only in Switch on disabled; the switches
//! appear as bits 0/1 of 2702h, §12.2), 200Dh status flags, 200Eh supply voltage (the
//! simulated DC link), 200Fh driver temperature, 2020h limits (max torque → 6073h, max
//! velocity → 6080h, max acceleration → 60C5h/60C6h), 2025h hard-stop homing settings and the
//! homing state, 2030h/2040h/2050h actual and target values, 2060h/2080h sub 1 the commutation
//! angle, 2096h sub 1 the position window (→ following error window 6065h, a following error
//! stops the axis with EMCY 8611h), 2100h home offset display, 2704h/2705h bit rate and
//! node-ID (kept by 1010h sub 1 or 2 in the LSS file of `--storage`, active after a restart
//! or NMT reset node), 2706h user variables (address/data), 5FFFh bootloader (takes the magic number, reads 0).
//!
//! Present, readable and writable within their ranges, without effect on the simulated axis:
//! 2010h, 2015h, the loop gains in 2030h/2040h/2050h, 2055h, 2056h, 2080h subs 2–7, 2090h,
//! 2095h, 2703h, 270Eh.
//!
//! 1010h/1011h sub 3 (actuator profile parameters, "not used") read 0 and refuse the signature
//! (`Config::store_groups`). 1029h has the manual's two error classes: sub 2 (application
//! error) is the actuator entering Fault (CiA 402-2 §7.2), by default 1 (the NMT state stays).
//! The cyclic modes run without SYNC, as in the manual's examples: each set-point written by
//! SDO is reached over 60C2h (`CyclicConfig::{sdo_set_points, cycle_start}`). (SDO block
//! transfer, which the manual does not list, is switched off: `Config::sdo_block_transfer`.)
//!
//! Also configuration of the core, from the manual: the manufacturer bytes of its EMCY table
//! (§13.2, `Config::emcy_additional_bytes`); an RPDO with too many bytes is not processed
//! (`LongRpdo::DiscardAndReport`); method 35 sets 6062h, 6063h and 6064h to zero
//! (`HomingConfig::rebase_internal_position`); a node-ID and bit rate kept by 1010h take
//! effect at the next reset, NMT reset node included, and the stored `$NODEID` COB-IDs (1014h,
//! the PDOs) follow it; the standard objects the manual does not list (1003h, guarding
//! 100Ch/100Dh, 603Fh, 6065h, 6066h, 6068h, 606Dh, 6072h, 6080h, 6086h, 60F4h) do not exist
//! ([`ABSENT`]; the firmware still sets the hidden 6065h and 6080h from 2096h and 2020h); 6084h
//! and 2100h follow a write of 6083h/607Ch at once. A set-point written before Operation
//! enabled is the cyclic target once enabled (the core's `CycleStart::SetPoint`).
//!
//! Teach mode (§8.1.9, 2025h sub 5: 1 presets the position to 0 and 607Dh sub 1 to 0 —
//! `Drive::preset_position` —, 2 sets 607Dh sub 2 to the position, 3 sets it to 65 535) and the
//! saving after each homing run (§8.1.10: the firmware stores 607Dh, 2025h sub 2/3 and 2050h
//! sub 8 and keeps the rest of the stored set — `Drive::store_entries`) work.
//!
//! # Not reproduced
//!
//! 2050h sub 8 position scaler (−5/−6 and teach mode 3 do not compute it: the manual gives no
//! formula) and 1016h sub 0 writable (the manual does not say what a write does; the core's
//! count is a constant).
//!
//! The manual's PDO mappability of its entries, 608Fh sub 2 read-only, its types of 605Bh–605Eh
//! (UNSIGNED16), 6082h and the torques 6071h, 6077h, 60B2h (INTEGER32: the core's torque
//! entries reserve four bytes for this), 6084h read-only (kept
//! equal to 6083h by the firmware), 1016h with one entry and 1018h without sub 4 are the core's
//! entry descriptions overridden ([`DESCRIPTIONS`]).

use std::ops::RangeInclusive;

use canopen_drive::cia402::fsa::State;
use canopen_drive::cia402::hm::{HardStopEntries, HomingConfig, VendorMethod};
use canopen_drive::cia402::objects::mode_bit;
use canopen_drive::cia402::{OptionCodes, ProfileConfig, StatusFlag, TorqueUnit, Units, VelocityUnit};
use canopen_drive::comm::error_control::ErrorBehaviour;
use canopen_drive::comm::pdo::LongRpdo;
use canopen_drive::hal::{DigitalInputs, HardwareFaults, Sample};
use canopen_drive::od::eds::EdsInfo;
use canopen_drive::od::{
    layout, AbortCode, Access, DataType, DefaultOverride, DefaultValue, DeviceInfo, EntryOverride, Object,
    PdoMapping, Var, WriteRule,
};
use canopen_drive::storage::Group;
use canopen_drive::wire::lss::BitRate::{Kbit1000, Kbit125, Kbit20, Kbit250, Kbit50, Kbit500};
use canopen_drive::wire::lss::BitTiming;
use canopen_drive_sim::motor::MotorParams;

use super::trinamic::method_mask;
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

use DataType::{Integer16, Integer32, Unsigned16, Unsigned32, Unsigned8};

/// 2005h limit switches.
pub const LIMIT_SWITCHES: u16 = 0x2005;
/// 2025h homing mode settings.
pub const HOMING_SETTINGS: u16 = 0x2025;
/// 2704h CAN bit rate.
pub const CAN_BIT_RATE: u16 = 0x2704;
/// 2705h node-ID.
pub const NODE_ID: u16 = 0x2705;
/// 2706h user variables.
pub const USER_VARIABLES: u16 = 0x2706;
/// Encoder steps per motor revolution (RSF, 14 bit).
pub const STEPS_PER_REVOLUTION: u32 = 16_384;
/// Gear ratio of the RSF-5B-30.
pub const GEAR_RATIO: u64 = 30;

const fn within(name: &'static str, data_type: DataType, low: u64, high: u64, default: u64) -> Var {
    rw(name, data_type).limits_unsigned(low, high).default(DefaultValue::Unsigned(default))
}

const fn signed(name: &'static str, data_type: DataType, low: i64, high: i64, default: i64) -> Var {
    rw(name, data_type).limits_signed(low, high).default(DefaultValue::Signed(default))
}

const HIGHEST: &str = "Highest sub-index supported";

// The start values of 2020h and 2096h, which the firmware copies into the core's objects (see
// `Actuator::after_tick`): those objects start at the same values.
/// 2020h sub 1 max torque (mA): the peak current; 6072h/6073h (‰ = mA at the 1 A rated current).
const MAX_TORQUE: u64 = 3252;
/// 2020h sub 2 max velocity (rpm); 6080h.
const MAX_VELOCITY: u64 = 10_000;
/// 2020h sub 3 max acceleration (rpm/s); 60C5h, 60C6h.
const MAX_ACCELERATION: u64 = 400_000;
/// 2096h sub 1 position window (steps); the following error window 6065h.
const POSITION_WINDOW: u64 = 50_000;

const MOTOR_SUBS: [(u8, Var); 3] = [
    highest(HIGHEST, 2),
    (1, within("Motor Poles", Unsigned8, 2, 254, 10)),
    (2, within("Gear Ratio", Unsigned8, 1, 200, GEAR_RATIO)),
];
const BRAKE_SUBS: [(u8, Var); 2] = [highest(HIGHEST, 1), (1, within("BrakeMode", Unsigned8, 0, 2, 0))];
const LIMITS_SUBS: [(u8, Var); 5] = [
    highest(HIGHEST, 4),
    (1, within("MaxTorque", Unsigned32, 0, 3252, MAX_TORQUE)),
    (2, within("MaxVelocity", Unsigned32, 0, 10_000, MAX_VELOCITY)),
    (3, within("MaxAcceleration", Unsigned32, 0, 400_000, MAX_ACCELERATION)),
    (4, within("DigitalInput Threshold", Unsigned32, 0, 24_000, 10_000)),
];
const HOMING_SUBS: [(u8, Var); 6] = [
    highest(HIGHEST, 5),
    (1, ro("HomingState", Unsigned8)),
    (2, within("PositionOffset_CW", Unsigned32, 0, 2_147_483_647, 40_000)),
    (3, within("PositionOffset_CCW", Unsigned32, 0, 2_147_483_647, 40_000)),
    (4, within("CurrentThreshold", Unsigned16, 0, 3000, 800)),
    (5, within("TeachPositionLimit", Unsigned8, 0, 3, 0)),
];
const TORQUE_SUBS: [(u8, Var); 10] = [
    highest(HIGHEST, 9),
    (1, ro("ActualCurrent", Integer32)),
    (2, ro("TargetCurrent", Integer32)),
    (3, ro("RampTargetCurrent", Integer32)),
    (4, within("P_Parameter", Unsigned16, 0, 65_535, 500)),
    (5, within("I_Parameter", Unsigned16, 0, 65_535, 5000)),
    (6, ro("PI_Torque_Error", Integer32)),
    (7, ro("PI_Torque_Error_Sum", Integer32)),
    (8, ro("PI_Flux_Error", Integer32)),
    (9, ro("PI_Flux_Error_Sum", Integer32)),
];
const VELOCITY_SUBS: [(u8, Var); 9] = [
    highest(HIGHEST, 8),
    (1, ro("ActualVelocity", Integer32)),
    (2, ro("TargetVelocity", Integer32).limits_signed(-200_000, 200_000)),
    (3, ro("RampTargetVelocity", Integer32)),
    (4, within("MotorHaltedVelocity", Unsigned32, 0, 200_000, 5)),
    (5, within("P_Parameter", Unsigned16, 0, 65_535, 1000)),
    (6, within("I_Parameter", Unsigned16, 0, 65_535, 100)),
    (7, ro("VelocityError", Integer32)),
    (8, ro("VelocityErrorSum", Integer32)),
];
const POSITION_SUBS: [(u8, Var); 14] = [
    highest(HIGHEST, 13),
    (1, rw("ActualPosition", Integer32)),
    (2, ro("TargetPosition", Integer32)),
    (3, ro("RampTargetPosition", Integer32)),
    (4, within("P_Parameter", Unsigned16, 0, 65_535, 100)),
    (5, ro("Position_Error", Integer32)),
    (6, within("TargetReachedVelocity", Unsigned32, 0, 200_000, 500)),
    (7, within("TargetReachedDistance", Unsigned32, 0, 100_000, 5)),
    (8, signed("PositionScaler", Integer16, -32_768, 32_767, 32_767)),
    (9, within("ActualPositionSelection", Unsigned8, 0, 1, 0)),
    (10, ro("ActualMotorPosition", Integer32)),
    (11, ro("ActualGearboxPosition", Integer32)),
    (12, ro("RawMotorEncoderPosition", Integer32)),
    (13, ro("RawGearboxEncoderPosition", Integer32)),
];
const ANGLE_SUBS: [(u8, Var); 2] = [highest(HIGHEST, 1), (1, ro("ActualAngle", Integer16))];
const ENCODER_SUBS: [(u8, Var); 8] = [
    highest(HIGHEST, 7),
    (1, ro("ActualAngle", Integer16)),
    (2, within("StepsPerRotation", Unsigned32, 0, 2_147_483_647, STEPS_PER_REVOLUTION as u64)),
    (3, within("Offset", Unsigned32, 0, 2_147_483_647, 0)),
    (4, within("Direction", Unsigned8, 0, 1, 1)),
    (5, within("InitMode", Unsigned8, 0, 2, 1)),
    (6, within("InitDelay", Unsigned16, 0, 10_000, 1000)),
    (7, signed("InitVelocity", Integer32, -200_000, 200_000, 200)),
];
const ILT_SUBS: [(u8, Var); 8] = [
    highest(HIGHEST, 7),
    (1, within("WindingTime_1", Unsigned16, 1000, 60_000, 3000)),
    (2, within("IltLimit_1", Unsigned32, 0, 54_000_000, 20_000_000)),
    (3, ro("IltSum_1", Unsigned32)),
    (4, within("WindingTime_2", Unsigned16, 1000, 60_000, 6000)),
    (5, within("IltLimit_2", Unsigned32, 0, 54_000_000, 20_000_000)),
    (6, ro("IltSum_2", Unsigned32)),
    (7, within("ClearExceededFlags", Unsigned8, 0, 255, 0)),
];
const VELOCITY_WINDOW_SUBS: [(u8, Var); 3] = [
    highest(HIGHEST, 2),
    (1, within("VelocityWindow", Unsigned16, 0, 65_535, 1000)),
    (2, within("ClearVelocityWindowError", Unsigned8, 0, 255, 0)),
];
const POSITION_WINDOW_SUBS: [(u8, Var); 3] = [
    highest(HIGHEST, 2),
    (1, rw("PositionWindow", Unsigned32).default(DefaultValue::Unsigned(POSITION_WINDOW))),
    (2, within("ClearPositionWindowError", Unsigned8, 0, 255, 0)),
];
const OUTPUT_SUBS: [(u8, Var); 3] = [
    highest(HIGHEST, 2),
    (1, within("Physical outputs", Unsigned32, 0, 2_147_483_647, 0).pdo(PdoMapping::Both)),
    (2, within("Output mask", Unsigned32, 0, 2_147_483_647, 0)),
];
const USER_SUBS: [(u8, Var); 4] = [
    highest(HIGHEST, 3),
    (1, within("Address", Unsigned8, 0, 255, 0)),
    (2, rw("Data", Integer32)),
    (3, rw("Store", Unsigned32).default(DefaultValue::Unsigned(305_419_896))),
];
const fn adc(name: &'static str) -> Var {
    ro(name, Unsigned16).limits_unsigned(0, 4095)
}
const ANALOG_SUBS: [(u8, Var); 7] = [
    highest(HIGHEST, 6),
    (1, adc("ADC_phase_A")),
    (2, adc("ADC_phase_B")),
    (3, adc("ADC_Vsupply")),
    (4, adc("ADC_Temp")),
    (5, adc("ADC_IN_1").pdo(PdoMapping::Tpdo)),
    (6, adc("ADC_IN_2").pdo(PdoMapping::Tpdo)),
];

/// The manufacturer objects of §4, the simulation objects at 5E00h, and 5FFFh.
pub static OBJECTS: [Object; 29] = layout([
    var(LIMIT_SWITCHES, within("Limit switches", Unsigned32, 0, 15, 0).rule(WriteRule::SwitchOnDisabled)),
    var(0x200D, ro("Status Flags", Unsigned32)),
    var(0x200E, ro("Supply Voltage", Unsigned32).default(DefaultValue::Unsigned(240))),
    var(0x200F, ro("Driver Temperature", Integer32).limits_signed(-20, 120)),
    Object::record(0x2010, "Motor Settings", &MOTOR_SUBS),
    Object::record(0x2015, "Brake Settings", &BRAKE_SUBS),
    Object::record(0x2020, "Limits", &LIMITS_SUBS),
    Object::record(HOMING_SETTINGS, "Homing Mode Settings", &HOMING_SUBS),
    Object::record(0x2030, "Torque Mode Settings", &TORQUE_SUBS),
    Object::record(0x2040, "Velocity Mode Settings", &VELOCITY_SUBS),
    Object::record(0x2050, "Position Mode Settings", &POSITION_SUBS),
    var(0x2055, within("Commutation Mode", Unsigned8, 0, 2, 2)),
    var(0x2056, within("Velocity Ramp Mode", Unsigned8, 0, 1, 1)),
    Object::record(0x2060, "Open Loop Settings", &ANGLE_SUBS),
    Object::record(0x2080, "Encoder Settings", &ENCODER_SUBS),
    Object::record(0x2090, "Ilt Monitor Settings", &ILT_SUBS),
    Object::record(0x2095, "Velocity Window Settings", &VELOCITY_WINDOW_SUBS),
    Object::record(0x2096, "Position Window Settings", &POSITION_WINDOW_SUBS),
    var(0x2100, ro("Home Offset Display", Integer32)),
    var(0x2702, ro("Digital Inputs", Unsigned32).limits_unsigned(0, 15).pdo(PdoMapping::Tpdo)),
    Object::record(0x2703, "Device Digital Outputs", &OUTPUT_SUBS),
    var(CAN_BIT_RATE, within("CAN Bit Rate", Unsigned16, 20, 1000, 1000)),
    var(NODE_ID, rw("Node ID", Unsigned8).limits_unsigned(1, 127).default(DefaultValue::NodeIdPlus(0))),
    Object::record(USER_VARIABLES, "User Variables", &USER_SUBS),
    Object::record(0x270E, "Analog Inputs", &ANALOG_SUBS),
    simulated_faults(PROFILE_SIMULATION),
    simulated_inputs(PROFILE_SIMULATION + 1),
    simulated_load(PROFILE_SIMULATION + 2),
    var(0x5FFF, rw("Bootloader mode", Unsigned32)),
]);

// --- PDOs (§3.1.15–3.1.18) -----------------------------------------------------------------

static RPDO_COMMUNICATION: [[(u8, Var); 3]; 4] = [
    rpdo_communication(0x4000_0000 | 0x200, 0xFF),
    rpdo_communication(0x4000_0000 | 0x300, 0xFF),
    rpdo_communication(0x4000_0000 | 0x400, 0xFF),
    rpdo_communication(0x4000_0000 | 0x500, 0xFF),
];
static TPDO_COMMUNICATION: [[(u8, Var); 6]; 4] = [
    tpdo_communication(0x4000_0000 | 0x180, 0xFF),
    tpdo_communication(0x4000_0000 | 0x280, 0xFF),
    tpdo_communication(0x4000_0000 | 0x380, 0x01),
    tpdo_communication(0x4000_0000 | 0x480, 0x01),
];

/// The PDO records.
pub static PDOS: [Object; 16] =
    layout(pdo_records(&RPDO_COMMUNICATION, &CIA402_RPDO_MAPPING, &TPDO_COMMUNICATION, &CIA402_TPDO_MAPPING));

// --- Value rules, defaults, configuration -----------------------------------------------

/// 1..=240, FEh and FFh (§3.1.15, §3.1.17).
const TRANSMISSION_TYPES: &[RangeInclusive<u64>] = &[1..=240, 0xFE..=0xFF];

const fn only(index: u16, sub: u8, values: &'static [RangeInclusive<u64>]) -> ValueRule {
    ValueRule { index, sub, values, refusal: AbortCode::InvalidValue, stores: false }
}

/// Transmission types, bit rates and the bootloader's magic number.
pub static RULES: [ValueRule; 10] = [
    only(0x1400, 2, TRANSMISSION_TYPES),
    only(0x1401, 2, TRANSMISSION_TYPES),
    only(0x1402, 2, TRANSMISSION_TYPES),
    only(0x1403, 2, TRANSMISSION_TYPES),
    only(0x1800, 2, TRANSMISSION_TYPES),
    only(0x1801, 2, TRANSMISSION_TYPES),
    only(0x1802, 2, TRANSMISSION_TYPES),
    only(0x1803, 2, TRANSMISSION_TYPES),
    only(CAN_BIT_RATE, 0, &[20..=20, 50..=50, 125..=125, 250..=250, 500..=500, 1000..=1000]),
    only(0x5FFF, 0, &[0x1234_5678..=0x1234_5678]),
];

/// The manual's defaults of standard objects (the velocities are encoder steps per second
/// here, see the module docs), the simulated actuator's rated current, and the start values of
/// the objects the firmware sets from 2020h and 2096h.
pub static DEFAULTS: [DefaultOverride; 22] = [
    // §3.1.14: two error classes; the application error (the drive's Fault) keeps the state.
    default_of(0x1029, 0, u(2)),
    default_of(0x1029, 2, u(1)),
    // §3.1.7/§3.1.8: the profile group cannot be stored or restored (reads 0).
    default_of(0x1010, 3, u(0)),
    default_of(0x1011, 3, u(0)),
    default_of(0x6067, 0, u(0xFFFF_FFFF)),
    default_of(0x6081, 0, u(6000)),
    default_of(0x6082, 0, u(500)),
    // rpm/s ("depends on actuator"): 100 revolutions/s², what the simulated actuator follows.
    default_of(0x6083, 0, u(6000)),
    default_of(0x6084, 0, u(6000)),
    default_of(0x6085, 0, u(6000)),
    default_of(0x6099, 1, u(1000)),
    default_of(0x6099, 2, u(500)),
    default_of(0x609A, 0, u(2000)),
    default_of(0x608F, 1, u(STEPS_PER_REVOLUTION as u64)),
    // The feed per revolution equal to the encoder steps: positions stay encoder steps.
    default_of(0x6092, 1, u(STEPS_PER_REVOLUTION as u64)),
    default_of(0x6075, 0, u(1000)),
    // What the firmware keeps them at from 2020h and 2096h sub 1 (6065h, 6072h, 6080h are
    // absent from the bus, their values still limit the axis).
    default_of(0x6072, 0, u(MAX_TORQUE)),
    default_of(0x6073, 0, u(MAX_TORQUE)),
    default_of(0x6080, 0, u(MAX_VELOCITY)),
    default_of(0x60C5, 0, u(MAX_ACCELERATION)),
    default_of(0x60C6, 0, u(MAX_ACCELERATION)),
    default_of(0x6065, 0, u(POSITION_WINDOW)),
];

/// The manual's descriptions of standard objects where they differ from CiA 301/402's: 1016h
/// and 1018h with fewer entries, the option
/// codes 605Bh–605Eh UNSIGNED16 (§5.1.2–5.1.5), the end velocity 6082h INTEGER32 (§6.1.12; a
/// magnitude for the core, so negative values are refused), and the profile deceleration 6084h
/// read-only (§6.1.14: the firmware keeps it equal to the profile acceleration 6083h).
pub static DESCRIPTIONS: [EntryOverride; 21] = [
    // One heartbeat consumer entry (§3.1.11), an identity without a serial number (§3.1.13).
    communication_entry(0x1016, 0).default(u(1)),
    communication_entry(0x1018, 0).default(u(3)),
    // Not mappable in the manual's tables.
    communication_entry(0x1001, 0).pdo(PdoMapping::No),
    profile_entry(0x606B, 0).pdo(PdoMapping::No),
    profile_entry(0x6081, 0).pdo(PdoMapping::No),
    profile_entry(0x6083, 0).pdo(PdoMapping::No),
    profile_entry(0x6085, 0).pdo(PdoMapping::No),
    profile_entry(0x6098, 0).pdo(PdoMapping::No),
    profile_entry(0x6099, 1).pdo(PdoMapping::No),
    profile_entry(0x6099, 2).pdo(PdoMapping::No),
    profile_entry(0x609A, 0).pdo(PdoMapping::No),
    // 608Fh sub 2 (motor revolutions) is read-only in the manual (§5.1.8).
    profile_entry(0x608F, 2).access(Access::ReadOnly),
    profile_entry(0x605B, 0).data_type(Unsigned16),
    profile_entry(0x605C, 0).data_type(Unsigned16),
    profile_entry(0x605D, 0).data_type(Unsigned16),
    profile_entry(0x605E, 0).data_type(Unsigned16),
    profile_entry(0x6082, 0).data_type(Integer32).limits_signed(0, i32::MAX as i64).pdo(PdoMapping::No),
    profile_entry(0x6084, 0).access(Access::ReadOnly).pdo(PdoMapping::No),
    // Torques in mA as INTEGER32 (§11.1.3–11.1.5): widened into the 4 bytes the core reserves.
    profile_entry(0x6071, 0).data_type(Integer32),
    profile_entry(0x6077, 0).data_type(Integer32),
    profile_entry(0x60B2, 0).data_type(Integer32).pdo(PdoMapping::No),
];

/// What the actuator saves after each homing run (§8.1.10): the position scaler 2050h sub 8,
/// the software limits 607Dh, the position offsets 2025h sub 2/3.
pub static HOMING_PARAMETERS: [(u16, u8); 5] =
    [(0x2025, 2), (0x2025, 3), (0x2050, 8), (0x607D, 1), (0x607D, 2)];

/// 1029h sub 1: 0 = Stopped, 1 = stay (§3.1.14).
pub static ERROR_BEHAVIOUR: [(u8, ErrorBehaviour); 2] =
    [(0, ErrorBehaviour::Stopped), (1, ErrorBehaviour::NoChange)];

/// The hard-stop methods of table 197.
pub static HARD_STOP_METHODS: [(i8, VendorMethod); 6] = [
    (-1, VendorMethod::HardStopLimit { positive: true }),
    (-2, VendorMethod::HardStopLimit { positive: false }),
    (-3, VendorMethod::HardStopRange { positive_first: true }),
    (-4, VendorMethod::HardStopRange { positive_first: false }),
    (-5, VendorMethod::HardStopRange { positive_first: true }),
    (-6, VendorMethod::HardStopRange { positive_first: false }),
];

/// The core's drive-profile configuration of this actuator.
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
        standard_methods: method_mask(&[17, 18, 35]),
        vendor_methods: &HARD_STOP_METHODS,
        hard_stop_entries: Some(HardStopEntries {
            threshold: (HOMING_SETTINGS, 4),
            time: None,
            back_off_positive: (HOMING_SETTINGS, 2),
            back_off_negative: (HOMING_SETTINGS, 3),
        }),
        // The methods drive into the stops; the limit switches do not end them (§8.1.3–8.1.6).
        hard_stop_passes_limit_switches: true,
        // §8.1 method 35: 6062h, 6063h and 6064h are all set to zero (6063h = 6064h, §6.1.5).
        rebase_internal_position: true,
        ..HomingConfig::new()
    };
    config.change_on_setpoint = false;
    config.following_error_fault = true;
    // The examples of §9.2–§11.2 stream the set-points by SDO.
    config.cyclic.sdo_set_points = true;
    // §9.2/§10.2/§11.2: no SYNC; each written set-point is reached over 60C2h.
    config.cyclic.cycle_start = canopen_drive::cia402::cyclic::CycleStart::SetPoint;
    config.nmt_stopped_fault = true;
    config.statusword_bit_14 = StatusFlag::Moving;
    config.statusword_bit_15 = StatusFlag::Negative;
    // Torques in mA (through 6075h), velocities in rpm and accelerations in rpm/s (§4.1.7, §6–§11).
    config.units =
        Units { torque: TorqueUnit::MilliAmps, velocity: VelocityUnit::MotorRpm, ..Units::CIA_402 };
    config
}

/// The manufacturer-specific bytes of the manual's EMCY table (§13.2) for the codes the core
/// raises (8611h 1: the position window following error).
pub static EMCY_BYTES: [(u16, [u8; 5]); 9] = communication_emcy_bytes((0x8611, [1, 0, 0, 0, 0]));

/// The core's standard objects the manual's object list does not have (guarding is listed as
/// removed): 0602 0000h from the bus, not in the EDS; the behaviour they carry keeps its
/// defaults (the firmware still sets 6065h from 2096h sub 1 and 6080h from 2020h sub 2).
pub static ABSENT: [u16; 12] =
    [0x1003, 0x100C, 0x100D, 0x603F, 0x6065, 0x6066, 0x6068, 0x606D, 0x6072, 0x6080, 0x6086, 0x60F4];

/// Identity (§3.1.1, §3.1.4–3.1.6, §3.1.13) and modes (§5.1.10).
pub fn device_info() -> DeviceInfo {
    DeviceInfo {
        device_type: 0x0042_0192,
        vendor_id: 0x0443,
        product_code: 0x0001_0008,
        revision_number: 0x0002_0003,
        device_name: "RSF-5B-30",
        hardware_version: "1.0",
        software_version: "1.0",
        vendor_name: "Harmonic Drive LLC (simulated)",
        drive_modes: mode_bit::PROFILE_POSITION
            | mode_bit::PROFILE_VELOCITY
            | mode_bit::HOMING
            | mode_bit::CYCLIC_POSITION
            | mode_bit::CYCLIC_VELOCITY
            | mode_bit::CYCLIC_TORQUE,
        ..DeviceInfo::servo_drive()
    }
}

/// The simulated actuator: a 16 384-step motor encoder, limit switches beyond ±150 000 (wired
/// to 2702h bits 0/1), elastic hard stops at ±200 000, no home switch.
pub fn axis() -> MotorParams {
    MotorParams {
        increments_per_revolution: STEPS_PER_REVOLUTION,
        negative_limit_switch: Some(-150_000),
        positive_limit_switch: Some(150_000),
        negative_hard_stop: Some(-200_000),
        positive_hard_stop: Some(200_000),
        hard_stop_stiffness: 1000.0,
        hard_stop_damping: 2.0,
        ..MotorParams::default()
    }
}

/// The profile.
pub fn profile() -> BoardProfile {
    BoardProfile {
        axes: 1,
        name: ProfileName::HarmonicDrive,
        config: Config {
            device: device_info(),
            manufacturer_objects: &OBJECTS,
            pdo_objects: &PDOS,
            profile: profile_config(),
            default_overrides: &DEFAULTS,
            entry_overrides: &DESCRIPTIONS,
            error_behaviour_values: &ERROR_BEHAVIOUR,
            sdo_block_transfer: false,
            // §3.1.7/§3.1.8: sub 3 (actuator profile parameters) is not used: it reads 0.
            store_groups: &[Group::All, Group::Communication, Group::Manufacturer],
            // §13.2 8220h: a PDO with too many bytes "could not be processed".
            long_rpdo: LongRpdo::DiscardAndReport,
            emcy_additional_bytes: &EMCY_BYTES,
            absent_objects: &ABSENT,
            // §4.1.22 (2704h): 20, 50, 125, 250, 500 and 1000 kbit/s.
            bit_rates: &[Kbit20, Kbit50, Kbit125, Kbit250, Kbit500, Kbit1000],
            ..Config::new(TEMPLATE_NODE_ID)
        },
        eds: EdsInfo {
            file_name: "harmonic-drive.eds",
            description: "Harmonic Drive CANopen actuator interface rebuilt on canopen-drive (simulated)",
            ..EdsInfo::default()
        },
        simulation: PROFILE_SIMULATION,
        rules: &RULES,
        axis: axis(),
        firmware: || Box::new(Actuator::default()),
    }
}

// --- The firmware ------------------------------------------------------------------------

/// The behaviour of the manufacturer objects on the simulated actuator.
#[derive(Debug)]
pub struct Actuator {
    /// 2706h: 256 user variables.
    user: [i32; 256],
    /// A homing run completed (2025h sub 1 = 1).
    homed: bool,
    /// Teach mode's position preset and the saving after homing (§8.1.9, §8.1.10).
    actions: Vec<Action>,
}

impl Default for Actuator {
    fn default() -> Self {
        Actuator { user: [0; 256], homed: false, actions: Vec::new() }
    }
}

/// Encoder steps per second as rpm.
fn rpm(steps_per_second: i64) -> i64 {
    steps_per_second * 60 / i64::from(STEPS_PER_REVOLUTION)
}

fn signed_value(od: &BoardDictionary, index: u16, sub: u8, bits: u32) -> i64 {
    let raw = value_of(od, index, sub);
    let shift = 64 - bits;
    ((raw << shift) as i64) >> shift
}

impl Actuator {
    /// The values derived from others, after a start or a reset loaded them: 6084h follows
    /// 6083h (§6.1.14), 2100h shows 607Ch (a write of either updates them at once).
    fn derived(od: &BoardDictionary, updates: &mut Vec<Update>) {
        updates.push(Update { index: 0x6084, sub: 0, value: value_of(od, 0x6083, 0) });
        updates.push(Update { index: 0x2100, sub: 0, value: value_of(od, 0x607C, 0) });
    }

    /// 2005h: bits 0/1 switch the left/right limit switch off, 2/3 invert them.
    pub fn configured_inputs(config: u64, inputs: DigitalInputs) -> DigitalInputs {
        let mut out = inputs - (DigitalInputs::NEGATIVE_LIMIT | DigitalInputs::POSITIVE_LIMIT);
        for (input, off, invert) in
            [(DigitalInputs::NEGATIVE_LIMIT, 1 << 0, 1 << 2), (DigitalInputs::POSITIVE_LIMIT, 1 << 1, 1 << 3)]
        {
            if inputs.contains(input) != (config & invert != 0) && config & off == 0 {
                out |= input;
            }
        }
        out
    }

    /// 200Dh from the drive's state.
    fn status_flags(od: &BoardDictionary, sample: &Sample, state: State) -> u64 {
        let statusword = value_of(od, 0x6041, 0);
        let mode = signed_value(od, 0x6061, 0, 8);
        let faults = sample.faults;
        let mut flags = 0u64;
        let mut set = |bit: u32, on: bool| {
            if on {
                flags |= 1 << bit;
            }
        };
        set(0, faults.contains(HardwareFaults::OVER_CURRENT));
        set(1, faults.contains(HardwareFaults::UNDER_VOLTAGE));
        set(2, faults.contains(HardwareFaults::OVER_VOLTAGE));
        set(3, faults.contains(HardwareFaults::OVER_TEMPERATURE));
        set(4, matches!(state, State::Fault | State::FaultReactionActive));
        set(5, state.drive_function_enabled());
        set(6, !faults.is_empty());
        set(8, mode == 0);
        set(9, matches!(mode, 3 | 9));
        set(10, matches!(mode, 1 | 6 | 8));
        set(11, mode == 10);
        set(13, statusword & 0x2000 != 0 && matches!(mode, 1 | 8));
        set(14, statusword & 0x0400 != 0 && matches!(mode, 1 | 8));
        set(15, true);
        set(16, !state.drive_function_enabled());
        set(20, mode == 6 && statusword & 0x1000 != 0);
        set(21, mode == 6 && statusword & 0x3400 == 0 && state.drive_function_enabled());
        set(22, sample.inputs.contains(DigitalInputs::NEGATIVE_LIMIT));
        set(23, sample.inputs.contains(DigitalInputs::POSITIVE_LIMIT));
        set(24, mode == 6 && statusword & 0x2000 != 0);
        flags
    }
}

impl Firmware for Actuator {
    fn inputs(&mut self, od: &BoardDictionary, sample: &mut Sample) {
        sample.inputs = Actuator::configured_inputs(value_of(od, LIMIT_SWITCHES, 0), sample.inputs);
    }

    fn written(
        &mut self,
        index: u16,
        sub: u8,
        value: u64,
        od: &BoardDictionary,
        _env: &Environment<'_>,
        updates: &mut Vec<Update>,
    ) {
        match (index, sub) {
            (USER_VARIABLES, 1) => {
                let slot = self.user.get(value as usize).copied().unwrap_or(0);
                updates.push(Update { index, sub: 2, value: u64::from(slot as u32) });
            }
            (USER_VARIABLES, 2) => {
                let address = value_of(od, USER_VARIABLES, 1) as usize;
                if let Some(slot) = self.user.get_mut(address) {
                    *slot = value as u32 as i32;
                }
            }
            // §8.1.9 teach mode: 1 marks the present position as 0 and as the min software limit,
            // 2 the present position as the max limit, 3 the scaled range (607Dh sub 2 = 65 535;
            // the position scaler 2050h sub 8 itself is not computed: the manual gives no formula).
            (HOMING_SETTINGS, 5) => match value {
                1 => {
                    self.actions.push(Action::PresetPosition(0));
                    updates.push(Update { index: 0x607D, sub: 1, value: 0 });
                }
                2 => updates.push(Update { index: 0x607D, sub: 2, value: value_of(od, 0x6064, 0) }),
                3 => updates.push(Update { index: 0x607D, sub: 2, value: 65_535 }),
                _ => {}
            },
            // 6084h is read-only (§6.1.14) and follows 6083h; 2100h shows 607Ch: at once.
            (0x6083, 0) => updates.push(Update { index: 0x6084, sub: 0, value }),
            (0x607C, 0) => updates.push(Update { index: 0x2100, sub: 0, value }),
            // Error flags are cleared by any write; the sub-index reads 0 again.
            (0x2090, 7) | (0x2095, 2) | (0x2096, 2) => updates.push(Update { index, sub, value: 0 }),
            (0x5FFF, 0) => {
                log!("5FFFh: the bootloader is not simulated");
                updates.push(Update { index, sub, value: 0 });
            }
            _ => {}
        }
    }

    fn take_actions(&mut self) -> Vec<Action> {
        core::mem::take(&mut self.actions)
    }

    fn stored(&mut self, sub: u8, od: &BoardDictionary, env: &Environment<'_>) {
        // 1010h sub 1 (all) and sub 2 (communication) keep 2704h and 2705h (§3.1.7).
        if !matches!(sub, 1 | 2) {
            return;
        }
        let node_id = u8::try_from(value_of(od, NODE_ID, 0)).unwrap_or(1);
        let timing = bit_timing_index(value_of(od, CAN_BIT_RATE, 0))
            .map(|table_index| BitTiming { table_selector: 0, table_index });
        if let Some(path) = env.lss_file {
            if let Err(e) = crate::lss_store::save(path, node_id, timing) {
                log!("1010h: cannot store node-ID and bit rate in {}: {e}", path.display());
            }
        }
        // Active after the next reset of the actuator (NMT reset node too).
        self.actions.push(Action::ConfigureNodeId(node_id));
    }

    fn start(&mut self, od: &BoardDictionary, env: &Environment<'_>, updates: &mut Vec<Update>) {
        Actuator::derived(od, updates);
        // 2704h shows the bit rate of the next start, at start-up the one it runs at.
        updates.push(Update { index: CAN_BIT_RATE, sub: 0, value: u64::from(env.bit_rate_kbit) });
    }

    fn reset(&mut self, od: &BoardDictionary, env: &Environment<'_>, updates: &mut Vec<Update>) {
        Actuator::derived(od, updates);
        // The actuator was reset: the stored bit rate is the one it runs at (the node-ID took
        // effect in the core).
        let rate = stored_bit_rate(env).unwrap_or(env.bit_rate_kbit);
        updates.push(Update { index: CAN_BIT_RATE, sub: 0, value: u64::from(rate) });
    }

    fn after_tick(&mut self, od: &BoardDictionary, sample: &Sample, state: State, updates: &mut Vec<Update>) {
        let mut put = |index: u16, sub: u8, value: u64| updates.push(Update { index, sub, value });
        put(0x200D, 0, Actuator::status_flags(od, sample, state));
        put(0x200E, 0, u64::from(sample.dc_link_millivolts / 100));
        let temperature: i64 =
            if sample.faults.contains(HardwareFaults::OVER_TEMPERATURE) { 120 } else { 25 };
        put(0x200F, 0, temperature as u64);
        // 2025h sub 1: homing state.
        let mode = signed_value(od, 0x6061, 0, 8);
        let statusword = value_of(od, 0x6041, 0);
        let method = signed_value(od, 0x6098, 0, 8);
        // 2025h sub 1: 0 not homed, 1 homed, 3/4/5 moving to an end (the negative or positive
        // stop), 255 stopped by an error.
        let homing = mode == 6;
        if homing && statusword & 0x1000 != 0 {
            if !self.homed {
                // §8.1.10: the new homing parameters go to flash after each homing run, and
                // only they.
                self.actions.push(Action::StoreEntries(&HOMING_PARAMETERS));
            }
            self.homed = true;
        } else if homing && statusword & 0x3400 == 0 && state.drive_function_enabled() {
            self.homed = false;
        }
        let homing_state = match statusword & 0x3400 {
            _ if self.homed => 1,
            0x0000 if homing && state.drive_function_enabled() => match method {
                -1 | -3 | -5 => 5,
                -2 | -4 | -6 => 4,
                _ => 3,
            },
            bits if homing && bits & 0x2000 != 0 => 255,
            _ => 0,
        };
        put(HOMING_SETTINGS, 1, homing_state);
        // 2030h: currents in mA (rated current 1000 mA: the ‰ values).
        let actual = i64::from(sample.torque);
        let demand = signed_value(od, 0x6074, 0, 16);
        put(0x2030, 1, actual as u64);
        put(0x2030, 2, demand as u64);
        put(0x2030, 3, demand as u64);
        put(0x2030, 6, (demand - actual) as u64);
        // 2040h: velocities in rpm (60FFh and 606Bh already are).
        let velocity = rpm(i64::from(sample.velocity));
        let target = signed_value(od, 0x60FF, 0, 32);
        let ramp = signed_value(od, 0x606B, 0, 32);
        put(0x2040, 1, velocity as u64);
        put(0x2040, 2, target.clamp(-200_000, 200_000) as u64);
        put(0x2040, 3, ramp as u64);
        put(0x2040, 7, (ramp - velocity) as u64);
        // 2050h: positions in encoder steps.
        let position = i64::from(sample.position);
        let gear = value_of(od, 0x2010, 2).max(1) as i64;
        put(0x2050, 1, value_of(od, 0x6064, 0));
        put(0x2050, 2, value_of(od, 0x607A, 0));
        put(0x2050, 3, value_of(od, 0x6062, 0));
        put(0x2050, 5, value_of(od, 0x60F4, 0));
        put(0x2050, 10, position as u64);
        put(0x2050, 11, (position / gear) as u64);
        put(0x2050, 12, position as u64);
        put(0x2050, 13, (position / gear) as u64);
        // 2060h/2080h sub 1: the commutation angle, one turn = 65 536.
        let turn = i64::from(STEPS_PER_REVOLUTION);
        let angle = (position.rem_euclid(turn) * 65_536 / turn) as i16;
        put(0x2060, 1, u64::from(angle as u16));
        put(0x2080, 1, u64::from(angle as u16));
        // 2100h: the home offset.

        // 2702h: the limit switch inputs on bits 0/1 while 2005h uses them (§12.2).
        let config = value_of(od, LIMIT_SWITCHES, 0);
        let mut inputs = 0;
        if config & 1 == 0 && sample.inputs.contains(DigitalInputs::NEGATIVE_LIMIT) {
            inputs |= 1;
        }
        if config & 2 == 0 && sample.inputs.contains(DigitalInputs::POSITIVE_LIMIT) {
            inputs |= 2;
        }
        put(0x2702, 0, inputs);
        // 2020h: the limits of the core (max current in ‰ = mA at 1 A rated, rpm, rpm/s).
        put(0x6073, 0, value_of(od, 0x2020, 1).min(u64::from(u16::MAX)));
        put(0x6072, 0, value_of(od, 0x2020, 1).min(u64::from(u16::MAX)));
        put(0x6080, 0, value_of(od, 0x2020, 2));
        put(0x60C5, 0, value_of(od, 0x2020, 3));
        put(0x60C6, 0, value_of(od, 0x2020, 3));
        // 2096h sub 1: the position window is the following error window.
        put(0x6065, 0, value_of(od, 0x2096, 1));
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    #[test]
    fn the_limit_switch_configuration_deactivates_and_inverts() {
        let left = DigitalInputs::NEGATIVE_LIMIT;
        let right = DigitalInputs::POSITIVE_LIMIT;
        let home = DigitalInputs::HOME;
        assert_eq!(Actuator::configured_inputs(0, left | home), left | home);
        assert_eq!(Actuator::configured_inputs(3, left | right), DigitalInputs::empty());
        assert_eq!(Actuator::configured_inputs(8, DigitalInputs::empty()), right);
        assert_eq!(Actuator::configured_inputs(8 | 2, DigitalInputs::empty()), DigitalInputs::empty());
    }

    #[test]
    fn transmission_types_of_the_manual() {
        let allowed = |t: u64| TRANSMISSION_TYPES.iter().any(|r| r.contains(&t));
        assert!(!allowed(0) && allowed(1) && allowed(240) && !allowed(241) && !allowed(0xFD));
        assert!(allowed(0xFE) && allowed(0xFF));
    }
}

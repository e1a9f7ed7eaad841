//! The communication-profile objects the crate brings (CiA 301 §7.5), and the
//! index constants of every object the crate itself reads or writes.

use super::{layout, Access, DataType, DefaultValue, DeviceField, Object, PdoMapping, Var};

/// The communication profile area (CiA 301): reset to its power-on values by NMT reset
/// communication.
pub const COMMUNICATION_AREA: core::ops::RangeInclusive<u16> = 0x1000..=0x1FFF;
/// The manufacturer and device profile areas: reset by NMT reset application (reset node).
pub const APPLICATION_AREA: core::ops::RangeInclusive<u16> = 0x2000..=0xFFFF;

/// 1000h device type.
pub const DEVICE_TYPE: u16 = 0x1000;
/// 1001h error register.
pub const ERROR_REGISTER: u16 = 0x1001;
/// 1005h COB-ID SYNC.
pub const COB_ID_SYNC: u16 = 0x1005;
/// 1006h communication cycle period (µs).
pub const COMMUNICATION_CYCLE_PERIOD: u16 = 0x1006;
/// 1007h synchronous window length (µs).
pub const SYNCHRONOUS_WINDOW_LENGTH: u16 = 0x1007;
/// 1019h synchronous counter overflow value.
pub const SYNCHRONOUS_COUNTER_OVERFLOW: u16 = 0x1019;
/// 1008h manufacturer device name.
pub const DEVICE_NAME: u16 = 0x1008;
/// 1009h manufacturer hardware version.
pub const HARDWARE_VERSION: u16 = 0x1009;
/// 100Ah manufacturer software version.
pub const SOFTWARE_VERSION: u16 = 0x100A;
/// 1003h pre-defined error field (error history, newest first).
pub const PRE_DEFINED_ERROR_FIELD: u16 = 0x1003;
/// 100Ch guard time (ms).
pub const GUARD_TIME: u16 = 0x100C;
/// 100Dh life time factor.
pub const LIFE_TIME_FACTOR: u16 = 0x100D;
/// 1010h store parameters (the storage's command object, `crate::storage`).
pub const STORE_PARAMETERS: u16 = 0x1010;
/// 1011h restore default parameters (the storage's command object).
pub const RESTORE_DEFAULT_PARAMETERS: u16 = 0x1011;
/// 1014h COB-ID EMCY.
pub const COB_ID_EMCY: u16 = 0x1014;
/// 1015h inhibit time EMCY (100 µs).
pub const INHIBIT_TIME_EMCY: u16 = 0x1015;
/// 1016h consumer heartbeat time.
pub const CONSUMER_HEARTBEAT_TIME: u16 = 0x1016;
/// 1017h producer heartbeat time (ms).
pub const PRODUCER_HEARTBEAT_TIME: u16 = 0x1017;
/// 1018h identity object.
pub const IDENTITY: u16 = 0x1018;
/// 1029h error behaviour.
pub const ERROR_BEHAVIOUR: u16 = 0x1029;
/// Entries of the heartbeat consumer 1016h.
pub const HEARTBEAT_CONSUMERS: u8 = 4;
/// 1021h store EDS.
pub const STORE_EDS: u16 = 0x1021;
/// 1022h store format: how 1021h is stored (0 = the EDS as plain ASCII, CiA 301).
pub const STORE_FORMAT: u16 = 0x1022;
/// 1200h SDO server parameter.
pub const SDO_SERVER_PARAMETER: u16 = 0x1200;

const fn u32_const(name: &'static str, field: DeviceField) -> Var {
    Var::new(name, DataType::Unsigned32).access(Access::ReadOnly).default(DefaultValue::Device(field))
}

const fn text(name: &'static str, field: DeviceField) -> Var {
    Var::new(name, DataType::VisibleString).access(Access::Const).default(DefaultValue::Device(field))
}

const HIGHEST_SUB: &str = "Highest sub-index supported";

/// Entries of the error history 1003h.
pub const ERROR_HISTORY_LEN: u8 = 8;

const IDENTITY_SUBS: [(u8, Var); 5] = [
    (0, Var::new(HIGHEST_SUB, DataType::Unsigned8).access(Access::Const).default(DefaultValue::Unsigned(4))),
    (1, u32_const("Vendor-ID", DeviceField::VendorId)),
    (2, u32_const("Product code", DeviceField::ProductCode)),
    (3, u32_const("Revision number", DeviceField::RevisionNumber)),
    (4, u32_const("Serial number", DeviceField::SerialNumber)),
];

const SDO_SERVER_SUBS: [(u8, Var); 3] = [
    (0, Var::new(HIGHEST_SUB, DataType::Unsigned8).access(Access::Const).default(DefaultValue::Unsigned(2))),
    (
        1,
        Var::new("COB-ID client to server (rx)", DataType::Unsigned32)
            .access(Access::ReadOnly)
            .default(DefaultValue::NodeIdPlus(0x600)),
    ),
    (
        2,
        Var::new("COB-ID server to client (tx)", DataType::Unsigned32)
            .access(Access::ReadOnly)
            .default(DefaultValue::NodeIdPlus(0x580)),
    ),
];

/// Every communication object of the crate, before the feature selection.
const ALL_COMMUNICATION: [Object; 23] = [
    Object::var(DEVICE_TYPE, "Device type", u32_const("Device type", DeviceField::DeviceType)),
    Object::var(
        ERROR_REGISTER,
        "Error register",
        Var::new("Error register", DataType::Unsigned8).pdo(PdoMapping::Tpdo),
    ),
    Object::array_with_sub0(
        PRE_DEFINED_ERROR_FIELD,
        "Pre-defined error field",
        ERROR_HISTORY_LEN,
        Var::new("Number of errors", DataType::Unsigned8).access(Access::ReadWrite),
        &Var::new("Standard error field", DataType::Unsigned32),
    ),
    Object::var(
        COB_ID_SYNC,
        "COB-ID SYNC",
        Var::new("COB-ID SYNC", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(0x80)),
    ),
    Object::var(
        COMMUNICATION_CYCLE_PERIOD,
        "Communication cycle period",
        Var::new("Communication cycle period", DataType::Unsigned32).access(Access::ReadWrite),
    ),
    Object::var(
        SYNCHRONOUS_WINDOW_LENGTH,
        "Synchronous window length",
        Var::new("Synchronous window length", DataType::Unsigned32).access(Access::ReadWrite),
    ),
    Object::var(
        DEVICE_NAME,
        "Manufacturer device name",
        text("Manufacturer device name", DeviceField::DeviceName),
    ),
    Object::var(
        HARDWARE_VERSION,
        "Manufacturer hardware version",
        text("Manufacturer hardware version", DeviceField::HardwareVersion),
    ),
    Object::var(
        SOFTWARE_VERSION,
        "Manufacturer software version",
        text("Manufacturer software version", DeviceField::SoftwareVersion),
    ),
    Object::var(
        GUARD_TIME,
        "Guard time",
        Var::new("Guard time", DataType::Unsigned16).access(Access::ReadWrite),
    ),
    Object::var(
        LIFE_TIME_FACTOR,
        "Life time factor",
        Var::new("Life time factor", DataType::Unsigned8).access(Access::ReadWrite),
    ),
    Object::array(
        STORE_PARAMETERS,
        "Store parameters",
        4,
        &Var::new("Store parameters", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(1)),
    ),
    Object::array(
        RESTORE_DEFAULT_PARAMETERS,
        "Restore default parameters",
        4,
        &Var::new("Restore default parameters", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(1)),
    ),
    Object::var(
        COB_ID_EMCY,
        "COB-ID EMCY",
        Var::new("COB-ID EMCY", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .default(DefaultValue::NodeIdPlus(0x80)),
    ),
    Object::var(
        INHIBIT_TIME_EMCY,
        "Inhibit time EMCY",
        Var::new("Inhibit time EMCY", DataType::Unsigned16).access(Access::ReadWrite),
    ),
    Object::array(
        CONSUMER_HEARTBEAT_TIME,
        "Consumer heartbeat time",
        HEARTBEAT_CONSUMERS,
        &Var::new("Consumer heartbeat time", DataType::Unsigned32).access(Access::ReadWrite),
    ),
    Object::var(
        PRODUCER_HEARTBEAT_TIME,
        "Producer heartbeat time",
        Var::new("Producer heartbeat time", DataType::Unsigned16).access(Access::ReadWrite),
    ),
    Object::record(IDENTITY, "Identity object", &IDENTITY_SUBS),
    Object::var(
        SYNCHRONOUS_COUNTER_OVERFLOW,
        "Synchronous counter overflow value",
        Var::new("Synchronous counter overflow value", DataType::Unsigned8).access(Access::ReadWrite),
    ),
    Object::var(
        STORE_EDS,
        "Store EDS",
        Var::new("Store EDS", DataType::Domain)
            .access(Access::ReadOnly)
            .default(DefaultValue::Device(DeviceField::Eds)),
    ),
    // 1021h serves the EDS uncompressed, as ASCII text (read-only, as CiA 301 lists it).
    Object::var(
        STORE_FORMAT,
        "Store format",
        Var::new("Store format", DataType::Unsigned8).access(Access::ReadOnly),
    ),
    // Sub 1 communication errors; sub 2 the drive's Fault (CiA 402-2 §7.2: entering Fault is
    // a severe device-internal error), shown when a configuration overrides sub 0 to 2.
    Object::array_with_sub0(
        ERROR_BEHAVIOUR,
        "Error behaviour",
        2,
        Var::new("Number of error classes", DataType::Unsigned8)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(1)),
        &Var::new("Error class", DataType::Unsigned8).access(Access::ReadWrite),
    ),
    Object::record(SDO_SERVER_PARAMETER, "SDO server parameter", &SDO_SERVER_SUBS),
];

/// Objects a build leaves out: 1021h and its format 1022h without the `eds-object` feature.
const fn included(object: &Object) -> bool {
    !matches!(object.index, STORE_EDS | STORE_FORMAT) || cfg!(feature = "eds-object")
}

// Loop indices are bounded by the array lengths; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
const fn included_count(all: &[Object]) -> usize {
    let (mut i, mut n) = (0, 0);
    while i < all.len() {
        if included(&all[i]) {
            n += 1;
        }
        i += 1;
    }
    n
}

// Loop indices are bounded by the array lengths; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
const fn select<const N: usize>(all: &[Object]) -> [Object; N] {
    let mut out = [Object::var(0, "", Var::new("", DataType::Unsigned8)); N];
    let (mut i, mut j) = (0, 0);
    while i < all.len() {
        if included(&all[i]) && j < N {
            out[j] = all[i];
            j += 1;
        }
        i += 1;
    }
    out
}

const COMMUNICATION_COUNT: usize = included_count(&ALL_COMMUNICATION);

/// The CiA 301 objects of the communication profile area (1000h–1FFFh) this crate implements.
pub static COMMUNICATION: [Object; COMMUNICATION_COUNT] = layout(select(&ALL_COMMUNICATION));

/// The objects of `all` at `indices` (ascending), in that order.
// Loop indices are bounded by the array lengths; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
const fn pick<const N: usize>(all: &[Object], indices: [u16; N]) -> [Object; N] {
    let mut out = [Object::var(0, "", Var::new("", DataType::Unsigned8)); N];
    let (mut i, mut j) = (0, 0);
    while i < all.len() && j < N {
        if all[i].index == indices[j] {
            out[j] = all[i];
            j += 1;
        }
        i += 1;
    }
    assert!(j == N, "an index to pick is not a communication object");
    out
}

/// The communication objects of a bootloader ([`crate::bootloader`]): the identification a
/// master compares before and after an update (1000h, 1008h–100Ah, 1018h), the error register,
/// the heartbeat producer and the SDO server's parameters.
pub static BOOTLOADER_COMMUNICATION: [Object; 8] = layout(pick(
    &ALL_COMMUNICATION,
    [
        DEVICE_TYPE,
        ERROR_REGISTER,
        DEVICE_NAME,
        HARDWARE_VERSION,
        SOFTWARE_VERSION,
        PRODUCER_HEARTBEAT_TIME,
        IDENTITY,
        SDO_SERVER_PARAMETER,
    ],
));

/// The mapping of the pre-defined PDOs 1–4 (CiA 402): controlword / statusword, then the mode,
/// the pp target / position, the pv target / velocity.
const RPDO_PRESET_MAPPING: [[u32; 2]; 4] =
    [[0x6040_0010, 0], [0x6040_0010, 0x6060_0008], [0x6040_0010, 0x607A_0020], [0x6040_0010, 0x60FF_0020]];
const TPDO_PRESET_MAPPING: [[u32; 2]; 4] =
    [[0x6041_0010, 0], [0x6041_0010, 0x6061_0008], [0x6041_0010, 0x6064_0020], [0x6041_0010, 0x606C_0020]];

/// The power-on value of [`DefaultValue::PdoPreset`] entries of the PDO records (1400h–1BFFh)
/// on a node of `devices` logical devices (CiA 402 axes): PDOs 1–4 carry the pre-defined
/// identifiers (CiA 301 §7.3.5; TPDOs with bit 30, no RTR) and the CiA 402 mapping, TPDOs 1–2
/// event-driven and 3–4 on every SYNC. Axis n > 0 has PDOs 4n + 1 … 4n + 4 with the same
/// mapping shifted to its objects (n × 800h) and the same transmission types, invalid until the
/// master gives them identifiers (CiA 301 pre-defines those of PDOs 1–4 only). Higher PDOs
/// start invalid and empty.
pub fn pdo_preset(index: u16, sub: u8, devices: u8) -> DefaultValue {
    use crate::wire::cob_id::{BIT30, INVALID};
    // (receive, communication record, PDO number − 1)
    let (receive, communication, number) = match index {
        0x1400..=0x15FF => (true, true, index - 0x1400),
        0x1600..=0x17FF => (true, false, index - 0x1600),
        0x1800..=0x19FF => (false, true, index - 0x1800),
        0x1A00..=0x1BFF => (false, false, index - 0x1A00),
        _ => return DefaultValue::Zero,
    };
    let number = usize::from(number);
    let predefined = number < 4;
    // The axis whose preset the PDO carries, and which of its four.
    let (axis, nth) = (number / 4, number % 4);
    let preset = axis < usize::from(devices.max(1));
    let (base, unassigned, mappings) = if receive {
        (0x200, INVALID, &RPDO_PRESET_MAPPING)
    } else {
        (BIT30 | 0x180, INVALID | BIT30, &TPDO_PRESET_MAPPING)
    };
    let shift = (axis as u32 * u32::from(super::COPY_STRIDE)) << 16;
    let mapping = match mappings.get(nth) {
        Some(m) if preset => m.map(|entry| if entry == 0 { 0 } else { entry + shift }),
        _ => [0, 0],
    };
    match (communication, sub) {
        (true, 1) if predefined => DefaultValue::NodeIdPlus(base + 0x100 * number as u32),
        (true, 1) => DefaultValue::Unsigned(u64::from(unassigned)),
        (true, 2) if preset && nth >= 2 => DefaultValue::Unsigned(1),
        (true, 2) => DefaultValue::Unsigned(255),
        (false, 0) => DefaultValue::Unsigned(mapping.iter().filter(|m| **m != 0).count() as u64),
        (false, s) => DefaultValue::Unsigned(u64::from(
            mapping.get(usize::from(s).wrapping_sub(1)).copied().unwrap_or(0),
        )),
        _ => DefaultValue::Zero,
    }
}

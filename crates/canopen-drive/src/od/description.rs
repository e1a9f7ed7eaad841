//! What the two device descriptions state, taken once from the dictionary and the drive: the
//! EDS ([`super::eds`], CiA 306) and the XDD ([`super::xdd`], CiA 311) differ in syntax only.
//!
//! Here are the facts of `[DeviceInfo]` (PDO counts and mapping granularity from the
//! dictionary, bit rates, LSS and the store commands from the drive's [`Capabilities`]), the
//! objects a description lists and the sub-indices it shows of each, with their names and
//! power-on values, and the text of values and limits (CiA 306 number formats, which CiA 311
//! attributes take as well).

use core::fmt::{self, Display, Write};

use super::eds::Capabilities;
use super::standard::{RESTORE_DEFAULT_PARAMETERS, STORE_PARAMETERS};
use super::{Access, Bound, DataType, DefaultValue, DeviceField, Dictionary, Kind, Object, Var};

/// The bit rates in kbit/s a description has a key or a value for (CiA 306 `BaudRate_n`, CiA 311
/// `supportedBaudRate`), ascending.
pub(super) const BIT_RATES: [u16; 8] = [10, 20, 50, 125, 250, 500, 800, 1000];

/// The facts of `[DeviceInfo]` (CiA 306) and of the XDD's network management (CiA 311).
pub(super) struct Facts {
    /// RPDO communication records (1400h–15FFh) the bus sees.
    pub rpdos: usize,
    /// TPDO communication records (1800h–19FFh) the bus sees.
    pub tpdos: usize,
    /// PDO mapping granularity in bits: 1 when a mapping record can be written (the crate's
    /// PDO mapping takes single bits: a BOOLEAN, dummy 0001h), 0 when no mapping can change.
    pub granularity: u8,
    /// What the drive around the dictionary can do.
    pub capabilities: Capabilities,
}

impl Facts {
    /// The facts of `od` in a drive that can do what `capabilities` say.
    pub fn of<const B: usize>(od: &Dictionary<B>, capabilities: &Capabilities) -> Self {
        let records =
            |range: core::ops::RangeInclusive<u16>| listed(od).filter(|o| range.contains(&o.index)).count();
        let writable_mapping = listed(od)
            .filter(|o| matches!(o.index, 0x1600..=0x17FF | 0x1A00..=0x1BFF))
            .any(|o| o.sub(1).is_some_and(|(var, _)| od.describe(o.index, 1, var).access.writable()));
        Facts {
            rpdos: records(0x1400..=0x15FF),
            tpdos: records(0x1800..=0x19FF),
            granularity: u8::from(writable_mapping),
            capabilities: *capabilities,
        }
    }

    /// Whether the device runs at `kbit` kbit/s.
    pub fn runs_at(&self, kbit: u16) -> bool {
        self.capabilities.bit_rates.iter().any(|rate| rate.kbit_per_s() == Some(kbit))
    }

    /// Whether a mapping may use the dummy entry of data type `index` (0001h–0007h): every one
    /// of them while mappings can change (the crate's mapping takes each at its type's size).
    pub fn dummy(&self, index: u16) -> bool {
        self.granularity != 0 && (1..=7).contains(&index)
    }
}

/// The object lists of a description (CiA 306 §4.5; CiA 311 counts them).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum List {
    /// 1000h, 1001h, 1018h.
    Mandatory,
    /// The other objects of the communication and the device profile areas.
    Optional,
    /// 2000h–5FFFh.
    Manufacturer,
}

impl List {
    /// The three lists, in the order of the description.
    pub const ALL: [List; 3] = [List::Mandatory, List::Optional, List::Manufacturer];

    /// The list `object` belongs to.
    pub fn of(object: &Object) -> List {
        match object.index {
            0x1000 | 0x1001 | 0x1018 => List::Mandatory,
            0x2000..=0x5FFF => List::Manufacturer,
            _ => List::Optional,
        }
    }

    /// The objects of `od` in this list, in index order.
    pub fn objects<const B: usize>(self, od: &Dictionary<B>) -> impl Iterator<Item = Object> + '_ {
        listed(od).filter(move |o| List::of(o) == self)
    }
}

/// The objects of `od` a description lists (those the bus sees), in index order.
pub(super) fn listed<const B: usize>(od: &Dictionary<B>) -> impl Iterator<Item = Object> + '_ {
    od.objects().filter(|o| !od.is_absent(o.index))
}

/// Object code (CiA 301 §7.4.3): 7 VAR, 8 ARRAY, 9 RECORD.
pub(super) fn object_code(object: &Object) -> u8 {
    match object.kind {
        Kind::Var(_) => 7,
        Kind::Array { .. } => 8,
        Kind::Record(_) => 9,
    }
}

/// One entry as a description shows it.
pub(super) struct Sub<'a> {
    /// Sub-index.
    pub sub: u8,
    /// Its description (the firmware's override, if any).
    pub var: &'a Var,
    /// Its power-on value: what the node reads at start-up.
    pub default: DefaultValue,
    /// Its name.
    pub name: Name<'a>,
}

/// The name of an entry: an object's (a VAR), a sub-index's, or an ARRAY element's with its
/// sub-index appended.
#[derive(Clone, Copy)]
pub(super) enum Name<'a> {
    /// An object's name with its instance number (e.g. "RPDO communication parameter 3"), and
    /// for a copy of a further logical device the device's number (e.g. "Controlword (axis 1)":
    /// a master that finds objects by name tells the axes apart).
    Object(&'a Object, u8),
    /// A sub-index's own name.
    Plain(&'static str),
    /// An ARRAY element: the element's name and the sub-index.
    Element(&'static str, u8),
}

impl Display for Name<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Name::Object(object, copy) => {
                match object.number {
                    0 => f.write_str(object.name())?,
                    n => write!(f, "{} {n}", object.name())?,
                }
                match copy {
                    0 => Ok(()),
                    k => write!(f, " (axis {k})"),
                }
            }
            Name::Plain(name) => f.write_str(name),
            Name::Element(name, sub) => write!(f, "{name} {sub}"),
        }
    }
}

/// The sub-indices of ARRAY or RECORD `object` a description shows, sub 0 included: those up to
/// the count an override or the configuration gives.
pub(super) fn sub_count<const B: usize>(od: &Dictionary<B>, object: &Object) -> usize {
    match &object.kind {
        Kind::Var(_) => 1,
        Kind::Array { sub0, len, .. } => 1 + array_len(od, object, sub0, *len),
        Kind::Record(subs) => subs.iter().filter(|(sub, _)| !od.hidden(object, *sub)).count(),
    }
}

/// The elements an ARRAY shows.
fn array_len<const B: usize>(od: &Dictionary<B>, object: &Object, sub0: &Var, len: u8) -> usize {
    (1..=od.array_len(object.index, sub0, len)).take_while(|sub| !od.hidden(object, *sub)).count()
}

/// Calls `each` with every entry of `object` a description shows, in sub-index order (a VAR:
/// its one entry, named after the object).
pub(super) fn for_each_sub<'a, const B: usize>(
    od: &Dictionary<B>,
    capabilities: &Capabilities,
    object: &'a Object,
    mut each: impl FnMut(Sub<'a>) -> fmt::Result,
) -> fmt::Result {
    let index = object.index;
    let entry = |sub: u8, var: &'a Var, name: Name<'a>| {
        let var = od.describe(index, sub, var);
        Sub { sub, var, default: power_on_value(od, capabilities, index, sub, var), name }
    };
    match &object.kind {
        Kind::Var(var) => each(entry(0, var, Name::Object(object, od.copy_of(index)))),
        Kind::Array { sub0, element, len } => {
            each(entry(0, sub0, Name::Plain(od.describe(index, 0, sub0).name())))?;
            let count = u8::try_from(array_len(od, object, sub0, *len)).unwrap_or(u8::MAX);
            for sub in 1..=count {
                each(entry(sub, element, Name::Element(od.describe(index, sub, element).name(), sub)))?;
            }
            Ok(())
        }
        Kind::Record(subs) => {
            for (sub, var) in subs.iter().filter(|(sub, _)| !od.hidden(object, *sub)) {
                each(entry(*sub, var, Name::Plain(od.describe(index, *sub, var).name())))?;
            }
            Ok(())
        }
    }
}

/// The value entry `index`/`sub` reads at start-up: its default, except for the store commands
/// 1010h/1011h subs 1–4, which read whether the drive stores that group.
fn power_on_value<const B: usize>(
    od: &Dictionary<B>,
    capabilities: &Capabilities,
    index: u16,
    sub: u8,
    var: &Var,
) -> DefaultValue {
    match (index, sub) {
        (STORE_PARAMETERS | RESTORE_DEFAULT_PARAMETERS, 1..=4) => {
            DefaultValue::Unsigned(u64::from(capabilities.store_commands >> sub & 1))
        }
        _ => od.default_of(index, sub, var),
    }
}

/// The text of a power-on value (CiA 306 `DefaultValue`, CiA 311 `defaultValue`), or `None` where
/// a description states none (a DOMAIN).
pub(super) fn value_text<'a, const B: usize>(
    od: &'a Dictionary<B>,
    var: &Var,
    default: DefaultValue,
) -> Option<ValueText<'a>> {
    if var.data_type == DataType::Domain {
        return None;
    }
    let device = od.device();
    // Numbers are shown in the entry's own width (a signed default as two's complement would
    // otherwise print 16 hex digits).
    let number = |value: u64| match var.data_type.fixed_size() {
        Some(n) if n < 8 => value & ((1u64 << (8 * n)) - 1),
        _ => value,
    };
    let text = match default {
        DefaultValue::Zero => match var.data_type {
            // An empty string: the key with no text.
            DataType::VisibleString | DataType::OctetString | DataType::UnicodeString => ValueText::Text(""),
            DataType::Real32 | DataType::Real64 => ValueText::Real(0.0),
            _ => ValueText::Hex(0),
        },
        DefaultValue::Unsigned(v) => ValueText::Hex(number(v)),
        DefaultValue::Signed(v) => ValueText::Signed(v),
        DefaultValue::Real(v) => ValueText::Real(v),
        DefaultValue::Text(s) => ValueText::Text(s),
        DefaultValue::Bytes(b) => ValueText::Bytes(b),
        DefaultValue::NodeIdPlus(base) => ValueText::NodeId(base),
        // Resolved by `default_of`.
        DefaultValue::PdoPreset => ValueText::Hex(0),
        DefaultValue::Device(field) => match field {
            DeviceField::DeviceType => ValueText::Hex32(od.device_type()),
            DeviceField::LogicalDeviceType => ValueText::Hex32(device.device_type),
            DeviceField::VendorId => ValueText::Hex32(device.vendor_id),
            DeviceField::ProductCode => ValueText::Hex32(device.product_code),
            DeviceField::RevisionNumber => ValueText::Hex32(device.revision_number),
            DeviceField::SerialNumber => ValueText::Hex32(device.serial_number),
            DeviceField::DriveModes => ValueText::Hex32(device.drive_modes),
            DeviceField::DeviceName => ValueText::Text(device.device_name),
            DeviceField::HardwareVersion => ValueText::Text(device.hardware_version),
            DeviceField::SoftwareVersion => ValueText::Text(device.software_version),
            DeviceField::Eds => return None,
            // Resolved by `default_of`.
            DeviceField::HomingMethodCount | DeviceField::HomingMethods => ValueText::Hex32(0),
        },
    };
    Some(text)
}

/// A value in the number formats of CiA 306 §4.6 (hex with `0x`, decimal without leading zeros).
#[derive(Clone, Copy)]
pub(super) enum ValueText<'a> {
    /// `0x` and the hex digits, no leading zeros.
    Hex(u64),
    /// `0x` and eight hex digits (identity and device fields).
    Hex32(u32),
    /// Decimal, with its sign.
    Signed(i64),
    /// A REAL32/REAL64 value.
    Real(f64),
    /// Text as it is.
    Text(&'a str),
    /// Hex digits, two per byte, no `0x` (OCTET_STRING).
    Bytes(&'a [u8]),
    /// `$NODEID+0x` and the hex digits of the value added to the node-ID.
    NodeId(u32),
}

impl Display for ValueText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ValueText::Hex(v) => write!(f, "0x{v:X}"),
            ValueText::Hex32(v) => write!(f, "0x{v:08X}"),
            ValueText::Signed(v) => write!(f, "{v}"),
            ValueText::Real(v) => write!(f, "{v}"),
            ValueText::Text(s) => f.write_str(s),
            ValueText::Bytes(bytes) => bytes.iter().try_for_each(|byte| write!(f, "{byte:02X}")),
            ValueText::NodeId(base) => write!(f, "$NODEID+0x{base:X}"),
        }
    }
}

/// The text of a limit (CiA 306 `LowLimit`/`HighLimit`, CiA 311 `lowLimit`/`highLimit`), or
/// `None` for no limit.
pub(super) fn limit_text(bound: Bound) -> Option<ValueText<'static>> {
    match bound {
        Bound::None => None,
        Bound::Signed(v) => Some(ValueText::Signed(v)),
        Bound::Unsigned(v) => Some(ValueText::Hex(v)),
        Bound::Real(v) => Some(ValueText::Real(v)),
    }
}

/// Whether the bus may read or write the entry, without the PDO directions: CiA 306 and 311
/// share `const`, `ro`, `wo` and `rw`.
pub(super) fn access_text(access: Access) -> &'static str {
    match access {
        Access::Const => "const",
        Access::ReadOnly => "ro",
        Access::WriteOnly => "wo",
        Access::ReadWrite => "rw",
    }
}

/// Text written through a character filter: `T` displayed, each character replaced by what
/// `map` writes for it.
pub(super) struct Filtered<T>(pub T, pub fn(char, &mut fmt::Formatter<'_>) -> fmt::Result);

impl<T: Display> Display for Filtered<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        struct Through<'a, 'b>(&'a mut fmt::Formatter<'b>, fn(char, &mut fmt::Formatter<'_>) -> fmt::Result);
        impl Write for Through<'_, '_> {
            fn write_str(&mut self, s: &str) -> fmt::Result {
                s.chars().try_for_each(|c| (self.1)(c, self.0))
            }
        }
        write!(Through(f, self.1), "{}", self.0)
    }
}

/// Counts the bytes a writer produces (to size a buffer for 1021h).
pub(super) fn count(write: impl FnOnce(&mut dyn Write) -> fmt::Result) -> usize {
    struct Counter(usize);
    impl Write for Counter {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            self.0 += s.len();
            Ok(())
        }
    }
    let mut counter = Counter(0);
    // Writing into a counter cannot fail.
    let _ = write(&mut counter);
    counter.0
}

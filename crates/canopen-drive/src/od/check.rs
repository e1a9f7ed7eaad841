//! The checks a table of objects must pass, and the error that names what is wrong.
//!
//! Every check here is a `const fn`: a firmware can run them on its own tables when they are
//! compiled ([`check_table`], [`check_manufacturer_table`], [`join`]), and the dictionary runs
//! the same ones when a drive is built, so a table that compiles with the check cannot fail at
//! start-up for a reason the check knows.

use core::fmt;

use super::entry::{Bound, DataType, DefaultValue, Kind, Object, Var};

/// The index range of manufacturer objects (CiA 301 §7.4.1).
pub const MANUFACTURER_AREA: core::ops::RangeInclusive<u16> = 0x2000..=0x5FFF;

/// Why a configuration or a set of tables cannot form a dictionary. Its `Display` names the
/// object (indices in hexadecimal, as CiA 301 writes them) and what is wrong with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConfigError {
    /// A node-ID outside 1..=127 (and not FFh, "unconfigured").
    InvalidNodeId,
    /// The PDO table ([`Config::pdo_objects`](crate::Config::pdo_objects)) does not describe
    /// as many PDOs as the drive type holds.
    PdoCount {
        /// Receive and transmit PDOs of the drive type (`RPDOS`, `TPDOS`).
        drive: (usize, usize),
        /// Receive and transmit PDOs the table describes.
        table: (usize, usize),
    },
    /// More than [`MAX_TABLES`](super::MAX_TABLES) tables.
    TooManyTables,
    /// Indices not ascending inside a table or across consecutive tables.
    NotSorted {
        /// The first index out of order.
        index: u16,
    },
    /// The same index twice, in one table or in two.
    DuplicateIndex {
        /// The index.
        index: u16,
    },
    /// A manufacturer object ([`Config::manufacturer_objects`](crate::Config::manufacturer_objects))
    /// outside 2000h–5FFFh.
    NotManufacturer {
        /// The object's index.
        index: u16,
    },
    /// A table was not passed through [`layout`](super::layout).
    NotLaidOut {
        /// The first object with a wrong offset.
        index: u16,
    },
    /// The value store is smaller than the tables need.
    StorageTooSmall {
        /// Bytes needed (the `OD_BYTES` that would do).
        needed: usize,
    },
    /// A string or DOMAIN entry whose storage exceeds 65 535 bytes.
    EntryTooLarge {
        /// Index of the entry.
        index: u16,
        /// Sub-index of the entry.
        sub: u8,
    },
    /// A RECORD whose sub-indices are not strictly ascending.
    SubsNotSorted {
        /// Index of the record.
        index: u16,
        /// The first sub-index out of order.
        sub: u8,
    },
    /// A default that the entry cannot hold: a number outside its data type's range, text or
    /// bytes for a number (or a number for text), a text longer than its capacity.
    DefaultType {
        /// Index of the entry.
        index: u16,
        /// Sub-index of the entry.
        sub: u8,
    },
    /// A default outside the entry's own limits (the drive would serve a value that a write
    /// of the same value is refused).
    DefaultOutsideLimits {
        /// Index of the entry.
        index: u16,
        /// Sub-index of the entry.
        sub: u8,
    },
    /// Limits of another kind than the entry's type (a signed limit of an unsigned entry,
    /// limits of a string), or a low limit above the high one.
    BadLimits {
        /// Index of the entry.
        index: u16,
        /// Sub-index of the entry.
        sub: u8,
    },
    /// An override ([`DefaultOverride`](super::DefaultOverride),
    /// [`EntryOverride`](super::EntryOverride)) of an entry the tables do not have.
    NoSuchEntry {
        /// Index of the entry.
        index: u16,
        /// Sub-index of the entry.
        sub: u8,
    },
    /// 6502h ([`DeviceInfo::drive_modes`](super::DeviceInfo)) lists CiA 402 modes this build
    /// does not run (their cargo features are off,
    /// [`crate::cia402::registry::IMPLEMENTED_MODES`]).
    ModesNotBuilt {
        /// The 6502h bits of the missing modes.
        modes: u32,
    },
    /// A table attached with more copies than [`MAX_COPIES`](super::MAX_COPIES) (or none), or
    /// with copies but wider than one [`COPY_STRIDE`](super::COPY_STRIDE) or reaching beyond
    /// FFFFh; or a drive type with more axes than that, or none.
    BadCopies {
        /// The table's first index.
        index: u16,
    },
    /// An [`EntryOverride`](super::EntryOverride) that changes the size or the storage of its
    /// entry.
    EntrySize {
        /// Index of the entry.
        index: u16,
        /// Sub-index of the entry.
        sub: u8,
    },
    /// [`join`] into a table whose length is not the number of objects joined.
    TableLength {
        /// The length of the table joined into.
        declared: usize,
        /// The objects of the tables joined.
        objects: usize,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ConfigError::*;
        match *self {
            InvalidNodeId => f.write_str("the node-ID is outside 1–127 (or FFh, unconfigured)"),
            PdoCount { drive, table } => write!(
                f,
                "the PDO table describes {} + {} PDOs, the drive type holds {} + {}",
                table.0, table.1, drive.0, drive.1
            ),
            TooManyTables => write!(f, "more than {} tables", super::MAX_TABLES),
            NotSorted { index } => write!(f, "object {index:04X}h: indices not in ascending order"),
            DuplicateIndex { index } => write!(f, "object {index:04X}h: described twice"),
            NotManufacturer { index } => {
                write!(f, "object {index:04X}h: a manufacturer object outside 2000h–5FFFh")
            }
            NotLaidOut { index } => write!(f, "object {index:04X}h: the table was not laid out (od::layout)"),
            StorageTooSmall { needed } => {
                write!(f, "the value store is too small: the tables need {needed} bytes")
            }
            EntryTooLarge { index, sub } => {
                write!(f, "object {index:04X}h sub {sub}: more than 65 535 bytes of storage")
            }
            SubsNotSorted { index, sub } => {
                write!(f, "object {index:04X}h sub {sub}: sub-indices not in ascending order")
            }
            DefaultType { index, sub } => {
                write!(f, "object {index:04X}h sub {sub}: the default does not fit the data type")
            }
            DefaultOutsideLimits { index, sub } => {
                write!(f, "object {index:04X}h sub {sub}: the default is outside the limits")
            }
            BadLimits { index, sub } => write!(
                f,
                "object {index:04X}h sub {sub}: limits not of the data type's kind, or low above high"
            ),
            NoSuchEntry { index, sub } => {
                write!(f, "object {index:04X}h sub {sub}: overridden but not in the tables")
            }
            ModesNotBuilt { modes } => {
                write!(
                    f,
                    "6502h lists modes this build does not run (bits {modes:#010X}): enable their features"
                )
            }
            BadCopies { index } => {
                write!(f, "object {index:04X}h: the table cannot be copied for that many axes")
            }
            EntrySize { index, sub } => {
                write!(f, "object {index:04X}h sub {sub}: the override changes the entry's size or storage")
            }
            TableLength { declared, objects } => {
                write!(f, "the joined tables hold {objects} objects, the table {declared}")
            }
        }
    }
}

impl core::error::Error for ConfigError {}

/// What is wrong with one entry's description, if anything.
#[derive(Clone, Copy)]
pub(super) enum VarProblem {
    TooLarge,
    DefaultType,
    DefaultOutsideLimits,
    BadLimits,
}

impl VarProblem {
    pub(super) const fn at(self, index: u16, sub: u8) -> ConfigError {
        match self {
            VarProblem::TooLarge => ConfigError::EntryTooLarge { index, sub },
            VarProblem::DefaultType => ConfigError::DefaultType { index, sub },
            VarProblem::DefaultOutsideLimits => ConfigError::DefaultOutsideLimits { index, sub },
            VarProblem::BadLimits => ConfigError::BadLimits { index, sub },
        }
    }
}

/// A numeric value as the checks compare it.
#[derive(Clone, Copy)]
enum Number {
    Int(i128),
    Real(f64),
}

/// How the values of a data type are compared.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Class {
    Unsigned,
    Signed,
    Real,
    /// TIME_OF_DAY, TIME_DIFFERENCE: fixed size, no arithmetic meaning here.
    Other,
    /// Strings and DOMAIN.
    Bytes,
}

const fn class(ty: DataType) -> Class {
    if ty.is_unsigned() {
        Class::Unsigned
    } else if ty.is_signed() {
        Class::Signed
    } else if matches!(ty, DataType::Real32 | DataType::Real64) {
        Class::Real
    } else if ty.is_variable() {
        Class::Bytes
    } else {
        Class::Other
    }
}

/// The range of an integer type (BOOLEAN: 0–1).
const fn int_range(ty: DataType) -> (i128, i128) {
    let bits = match ty.fixed_size() {
        Some(n) => 8 * n as u32,
        None => 0,
    };
    match class(ty) {
        _ if matches!(ty, DataType::Boolean) => (0, 1),
        Class::Unsigned | Class::Other => (0, (1i128 << bits) - 1),
        Class::Signed => (-(1i128 << (bits - 1)), (1i128 << (bits - 1)) - 1),
        Class::Real | Class::Bytes => (0, 0),
    }
}

/// A limit as a number, `None` for [`Bound::None`]; `Err` when its kind is not the type's.
const fn bound(ty: DataType, bound: Bound) -> Result<Option<Number>, VarProblem> {
    match (class(ty), bound) {
        (_, Bound::None) => Ok(None),
        (Class::Unsigned, Bound::Unsigned(v)) => Ok(Some(Number::Int(v as i128))),
        (Class::Signed, Bound::Signed(v)) => Ok(Some(Number::Int(v as i128))),
        (Class::Real, Bound::Real(v)) if !v.is_nan() => Ok(Some(Number::Real(v))),
        _ => Err(VarProblem::BadLimits),
    }
}

/// `a <= b` for two numbers of one kind (different kinds cannot meet: each comes from the
/// entry's own class).
const fn at_most(a: Number, b: Number) -> bool {
    match (a, b) {
        (Number::Int(a), Number::Int(b)) => a <= b,
        (Number::Real(a), Number::Real(b)) => a <= b,
        _ => true,
    }
}

/// Checks one entry: its storage, its limits against its type, its default against its type
/// and its limits. Defaults the drive resolves at start-up (`NodeIdPlus`, `Device`,
/// `PdoPreset`) are checked for their kind only.
pub(super) const fn check_var(var: &Var) -> Result<(), VarProblem> {
    let ty = var.data_type;
    if ty.is_variable() && var.storage_size() > u16::MAX as usize {
        return Err(VarProblem::TooLarge);
    }
    let low = match bound(ty, var.low()) {
        Ok(b) => b,
        Err(e) => return Err(e),
    };
    let high = match bound(ty, var.high()) {
        Ok(b) => b,
        Err(e) => return Err(e),
    };
    if let (Some(l), Some(h)) = (low, high) {
        if !at_most(l, h) {
            return Err(VarProblem::BadLimits);
        }
    }
    let (min, max) = int_range(ty);
    let value = match (class(ty), var.default) {
        (Class::Bytes, DefaultValue::Zero) => None,
        (Class::Bytes, DefaultValue::Text(t)) => {
            if t.len() > var.capacity as usize && !var.is_fixed() {
                return Err(VarProblem::DefaultType);
            }
            None
        }
        (Class::Bytes, DefaultValue::Bytes(b)) => {
            if b.len() > var.capacity as usize && !var.is_fixed() {
                return Err(VarProblem::DefaultType);
            }
            None
        }
        (Class::Bytes, DefaultValue::Device(_)) => None,
        (Class::Bytes, _) => return Err(VarProblem::DefaultType),
        (_, DefaultValue::Text(_) | DefaultValue::Bytes(_)) => return Err(VarProblem::DefaultType),
        (_, DefaultValue::Device(_) | DefaultValue::PdoPreset) => None,
        (Class::Unsigned | Class::Other, DefaultValue::NodeIdPlus(_)) => None,
        (_, DefaultValue::NodeIdPlus(_)) => return Err(VarProblem::DefaultType),
        (Class::Real, DefaultValue::Zero) => Some(Number::Real(0.0)),
        (Class::Real, DefaultValue::Real(v)) => Some(Number::Real(v)),
        (Class::Real, _) => return Err(VarProblem::DefaultType),
        (_, DefaultValue::Real(_)) => return Err(VarProblem::DefaultType),
        (_, DefaultValue::Zero) => Some(Number::Int(0)),
        (_, DefaultValue::Unsigned(v)) => Some(Number::Int(v as i128)),
        (_, DefaultValue::Signed(v)) => Some(Number::Int(v as i128)),
    };
    let Some(value) = value else {
        return Ok(());
    };
    if let Number::Int(v) = value {
        if v < min || v > max {
            return Err(VarProblem::DefaultType);
        }
    }
    if let Some(l) = low {
        if !at_most(l, value) {
            return Err(VarProblem::DefaultOutsideLimits);
        }
    }
    if let Some(h) = high {
        if !at_most(value, h) {
            return Err(VarProblem::DefaultOutsideLimits);
        }
    }
    Ok(())
}

/// Checks one object's entries ([`check_table`] without the order and the layout).
// The loop index is bounded by the length; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
pub(super) const fn check_object(object: &Object) -> Result<(), ConfigError> {
    let index = object.index;
    match &object.kind {
        Kind::Var(var) => match check_var(var) {
            Ok(()) => Ok(()),
            Err(e) => Err(e.at(index, 0)),
        },
        Kind::Array { sub0, element, .. } => {
            if let Err(e) = check_var(sub0) {
                return Err(e.at(index, 0));
            }
            match check_var(element) {
                Ok(()) => Ok(()),
                Err(e) => Err(e.at(index, 1)),
            }
        }
        Kind::Record(subs) => {
            let mut i = 0;
            while i < subs.len() {
                let (sub, var) = &subs[i];
                if i > 0 && subs[i - 1].0 >= *sub {
                    return Err(ConfigError::SubsNotSorted { index, sub: *sub });
                }
                if let Err(e) = check_var(var) {
                    return Err(e.at(index, *sub));
                }
                i += 1;
            }
            Ok(())
        }
    }
}

/// Checks a table as the dictionary will when a drive is built with it: indices strictly
/// ascending, laid out by [`layout`](super::layout), and each entry's description consistent
/// (storage, limits of the entry's type, a default that fits the type and lies within the
/// limits). A `const fn`, so a table can be checked when it is compiled:
///
/// ```
/// use canopen_drive::od::{self, layout, Access, DataType, DefaultValue, Object, Var};
/// static VENDOR: [Object; 1] = layout([Object::var(0x2000, "Pole pairs",
///     Var::new("Pole pairs", DataType::Unsigned8).access(Access::ReadWrite)
///         .default(DefaultValue::Unsigned(4)).limits_unsigned(1, 32))]);
/// // Fails the build (not the firmware) when the table is wrong.
/// const _: () = assert!(od::check_manufacturer_table(&VENDOR).is_ok());
/// ```
///
/// At run time the error says what is wrong (`Display`).
// The loop index is bounded by the length; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
pub const fn check_table(objects: &[Object]) -> Result<(), ConfigError> {
    let mut offset = 0usize;
    let mut i = 0;
    while i < objects.len() {
        let object = &objects[i];
        if i > 0 {
            let previous = objects[i - 1].index;
            if previous == object.index {
                return Err(ConfigError::DuplicateIndex { index: object.index });
            }
            if previous > object.index {
                return Err(ConfigError::NotSorted { index: object.index });
            }
        }
        if object.base as usize != offset {
            return Err(ConfigError::NotLaidOut { index: object.index });
        }
        if let Err(e) = check_object(object) {
            return Err(e);
        }
        offset += object.storage_size();
        i += 1;
    }
    Ok(())
}

/// [`check_table`] for a table of manufacturer objects
/// ([`Config::manufacturer_objects`](crate::Config::manufacturer_objects)): also every index
/// inside 2000h–5FFFh ([`ConfigError::NotManufacturer`]).
// The loop index is bounded by the length; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
pub const fn check_manufacturer_table(objects: &[Object]) -> Result<(), ConfigError> {
    let mut i = 0;
    while i < objects.len() {
        let index = objects[i].index;
        if index < *MANUFACTURER_AREA.start() || index > *MANUFACTURER_AREA.end() {
            return Err(ConfigError::NotManufacturer { index });
        }
        i += 1;
    }
    check_table(objects)
}

/// Joins tables into one, in index order, laid out: a firmware's hand-written objects and the
/// ones `canopen-drive-build` generated from an EDS, as the one table of
/// [`Config::manufacturer_objects`](crate::Config::manufacturer_objects). The tables may
/// interleave; each must be in ascending order, no index may appear twice, and `N` must be the
/// number of their objects. The result passes [`check_table`] (it is checked before it is
/// returned). A `const fn`, for a `static`:
///
/// ```
/// use canopen_drive::od::{self, layout, Access, DataType, Object, Var};
/// static HAND: [Object; 1] = layout([Object::var(0x2000, "Mode",
///     Var::new("Mode", DataType::Unsigned8).access(Access::ReadWrite))]);
/// // E.g. `include!(concat!(env!("OUT_DIR"), "/vendor_objects.rs"))` in a firmware.
/// static GENERATED: [Object; 2] = layout([
///     Object::var(0x2001, "Gain", Var::new("Gain", DataType::Unsigned16).access(Access::ReadWrite)),
///     Object::var(0x3000, "Offset", Var::new("Offset", DataType::Integer32).access(Access::ReadWrite)),
/// ]);
/// static VENDOR: [Object; 3] = match od::join(&[&HAND, &GENERATED]) {
///     Ok(table) => table,
///     Err(_) => panic!("the vendor tables do not join (run od::join at run time for the reason)"),
/// };
/// assert_eq!(VENDOR.map(|o| o.index), [0x2000, 0x2001, 0x3000]);
/// ```
// The loop indices are bounded by the lengths; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
pub const fn join<const N: usize>(tables: &[&[Object]]) -> Result<[Object; N], ConfigError> {
    let mut objects = 0;
    let mut t = 0;
    while t < tables.len() {
        objects += tables[t].len();
        t += 1;
    }
    if objects != N {
        return Err(ConfigError::TableLength { declared: N, objects });
    }
    const FILLER: Object = Object::var(0, "", Var::new("", DataType::Unsigned8));
    let mut out = [FILLER; N];
    // Where each table's next object is (at most MAX_JOINED tables).
    let mut next = [0usize; MAX_JOINED];
    if tables.len() > MAX_JOINED {
        return Err(ConfigError::TooManyTables);
    }
    let mut n = 0;
    while n < N {
        // The table whose next object has the lowest index.
        let mut pick = usize::MAX;
        let mut t = 0;
        while t < tables.len() {
            if next[t] < tables[t].len() {
                let candidate = &tables[t][next[t]];
                if next[t] > 0 && tables[t][next[t] - 1].index >= candidate.index {
                    return Err(if tables[t][next[t] - 1].index == candidate.index {
                        ConfigError::DuplicateIndex { index: candidate.index }
                    } else {
                        ConfigError::NotSorted { index: candidate.index }
                    });
                }
                if pick == usize::MAX || candidate.index < tables[pick][next[pick]].index {
                    pick = t;
                } else if candidate.index == tables[pick][next[pick]].index {
                    return Err(ConfigError::DuplicateIndex { index: candidate.index });
                }
            }
            t += 1;
        }
        if pick == usize::MAX {
            break;
        }
        out[n] = tables[pick][next[pick]];
        next[pick] += 1;
        n += 1;
    }
    let out = super::entry::layout(out);
    match check_table(&out) {
        Ok(()) => Ok(out),
        Err(e) => Err(e),
    }
}

/// Most tables [`join`] takes at once.
pub const MAX_JOINED: usize = 8;

//! The object dictionary (CiA 301 §7.4).
//!
//! The dictionary is a list of `static` tables of [`Object`]s (the description) plus one byte
//! store owned by the dictionary (the values). Every value lives little-endian in the store,
//! exactly as it travels in an SDO or a PDO, so reads, writes, PDO mapping and parameter storage
//! are all byte copies. Constants and identity fields take no RAM: they are read from the
//! description and the [`DeviceInfo`].
//!
//! Lookup is a binary search per table (tables cover disjoint, ascending index ranges), then a
//! direct or short linear step to the sub-index: O(log n), no allocation.
//!
//! Access by the device itself ([`Dictionary::get`], [`Dictionary::set`]) bypasses SDO access
//! rights; access from the bus goes through [`Dictionary::check_write`] and friends, which answer
//! with the exact [`AbortCode`].

mod check;
mod description;
pub mod eds;
mod entry;
mod first_level;
mod overrides;
pub mod persist;
pub mod standard;
pub mod xdd;

pub use crate::wire::AbortCode;
pub use check::{check_manufacturer_table, check_table, join, ConfigError, MANUFACTURER_AREA, MAX_JOINED};
pub use entry::{
    layout, owned, Access, Bound, DataType, DefaultValue, DeviceField, Kind, Object, Owner, PdoMapping, Var,
    WriteRule,
};
pub(crate) use first_level::{first_level, FirstLevel};
pub use overrides::EntryOverride;

use core::ops::RangeInclusive;

/// Most tables one dictionary joins (communication, PDOs, program download, manufacturer,
/// device profile, the firmware's further device-profile objects).
pub const MAX_TABLES: usize = 6;

/// 1000h's additional information (bits 16–31) on a node of several logical devices
/// (CiA 301; the CiA 402-2 text writes 0FFFh, which reads as a slip for CiA 301's FFFFh).
pub const MULTI_DEVICE: u32 = 0xFFFF_0000;

/// Distance between two copies of a table attached for several logical devices
/// ([`Dictionary::attach_copies`]): CiA 402 gives axis n the profile area `6000h + n × 800h`.
pub const COPY_STRIDE: u16 = 0x800;

/// Most copies of one table (CiA 301/402: up to eight logical devices on a node).
pub const MAX_COPIES: u8 = 8;

/// Bytes of value store that `tables` need (what [`Dictionary::used_bytes`] reports once they are
/// attached), at compile time: a firmware sizes its dictionary with it instead of a guess, e.g.
/// `Drive<H, { STANDARD_OD_BYTES + od::storage_bytes(&[&VENDOR]) }>` (see
/// [`crate::drive::STANDARD_OD_BYTES`]).
#[allow(clippy::indexing_slicing)] // `while` bounds (no iterators in a const fn)
pub const fn storage_bytes(tables: &[&[Object]]) -> usize {
    let mut total = 0;
    let mut t = 0;
    while t < tables.len() {
        let mut o = 0;
        while o < tables[t].len() {
            total += tables[t][o].storage_size();
            o += 1;
        }
        t += 1;
    }
    total
}

/// Identity and descriptive data of the device, given by the firmware at start-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceInfo {
    /// 1000h device type. CiA 402 servo drive: 0x0002_0192.
    pub device_type: u32,
    /// 1018h sub 1, assigned by CiA.
    pub vendor_id: u32,
    /// 1018h sub 2.
    pub product_code: u32,
    /// 1018h sub 3 (bits 31..16 major, 15..0 minor).
    pub revision_number: u32,
    /// 1018h sub 4.
    pub serial_number: u32,
    /// 1008h.
    pub device_name: &'static str,
    /// 1009h.
    pub hardware_version: &'static str,
    /// 100Ah.
    pub software_version: &'static str,
    /// EDS `[DeviceInfo] VendorName`.
    pub vendor_name: &'static str,
    /// Contents of 1021h (the device's EDS), when the `eds-object` feature serves it.
    pub eds: &'static [u8],
    /// 6502h: the CiA 402 modes of operation the drive supports (bit 0 pp, 2 pv, 3 tq, …;
    /// CiA 402-2 §8.4.12). 6060h accepts only these. Default: the modes this crate runs.
    pub drive_modes: u32,
}

/// The firmware's own power-on value for an entry of the crate's tables (a default its
/// documentation gives instead of the crate's, e.g. 6085h quick stop deceleration): used at
/// power-on, by every reset of the entry's area, after restore defaults (1011h), and in the EDS.
/// See [`crate::Config::default_overrides`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DefaultOverride {
    /// Index of the entry.
    pub index: u16,
    /// Sub-index of the entry.
    pub sub: u8,
    /// Its power-on value.
    pub value: DefaultValue,
}

/// Callbacks of the firmware for its own objects (manufacturer area 2000h–5FFFh, or refinements
/// of any other entry). Every method has a default that does nothing, so a firmware implements
/// only what it needs. Hooks run inside [`crate::Drive::on_frame`]: keep them short.
pub trait ObjectHooks {
    /// Whether [`validate`](Self::validate) may refuse a value (`false` lets the process data
    /// path skip the check pass for mappings without rules).
    const VALIDATES: bool = true;

    /// Whether [`written`](Self::written) does anything.
    const NOTIFIES: bool = true;

    /// Length of a value the hook serves itself, or `None` to read the dictionary's store.
    /// An `Err` refuses the upload with that code.
    fn read_len(&mut self, index: u16, sub: u8) -> Option<Result<usize, AbortCode>> {
        let _ = (index, sub);
        None
    }

    /// Copies bytes of a value served by the hook (see [`read_len`](Self::read_len)) from
    /// `offset` on into `buf`; returns the bytes copied.
    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let _ = (index, sub, offset, buf);
        Ok(0)
    }

    /// Checks a value the bus wants to write, after the dictionary's own checks (access, size,
    /// limits). Refuse with the precise code, e.g. [`AbortCode::InvalidValue`].
    fn validate(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let _ = (index, sub, data);
        Ok(())
    }

    /// Called after a value from the bus was stored.
    fn written(&mut self, index: u16, sub: u8, data: &[u8]) {
        let _ = (index, sub, data);
    }

    /// Called after a store on command (1010h sub `sub`, the group) succeeded: the firmware
    /// may keep its own data that belongs to the group (a node-ID, a bit rate).
    fn stored(&mut self, sub: u8) {
        let _ = sub;
    }
}

/// No hooks: every value lives in the dictionary.
impl ObjectHooks for () {
    const VALIDATES: bool = false;
    const NOTIFIES: bool = false;
}

/// A resolved entry: one sub-index, its description and where its value lives.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// The object the entry belongs to.
    pub object: &'static Object,
    /// The entry's description.
    pub var: &'static Var,
    /// Sub-index.
    pub sub: u8,
    /// Index (the object's, or a copy's: [`Dictionary::attach_copies`]).
    index: u16,
    offset: u16,
}

impl Entry {
    /// Index of the entry's object (a copy's own index, where `object` describes the first).
    pub fn index(&self) -> u16 {
        self.index
    }
}

/// Up to four little-endian bytes of a value as a number (missing bytes read as 0): what the
/// services' write rules compare.
pub fn le_u32(data: &[u8]) -> u32 {
    data.iter().take(4).rev().fold(0, |acc, b| (acc << 8) | u32::from(*b))
}

/// A value type the device reads and writes with [`Dictionary::get`] / [`Dictionary::set`].
pub trait Scalar: Copy {
    /// Bytes on the wire.
    const SIZE: usize;
    /// Decodes `SIZE` little-endian bytes.
    fn from_le(bytes: &[u8]) -> Self;
    /// Encodes into `SIZE` little-endian bytes (`out.len() == SIZE`).
    fn to_le(self, out: &mut [u8]);
}

macro_rules! scalar {
    ($($t:ty),*) => {$(
        impl Scalar for $t {
            const SIZE: usize = core::mem::size_of::<$t>();
            fn from_le(bytes: &[u8]) -> Self {
                const N: usize = core::mem::size_of::<$t>();
                // The common case, a value of exactly its size: a fixed-size copy.
                if let Some(exact) = bytes.get(..N).and_then(|b| <[u8; N]>::try_from(b).ok()) {
                    return <$t>::from_le_bytes(exact);
                }
                let mut raw = [0u8; N];
                for (d, s) in raw.iter_mut().zip(bytes) {
                    *d = *s;
                }
                <$t>::from_le_bytes(raw)
            }
            fn to_le(self, out: &mut [u8]) {
                let bytes = self.to_le_bytes();
                match <&mut [u8; core::mem::size_of::<$t>()]>::try_from(&mut *out) {
                    Ok(exact) => *exact = bytes,
                    Err(_) => {
                        for (d, s) in out.iter_mut().zip(bytes) {
                            *d = s;
                        }
                    }
                }
            }
        }
    )*};
}
scalar!(u8, u16, u32, u64, i8, i16, i32, i64, f32, f64);

/// A numeric entry resolved once, for the device's own per-tick reads and writes: the store
/// offset of a stored value, so [`Dictionary::load`] and [`Dictionary::store`] are a bounds
/// check and a byte copy instead of a lookup. A constant, missing or differently sized entry
/// resolves to a slot that goes through [`Dictionary::get`] / [`Dictionary::set`] (same answer,
/// full cost).
///
/// A slot belongs to the dictionary layout it was resolved in: the tables and their order are
/// fixed when a dictionary is built, so a slot stays valid for every dictionary built from the
/// same configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot<T> {
    index: u16,
    /// Store offset of a stored value of `T::SIZE` bytes; [`NOT_STORED`]: resolved by lookup
    /// (a sentinel rather than an `Option`: six bytes a slot, not eight — a drive holds ~80).
    offset: u16,
    sub: u8,
    _value: core::marker::PhantomData<T>,
}

/// [`Slot::offset`] of a slot that looks its entry up (a store never reaches this offset: a
/// dictionary's store is below 64 KiB).
const NOT_STORED: u16 = u16::MAX;

impl<T: Scalar> Slot<T> {
    /// A slot that resolves `index`/`sub` on every access (the cost of [`Dictionary::get`]);
    /// the placeholder before [`Dictionary::slot`] resolved it.
    pub const fn lookup(index: u16, sub: u8) -> Self {
        Slot { index, sub, offset: NOT_STORED, _value: core::marker::PhantomData }
    }

    /// Index of the entry.
    pub fn index(&self) -> u16 {
        self.index
    }

    /// Whether the slot reaches a stored value directly (no lookup per access).
    pub fn is_stored(&self) -> bool {
        self.offset != NOT_STORED
    }
}

/// A signed integer entry resolved once, read and written at the width its description has
/// (an entry a firmware may widen, [`Var::is_widenable`]): [`Dictionary::load_int`] sign-extends,
/// [`Dictionary::store_int`] saturates to the width. An entry that is not a stored integer
/// reads 0 and is not written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntSlot {
    index: u16,
    /// Store offset, or [`NOT_STORED`] (resolved by lookup).
    offset: u16,
    sub: u8,
    /// Bytes of the value (1–8) when stored.
    len: u8,
}

impl IntSlot {
    /// A slot that resolves `index`/`sub` on every access.
    pub const fn lookup(index: u16, sub: u8) -> Self {
        IntSlot { index, sub, offset: NOT_STORED, len: 0 }
    }

    /// Whether the slot reaches a stored value directly (no lookup per access).
    pub fn is_stored(&self) -> bool {
        self.offset != NOT_STORED
    }
}

/// The place of a stored numeric value of up to 8 bytes ([`Dictionary::span`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    offset: u16,
    len: u8,
}

impl Span {
    /// The span of `len` bytes at store offset `offset` (one that [`Dictionary::span`] gave).
    pub(crate) const fn new(offset: u16, len: u8) -> Self {
        Span { offset, len }
    }

    /// Store offset of the value.
    pub fn offset(&self) -> u16 {
        self.offset
    }

    /// Bytes of the value.
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// Whether the span holds no value (a PDO's dummy entry).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// A set of homing methods (6098h values) as 60E3h lists them: ascending, the negative
/// (manufacturer-specific) methods first. The drive profile computes it from its configuration
/// (`cia402::hm::HomingConfig::method_list`); the dictionary only lists it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MethodList {
    /// Bit `m + 128` of the 256-bit set (two halves): method `m` is in the list.
    bits: [u128; 2],
}

impl MethodList {
    /// No method.
    pub const EMPTY: MethodList = MethodList { bits: [0, 0] };

    /// The list with `method` added.
    pub const fn with(self, method: i8) -> Self {
        let position = (method as i16 + 128) as u32;
        let mut bits = self.bits;
        if position < 128 {
            bits[0] |= 1 << position;
        } else {
            bits[1] |= 1 << (position - 128);
        }
        MethodList { bits }
    }

    /// The methods, ascending.
    pub fn iter(&self) -> impl Iterator<Item = i8> + '_ {
        (0u32..256).filter_map(move |position| {
            let half = self.bits.get((position / 128) as usize)?;
            (half & (1 << (position % 128)) != 0).then(|| (position as i16 - 128) as i8)
        })
    }

    /// How many methods (60E3h sub 0).
    pub fn count(&self) -> u8 {
        u8::try_from(self.bits[0].count_ones() + self.bits[1].count_ones()).unwrap_or(u8::MAX)
    }

    /// 60E3h sub `sub` (1-based): the `sub`-th method, `None` beyond the list.
    pub fn nth(&self, sub: u8) -> Option<i8> {
        self.iter().nth(usize::from(sub).checked_sub(1)?)
    }
}

/// The object dictionary: description tables plus a value store of `BYTES` bytes.
pub struct Dictionary<const BYTES: usize> {
    /// The tables attached, in index order.
    tables: [Table; MAX_TABLES],
    /// Tables attached (at most [`MAX_TABLES`]).
    table_count: u8,
    store: [u8; BYTES],
    device: DeviceInfo,
    node_id: u8,
    overrides: &'static [DefaultOverride],
    /// The firmware's descriptions of entries of the tables ([`EntryOverride`]).
    entry_overrides: &'static [EntryOverride],
    /// The homing methods 60E3h lists ([`DeviceField::HomingMethods`]).
    homing: MethodList,
    /// Objects of the tables the device does not show on the bus ([`Self::set_absent`]).
    absent: &'static [u16],
    /// Counts the changes of the store ([`Self::revision`]).
    revision: u32,
    /// Counts the changes of process data alone ([`Self::touch_process_data`]): the
    /// configuration's revision is [`Self::revision`] without them.
    process_data_touches: u32,
}

/// One table of a dictionary: its descriptions and where they lie.
#[derive(Clone, Copy)]
pub(crate) struct Table {
    descriptions: Descriptions,
    /// The first and the last index of every copy (an empty table: an empty range), so that
    /// a look-up picks its table without reading the descriptions.
    first: u16,
    last: u16,
    /// Start of the table's values in the store.
    pub(crate) region: u16,
    /// Bytes of store one copy takes.
    pub(crate) span: u16,
    /// Copies ([`Dictionary::attach_copies`]): copy k lies [`COPY_STRIDE`] × k above the
    /// table's indices, its values `span` × k above `region`.
    pub(crate) copies: u8,
}

impl Table {
    const EMPTY: Table =
        Table { descriptions: Descriptions::Plain(&[]), first: 1, last: 0, region: 0, span: 0, copies: 1 };

    /// The table's descriptions.
    #[inline]
    pub(crate) fn objects(&self) -> &'static [Object] {
        match self.descriptions {
            Descriptions::Plain(objects) => objects,
            Descriptions::Indexed(level) => level.objects(),
        }
    }

    /// Where copy `k`'s values start.
    pub(crate) fn region_of(&self, k: u16) -> usize {
        usize::from(self.region) + usize::from(self.span) * usize::from(k)
    }
}

/// A table's descriptions, and how a look-up finds one of them. (An enum in the size of the
/// slice: a table's first level costs no RAM.)
#[derive(Clone, Copy)]
enum Descriptions {
    /// Binary-searched.
    Plain(&'static [Object]),
    /// Grouped by index ([`FirstLevel`]): a look-up scans the group of its index.
    Indexed(&'static FirstLevel),
}

/// A default value resolved to bytes.
enum DefaultBytes {
    Number([u8; 8], usize),
    Slice(&'static [u8]),
}

impl DefaultBytes {
    fn bytes(&self) -> &[u8] {
        match self {
            DefaultBytes::Number(raw, n) => raw.get(..*n).unwrap_or(&[]),
            DefaultBytes::Slice(s) => s,
        }
    }
}

impl<const BYTES: usize> Dictionary<BYTES> {
    /// Joins `tables` (each laid out by [`layout`], covering disjoint ascending index ranges,
    /// given in ascending order) into a dictionary with every value at its default. The
    /// tables' order and layout are checked here; their entries (defaults against types and
    /// limits, sub-indices) by [`check_table`] (which `Drive::new` runs on the firmware's
    /// tables), so that an image whose tables are fixed does not carry that code.
    pub fn new(tables: &[&'static [Object]], device: DeviceInfo, node_id: u8) -> Result<Self, ConfigError> {
        let mut dict = Dictionary::empty(device, node_id);
        dict.attach(tables)?;
        Ok(dict)
    }

    /// A dictionary without tables (every access answers "object does not exist"), to be given
    /// its tables in place with [`attach`](Self::attach): the store is only zeroed here, so a
    /// dictionary inside a larger structure can be set up without being moved.
    pub fn empty(device: DeviceInfo, node_id: u8) -> Self {
        Dictionary {
            tables: [Table::EMPTY; MAX_TABLES],
            table_count: 0,
            store: [0; BYTES],
            device,
            node_id,
            overrides: &[],
            entry_overrides: &[],
            homing: MethodList::EMPTY,
            absent: &[],
            revision: 0,
            process_data_touches: 0,
        }
    }

    /// Objects of the tables that the device does not have as far as the bus can tell: SDO
    /// and PDO mapping answer "object does not exist" (0x0602_0000) and the EDS leaves them
    /// out, while the device side keeps reading their (default) values, so the behaviour they
    /// carry stays at its defaults.
    pub fn set_absent(&mut self, indices: &'static [u16]) {
        self.absent = indices;
    }

    /// Whether the object at `index` is hidden from the bus ([`Self::set_absent`]).
    pub fn is_absent(&self, index: u16) -> bool {
        // Nearly always none: then no scan.
        !self.absent.is_empty() && self.absent.contains(&index)
    }

    /// [`Self::entry`] as the bus sees the dictionary: an absent object does not exist.
    #[inline]
    pub fn bus_entry(&self, index: u16, sub: u8) -> Result<Entry, AbortCode> {
        if self.is_absent(index) {
            return Err(AbortCode::ObjectDoesNotExist);
        }
        self.entry(index, sub)
    }

    /// Replaces the tables with `tables` (see [`new`](Self::new)) and sets every value to its
    /// default. On an error the dictionary is left without tables.
    pub fn attach(&mut self, tables: &[&'static [Object]]) -> Result<(), ConfigError> {
        self.attach_copies(tables, &[])
    }

    /// [`attach`](Self::attach), with `copies[t]` copies of table `t` (1 where `copies` is
    /// shorter): the objects of one logical device described once and attached for several,
    /// copy k at the table's indices + k × [`COPY_STRIDE`] with values of its own (CiA 402:
    /// axis k's profile area). A table with copies lies inside one stride.
    pub fn attach_copies(&mut self, tables: &[&'static [Object]], copies: &[u8]) -> Result<(), ConfigError> {
        self.attach_indexed(tables, &[], copies)
    }

    /// [`attach_copies`](Self::attach_copies), with `first_levels[t]` the first level of table
    /// `t` (made by [`first_level`] at compile time), where it has one: a look-up of its objects
    /// scans the group of its index instead of binary-searching the table. A first level made
    /// for another table is left unused.
    pub(crate) fn attach_indexed(
        &mut self,
        tables: &[&'static [Object]],
        first_levels: &[Option<&'static FirstLevel>],
        copies: &[u8],
    ) -> Result<(), ConfigError> {
        self.table_count = 0;
        if tables.len() > MAX_TABLES {
            return Err(ConfigError::TooManyTables);
        }
        let mut region = 0usize;
        let mut previous: Option<u16> = None;
        // Empty tables (an option left out) take no place.
        let mut count = 0;
        for (t, table) in tables.iter().enumerate().filter(|(_, table)| !table.is_empty()) {
            let n = copies.get(t).copied().unwrap_or(1);
            let (first, last) = match (table.first(), table.last()) {
                (Some(first), Some(last)) => (first.index, last.index),
                _ => (1, 0),
            };
            let wide = !table.is_empty() && last.wrapping_sub(first) >= COPY_STRIDE;
            if n == 0 || n > MAX_COPIES || (n > 1 && wide) {
                return Err(ConfigError::BadCopies { index: first });
            }
            let mut offset = 0usize;
            for object in table.iter() {
                if previous.is_some_and(|p| p == object.index) {
                    return Err(ConfigError::DuplicateIndex { index: object.index });
                }
                if previous.is_some_and(|p| p > object.index) {
                    return Err(ConfigError::NotSorted { index: object.index });
                }
                previous = Some(object.index);
                if usize::from(object.base) != offset {
                    return Err(ConfigError::NotLaidOut { index: object.index });
                }
                offset += object.storage_size();
            }
            let shift = u32::from(n - 1) * u32::from(COPY_STRIDE);
            let top = u16::try_from(u32::from(last) + shift)
                .map_err(|_| ConfigError::BadCopies { index: first })?;
            if n > 1 && !table.is_empty() {
                previous = Some(top);
            }
            let too_small = |needed| ConfigError::StorageTooSmall { needed };
            let slot = self.tables.get_mut(count).ok_or(ConfigError::TooManyTables)?;
            count += 1;
            let descriptions = match first_levels.get(t).copied().flatten() {
                Some(level) if level.is_some() && core::ptr::eq(level.objects(), *table) => {
                    Descriptions::Indexed(level)
                }
                _ => Descriptions::Plain(table),
            };
            *slot = Table {
                descriptions,
                first,
                last: if table.is_empty() { 0 } else { top },
                region: u16::try_from(region).map_err(|_| too_small(region))?,
                span: u16::try_from(offset).map_err(|_| too_small(offset))?,
                copies: n,
            };
            region += offset * usize::from(n);
        }
        if region > BYTES || region > usize::from(u16::MAX) {
            return Err(ConfigError::StorageTooSmall { needed: region });
        }
        self.table_count = count as u8;
        self.reset(0x0000..=0xFFFF);
        Ok(())
    }

    /// The logical devices of the node: the most copies of a table (1 without copies).
    pub fn devices(&self) -> u8 {
        self.attached().iter().map(|t| t.copies).max().unwrap_or(1)
    }

    /// Which copy of its table `index` lies in (0 for the first, and for an index of a table
    /// without copies): the logical device (CiA 402 axis) of the object.
    pub fn copy_of(&self, index: u16) -> u8 {
        self.attached()
            .iter()
            .find(|t| t.copies > 1 && (t.first..=t.last).contains(&index))
            .map_or(0, |t| ((index - t.first) / COPY_STRIDE) as u8)
    }

    /// Replaces the crate's defaults of some entries with the firmware's own
    /// ([`DefaultOverride`]) and sets every value to its (new) default. An override of an
    /// entry that does not exist, or whose value does not fit the entry, is refused.
    pub fn set_default_overrides(
        &mut self,
        overrides: &'static [DefaultOverride],
    ) -> Result<(), ConfigError> {
        // Checked with the overrides in place: one may show sub-indices another one sets (an
        // ARRAY's constant count, 1029h).
        let previous = core::mem::replace(&mut self.overrides, overrides);
        for o in overrides {
            let problem = match self.entry(o.index, o.sub) {
                Ok(entry) => overrides::default_problem(entry.var, o.value, o.index, o.sub),
                Err(_) => Some(ConfigError::NoSuchEntry { index: o.index, sub: o.sub }),
            };
            if let Some(problem) = problem {
                self.overrides = previous;
                return Err(problem);
            }
        }
        self.reset(0x0000..=0xFFFF);
        Ok(())
    }

    /// The power-on value of sub-index `sub` of `index`, described by `var`: the firmware's
    /// override, or the table's default.
    pub fn default_of(&self, index: u16, sub: u8, var: &Var) -> DefaultValue {
        let default =
            self.overrides.iter().find(|o| o.index == index && o.sub == sub).map_or(var.default, |o| o.value);
        match default {
            DefaultValue::Device(DeviceField::HomingMethodCount) => {
                DefaultValue::Unsigned(u64::from(self.homing.count()))
            }
            DefaultValue::Device(DeviceField::HomingMethods) => {
                DefaultValue::Signed(self.homing.nth(sub).map_or(0, i64::from))
            }
            DefaultValue::PdoPreset => standard::pdo_preset(index, sub, self.devices()),
            other => other,
        }
    }

    /// The homing methods the drive supports, for the entries whose default is
    /// [`DeviceField::HomingMethodCount`] or [`DeviceField::HomingMethods`] (60E3h).
    pub fn set_homing_methods(&mut self, methods: MethodList) {
        self.homing = methods;
    }

    /// The number of elements of ARRAY `index` with `len` elements and sub-index 0 `sub0`: fewer
    /// when sub 0 counts a list of the configuration ([`DeviceField::HomingMethodCount`]) or is
    /// a constant below `len` (the table's or a firmware's default).
    pub fn array_len(&self, index: u16, sub0: &Var, len: u8) -> u8 {
        match sub0.default {
            DefaultValue::Device(DeviceField::HomingMethodCount) => self.homing.count().min(len),
            // A constant count below the array's length shows that many elements: an ARRAY
            // whose further elements a configuration switches on (1029h) by overriding it.
            _ if sub0.access == Access::Const => match self.default_of(index, 0, sub0) {
                DefaultValue::Unsigned(n) => u8::try_from(n).unwrap_or(u8::MAX).min(len),
                _ => len,
            },
            _ => len,
        }
    }

    /// Bytes of the store the tables use.
    pub fn used_bytes(&self) -> usize {
        self.attached().iter().map(|t| usize::from(t.span) * usize::from(t.copies)).sum()
    }

    /// The node-ID that `$NODEID` defaults resolve to.
    pub fn node_id(&self) -> u8 {
        self.node_id
    }

    /// Changes the node-ID used by `$NODEID` defaults (applied at the next reset).
    pub fn set_node_id(&mut self, node_id: u8) {
        self.node_id = node_id;
    }

    /// 1000h: [`DeviceInfo::device_type`], or on a node of several logical devices
    /// ([`Self::devices`]) the multi-device marker [`MULTI_DEVICE`] and the first device's
    /// profile number.
    pub fn device_type(&self) -> u32 {
        let device_type = self.device.device_type;
        if self.devices() > 1 {
            MULTI_DEVICE | device_type & 0xFFFF
        } else {
            device_type
        }
    }

    /// The device description.
    pub fn device(&self) -> &DeviceInfo {
        &self.device
    }

    /// The tables attached.
    pub(crate) fn attached(&self) -> &[Table] {
        self.tables.get(..usize::from(self.table_count)).unwrap_or(&[])
    }

    /// Every object where it lies, in ascending index order: (index, description, start of its
    /// table's region of values). A copy of a table ([`Self::attach_copies`]) gives its
    /// objects' descriptions with the copy's indices.
    pub(crate) fn placements(&self) -> impl Iterator<Item = (u16, &'static Object, u16)> + '_ {
        self.attached().iter().flat_map(|table| {
            (0..u16::from(table.copies)).flat_map(move |k| {
                let region = table.region_of(k) as u16;
                table
                    .objects()
                    .iter()
                    .map(move |o| (o.index.wrapping_add(COPY_STRIDE.wrapping_mul(k)), o, region))
            })
        })
    }

    /// Every object, in ascending index order: a copy of a table ([`Self::attach_copies`])
    /// gives its descriptions with the copy's indices.
    pub fn objects(&self) -> impl Iterator<Item = Object> + '_ {
        self.placements().map(|(index, object, _)| object.at(index))
    }

    /// The object at `index`.
    pub fn object(&self, index: u16) -> Option<(&'static Object, u16)> {
        // The ranges ascend and do not overlap (`attach` checks): the last one that starts at or
        // below `index` is the only one that can hold it. (From the top: the drive profile's
        // objects, those of nearly every request, are in the last table or the one below.)
        let table = self.attached().iter().rfind(|t| t.first <= index)?;
        if index > table.last {
            return None;
        }
        // (Compared as u32: a u16 key the copy arithmetic made would be re-extended on every
        // step of the search.)
        let (mut key, mut region) = (u32::from(index), table.region);
        if table.copies > 1 {
            // Copy k of the table: its objects k strides up, its values k spans up.
            let k = (index - table.first) / COPY_STRIDE;
            key -= u32::from(k * COPY_STRIDE);
            region += k * table.span;
        }
        let object = match table.descriptions {
            // The group of the index: a few objects at most (the drive profile's: up to 8).
            Descriptions::Indexed(level) => {
                let group = level.objects().get(level.group(key as u16)?)?;
                group.iter().find(|o| u32::from(o.index) == key)?
            }
            Descriptions::Plain(objects) => {
                let pos = objects.binary_search_by_key(&key, |o| u32::from(o.index)).ok()?;
                objects.get(pos)?
            }
        };
        Some((object, region))
    }

    /// Resolves `index`/`sub`, or answers 0x0602_0000 / 0x0609_0011.
    pub fn entry(&self, index: u16, sub: u8) -> Result<Entry, AbortCode> {
        let (object, region) = self.object(index).ok_or(AbortCode::ObjectDoesNotExist)?;
        let (var, offset) = object.sub(sub).ok_or(AbortCode::SubIndexDoesNotExist)?;
        if let Kind::Array { sub0, len, .. } = &object.kind {
            if sub > self.array_len(index, sub0, *len) {
                return Err(AbortCode::SubIndexDoesNotExist);
            }
        }
        let offset = usize::from(region) + usize::from(object.base) + offset;
        let var = self.resolve(index, object, sub, var)?;
        Ok(Entry { object, var, sub, index, offset: offset as u16 })
    }

    fn default_bytes(&self, var: &Var, default: DefaultValue) -> DefaultBytes {
        let number = |v: u64| {
            let size = var.data_type.fixed_size().unwrap_or(0).min(8);
            DefaultBytes::Number(v.to_le_bytes(), size)
        };
        match default {
            DefaultValue::Zero => number(0),
            DefaultValue::Unsigned(v) => number(v),
            DefaultValue::Signed(v) => number(v as u64),
            DefaultValue::Real(v) => match var.data_type {
                DataType::Real32 => number(u64::from((v as f32).to_bits())),
                _ => number(v.to_bits()),
            },
            DefaultValue::Text(s) => DefaultBytes::Slice(s.as_bytes()),
            DefaultValue::Bytes(b) => DefaultBytes::Slice(b),
            DefaultValue::NodeIdPlus(base) => number(u64::from(base.wrapping_add(u32::from(self.node_id)))),
            DefaultValue::Device(field) => {
                let d = &self.device;
                match field {
                    DeviceField::DeviceType => number(u64::from(self.device_type())),
                    DeviceField::LogicalDeviceType => number(u64::from(d.device_type)),
                    DeviceField::VendorId => number(u64::from(d.vendor_id)),
                    DeviceField::ProductCode => number(u64::from(d.product_code)),
                    DeviceField::RevisionNumber => number(u64::from(d.revision_number)),
                    DeviceField::SerialNumber => number(u64::from(d.serial_number)),
                    DeviceField::DriveModes => number(u64::from(d.drive_modes)),
                    DeviceField::DeviceName => DefaultBytes::Slice(d.device_name.as_bytes()),
                    DeviceField::HardwareVersion => DefaultBytes::Slice(d.hardware_version.as_bytes()),
                    DeviceField::SoftwareVersion => DefaultBytes::Slice(d.software_version.as_bytes()),
                    DeviceField::Eds => DefaultBytes::Slice(d.eds),
                    // Resolved by `default_of`.
                    DeviceField::HomingMethodCount | DeviceField::HomingMethods => number(0),
                }
            }
            // Resolved by `default_of`.
            DefaultValue::PdoPreset => number(0),
        }
    }

    /// The stored bytes of `entry` (its current value), or `None` for a fixed entry.
    fn stored(&self, entry: &Entry) -> Option<&[u8]> {
        if entry.var.is_fixed() {
            return None;
        }
        let start = usize::from(entry.offset);
        match entry.var.data_type.fixed_size() {
            Some(n) => self.store.get(start..start + n),
            None => {
                let len = u16::from_le_bytes([*self.store.get(start)?, *self.store.get(start + 1)?]);
                let len = usize::from(len.min(entry.var.capacity));
                self.store.get(start + 2..start + 2 + len)
            }
        }
    }

    /// Current length of the value in bytes (what an SDO upload transfers).
    pub fn value_len(&self, entry: &Entry) -> usize {
        match self.stored(entry) {
            Some(bytes) => bytes.len(),
            None => self
                .default_bytes(entry.var, self.default_of(entry.index(), entry.sub, entry.var))
                .bytes()
                .len(),
        }
    }

    /// Copies the value of `entry` from byte `offset` on into `buf`; returns the bytes copied.
    pub fn read(&self, entry: &Entry, offset: usize, buf: &mut [u8]) -> usize {
        let default;
        let value = match self.stored(entry) {
            Some(bytes) => bytes,
            None => {
                default = self.default_bytes(entry.var, self.default_of(entry.index(), entry.sub, entry.var));
                default.bytes()
            }
        };
        let rest = value.get(offset..).unwrap_or(&[]);
        let n = rest.len().min(buf.len());
        if let (Some(d), Some(s)) = (buf.get_mut(..n), rest.get(..n)) {
            d.copy_from_slice(s);
        }
        n
    }

    /// Copies a stored value of 1..=4 bytes (an expedited SDO upload) into `buf`; `None` for
    /// any other entry (longer, variable or fixed: [`read`](Self::read) serves those).
    #[inline]
    pub fn read_small(&self, entry: &Entry, buf: &mut [u8; 4]) -> Option<usize> {
        let n = entry.var.data_type.fixed_size().filter(|n| (1..=4).contains(n) && !entry.var.is_fixed())?;
        let start = usize::from(entry.offset);
        // One word, masked to the value's bytes (a copy of 1..=4 bytes would call memcpy).
        let value = match self.store.get(start..start + 4) {
            Some(word) => <u32 as Scalar>::from_le(word) & (u32::MAX >> (32 - 8 * n)),
            None => <u32 as Scalar>::from_le(self.store.get(start..start + n)?),
        };
        *buf = value.to_le_bytes();
        Some(n)
    }

    /// Where a stored numeric value of up to 8 bytes lives (what a PDO maps), for
    /// [`load_span`](Self::load_span) / [`store_span`](Self::store_span) without a lookup or a
    /// copy of variable length; `None` for constants and other entries.
    pub fn span(&self, entry: &Entry) -> Option<Span> {
        let len = entry.var.data_type.fixed_size().filter(|n| *n <= 8 && !entry.var.is_fixed())?;
        Some(Span { offset: entry.offset, len: len as u8 })
    }

    /// The value at `span`, little-endian, zero-extended to 64 bits.
    #[inline]
    pub fn load_span(&self, span: Span) -> u64 {
        let start = usize::from(span.offset);
        match span.len {
            1 => self.store.get(start).map_or(0, |b| u64::from(*b)),
            2 => self.store.get(start..start + 2).map_or(0, |b| u64::from(<u16 as Scalar>::from_le(b))),
            4 => self.store.get(start..start + 4).map_or(0, |b| u64::from(<u32 as Scalar>::from_le(b))),
            n => self
                .store
                .get(start..start + usize::from(n))
                .map_or(0, |bytes| bytes.iter().rev().fold(0, |value, byte| value << 8 | u64::from(*byte))),
        }
    }

    /// Stores the first bytes of `data` (little-endian, as on the bus) as the value at `span`
    /// (after the checks a bus write needs). Not counted in [`revision`](Self::revision): the
    /// caller counts its batch of span writes once with [`touch`](Self::touch).
    #[inline]
    pub fn fill_span(&mut self, span: Span, data: &[u8]) {
        let start = usize::from(span.offset);
        copy_small(self.store.get_mut(start..).unwrap_or(&mut []), data, span.len);
    }

    /// Stores the low bytes of `value` at `span` (after the checks a bus write needs). Not
    /// counted in [`revision`](Self::revision), as [`fill_span`](Self::fill_span).
    #[inline]
    pub fn store_span(&mut self, span: Span, value: u64) {
        let start = usize::from(span.offset);
        let bytes = value.to_le_bytes();
        if let (Some(dst), Some(src)) =
            (self.store.get_mut(start..start + usize::from(span.len)), bytes.get(..usize::from(span.len)))
        {
            for (d, s) in dst.iter_mut().zip(src) {
                *d = *s;
            }
        }
    }

    /// Checks that `data` is an acceptable new value for `entry` from the bus: size and limits
    /// (CiA 301 §7.2.4). Access rights and NMT rules are the caller's (they depend
    /// on the service).
    pub fn check_write(&self, entry: &Entry, data: &[u8]) -> Result<(), AbortCode> {
        let var = entry.var;
        match var.data_type.fixed_size() {
            Some(n) if data.len() > n => return Err(AbortCode::LengthTooHigh),
            Some(n) if data.len() < n => return Err(AbortCode::LengthTooLow),
            Some(_) => {}
            None if data.len() > usize::from(var.capacity) => return Err(AbortCode::LengthTooHigh),
            None => return Ok(()),
        }
        if !has_limits(var) {
            return Ok(());
        }
        check_limits(var, data)
    }

    /// Whether a value written to an entry described by `var` must be checked against limits
    /// beyond its type's range (its bounds, BOOLEAN's 0/1, a REAL's NaN).
    pub fn has_limits(var: &Var) -> bool {
        has_limits(var)
    }

    /// Checks a numeric value of the entry's size against the limits of `var`
    /// ([`has_limits`](Self::has_limits)).
    pub fn check_limits(var: &Var, data: &[u8]) -> Result<(), AbortCode> {
        check_limits(var, data)
    }

    /// Stores `data` as the value of `entry` (after [`check_write`](Self::check_write)).
    /// Fixed entries are not changed.
    pub fn commit(&mut self, entry: &Entry, data: &[u8]) {
        if entry.var.is_fixed() {
            return;
        }
        let start = usize::from(entry.offset);
        match entry.var.data_type.fixed_size() {
            // The value of a bus write (`check_write` let only its exact size through).
            Some(n) if n == data.len() && n <= 8 => {
                copy_small(self.values_mut().get_mut(start..).unwrap_or(&mut []), data, n as u8);
            }
            Some(n) => {
                if let Some(dst) = self.values_mut().get_mut(start..start + n) {
                    dst.fill(0);
                    let k = data.len().min(n);
                    if let (Some(d), Some(s)) = (dst.get_mut(..k), data.get(..k)) {
                        d.copy_from_slice(s);
                    }
                }
            }
            None => {
                let k = data.len().min(usize::from(entry.var.capacity));
                if let Some(dst) = self.values_mut().get_mut(start..start + 2 + k) {
                    let (len, body) = dst.split_at_mut(2);
                    len.copy_from_slice(&(k as u16).to_le_bytes());
                    if let Some(s) = data.get(..k) {
                        body.copy_from_slice(s);
                    }
                }
            }
        }
    }

    /// Reads a numeric value from the device side (no access check). Refuses a size mismatch
    /// with 0x0607_0010.
    pub fn get<T: Scalar>(&self, index: u16, sub: u8) -> Result<T, AbortCode> {
        let entry = self.entry(index, sub)?;
        if entry.var.data_type.fixed_size() != Some(T::SIZE) {
            return Err(AbortCode::LengthMismatch);
        }
        if let Some(bytes) = self.stored(&entry) {
            return Ok(T::from_le(bytes));
        }
        let mut raw = [0u8; 8];
        let n = self.read(&entry, 0, &mut raw);
        Ok(T::from_le(raw.get(..n).unwrap_or(&[])))
    }

    /// Writes a numeric value from the device side (no access or limit check; fixed entries are
    /// not changed). Refuses a size mismatch with 0x0607_0010.
    pub fn set<T: Scalar>(&mut self, index: u16, sub: u8, value: T) -> Result<(), AbortCode> {
        let entry = self.entry(index, sub)?;
        if entry.var.data_type.fixed_size() != Some(T::SIZE) {
            return Err(AbortCode::LengthMismatch);
        }
        let mut raw = [0u8; 8];
        if let Some(bytes) = raw.get_mut(..T::SIZE) {
            value.to_le(bytes);
            self.commit(&entry, bytes);
        }
        Ok(())
    }

    /// A number that changes whenever a value may have changed: every write through this type
    /// counts (bus, device side, storage, reset) but for two kinds of fast writes: those
    /// through slots ([`store`](Self::store), [`store_int`](Self::store_int)), the profile's
    /// outputs of a tick, and those through spans ([`fill_span`](Self::fill_span),
    /// [`store_span`](Self::store_span)), an RPDO's entries, counted once per frame with
    /// [`touch`](Self::touch). Equal revisions between two ticks mean that nobody else wrote: a
    /// reader that derives something from the values (the profile's idle tick, TPDO change
    /// detection) can skip the work while the revision it saw stands.
    #[inline]
    pub fn revision(&self) -> u32 {
        self.revision
    }

    /// A number that changes whenever a value that is not process data may have changed:
    /// [`revision`](Self::revision) but for the writes counted with
    /// [`touch_process_data`](Self::touch_process_data) (an RPDO that maps only set-points and
    /// commands). What a reader derives from configuration alone (converted limits, timing)
    /// stands while it does.
    #[inline]
    pub fn configuration_revision(&self) -> u32 {
        self.revision.wrapping_sub(self.process_data_touches)
    }

    /// Counts a change in [`Self::revision`] and so in [`Self::configuration_revision`] (for a
    /// caller about to write through slots or spans outside the profile's tick: an RPDO, the
    /// firmware's device-side access).
    #[inline]
    pub fn touch(&mut self) {
        self.revision = self.revision.wrapping_add(1);
    }

    /// Counts a change in [`Self::revision`] only: for a caller about to write process data
    /// alone (set-points and commands, as the owner of the entries says), which changes
    /// nothing derived from configuration.
    #[inline]
    pub fn touch_process_data(&mut self) {
        self.revision = self.revision.wrapping_add(1);
        self.process_data_touches = self.process_data_touches.wrapping_add(1);
    }

    /// The store, for a write: counted in [`Self::revision`].
    #[inline]
    fn values_mut(&mut self) -> &mut [u8; BYTES] {
        self.touch();
        &mut self.store
    }

    /// Resolves a numeric entry for [`load`](Self::load) / [`store`](Self::store).
    pub fn slot<T: Scalar>(&self, index: u16, sub: u8) -> Slot<T> {
        let offset = self
            .entry(index, sub)
            .ok()
            .filter(|e| !e.var.is_fixed() && e.var.data_type.fixed_size() == Some(T::SIZE))
            .map_or(NOT_STORED, |e| e.offset);
        Slot { offset, ..Slot::lookup(index, sub) }
    }

    /// The value behind `slot`: what [`get`](Self::get) answers, or `T`'s default when the
    /// entry is missing or differently sized.
    #[inline]
    pub fn load<T: Scalar + Default>(&self, slot: Slot<T>) -> T {
        self.load_or(slot, T::default())
    }

    /// The value behind `slot`, or `missing` when the entry is missing or differently sized.
    #[inline]
    pub fn load_or<T: Scalar>(&self, slot: Slot<T>, missing: T) -> T {
        if slot.offset == NOT_STORED {
            return self.load_looked_up(slot, missing);
        }
        let start = usize::from(slot.offset);
        self.store.get(start..start + T::SIZE).map_or(missing, T::from_le)
    }

    /// [`load_or`](Self::load_or) of a slot to look up: out of line, so that the many places
    /// that load a slot hold only its fast path.
    #[cold]
    #[inline(never)]
    fn load_looked_up<T: Scalar>(&self, slot: Slot<T>, missing: T) -> T {
        self.get::<T>(slot.index, slot.sub).unwrap_or(missing)
    }

    /// Writes the value behind `slot` as [`set`](Self::set) does (a missing, constant or
    /// differently sized entry is left alone). Not counted in [`revision`](Self::revision): see
    /// there.
    #[inline]
    pub fn store<T: Scalar>(&mut self, slot: Slot<T>, value: T) {
        if slot.offset == NOT_STORED {
            self.store_looked_up(slot, value);
            return;
        }
        let start = usize::from(slot.offset);
        if let Some(bytes) = self.store.get_mut(start..start + T::SIZE) {
            value.to_le(bytes);
        }
    }

    /// [`store`](Self::store) of a slot to look up, out of line as
    /// [`load_looked_up`](Self::load_looked_up).
    #[cold]
    #[inline(never)]
    fn store_looked_up<T: Scalar>(&mut self, slot: Slot<T>, value: T) {
        let _ = self.set::<T>(slot.index, slot.sub, value);
    }

    /// Resolves an integer entry for [`load_int`](Self::load_int) /
    /// [`store_int`](Self::store_int).
    pub fn int_slot(&self, index: u16, sub: u8) -> IntSlot {
        let resolved = self.entry(index, sub).ok().and_then(|e| Some((e.offset, self.int_width(&e)?)));
        match resolved {
            Some((offset, len)) => IntSlot { index, sub, offset, len },
            None => IntSlot::lookup(index, sub),
        }
    }

    /// The bytes of a stored integer entry (read as signed whatever its description says: a
    /// firmware's UNSIGNED description of a signed value changes only what the bus sees).
    fn int_width(&self, entry: &Entry) -> Option<u8> {
        let n = entry.var.data_type.fixed_size().filter(|n| *n <= 8)?;
        let integer = entry.var.data_type.is_signed() || entry.var.data_type.is_unsigned();
        (integer && !entry.var.is_fixed()).then_some(n as u8)
    }

    /// The value behind `slot`, sign-extended (0 when the entry is not a stored integer).
    #[inline]
    pub fn load_int(&self, slot: IntSlot) -> i64 {
        let start = usize::from(slot.offset);
        match (slot.offset, slot.len) {
            (NOT_STORED, _) => self.load_int_other(slot),
            (_, 2) => self.store.get(start..start + 2).map_or(0, |b| i64::from(<i16 as Scalar>::from_le(b))),
            (_, 4) => self.store.get(start..start + 4).map_or(0, |b| i64::from(<i32 as Scalar>::from_le(b))),
            _ => self.load_int_other(slot),
        }
    }

    /// [`load_int`](Self::load_int) of a slot to look up, or of a width other than 2 or 4.
    #[inline(never)]
    fn load_int_other(&self, slot: IntSlot) -> i64 {
        let Some((start, n)) = self.int_place(slot) else { return 0 };
        self.store.get(start..start + usize::from(n)).map_or(0, |bytes| {
            let raw = bytes.iter().rev().fold(0u64, |value, byte| value << 8 | u64::from(*byte));
            sign_extend(raw, bytes.len())
        })
    }

    /// Writes `value` behind `slot`, saturated to the signed range of the entry's width (an
    /// entry that is not a stored integer is left alone). Not counted in
    /// [`revision`](Self::revision): see there.
    #[inline]
    pub fn store_int(&mut self, slot: IntSlot, value: i64) {
        let start = usize::from(slot.offset);
        // The common widths as fixed-size copies in place.
        match (slot.offset, slot.len) {
            (NOT_STORED, _) => self.store_int_other(slot, value),
            (_, 2) => {
                let v = value.clamp(i64::from(i16::MIN), i64::from(i16::MAX)) as i16;
                if let Some(dst) = self.store.get_mut(start..start + 2) {
                    Scalar::to_le(v, dst);
                }
            }
            (_, 4) => {
                let v = crate::wide::saturate_i32(value);
                if let Some(dst) = self.store.get_mut(start..start + 4) {
                    Scalar::to_le(v, dst);
                }
            }
            _ => self.store_int_other(slot, value),
        }
    }

    /// [`store_int`](Self::store_int) of a slot to look up, or of a width other than 2 or 4.
    #[inline(never)]
    fn store_int_other(&mut self, slot: IntSlot, value: i64) {
        let Some((start, n)) = self.int_place(slot) else { return };
        let max = i64::MAX >> (64 - 8 * u32::from(n));
        let bytes = value.clamp(-max - 1, max).to_le_bytes();
        if let Some(dst) = self.store.get_mut(start..start + usize::from(n)) {
            for (d, s) in dst.iter_mut().zip(bytes) {
                *d = s;
            }
        }
    }

    /// Where the value behind an [`IntSlot`] lives: its store offset and width.
    fn int_place(&self, slot: IntSlot) -> Option<(usize, u8)> {
        if slot.offset != NOT_STORED {
            return Some((usize::from(slot.offset), slot.len));
        }
        let entry = self.entry(slot.index, slot.sub).ok()?;
        Some((usize::from(entry.offset), self.int_width(&entry)?))
    }

    /// Sets every stored value of the objects in `range` back to its default.
    pub fn reset(&mut self, range: RangeInclusive<u16>) {
        for t in 0..self.attached().len() {
            let Some(&table) = self.tables.get(t) else { break };
            for k in 0..u16::from(table.copies) {
                let region = table.region_of(k);
                for object in table.objects().iter() {
                    let index = object.index.wrapping_add(k.wrapping_mul(COPY_STRIDE));
                    if !range.contains(&index) {
                        continue;
                    }
                    for sub in 0..=object.highest_sub() {
                        if let Some((var, offset)) = object.sub(sub) {
                            let var = self.describe(index, sub, var);
                            let offset = region + usize::from(object.base) + offset;
                            let entry = Entry { object, var, sub, index, offset: offset as u16 };
                            let default = self.default_bytes(var, self.default_of(index, sub, var));
                            self.commit(&entry, default.bytes());
                        }
                    }
                }
            }
        }
    }
}

/// Copies the first `n` bytes of `src` to `dst` (fewer when either is shorter): fixed-size
/// moves for 1, 2 and 4 bytes, where a copy of variable length would call `memcpy`.
#[inline]
fn copy_small(dst: &mut [u8], src: &[u8], n: u8) {
    match n {
        1 => {
            if let (Some(d), Some(s)) = (dst.first_mut(), src.first()) {
                *d = *s;
            }
        }
        2 => {
            if let (Some(d), Some(s)) = (dst.first_chunk_mut::<2>(), src.first_chunk::<2>()) {
                *d = *s;
            }
        }
        4 => {
            if let (Some(d), Some(s)) = (dst.first_chunk_mut::<4>(), src.first_chunk::<4>()) {
                *d = *s;
            }
        }
        n => {
            for (d, s) in dst.iter_mut().zip(src).take(usize::from(n)) {
                *d = *s;
            }
        }
    }
}

/// The two's-complement number in the low `bytes` (1–8) bytes of `raw`, sign-extended.
fn sign_extend(raw: u64, bytes: usize) -> i64 {
    let shift = 64 - 8 * bytes.clamp(1, 8) as u32;
    ((raw << shift) as i64) >> shift
}

/// Whether a numeric write to `var` has limits to check beyond its type's range.
#[inline]
fn has_limits(var: &Var) -> bool {
    var.has_bounds() || matches!(var.data_type, DataType::Boolean | DataType::Real32 | DataType::Real64)
}

/// Value range check of a numeric write (limits of the entry and of BOOLEAN).
fn check_limits(var: &Var, data: &[u8]) -> Result<(), AbortCode> {
    let ty = var.data_type;
    let n = data.len().min(8);
    if n == 0 || !has_limits(var) {
        return Ok(());
    }
    let mut raw = [0u8; 8];
    copy_small(&mut raw, data, n as u8);
    let unsigned = u64::from_le_bytes(raw);
    if ty.is_signed() {
        let value = sign_extend(unsigned, n);
        if let Bound::Signed(low) = var.low() {
            if value < low {
                return Err(AbortCode::ValueTooLow);
            }
        }
        if let Bound::Signed(high) = var.high() {
            if value > high {
                return Err(AbortCode::ValueTooHigh);
            }
        }
    } else if ty.is_unsigned() {
        if ty == DataType::Boolean && unsigned > 1 {
            return Err(AbortCode::ValueTooHigh);
        }
        if let Bound::Unsigned(low) = var.low() {
            if unsigned < low {
                return Err(AbortCode::ValueTooLow);
            }
        }
        if let Bound::Unsigned(high) = var.high() {
            if unsigned > high {
                return Err(AbortCode::ValueTooHigh);
            }
        }
    } else if matches!(ty, DataType::Real32 | DataType::Real64) {
        let value = if ty == DataType::Real32 {
            f64::from(f32::from_bits(unsigned as u32))
        } else {
            f64::from_bits(unsigned)
        };
        if value.is_nan() {
            return Err(AbortCode::InvalidValue);
        }
        if let Bound::Real(low) = var.low() {
            if value < low {
                return Err(AbortCode::ValueTooLow);
            }
        }
        if let Bound::Real(high) = var.high() {
            if value > high {
                return Err(AbortCode::ValueTooHigh);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SUBS: [(u8, Var); 3] = [
        (
            0,
            Var::new("Highest sub-index supported", DataType::Unsigned8)
                .access(Access::Const)
                .default(DefaultValue::Unsigned(2)),
        ),
        (
            1,
            Var::new("Signed 24", DataType::Integer24)
                .access(Access::ReadWrite)
                .limits_signed(-1000, 1000)
                .default(DefaultValue::Signed(-7)),
        ),
        (2, Var::new("Real", DataType::Real32).access(Access::ReadWrite).default(DefaultValue::Real(1.5))),
    ];

    static TABLE: [Object; 4] = layout([
        Object::var(
            0x2000,
            "Text",
            Var::new("Text", DataType::VisibleString)
                .access(Access::ReadWrite)
                .capacity(8)
                .default(DefaultValue::Text("abc")),
        ),
        Object::array(
            0x2001,
            "Array",
            3,
            &Var::new("Element", DataType::Unsigned16)
                .access(Access::ReadWrite)
                .default(DefaultValue::Unsigned(0xBEEF)),
        ),
        Object::record(0x2002, "Record", &SUBS),
        Object::var(
            0x2003,
            "Node",
            Var::new("Node", DataType::Unsigned32).default(DefaultValue::NodeIdPlus(0x180)),
        ),
    ]);

    fn dict() -> Dictionary<256> {
        Dictionary::new(&[&TABLE], DeviceInfo::servo_drive(), 9).unwrap()
    }

    #[test]
    fn defaults_and_typed_access() {
        let mut od = dict();
        assert_eq!(od.get::<u16>(0x2001, 3), Ok(0xBEEF));
        assert_eq!(od.get::<u8>(0x2001, 0), Ok(3));
        assert_eq!(od.get::<u32>(0x2003, 0), Ok(0x189));
        assert_eq!(od.get::<f32>(0x2002, 2), Ok(1.5));
        assert_eq!(od.get::<u32>(0x2001, 1), Err(AbortCode::LengthMismatch));
        assert_eq!(od.get::<u16>(0x2001, 4), Err(AbortCode::SubIndexDoesNotExist));
        assert_eq!(od.get::<u16>(0x2100, 0), Err(AbortCode::ObjectDoesNotExist));
        od.set::<u16>(0x2001, 2, 7).unwrap();
        assert_eq!(od.get::<u16>(0x2001, 1), Ok(0xBEEF), "neighbours untouched");
        assert_eq!(od.get::<u16>(0x2001, 2), Ok(7));
        // A constant never changes.
        od.set::<u8>(0x2001, 0, 9).unwrap();
        assert_eq!(od.get::<u8>(0x2001, 0), Ok(3));
        od.reset(0x2001..=0x2001);
        assert_eq!(od.get::<u16>(0x2001, 2), Ok(0xBEEF));
    }

    #[test]
    fn int_slots_read_and_write_at_the_entrys_width() {
        let mut od = dict();
        // INTEGER24, default −7: sign-extended from three bytes.
        let s24 = od.int_slot(0x2002, 1);
        assert!(s24.is_stored());
        assert_eq!(od.load_int(s24), -7);
        od.store_int(s24, -8_388_609);
        assert_eq!(od.load_int(s24), -8_388_608, "saturated to the width");
        od.store_int(s24, 123_456);
        assert_eq!(od.get::<u32>(0x2002, 1).ok(), None, "three bytes, not four");
        assert_eq!(od.load_int(IntSlot::lookup(0x2002, 1)), 123_456, "the lookup answers alike");
        // An unsigned description of the bytes reads them as signed (the core's meaning).
        let u16_slot = od.int_slot(0x2001, 1);
        assert_eq!(od.load_int(u16_slot), -16_657); // 0xBEEF
        od.store_int(u16_slot, 40_000);
        assert_eq!(od.get::<u16>(0x2001, 1), Ok(0x7FFF));
        // Not an integer, or missing: 0, and nothing written.
        let real = od.int_slot(0x2002, 2);
        assert!(!real.is_stored());
        od.store_int(real, 5);
        assert_eq!((od.load_int(real), od.get::<f32>(0x2002, 2)), (0, Ok(1.5)));
        assert_eq!(od.load_int(od.int_slot(0x2100, 0)), 0);
    }

    #[test]
    fn strings_keep_their_length() {
        let mut od = dict();
        let entry = od.entry(0x2000, 0).unwrap();
        assert_eq!(od.value_len(&entry), 3);
        assert_eq!(od.check_write(&entry, b"123456789"), Err(AbortCode::LengthTooHigh));
        od.check_write(&entry, b"12345").unwrap();
        od.commit(&entry, b"12345");
        let mut buf = [0u8; 16];
        assert_eq!(od.read(&entry, 0, &mut buf), 5);
        assert_eq!(&buf[..5], b"12345");
        assert_eq!(od.read(&entry, 3, &mut buf), 2);
        assert_eq!(&buf[..2], b"45");
        assert_eq!(od.read(&entry, 9, &mut buf), 0);
    }

    #[test]
    fn limits_of_signed_24_bit_and_real() {
        let od = dict();
        let s24 = od.entry(0x2002, 1).unwrap();
        assert_eq!(od.check_write(&s24, &1001i32.to_le_bytes()[..3]), Err(AbortCode::ValueTooHigh));
        assert_eq!(od.check_write(&s24, &(-1001i32).to_le_bytes()[..3]), Err(AbortCode::ValueTooLow));
        assert_eq!(od.check_write(&s24, &(-1000i32).to_le_bytes()[..3]), Ok(()));
        assert_eq!(od.check_write(&s24, &[0, 0]), Err(AbortCode::LengthTooLow));
        let real = od.entry(0x2002, 2).unwrap();
        assert_eq!(od.check_write(&real, &f32::NAN.to_le_bytes()), Err(AbortCode::InvalidValue));
        assert_eq!(od.check_write(&real, &2.0f32.to_le_bytes()), Ok(()));
    }

    #[test]
    fn bad_tables_are_refused() {
        static UNSORTED: [Object; 2] = layout([
            Object::var(0x2001, "b", Var::new("b", DataType::Unsigned8)),
            Object::var(0x2000, "a", Var::new("a", DataType::Unsigned8)),
        ]);
        static NOT_LAID_OUT: [Object; 2] = [
            Object::var(0x2000, "a", Var::new("a", DataType::Unsigned8)),
            Object::var(0x2001, "b", Var::new("b", DataType::Unsigned8)),
        ];
        let info = DeviceInfo::servo_drive();
        assert_eq!(
            Dictionary::<64>::new(&[&UNSORTED], info, 1).err(),
            Some(ConfigError::NotSorted { index: 0x2000 })
        );
        assert_eq!(
            Dictionary::<64>::new(&[&NOT_LAID_OUT], info, 1).err(),
            Some(ConfigError::NotLaidOut { index: 0x2001 })
        );
        assert_eq!(
            Dictionary::<64>::new(&[&TABLE, &TABLE], info, 1).err(),
            Some(ConfigError::NotSorted { index: 0x2000 })
        );
        assert_eq!(
            Dictionary::<8>::new(&[&TABLE], info, 1).err(),
            Some(ConfigError::StorageTooSmall { needed: 27 })
        );
        let too_many: [&'static [Object]; 7] = [&[]; 7];
        assert_eq!(Dictionary::<8>::new(&too_many, info, 1).err(), Some(ConfigError::TooManyTables));
    }

    #[test]
    fn overridden_defaults_hold_at_power_on_and_after_a_reset() {
        static OVERRIDES: [DefaultOverride; 3] = [
            DefaultOverride { index: 0x2001, sub: 2, value: DefaultValue::Unsigned(7) },
            DefaultOverride { index: 0x2000, sub: 0, value: DefaultValue::Text("xy") },
            DefaultOverride { index: 0x2003, sub: 0, value: DefaultValue::NodeIdPlus(0x100) },
        ];
        let mut od = dict();
        od.set_default_overrides(&OVERRIDES).unwrap();
        assert_eq!(od.get::<u16>(0x2001, 1), Ok(0xBEEF), "not overridden");
        assert_eq!(od.get::<u16>(0x2001, 2), Ok(7));
        assert_eq!(od.get::<u32>(0x2003, 0), Ok(0x109));
        let text = od.entry(0x2000, 0).unwrap();
        assert_eq!(od.value_len(&text), 2);
        od.set::<u16>(0x2001, 2, 1).unwrap();
        od.reset(0x2001..=0x2001);
        assert_eq!(od.get::<u16>(0x2001, 2), Ok(7), "a reset restores the firmware's default");
        let var = od.entry(0x2001, 2).unwrap().var;
        assert_eq!(od.default_of(0x2001, 2, var), DefaultValue::Unsigned(7));
        assert_eq!(od.default_of(0x2001, 3, var), DefaultValue::Unsigned(0xBEEF));

        // Entries that do not exist, and values that do not fit, are refused.
        static MISSING: [DefaultOverride; 1] =
            [DefaultOverride { index: 0x2001, sub: 9, value: DefaultValue::Unsigned(1) }];
        static TOO_LONG: [DefaultOverride; 1] =
            [DefaultOverride { index: 0x2000, sub: 0, value: DefaultValue::Text("123456789") }];
        static NOT_TEXT: [DefaultOverride; 1] =
            [DefaultOverride { index: 0x2001, sub: 1, value: DefaultValue::Text("1") }];
        let refused = [
            (&MISSING, ConfigError::NoSuchEntry { index: 0x2001, sub: 9 }),
            (&TOO_LONG, ConfigError::DefaultType { index: 0x2000, sub: 0 }),
            (&NOT_TEXT, ConfigError::DefaultType { index: 0x2001, sub: 1 }),
        ];
        for (bad, error) in refused {
            assert_eq!(dict().set_default_overrides(bad), Err(error));
        }
    }

    #[test]
    fn lookups_across_tables() {
        let od = Dictionary::<4096>::new(&[&standard::COMMUNICATION, &TABLE], DeviceInfo::servo_drive(), 3)
            .unwrap();
        assert_eq!(od.get::<u32>(0x1000, 0), Ok(0x0002_0192));
        assert_eq!(od.get::<u32>(0x1200, 2), Ok(0x583));
        assert_eq!(od.get::<u16>(0x2001, 1), Ok(0xBEEF));
        assert!(od.objects().map(|o| o.index).is_sorted());
        assert_eq!(od.entry(0x1FFF, 0).err(), Some(AbortCode::ObjectDoesNotExist));
        assert_eq!(od.entry(0x0000, 0).err(), Some(AbortCode::ObjectDoesNotExist));
        assert_eq!(od.entry(0xFFFF, 0).err(), Some(AbortCode::ObjectDoesNotExist));
    }

    /// A device-profile table of two objects, attached once per logical device.
    static DEVICE: [Object; 2] = layout([
        Object::var(
            0x6040,
            "Word",
            Var::new("Word", DataType::Unsigned16)
                .access(Access::ReadWrite)
                .default(DefaultValue::Unsigned(7)),
        ),
        Object::var(
            0x67FF,
            "Type",
            Var::new("Type", DataType::Unsigned32)
                .access(Access::Const)
                .default(DefaultValue::Device(DeviceField::LogicalDeviceType)),
        ),
    ]);

    #[test]
    fn copies_of_a_table_are_devices_of_their_own() {
        extern crate std;
        let tables: [&'static [Object]; 2] = [&TABLE, &DEVICE];
        let mut od = Dictionary::<4096>::empty(DeviceInfo::servo_drive(), 3);
        od.attach_copies(&tables, &[1, 8]).unwrap();
        assert_eq!(od.devices(), 8);
        assert_eq!(od.used_bytes(), TABLE.iter().map(Object::storage_size).sum::<usize>() + 8 * 2);
        // Device n's objects at 6040h + n × 800h, each its own value; nothing beyond the eighth.
        for n in 0..8u16 {
            assert_eq!(od.get::<u16>(0x6040 + n * 0x800, 0), Ok(7));
            od.set::<u16>(0x6040 + n * 0x800, 0, 100 + n).unwrap();
            assert_eq!(od.get::<u32>(0x67FF + n * 0x800, 0), Ok(0x0002_0192), "each device's own type");
            assert_eq!(od.copy_of(0x6040 + n * 0x800), n as u8);
        }
        for n in 0..8u16 {
            assert_eq!(od.get::<u16>(0x6040 + n * 0x800, 0), Ok(100 + n));
        }
        assert_eq!(od.get::<u32>(0x9FFF, 0), Ok(0x0002_0192), "the eighth device's last object");
        for missing in [0x6041, 0x6841, 0x6000, 0x67FE, 0xA040, 0xFFFF] {
            assert_eq!(od.entry(missing, 0).err(), Some(AbortCode::ObjectDoesNotExist), "{missing:04X}h");
        }
        assert_eq!(od.entry(0x6840, 0).map(|e| e.index()), Ok(0x6840));
        let indices: std::vec::Vec<u16> = od.objects().map(|o| o.index).collect();
        assert!(indices.is_sorted() && indices.len() == TABLE.len() + 16, "{indices:x?}");
        // 1000h of a node of several devices: the multi-device marker, the first device's profile.
        assert_eq!(od.device_type(), 0xFFFF_0192);
        od.reset(0x6800..=0x6FFF);
        assert_eq!(
            (od.get::<u16>(0x6040, 0), od.get::<u16>(0x6840, 0)),
            (Ok(100), Ok(7)),
            "one device reset"
        );
        let parameters: std::vec::Vec<u16> = od.parameters(0x6000..=0x9FFF).map(|e| e.index()).collect();
        assert_eq!(parameters, (0..8).map(|n| 0x6040 + n * 0x800).collect::<std::vec::Vec<u16>>());

        // Refused: no copies, more than eight, a table wider than one stride.
        let mut od = Dictionary::<4096>::empty(DeviceInfo::servo_drive(), 3);
        assert_eq!(od.attach_copies(&tables, &[1, 9]), Err(ConfigError::BadCopies { index: 0x6040 }));
        assert_eq!(od.attach_copies(&tables, &[1, 0]), Err(ConfigError::BadCopies { index: 0x6040 }));
        static WIDE: [Object; 2] = layout([DEVICE[0], DEVICE[0].at(0x6840)]);
        assert_eq!(od.attach_copies(&[&WIDE], &[2]), Err(ConfigError::BadCopies { index: 0x6040 }));
        assert_eq!(od.attach_copies(&[&WIDE], &[1]), Ok(()));
        let single = Dictionary::<4096>::new(&tables, DeviceInfo::servo_drive(), 3).unwrap();
        assert_eq!((single.devices(), single.device_type()), (1, 0x0002_0192));
    }
}

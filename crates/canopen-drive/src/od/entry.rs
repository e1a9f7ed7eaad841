//! The description of an object: one `static` table of [`Object`]s is the single source of truth
//! from which the dictionary's storage, its access checks and the EDS file are all derived.
//!
//! Tables are written with `const fn` builders and laid out by [`layout`] at compile time:
//!
//! ```
//! use canopen_drive::od::{layout, Access, DataType, DefaultValue, Object, Var};
//! static VENDOR_OBJECTS: [Object; 1] = layout([Object::var(
//!     0x2000,
//!     "Motor pole pairs",
//!     Var::new("Motor pole pairs", DataType::Unsigned8)
//!         .access(Access::ReadWrite)
//!         .default(DefaultValue::Unsigned(4))
//!         .limits_unsigned(1, 32),
//! )]);
//! # assert_eq!(VENDOR_OBJECTS[0].index, 0x2000);
//! ```

/// CiA 301 basic data types (CiA 301 §7.1.6); the discriminant is the data-type index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u16)]
pub enum DataType {
    /// 0x0001 BOOLEAN (one byte, 0 or 1).
    Boolean = 0x0001,
    /// 0x0002 INTEGER8.
    Integer8 = 0x0002,
    /// 0x0003 INTEGER16.
    Integer16 = 0x0003,
    /// 0x0004 INTEGER32.
    Integer32 = 0x0004,
    /// 0x0005 UNSIGNED8.
    Unsigned8 = 0x0005,
    /// 0x0006 UNSIGNED16.
    Unsigned16 = 0x0006,
    /// 0x0007 UNSIGNED32.
    Unsigned32 = 0x0007,
    /// 0x0008 REAL32 (IEEE 754 binary32).
    Real32 = 0x0008,
    /// 0x0009 VISIBLE_STRING (no terminator; length = transferred length).
    VisibleString = 0x0009,
    /// 0x000A OCTET_STRING.
    OctetString = 0x000A,
    /// 0x000B UNICODE_STRING (UTF-16 code units).
    UnicodeString = 0x000B,
    /// 0x000C TIME_OF_DAY (6 bytes).
    TimeOfDay = 0x000C,
    /// 0x000D TIME_DIFFERENCE (6 bytes).
    TimeDifference = 0x000D,
    /// 0x000F DOMAIN (opaque block).
    Domain = 0x000F,
    /// 0x0010 INTEGER24.
    Integer24 = 0x0010,
    /// 0x0011 REAL64 (IEEE 754 binary64).
    Real64 = 0x0011,
    /// 0x0012 INTEGER40.
    Integer40 = 0x0012,
    /// 0x0013 INTEGER48.
    Integer48 = 0x0013,
    /// 0x0014 INTEGER56.
    Integer56 = 0x0014,
    /// 0x0015 INTEGER64.
    Integer64 = 0x0015,
    /// 0x0016 UNSIGNED24.
    Unsigned24 = 0x0016,
    /// 0x0018 UNSIGNED40.
    Unsigned40 = 0x0018,
    /// 0x0019 UNSIGNED48.
    Unsigned48 = 0x0019,
    /// 0x001A UNSIGNED56.
    Unsigned56 = 0x001A,
    /// 0x001B UNSIGNED64.
    Unsigned64 = 0x001B,
}

impl DataType {
    /// Size in bytes of a fixed-size type; `None` for strings and DOMAIN.
    // Every discriminant is below the table's length (the indices of a const loop too).
    #[allow(clippy::indexing_slicing)]
    #[inline]
    pub const fn fixed_size(self) -> Option<usize> {
        // One load from a table by the data-type index (all are below 0x1C).
        const SIZES: [u8; 0x1C] = {
            let mut sizes = [0u8; 0x1C];
            let all = [
                DataType::Boolean,
                DataType::Integer8,
                DataType::Integer16,
                DataType::Integer32,
                DataType::Unsigned8,
                DataType::Unsigned16,
                DataType::Unsigned32,
                DataType::Real32,
                DataType::VisibleString,
                DataType::OctetString,
                DataType::UnicodeString,
                DataType::TimeOfDay,
                DataType::TimeDifference,
                DataType::Domain,
                DataType::Integer24,
                DataType::Real64,
                DataType::Integer40,
                DataType::Integer48,
                DataType::Integer56,
                DataType::Integer64,
                DataType::Unsigned24,
                DataType::Unsigned40,
                DataType::Unsigned48,
                DataType::Unsigned56,
                DataType::Unsigned64,
            ];
            let mut i = 0;
            while i < all.len() {
                if let Some(n) = all[i].size_by_type() {
                    sizes[all[i] as usize] = n as u8;
                }
                i += 1;
            }
            sizes
        };
        match SIZES[self as usize] {
            0 => None,
            n => Some(n as usize),
        }
    }

    /// [`fixed_size`](Self::fixed_size) by the type's definition.
    const fn size_by_type(self) -> Option<usize> {
        use DataType::*;
        Some(match self {
            Boolean | Integer8 | Unsigned8 => 1,
            Integer16 | Unsigned16 => 2,
            Integer24 | Unsigned24 => 3,
            Integer32 | Unsigned32 | Real32 => 4,
            Integer40 | Unsigned40 => 5,
            Integer48 | Unsigned48 | TimeOfDay | TimeDifference => 6,
            Integer56 | Unsigned56 => 7,
            Integer64 | Unsigned64 | Real64 => 8,
            VisibleString | OctetString | UnicodeString | Domain => return None,
        })
    }

    /// True for the two's-complement integer types.
    pub const fn is_signed(self) -> bool {
        use DataType::*;
        matches!(
            self,
            Integer8 | Integer16 | Integer24 | Integer32 | Integer40 | Integer48 | Integer56 | Integer64
        )
    }

    /// True for the unsigned integer types and BOOLEAN.
    pub const fn is_unsigned(self) -> bool {
        use DataType::*;
        matches!(
            self,
            Boolean
                | Unsigned8
                | Unsigned16
                | Unsigned24
                | Unsigned32
                | Unsigned40
                | Unsigned48
                | Unsigned56
                | Unsigned64
        )
    }

    /// True for the variable-length types whose writes may be shorter than the storage.
    pub const fn is_variable(self) -> bool {
        self.fixed_size().is_none()
    }
}

/// SDO access of an entry (EDS `AccessType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Access {
    /// Read only; the device may change the value.
    ReadOnly,
    /// Write only.
    WriteOnly,
    /// Read and write.
    ReadWrite,
    /// Constant: read only, never changes, takes no RAM.
    Const,
}

impl Access {
    /// SDO upload allowed.
    pub const fn readable(self) -> bool {
        !matches!(self, Access::WriteOnly)
    }
    /// SDO download allowed.
    pub const fn writable(self) -> bool {
        matches!(self, Access::WriteOnly | Access::ReadWrite)
    }
}

/// Whether an entry may be mapped into PDOs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PdoMapping {
    /// Not mappable.
    No,
    /// Receive PDOs only (the master writes it as process data).
    Rpdo,
    /// Transmit PDOs only (the drive sends it as process data).
    Tpdo,
    /// Both directions.
    Both,
}

/// NMT states in which SDO writes to an entry are accepted (CiA 301 §7.3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WriteRule {
    /// Whenever SDO is served.
    Always,
    /// Only outside Operational; in Operational the write is refused with 0x0800_0022.
    NotOperational,
    /// Only while the CiA 402 state machine is in Switch on disabled (or still Not ready to
    /// switch on); in any other state the write is refused with 0x0800_0022. CiA 402 has no
    /// such rule; it is for parameters a device lets change only with the power stage off.
    SwitchOnDisabled,
}

/// A low or high limit of a numeric entry.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Bound {
    /// No limit beyond the data type's own range.
    None,
    /// A limit for a signed integer type.
    Signed(i64),
    /// A limit for an unsigned integer type.
    Unsigned(u64),
    /// A limit for REAL32/REAL64.
    Real(f64),
}

impl Bound {
    /// The kind (0 none, 1 signed, 2 unsigned, 3 real) and the raw value.
    const fn encode(self) -> (u8, u64) {
        match self {
            Bound::None => (0, 0),
            Bound::Signed(v) => (1, v as u64),
            Bound::Unsigned(v) => (2, v),
            Bound::Real(v) => (3, v.to_bits()),
        }
    }

    const fn decode(kind: u8, raw: u64) -> Self {
        match kind {
            1 => Bound::Signed(raw as i64),
            2 => Bound::Unsigned(raw),
            3 => Bound::Real(f64::from_bits(raw)),
            _ => Bound::None,
        }
    }
}

/// Fields of the device description that defaults may refer to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DeviceField {
    /// 1000h device type (on a node of several logical devices: FFFFh, the multi-device
    /// marker, in the additional information, and the first device's profile number).
    DeviceType,
    /// 67FFh + n × 800h: the device type of one logical device of a multi-axis node (the
    /// single-device value of 1000h, [`DeviceInfo::device_type`](super::DeviceInfo)).
    LogicalDeviceType,
    /// 1018h sub 1 vendor-ID.
    VendorId,
    /// 1018h sub 2 product code.
    ProductCode,
    /// 1018h sub 3 revision number.
    RevisionNumber,
    /// 1018h sub 4 serial number.
    SerialNumber,
    /// 1008h manufacturer device name.
    DeviceName,
    /// 1009h manufacturer hardware version.
    HardwareVersion,
    /// 100Ah manufacturer software version.
    SoftwareVersion,
    /// 1021h the device's EDS file.
    Eds,
    /// 6502h supported drive modes.
    DriveModes,
    /// 60E3h sub 0: how many homing methods the configuration supports.
    HomingMethodCount,
    /// 60E3h sub 1..: the supported homing methods, ascending (each sub-index its own).
    HomingMethods,
}

/// The power-on value of an entry (before stored parameters are applied).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DefaultValue {
    /// Zero / empty.
    Zero,
    /// An unsigned integer (also BOOLEAN).
    Unsigned(u64),
    /// A signed integer.
    Signed(i64),
    /// A REAL32 or REAL64 value.
    Real(f64),
    /// Text for VISIBLE_STRING.
    Text(&'static str),
    /// Bytes for OCTET_STRING and DOMAIN.
    Bytes(&'static [u8]),
    /// The node-ID plus this value (EDS `$NODEID+0x...`), e.g. 0x580 for the SDO tx COB-ID.
    NodeIdPlus(u32),
    /// A field of the device description given at start-up (identity, names, EDS).
    Device(DeviceField),
    /// The value of the pre-defined PDO set for this PDO record entry (COB-ID, transmission
    /// type, mapping of PDOs 1–4; see [`od::standard::pdo_preset`](crate::od::standard::pdo_preset)),
    /// resolved from the index and sub-index.
    PdoPreset,
}

/// A name for the EDS, kept only with the `names` feature: without it the description holds no
/// string (not even an empty one's pointer), which saves 8 bytes per entry and object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct Name(#[cfg(feature = "names")] &'static str);

impl Name {
    #[allow(unused_variables)]
    const fn new(name: &'static str) -> Self {
        Name(
            #[cfg(feature = "names")]
            name,
        )
    }

    /// The name ("" without the `names` feature).
    const fn get(&self) -> &'static str {
        #[cfg(feature = "names")]
        return self.0;
        #[cfg(not(feature = "names"))]
        ""
    }
}

/// One value of the dictionary: a VAR, or one sub-index of an ARRAY or RECORD.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Var {
    /// Parameter name as written to the EDS ([`Var::name`]).
    name: Name,
    /// CiA 301 data type.
    pub data_type: DataType,
    /// SDO access.
    pub access: Access,
    /// PDO mappability.
    pub pdo: PdoMapping,
    /// The raw values of the low and the high limit ([`Var::low`], [`Var::high`]): two words and
    /// a byte of kinds instead of two 16-byte enums (a dictionary has hundreds of entries).
    limits: [u64; 2],
    /// The kinds of the limits: bits 0–1 the low one, bits 2–3 the high one ([`Bound`]'s
    /// order: none, signed, unsigned, real).
    limit_kinds: u8,
    /// Power-on value.
    pub default: DefaultValue,
    /// Storage in bytes for VISIBLE_STRING, OCTET_STRING, UNICODE_STRING and DOMAIN. For a
    /// numeric type: the bytes its value may take when a firmware widens the entry (an
    /// [`EntryOverride`](super::EntryOverride) to a larger integer type of the same
    /// signedness, e.g. a torque as INTEGER32); 0 or its size: not widenable.
    pub capacity: u16,
    /// NMT states in which SDO writes are accepted.
    pub rule: WriteRule,
}

impl Var {
    /// A read-only entry of type `data_type` with default zero, no limits, not mappable.
    pub const fn new(name: &'static str, data_type: DataType) -> Self {
        Var {
            name: Name::new(name),
            data_type,
            access: Access::ReadOnly,
            pdo: PdoMapping::No,
            limits: [0; 2],
            limit_kinds: 0,
            default: DefaultValue::Zero,
            capacity: 0,
            rule: WriteRule::Always,
        }
    }
    /// Sets the SDO access.
    pub const fn access(mut self, access: Access) -> Self {
        self.access = access;
        self
    }
    /// Sets the PDO mappability.
    pub const fn pdo(mut self, pdo: PdoMapping) -> Self {
        self.pdo = pdo;
        self
    }
    /// Sets the power-on value.
    pub const fn default(mut self, default: DefaultValue) -> Self {
        self.default = default;
        self
    }
    /// Sets inclusive limits for an unsigned type.
    pub const fn limits_unsigned(self, low: u64, high: u64) -> Self {
        self.limits(Bound::Unsigned(low), Bound::Unsigned(high))
    }
    /// Sets inclusive limits for a signed type.
    pub const fn limits_signed(self, low: i64, high: i64) -> Self {
        self.limits(Bound::Signed(low), Bound::Signed(high))
    }

    /// Sets both limits (either may be [`Bound::None`]).
    pub const fn limits(mut self, low: Bound, high: Bound) -> Self {
        let (low_kind, low_raw) = low.encode();
        let (high_kind, high_raw) = high.encode();
        self.limits = [low_raw, high_raw];
        self.limit_kinds = low_kind | high_kind << 2;
        self
    }

    /// The lowest accepted value.
    pub const fn low(&self) -> Bound {
        Bound::decode(self.limit_kinds & 3, self.limits[0])
    }

    /// The highest accepted value.
    pub const fn high(&self) -> Bound {
        Bound::decode(self.limit_kinds >> 2 & 3, self.limits[1])
    }

    /// Whether either limit is set.
    pub const fn has_bounds(&self) -> bool {
        self.limit_kinds != 0
    }

    /// The parameter name as written to the EDS ("" without the `names` feature).
    pub const fn name(&self) -> &'static str {
        self.name.get()
    }
    /// Sets the storage size of a string or DOMAIN entry, or the bytes a numeric entry may be
    /// widened to ([`Var::capacity`](Var#structfield.capacity)).
    pub const fn capacity(mut self, bytes: u16) -> Self {
        self.capacity = bytes;
        self
    }
    /// Sets the NMT states in which SDO writes are accepted.
    pub const fn rule(mut self, rule: WriteRule) -> Self {
        self.rule = rule;
        self
    }

    /// True when the value is the default forever (constants and identity fields): such
    /// entries take no RAM.
    pub const fn is_fixed(&self) -> bool {
        matches!(self.access, Access::Const) || matches!(self.default, DefaultValue::Device(_))
    }

    /// Bytes of RAM the entry takes in the dictionary's store.
    pub const fn storage_size(&self) -> usize {
        if self.is_fixed() {
            return 0;
        }
        match self.data_type.fixed_size() {
            Some(n) if n < self.capacity as usize => self.capacity as usize,
            Some(n) => n,
            // A two-byte length prefix, then the capacity.
            None => 2 + self.capacity as usize,
        }
    }

    /// Whether the entry may be widened: a numeric entry whose storage is larger than its
    /// type ([`Var::capacity`](Var#structfield.capacity)).
    pub const fn is_widenable(&self) -> bool {
        match self.data_type.fixed_size() {
            Some(n) => n < self.capacity as usize,
            None => false,
        }
    }
}

/// How an object's sub-indices are organised (EDS `ObjectType`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Kind {
    /// A single value at sub-index 0 (object code 0x7).
    Var(Var),
    /// Sub 0 = count, subs 1..=len of the same type (object code 0x8). Element names get the
    /// sub-index appended.
    Array {
        /// Sub-index 0.
        sub0: Var,
        /// Description shared by subs 1..=len (a reference: an object is as large as its
        /// largest kind, and every object of a table pays for it).
        element: &'static Var,
        /// Highest sub-index.
        len: u8,
    },
    /// Sub-indices of different types, sorted by sub-index, sub 0 included (object code 0x9).
    Record(&'static [(u8, Var)]),
}

/// The module of the crate that rules an object's values beyond type and limits and reacts to
/// its writes (the role of CANopenNode's OD extensions). The dictionary only carries the tag:
/// the composer ([`crate::Drive`]) hands a write from the bus to the owner's own check, and the
/// value, once stored, to the owner's reaction. An object without an owner is a plain value
/// (the firmware's [`ObjectHooks`](super::ObjectHooks) still see it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
#[non_exhaustive]
pub enum Owner {
    /// No rule beyond type, access and limits.
    #[default]
    Dictionary,
    /// The EMCY producer (`comm::emcy`): 1014h, 1015h.
    Emcy,
    /// The error history (`comm::emcy`): 1003h.
    ErrorHistory,
    /// The error behaviour (`comm::error_control`): 1029h.
    ErrorBehaviour,
    /// SYNC (`comm::sync`): 1005h, 1006h, 1019h.
    Sync,
    /// The heartbeat producer (`comm::heartbeat`): 1017h.
    HeartbeatProducer,
    /// The heartbeat consumer (`comm::error_control`): 1016h.
    HeartbeatConsumer,
    /// Node guarding (`comm::error_control`): 100Ch, 100Dh.
    Guarding,
    /// The PDO records (`comm::pdo`): 1400h–1BFFh.
    Pdo,
    /// Store and restore on command (`storage`): 1010h, 1011h.
    Storage,
    /// Program download (`comm::program`): 1F50h, 1F51h, 1F56h, 1F57h.
    Program,
    /// The CiA 402 drive profile (`cia402`): its objects and the cascade's.
    Profile,
}

/// One object (one index) of the dictionary.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Object {
    /// Index (0x1000..=0xFFFF).
    pub index: u16,
    /// Object name as written to the EDS ([`Object::name`]).
    name: Name,
    /// Sub-index organisation.
    pub kind: Kind,
    /// Offset of the object's first stored byte inside its table's region; set by [`layout`].
    pub base: u16,
    /// Instance number appended to the name in the EDS (e.g. "RPDO communication parameter 3");
    /// 0 = none.
    pub number: u16,
    /// The module that rules the object's values and reacts to its writes.
    pub owner: Owner,
}

impl Object {
    /// An object of `kind`: no instance number, no owner, its store offset set later by [`layout`].
    const fn of(index: u16, name: &'static str, kind: Kind) -> Self {
        Object { index, name: Name::new(name), kind, base: 0, number: 0, owner: Owner::Dictionary }
    }

    /// The same description at `index` (a copy of a logical device's object, e.g. CiA 402
    /// axis n's at the first axis's index + n × 800h).
    pub const fn at(mut self, index: u16) -> Object {
        self.index = index;
        self
    }

    /// A VAR object.
    pub const fn var(index: u16, name: &'static str, var: Var) -> Self {
        Object::of(index, name, Kind::Var(var))
    }
    /// An ARRAY object with a read-only sub 0 holding `len`.
    /// In a `static` or `const` table `&Var::new(..)` is a `'static` reference.
    pub const fn array(index: u16, name: &'static str, len: u8, element: &'static Var) -> Self {
        let sub0 = Var::new("Highest sub-index supported", DataType::Unsigned8)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(len as u64));
        Object::array_with_sub0(index, name, len, sub0, element)
    }
    /// An ARRAY object with a custom sub 0 (e.g. a writable count).
    pub const fn array_with_sub0(
        index: u16,
        name: &'static str,
        len: u8,
        sub0: Var,
        element: &'static Var,
    ) -> Self {
        Object::of(index, name, Kind::Array { sub0, element, len })
    }
    /// A RECORD object; `subs` sorted by sub-index, sub 0 included.
    pub const fn record(index: u16, name: &'static str, subs: &'static [(u8, Var)]) -> Self {
        Object::of(index, name, Kind::Record(subs))
    }

    /// The object name as written to the EDS ("" without the `names` feature).
    pub const fn name(&self) -> &'static str {
        self.name.get()
    }

    /// The same object, ruled by `owner`.
    pub const fn owned_by(mut self, owner: Owner) -> Self {
        self.owner = owner;
        self
    }

    /// The same object with an instance number for its EDS name.
    pub const fn numbered(mut self, number: u16) -> Self {
        self.number = number;
        self
    }

    /// Bytes of RAM the whole object takes.
    // The loop index is bounded by `subs.len()`; `get` is not usable in a const fn.
    #[allow(clippy::indexing_slicing)]
    pub const fn storage_size(&self) -> usize {
        match &self.kind {
            Kind::Var(v) => v.storage_size(),
            Kind::Array { sub0, element, len } => {
                sub0.storage_size() + element.storage_size() * (*len as usize)
            }
            Kind::Record(subs) => {
                let mut total = 0;
                let mut i = 0;
                while i < subs.len() {
                    total += subs[i].1.storage_size();
                    i += 1;
                }
                total
            }
        }
    }

    /// The description of sub-index `sub` and its byte offset inside the object's storage.
    #[inline]
    pub fn sub(&self, sub: u8) -> Option<(&Var, usize)> {
        match &self.kind {
            Kind::Var(v) => (sub == 0).then_some((v, 0)),
            Kind::Array { sub0, element, len } => match sub {
                0 => Some((sub0, 0)),
                s if s <= *len => {
                    Some((element, sub0.storage_size() + element.storage_size() * usize::from(s - 1)))
                }
                _ => None,
            },
            Kind::Record(subs) => {
                let mut offset = 0;
                for (s, v) in subs.iter() {
                    if *s == sub {
                        return Some((v, offset));
                    }
                    offset += v.storage_size();
                }
                None
            }
        }
    }

    /// Highest sub-index (0 for a VAR).
    pub fn highest_sub(&self) -> u8 {
        match &self.kind {
            Kind::Var(_) => 0,
            Kind::Array { len, .. } => *len,
            Kind::Record(subs) => subs.last().map_or(0, |(s, _)| *s),
        }
    }
}

/// Every object of `objects` ruled by `owner` (a module's whole table).
// The loop index is bounded by `N`; `get_mut` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
pub const fn owned<const N: usize>(owner: Owner, mut objects: [Object; N]) -> [Object; N] {
    let mut i = 0;
    while i < N {
        objects[i].owner = owner;
        i += 1;
    }
    objects
}

/// Lays a table out: gives each object its storage offset inside the table's region.
/// The dictionary refuses a table that was not laid out (see
/// [`ConfigError::NotLaidOut`](super::ConfigError::NotLaidOut)).
// The loop index is bounded by `N`; `get_mut` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
pub const fn layout<const N: usize>(mut objects: [Object; N]) -> [Object; N] {
    let mut offset = 0usize;
    let mut i = 0;
    while i < N {
        objects[i].base = offset as u16;
        offset += objects[i].storage_size();
        i += 1;
    }
    objects
}

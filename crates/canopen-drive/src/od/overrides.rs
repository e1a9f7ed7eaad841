//! Description overrides: the firmware's own description of an entry of the crate's tables.
//!
//! A drive's documentation sometimes describes a standard object differently from CiA 301/402:
//! another data type of the same size (an option code as UNSIGNED16, a profile velocity as
//! INTEGER32), another access (a deceleration the drive derives itself, read-only), other PDO
//! mappability, limits or default. An [`EntryOverride`] replaces the description of one entry
//! (index and sub-index) for every user of the dictionary: SDO access checks, value limits,
//! PDO mapping, parameter storage and the EDS. The override is configuration
//! ([`crate::Config::entry_overrides`], empty by default: the standard descriptions).
//!
//! The layout of the value store and the core's own per-tick reads of an entry depend on its
//! size, so an override must keep it: same fixed size (or the same capacity for a string),
//! same storage (a constant stays a constant). The exception are entries whose table reserves
//! wider storage ([`Var::is_widenable`]; the core's torque values 6071h, 6074h, 6077h, 6078h and
//! 60B2h reserve 4 bytes): an integer of the same signedness up to that size, which the core
//! reads and writes at whatever width the entry has ([`Dictionary::int_slot`]).
//! [`Dictionary::set_entry_overrides`] refuses anything else with [`ConfigError::EntrySize`]. The bytes of a value are the same under the
//! old and the new type; only their meaning on the bus changes (an INTEGER16 −1 read through an
//! UNSIGNED16 description is 65 535).
//!
//! An override of sub-index 0 of an ARRAY or RECORD whose default is a constant count smaller
//! than the table's highest sub-index hides the entries above it (1016h with one consumer
//! entry, 1018h without the serial number): they answer 0x0609_0011 and leave the EDS.
//!
//! An override is built from the crate's own description and changed with `const fn`s, so it
//! can live in a `static`:
//!
//! ```
//! use canopen_drive::cia402::objects::SHUTDOWN_OPTION_CODE;
//! use canopen_drive::cia402::registry::PROFILE;
//! use canopen_drive::od::{DataType, EntryOverride};
//! static OVERRIDES: [EntryOverride; 1] =
//!     [EntryOverride::of(&PROFILE, SHUTDOWN_OPTION_CODE, 0).data_type(DataType::Unsigned16)];
//! # assert_eq!(OVERRIDES[0].var().map(|v| v.data_type), Some(DataType::Unsigned16));
//! ```

use super::{
    AbortCode, Access, Bound, ConfigError, DataType, DefaultValue, Dictionary, Kind, Object, PdoMapping, Var,
    WriteRule,
};

/// The firmware's description of entry `index`/`sub` of the crate's tables, replacing the
/// table's own, for every user of the dictionary ([`crate::Config::entry_overrides`]; it must
/// keep the entry's size, see [`ConfigError::EntrySize`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EntryOverride {
    index: u16,
    sub: u8,
    /// `None`: [`EntryOverride::of`] did not find the entry (refused when the dictionary is
    /// configured).
    var: Option<Var>,
}

impl EntryOverride {
    /// Describes `index`/`sub` as `var`.
    pub const fn new(index: u16, sub: u8, var: Var) -> Self {
        EntryOverride { index, sub, var: Some(var) }
    }

    /// Starts from the description of `index`/`sub` in `table` (e.g.
    /// [`crate::cia402::registry::PROFILE`]), to be changed by the other methods. An entry that
    /// `table` does not have makes an override the dictionary refuses
    /// ([`ConfigError::NoSuchEntry`]).
    pub const fn of(table: &[Object], index: u16, sub: u8) -> Self {
        EntryOverride { index, sub, var: find(table, index, sub) }
    }

    /// Index of the entry.
    pub const fn index(&self) -> u16 {
        self.index
    }

    /// Sub-index of the entry.
    pub const fn sub(&self) -> u8 {
        self.sub
    }

    /// The description, or `None` when [`of`](Self::of) did not find the entry.
    pub const fn var(&self) -> Option<&Var> {
        self.var.as_ref()
    }

    /// Another data type (of the same size, or the dictionary refuses the override). Limits and
    /// a default of the other signedness are carried over with the same bytes where they can
    /// be (a default of −1 becomes 65 535 in an UNSIGNED16), limits that cannot are dropped.
    pub const fn data_type(mut self, data_type: DataType) -> Self {
        if let Some(var) = &mut self.var {
            *var = var.limits(bound_as(var.low(), data_type), bound_as(var.high(), data_type));
            var.default = default_as(var.default, data_type);
            var.data_type = data_type;
        }
        self
    }

    /// Another SDO access (a constant must stay a constant: it has no storage).
    pub const fn access(mut self, access: Access) -> Self {
        if let Some(var) = &mut self.var {
            var.access = access;
        }
        self
    }

    /// Another PDO mappability.
    pub const fn pdo(mut self, pdo: PdoMapping) -> Self {
        if let Some(var) = &mut self.var {
            var.pdo = pdo;
        }
        self
    }

    /// Inclusive limits for an unsigned type.
    pub const fn limits_unsigned(mut self, low: u64, high: u64) -> Self {
        if let Some(var) = &mut self.var {
            *var = var.limits(Bound::Unsigned(low), Bound::Unsigned(high));
        }
        self
    }

    /// Inclusive limits for a signed type.
    pub const fn limits_signed(mut self, low: i64, high: i64) -> Self {
        if let Some(var) = &mut self.var {
            *var = var.limits(Bound::Signed(low), Bound::Signed(high));
        }
        self
    }

    /// Another power-on value.
    pub const fn default(mut self, default: DefaultValue) -> Self {
        if let Some(var) = &mut self.var {
            var.default = default;
        }
        self
    }

    /// Other NMT / drive states in which SDO writes are accepted.
    pub const fn rule(mut self, rule: WriteRule) -> Self {
        if let Some(var) = &mut self.var {
            var.rule = rule;
        }
        self
    }
}

/// The description of `index`/`sub` in `table`.
// The loop index is bounded by the slices' lengths; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
const fn find(table: &[Object], index: u16, sub: u8) -> Option<Var> {
    let mut i = 0;
    while i < table.len() {
        let object = &table[i];
        if object.index == index {
            return match &object.kind {
                Kind::Var(var) if sub == 0 => Some(*var),
                Kind::Var(_) => None,
                Kind::Array { sub0, .. } if sub == 0 => Some(*sub0),
                Kind::Array { element, len, .. } if sub <= *len => Some(**element),
                Kind::Array { .. } => None,
                Kind::Record(subs) => {
                    let mut k = 0;
                    while k < subs.len() {
                        if subs[k].0 == sub {
                            return Some(subs[k].1);
                        }
                        k += 1;
                    }
                    None
                }
            };
        }
        i += 1;
    }
    None
}

/// `bound` for an entry of `data_type`: a bound of the other signedness converted where the
/// value can be, else none.
const fn bound_as(bound: Bound, data_type: DataType) -> Bound {
    match bound {
        Bound::Signed(v) if data_type.is_unsigned() => {
            if v >= 0 {
                Bound::Unsigned(v as u64)
            } else {
                Bound::None
            }
        }
        Bound::Unsigned(v) if data_type.is_signed() => {
            if v <= i64::MAX as u64 {
                Bound::Signed(v as i64)
            } else {
                Bound::None
            }
        }
        other => other,
    }
}

/// `default` for an entry of `data_type`: the same bytes, read with the new signedness.
const fn default_as(default: DefaultValue, data_type: DataType) -> DefaultValue {
    let bits = match data_type.fixed_size() {
        Some(n) if n < 8 => 8 * n as u32,
        _ => 64,
    };
    match default {
        DefaultValue::Signed(v) if data_type.is_unsigned() => {
            let mask = if bits == 64 { u64::MAX } else { (1u64 << bits) - 1 };
            DefaultValue::Unsigned(v as u64 & mask)
        }
        DefaultValue::Unsigned(v) if data_type.is_signed() => {
            let shift = 64 - bits;
            DefaultValue::Signed(((v << shift) as i64) >> shift)
        }
        other => other,
    }
}

impl<const BYTES: usize> Dictionary<BYTES> {
    /// Replaces the descriptions of some entries with the firmware's ([`EntryOverride`]) and
    /// sets every value to its (new) default. Refused: an override of an entry that does not
    /// exist ([`ConfigError::NoSuchEntry`]) or whose description is wrong in itself (its
    /// default, its limits: [`check_table`](super::check_table)'s errors), and one that changes
    /// the entry's size or storage ([`ConfigError::EntrySize`]).
    pub fn set_entry_overrides(&mut self, overrides: &'static [EntryOverride]) -> Result<(), ConfigError> {
        for o in overrides {
            let missing = ConfigError::NoSuchEntry { index: o.index, sub: o.sub };
            let var = o.var.as_ref().ok_or(missing)?;
            let (object, _) = self.object(o.index).ok_or(missing)?;
            let (table, _) = object.sub(o.sub).ok_or(missing)?;
            // Another size only where the table reserved the storage, to an integer of the same
            // signedness (the core reads such entries whatever their width).
            let resized = var.data_type.fixed_size() != table.data_type.fixed_size();
            let widenable = table.is_widenable()
                && var.data_type.is_signed() == table.data_type.is_signed()
                && var.data_type.is_unsigned() == table.data_type.is_unsigned()
                && (var.data_type.is_signed() || var.data_type.is_unsigned());
            if (resized && !widenable)
                || var.storage_size() != table.storage_size()
                || var.is_fixed() != table.is_fixed()
            {
                return Err(ConfigError::EntrySize { index: o.index, sub: o.sub });
            }
            if let Err(problem) = super::check::check_var(var) {
                return Err(problem.at(o.index, o.sub));
            }
            let count = counted(o).filter(|_| o.sub == 0 && !matches!(object.kind, Kind::Var(_)));
            if count.is_some_and(|n| n > u64::from(object.highest_sub())) {
                return Err(ConfigError::DefaultOutsideLimits { index: o.index, sub: o.sub });
            }
        }
        self.entry_overrides = overrides;
        self.reset(0x0000..=0xFFFF);
        Ok(())
    }

    /// The description of `index`/`sub`: the firmware's override, or `var` (the table's).
    #[inline]
    pub fn describe<'v>(&self, index: u16, sub: u8, var: &'v Var) -> &'v Var {
        if self.entry_overrides.is_empty() {
            return var;
        }
        self.entry_overrides
            .iter()
            .find(|o| o.index == index && o.sub == sub)
            .and_then(|o| o.var.as_ref())
            .unwrap_or(var)
    }

    /// The description of `sub` of `object` (`var`, the table's, or the firmware's override),
    /// or 0x0609_0011 for an entry an override hides. One test when there are no overrides.
    #[inline]
    pub(super) fn resolve(
        &self,
        index: u16,
        object: &Object,
        sub: u8,
        var: &'static Var,
    ) -> Result<&'static Var, AbortCode> {
        if self.entry_overrides.is_empty() {
            return Ok(var);
        }
        self.resolve_overridden(index, object, sub, var)
    }

    /// [`Self::resolve`] with overrides: `index` is the entry's (`object` may describe a copy).
    #[cold]
    fn resolve_overridden(
        &self,
        index: u16,
        object: &Object,
        sub: u8,
        var: &'static Var,
    ) -> Result<&'static Var, AbortCode> {
        if self.hidden(&object.at(index), sub) {
            return Err(AbortCode::SubIndexDoesNotExist);
        }
        Ok(self.describe(index, sub, var))
    }

    /// Whether sub-index `sub` of `object` lies above the count an override of its sub-index 0
    /// sets (see the [module docs](self)).
    #[inline]
    pub(crate) fn hidden(&self, object: &Object, sub: u8) -> bool {
        if self.entry_overrides.is_empty() || sub == 0 || matches!(object.kind, Kind::Var(_)) {
            return false;
        }
        self.entry_overrides
            .iter()
            .find(|o| o.index == object.index && o.sub == 0)
            .and_then(counted)
            .is_some_and(|n| u64::from(sub) > n)
    }
}

/// The constant count an override of a sub-index 0 gives.
fn counted(o: &EntryOverride) -> Option<u64> {
    match o.var.as_ref()? {
        var if var.is_fixed() => match var.default {
            DefaultValue::Unsigned(n) => Some(n),
            _ => None,
        },
        _ => None,
    }
}

/// What is wrong with `value` as the default of entry `index`/`sub` described by `var` (its
/// type, its capacity, its limits), if anything.
pub(super) fn default_problem(var: &Var, value: DefaultValue, index: u16, sub: u8) -> Option<ConfigError> {
    super::check::check_var(&var.default(value)).err().map(|problem| problem.at(index, sub))
}

#[cfg(test)]
mod tests {
    use super::super::{layout, DeviceInfo};
    use super::*;

    const RECORD: [(u8, Var); 2] = [
        (
            0,
            Var::new("Highest sub-index supported", DataType::Unsigned8)
                .access(Access::Const)
                .default(DefaultValue::Unsigned(1)),
        ),
        (1, Var::new("Text", DataType::VisibleString).access(Access::ReadWrite).capacity(4)),
    ];

    static TABLE: [Object; 3] = layout([
        Object::var(
            0x2000,
            "Option",
            Var::new("Option", DataType::Integer16)
                .access(Access::ReadWrite)
                .pdo(PdoMapping::Rpdo)
                .limits_signed(-2, 3)
                .default(DefaultValue::Signed(-1)),
        ),
        Object::array(
            0x2001,
            "Array",
            2,
            &Var::new("Element", DataType::Unsigned32).access(Access::ReadWrite),
        ),
        Object::record(0x2002, "Record", &RECORD),
    ]);

    fn dict() -> Dictionary<64> {
        Dictionary::new(&[&TABLE], DeviceInfo::servo_drive(), 1).unwrap()
    }

    #[test]
    fn a_retyped_entry_keeps_its_bytes() {
        static RETYPED: [EntryOverride; 1] =
            [EntryOverride::of(&TABLE, 0x2000, 0).data_type(DataType::Unsigned16)];
        let var = RETYPED[0].var().unwrap();
        assert_eq!(var.default, DefaultValue::Unsigned(0xFFFF));
        assert_eq!((var.low(), var.high()), (Bound::None, Bound::Unsigned(3)));
        assert_eq!((var.name(), var.pdo), ("Option", PdoMapping::Rpdo));
        // The default (-1 as 16 bits) lies above the high limit 3 under the new type: refused.
        assert_eq!(
            dict().set_entry_overrides(&RETYPED),
            Err(ConfigError::DefaultOutsideLimits { index: 0x2000, sub: 0 })
        );
        static RETYPED_WITHIN: [EntryOverride; 1] =
            [EntryOverride::of(&TABLE, 0x2000, 0).data_type(DataType::Unsigned16).limits_unsigned(0, 0xFFFF)];
        let mut od = dict();
        od.set_entry_overrides(&RETYPED_WITHIN).unwrap();
        let entry = od.entry(0x2000, 0).unwrap();
        assert_eq!(entry.var.data_type, DataType::Unsigned16);
        assert_eq!(od.get::<i16>(0x2000, 0), Ok(-1), "the device still reads its 16 bits");
        assert_eq!(od.check_write(&entry, &4u16.to_le_bytes()), Ok(()));
        static RETYPED_LOW: [EntryOverride; 1] = [EntryOverride::of(&TABLE, 0x2000, 0)
            .data_type(DataType::Unsigned16)
            .limits_unsigned(0, 3)
            .default(DefaultValue::Unsigned(2))];
        let mut od = dict();
        od.set_entry_overrides(&RETYPED_LOW).unwrap();
        let entry = od.entry(0x2000, 0).unwrap();
        assert_eq!(od.check_write(&entry, &4u16.to_le_bytes()), Err(AbortCode::ValueTooHigh));
        // And back: a signed description of an unsigned entry.
        let back = EntryOverride::of(&TABLE, 0x2000, 0)
            .data_type(DataType::Unsigned16)
            .data_type(DataType::Integer16);
        let back = back.var().unwrap();
        assert_eq!(
            (back.default, back.low(), back.high()),
            (DefaultValue::Signed(-1), Bound::None, Bound::Signed(3))
        );
    }

    #[test]
    fn entries_of_arrays_and_records_are_found() {
        assert_eq!(EntryOverride::of(&TABLE, 0x2001, 2).var().map(|v| v.name()), Some("Element"));
        assert_eq!(
            EntryOverride::of(&TABLE, 0x2001, 0).var().map(|v| v.data_type),
            Some(DataType::Unsigned8)
        );
        assert_eq!(EntryOverride::of(&TABLE, 0x2002, 1).var().map(|v| v.name()), Some("Text"));
        for (index, sub) in [(0x2001, 3), (0x2002, 2), (0x2000, 1), (0x2003, 0)] {
            assert_eq!(EntryOverride::of(&TABLE, index, sub).var(), None);
        }
        // One element of an array, not its neighbours.
        static ONE: [EntryOverride; 1] = [EntryOverride::of(&TABLE, 0x2001, 2).access(Access::ReadOnly)];
        let mut od = dict();
        od.set_entry_overrides(&ONE).unwrap();
        assert_eq!(od.entry(0x2001, 1).unwrap().var.access, Access::ReadWrite);
        assert_eq!(od.entry(0x2001, 2).unwrap().var.access, Access::ReadOnly);
    }

    #[test]
    fn a_smaller_count_hides_the_entries_above_it() {
        static SHORTER: [EntryOverride; 2] = [
            EntryOverride::of(&TABLE, 0x2001, 0).default(DefaultValue::Unsigned(1)),
            EntryOverride::of(&TABLE, 0x2002, 0).default(DefaultValue::Unsigned(0)),
        ];
        let mut od = dict();
        od.set_entry_overrides(&SHORTER).unwrap();
        assert_eq!(od.get::<u8>(0x2001, 0), Ok(1));
        assert!(od.entry(0x2001, 1).is_ok());
        assert_eq!(od.entry(0x2001, 2).err(), Some(AbortCode::SubIndexDoesNotExist));
        assert_eq!(od.entry(0x2002, 1).err(), Some(AbortCode::SubIndexDoesNotExist));
        assert_eq!(
            od.parameters(0x2000..=0x2002).map(|e| (e.index(), e.sub)).collect::<heapless::Vec<_, 4>>(),
            [(0x2000, 0), (0x2001, 1)]
        );
        static LONGER: [EntryOverride; 1] =
            [EntryOverride::of(&TABLE, 0x2001, 0).default(DefaultValue::Unsigned(3))];
        assert_eq!(
            dict().set_entry_overrides(&LONGER),
            Err(ConfigError::DefaultOutsideLimits { index: 0x2001, sub: 0 })
        );
    }

    #[test]
    fn overrides_that_change_the_storage_are_refused() {
        static WIDER: [EntryOverride; 1] =
            [EntryOverride::of(&TABLE, 0x2000, 0).data_type(DataType::Integer32)];
        static CONSTANT: [EntryOverride; 1] = [EntryOverride::of(&TABLE, 0x2000, 0).access(Access::Const)];
        static LONGER: [EntryOverride; 1] =
            [EntryOverride::new(0x2002, 1, Var::new("Text", DataType::VisibleString).capacity(8))];
        static NUMBER: [EntryOverride; 1] =
            [EntryOverride::of(&TABLE, 0x2002, 1).data_type(DataType::Unsigned32)];
        for (bad, sub) in [(&WIDER, 0), (&CONSTANT, 0), (&LONGER, 1), (&NUMBER, 1)] {
            let index = bad[0].index();
            assert_eq!(dict().set_entry_overrides(bad), Err(ConfigError::EntrySize { index, sub }));
        }
        static MISSING: [EntryOverride; 1] = [EntryOverride::of(&TABLE, 0x2003, 0)];
        static NOT_HERE: [EntryOverride; 1] =
            [EntryOverride::new(0x2001, 3, Var::new("x", DataType::Unsigned32))];
        static TEXT: [EntryOverride; 1] =
            [EntryOverride::of(&TABLE, 0x2000, 0).default(DefaultValue::Text("no"))];
        let refused = [
            (&MISSING, ConfigError::NoSuchEntry { index: 0x2003, sub: 0 }),
            (&NOT_HERE, ConfigError::NoSuchEntry { index: 0x2001, sub: 3 }),
            (&TEXT, ConfigError::DefaultType { index: 0x2000, sub: 0 }),
        ];
        for (bad, error) in refused {
            assert_eq!(dict().set_entry_overrides(bad), Err(error));
        }
    }
}

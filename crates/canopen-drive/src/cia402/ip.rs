//! The input buffer of interpolated position mode (ip, CiA 402-2 §13.2, §13.5): the data
//! records the master sends through 60C1h, their configuration 60C4h, the interpolation
//! period 60C2h and the algorithm select 60C0h.
//!
//! ```text
//! 60C0h interpolation sub mode select   I16  rw  0 = linear (the only algorithm here)
//! 60C1h interpolation data record       ARRAY of I32, rw, RPDO-mappable
//!        sub 1 = position set-point, sub 2 = spare word for a longer record
//! 60C2h interpolation time period       sub 1 U8 value (1), sub 2 I8 index (−3): value × 10^index s
//! 60C4h interpolation data configuration
//!        sub 1 maximum buffer size  U32 ro   MAX_RECORDS
//!        sub 2 actual buffer size   U32 rw   0 (= the whole capacity, see below)
//!        sub 3 buffer organisation  U8  rw   0 FIFO, 1 ring
//!        sub 4 buffer position      U16 rw   ring slot the next record goes to (0-based)
//!        sub 5 size of data record  U8  wo   bytes: 4 × entries of 60C1h (4 or 8)
//!        sub 6 buffer clear         U8  wo   0 clear + disable access, 1 enable access
//! ```
//!
//! [`IpBuffer`] holds up to [`MAX_RECORDS`] records of up to [`RECORD_ENTRIES`] INTEGER32
//! words. Linear interpolation needs one word per record (the position set-point, 60C1h.1);
//! the second word exists so that a master may configure 8-byte records (e.g. a set-point
//! with a time slice for asynchronous operation) and have them buffered whole. The profile
//! drives the buffer through three calls:
//!
//! - [`check_write`] before an SDO write of 60C0h–60C4h is committed (value rules below);
//! - [`IpBuffer::written`] after a write of 60C1h or 60C4h was committed to the dictionary,
//!   from an SDO or an RPDO;
//! - [`IpBuffer::next`] once per interpolation cycle while interpolation is active.
//!
//! Every call does work bounded by [`MAX_RECORDS`] and never allocates.
//!
//! # Choices where the standard leaves room (CiA 402-2 §13.2)
//!
//! - **60C4h sub 0 is 6**: only subs 1–6 are defined, so the object reports 6 and sub 7 answers
//!   "sub-index does not exist" (0609 0011h), instead of the 07h printed in the standard.
//! - **Power-on state**: access enabled and the buffer empty, so a master that never writes
//!   60C4h.6 can still stream records; 60C4h.6 therefore defaults to 1 here. The standard's
//!   default 0 would leave the buffer locked after every reset.
//! - **Actual buffer size 0** (the standard's default) means "not configured": the whole
//!   capacity ([`MAX_RECORDS`]) is used. 1…[`MAX_RECORDS`] limit the buffer to that many
//!   records; more is refused with 0609 0031h.
//! - **Size of data record** is taken in bytes as a multiple of 4: 4 × the number of 60C1h
//!   words per record. 4 and 8 are accepted; other multiples of 4 above 8 are too high
//!   (0609 0031h), values that are not multiples of 4 are invalid (0609 0030h), 0 is too low.
//!   The default is 4 (one word): the standard's default 1 cannot hold an INTEGER32.
//! - **Record completion**: a record is complete when its last word (60C1h sub = words per
//!   record) is written; the record then takes the present values of 60C1h.1… from the
//!   dictionary. Writes of earlier words only stage them; writes of words beyond the record
//!   are kept in the dictionary and have no effect on the buffer.
//! - **FIFO**: a complete record is appended at the tail; [`IpBuffer::next`] takes the head and
//!   answers `None` when the buffer is empty (the profile then holds the last point). 60C4h.4
//!   has no effect.
//! - **Ring**: a complete record is stored in the slot 60C4h.4 names; the position does not
//!   advance by itself, so a second record written without changing 60C4h.4 replaces the
//!   first (this crate's reading of a text that allows both). [`IpBuffer::next`] replays the
//!   occupied slots cyclically in slot order from the read pointer, skipping slots never
//!   written since the last clear or reorganisation (an empty slot holds no set-point).
//! - **Overflow**: a complete record that cannot be placed (FIFO full, or a ring position
//!   outside the buffer) is refused: over SDO, [`check_write`] answers 0800 0020h before the
//!   word is committed; from an RPDO (which cannot be refused), [`IpBuffer::written`] keeps the
//!   buffer as it is, gives the record back in [`Written::Overflow`] and counts it in
//!   [`IpBuffer::overflows`], which the profile turns into a warning or an EMCY.
//! - **Access disabled** (after 60C4h.6 = 0): SDO writes of 60C1h are refused with
//!   0800 0022h (not possible in the present device state); RPDO writes are stored in the
//!   dictionary but do not enter the buffer ([`Written::Refused`]).
//! - **Reorganisation**: any write of 60C4h.2, .3 or .5 (even with the same value) lays the
//!   buffer out anew: every record is discarded, the read pointer goes back to the first
//!   record and 60C4h.4 to 0. Access stays as it was.
//! - **Clear** (60C4h.6 = 0): every record is discarded, the words of 60C1h are zeroed, the read
//!   pointer and 60C4h.4 go back to 0 and access is disabled until 60C4h.6 = 1.
//! - **60C0h** accepts only 0 (linear); every other value is refused with 0609 0030h.
//! - **60C2h** keeps the standard's ranges (sub 1 any UNSIGNED8, sub 2 −128…+63; +64 and above
//!   answer 0609 0031h). Whether a period can be run is [`interpolation_period_us`]'s answer.
//!
//! Whether the configuration may change while interpolation is active is the profile's
//! decision; this module accepts it at any time. After the dictionary is reset or restored,
//! the profile calls [`IpBuffer::reload`] (or starts from [`IpBuffer::new`]).

use super::cyclic::{Interpolator, Limiter};
use super::objects::Rule;
pub use super::objects::INTERPOLATION_TIME_PERIOD;
use super::Axis;
use crate::od::{le_u32, AbortCode, Access, DataType, DefaultValue, Dictionary, Object, PdoMapping, Var};

/// 60C0h interpolation sub mode select.
pub const INTERPOLATION_SUB_MODE_SELECT: u16 = 0x60C0;
/// 60C1h interpolation data record.
pub const INTERPOLATION_DATA_RECORD: u16 = 0x60C1;
/// 60C4h interpolation data configuration.
pub const INTERPOLATION_DATA_CONFIGURATION: u16 = 0x60C4;

/// Sub-indices of 60C2h.
pub mod period_sub {
    /// Sub 1: interpolation time period value (UNSIGNED8).
    pub const VALUE: u8 = 1;
    /// Sub 2: interpolation time index (INTEGER8, the power of ten).
    pub const INDEX: u8 = 2;
}

/// Sub-indices of 60C4h.
pub mod config_sub {
    /// Sub 1: maximum buffer size (records, ro).
    pub const MAX_BUFFER_SIZE: u8 = 1;
    /// Sub 2: actual buffer size (records, rw).
    pub const ACTUAL_BUFFER_SIZE: u8 = 2;
    /// Sub 3: buffer organisation (0 FIFO, 1 ring).
    pub const BUFFER_ORGANISATION: u8 = 3;
    /// Sub 4: buffer position (ring slot of the next record).
    pub const BUFFER_POSITION: u8 = 4;
    /// Sub 5: size of one data record in bytes (wo).
    pub const SIZE_OF_DATA_RECORD: u8 = 5;
    /// Sub 6: buffer clear (wo).
    pub const BUFFER_CLEAR: u8 = 6;
}

/// Records the buffer holds at most (60C4h.1).
pub const MAX_RECORDS: usize = 16;
/// INTEGER32 words per record at most (the highest sub-index of 60C1h).
pub const RECORD_ENTRIES: usize = 2;
/// One data record: the words of 60C1h.1…; words beyond the configured record size are 0.
pub type Record = [i32; RECORD_ENTRIES];

/// 60C0h value of linear interpolation.
pub const LINEAR: i16 = 0;
/// Bytes of one 60C1h word.
const WORD_BYTES: usize = 4;

// The ring's occupied slots are a bit mask of a u32.
const _: () = assert!(MAX_RECORDS >= 1 && MAX_RECORDS <= 32);
const _: () = assert!(RECORD_ENTRIES >= 1 && RECORD_ENTRIES * WORD_BYTES <= 254);

/// 60C0h interpolation sub mode select (INTEGER16, rw, default 0 = linear).
pub const SUB_MODE_SELECT_OBJECT: Object = Object::var(
    INTERPOLATION_SUB_MODE_SELECT,
    "Interpolation sub mode select",
    Var::new("Interpolation sub mode select", DataType::Integer16)
        .access(Access::ReadWrite)
        .default(DefaultValue::Signed(LINEAR as i64)),
);

/// 60C1h interpolation data record (ARRAY of INTEGER32, rw, RPDO-mappable, default 0).
pub const DATA_RECORD_OBJECT: Object = Object::array(
    INTERPOLATION_DATA_RECORD,
    "Interpolation data record",
    RECORD_ENTRIES as u8,
    &Var::new("Interpolation data record", DataType::Integer32)
        .access(Access::ReadWrite)
        .pdo(PdoMapping::Rpdo),
);

const fn highest_sub(n: u64) -> Var {
    Var::new("Highest sub-index supported", DataType::Unsigned8)
        .access(Access::Const)
        .default(DefaultValue::Unsigned(n))
}

const TIME_PERIOD_SUBS: [(u8, Var); 3] = [
    (0, highest_sub(2)),
    (
        period_sub::VALUE,
        Var::new("Interpolation time period value", DataType::Unsigned8)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(1)),
    ),
    (
        period_sub::INDEX,
        Var::new("Interpolation time index", DataType::Integer8)
            .access(Access::ReadWrite)
            .default(DefaultValue::Signed(-3))
            .limits_signed(-128, 63),
    ),
];

/// 60C2h interpolation time period (RECORD: sub 1 value U8 = 1, sub 2 index I8 = −3, −128…+63;
/// 1 ms by default).
pub const TIME_PERIOD_OBJECT: Object =
    Object::record(INTERPOLATION_TIME_PERIOD, "Interpolation time period", &TIME_PERIOD_SUBS);

const DATA_CONFIGURATION_SUBS: [(u8, Var); 7] = [
    (0, highest_sub(6)),
    (
        config_sub::MAX_BUFFER_SIZE,
        Var::new("Maximum buffer size", DataType::Unsigned32)
            .default(DefaultValue::Unsigned(MAX_RECORDS as u64)),
    ),
    (
        config_sub::ACTUAL_BUFFER_SIZE,
        Var::new("Actual buffer size", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .limits_unsigned(0, MAX_RECORDS as u64),
    ),
    (
        config_sub::BUFFER_ORGANISATION,
        Var::new("Buffer organisation", DataType::Unsigned8).access(Access::ReadWrite),
    ),
    (
        config_sub::BUFFER_POSITION,
        Var::new("Buffer position", DataType::Unsigned16).access(Access::ReadWrite),
    ),
    (
        config_sub::SIZE_OF_DATA_RECORD,
        Var::new("Size of data record", DataType::Unsigned8)
            .access(Access::WriteOnly)
            .default(DefaultValue::Unsigned(WORD_BYTES as u64))
            .limits_unsigned(1, 254),
    ),
    (
        config_sub::BUFFER_CLEAR,
        Var::new("Buffer clear", DataType::Unsigned8)
            .access(Access::WriteOnly)
            .default(DefaultValue::Unsigned(ENABLE_ACCESS as u64)),
    ),
];

/// 60C4h interpolation data configuration (RECORD, subs 1–6, sub 0 = 6; see the module docs
/// for the defaults that differ from the standard's table).
pub const DATA_CONFIGURATION_OBJECT: Object = Object::record(
    INTERPOLATION_DATA_CONFIGURATION,
    "Interpolation data configuration",
    &DATA_CONFIGURATION_SUBS,
);

/// 60C4h.6 value that clears the buffer and disables access.
pub const CLEAR_AND_DISABLE: u8 = 0;
/// 60C4h.6 value that enables access.
pub const ENABLE_ACCESS: u8 = 1;

/// 60C2h in microseconds: `value × 10^index` s, computed exactly in integers.
///
/// `None` when the period is not a whole number of microseconds, is shorter than 1 µs (value
/// 0 included) or longer than one hour.
pub fn interpolation_period_us(value: u8, index: i8) -> Option<u32> {
    const HOUR_US: u64 = 3_600_000_000;
    let exponent = i32::from(index) + 6;
    let micros = if exponent >= 0 {
        let scale = 10u64.checked_pow(u32::try_from(exponent).ok()?)?;
        u64::from(value).checked_mul(scale)?
    } else {
        let divisor = 10u64.checked_pow(exponent.unsigned_abs())?;
        let value = u64::from(value);
        if !value.is_multiple_of(divisor) {
            return None;
        }
        value / divisor
    };
    if micros == 0 || micros > HOUR_US {
        return None;
    }
    u32::try_from(micros).ok()
}

/// 60C4h.3: how the buffer is organised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Organisation {
    /// 0: records are appended and consumed once, oldest first.
    Fifo = 0,
    /// 1: records sit in slots chosen by 60C4h.4 and are replayed cyclically.
    Ring = 1,
}

impl Organisation {
    /// The organisation of a 60C4h.3 value; `None` for the reserved values.
    pub const fn from_raw(raw: u8) -> Option<Self> {
        match raw {
            0 => Some(Organisation::Fifo),
            1 => Some(Organisation::Ring),
            _ => None,
        }
    }
}

/// What a write of 60C1h or 60C4h did to the buffer ([`IpBuffer::written`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Written {
    /// The entry has no effect on the buffer (another object, 60C4h.4, or a 60C1h word beyond
    /// the configured record size).
    Ignored,
    /// A word of a record was staged; the record is not complete yet.
    Staged,
    /// A record was completed and stored (FIFO: at the tail; ring: in its slot).
    Stored,
    /// A record was completed but the buffer could not take it (FIFO full, or ring position
    /// outside the buffer): the buffer is unchanged and the record is given back. The overflow
    /// counter was incremented.
    Overflow(Record),
    /// A 60C1h word arrived while access is disabled (60C4h.6 = 0): not buffered.
    Refused,
    /// 60C4h.2, .3 or .5 was written: the buffer was laid out anew and every record discarded.
    Reorganised,
    /// 60C4h.6 = 0: every record discarded, access disabled.
    Cleared,
    /// 60C4h.6 = 1: access enabled.
    Enabled,
}

/// The ip input buffer: [`MAX_RECORDS`] records of [`RECORD_ENTRIES`] words in caller-owned
/// storage, organised as FIFO or ring (see the module docs for the semantics).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IpBuffer {
    records: [Record; MAX_RECORDS],
    organisation: Organisation,
    /// Records the buffer may hold, 1..=MAX_RECORDS.
    capacity: usize,
    /// Words per record, 1..=RECORD_ENTRIES.
    entries: usize,
    enabled: bool,
    /// FIFO: slot of the oldest record. Ring: read pointer (next slot to look at).
    head: usize,
    /// FIFO: records held.
    count: usize,
    /// Ring: bit n set = slot n holds a record.
    occupied: u32,
    overflows: u32,
    /// The axis whose 60C1h/60C4h these are.
    axis: Axis,
}

impl Default for IpBuffer {
    fn default() -> Self {
        IpBuffer::new()
    }
}

/// `index % modulus`, 0 for a zero modulus.
fn wrap(index: usize, modulus: usize) -> usize {
    index.checked_rem(modulus).unwrap_or(0)
}

impl IpBuffer {
    /// The power-on buffer, matching the objects' defaults: FIFO over the whole capacity,
    /// one word per record, access enabled, empty.
    pub const fn new() -> Self {
        Self::for_axis(Axis::FIRST)
    }

    /// [`Self::new`] for the objects of `axis`.
    pub const fn for_axis(axis: Axis) -> Self {
        IpBuffer {
            records: [[0; RECORD_ENTRIES]; MAX_RECORDS],
            organisation: Organisation::Fifo,
            capacity: MAX_RECORDS,
            entries: 1,
            enabled: true,
            head: 0,
            count: 0,
            occupied: 0,
            overflows: 0,
            axis,
        }
    }

    /// This buffer's 60C4h.
    fn configuration(&self) -> u16 {
        self.axis.index(INTERPOLATION_DATA_CONFIGURATION)
    }

    /// Takes the configuration 60C4h.2, .3, .5 and .6 from the dictionary (e.g. after a reset
    /// or a restore of stored parameters) and discards every record. Values the dictionary
    /// should never hold (set from the device side) fall back to the power-on meaning.
    pub fn reload<const B: usize>(&mut self, od: &Dictionary<B>) {
        self.configure(od);
        let clear = od.get::<u8>(self.configuration(), config_sub::BUFFER_CLEAR);
        self.enabled = clear != Ok(CLEAR_AND_DISABLE);
        self.clear();
    }

    /// Buffer organisation (60C4h.3).
    pub fn organisation(&self) -> Organisation {
        self.organisation
    }

    /// Records the buffer may hold (60C4h.2, or [`MAX_RECORDS`] when that is 0).
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Words of 60C1h per record (60C4h.5 / 4).
    pub fn record_entries(&self) -> usize {
        self.entries
    }

    /// True while records are accepted (60C4h.6 last written 1, or never written).
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// Records held: FIFO records not yet consumed, or occupied ring slots.
    pub fn len(&self) -> usize {
        match self.organisation {
            Organisation::Fifo => self.count,
            Organisation::Ring => self.occupied.count_ones() as usize,
        }
    }

    /// True when [`next`](Self::next) has nothing to give.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// True when the FIFO cannot take another record (always false for a ring).
    pub fn is_full(&self) -> bool {
        self.organisation == Organisation::Fifo && self.count >= self.capacity
    }

    /// Complete records that could not be buffered since power-on (saturating). The profile
    /// compares it with the value it last saw to raise its warning or EMCY.
    pub fn overflows(&self) -> u32 {
        self.overflows
    }

    /// Discards every record and sets the read pointer to the first record. Access and
    /// configuration stay as they are.
    pub fn clear(&mut self) {
        self.head = 0;
        self.count = 0;
        self.occupied = 0;
    }

    /// The record [`next`](Self::next) would give, without taking it.
    pub fn peek(&self) -> Option<Record> {
        let slot = match self.organisation {
            Organisation::Fifo => (self.count > 0).then_some(self.head)?,
            Organisation::Ring => self.next_occupied()?,
        };
        self.records.get(slot).copied()
    }

    /// The record to actuate in this interpolation cycle. FIFO: the oldest record, removed
    /// from the buffer; `None` when empty (underflow: hold the last point). Ring: the next
    /// occupied slot after the read pointer, cyclically; `None` only when no slot is occupied.
    // Not an `Iterator`: a ring never ends, and `for` over it would never return.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Option<Record> {
        match self.organisation {
            Organisation::Fifo => {
                if self.count == 0 {
                    return None;
                }
                let record = self.records.get(self.head).copied();
                self.head = wrap(self.head + 1, MAX_RECORDS);
                self.count -= 1;
                record
            }
            Organisation::Ring => {
                let slot = self.next_occupied()?;
                self.head = wrap(slot + 1, self.capacity);
                self.records.get(slot).copied()
            }
        }
    }

    /// The first occupied ring slot at or after the read pointer, wrapping around.
    fn next_occupied(&self) -> Option<usize> {
        (0..self.capacity)
            .map(|step| wrap(self.head + step, self.capacity))
            .find(|slot| self.occupied & (1 << slot) != 0)
    }

    /// Updates the buffer after a write of `index`/`sub` was committed to `od` (from an SDO
    /// or an RPDO). Writes of other objects are [`Written::Ignored`].
    pub fn written<const B: usize>(&mut self, od: &mut Dictionary<B>, index: u16, sub: u8) -> Written {
        use config_sub::*;
        let configuration = self.configuration();
        match (self.axis.relative(index).unwrap_or(0), sub) {
            (INTERPOLATION_DATA_RECORD, sub) => self.word_written(od, sub),
            (
                INTERPOLATION_DATA_CONFIGURATION,
                ACTUAL_BUFFER_SIZE | BUFFER_ORGANISATION | SIZE_OF_DATA_RECORD,
            ) => {
                self.configure(od);
                self.clear();
                let _ = od.set::<u16>(configuration, BUFFER_POSITION, 0);
                Written::Reorganised
            }
            (INTERPOLATION_DATA_CONFIGURATION, BUFFER_CLEAR) => {
                match od.get::<u8>(configuration, BUFFER_CLEAR) {
                    Ok(CLEAR_AND_DISABLE) => {
                        self.clear();
                        self.enabled = false;
                        let _ = od.set::<u16>(configuration, BUFFER_POSITION, 0);
                        for word in 1..=RECORD_ENTRIES as u8 {
                            let _ = od.set::<i32>(self.axis.index(INTERPOLATION_DATA_RECORD), word, 0);
                        }
                        Written::Cleared
                    }
                    Ok(ENABLE_ACCESS) => {
                        self.enabled = true;
                        Written::Enabled
                    }
                    _ => Written::Ignored,
                }
            }
            _ => Written::Ignored,
        }
    }

    /// 60C1h sub `word` was written.
    fn word_written<const B: usize>(&mut self, od: &Dictionary<B>, word: u8) -> Written {
        let word = usize::from(word);
        if word == 0 || word > self.entries {
            return Written::Ignored;
        }
        if !self.enabled {
            return Written::Refused;
        }
        if word < self.entries {
            return Written::Staged;
        }
        let mut record = [0; RECORD_ENTRIES];
        for (sub, value) in (1u8..).zip(record.iter_mut().take(self.entries)) {
            *value = od.get::<i32>(self.axis.index(INTERPOLATION_DATA_RECORD), sub).unwrap_or(0);
        }
        let slot = match self.organisation {
            Organisation::Fifo => {
                (self.count < self.capacity).then(|| wrap(self.head + self.count, MAX_RECORDS))
            }
            Organisation::Ring => Some(ring_position(od, self.axis)).filter(|slot| *slot < self.capacity),
        };
        match slot.and_then(|slot| self.records.get_mut(slot).map(|r| (slot, r))) {
            Some((slot, stored)) => {
                *stored = record;
                match self.organisation {
                    Organisation::Fifo => self.count += 1,
                    Organisation::Ring => self.occupied |= 1 << slot,
                }
                Written::Stored
            }
            None => {
                self.overflows = self.overflows.saturating_add(1);
                Written::Overflow(record)
            }
        }
    }

    /// Takes size, organisation and record size from the dictionary.
    fn configure<const B: usize>(&mut self, od: &Dictionary<B>) {
        use config_sub::*;
        let configuration = self.configuration();
        let size = od.get::<u32>(configuration, ACTUAL_BUFFER_SIZE).unwrap_or(0);
        self.capacity = match usize::try_from(size) {
            Ok(n) if (1..=MAX_RECORDS).contains(&n) => n,
            _ => MAX_RECORDS,
        };
        let organisation = od.get::<u8>(configuration, BUFFER_ORGANISATION).unwrap_or(0);
        self.organisation = Organisation::from_raw(organisation).unwrap_or(Organisation::Fifo);
        let bytes = od.get::<u8>(configuration, SIZE_OF_DATA_RECORD).unwrap_or(0);
        self.entries = record_entries(bytes).unwrap_or(1);
    }
}

/// `axis`'s 60C4h.4 as a slot number.
fn ring_position<const B: usize>(od: &Dictionary<B>, axis: Axis) -> usize {
    let position = od.get::<u16>(axis.index(INTERPOLATION_DATA_CONFIGURATION), config_sub::BUFFER_POSITION);
    usize::from(position.unwrap_or(0))
}

/// Words per record of a 60C4h.5 value, when it is one this buffer takes.
fn record_entries(bytes: u8) -> Option<usize> {
    let bytes = usize::from(bytes);
    let words = bytes / WORD_BYTES;
    (bytes.is_multiple_of(WORD_BYTES) && (1..=RECORD_ENTRIES).contains(&words)).then_some(words)
}

/// Value rules of 60C0h, 60C1h, 60C2h and 60C4h beyond type and limits, for an SDO write of
/// `data` to `index`/`sub` (after the dictionary's own size and limit checks). Other objects
/// pass.
///
/// - 60C0h ≠ 0 → 0609 0030h.
/// - 60C1h while access is disabled → 0800 0022h; the last word of a record when the record
///   cannot be placed (FIFO full, ring position outside the buffer) → 0800 0020h.
/// - 60C2h.2 > 63 → 0609 0031h.
/// - 60C4h.2 > [`MAX_RECORDS`] → 0609 0031h; 60C4h.3 ∉ {0, 1} → 0609 0030h; 60C4h.4 outside
///   the ring → 0609 0031h (no check for a FIFO, where it has no effect); 60C4h.5 not a
///   multiple of 4 → 0609 0030h, 0 → 0609 0032h, above 4 × [`RECORD_ENTRIES`] → 0609 0031h;
///   60C4h.6 ∉ {0, 1} → 0609 0030h.
pub fn check_write<const B: usize>(
    od: &Dictionary<B>,
    buffer: &IpBuffer,
    index: u16,
    sub: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    use config_sub::*;
    let raw = le_u32(data);
    let refusal = match (buffer.axis.relative(index).unwrap_or(0), sub) {
        (INTERPOLATION_SUB_MODE_SELECT, 0) => {
            (raw as u16 as i16 != LINEAR).then_some(AbortCode::InvalidValue)
        }
        (INTERPOLATION_DATA_RECORD, word) if word >= 1 => {
            let last = usize::from(word) == buffer.entries;
            let placeable = match buffer.organisation {
                Organisation::Fifo => !buffer.is_full(),
                Organisation::Ring => ring_position(od, buffer.axis) < buffer.capacity,
            };
            if !buffer.enabled {
                Some(AbortCode::CannotStoreDeviceState)
            } else {
                (last && !placeable).then_some(AbortCode::CannotStore)
            }
        }
        (INTERPOLATION_TIME_PERIOD, period_sub::INDEX) => {
            (raw as u8 as i8 > 63).then_some(AbortCode::ValueTooHigh)
        }
        (INTERPOLATION_DATA_CONFIGURATION, ACTUAL_BUFFER_SIZE) => {
            usize::try_from(raw).map_or(true, |size| size > MAX_RECORDS).then_some(AbortCode::ValueTooHigh)
        }
        (INTERPOLATION_DATA_CONFIGURATION, BUFFER_ORGANISATION) => u8::try_from(raw)
            .ok()
            .and_then(Organisation::from_raw)
            .is_none()
            .then_some(AbortCode::InvalidValue),
        (INTERPOLATION_DATA_CONFIGURATION, BUFFER_POSITION) => {
            let outside = usize::try_from(raw).map_or(true, |slot| slot >= buffer.capacity);
            (buffer.organisation == Organisation::Ring && outside).then_some(AbortCode::ValueTooHigh)
        }
        (INTERPOLATION_DATA_CONFIGURATION, SIZE_OF_DATA_RECORD) => match usize::try_from(raw) {
            Ok(0) => Some(AbortCode::ValueTooLow),
            Ok(bytes) if bytes <= RECORD_ENTRIES * WORD_BYTES => {
                (!bytes.is_multiple_of(WORD_BYTES)).then_some(AbortCode::InvalidValue)
            }
            _ => Some(AbortCode::ValueTooHigh),
        },
        (INTERPOLATION_DATA_CONFIGURATION, BUFFER_CLEAR) => {
            (!matches!(raw, 0 | 1)).then_some(AbortCode::InvalidValue)
        }
        _ => None,
    };
    refusal.map_or(Ok(()), Err)
}

/// ip as the running mode of a profile ([`crate::cia402::profile`]): the interpolation between
/// the data records, the position limiter, and whether interpolation is active (controlword
/// bit 4). It exists while ip is the active mode; the buffer of data records (60C1h, 60C4h)
/// belongs to the objects and outlives it ([`IpBuffer`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// The demand between two records.
    pub interpolator: Interpolator,
    /// The demand within the limits.
    pub limiter: Limiter,
    /// Controlword bit 4 was 1 (and no halt) in the last tick.
    pub active: bool,
}

impl Run {
    /// ip becomes active, the axis at `actual` (increments).
    pub fn start(actual: i64) -> Self {
        let mut run =
            Run { interpolator: Interpolator::default(), limiter: Limiter::default(), active: false };
        run.reset(actual);
        run
    }

    /// Interpolation starts over from the axis as it is, inactive.
    pub fn reset(&mut self, actual: i64) {
        self.limiter.reset(actual);
        self.active = false;
        self.interpolator.reset(actual);
    }
}

/// ip's objects (60C0h, 60C1h, 60C4h), in [`super::registry::PROFILE`] when the build runs ip
/// (the interpolation time period 60C2h, which every cyclic mode reads, is in every build).
pub(crate) const OBJECTS: [Object; 3] =
    [SUB_MODE_SELECT_OBJECT, DATA_RECORD_OBJECT, DATA_CONFIGURATION_OBJECT];

/// The value rule of `index`/`sub` among ip's objects and 60C2h ([`super::registry::rule`]);
/// `pdo`: as an RPDO writes it (a record is then taken or dropped, never refused).
pub(crate) fn rule(index: u16, sub: u8, pdo: bool) -> Option<Rule> {
    match index {
        INTERPOLATION_DATA_RECORD if sub == 0 => None,
        INTERPOLATION_DATA_RECORD if pdo => Some(Rule::InterpolationRecordPdo),
        INTERPOLATION_DATA_RECORD => Some(Rule::InterpolationRecord),
        INTERPOLATION_DATA_CONFIGURATION => Some(Rule::InterpolationConfiguration),
        INTERPOLATION_SUB_MODE_SELECT | INTERPOLATION_TIME_PERIOD => Some(Rule::Interpolation),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::config_sub::*;
    use super::*;
    use crate::od::{layout, DeviceInfo};

    static TABLE: [Object; 4] =
        layout([SUB_MODE_SELECT_OBJECT, DATA_RECORD_OBJECT, TIME_PERIOD_OBJECT, DATA_CONFIGURATION_OBJECT]);

    const CONF: u16 = INTERPOLATION_DATA_CONFIGURATION;
    const DATA: u16 = INTERPOLATION_DATA_RECORD;

    fn dict() -> Dictionary<128> {
        Dictionary::new(&[&TABLE], DeviceInfo::servo_drive(), 1).unwrap()
    }

    /// An SDO download as the drive performs it: access, dictionary checks, the ip rules,
    /// commit, then the buffer update.
    fn sdo_write(
        od: &mut Dictionary<128>,
        ip: &mut IpBuffer,
        index: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<Written, AbortCode> {
        let entry = od.entry(index, sub)?;
        if !entry.var.access.writable() {
            return Err(AbortCode::WriteOfReadOnly);
        }
        od.check_write(&entry, data)?;
        check_write(od, ip, index, sub, data)?;
        od.commit(&entry, data);
        Ok(ip.written(od, index, sub))
    }

    /// An SDO upload's access check and value.
    fn sdo_read(od: &Dictionary<128>, index: u16, sub: u8) -> Result<u64, AbortCode> {
        let entry = od.entry(index, sub)?;
        if !entry.var.access.readable() {
            return Err(AbortCode::ReadOfWriteOnly);
        }
        let mut raw = [0u8; 8];
        od.read(&entry, 0, &mut raw);
        Ok(u64::from_le_bytes(raw))
    }

    /// A record written word by word over SDO.
    fn send(od: &mut Dictionary<128>, ip: &mut IpBuffer, words: &[i32]) -> Result<Written, AbortCode> {
        let mut last = Written::Ignored;
        for (sub, word) in (1u8..).zip(words) {
            last = sdo_write(od, ip, DATA, sub, &word.to_le_bytes())?;
        }
        Ok(last)
    }

    /// A one-word record arriving by RPDO (no checks: the mapping writes, then the profile
    /// tells the buffer).
    fn rpdo(od: &mut Dictionary<128>, ip: &mut IpBuffer, position: i32) -> Written {
        od.set::<i32>(DATA, 1, position).unwrap();
        ip.written(od, DATA, 1)
    }

    fn ring_of(size: u32) -> (Dictionary<128>, IpBuffer) {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        sdo_write(&mut od, &mut ip, CONF, ACTUAL_BUFFER_SIZE, &size.to_le_bytes()).unwrap();
        sdo_write(&mut od, &mut ip, CONF, BUFFER_ORGANISATION, &[1]).unwrap();
        (od, ip)
    }

    fn at(od: &mut Dictionary<128>, ip: &mut IpBuffer, slot: u16) {
        assert_eq!(sdo_write(od, ip, CONF, BUFFER_POSITION, &slot.to_le_bytes()), Ok(Written::Ignored));
    }

    #[test]
    fn power_on_buffer_is_an_enabled_empty_fifo_of_one_word_records() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        assert_eq!(ip, IpBuffer::default());
        ip.reload(&od);
        assert_eq!(ip, IpBuffer::new());
        assert!(ip.is_enabled() && ip.is_empty() && !ip.is_full());
        assert_eq!(
            (ip.organisation(), ip.capacity(), ip.record_entries()),
            (Organisation::Fifo, MAX_RECORDS, 1)
        );
        assert_eq!(od.get::<i16>(INTERPOLATION_SUB_MODE_SELECT, 0), Ok(0));
        assert_eq!(od.get::<u32>(CONF, ACTUAL_BUFFER_SIZE), Ok(0));
        assert_eq!(od.get::<u8>(CONF, BUFFER_ORGANISATION), Ok(0));
        assert_eq!(od.get::<u16>(CONF, BUFFER_POSITION), Ok(0));
        // A master that never touches 60C4h streams at once.
        assert_eq!(sdo_write(&mut od, &mut ip, DATA, 1, &5i32.to_le_bytes()), Ok(Written::Stored));
        assert_eq!(ip.next(), Some([5, 0]));
    }

    #[test]
    fn data_configuration_has_six_sub_indices() {
        let od = dict();
        assert_eq!(od.get::<u8>(CONF, 0), Ok(6));
        assert_eq!(od.entry(CONF, 7).err(), Some(AbortCode::SubIndexDoesNotExist));
        assert_eq!(od.get::<u8>(DATA, 0), Ok(RECORD_ENTRIES as u8));
        assert_eq!(od.get::<u8>(INTERPOLATION_TIME_PERIOD, 0), Ok(2));
        let word = od.entry(DATA, 1).unwrap();
        assert_eq!((word.var.pdo, word.var.access), (PdoMapping::Rpdo, Access::ReadWrite));
    }

    #[test]
    fn n_149_ring_of_four_records_replays_cyclically() {
        let (mut od, mut ip) = ring_of(4);
        for (slot, position) in [(0u16, 100), (1, 200), (2, 300), (3, 400)] {
            at(&mut od, &mut ip, slot);
            assert_eq!(send(&mut od, &mut ip, &[position]), Ok(Written::Stored));
        }
        assert_eq!(ip.len(), 4);
        let replay: [i32; 10] = core::array::from_fn(|_| ip.next().unwrap()[0]);
        assert_eq!(replay, [100, 200, 300, 400, 100, 200, 300, 400, 100, 200]);
        assert_eq!(ip.len(), 4, "a ring is not consumed");
    }

    #[test]
    fn ring_skips_slots_never_written() {
        let (mut od, mut ip) = ring_of(4);
        at(&mut od, &mut ip, 1);
        send(&mut od, &mut ip, &[10]).unwrap();
        at(&mut od, &mut ip, 3);
        send(&mut od, &mut ip, &[30]).unwrap();
        assert_eq!(ip.peek(), Some([10, 0]));
        let replay: [i32; 5] = core::array::from_fn(|_| ip.next().unwrap()[0]);
        assert_eq!(replay, [10, 30, 10, 30, 10]);
    }

    #[test]
    fn n_150_buffer_clear_empties_and_disables_then_enable_accepts_again() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        for position in [1, 2, 3] {
            send(&mut od, &mut ip, &[position]).unwrap();
        }
        assert_eq!(sdo_write(&mut od, &mut ip, CONF, BUFFER_CLEAR, &[0]), Ok(Written::Cleared));
        assert!(ip.is_empty() && !ip.is_enabled());
        assert_eq!(ip.next(), None, "no further motion on SYNC");
        assert_eq!(od.get::<i32>(DATA, 1), Ok(0), "the ip data records are cleared too");
        // Access is disabled: SDO refused, RPDO not buffered.
        assert_eq!(send(&mut od, &mut ip, &[4]), Err(AbortCode::CannotStoreDeviceState));
        assert_eq!(rpdo(&mut od, &mut ip, 4), Written::Refused);
        assert!(ip.is_empty());
        assert_eq!(sdo_write(&mut od, &mut ip, CONF, BUFFER_CLEAR, &[1]), Ok(Written::Enabled));
        assert_eq!(send(&mut od, &mut ip, &[5]), Ok(Written::Stored));
        assert_eq!(ip.next(), Some([5, 0]));
    }

    #[test]
    fn n_150_clearing_a_ring_resets_the_read_pointer() {
        let (mut od, mut ip) = ring_of(3);
        for (slot, position) in [(0u16, 1), (1, 2), (2, 3)] {
            at(&mut od, &mut ip, slot);
            send(&mut od, &mut ip, &[position]).unwrap();
        }
        ip.next();
        ip.next();
        sdo_write(&mut od, &mut ip, CONF, BUFFER_CLEAR, &[0]).unwrap();
        assert_eq!(od.get::<u16>(CONF, BUFFER_POSITION), Ok(0));
        sdo_write(&mut od, &mut ip, CONF, BUFFER_CLEAR, &[1]).unwrap();
        for (slot, position) in [(0u16, 7), (2, 9)] {
            at(&mut od, &mut ip, slot);
            send(&mut od, &mut ip, &[position]).unwrap();
        }
        assert_eq!(ip.next(), Some([7, 0]), "replay starts again at the first record");
        assert_eq!(ip.next(), Some([9, 0]));
    }

    #[test]
    fn n_151_max_size_is_read_only_and_subs_5_and_6_write_only() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        let max = sdo_read(&od, CONF, MAX_BUFFER_SIZE).unwrap();
        assert!(max >= 1);
        assert_eq!(max, MAX_RECORDS as u64);
        assert_eq!(
            sdo_write(&mut od, &mut ip, CONF, MAX_BUFFER_SIZE, &4u32.to_le_bytes()),
            Err(AbortCode::WriteOfReadOnly)
        );
        assert_eq!(sdo_read(&od, CONF, SIZE_OF_DATA_RECORD), Err(AbortCode::ReadOfWriteOnly));
        assert_eq!(sdo_read(&od, CONF, BUFFER_CLEAR), Err(AbortCode::ReadOfWriteOnly));
        assert_eq!(AbortCode::ReadOfWriteOnly.code(), 0x0601_0001);
        assert_eq!(sdo_write(&mut od, &mut ip, CONF, SIZE_OF_DATA_RECORD, &[4]), Ok(Written::Reorganised));
        assert_eq!(sdo_write(&mut od, &mut ip, CONF, BUFFER_CLEAR, &[1]), Ok(Written::Enabled));
    }

    #[test]
    fn n_152_time_period_defaults_and_index_range() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        let period = INTERPOLATION_TIME_PERIOD;
        assert_eq!(od.get::<u8>(period, period_sub::VALUE), Ok(1));
        assert_eq!(od.get::<i8>(period, period_sub::INDEX), Ok(-3));
        for index in [-128i8, -6, 0, 63] {
            assert_eq!(
                sdo_write(&mut od, &mut ip, period, period_sub::INDEX, &index.to_le_bytes()),
                Ok(Written::Ignored)
            );
            assert_eq!(od.get::<i8>(period, period_sub::INDEX), Ok(index));
        }
        assert_eq!(
            sdo_write(&mut od, &mut ip, period, period_sub::INDEX, &[64]),
            Err(AbortCode::ValueTooHigh)
        );
        assert_eq!(
            sdo_write(&mut od, &mut ip, period, period_sub::INDEX, &[127]),
            Err(AbortCode::ValueTooHigh)
        );
        assert_eq!(od.get::<i8>(period, period_sub::INDEX), Ok(63), "refused writes change nothing");
        // The rule holds on its own, without the dictionary's limits.
        assert_eq!(check_write(&od, &ip, period, period_sub::INDEX, &[64]), Err(AbortCode::ValueTooHigh));
        assert_eq!(sdo_write(&mut od, &mut ip, period, period_sub::VALUE, &[250]), Ok(Written::Ignored));
        od.reset(period..=period);
        assert_eq!(od.get::<u8>(period, period_sub::VALUE), Ok(1));
        assert_eq!(od.get::<i8>(period, period_sub::INDEX), Ok(-3));
    }

    #[test]
    fn n_153_fifo_last_word_appends_one_record() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        assert_eq!(sdo_write(&mut od, &mut ip, CONF, SIZE_OF_DATA_RECORD, &[8]), Ok(Written::Reorganised));
        assert_eq!(ip.record_entries(), 2);
        assert_eq!(sdo_write(&mut od, &mut ip, DATA, 1, &10i32.to_le_bytes()), Ok(Written::Staged));
        assert!(ip.is_empty(), "a half record is not buffered");
        assert_eq!(sdo_write(&mut od, &mut ip, DATA, 2, &11i32.to_le_bytes()), Ok(Written::Stored));
        assert_eq!(ip.len(), 1);
        // The next write starts a new record.
        assert_eq!(sdo_write(&mut od, &mut ip, DATA, 1, &20i32.to_le_bytes()), Ok(Written::Staged));
        assert_eq!(ip.len(), 1);
        assert_eq!(sdo_write(&mut od, &mut ip, DATA, 2, &21i32.to_le_bytes()), Ok(Written::Stored));
        assert_eq!(ip.len(), 2);
        assert_eq!(ip.next(), Some([10, 11]));
        assert_eq!(ip.next(), Some([20, 21]));
        assert_eq!(ip.next(), None);
    }

    #[test]
    fn n_153_ring_record_without_a_new_position_overwrites_the_slot() {
        let (mut od, mut ip) = ring_of(4);
        at(&mut od, &mut ip, 2);
        assert_eq!(send(&mut od, &mut ip, &[100]), Ok(Written::Stored));
        assert_eq!(od.get::<u16>(CONF, BUFFER_POSITION), Ok(2), "the ring position does not advance");
        assert_eq!(send(&mut od, &mut ip, &[200]), Ok(Written::Stored));
        assert_eq!(ip.len(), 1);
        assert_eq!(ip.next(), Some([200, 0]));
        assert_eq!(ip.next(), Some([200, 0]));
    }

    #[test]
    fn fifo_consumes_oldest_first_and_underflows_to_none() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        assert_eq!(ip.next(), None);
        for position in [1, 2, 3] {
            assert_eq!(rpdo(&mut od, &mut ip, position), Written::Stored);
        }
        assert_eq!(ip.peek(), Some([1, 0]));
        assert_eq!(ip.next(), Some([1, 0]));
        rpdo(&mut od, &mut ip, 4);
        let rest: [Option<Record>; 4] = core::array::from_fn(|_| ip.next());
        assert_eq!(rest, [Some([2, 0]), Some([3, 0]), Some([4, 0]), None]);
        assert_eq!((ip.next(), ip.peek(), ip.len()), (None, None, 0));
    }

    #[test]
    fn fifo_wraps_around_its_storage() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        for position in 0..(3 * MAX_RECORDS as i32) {
            assert_eq!(rpdo(&mut od, &mut ip, position), Written::Stored);
            assert_eq!(ip.next(), Some([position, 0]));
        }
        assert_eq!(ip.overflows(), 0);
    }

    #[test]
    fn fifo_overflow_from_an_rpdo_gives_the_newest_back_and_counts() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        sdo_write(&mut od, &mut ip, CONF, ACTUAL_BUFFER_SIZE, &2u32.to_le_bytes()).unwrap();
        assert_eq!(rpdo(&mut od, &mut ip, 1), Written::Stored);
        assert_eq!(rpdo(&mut od, &mut ip, 2), Written::Stored);
        assert!(ip.is_full());
        assert_eq!(rpdo(&mut od, &mut ip, 3), Written::Overflow([3, 0]));
        assert_eq!(rpdo(&mut od, &mut ip, 4), Written::Overflow([4, 0]));
        assert_eq!(ip.overflows(), 2);
        assert_eq!(ip.next(), Some([1, 0]), "the buffered records are kept");
        assert_eq!(rpdo(&mut od, &mut ip, 5), Written::Stored);
        let rest: [Option<Record>; 3] = core::array::from_fn(|_| ip.next());
        assert_eq!(rest, [Some([2, 0]), Some([5, 0]), None]);
    }

    #[test]
    fn fifo_overflow_over_sdo_is_refused() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        sdo_write(&mut od, &mut ip, CONF, ACTUAL_BUFFER_SIZE, &1u32.to_le_bytes()).unwrap();
        assert_eq!(send(&mut od, &mut ip, &[1]), Ok(Written::Stored));
        assert_eq!(send(&mut od, &mut ip, &[2]), Err(AbortCode::CannotStore));
        assert_eq!(AbortCode::CannotStore.code(), 0x0800_0020);
        assert_eq!(od.get::<i32>(DATA, 1), Ok(1), "the refused word was not committed");
        assert_eq!(ip.overflows(), 0);
        assert_eq!(ip.next(), Some([1, 0]));
        assert_eq!(send(&mut od, &mut ip, &[3]), Ok(Written::Stored));
    }

    #[test]
    fn reorganisation_discards_records_and_resets_pointers() {
        let (mut od, mut ip) = ring_of(4);
        for (slot, position) in [(0u16, 1), (1, 2), (2, 3)] {
            at(&mut od, &mut ip, slot);
            send(&mut od, &mut ip, &[position]).unwrap();
        }
        ip.next();
        // Size change, even to the same value.
        assert_eq!(
            sdo_write(&mut od, &mut ip, CONF, ACTUAL_BUFFER_SIZE, &4u32.to_le_bytes()),
            Ok(Written::Reorganised)
        );
        assert!(ip.is_empty());
        assert_eq!(ip.next(), None);
        assert_eq!(od.get::<u16>(CONF, BUFFER_POSITION), Ok(0));
        at(&mut od, &mut ip, 0);
        send(&mut od, &mut ip, &[8]).unwrap();
        at(&mut od, &mut ip, 1);
        send(&mut od, &mut ip, &[9]).unwrap();
        assert_eq!(ip.next(), Some([8, 0]), "the read pointer is back at the first record");
        // Organisation change: ring → FIFO.
        assert_eq!(sdo_write(&mut od, &mut ip, CONF, BUFFER_ORGANISATION, &[0]), Ok(Written::Reorganised));
        assert_eq!((ip.organisation(), ip.len()), (Organisation::Fifo, 0));
        assert_eq!((ip.capacity(), ip.is_enabled()), (4, true));
        // Record size change.
        rpdo(&mut od, &mut ip, 5);
        assert_eq!(sdo_write(&mut od, &mut ip, CONF, SIZE_OF_DATA_RECORD, &[8]), Ok(Written::Reorganised));
        assert!(ip.is_empty());
        // Size 0 is the whole capacity.
        sdo_write(&mut od, &mut ip, CONF, ACTUAL_BUFFER_SIZE, &0u32.to_le_bytes()).unwrap();
        assert_eq!(ip.capacity(), MAX_RECORDS);
    }

    #[test]
    fn reload_takes_the_dictionary_configuration() {
        let mut od = dict();
        od.set::<u32>(CONF, ACTUAL_BUFFER_SIZE, 3).unwrap();
        od.set::<u8>(CONF, BUFFER_ORGANISATION, 1).unwrap();
        od.set::<u8>(CONF, SIZE_OF_DATA_RECORD, 8).unwrap();
        od.set::<u8>(CONF, BUFFER_CLEAR, 0).unwrap();
        let mut ip = IpBuffer::new();
        rpdo(&mut od, &mut ip, 1);
        ip.reload(&od);
        assert_eq!((ip.capacity(), ip.organisation(), ip.record_entries()), (3, Organisation::Ring, 2));
        assert!(ip.is_empty() && !ip.is_enabled());
        // Values only the device side could have set fall back to the power-on meaning.
        od.set::<u32>(CONF, ACTUAL_BUFFER_SIZE, 1000).unwrap();
        od.set::<u8>(CONF, BUFFER_ORGANISATION, 9).unwrap();
        od.set::<u8>(CONF, SIZE_OF_DATA_RECORD, 6).unwrap();
        od.set::<u8>(CONF, BUFFER_CLEAR, 1).unwrap();
        ip.reload(&od);
        assert_eq!(
            (ip.capacity(), ip.organisation(), ip.record_entries()),
            (MAX_RECORDS, Organisation::Fifo, 1)
        );
        assert!(ip.is_empty() && ip.is_enabled());
        assert_eq!(ip.next(), None);
    }

    #[test]
    fn ring_position_outside_the_buffer_is_refused() {
        let (mut od, mut ip) = ring_of(4);
        assert_eq!(
            sdo_write(&mut od, &mut ip, CONF, BUFFER_POSITION, &4u16.to_le_bytes()),
            Err(AbortCode::ValueTooHigh)
        );
        at(&mut od, &mut ip, 3);
        // Set from the device side: the record cannot be placed.
        od.set::<u16>(CONF, BUFFER_POSITION, 9).unwrap();
        assert_eq!(send(&mut od, &mut ip, &[1]), Err(AbortCode::CannotStore));
        assert_eq!(rpdo(&mut od, &mut ip, 1), Written::Overflow([1, 0]));
        assert_eq!((ip.overflows(), ip.len()), (1, 0));
        // In a FIFO the position has no effect and is not checked.
        let mut od = dict();
        let mut ip = IpBuffer::new();
        assert_eq!(
            sdo_write(&mut od, &mut ip, CONF, BUFFER_POSITION, &500u16.to_le_bytes()),
            Ok(Written::Ignored)
        );
        assert_eq!(rpdo(&mut od, &mut ip, 1), Written::Stored);
    }

    #[test]
    fn words_beyond_the_record_do_not_touch_the_buffer() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        assert_eq!(sdo_write(&mut od, &mut ip, DATA, 2, &7i32.to_le_bytes()), Ok(Written::Ignored));
        assert_eq!(od.get::<i32>(DATA, 2), Ok(7));
        assert!(ip.is_empty());
        assert_eq!(sdo_write(&mut od, &mut ip, DATA, 0, &[1]), Err(AbortCode::WriteOfReadOnly));
        assert_eq!(sdo_write(&mut od, &mut ip, DATA, 3, &[0; 4]), Err(AbortCode::SubIndexDoesNotExist));
        assert_eq!(ip.written(&mut od, 0x6040, 0), Written::Ignored);
    }

    #[test]
    fn sub_mode_select_accepts_only_linear() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        let select = INTERPOLATION_SUB_MODE_SELECT;
        assert_eq!(sdo_write(&mut od, &mut ip, select, 0, &0i16.to_le_bytes()), Ok(Written::Ignored));
        for refused in [1i16, -1, 32767, -32768] {
            assert_eq!(
                sdo_write(&mut od, &mut ip, select, 0, &refused.to_le_bytes()),
                Err(AbortCode::InvalidValue)
            );
        }
        assert_eq!(od.get::<i16>(select, 0), Ok(0));
    }

    #[test]
    fn configuration_value_rules() {
        let mut od = dict();
        let mut ip = IpBuffer::new();
        let mut write = |sub: u8, data: &[u8]| sdo_write(&mut od, &mut ip, CONF, sub, data).map(|_| ());
        let max = MAX_RECORDS as u32;
        assert_eq!(write(ACTUAL_BUFFER_SIZE, &(max + 1).to_le_bytes()), Err(AbortCode::ValueTooHigh));
        assert_eq!(write(ACTUAL_BUFFER_SIZE, &u32::MAX.to_le_bytes()), Err(AbortCode::ValueTooHigh));
        assert_eq!(write(ACTUAL_BUFFER_SIZE, &max.to_le_bytes()), Ok(()));
        assert_eq!(write(ACTUAL_BUFFER_SIZE, &1u32.to_le_bytes()), Ok(()));
        assert_eq!(write(BUFFER_ORGANISATION, &[2]), Err(AbortCode::InvalidValue));
        assert_eq!(write(BUFFER_ORGANISATION, &[0xFF]), Err(AbortCode::InvalidValue));
        assert_eq!(write(BUFFER_ORGANISATION, &[1]), Ok(()));
        assert_eq!(write(BUFFER_ORGANISATION, &[0]), Ok(()));
        assert_eq!(write(SIZE_OF_DATA_RECORD, &[0]), Err(AbortCode::ValueTooLow));
        assert_eq!(write(SIZE_OF_DATA_RECORD, &[1]), Err(AbortCode::InvalidValue));
        assert_eq!(write(SIZE_OF_DATA_RECORD, &[6]), Err(AbortCode::InvalidValue));
        assert_eq!(write(SIZE_OF_DATA_RECORD, &[12]), Err(AbortCode::ValueTooHigh));
        assert_eq!(write(SIZE_OF_DATA_RECORD, &[255]), Err(AbortCode::ValueTooHigh));
        assert_eq!(write(SIZE_OF_DATA_RECORD, &[4]), Ok(()));
        assert_eq!(write(SIZE_OF_DATA_RECORD, &[8]), Ok(()));
        assert_eq!(write(BUFFER_CLEAR, &[2]), Err(AbortCode::InvalidValue));
        assert_eq!(write(BUFFER_CLEAR, &[0]), Ok(()));
        assert_eq!(write(BUFFER_CLEAR, &[1]), Ok(()));
        assert_eq!(write(BUFFER_POSITION, &[0, 0, 0]), Err(AbortCode::LengthTooHigh));
        // A refused value leaves the buffer as it was.
        assert_eq!((ip.capacity(), ip.organisation(), ip.record_entries()), (1, Organisation::Fifo, 2));
    }

    #[test]
    fn period_conversion_is_exact() {
        assert_eq!(interpolation_period_us(1, -3), Some(1_000));
        assert_eq!(interpolation_period_us(1, -6), Some(1));
        assert_eq!(interpolation_period_us(250, -6), Some(250));
        assert_eq!(interpolation_period_us(125, -5), Some(1_250));
        assert_eq!(interpolation_period_us(10, -7), Some(1));
        assert_eq!(interpolation_period_us(200, -8), Some(2));
        assert_eq!(interpolation_period_us(4, -4), Some(400));
        assert_eq!(interpolation_period_us(1, 0), Some(1_000_000));
        assert_eq!(interpolation_period_us(36, 2), Some(3_600_000_000));
        assert_eq!(interpolation_period_us(1, -6 + 9), Some(1_000_000_000));
        // Not a whole number of µs, shorter than 1 µs, zero, or longer than an hour.
        assert_eq!(interpolation_period_us(15, -7), None);
        assert_eq!(interpolation_period_us(5, -7), None);
        assert_eq!(interpolation_period_us(255, -9), None);
        assert_eq!(interpolation_period_us(0, -3), None);
        assert_eq!(interpolation_period_us(37, 2), None);
        assert_eq!(interpolation_period_us(1, 4), None);
        assert_eq!(interpolation_period_us(255, 63), None);
        assert_eq!(interpolation_period_us(255, -128), None);
        assert_eq!(interpolation_period_us(1, i8::MIN), None);
    }
}

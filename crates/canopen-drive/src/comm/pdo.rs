//! Process data objects (CiA 301 §7.2.2): RPDOs and TPDOs with dynamic mapping.
//!
//! ```text
//! communication record 1400h+n (RPDO) / 1800h+n (TPDO):
//!   sub1 COB-ID (bit 31 = invalid, TPDO bit 30 = no RTR), sub2 transmission type,
//!   sub3 inhibit time (TPDO, 100 µs), sub5 event timer (ms), sub6 SYNC start value (TPDO)
//! mapping record 1600h+n / 1A00h+n:
//!   sub0 number of entries (0 = disabled), sub1..8 = index << 16 | sub << 8 | bit length
//! frame: the mapped values packed from bit 0 of byte 0, little-endian, DLC = mapped bytes
//! ```
//!
//! The number of PDOs is a compile-time capacity of [`PdoSet`]; the matching dictionary
//! objects come from [`objects`] (the crate's default table has 4 + 4 with the CiA 402
//! predefined mapping: RPDO1 6040h; RPDO2 6040h+6060h; RPDO3 6040h+607Ah; RPDO4 6040h+60FFh;
//! TPDO1 6041h; TPDO2 6041h+6061h; TPDO3 6041h+6064h; TPDO4 6041h+606Ch).
//!
//! Decisions where the standard leaves room (CiA 301 §7.2.2):
//! - Changing a mapping while the PDO is valid, or a mapping entry while sub0 ≠ 0, is refused
//!   with 0x0601_0000 (as CANopenNode and Copley drives do).
//! - An entry maps a whole object (bit length = its size), or 1 bit of a BOOLEAN; dummy entries
//!   0001h–0007h of their type's size skip bits. At most [`MAX_MAPPED`] entries and 64 bits.
//! - RTR: a TPDO whose COB-ID has bit 30 = 0 answers remote frames (type 252 with the data
//!   sampled at the last SYNC, any other type with fresh data). Types 241–251 are refused.
//! - An RPDO shorter than its mapping raises EMCY 0x8210 and is not applied; a longer one is
//!   applied and raises EMCY 0x8220 as CiA 301 says (both cleared by the next correct frame).
//!   [`LongRpdo`] makes the long case silent or discarded instead. An RPDO whose
//!   values fail a limit check, the drive's value rules ([`ValueRules`], the same as for SDO)
//!   or the firmware's hook is not applied at all.
//! - A synchronous RPDO (types 0–240) is latched on reception and applied at the first tick
//!   after the next SYNC; synchronous TPDOs are sampled and queued when the SYNC is processed.
//! - A valid PDO whose stored mapping cannot be resolved (e.g. after a firmware change) is
//!   disabled and reported with EMCY 0x8200.

use crate::od::{
    AbortCode, Access, DataType, DefaultValue, Dictionary, Entry, Object, ObjectHooks, PdoMapping, Span, Var,
};
use crate::time::{Duration, Instant, ShortDuration};
use crate::wire::cob_id::{self, CobId};

/// First RPDO communication parameter (1400h).
pub const RPDO_COMMUNICATION: u16 = 0x1400;
/// First RPDO mapping parameter (1600h).
pub const RPDO_MAPPING: u16 = 0x1600;
/// First TPDO communication parameter (1800h).
pub const TPDO_COMMUNICATION: u16 = 0x1800;
/// First TPDO mapping parameter (1A00h).
pub const TPDO_MAPPING: u16 = 0x1A00;
/// Most mapping entries per PDO.
pub const MAX_MAPPED: u8 = 8;

/// Direction of a PDO.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Received by the drive.
    Rpdo,
    /// Transmitted by the drive.
    Tpdo,
}

/// Which record of which PDO an index names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PdoRecord {
    /// RPDO or TPDO.
    pub direction: Direction,
    /// Communication (true) or mapping (false) record.
    pub communication: bool,
    /// PDO number - 1.
    pub number: usize,
}

impl PdoRecord {
    /// The record at `index`, if it is a PDO record (1400h–1BFFh).
    pub fn of(index: u16) -> Option<Self> {
        let (direction, communication, base) = match index {
            0x1400..=0x15FF => (Direction::Rpdo, true, RPDO_COMMUNICATION),
            0x1600..=0x17FF => (Direction::Rpdo, false, RPDO_MAPPING),
            0x1800..=0x19FF => (Direction::Tpdo, true, TPDO_COMMUNICATION),
            0x1A00..=0x1BFF => (Direction::Tpdo, false, TPDO_MAPPING),
            _ => return None,
        };
        Some(PdoRecord { direction, communication, number: usize::from(index - base) })
    }

    fn communication_index(self) -> u16 {
        let base = match self.direction {
            Direction::Rpdo => RPDO_COMMUNICATION,
            Direction::Tpdo => TPDO_COMMUNICATION,
        };
        base + self.number as u16
    }

    fn mapping_index(self) -> u16 {
        self.communication_index() + 0x200
    }
}

// --- The dictionary objects -------------------------------------------------------------

const HIGHEST_SUB: &str = "Highest sub-index supported";

const fn u32_rw(name: &'static str, default: DefaultValue) -> Var {
    Var::new(name, DataType::Unsigned32).access(Access::ReadWrite).default(default)
}

// One description per record kind, shared by every PDO of the table: the defaults that
// differ from PDO to PDO (COB-ID, transmission type, mapping) are `DefaultValue::PdoPreset`,
// computed by `od::standard::pdo_preset` from the index (a description per PDO cost ~10 KiB of flash).

static RPDO_COMMUNICATION_SUBS: [(u8, Var); 4] = [
    (0, Var::new(HIGHEST_SUB, DataType::Unsigned8).access(Access::Const).default(DefaultValue::Unsigned(5))),
    (1, u32_rw("COB-ID used by RPDO", DefaultValue::PdoPreset)),
    (
        2,
        Var::new("Transmission type", DataType::Unsigned8)
            .access(Access::ReadWrite)
            .default(DefaultValue::Unsigned(255)),
    ),
    (5, Var::new("Event timer", DataType::Unsigned16).access(Access::ReadWrite)),
];

static TPDO_COMMUNICATION_SUBS: [(u8, Var); 6] = [
    (0, Var::new(HIGHEST_SUB, DataType::Unsigned8).access(Access::Const).default(DefaultValue::Unsigned(6))),
    (1, u32_rw("COB-ID used by TPDO", DefaultValue::PdoPreset)),
    (
        2,
        Var::new("Transmission type", DataType::Unsigned8)
            .access(Access::ReadWrite)
            .default(DefaultValue::PdoPreset),
    ),
    (3, Var::new("Inhibit time", DataType::Unsigned16).access(Access::ReadWrite)),
    (5, Var::new("Event timer", DataType::Unsigned16).access(Access::ReadWrite)),
    (6, Var::new("SYNC start value", DataType::Unsigned8).access(Access::ReadWrite)),
];

/// Mapping entry `name` (each its own name: masters look entries up by name).
const fn mapping_entry(name: &'static str) -> Var {
    u32_rw(name, DefaultValue::PdoPreset)
}

static MAPPING_SUBS: [(u8, Var); 9] = [
    (
        0,
        Var::new("Number of mapped objects", DataType::Unsigned8)
            .access(Access::ReadWrite)
            .default(DefaultValue::PdoPreset),
    ),
    (1, mapping_entry("Mapping entry 1")),
    (2, mapping_entry("Mapping entry 2")),
    (3, mapping_entry("Mapping entry 3")),
    (4, mapping_entry("Mapping entry 4")),
    (5, mapping_entry("Mapping entry 5")),
    (6, mapping_entry("Mapping entry 6")),
    (7, mapping_entry("Mapping entry 7")),
    (8, mapping_entry("Mapping entry 8")),
];

/// The power-on value of [`DefaultValue::PdoPreset`] entries (the pre-defined connection set,
/// a fact of the dictionary: [`crate::od::standard::pdo_preset`]).
pub use crate::od::standard::pdo_preset as preset;

/// The 1400h/1600h/1800h/1A00h objects of `rpdos` RPDOs and `N / 2 - rpdos` TPDOs, to be laid out
/// with [`crate::od::layout`]: `static PDOS: [Object; 16] = layout(pdo::objects::<16>(4));`.
/// PDOs 1–4 carry the CiA 402 pre-defined identifiers and mapping; the others start invalid
/// and empty.
// Indices are bounded by the loops and by `min(4)`; `get` is not usable in a const fn.
#[allow(clippy::indexing_slicing)]
pub const fn objects<const N: usize>(rpdos: usize) -> [Object; N] {
    let tpdos = N / 2 - rpdos;
    let mut out = [Object::var(0, "", Var::new("", DataType::Unsigned8)); N];
    let mut i = 0;
    while i < rpdos {
        let n = (i + 1) as u16;
        out[i] = Object::record(
            RPDO_COMMUNICATION + i as u16,
            "RPDO communication parameter",
            &RPDO_COMMUNICATION_SUBS,
        )
        .numbered(n);
        out[rpdos + i] =
            Object::record(RPDO_MAPPING + i as u16, "RPDO mapping parameter", &MAPPING_SUBS).numbered(n);
        i += 1;
    }
    let mut j = 0;
    while j < tpdos {
        let n = (j + 1) as u16;
        out[2 * rpdos + j] = Object::record(
            TPDO_COMMUNICATION + j as u16,
            "TPDO communication parameter",
            &TPDO_COMMUNICATION_SUBS,
        )
        .numbered(n);
        out[2 * rpdos + tpdos + j] =
            Object::record(TPDO_MAPPING + j as u16, "TPDO mapping parameter", &MAPPING_SUBS).numbered(n);
        j += 1;
    }
    out
}

/// The default 4 RPDOs + 4 TPDOs.
pub static DEFAULT_OBJECTS: [Object; 16] = crate::od::layout(objects::<16>(4));

/// Counts the RPDO and TPDO communication records of a table.
pub fn count(table: &[Object]) -> (usize, usize) {
    table.iter().fold((0, 0), |(r, t), o| match PdoRecord::of(o.index) {
        Some(PdoRecord { direction: Direction::Rpdo, communication: true, .. }) => (r + 1, t),
        Some(PdoRecord { direction: Direction::Tpdo, communication: true, .. }) => (r, t + 1),
        _ => (r, t),
    })
}

// --- Mapping ---------------------------------------------------------------------------

/// One mapping entry, decided when the mapping was validated: where its value lives, and what a
/// received value must pass besides its size (which the mapping already fixed).
#[derive(Clone, Copy, Debug)]
struct Slot {
    /// Index of the mapped entry (0 for a dummy entry).
    index: u16,
    /// Store offset of the value (every mappable entry is a stored number of up to 8 bytes).
    offset: u16,
    /// Sub-index of the mapped entry.
    sub: u8,
    /// Mapped length in bits.
    bits: u8,
    /// Bytes of the stored value; 0 for a dummy entry.
    len: u8,
    /// The value rule of the entry's owner, as [`ValueRules::rule`] gave it (RPDOs; 0: none),
    /// and [`LIMITS`] when a received value must be checked against the entry's limits (rare:
    /// the description is looked up again for it). Eight bytes a slot: a node holds 64.
    rule: u8,
}

/// Bit of [`Slot::rule`]: the entry has limits beyond its type's range
/// ([`Dictionary::has_limits`]); the bits of [`ValueRules::rule`] stay below it or are
/// [`ValueRules::REACTS`].
const LIMITS: u8 = 0x40;

impl Slot {
    const DUMMY: Slot = Slot { index: 0, offset: 0, sub: 0, bits: 0, len: 0, rule: 0 };

    fn span(&self) -> Span {
        Span::new(self.offset, self.len)
    }
}

/// A validated mapping.
#[derive(Clone, Copy, Debug)]
struct Mapping {
    slots: [Slot; MAX_MAPPED as usize],
    count: u8,
    /// Mapped bits, at most 64 ([`resolve_mapping`] refuses more).
    bits: u8,
    /// Some received value has a limit or a rule to pass (RPDOs).
    checked: bool,
    /// Every entry is process data ([`ValueRules::is_process_data`]; RPDOs): a frame changes no
    /// configuration ([`Dictionary::touch_process_data`]).
    process_data: bool,
}

impl Mapping {
    const EMPTY: Mapping = Mapping {
        slots: [Slot::DUMMY; MAX_MAPPED as usize],
        count: 0,
        bits: 0,
        checked: false,
        process_data: false,
    };

    fn bytes(&self) -> usize {
        usize::from(self.bits).div_ceil(8)
    }

    fn slots(&self) -> &[Slot] {
        self.slots.get(..usize::from(self.count)).unwrap_or(&[])
    }
}

/// Resolves one mapping entry value, with the abort code of CiA 301 §7.2.2 when it cannot be
/// mapped; also the entry, for its rule.
fn resolve<const B: usize>(
    od: &Dictionary<B>,
    raw: u32,
    direction: Direction,
) -> Result<(Slot, Option<Entry>), AbortCode> {
    let index = (raw >> 16) as u16;
    let sub = (raw >> 8) as u8;
    let bits = raw as u8;
    if bits == 0 {
        return Err(AbortCode::ObjectNotMappable);
    }
    // Dummy entries: data types 0001h..0007h, sub 0, their own size.
    if (1..=7).contains(&index) {
        let size = match index {
            1 => 1,
            2 | 5 => 8,
            3 | 6 => 16,
            _ => 32,
        };
        return if sub == 0 && bits == size {
            Ok((Slot { bits, ..Slot::DUMMY }, None))
        } else {
            Err(AbortCode::ObjectNotMappable)
        };
    }
    let entry = od.bus_entry(index, sub)?;
    let var = entry.var;
    let direction_ok = match direction {
        Direction::Rpdo => matches!(var.pdo, PdoMapping::Rpdo | PdoMapping::Both) && var.access.writable(),
        Direction::Tpdo => matches!(var.pdo, PdoMapping::Tpdo | PdoMapping::Both) && var.access.readable(),
    };
    let size_bits = var.data_type.fixed_size().map(|n| n * 8);
    let length_ok = size_bits == Some(usize::from(bits)) || (var.data_type == DataType::Boolean && bits == 1);
    let span = od.span(&entry).filter(|_| direction_ok && length_ok);
    let Some(span) = span else { return Err(AbortCode::ObjectNotMappable) };
    let limits = if direction == Direction::Rpdo && Dictionary::<B>::has_limits(var) { LIMITS } else { 0 };
    let slot = Slot { index, offset: span.offset(), sub, bits, len: span.len() as u8, rule: limits };
    Ok((slot, Some(entry)))
}

/// Resolves the mapping record of `record` as stored in the dictionary, each RPDO entry with its
/// rule from `rules`.
fn resolve_mapping<const B: usize>(
    od: &Dictionary<B>,
    record: PdoRecord,
    rules: &impl ValueRules<B>,
) -> Result<Mapping, AbortCode> {
    let index = record.mapping_index();
    let count = od.get::<u8>(index, 0)?;
    if count > MAX_MAPPED {
        return Err(AbortCode::PdoLengthExceeded);
    }
    let mut mapping = Mapping { count, process_data: record.direction == Direction::Rpdo, ..Mapping::EMPTY };
    let mut bits = 0u16;
    for (sub, slot) in (1..=count).zip(mapping.slots.iter_mut()) {
        let (resolved, entry) = resolve(od, od.get::<u32>(index, sub)?, record.direction)?;
        *slot = resolved;
        if let (Some(entry), Direction::Rpdo) = (entry, record.direction) {
            slot.rule |= rules.rule(&entry) & !LIMITS;
            mapping.process_data &= rules.is_process_data(&entry);
        }
        bits += u16::from(slot.bits);
        mapping.checked |= slot.rule != 0;
    }
    mapping.bits = u8::try_from(bits).ok().filter(|b| *b <= 64).ok_or(AbortCode::PdoLengthExceeded)?;
    Ok(mapping)
}

fn cob_id_of<const B: usize>(od: &Dictionary<B>, record: PdoRecord) -> Option<CobId> {
    CobId::parse(od.get::<u32>(record.communication_index(), 1).ok()?).ok()
}

/// Value rules of the PDO records beyond type and limits (CiA 301 §7.2.2), checked before a write
/// from the bus is stored.
pub fn check_write<const B: usize>(
    od: &Dictionary<B>,
    index: u16,
    sub: u8,
    data: &[u8],
    remap_while_valid: bool,
) -> Result<(), AbortCode> {
    let Some(record) = PdoRecord::of(index) else { return Ok(()) };
    let raw = data.iter().rev().fold(0u32, |acc, b| (acc << 8) | u32::from(*b));
    let current = cob_id_of(od, record);
    let valid = current.is_some_and(|c| c.valid);
    if !record.communication {
        // Mapping: only while the PDO is invalid (unless the drive lets mappings change while
        // it is valid), entries only while sub0 = 0.
        if valid && !remap_while_valid {
            return Err(AbortCode::UnsupportedAccess);
        }
        if sub == 0 {
            let count = raw as u8;
            if count > MAX_MAPPED {
                return Err(AbortCode::PdoLengthExceeded);
            }
            let mut bits = 0u16;
            for s in 1..=count {
                bits += u16::from(resolve(od, od.get::<u32>(index, s)?, record.direction)?.0.bits);
            }
            return if bits > 64 { Err(AbortCode::PdoLengthExceeded) } else { Ok(()) };
        }
        if od.get::<u8>(index, 0)? != 0 {
            return Err(AbortCode::UnsupportedAccess);
        }
        if raw != 0 {
            resolve(od, raw, record.direction)?;
        }
        return Ok(());
    }
    match sub {
        1 => {
            let new = CobId::parse(raw).map_err(|_| AbortCode::InvalidValue)?;
            if new.valid && cob_id::is_restricted(new.can_id) {
                return Err(AbortCode::InvalidValue);
            }
            if let Some(old) = current {
                if old.valid && new.valid && old.can_id != new.can_id {
                    return Err(AbortCode::InvalidValue);
                }
            }
            if new.valid && !valid {
                // Validating: the mapping must be usable and not empty.
                let mapping = resolve_mapping(od, record, &NoRules).map_err(|_| AbortCode::InvalidValue)?;
                if mapping.count == 0 {
                    return Err(AbortCode::InvalidValue);
                }
            }
            Ok(())
        }
        2 => match (record.direction, raw) {
            (_, 0..=240 | 254 | 255) => Ok(()),
            (Direction::Tpdo, 252 | 253) => Ok(()),
            _ => Err(AbortCode::InvalidValue),
        },
        // Inhibit time and SYNC start value only while the PDO is invalid.
        3 | 6 if valid => Err(AbortCode::InvalidValue),
        6 if raw > 240 => Err(AbortCode::InvalidValue),
        _ => Ok(()),
    }
}

// --- Runtime ---------------------------------------------------------------------------

/// Where PDO frames go: the drive's transmit queue.
pub trait FrameSink {
    /// Queues a frame; false when it was dropped.
    fn send(&mut self, id: u16, data: &[u8]) -> bool;

    /// Queues a frame of the first `len` bytes of `data`, whose further bytes are zero (a whole
    /// frame's buffer: no copy of a variable length on the way).
    fn send_array(&mut self, id: u16, data: [u8; 8], len: usize) -> bool {
        self.send(id, data.get(..len).unwrap_or(&data))
    }
}

/// Something the PDO layer asks the drive to report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum PdoEvent {
    /// Raise the EMCY `code`.
    Raise(u16),
    /// Clear the EMCY `code`.
    Clear(u16),
    /// An RPDO timed out (EMCY 0x8250 and the communication-error reaction).
    RpdoTimeout(u16),
    /// An RPDO stored a value whose rule asks for the owner's reaction
    /// ([`ValueRules::REACTS`]).
    Written {
        /// Index of the entry.
        index: u16,
        /// Sub-index of the entry.
        sub: u8,
        /// The entry's rule.
        rule: u8,
    },
}

#[derive(Clone, Copy, Debug)]
struct Rpdo {
    can_id: Option<u16>,
    synchronous: bool,
    mapping: Mapping,
    latched: Option<[u8; 8]>,
    ready: Option<[u8; 8]>,
    timeout: ShortDuration,
    deadline: Option<Instant>,
}

impl Rpdo {
    const OFF: Rpdo = Rpdo {
        can_id: None,
        synchronous: false,
        mapping: Mapping::EMPTY,
        latched: None,
        ready: None,
        timeout: ShortDuration::ZERO,
        deadline: None,
    };
}

#[derive(Clone, Copy, Debug)]
struct Tpdo {
    can_id: Option<u16>,
    rtr: bool,
    transmission: u8,
    mapping: Mapping,
    inhibit: ShortDuration,
    event_timer: ShortDuration,
    sync_start: u8,
    /// SYNCs counted towards the next cyclic transmission; `None` until the start value.
    sync_count: Option<u8>,
    next_allowed: Instant,
    pending: bool,
    event_deadline: Option<Instant>,
    /// Types 0, 254 and 255: the data last sent or compared, for change detection; type 252:
    /// the data sampled at the last SYNC, for the next remote request (one field: the type
    /// decides which, and a new configuration clears it).
    data: Option<[u8; 8]>,
    changed: bool,
}

impl Tpdo {
    const OFF: Tpdo = Tpdo {
        can_id: None,
        rtr: false,
        transmission: 255,
        mapping: Mapping::EMPTY,
        inhibit: ShortDuration::ZERO,
        event_timer: ShortDuration::ZERO,
        sync_start: 0,
        sync_count: None,
        next_allowed: Instant::ZERO,
        pending: false,
        event_deadline: None,
        data: None,
        changed: false,
    };

    fn event_driven(&self) -> bool {
        matches!(self.transmission, 254 | 255)
    }
}

/// The policy for an RPDO longer than its mapping (CiA 301 §7.2.2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LongRpdo {
    /// CiA 301: the first bytes are applied; EMCY 0x8220 is sent (the default).
    #[default]
    ApplyAndReport,
    /// The first bytes are applied without an EMCY.
    Apply,
    /// Not applied, EMCY 0x8220 (what some masters' conformance expectations want).
    DiscardAndReport,
}

/// A data frame offered to the RPDOs.
#[derive(Clone, Copy, Debug)]
pub struct RpdoFrame<'a> {
    /// CAN identifier.
    pub can_id: u16,
    /// Frame data.
    pub data: &'a [u8],
    /// Reception time.
    pub now: Instant,
    /// The synchronous window (1007h) has closed since the last SYNC.
    pub late: bool,
}

/// Runtime state of `R` RPDOs and `T` TPDOs.
pub struct PdoSet<const R: usize, const T: usize> {
    rpdos: [Rpdo; R],
    tpdos: [Tpdo; T],
    /// Some synchronous RPDO latched a frame since the last SYNC.
    latched: bool,
    /// Some RPDO has a frame ready for the next tick.
    ready: bool,
    /// Before this instant no event-driven TPDO is pending, due or waiting to be armed
    /// ([`Instant::ZERO`]: look at the next call).
    idle_until: Instant,
    /// EMCY 8210h / 8220h raised by an RPDO and not cleared since (a correct frame clears them:
    /// then, and only then, the clear is reported).
    length_errors: (bool, bool),
    /// What an RPDO longer than its mapping does.
    pub long_rpdo: LongRpdo,
    /// The unit of the TPDO inhibit time (sub 3): 100 µs in CiA 301.
    pub inhibit_unit: Duration,
}

impl<const R: usize, const T: usize> Default for PdoSet<R, T> {
    fn default() -> Self {
        PdoSet {
            rpdos: [Rpdo::OFF; R],
            tpdos: [Tpdo::OFF; T],
            length_errors: (false, false),
            latched: false,
            ready: false,
            idle_until: Instant::ZERO,
            long_rpdo: LongRpdo::ApplyAndReport,
            inhibit_unit: INHIBIT_UNIT,
        }
    }
}

/// The unit of the inhibit times in CiA 301 (TPDO sub 3, 1015h): 100 µs.
pub const INHIBIT_UNIT: Duration = Duration::from_micros(100);

/// The `bits` bits at bit `position` of the frame.
fn get_bits(frame: &[u8; 8], position: usize, bits: usize) -> u64 {
    field_mask(position, bits).map_or(0, |mask| (u64::from_le_bytes(*frame) & mask) >> position)
}

/// The mask of `bits` bits from bit `position` on, cut at the frame's 64 bits (`None`: empty).
fn field_mask(position: usize, bits: usize) -> Option<u64> {
    let bits = bits.min(64usize.checked_sub(position)?);
    let ones = match bits {
        0 => return None,
        64 => u64::MAX,
        n => (1u64 << n) - 1,
    };
    Some(ones << position)
}

fn sample<const B: usize>(od: &Dictionary<B>, mapping: &Mapping) -> [u8; 8] {
    // The frame as one little-endian word, each value or-ed in at its bit position: a validated
    // mapping holds at most 64 bits, and each value fills its field exactly (a whole entry, or
    // the low bit of a BOOLEAN, masked).
    let mut word = 0u64;
    let mut position = 0u32;
    for slot in mapping.slots() {
        let mut value = od.load_span(slot.span());
        if u32::from(slot.bits) < 8 * u32::from(slot.len) {
            value &= (1u64 << slot.bits) - 1;
        }
        word |= value.checked_shl(position).unwrap_or(0);
        position += u32::from(slot.bits);
    }
    word.to_le_bytes()
}

impl<const R: usize, const T: usize> PdoSet<R, T> {
    /// Reloads the configuration of every PDO from the dictionary; returns the EMCY to raise
    /// when a valid PDO's mapping cannot be resolved (0x8200).
    pub fn configure_all<const B: usize>(
        &mut self,
        od: &Dictionary<B>,
        rules: &impl ValueRules<B>,
    ) -> Option<PdoEvent> {
        let mut event = None;
        for number in 0..R {
            let record = PdoRecord { direction: Direction::Rpdo, communication: true, number };
            event = self.configure(od, record, rules).or(event);
        }
        for number in 0..T {
            let record = PdoRecord { direction: Direction::Tpdo, communication: true, number };
            event = self.configure(od, record, rules).or(event);
        }
        event
    }

    /// Reloads one PDO after a write to one of its records.
    pub fn configure<const B: usize>(
        &mut self,
        od: &Dictionary<B>,
        record: PdoRecord,
        rules: &impl ValueRules<B>,
    ) -> Option<PdoEvent> {
        let cob = cob_id_of(od, record);
        let communication = record.communication_index();
        let transmission = od.get::<u8>(communication, 2).unwrap_or(255);
        let event_timer = Duration::from_millis(u64::from(od.get::<u16>(communication, 5).unwrap_or(0)));
        let event_timer = ShortDuration::saturating(event_timer);
        let (mapping, broken) = match cob {
            Some(c) if c.valid => match resolve_mapping(od, record, rules) {
                Ok(m) => (Some(m), false),
                Err(_) => (None, true),
            },
            _ => (None, false),
        };
        let can_id = mapping.and(cob).map(|c| c.can_id);
        if broken {
            crate::fmt::warning!(
                "PDO: {:?} {} has a mapping that cannot be resolved: disabled",
                record.direction,
                record.number + 1
            );
        } else {
            crate::fmt::debug!(
                "PDO: {:?} {} {}: COB-ID {:x}, {} entries",
                record.direction,
                record.number + 1,
                if can_id.is_some() { "valid" } else { "invalid" },
                can_id.unwrap_or(0),
                mapping.map_or(0, |m| m.count)
            );
        }
        let mapping = mapping.unwrap_or(Mapping::EMPTY);
        match record.direction {
            Direction::Rpdo => {
                if let Some(rpdo) = self.rpdos.get_mut(record.number) {
                    *rpdo = Rpdo {
                        can_id,
                        synchronous: transmission <= 240,
                        mapping,
                        timeout: event_timer,
                        ..Rpdo::OFF
                    };
                }
            }
            Direction::Tpdo => {
                self.idle_until = Instant::ZERO;
                if let Some(tpdo) = self.tpdos.get_mut(record.number) {
                    let inhibit = u64::from(od.get::<u16>(communication, 3).unwrap_or(0))
                        * self.inhibit_unit.as_micros();
                    *tpdo = Tpdo {
                        can_id,
                        rtr: cob.is_some_and(|c| !c.bit30),
                        transmission,
                        mapping,
                        inhibit: ShortDuration::saturating(Duration::from_micros(inhibit)),
                        event_timer,
                        sync_start: od.get::<u8>(communication, 6).unwrap_or(0),
                        ..Tpdo::OFF
                    };
                }
            }
        }
        broken.then_some(PdoEvent::Raise(crate::comm::emcy::code::PROTOCOL))
    }

    /// Entering Operational at `now`: event-driven TPDOs are sent once right away, cyclic
    /// counters restart, RPDO supervision waits for the first frame.
    pub fn start(&mut self, now: Instant) {
        self.idle_until = Instant::ZERO;
        for tpdo in self.tpdos.iter_mut().filter(|t| t.can_id.is_some()) {
            tpdo.pending = tpdo.event_driven();
            tpdo.sync_count = None;
            tpdo.data = None;
            tpdo.changed = tpdo.transmission == 0;
            tpdo.event_deadline = None;
            tpdo.next_allowed = now;
        }
        for rpdo in self.rpdos.iter_mut() {
            rpdo.deadline = None;
            rpdo.latched = None;
            rpdo.ready = None;
        }
    }

    /// The identifiers the PDOs receive: those of the valid RPDOs, and of the TPDOs that answer
    /// remote frames.
    pub fn received_ids(&self) -> impl Iterator<Item = u16> + '_ {
        let rpdos = self.rpdos.iter().filter_map(|r| r.can_id);
        rpdos.chain(self.tpdos.iter().filter(|t| t.rtr).filter_map(|t| t.can_id))
    }

    /// Handles a data frame; returns false when no RPDO uses its identifier. `rules` are the
    /// value rules beyond type and limits that every mapped value must pass ([`ValueRules`]);
    /// `events` receives the EMCY changes to make.
    pub fn on_frame<const B: usize>(
        &mut self,
        frame: RpdoFrame<'_>,
        od: &mut Dictionary<B>,
        hooks: &mut impl ObjectHooks,
        rules: &impl ValueRules<B>,
        events: &mut impl FnMut(PdoEvent),
    ) -> bool {
        let RpdoFrame { can_id, data, now, late } = frame;
        let policy = self.long_rpdo;
        let Some(rpdo) = self.rpdos.iter_mut().find(|r| r.can_id == Some(can_id)) else {
            return false;
        };
        let needed = rpdo.mapping.bytes();
        let (short, long) = &mut self.length_errors;
        if data.len() < needed {
            *short = true;
            events(PdoEvent::Raise(crate::comm::emcy::code::PDO_LENGTH));
            return true;
        }
        if core::mem::take(short) {
            events(PdoEvent::Clear(crate::comm::emcy::code::PDO_LENGTH));
        }
        if data.len() > needed && policy != LongRpdo::Apply {
            *long = true;
            events(PdoEvent::Raise(crate::comm::emcy::code::PDO_LENGTH_EXCEEDED));
            if policy == LongRpdo::DiscardAndReport {
                return true;
            }
        } else if core::mem::take(long) {
            events(PdoEvent::Clear(crate::comm::emcy::code::PDO_LENGTH_EXCEEDED));
        }
        if rpdo.timeout != ShortDuration::ZERO {
            if rpdo.deadline.is_none() {
                // Monitoring starts with the first reception; a timed-out RPDO recovers here.
                events(PdoEvent::Clear(crate::comm::emcy::code::RPDO_TIMEOUT));
            }
            rpdo.deadline = Some(now + rpdo.timeout);
        }
        let frame = match data.first_chunk::<8>() {
            // A full frame: a fixed-size copy.
            Some(whole) => *whole,
            None => {
                let mut frame = [0u8; 8];
                for (dst, src) in frame.iter_mut().zip(data) {
                    *dst = *src;
                }
                frame
            }
        };
        if rpdo.synchronous {
            // Outside the synchronous window the data wait for nothing: discarded.
            if !late {
                rpdo.latched = Some(frame);
                self.latched = true;
            }
        } else {
            apply(od, hooks, rules, &rpdo.mapping, &frame, events);
        }
        true
    }

    /// A SYNC was processed: latched RPDOs become ready for the next tick, synchronous TPDOs are
    /// sampled and sent.
    pub fn on_sync<const B: usize>(
        &mut self,
        counter: Option<u8>,
        now: Instant,
        od: &Dictionary<B>,
        tx: &mut impl FrameSink,
    ) {
        if core::mem::take(&mut self.latched) {
            for rpdo in self.rpdos.iter_mut() {
                if let Some(frame) = rpdo.latched.take() {
                    rpdo.ready = Some(frame);
                    self.ready = true;
                }
            }
        }
        for tpdo in self.tpdos.iter_mut() {
            let Some(can_id) = tpdo.can_id else { continue };
            match tpdo.transmission {
                0 if core::mem::take(&mut tpdo.changed) => {
                    send(tx, can_id, &sample(od, &tpdo.mapping), &tpdo.mapping);
                }
                n @ 1..=240 => {
                    let count = match (tpdo.sync_count, tpdo.sync_start, counter) {
                        // Waiting for the SYNC whose counter equals the start value.
                        (None, start @ 1..=240, Some(c)) if c != start => continue,
                        // The SYNC whose counter equals the start value sends the first one.
                        (None, 1..=240, Some(_)) => n,
                        // Counting starts with the first SYNC: the n-th one sends.
                        (None, _, _) => 1,
                        (Some(k), _, _) => k,
                    };
                    if count >= n {
                        send(tx, can_id, &sample(od, &tpdo.mapping), &tpdo.mapping);
                        tpdo.sync_count = Some(1);
                    } else {
                        tpdo.sync_count = Some(count + 1);
                    }
                }
                252 => tpdo.data = Some(sample(od, &tpdo.mapping)),
                _ => {}
            }
        }
        let _ = now;
    }

    /// Whether an RPDO made ready by the last SYNC waits for [`apply_ready`](Self::apply_ready).
    pub fn has_ready(&self) -> bool {
        self.ready
    }

    /// Applies the RPDOs made ready by the last SYNC (the tick calls this first), each value
    /// checked against `rules` as in [`on_frame`](Self::on_frame).
    pub fn apply_ready<const B: usize>(
        &mut self,
        od: &mut Dictionary<B>,
        hooks: &mut impl ObjectHooks,
        rules: &impl ValueRules<B>,
        events: &mut impl FnMut(PdoEvent),
    ) {
        if !core::mem::take(&mut self.ready) {
            return;
        }
        for rpdo in self.rpdos.iter_mut() {
            if let Some(frame) = rpdo.ready.take() {
                apply(od, hooks, rules, &rpdo.mapping, &frame, events);
            }
        }
    }

    /// Detects changes of the values mapped into event-driven and acyclic TPDOs (the tick calls
    /// this last) and sends what the inhibit time allows.
    pub fn detect_changes<const B: usize>(
        &mut self,
        now: Instant,
        od: &Dictionary<B>,
        tx: &mut impl FrameSink,
    ) {
        for tpdo in self.tpdos.iter_mut() {
            if tpdo.can_id.is_none() || !(tpdo.event_driven() || tpdo.transmission == 0) {
                continue;
            }
            let data = sample(od, &tpdo.mapping);
            if tpdo.data != Some(data) {
                tpdo.data = Some(data);
                if tpdo.transmission == 0 {
                    tpdo.changed = true;
                } else {
                    tpdo.pending = true;
                    self.idle_until = Instant::ZERO;
                }
            }
        }
        self.send_pending(now, od, tx);
    }

    /// What is due at `now` of the event-driven TPDOs (pending ones the inhibit time allows,
    /// event timers), without change detection: for a tick after which no mapped value can
    /// have changed ([`Dictionary::revision`]).
    #[inline]
    pub fn send_due<const B: usize>(&mut self, now: Instant, od: &Dictionary<B>, tx: &mut impl FrameSink) {
        if now >= self.idle_until {
            self.send_pending(now, od, tx);
        }
    }

    fn send_pending<const B: usize>(&mut self, now: Instant, od: &Dictionary<B>, tx: &mut impl FrameSink) {
        if now < self.idle_until {
            return;
        }
        let mut wake = Instant::MAX;
        for tpdo in self.tpdos.iter_mut() {
            let Some(can_id) = tpdo.can_id else { continue };
            if !tpdo.event_driven() {
                continue;
            }
            let timer_due = tpdo.event_deadline.is_some_and(|d| now >= d);
            if (tpdo.pending || timer_due) && now >= tpdo.next_allowed {
                let data = sample(od, &tpdo.mapping);
                if send(tx, can_id, &data, &tpdo.mapping) {
                    tpdo.data = Some(data);
                    tpdo.pending = false;
                    tpdo.next_allowed = now + tpdo.inhibit;
                    tpdo.event_deadline =
                        (tpdo.event_timer != ShortDuration::ZERO).then(|| now + tpdo.event_timer);
                }
            } else if tpdo.event_deadline.is_none() && tpdo.event_timer != ShortDuration::ZERO {
                tpdo.event_deadline = Some(now + tpdo.event_timer);
            }
            if tpdo.pending {
                wake = wake.min(tpdo.next_allowed);
            }
            if let Some(deadline) = tpdo.event_deadline {
                wake = wake.min(deadline.max(tpdo.next_allowed));
            }
        }
        self.idle_until = wake;
    }

    /// Timers due at `now`: event timers, inhibited transmissions, RPDO timeouts.
    pub fn poll<const B: usize>(
        &mut self,
        now: Instant,
        od: &Dictionary<B>,
        tx: &mut impl FrameSink,
        events: &mut impl FnMut(PdoEvent),
    ) {
        self.send_pending(now, od, tx);
        for (number, rpdo) in self.rpdos.iter_mut().enumerate() {
            if rpdo.deadline.is_some_and(|d| now >= d) {
                rpdo.deadline = None;
                events(PdoEvent::RpdoTimeout(number as u16 + 1));
            }
        }
    }

    /// A remote frame on `can_id`: answered by a TPDO that allows RTR; returns whether one did.
    pub fn on_remote<const B: usize>(
        &mut self,
        can_id: u16,
        now: Instant,
        od: &Dictionary<B>,
        tx: &mut impl FrameSink,
    ) -> bool {
        let Some(tpdo) = self.tpdos.iter_mut().find(|t| t.can_id == Some(can_id) && t.rtr) else {
            return false;
        };
        let data = match (tpdo.transmission, tpdo.data) {
            (252, Some(sampled)) => sampled,
            (252, None) => return true,
            _ => sample(od, &tpdo.mapping),
        };
        send(tx, can_id, &data, &tpdo.mapping);
        tpdo.next_allowed = now + tpdo.inhibit;
        true
    }

    /// When [`poll`](Self::poll) has something to do.
    pub fn deadline(&self) -> Option<Instant> {
        let tpdo = self.tpdos.iter().filter(|t| t.can_id.is_some() && t.event_driven()).filter_map(|t| {
            let pending = t.pending.then_some(t.next_allowed);
            match (pending, t.event_deadline) {
                (Some(a), Some(b)) => Some(a.min(b.max(t.next_allowed))),
                (a, b) => a.or(b.map(|b| b.max(t.next_allowed))),
            }
        });
        let rpdo = self.rpdos.iter().filter_map(|r| r.deadline);
        tpdo.chain(rpdo).min()
    }
}

fn send(tx: &mut impl FrameSink, can_id: u16, data: &[u8; 8], mapping: &Mapping) -> bool {
    tx.send_array(can_id, *data, mapping.bytes())
}

/// The value rules beyond type and limits that the drive applies to writes from the bus (the
/// modes 6502h lists, supported option codes, …): an RPDO must not store a value that an SDO
/// download of the same entry would be refused. The rule of an entry is decided once, when its
/// mapping is validated ([`rule`](Self::rule)); a received value then passes only the check of
/// its rule ([`check`](Self::check)), and an entry without a rule is a plain copy.
pub trait ValueRules<const B: usize> {
    /// Bit of a rule: the owner reacts to a stored value ([`PdoEvent::Written`]).
    const REACTS: u8 = 0x80;

    /// The rule of `entry` as an RPDO writes it: 0 for none, else a value of the implementor's
    /// own numbering below 40h, with [`REACTS`](Self::REACTS) set when the owner reacts to the
    /// value.
    fn rule(&self, entry: &Entry) -> u8;

    /// Checks `data` (size and limits already checked) as the new value of `index`/`sub`
    /// under `rule`.
    fn check(&self, od: &Dictionary<B>, rule: u8, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode>;

    /// Whether `entry` is process data, a set-point or a command whose value changes nothing
    /// derived from configuration: an RPDO that maps only such entries is counted in
    /// [`Dictionary::revision`] but not in [`Dictionary::configuration_revision`]. None is by
    /// default.
    fn is_process_data(&self, _entry: &Entry) -> bool {
        false
    }
}

/// No rules beyond type and limits.
pub struct NoRules;

impl<const B: usize> ValueRules<B> for NoRules {
    fn rule(&self, _entry: &Entry) -> u8 {
        0
    }

    fn check(&self, _: &Dictionary<B>, _: u8, _: u16, _: u8, _: &[u8]) -> Result<(), AbortCode> {
        Ok(())
    }
}

/// Writes an RPDO's values into the dictionary: all or nothing (limits, value rules and hooks
/// checked first, when the mapping or the hooks have any).
fn apply<const B: usize, V: ValueRules<B>, H: ObjectHooks>(
    od: &mut Dictionary<B>,
    hooks: &mut H,
    rules: &V,
    mapping: &Mapping,
    frame: &[u8; 8],
    events: &mut impl FnMut(PdoEvent),
) {
    if mapping.checked || H::VALIDATES {
        let mut position = 0;
        for slot in mapping.slots() {
            let at = position;
            position += usize::from(slot.bits);
            if slot.rule == 0 && !H::VALIDATES {
                continue;
            }
            let bytes = get_bits(frame, at, usize::from(slot.bits)).to_le_bytes();
            let data = bytes.get(..usize::from(slot.len)).unwrap_or(&[]);
            if data.is_empty() {
                continue;
            }
            let limits_ok = slot.rule & LIMITS == 0
                || od
                    .entry(slot.index, slot.sub)
                    .is_ok_and(|e| Dictionary::<B>::check_limits(e.var, data).is_ok());
            let rule = slot.rule & !LIMITS;
            if !limits_ok
                || (rule != 0 && rules.check(od, rule, slot.index, slot.sub, data).is_err())
                || hooks.validate(slot.index, slot.sub, data).is_err()
            {
                return;
            }
        }
    }
    if mapping.process_data {
        od.touch_process_data();
    } else {
        od.touch();
    }
    let mut position = 0;
    for slot in mapping.slots() {
        let bits = usize::from(slot.bits);
        match (position % 8, bits % 8, frame.get(position / 8..)) {
            // Whole bytes: stored as received (little-endian, as in the store).
            (0, 0, Some(field)) => od.fill_span(slot.span(), field),
            _ => od.store_span(slot.span(), get_bits(frame, position, bits)),
        }
        if H::NOTIFIES && slot.len != 0 {
            let bytes = get_bits(frame, position, bits).to_le_bytes();
            hooks.written(slot.index, slot.sub, bytes.get(..usize::from(slot.len)).unwrap_or(&[]));
        }
        position += bits;
        if slot.rule & V::REACTS != 0 {
            events(PdoEvent::Written { index: slot.index, sub: slot.sub, rule: slot.rule });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::cob_id::{BIT30, INVALID};

    /// `bits` bits of `value` written bit by bit at `position` into `frame` (the reference of
    /// CiA 301's bit order), cut at the end of the frame.
    fn reference_put(frame: &mut [u8; 8], position: usize, bits: usize, value: u64) {
        for bit in 0..bits {
            let target = position + bit;
            if let Some(byte) = frame.get_mut(target / 8) {
                let mask = 1u8 << (target % 8);
                if (value >> bit) & 1 == 1 {
                    *byte |= mask;
                } else {
                    *byte &= !mask;
                }
            }
        }
    }

    /// Reading a field agrees with the bit-by-bit reference at every position and width,
    /// including fields cut at the end of the frame.
    #[test]
    fn bit_fields_match_a_bit_by_bit_reference() {
        let value = 0xA5C3_0F96_1E2D_3C4Bu64;
        let background = [0x5Au8, 0xFF, 0x00, 0x81, 0x7E, 0x33, 0xCC, 0x01];
        for position in 0..=70 {
            for bits in 0..=64 {
                let mut frame = background;
                reference_put(&mut frame, position, bits, value);
                let kept = bits.min(64usize.saturating_sub(position));
                let want = if kept == 0 { 0 } else { value & (u64::MAX >> (64 - kept)) };
                assert_eq!(get_bits(&frame, position, bits), want, "get {bits} bits at {position}");
            }
        }
    }

    /// A TPDO samples a 16-bit value, a 1-bit BOOLEAN and a 32-bit value at bits 0, 16 and 17 as
    /// the reference packs them; an RPDO with the same mapping stores them back.
    #[test]
    fn sampled_and_applied_fields_sit_at_their_bit_positions() {
        const fn both(name: &'static str, data_type: DataType) -> Var {
            Var::new(name, data_type).access(Access::ReadWrite).pdo(PdoMapping::Both)
        }
        static TABLE: [Object; 3] = crate::od::layout([
            Object::var(0x2000, "a", both("a", DataType::Unsigned16)),
            Object::var(0x2001, "b", both("b", DataType::Boolean)),
            Object::var(0x2002, "c", both("c", DataType::Unsigned32)),
        ]);
        let mut od = Dictionary::<64>::new(&[&TABLE], crate::od::DeviceInfo::servo_drive(), 1).unwrap();
        let entries = [0x2000_0010u32, 0x2001_0001, 0x2002_0020];
        let mapping_of = |od: &Dictionary<64>, direction| {
            let mut mapping = Mapping::EMPTY;
            for (slot, raw) in mapping.slots.iter_mut().zip(entries) {
                *slot = resolve(od, raw, direction).unwrap().0;
                mapping.count += 1;
                mapping.bits += slot.bits;
                mapping.checked |= slot.rule != 0;
            }
            mapping
        };
        od.set::<u16>(0x2000, 0, 0x1234).unwrap();
        od.set::<u8>(0x2001, 0, 1).unwrap();
        od.set::<u32>(0x2002, 0, 0xDEAD_BEEF).unwrap();
        let frame = sample(&od, &mapping_of(&od, Direction::Tpdo));
        let mut expected = [0u8; 8];
        reference_put(&mut expected, 0, 16, 0x1234);
        reference_put(&mut expected, 16, 1, 1);
        reference_put(&mut expected, 17, 32, 0xDEAD_BEEF);
        assert_eq!(frame, expected);
        assert_eq!(frame[..2], [0x34, 0x12]);

        od.reset(0x2000..=0x2002);
        let rpdo = mapping_of(&od, Direction::Rpdo);
        apply(&mut od, &mut (), &NoRules, &rpdo, &frame, &mut |_| {});
        assert_eq!(od.get::<u16>(0x2000, 0), Ok(0x1234));
        assert_eq!(od.get::<u8>(0x2001, 0), Ok(1));
        assert_eq!(od.get::<u32>(0x2002, 0), Ok(0xDEAD_BEEF));
    }

    #[test]
    fn default_table_is_ordered_and_counted() {
        assert_eq!(count(&DEFAULT_OBJECTS), (4, 4));
        assert!(DEFAULT_OBJECTS.windows(2).all(|w| w[0].index < w[1].index));
        assert_eq!(DEFAULT_OBJECTS[0].index, 0x1400);
        assert_eq!(DEFAULT_OBJECTS[15].index, 0x1A03);
        assert_eq!(DEFAULT_OBJECTS[5].number, 2);
        static BIG: [Object; 20] = crate::od::layout(objects::<20>(6));
        assert_eq!(count(&BIG), (6, 4));
        assert_eq!(BIG[5].index, 0x1405);
        assert_eq!(BIG[6].index, 0x1600);
    }

    #[test]
    fn presets_give_pdos_1_to_4_the_cia_402_set_and_the_others_nothing() {
        static BIG: [Object; 20] = crate::od::layout(objects::<20>(6));
        let od =
            crate::od::Dictionary::<2048>::new(&[&BIG], crate::od::DeviceInfo::servo_drive(), 9).unwrap();
        let u32_of = |index, sub| od.get::<u32>(index, sub).unwrap();
        assert_eq!(u32_of(0x1401, 1), 0x309);
        assert_eq!(u32_of(0x1404, 1), INVALID, "RPDO5 starts invalid");
        assert_eq!(u32_of(0x1405, 1), INVALID);
        assert_eq!(u32_of(0x1803, 1), BIT30 | 0x489);
        assert_eq!(od.get::<u8>(0x1801, 2).unwrap(), 255);
        assert_eq!(od.get::<u8>(0x1802, 2).unwrap(), 1);
        assert_eq!(od.get::<u8>(0x1400, 2).unwrap(), 255);
        assert_eq!(od.get::<u8>(0x1603, 0).unwrap(), 2);
        assert_eq!(u32_of(0x1603, 2), 0x60FF_0020);
        assert_eq!(od.get::<u8>(0x1604, 0).unwrap(), 0, "RPDO5 maps nothing");
        assert_eq!(u32_of(0x1605, 1), 0);
        assert_eq!(od.get::<u8>(0x1A00, 0).unwrap(), 1);
        assert_eq!(u32_of(0x1A00, 1), 0x6041_0010);
        assert_eq!(u32_of(0x1A00, 2), 0);
    }
}

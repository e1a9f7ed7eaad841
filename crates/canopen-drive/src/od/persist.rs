//! Parameter records: how the dictionary's parameters leave RAM for non-volatile memory and come
//! back (CiA 301 §7.5.2, objects 1010h/1011h; the storage itself is [`crate::storage`]).
//!
//! ## Which entries are parameters
//!
//! An entry is a *parameter* when the bus may write it (access `rw` or `wo`), its value lives in
//! the dictionary's store (it is not a constant or an identity field, see [`Var::is_fixed`]), and
//! its object is not one of [`NOT_PARAMETERS`]: the error history 1003h is a record of events,
//! 1010h and 1011h are commands. [`is_parameter`] is the rule;
//! [`Dictionary::parameters`] walks the parameters of an index range.
//!
//! ## Record format
//!
//! A stream of records, one per parameter, nothing between them, all numbers little-endian:
//!
//! ```text
//! offset  size  field
//!      0     2  index
//!      2     1  sub-index
//!      3     1  data type: low byte of the CiA 301 data-type index (0x07 = UNSIGNED32)
//!      4     2  n = length of the value in bytes
//!      6     n  the value, byte for byte as an SDO upload returns it
//! ```
//!
//! [`Dictionary::emit_records`] writes the stream in pieces to any sink; [`RecordParser`] splits
//! a stream fed in pieces of any size back into records; [`RecordLoader`] applies the records of
//! a stream to a dictionary.
//!
//! ## What a load applies
//!
//! A record is applied only when its entry exists, is a parameter, has the recorded data type,
//! has a value of the right size and passes [`Dictionary::check_write`] (limits). Anything else
//! is skipped and counted in [`LoadStats::skipped`], never applied. No input bytes can make a
//! load panic or write outside the entry a record names.
//!
//! An entry whose default is `$NODEID + base` (the COB-IDs of the pre-defined connection set)
//! and that holds that default is stored as `base`, and a stored `base` loads as `base` plus
//! the node-ID of the time: a node-ID changed after the store (LSS, a vendor object) moves
//! those COB-IDs with it, as their defaults would. Other values are stored as they are.

use core::ops::RangeInclusive;

use super::standard::PRE_DEFINED_ERROR_FIELD;
use super::{DefaultValue, Dictionary, Entry, Kind, Var, COPY_STRIDE};

/// Objects whose writable entries are not parameters: 1003h (error history: sub 0 counts the
/// errors held in RAM), 1010h (store parameters) and 1011h (restore default parameters).
pub const NOT_PARAMETERS: [u16; 3] = [PRE_DEFINED_ERROR_FIELD, 0x1010, 0x1011];

/// True when entry `var` of object `index` is a parameter (see the [module docs](self)).
pub fn is_parameter(index: u16, var: &Var) -> bool {
    var.access.writable() && !var.is_fixed() && !NOT_PARAMETERS.contains(&index)
}

/// The fixed part of a record: which entry, its type and the length of the value that follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RecordHeader {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// Low byte of the CiA 301 data-type index of the entry when it was saved.
    pub data_type: u8,
    /// Length of the value in bytes.
    pub len: u16,
}

impl RecordHeader {
    /// Bytes of an encoded header.
    pub const SIZE: usize = 6;

    /// The header as it is stored.
    pub fn encode(&self) -> [u8; Self::SIZE] {
        let [i0, i1] = self.index.to_le_bytes();
        let [l0, l1] = self.len.to_le_bytes();
        [i0, i1, self.sub, self.data_type, l0, l1]
    }

    /// Reads a stored header (every bit pattern is a header; checks come later).
    pub fn decode(raw: [u8; Self::SIZE]) -> Self {
        let [i0, i1, sub, data_type, l0, l1] = raw;
        RecordHeader {
            index: u16::from_le_bytes([i0, i1]),
            sub,
            data_type,
            len: u16::from_le_bytes([l0, l1]),
        }
    }

    /// Bytes of the whole record (header and value).
    pub fn record_len(&self) -> usize {
        Self::SIZE + usize::from(self.len)
    }
}

/// Data-type code of `var` as a record carries it.
fn type_code(var: &Var) -> u8 {
    // Every CiA 301 basic type index is below 0x100.
    (var.data_type as u16 & 0xFF) as u8
}

/// The parameters of an index range in ascending index and sub-index order; see
/// [`Dictionary::parameters`].
pub struct Parameters<'a, const BYTES: usize> {
    od: &'a Dictionary<BYTES>,
    range: RangeInclusive<u16>,
    table: usize,
    /// The copy of the table ([`Dictionary::attach_copies`]).
    copy: u8,
    object: usize,
    /// Next sub-index to look at (a `u16` so that it can step past 255).
    sub: u16,
}

impl<const BYTES: usize> Iterator for Parameters<'_, BYTES> {
    type Item = Entry;

    fn next(&mut self) -> Option<Entry> {
        loop {
            let table = *self.od.attached().get(self.table)?;
            let shift = u16::from(self.copy) * COPY_STRIDE;
            let region = table.region_of(u16::from(self.copy));
            let copies = table.copies;
            let table = table.objects();
            let Some(object) = table.get(self.object) else {
                if self.copy + 1 < copies {
                    self.copy += 1;
                } else {
                    self.table += 1;
                    self.copy = 0;
                }
                self.object = 0;
                self.sub = 0;
                continue;
            };
            let index = object.index.wrapping_add(shift);
            let sub = self.sub;
            if !self.range.contains(&index) || sub > u16::from(object.highest_sub()) {
                self.object += 1;
                self.sub = 0;
                continue;
            }
            self.sub += 1;
            let sub = sub as u8;
            let Some((var, offset)) = object.sub(sub) else { continue };
            if self.od.hidden(&object.at(index), sub) {
                continue;
            }
            if let Kind::Array { sub0, len, .. } = &object.kind {
                if sub > self.od.array_len(index, sub0, *len) {
                    continue;
                }
            }
            let var = self.od.describe(index, sub, var);
            if !is_parameter(index, var) {
                continue;
            }
            let offset = region + usize::from(object.base) + offset;
            if let Ok(offset) = u16::try_from(offset) {
                return Some(Entry { object, var, sub, index, offset });
            }
        }
    }
}

impl<const BYTES: usize> Dictionary<BYTES> {
    /// Every parameter (see [`is_parameter`]) of the objects in `range`, in ascending index and
    /// sub-index order.
    pub fn parameters(&self, range: RangeInclusive<u16>) -> Parameters<'_, BYTES> {
        Parameters { od: self, range, table: 0, copy: 0, object: 0, sub: 0 }
    }

    /// The record header of `entry` with its current value length.
    pub fn record_header(&self, entry: &Entry) -> RecordHeader {
        // A value is at most the entry's capacity, which the dictionary keeps below 65 536.
        let len = u16::try_from(self.value_len(entry)).unwrap_or(u16::MAX);
        RecordHeader { index: entry.index(), sub: entry.sub, data_type: type_code(entry.var), len }
    }

    /// Writes the records of every parameter in `range` (current values) to `sink`, in pieces
    /// of at most 32 bytes, and returns the bytes written. Stops at the first error of `sink`.
    pub fn emit_records<E>(
        &self,
        range: RangeInclusive<u16>,
        sink: impl FnMut(&[u8]) -> Result<(), E>,
    ) -> Result<usize, E> {
        self.emit_records_where(range, |_, _| true, sink)
    }

    /// [`emit_records`](Self::emit_records) of the parameters in `range` that `keep` (index,
    /// sub-index) selects.
    pub fn emit_records_where<E>(
        &self,
        range: RangeInclusive<u16>,
        keep: impl Fn(u16, u8) -> bool,
        mut sink: impl FnMut(&[u8]) -> Result<(), E>,
    ) -> Result<usize, E> {
        let mut total = 0usize;
        let mut piece = [0u8; 32];
        for entry in self.parameters(range).filter(|e| keep(e.index(), e.sub)) {
            let header = self.record_header(&entry);
            sink(&header.encode())?;
            if let Some(relative) = self.node_relative(&entry) {
                // Stored without the node-ID, so it follows a node-ID changed before loading.
                let bytes = relative.to_le_bytes();
                sink(bytes.get(..usize::from(header.len)).unwrap_or(&[]))?;
                total += header.record_len();
                continue;
            }
            let len = usize::from(header.len);
            let mut offset = 0usize;
            while offset < len {
                let want = (len - offset).min(piece.len());
                let n = self.read(&entry, offset, piece.get_mut(..want).unwrap_or(&mut []));
                if n == 0 {
                    break;
                }
                sink(piece.get(..n).unwrap_or(&[]))?;
                offset += n;
            }
            // A value never shrinks while `self` is borrowed; pad defensively so that the
            // stream always matches its headers.
            while offset < len {
                let n = (len - offset).min(piece.len());
                piece.fill(0);
                sink(piece.get(..n).unwrap_or(&[]))?;
                offset += n;
            }
            total += header.record_len();
        }
        Ok(total)
    }

    /// Bytes [`emit_records`](Self::emit_records) would write for `range`.
    pub fn records_len(&self, range: RangeInclusive<u16>) -> usize {
        self.records_len_where(range, |_, _| true)
    }

    /// Bytes [`emit_records_where`](Self::emit_records_where) would write.
    pub fn records_len_where(&self, range: RangeInclusive<u16>, keep: impl Fn(u16, u8) -> bool) -> usize {
        self.parameters(range)
            .filter(|e| keep(e.index(), e.sub))
            .map(|entry| self.record_header(&entry).record_len())
            .sum()
    }

    /// Applies the records of `payload` whose index lies in `range`; see [`RecordLoader`].
    pub fn load_records(&mut self, range: RangeInclusive<u16>, payload: &[u8]) -> LoadStats {
        let mut loader = RecordLoader::new(range, payload.len());
        loader.feed(self, payload);
        loader.finish(self)
    }

    /// Writes `data` into the stored value of variable-length `entry` from byte `at` on, without
    /// touching its length.
    fn write_variable_part(&mut self, entry: &Entry, at: usize, data: &[u8]) {
        let start = usize::from(entry.offset) + 2 + at;
        if at + data.len() > usize::from(entry.var.capacity) {
            return;
        }
        if let Some(dst) = self.values_mut().get_mut(start..start + data.len()) {
            dst.copy_from_slice(data);
        }
    }

    /// Sets the length of the stored value of variable-length `entry`.
    fn set_variable_len(&mut self, entry: &Entry, len: u16) {
        let start = usize::from(entry.offset);
        if let Some(dst) = self.values_mut().get_mut(start..start + 2) {
            dst.copy_from_slice(&len.min(entry.var.capacity).to_le_bytes());
        }
    }

    /// The value to store for `entry` when it holds its `$NODEID + base` default: `base` (a
    /// node-relative value; loading adds the node-ID of the time). `None` for every other
    /// entry or value.
    fn node_relative(&self, entry: &Entry) -> Option<u64> {
        let DefaultValue::NodeIdPlus(base) = self.default_of(entry.index(), entry.sub, entry.var) else {
            return None;
        };
        let size = entry.var.data_type.fixed_size().filter(|n| *n <= 8)?;
        let mut raw = [0u8; 8];
        let n = self.read(entry, 0, raw.get_mut(..size)?);
        let value = u64::from_le_bytes(raw);
        let current = u64::from(base.wrapping_add(u32::from(self.node_id)));
        (n == size && value == current && base != 0).then_some(u64::from(base))
    }

    /// A loaded value of `entry`: a node-relative one ([`Self::node_relative`]) with the present
    /// node-ID added.
    fn node_absolute(&self, entry: &Entry, value: &mut [u8]) {
        let DefaultValue::NodeIdPlus(base) = self.default_of(entry.index(), entry.sub, entry.var) else {
            return;
        };
        let mut raw = [0u8; 8];
        if let Some(dst) = raw.get_mut(..value.len()) {
            dst.copy_from_slice(value);
        }
        if u64::from_le_bytes(raw) == u64::from(base) && base != 0 {
            let absolute = u64::from(base.wrapping_add(u32::from(self.node_id))).to_le_bytes();
            let n = value.len();
            value.copy_from_slice(absolute.get(..n).unwrap_or(&[]));
        }
    }

    /// Sets `entry` back to its default value.
    fn reset_entry(&mut self, entry: &Entry) {
        let default = self.default_bytes(entry.var, self.default_of(entry.index(), entry.sub, entry.var));
        self.commit(entry, default.bytes());
    }
}

/// One step of a record stream, see [`RecordParser::next`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RecordEvent<'a> {
    /// A record begins.
    Start(RecordHeader),
    /// The next piece of the value of the current record.
    Data(&'a [u8]),
    /// The current record is complete.
    End,
    /// The stream ends inside a record header, or a header announces more bytes than the stream
    /// has left. Nothing follows.
    Malformed,
}

#[derive(Clone, Copy, Debug)]
enum ParseState {
    Header { raw: [u8; RecordHeader::SIZE], have: usize },
    Data { left: usize },
    End,
    Done,
}

/// Splits a record stream of known length, fed in pieces of any size, into [`RecordEvent`]s.
/// It never reads past the length it was given.
#[derive(Clone, Debug)]
pub struct RecordParser {
    state: ParseState,
    remaining: usize,
}

impl RecordParser {
    /// A parser for a stream of `len` bytes.
    pub const fn new(len: usize) -> Self {
        RecordParser { state: ParseState::Header { raw: [0; RecordHeader::SIZE], have: 0 }, remaining: len }
    }

    /// Bytes of the stream not consumed yet.
    pub fn remaining(&self) -> usize {
        self.remaining
    }

    /// The next event, consuming bytes from the front of `input`, or `None` when `input` holds
    /// no more bytes of the stream (feed the next piece then).
    pub fn next<'a>(&mut self, input: &mut &'a [u8]) -> Option<RecordEvent<'a>> {
        loop {
            match &mut self.state {
                ParseState::Done => return None,
                ParseState::End => {
                    self.state = ParseState::Header { raw: [0; RecordHeader::SIZE], have: 0 };
                    return Some(RecordEvent::End);
                }
                ParseState::Header { raw, have } => {
                    if *have == 0 && self.remaining > 0 && self.remaining < RecordHeader::SIZE {
                        self.state = ParseState::Done;
                        return Some(RecordEvent::Malformed);
                    }
                    let n = (RecordHeader::SIZE - *have).min(input.len()).min(self.remaining);
                    if n == 0 {
                        return None;
                    }
                    let (head, rest) = input.split_at(n);
                    if let Some(dst) = raw.get_mut(*have..*have + n) {
                        dst.copy_from_slice(head);
                    }
                    *input = rest;
                    *have += n;
                    self.remaining -= n;
                    if *have < RecordHeader::SIZE {
                        continue;
                    }
                    let header = RecordHeader::decode(*raw);
                    let len = usize::from(header.len);
                    self.state = if len > self.remaining {
                        ParseState::Done
                    } else if len == 0 {
                        ParseState::End
                    } else {
                        ParseState::Data { left: len }
                    };
                    if len > self.remaining {
                        return Some(RecordEvent::Malformed);
                    }
                    return Some(RecordEvent::Start(header));
                }
                ParseState::Data { left } => {
                    let n = (*left).min(input.len()).min(self.remaining);
                    if n == 0 {
                        return None;
                    }
                    let (piece, rest) = input.split_at(n);
                    *input = rest;
                    *left -= n;
                    self.remaining -= n;
                    if *left == 0 {
                        self.state = ParseState::End;
                    }
                    return Some(RecordEvent::Data(piece));
                }
            }
        }
    }
}

/// How many records a load applied and skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoadStats {
    /// Records written into the dictionary.
    pub applied: u32,
    /// Records refused: unknown entry, not a parameter, other data type, wrong size, outside
    /// the limits, or cut off by the end of the stream.
    pub skipped: u32,
}

/// What the loader does with the record it is in.
#[derive(Clone, Copy, Debug)]
enum Current {
    /// Between records.
    Idle,
    /// Outside the range being loaded: not applied, not counted.
    Ignore,
    /// Refused (already counted).
    Skip,
    /// A fixed-size value collected here until the record ends, then checked and committed.
    Fixed { entry: Entry, raw: [u8; 8], have: usize },
    /// A variable-length value streamed into the store; its length is set when it ends.
    Variable { entry: Entry, have: usize },
}

/// Applies a record stream of known length, fed in pieces of any size, to a dictionary.
///
/// Records outside the loader's index range are passed over; the others are applied or
/// skipped as the [module docs](self) say. A string or DOMAIN value is written into the store
/// as it arrives and takes its new length when the record ends; a record the stream does not
/// finish is never applied ([`finish`](Self::finish) sets a half-written value back to its
/// default).
#[derive(Clone, Debug)]
pub struct RecordLoader {
    parser: RecordParser,
    range: RangeInclusive<u16>,
    current: Current,
    stats: LoadStats,
}

impl RecordLoader {
    /// A loader for a stream of `len` bytes that applies the records of objects in `range`.
    pub fn new(range: RangeInclusive<u16>, len: usize) -> Self {
        RecordLoader {
            parser: RecordParser::new(len),
            range,
            current: Current::Idle,
            stats: LoadStats::default(),
        }
    }

    /// Applies what `piece`, the next bytes of the stream, completes. Bytes past the stream's
    /// length are ignored.
    pub fn feed<const BYTES: usize>(&mut self, od: &mut Dictionary<BYTES>, mut piece: &[u8]) {
        while let Some(event) = self.parser.next(&mut piece) {
            match event {
                RecordEvent::Start(header) => self.current = self.start(od, &header),
                RecordEvent::Data(data) => self.data(od, data),
                RecordEvent::End => self.end(od),
                RecordEvent::Malformed => {
                    self.stats.skipped = self.stats.skipped.saturating_add(1);
                    self.current = Current::Idle;
                }
            }
        }
    }

    /// The counts, after undoing a record the stream did not finish.
    pub fn finish<const BYTES: usize>(self, od: &mut Dictionary<BYTES>) -> LoadStats {
        let mut stats = self.stats;
        match self.current {
            Current::Idle | Current::Ignore | Current::Skip => {}
            Current::Fixed { .. } => stats.skipped = stats.skipped.saturating_add(1),
            Current::Variable { entry, .. } => {
                od.reset_entry(&entry);
                stats.skipped = stats.skipped.saturating_add(1);
            }
        }
        stats
    }

    fn skip(&mut self) -> Current {
        self.stats.skipped = self.stats.skipped.saturating_add(1);
        Current::Skip
    }

    fn start<const BYTES: usize>(&mut self, od: &mut Dictionary<BYTES>, header: &RecordHeader) -> Current {
        if !self.range.contains(&header.index) {
            return Current::Ignore;
        }
        let Ok(entry) = od.entry(header.index, header.sub) else { return self.skip() };
        if !is_parameter(header.index, entry.var) || type_code(entry.var) != header.data_type {
            return self.skip();
        }
        let len = usize::from(header.len);
        match entry.var.data_type.fixed_size() {
            Some(size) if size == len && size <= 8 => Current::Fixed { entry, raw: [0; 8], have: 0 },
            Some(_) => self.skip(),
            None if len > usize::from(entry.var.capacity) => self.skip(),
            None => {
                od.set_variable_len(&entry, 0);
                Current::Variable { entry, have: 0 }
            }
        }
    }

    fn data<const BYTES: usize>(&mut self, od: &mut Dictionary<BYTES>, data: &[u8]) {
        match &mut self.current {
            Current::Fixed { raw, have, .. } => {
                if let Some(dst) = raw.get_mut(*have..*have + data.len()) {
                    dst.copy_from_slice(data);
                }
                *have += data.len();
            }
            Current::Variable { entry, have } => {
                od.write_variable_part(entry, *have, data);
                *have += data.len();
            }
            Current::Idle | Current::Ignore | Current::Skip => {}
        }
    }

    fn end<const BYTES: usize>(&mut self, od: &mut Dictionary<BYTES>) {
        match self.current {
            Current::Fixed { entry, mut raw, have } => {
                if let Some(value) = raw.get_mut(..have) {
                    od.node_absolute(&entry, value);
                }
                let value = raw.get(..have).unwrap_or(&[]);
                if od.check_write(&entry, value).is_ok() {
                    od.commit(&entry, value);
                    self.stats.applied = self.stats.applied.saturating_add(1);
                } else {
                    self.stats.skipped = self.stats.skipped.saturating_add(1);
                }
            }
            Current::Variable { entry, have } => {
                od.set_variable_len(&entry, u16::try_from(have).unwrap_or(u16::MAX));
                self.stats.applied = self.stats.applied.saturating_add(1);
            }
            Current::Idle | Current::Ignore | Current::Skip => {}
        }
        self.current = Current::Idle;
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::super::standard::COMMUNICATION;
    use super::super::{layout, Access, DataType, DefaultValue, DeviceInfo, Object, Var};
    use super::*;

    const RECORD_SUBS: [(u8, Var); 3] = [
        (0, Var::new("Highest sub-index supported", DataType::Unsigned8).access(Access::Const)),
        (1, Var::new("Gain", DataType::Integer16).access(Access::ReadWrite).limits_signed(-100, 100)),
        (2, Var::new("Status", DataType::Unsigned32)),
    ];

    static VENDOR: [Object; 4] = layout([
        Object::var(
            0x2000,
            "Name",
            Var::new("Name", DataType::VisibleString)
                .access(Access::ReadWrite)
                .capacity(40)
                .default(DefaultValue::Text("motor")),
        ),
        Object::var(0x2001, "Secret", Var::new("Secret", DataType::Unsigned8).access(Access::WriteOnly)),
        Object::record(0x2002, "Loop", &RECORD_SUBS),
        Object::array(
            0x2003,
            "Offsets",
            3,
            &Var::new("Offset", DataType::Integer32)
                .access(Access::ReadWrite)
                .default(DefaultValue::Signed(-1)),
        ),
    ]);

    fn dict() -> Dictionary<1024> {
        Dictionary::new(&[&COMMUNICATION, &VENDOR], DeviceInfo::servo_drive(), 4).unwrap()
    }

    fn records(od: &Dictionary<1024>, range: RangeInclusive<u16>) -> Vec<u8> {
        let mut out = Vec::new();
        let n = od
            .emit_records::<()>(range.clone(), |b| {
                assert!(b.len() <= 32);
                out.extend_from_slice(b);
                Ok(())
            })
            .unwrap();
        assert_eq!(n, out.len());
        assert_eq!(od.records_len(range), n);
        out
    }

    fn snapshot(od: &Dictionary<1024>) -> Vec<(u16, u8, Vec<u8>)> {
        od.parameters(0..=0xFFFF)
            .map(|e| {
                let mut buf = [0u8; 64];
                let n = od.read(&e, 0, &mut buf);
                (e.index(), e.sub, buf[..n].to_vec())
            })
            .collect()
    }

    #[test]
    fn parameters_are_writable_stored_entries() {
        let od = dict();
        let all: Vec<(u16, u8)> = od.parameters(0..=0xFFFF).map(|e| (e.index(), e.sub)).collect();
        assert!(all.is_sorted());
        for present in [(0x100C, 0), (0x1014, 0), (0x1016, 1), (0x1016, 4), (0x1017, 0), (0x1029, 1)] {
            assert!(all.contains(&present), "{present:x?}");
        }
        // Read-only, constant and identity entries, and the error history, are not parameters.
        for absent in [(0x1000, 0), (0x1001, 0), (0x1003, 0), (0x1016, 0), (0x1018, 1), (0x1200, 1)] {
            assert!(!all.contains(&absent), "{absent:x?}");
        }
        let vendor: Vec<(u16, u8)> = od.parameters(0x2000..=0xFFFF).map(|e| (e.index(), e.sub)).collect();
        assert_eq!(vendor, [(0x2000, 0), (0x2001, 0), (0x2002, 1), (0x2003, 1), (0x2003, 2), (0x2003, 3)]);
        let vendor: Vec<(u16, u8)> = od.parameters(0x2001..=0x2002).map(|e| (e.index(), e.sub)).collect();
        assert_eq!(vendor, [(0x2001, 0), (0x2002, 1)]);
        assert_eq!(od.parameters(0x3000..=0x5FFF).count(), 0);
    }

    #[test]
    fn record_layout() {
        let mut od = dict();
        od.set::<i16>(0x2002, 1, -2).unwrap();
        assert_eq!(records(&od, 0x2002..=0x2002), [0x02, 0x20, 0x01, 0x03, 0x02, 0x00, 0xFE, 0xFF]);
        let name = od.entry(0x2000, 0).unwrap();
        od.commit(&name, b"ab");
        assert_eq!(records(&od, 0x2000..=0x2000), [0x00, 0x20, 0x00, 0x09, 0x02, 0x00, b'a', b'b']);
        let header = RecordHeader { index: 0x1234, sub: 5, data_type: 7, len: 0x0102 };
        assert_eq!(RecordHeader::decode(header.encode()), header);
    }

    #[test]
    fn round_trip_in_pieces_of_every_size() {
        let mut od = dict();
        od.set::<u16>(0x1017, 0, 250).unwrap();
        od.set::<u32>(0x1016, 3, 0x0005_0064).unwrap();
        od.set::<i32>(0x2003, 2, 123_456).unwrap();
        od.set::<u8>(0x2001, 0, 9).unwrap();
        let name = od.entry(0x2000, 0).unwrap();
        od.commit(&name, b"a rather long motor name, 36 bytes!");
        let stream = records(&od, 0..=0xFFFF);
        let expected = snapshot(&od);
        for piece in 1..=stream.len() {
            let mut fresh = dict();
            let mut loader = RecordLoader::new(0..=0xFFFF, stream.len());
            for chunk in stream.chunks(piece) {
                loader.feed(&mut fresh, chunk);
            }
            let stats = loader.finish(&mut fresh);
            let applied = od.parameters(0..=0xFFFF).count() as u32;
            assert_eq!(stats, LoadStats { applied, skipped: 0 }, "pieces of {piece}");
            assert_eq!(snapshot(&fresh), expected);
        }
    }

    #[test]
    fn range_selects_records() {
        let mut od = dict();
        od.set::<u16>(0x1017, 0, 250).unwrap();
        od.set::<i32>(0x2003, 1, 5).unwrap();
        let stream = records(&od, 0..=0xFFFF);
        let mut fresh = dict();
        let stats = fresh.load_records(0x2000..=0x5FFF, &stream);
        assert_eq!(stats, LoadStats { applied: 6, skipped: 0 });
        assert_eq!(fresh.get::<u16>(0x1017, 0), Ok(0), "communication not loaded");
        assert_eq!(fresh.get::<i32>(0x2003, 1), Ok(5));
    }

    fn record(index: u16, sub: u8, data_type: u8, value: &[u8]) -> Vec<u8> {
        let header = RecordHeader { index, sub, data_type, len: value.len() as u16 };
        let mut out = header.encode().to_vec();
        out.extend_from_slice(value);
        out
    }

    #[test]
    fn refused_records_are_skipped_and_counted() {
        let mut stream = Vec::new();
        stream.extend(record(0x2100, 0, 0x07, &[1, 2, 3, 4])); // unknown object
        stream.extend(record(0x2002, 9, 0x03, &[1, 0])); // unknown sub
        stream.extend(record(0x2002, 2, 0x07, &[1, 0, 0, 0])); // read-only
        stream.extend(record(0x1003, 0, 0x05, &[3])); // error history is not a parameter
        stream.extend(record(0x2002, 1, 0x06, &[1, 0])); // other data type
        stream.extend(record(0x2002, 1, 0x03, &[1, 0, 0])); // wrong size
        stream.extend(record(0x2002, 1, 0x03, &101i16.to_le_bytes())); // above the limit
        stream.extend(record(0x2000, 0, 0x09, &[b'x'; 41])); // longer than the capacity
        stream.extend(record(0x2002, 1, 0x03, &(-100i16).to_le_bytes())); // fine
        stream.extend(record(0x2000, 0, 0x09, b"")); // fine: empty string
        let mut od = dict();
        let stats = od.load_records(0..=0xFFFF, &stream);
        assert_eq!(stats, LoadStats { applied: 2, skipped: 8 });
        assert_eq!(od.get::<i16>(0x2002, 1), Ok(-100));
        assert_eq!(od.get::<u8>(0x1003, 0), Ok(0));
        let name = od.entry(0x2000, 0).unwrap();
        assert_eq!(od.value_len(&name), 0);
    }

    #[test]
    fn a_cut_stream_applies_nothing_of_the_cut_record() {
        let mut od = dict();
        let name = od.entry(0x2000, 0).unwrap();
        od.commit(&name, b"new name");
        od.set::<i32>(0x2003, 3, 77).unwrap();
        let stream = records(&od, 0x2000..=0x2003);
        // The parser is told the stream is longer than what it gets: the last record is cut.
        for cut in 0..stream.len() {
            let mut fresh = dict();
            let mut loader = RecordLoader::new(0..=0xFFFF, stream.len());
            loader.feed(&mut fresh, &stream[..cut]);
            let stats = loader.finish(&mut fresh);
            let name = fresh.entry(0x2000, 0).unwrap();
            let mut buf = [0u8; 40];
            let n = fresh.read(&name, 0, &mut buf);
            assert!(&buf[..n] == b"new name" || &buf[..n] == b"motor", "cut at {cut}");
            assert!(stats.applied <= 6);
        }
        // A stream whose length ends inside a record is malformed there.
        let mut fresh = dict();
        let stats = fresh.load_records(0..=0xFFFF, &stream[..stream.len() - 1]);
        assert_eq!(stats, LoadStats { applied: 5, skipped: 1 });
        assert_eq!(fresh.get::<i32>(0x2003, 3), Ok(-1));
        let stats = fresh.load_records(0..=0xFFFF, &stream[..3]);
        assert_eq!(stats, LoadStats { applied: 0, skipped: 1 });
    }

    #[test]
    fn arbitrary_bytes_never_panic() {
        // A small deterministic generator: every byte pattern class shows up.
        let mut state = 0x1234_5678u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        for round in 0..2000 {
            let len = (next() % 200) as usize;
            let mut bytes: Vec<u8> = (0..len).map(|_| next() as u8).collect();
            // Make some records plausible so that deeper paths run.
            if round % 2 == 0 && len >= 6 {
                let index = [0x1017u16, 0x2000, 0x2002, 0x2003, 0x1016][(next() % 5) as usize];
                bytes[0..2].copy_from_slice(&index.to_le_bytes());
                bytes[4] = (next() % 48) as u8;
                bytes[5] = 0;
            }
            let mut od = dict();
            let _ = od.load_records(0..=0xFFFF, &bytes);
            let mut loader = RecordLoader::new(0..=0xFFFF, len + (round % 3));
            for chunk in bytes.chunks(1 + round % 7) {
                loader.feed(&mut od, chunk);
            }
            let _ = loader.finish(&mut od);
        }
    }
}

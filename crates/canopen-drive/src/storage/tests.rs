extern crate std;
use std::vec;
use std::vec::Vec;

use super::*;
use crate::od::standard::COMMUNICATION;
use crate::od::{layout, Access, DataType, DefaultValue, Object, Var};

/// RAM NOR flash: erase to 0xFF by sector, program only erased units (a second program of a
/// unit fails the test), AND semantics.
struct TestFlash {
    bytes: Vec<u8>,
    programmed: Vec<bool>,
    erase: usize,
    write: usize,
    /// Reads left before reads fail (`None`: never).
    reads_left: Option<usize>,
    /// Bytes whose reads fail (like a word with an ECC error after an interrupted program).
    unreadable: Option<core::ops::Range<usize>>,
}

impl TestFlash {
    fn new(capacity: usize, erase: usize, write: usize) -> Self {
        TestFlash {
            bytes: vec![0xFF; capacity],
            programmed: vec![false; capacity / write],
            erase,
            write,
            reads_left: None,
            unreadable: None,
        }
    }
}

impl NonVolatile for TestFlash {
    fn capacity(&self) -> usize {
        self.bytes.len()
    }
    fn erase_size(&self) -> usize {
        self.erase
    }
    fn write_size(&self) -> usize {
        self.write
    }
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        if let Some(left) = &mut self.reads_left {
            if *left == 0 {
                return Err(NvError::Device);
            }
            *left -= 1;
        }
        let at = offset as usize;
        if self.unreadable.as_ref().is_some_and(|bad| bad.start < at + buf.len() && at < bad.end) {
            return Err(NvError::Device);
        }
        buf.copy_from_slice(self.bytes.get(at..at + buf.len()).ok_or(NvError::OutOfBounds)?);
        Ok(())
    }
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        let at = offset as usize;
        assert!(
            at.is_multiple_of(self.write) && data.len().is_multiple_of(self.write),
            "unaligned write {at} + {}",
            data.len()
        );
        let dst = self.bytes.get_mut(at..at + data.len()).ok_or(NvError::OutOfBounds)?;
        for (d, s) in dst.iter_mut().zip(data) {
            *d &= *s;
        }
        for unit in at / self.write..(at + data.len()) / self.write {
            assert!(!self.programmed[unit], "unit at {} programmed twice", unit * self.write);
            self.programmed[unit] = true;
        }
        Ok(())
    }
    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        let (from, to) = (from as usize, to as usize);
        assert!(from % self.erase == 0 && to % self.erase == 0 && from <= to, "unaligned erase");
        self.bytes.get_mut(from..to).ok_or(NvError::OutOfBounds)?.fill(0xFF);
        if self.unreadable.as_ref().is_some_and(|bad| from <= bad.start && bad.end <= to) {
            self.unreadable = None;
        }
        self.programmed[from / self.write..to / self.write].fill(false);
        Ok(())
    }
}

const LOOP_SUBS: [(u8, Var); 3] = [
    (
        0,
        Var::new("Highest sub-index supported", DataType::Unsigned8)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(2)),
    ),
    (1, Var::new("Gain", DataType::Integer16).access(Access::ReadWrite).limits_signed(-1000, 1000)),
    (2, Var::new("Ratio", DataType::Real32).access(Access::ReadWrite).default(DefaultValue::Real(1.0))),
];

static MANUFACTURER: [Object; 3] = layout([
    Object::var(
        0x2000,
        "Axis name",
        Var::new("Axis name", DataType::VisibleString)
            .access(Access::ReadWrite)
            .capacity(24)
            .default(DefaultValue::Text("axis")),
    ),
    Object::record(0x2001, "Loop", &LOOP_SUBS),
    Object::array(
        0x2002,
        "Offsets",
        4,
        &Var::new("Offset", DataType::Integer32).access(Access::ReadWrite).default(DefaultValue::Signed(-5)),
    ),
]);

static APPLICATION: [Object; 1] = layout([Object::var(
    0x6065,
    "Following error window",
    Var::new("Following error window", DataType::Unsigned32)
        .access(Access::ReadWrite)
        .default(DefaultValue::Unsigned(1000)),
)]);

type Od = Dictionary<1024>;

fn dict() -> Od {
    Dictionary::new(&[&COMMUNICATION, &MANUFACTURER, &APPLICATION], DeviceInfo::servo_drive(), 5).unwrap()
}

/// Every parameter with its value.
fn values(od: &Od) -> Vec<(u16, u8, Vec<u8>)> {
    od.parameters(0..=0xFFFF)
        .map(|e| {
            let mut buf = [0u8; 32];
            let n = od.read(&e, 0, &mut buf);
            (e.index(), e.sub, buf[..n].to_vec())
        })
        .collect()
}

/// Values of the parameters of `group` only.
fn group_values(od: &Od, group: Group) -> Vec<(u16, u8, Vec<u8>)> {
    values(od).into_iter().filter(|(index, _, _)| group.contains(*index)).collect()
}

/// Gives every parameter a value derived from `seed` (all differ from the defaults and from
/// other seeds).
fn set_all(od: &mut Od, seed: u8) {
    od.set::<u16>(0x1017, 0, 100 + u16::from(seed)).unwrap();
    od.set::<u16>(0x100C, 0, 10 + u16::from(seed)).unwrap();
    od.set::<u32>(0x1016, 2, 0x0003_0000 + u32::from(seed)).unwrap();
    set_manufacturer(od, seed);
    od.set::<u32>(0x6065, 0, 5000 + u32::from(seed)).unwrap();
}

fn set_manufacturer(od: &mut Od, seed: u8) {
    let name = od.entry(0x2000, 0).unwrap();
    let text = std::format!("axis number {seed}");
    od.commit(&name, text.as_bytes());
    od.set::<i16>(0x2001, 1, -10 - i16::from(seed)).unwrap();
    od.set::<f32>(0x2001, 2, 0.5 + f32::from(seed)).unwrap();
    for sub in 1..=4 {
        od.set::<i32>(0x2002, sub, i32::from(seed) * 1000 + i32::from(sub)).unwrap();
    }
}

fn storage(flash: TestFlash) -> Storage<TestFlash> {
    Storage::new(flash, 0x5157_0001).unwrap()
}

fn loaded(storage: &mut Storage<TestFlash>) -> (Od, LoadReport) {
    let mut od = dict();
    let report = storage.load(&mut od, Group::All).unwrap();
    (od, report)
}

#[test]
fn nothing_stored_is_empty() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let (od, report) = loaded(&mut storage);
    assert_eq!(report, LoadReport { image: ImageState::Empty, applied: 0, skipped: 0 });
    assert_eq!(values(&od), values(&dict()));
    assert_eq!(storage.status(), Ok(ImageState::Empty));
}

#[test]
fn store_and_load_alternate_banks() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    let parameters = od.parameters(0..=0xFFFF).count() as u32;
    for round in 1..=5u8 {
        set_all(&mut od, round);
        storage.store(&od, Group::All).unwrap();
        let (fresh, report) = loaded(&mut storage);
        assert_eq!(
            report,
            LoadReport {
                image: ImageState::Found { sequence: u32::from(round) },
                applied: parameters,
                skipped: 0
            }
        );
        assert_eq!(values(&fresh), values(&od));
        // Odd sequence numbers in bank 0, even ones in bank 1.
        let bank = if round % 2 == 1 { 0 } else { 1024 };
        assert_eq!(&storage.area().bytes[bank..bank + 4], b"COPJ");
        assert_eq!(storage.area().bytes[bank + 12], round);
    }
}

#[test]
fn write_sizes_from_one_to_256_bytes() {
    for write in [1usize, 2, 4, 8, 16, 32, 64, 128, 256] {
        let erase = 512.max(write);
        let mut storage = storage(TestFlash::new(4 * erase, erase, write));
        let mut od = dict();
        set_all(&mut od, 7);
        storage.store(&od, Group::All).unwrap();
        set_manufacturer(&mut od, 8);
        storage.store(&od, Group::Manufacturer).unwrap();
        let (fresh, report) = loaded(&mut storage);
        assert_eq!(report.image, ImageState::Found { sequence: 2 }, "write size {write}");
        assert_eq!(values(&fresh), values(&od), "write size {write}");
        // The payload starts after the header, padded to the write size.
        let image = &storage.area().bytes[storage.bank_size as usize..];
        assert_eq!(&image[..4], b"COPJ");
        let first = HEADER_LEN.max(write);
        assert!(image[HEADER_LEN..first].iter().all(|b| *b == 0xFF));
        assert_ne!(image[first], 0xFF);
    }
}

#[test]
fn geometry_is_checked() {
    let sig = 1;
    assert_eq!(
        Storage::new(TestFlash::new(256, 256, 4), sig).err(),
        Some(StorageError::Geometry),
        "one sector"
    );
    assert_eq!(Storage::new(TestFlash::new(1024, 256, 3), sig).err(), Some(StorageError::Geometry));
    assert_eq!(Storage::new(TestFlash::new(1024, 250, 4), sig).err(), Some(StorageError::Geometry));
    assert_eq!(
        Storage::new(TestFlash::new(48, 8, 4), sig).err(),
        Some(StorageError::Geometry),
        "bank < header"
    );
    let three = Storage::new(TestFlash::new(768, 256, 4), sig).unwrap();
    assert_eq!(three.max_payload(), 256 - 32, "odd last sector unused");
    let wide = Storage::new(TestFlash::new(2048, 512, 64), sig).unwrap();
    assert_eq!(wide.max_payload(), 1024 - 64);
}

/// Stores set 1 (sequence 1, bank 0) then set 2 (sequence 2, bank 1).
fn two_images() -> (Storage<TestFlash>, Od, Od) {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut one = dict();
    set_all(&mut one, 1);
    storage.store(&one, Group::All).unwrap();
    let mut two = dict();
    set_all(&mut two, 2);
    storage.store(&two, Group::All).unwrap();
    (storage, one, two)
}

#[test]
fn damage_anywhere_in_the_newer_bank_falls_back_to_the_older_image() {
    let (mut storage, one, _) = two_images();
    let payload_len = dict_records_len(&one);
    let bank = storage.bank_size as usize;
    for at in 0..HEADER_LEN + payload_len {
        for flip in [0x01u8, 0x80, 0xFF] {
            storage.area_mut().bytes[bank + at] ^= flip;
            let (od, report) = loaded(&mut storage);
            assert_eq!(report.image, ImageState::Found { sequence: 1 }, "byte {at} ^ {flip:#x}");
            assert_eq!(values(&od), values(&one));
            storage.area_mut().bytes[bank + at] ^= flip;
        }
    }
}

#[test]
fn damage_anywhere_in_the_older_bank_is_ignored() {
    let (mut storage, _, two) = two_images();
    let payload_len = dict_records_len(&two);
    for at in 0..HEADER_LEN + payload_len {
        storage.area_mut().bytes[at] ^= 0x10;
        let (od, report) = loaded(&mut storage);
        assert_eq!(report.image, ImageState::Found { sequence: 2 }, "byte {at}");
        assert_eq!(values(&od), values(&two));
        storage.area_mut().bytes[at] ^= 0x10;
    }
}

#[test]
fn damage_to_the_only_image_gives_defaults_and_corrupt() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    set_all(&mut od, 3);
    storage.store(&od, Group::All).unwrap();
    for at in 0..HEADER_LEN + dict_records_len(&od) {
        storage.area_mut().bytes[at] ^= 0x04;
        let (fresh, report) = loaded(&mut storage);
        assert_eq!(report, LoadReport { image: ImageState::Corrupt, applied: 0, skipped: 0 }, "byte {at}");
        assert!(report.image.is_lost());
        assert_eq!(values(&fresh), values(&dict()));
        storage.area_mut().bytes[at] ^= 0x04;
    }
    // A store after damage replaces the damaged bank's content cleanly.
    storage.area_mut().bytes[40] ^= 0x04;
    storage.store(&od, Group::All).unwrap();
    assert_eq!(loaded(&mut storage).1.image, ImageState::Found { sequence: 1 });
}

fn dict_records_len(od: &Od) -> usize {
    od.records_len(0..=0xFFFF)
}

#[test]
fn a_foreign_signature_or_format_is_not_loaded() {
    let mut flash = TestFlash::new(2048, 256, 4);
    let mut od = dict();
    set_all(&mut od, 4);
    Storage::new(&mut flash, 0xAAAA_0001).unwrap().store(&od, Group::All).unwrap();

    let mut other = Storage::new(&mut flash, 0xBBBB_0002).unwrap();
    let mut fresh = dict();
    let report = other.load(&mut fresh, Group::All).unwrap();
    assert_eq!(report, LoadReport { image: ImageState::Foreign, applied: 0, skipped: 0 });
    assert!(report.image.is_lost());
    assert_eq!(values(&fresh), values(&dict()));

    // Storing over a foreign image works and is then ours.
    other.store(&fresh, Group::All).unwrap();
    assert_eq!(other.status(), Ok(ImageState::Found { sequence: 1 }));
    // The first device now sees one foreign and no own image.
    assert_eq!(Storage::new(&mut flash, 0xAAAA_0001).unwrap().status(), Ok(ImageState::Foreign));

    // A header of another format version, with a correct CRC, is foreign too.
    let mut flash = TestFlash::new(2048, 256, 4);
    let header = Header { version: FORMAT_VERSION + 1, signature: 7, sequence: 9, len: 0, crc: 0 };
    flash.bytes[..HEADER_LEN].copy_from_slice(&header.encode());
    assert_eq!(Storage::new(&mut flash, 7).unwrap().status(), Ok(ImageState::Foreign));
}

/// Rewrites the sequence number of the image in `bank` (behind the journal's back).
fn set_sequence(storage: &mut Storage<TestFlash>, bank: usize, sequence: u32) {
    let start = storage.bank_start(bank) as usize;
    let raw: [u8; HEADER_LEN] = storage.area().bytes[start..start + HEADER_LEN].try_into().unwrap();
    let Decoded::Header(mut header) = Header::decode(&raw) else { panic!("no header") };
    header.sequence = sequence;
    storage.area_mut().bytes[start..start + HEADER_LEN].copy_from_slice(&header.encode());
}

#[test]
fn sequence_numbers_wrap() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    set_all(&mut od, 1);
    storage.store(&od, Group::All).unwrap();
    set_sequence(&mut storage, 0, u32::MAX - 1);
    set_all(&mut od, 2);
    storage.store(&od, Group::All).unwrap();
    assert_eq!(storage.status(), Ok(ImageState::Found { sequence: u32::MAX }));
    set_all(&mut od, 3);
    storage.store(&od, Group::All).unwrap();
    let (fresh, report) = loaded(&mut storage);
    assert_eq!(report.image, ImageState::Found { sequence: 0 }, "0 is newer than 0xFFFF_FFFF");
    assert_eq!(values(&fresh), values(&od));
    set_all(&mut od, 4);
    storage.store(&od, Group::All).unwrap();
    let (fresh, report) = loaded(&mut storage);
    assert_eq!(report.image, ImageState::Found { sequence: 1 });
    assert_eq!(values(&fresh), values(&od));
    // Bank 0 holds sequence 0 here, bank 1 sequence 1: the newer one is taken whichever bank.
    assert_eq!(storage.area().bytes[12], 0);
}

/// A storage holding the values of seed 1 (returned as the first dictionary) and a dictionary
/// changed to seed 2 since.
fn stored_then_changed() -> (Storage<TestFlash>, Od, Od) {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    set_all(&mut od, 1);
    storage.store(&od, Group::All).unwrap();
    let stored = od_clone(&od);
    set_all(&mut od, 2);
    (storage, stored, od)
}

#[test]
fn storing_one_group_keeps_the_others_from_the_image() {
    let (mut storage, a, od) = stored_then_changed();
    let b = od_clone(&od);
    storage.store(&od, Group::Manufacturer).unwrap();
    let (fresh, _) = loaded(&mut storage);
    assert_eq!(group_values(&fresh, Group::Manufacturer), group_values(&b, Group::Manufacturer));
    assert_eq!(group_values(&fresh, Group::Communication), group_values(&a, Group::Communication));
    assert_eq!(group_values(&fresh, Group::Application), group_values(&a, Group::Application));

    storage.store(&od, Group::Application).unwrap();
    storage.store(&od, Group::Communication).unwrap();
    let (fresh, report) = loaded(&mut storage);
    assert_eq!(report.image, ImageState::Found { sequence: 4 });
    assert_eq!(values(&fresh), values(&b));
}

#[test]
fn storing_single_entries_keeps_every_other_record() {
    let (mut nv, a, od) = stored_then_changed();
    let mut empty = storage(TestFlash::new(2048, 256, 4));
    // Two entries of a record and one of an array; 1000h (not a parameter) is left out.
    let entries = [(0x2001, 1), (0x2002, 3), (0x6065, 0), (0x1000, 0)];
    nv.store_entries(&od, &entries).unwrap();
    let (fresh, report) = loaded(&mut nv);
    assert_eq!(report.image, ImageState::Found { sequence: 2 });
    // `base` with the selected entries' values from `od`.
    let merged = |base: &Od| -> Vec<_> {
        let pick =
            |(old, new): ((u16, u8, Vec<u8>), _)| if entries.contains(&(old.0, old.1)) { new } else { old };
        values(base).into_iter().zip(values(&od)).map(pick).collect()
    };
    assert_eq!(values(&fresh), merged(&a));
    assert_ne!(values(&fresh), values(&a));

    // Without an image: only the entries, every other parameter at its default.
    empty.store_entries(&od, &entries).unwrap();
    let (fresh, report) = loaded(&mut empty);
    assert_eq!(report.applied, 3);
    assert_eq!(values(&fresh), merged(&dict()));
}

#[test]
fn storing_a_group_without_an_image_stores_that_group_only() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    set_all(&mut od, 6);
    storage.store(&od, Group::Communication).unwrap();
    let (fresh, report) = loaded(&mut storage);
    let communication = od.parameters(Group::Communication.range()).count() as u32;
    assert_eq!(report.applied, communication);
    assert_eq!(group_values(&fresh, Group::Communication), group_values(&od, Group::Communication));
    assert_eq!(group_values(&fresh, Group::Manufacturer), group_values(&dict(), Group::Manufacturer));
}

#[test]
fn restoring_defaults_drops_the_group_from_the_image() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    set_all(&mut od, 1);
    storage.store(&od, Group::All).unwrap();
    let before = values(&od);

    storage.restore_defaults(Group::Manufacturer).unwrap();
    assert_eq!(values(&od), before, "RAM values do not change");
    let (fresh, report) = loaded(&mut storage);
    assert_eq!(report.image, ImageState::Found { sequence: 2 });
    assert_eq!(group_values(&fresh, Group::Manufacturer), group_values(&dict(), Group::Manufacturer));
    assert_eq!(group_values(&fresh, Group::Communication), group_values(&od, Group::Communication));
    assert_eq!(group_values(&fresh, Group::Application), group_values(&od, Group::Application));

    // Storing the group again brings it back; restoring everything empties the image.
    storage.store(&od, Group::Manufacturer).unwrap();
    assert_eq!(values(&loaded(&mut storage).0), before);
    storage.restore_defaults(Group::All).unwrap();
    let (fresh, report) = loaded(&mut storage);
    assert_eq!(report, LoadReport { image: ImageState::Found { sequence: 4 }, applied: 0, skipped: 0 });
    assert_eq!(values(&fresh), values(&dict()));
    assert_eq!(
        storage.payload_len(&od, Group::Communication),
        Ok(od.records_len(Group::Communication.range()))
    );
}

#[test]
fn loading_one_group_applies_only_that_group() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    set_all(&mut od, 9);
    storage.store(&od, Group::All).unwrap();
    let mut fresh = dict();
    let report = storage.load(&mut fresh, Group::Communication).unwrap();
    assert_eq!(report.applied, od.parameters(Group::Communication.range()).count() as u32);
    assert_eq!(group_values(&fresh, Group::Communication), group_values(&od, Group::Communication));
    assert_eq!(group_values(&fresh, Group::Manufacturer), group_values(&dict(), Group::Manufacturer));
}

#[test]
fn records_the_firmware_no_longer_accepts_are_skipped() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    set_all(&mut od, 1);
    storage.store(&od, Group::All).unwrap();
    // A firmware without the manufacturer objects and with a narrower limit on 2001h.
    static NARROW_SUBS: [(u8, Var); 2] = [
        (
            0,
            Var::new("Highest sub-index supported", DataType::Unsigned8)
                .access(Access::Const)
                .default(DefaultValue::Unsigned(1)),
        ),
        (1, Var::new("Gain", DataType::Integer16).access(Access::ReadWrite).limits_signed(0, 1000)),
    ];
    static NARROW: [Object; 1] = layout([Object::record(0x2001, "Loop", &NARROW_SUBS)]);
    let mut other =
        Dictionary::<1024>::new(&[&COMMUNICATION, &NARROW], DeviceInfo::servo_drive(), 5).unwrap();
    let report = storage.load(&mut other, Group::All).unwrap();
    let communication = od.parameters(Group::Communication.range()).count() as u32;
    // Skipped: 2000h (gone), 2001h sub 1 (-11 < 0), 2001h sub 2 (gone), 2002h subs 1..4 (gone), 6065h.
    assert_eq!(report.applied, communication);
    assert_eq!(report.skipped, 8);
    assert_eq!(other.get::<i16>(0x2001, 1), Ok(0));
}

#[test]
fn an_image_larger_than_a_bank_is_refused_before_anything_is_erased() {
    // Banks of 128 bytes: 96 bytes of payload.
    let mut storage = storage(TestFlash::new(256, 128, 4));
    static SMALL: [Object; 1] = layout([Object::var(
        0x2000,
        "Name",
        Var::new("Name", DataType::OctetString).access(Access::ReadWrite).capacity(120),
    )]);
    let mut od = Dictionary::<256>::new(&[&SMALL], DeviceInfo::servo_drive(), 5).unwrap();
    let name = od.entry(0x2000, 0).unwrap();
    od.commit(&name, &[7; 60]);
    storage.store(&od, Group::All).unwrap();
    od.commit(&name, &[8; 100]);
    assert_eq!(storage.store(&od, Group::All), Err(StorageError::NoSpace));
    assert!(storage.area().bytes[128..].iter().all(|b| *b == 0xFF), "nothing erased or written");
    let mut fresh = Dictionary::<256>::new(&[&SMALL], DeviceInfo::servo_drive(), 5).unwrap();
    storage.load(&mut fresh, Group::All).unwrap();
    let mut buf = [0u8; 120];
    assert_eq!(fresh.read(&name, 0, &mut buf), 60);
    assert_eq!(AbortCode::from(StorageError::NoSpace), AbortCode::CannotStore);
    assert_eq!(AbortCode::from(StorageError::Area(NvError::Device)), AbortCode::HardwareError);
}

#[test]
fn a_read_failure_during_load_leaves_defaults() {
    let mut storage = storage(TestFlash::new(2048, 256, 4));
    let mut od = dict();
    set_all(&mut od, 5);
    storage.store(&od, Group::All).unwrap();
    // Count the reads of a successful load, then fail each one in turn.
    storage.area_mut().reads_left = Some(usize::MAX);
    loaded(&mut storage);
    let reads = usize::MAX - storage.area().reads_left.unwrap();
    for n in 0..reads {
        storage.area_mut().reads_left = Some(n);
        let mut fresh = dict();
        assert_eq!(storage.load(&mut fresh, Group::All), Err(StorageError::Area(NvError::Device)));
        assert_eq!(values(&fresh), values(&dict()), "read {n} failed");
    }
    storage.area_mut().reads_left = None;
    assert_eq!(values(&loaded(&mut storage).0), values(&od));
}

#[test]
fn groups_follow_the_sub_indices() {
    for group in Group::ALL {
        assert_eq!(Group::from_sub(group.sub()), Some(group));
        for index in [0x1000u16, 0x1FFF, 0x2000, 0x5FFF, 0x6000, 0x9FFF, 0xA000] {
            assert_eq!(group.contains(index), group.range().contains(&index));
        }
    }
    assert_eq!(Group::from_sub(0), None);
    assert_eq!(SAVE_SIGNATURE.to_le_bytes(), *b"save");
    assert_eq!(LOAD_SIGNATURE.to_le_bytes(), *b"load");
    assert_eq!(Group::from_sub(5), None);
    assert!(Group::Manufacturer.contains(0x2000) && !Group::Manufacturer.contains(0x6000));
    let device = DeviceInfo::servo_drive();
    assert_ne!(device_signature(&device, 1), device_signature(&device, 2));
}

fn od_clone(od: &Od) -> Od {
    let mut copy = dict();
    for (index, sub, value) in values(od) {
        let entry = copy.entry(index, sub).unwrap();
        copy.commit(&entry, &value);
    }
    copy
}

#[test]
fn an_unreadable_bank_counts_as_corrupt() {
    let (mut storage, one, two) = two_images();
    let bank = storage.bank_size as usize;
    // The newer bank (1) fails to read: the older image is loaded.
    storage.area_mut().unreadable = Some(bank + 40..bank + 44);
    let (od, report) = loaded(&mut storage);
    assert_eq!(report.image, ImageState::Found { sequence: 1 });
    assert_eq!(values(&od), values(&one));
    // A store goes to the unreadable bank, whose erase cures it, and is then loaded.
    storage.store(&two, Group::All).unwrap();
    assert_eq!(storage.area().unreadable, None);
    let (od, report) = loaded(&mut storage);
    assert_eq!(report.image, ImageState::Found { sequence: 2 });
    assert_eq!(values(&od), values(&two));
    // Both banks unreadable: the area is failing.
    storage.area_mut().unreadable = Some(0..2048);
    let mut od = dict();
    assert_eq!(storage.load(&mut od, Group::All), Err(StorageError::Area(NvError::Device)));
    assert_eq!(storage.store(&od, Group::All), Err(StorageError::Area(NvError::Device)));
}

#[test]
fn any_flash_content_loads_without_panic() {
    let mut state = 0x0BAD_5EEDu32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state
    };
    let signature = 0x5157_0001;
    for round in 0..400 {
        let mut flash = TestFlash::new(1024, 256, 4);
        for b in flash.bytes.iter_mut() {
            *b = next() as u8;
        }
        // Half the rounds get a valid header over a payload of random records, so that the
        // record checks run on garbage.
        if round % 2 == 0 {
            let len = next() % 400;
            let payload: Vec<u8> = (0..len)
                .map(|i| match i % 9 {
                    0 => 0x17,
                    1 => [0x10, 0x20, 0x60][(next() % 3) as usize],
                    _ => next() as u8,
                })
                .collect();
            flash.bytes[32..32 + payload.len()].copy_from_slice(&payload);
            let header = Header {
                version: FORMAT_VERSION,
                signature,
                sequence: next(),
                len,
                crc: crc32::crc32(&payload),
            };
            flash.bytes[..HEADER_LEN].copy_from_slice(&header.encode());
        }
        let mut storage = Storage::new(flash, signature).unwrap();
        let mut od = dict();
        let report = storage.load(&mut od, Group::All).unwrap();
        if round % 2 == 0 {
            assert!(matches!(report.image, ImageState::Found { .. }));
        }
        // Whatever was applied passed the dictionary's own checks; a store of it works.
        storage.store(&od, Group::All).unwrap();
        let mut again = dict();
        storage.load(&mut again, Group::All).unwrap();
        assert_eq!(values(&again), values(&od), "round {round}");
    }
}

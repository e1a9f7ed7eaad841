//! Non-volatile areas for the host: [`SimFlash`], a NOR flash in RAM that can lose power in
//! the middle of any operation, and [`FileFlash`], the same semantics kept in a file (the
//! Linux program's `--storage PATH`).
//!
//! Both implement [`NonVolatile`], the trait the core's
//! [`Storage`](canopen_drive::storage::Storage) journal runs on.
//!
//! ## Power-cut injection
//!
//! [`SimFlash`] counts *steps*: every programmed write unit and every erased sector is one
//! step. [`SimFlash::cut_after`]`(k)` lets `k` more steps complete and interrupts the next one:
//! that unit or sector is left in a plausible partial state, the operation fails with
//! [`NvError::Device`] and so does every later operation (reads included) until
//! [`SimFlash::power_on`]. The partial states come from a seeded generator, so a run is
//! reproducible:
//!
//! - an interrupted program clears some, not all, of the bits it was clearing;
//! - an interrupted erase leaves the sector unchanged, with some bits set, erased up to some
//!   byte, or all zero (the pre-programming phase some chips run before erasing).

use std::fs::{File, OpenOptions};
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::Path;

use canopen_drive::storage::{NonVolatile, NvError};

/// Checks that `offset..offset + len` lies in `capacity` and is made of whole `unit`s.
fn check_range(offset: u32, len: usize, unit: usize, capacity: usize) -> Result<usize, NvError> {
    let start = offset as usize;
    if start.checked_add(len).is_none_or(|end| end > capacity) {
        return Err(NvError::OutOfBounds);
    }
    if unit == 0 || !start.is_multiple_of(unit) || !len.is_multiple_of(unit) {
        return Err(NvError::NotAligned);
    }
    Ok(start)
}

/// A NOR flash in RAM with exact program/erase semantics and power-cut injection (see the
/// [module docs](self)). `Clone` takes a snapshot of the whole chip.
///
/// ```
/// use canopen_drive::storage::{NonVolatile, NvError};
/// use canopen_drive_sim::flash::SimFlash;
///
/// let mut flash = SimFlash::new(1024, 256, 4);
/// flash.write(0, &[0x0F, 0xF0, 0x00, 0xFF]).unwrap();
/// flash.write(0, &[0xFF, 0x0F, 0xFF, 0x00]).unwrap(); // programming only clears bits
/// assert_eq!(&flash.bytes()[..4], &[0x0F, 0x00, 0x00, 0x00]);
/// assert_eq!(flash.overwrites(), 1);
///
/// flash.cut_after(1); // one more step completes, the next is interrupted
/// assert_eq!(flash.write(4, &[0; 8]), Err(NvError::Device));
/// assert_eq!(&flash.bytes()[4..8], &[0; 4]);
/// assert_eq!(flash.read(0, &mut [0; 4]), Err(NvError::Device)); // no power
/// flash.power_on();
/// flash.erase(0, 256).unwrap();
/// ```
#[derive(Clone, Debug)]
pub struct SimFlash {
    bytes: Vec<u8>,
    erase_size: usize,
    write_size: usize,
    steps: u64,
    cut_at: Option<u64>,
    powered: bool,
    rng: u64,
    overwrites: u64,
    sector_erases: Vec<u32>,
}

impl SimFlash {
    /// An erased chip of `capacity` bytes with sectors of `erase_size` bytes and program units
    /// of `write_size` bytes. `capacity` is rounded down to whole sectors; sizes of 0 count as 1.
    pub fn new(capacity: usize, erase_size: usize, write_size: usize) -> Self {
        let erase_size = erase_size.max(1);
        let capacity = capacity / erase_size * erase_size;
        SimFlash {
            bytes: vec![0xFF; capacity],
            erase_size,
            write_size: write_size.max(1),
            steps: 0,
            cut_at: None,
            powered: true,
            rng: 0x9E37_79B9_7F4A_7C15,
            overwrites: 0,
            sector_erases: vec![0; capacity / erase_size],
        }
    }

    /// Lets `steps` more steps complete, then interrupts the next one and turns the power off.
    pub fn cut_after(&mut self, steps: u64) {
        self.cut_at = Some(self.steps.saturating_add(steps));
    }

    /// Turns the power back on and cancels a pending cut.
    pub fn power_on(&mut self) {
        self.powered = true;
        self.cut_at = None;
    }

    /// False from a cut until [`power_on`](Self::power_on).
    pub fn is_powered(&self) -> bool {
        self.powered
    }

    /// Steps (program units and sector erases) completed since the chip was made.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Seeds the generator of partial states.
    pub fn set_seed(&mut self, seed: u64) {
        // Xorshift needs a non-zero state.
        self.rng = seed ^ 0x9E37_79B9_7F4A_7C15;
        if self.rng == 0 {
            self.rng = 1;
        }
    }

    /// The chip's contents.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The chip's contents, writable without NOR rules (to model damage).
    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.bytes
    }

    /// Programs of a unit that was not erased (a correct user of NOR flash makes none).
    pub fn overwrites(&self) -> u64 {
        self.overwrites
    }

    /// How often each sector was erased (completed erases).
    pub fn sector_erases(&self) -> &[u32] {
        &self.sector_erases
    }

    fn random(&mut self) -> u64 {
        let mut x = self.rng;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.rng = x;
        x
    }

    /// True when the step about to run is the one the cut interrupts.
    fn cut_now(&self) -> bool {
        self.cut_at == Some(self.steps)
    }

    fn lose_power(&mut self) -> NvError {
        self.powered = false;
        self.cut_at = None;
        NvError::Device
    }

    fn program_unit(&mut self, at: usize, data: &[u8]) -> Result<(), NvError> {
        let cut = self.cut_now();
        let Some(unit) = self.bytes.get(at..at + data.len()) else { return Err(NvError::OutOfBounds) };
        if unit.iter().any(|b| *b != 0xFF) {
            self.overwrites += 1;
        }
        let mut new = unit.to_vec();
        for (byte, want) in new.iter_mut().zip(data) {
            let clearing = *byte & !*want;
            let cleared = if cut { clearing & self.random() as u8 } else { clearing };
            *byte &= !cleared;
        }
        if let Some(unit) = self.bytes.get_mut(at..at + data.len()) {
            unit.copy_from_slice(&new);
        }
        if cut {
            return Err(self.lose_power());
        }
        self.steps += 1;
        Ok(())
    }

    fn erase_sector(&mut self, at: usize) -> Result<(), NvError> {
        let size = self.erase_size;
        if !self.cut_now() {
            self.bytes.get_mut(at..at + size).ok_or(NvError::OutOfBounds)?.fill(0xFF);
            if let Some(count) = self.sector_erases.get_mut(at / size) {
                *count += 1;
            }
            self.steps += 1;
            return Ok(());
        }
        let mode = self.random() % 4;
        let erased_to = (self.random() as usize) % (size + 1);
        let mut noise = Vec::with_capacity(size);
        for _ in 0..size {
            noise.push(self.random() as u8);
        }
        let sector = self.bytes.get_mut(at..at + size).ok_or(NvError::OutOfBounds)?;
        match mode {
            0 => {}
            1 => sector.iter_mut().zip(noise).for_each(|(b, n)| *b |= n),
            2 => sector.iter_mut().take(erased_to).for_each(|b| *b = 0xFF),
            _ => sector.fill(0),
        }
        Err(self.lose_power())
    }
}

impl NonVolatile for SimFlash {
    fn capacity(&self) -> usize {
        self.bytes.len()
    }

    fn erase_size(&self) -> usize {
        self.erase_size
    }

    fn write_size(&self) -> usize {
        self.write_size
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        if !self.powered {
            return Err(NvError::Device);
        }
        let start = check_range(offset, buf.len(), 1, self.bytes.len())?;
        buf.copy_from_slice(self.bytes.get(start..start + buf.len()).ok_or(NvError::OutOfBounds)?);
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        if !self.powered {
            return Err(NvError::Device);
        }
        let start = check_range(offset, data.len(), self.write_size, self.bytes.len())?;
        for (i, unit) in data.chunks(self.write_size).enumerate() {
            self.program_unit(start + i * self.write_size, unit)?;
        }
        Ok(())
    }

    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        if !self.powered {
            return Err(NvError::Device);
        }
        let len = (to as usize).checked_sub(from as usize).ok_or(NvError::OutOfBounds)?;
        let start = check_range(from, len, self.erase_size, self.bytes.len())?;
        for sector in (start..start + len).step_by(self.erase_size) {
            self.erase_sector(sector)?;
        }
        Ok(())
    }
}

/// A NOR flash kept in a file of fixed size, for a drive on a host that keeps its parameters
/// across runs. A new file is created erased (all 0xFF). Every write and erase reaches the disk
/// (`fsync`) before it returns, in order, so the journal's commit point keeps its meaning if
/// the host crashes.
#[derive(Debug)]
pub struct FileFlash {
    file: File,
    capacity: usize,
    erase_size: usize,
    write_size: usize,
    /// The file has another size ([`open_tolerant`](Self::open_tolerant)): it reads as
    /// damaged data and gets its size at the first erase or write.
    wrong_size: bool,
}

impl FileFlash {
    /// Size of the file [`open_default`](Self::open_default) uses: 16 KiB.
    pub const DEFAULT_CAPACITY: usize = 16 * 1024;
    /// Sector size of [`open_default`](Self::open_default): 4 KiB, like a serial NOR chip.
    pub const DEFAULT_ERASE_SIZE: usize = 4096;
    /// Program unit of [`open_default`](Self::open_default).
    pub const DEFAULT_WRITE_SIZE: usize = 4;

    /// Opens the area in the file at `path`, creating it erased if it does not exist. An
    /// existing file must have exactly `capacity` bytes; `capacity` must be whole sectors and
    /// a sector whole program units.
    pub fn open(
        path: impl AsRef<Path>,
        capacity: usize,
        erase_size: usize,
        write_size: usize,
    ) -> io::Result<Self> {
        check_geometry(capacity, erase_size, write_size)?;
        let mut file = OpenOptions::new().read(true).write(true).create(true).truncate(false).open(path)?;
        let len = file.metadata()?.len();
        if len == 0 {
            file.write_all(&vec![0xFF; capacity])?;
            file.sync_all()?;
        } else if len != capacity as u64 {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!("storage file has {len} bytes, expected {capacity}"),
            ));
        }
        Ok(FileFlash { file, capacity, erase_size, write_size, wrong_size: false })
    }

    /// [`open`](Self::open) with the default geometry (16 KiB, 4 KiB sectors, 4-byte units).
    pub fn open_default(path: impl AsRef<Path>) -> io::Result<Self> {
        Self::open(path, Self::DEFAULT_CAPACITY, Self::DEFAULT_ERASE_SIZE, Self::DEFAULT_WRITE_SIZE)
    }

    /// Like [`open`](Self::open), with one rule for every kind of damage: an existing file of
    /// another size (an empty one too) is not an error but a damaged medium, as damaged
    /// contents are. It reads as programmed zeros, so that a load finds no valid image (the
    /// defaults apply and the image is reported lost), and it is not changed until the first
    /// erase or write (a store), which first gives it its size, erased. A missing file is
    /// created erased, as by `open`.
    ///
    /// Returns the flash and, for a file of another size, what is wrong with it.
    pub fn open_tolerant(
        path: impl AsRef<Path>,
        capacity: usize,
        erase_size: usize,
        write_size: usize,
    ) -> io::Result<(Self, Option<String>)> {
        let path = path.as_ref();
        let len = match std::fs::metadata(path) {
            Ok(metadata) => Some(metadata.len()),
            Err(e) if e.kind() == io::ErrorKind::NotFound => None,
            Err(e) => return Err(e),
        };
        match len {
            Some(len) if len != capacity as u64 => {
                check_geometry(capacity, erase_size, write_size)?;
                let file = OpenOptions::new().read(true).write(true).open(path)?;
                let flash = FileFlash { file, capacity, erase_size, write_size, wrong_size: true };
                Ok((flash, Some(format!("the file has {len} bytes, not {capacity}"))))
            }
            _ => Ok((Self::open(path, capacity, erase_size, write_size)?, None)),
        }
    }

    /// [`open_tolerant`](Self::open_tolerant) with the default geometry.
    pub fn open_default_tolerant(path: impl AsRef<Path>) -> io::Result<(Self, Option<String>)> {
        Self::open_tolerant(path, Self::DEFAULT_CAPACITY, Self::DEFAULT_ERASE_SIZE, Self::DEFAULT_WRITE_SIZE)
    }

    /// Before the first change of a file of the wrong size: gives it its size, erased.
    fn restore_size(&mut self) -> io::Result<()> {
        if self.wrong_size {
            self.file.set_len(0)?;
            self.write_at(0, &vec![0xFF; self.capacity])?;
            self.wrong_size = false;
        }
        Ok(())
    }

    fn read_at(&mut self, start: usize, buf: &mut [u8]) -> io::Result<()> {
        self.file.seek(SeekFrom::Start(start as u64))?;
        self.file.read_exact(buf)
    }

    fn write_at(&mut self, start: usize, data: &[u8]) -> io::Result<()> {
        self.file.seek(SeekFrom::Start(start as u64))?;
        self.file.write_all(data)?;
        self.file.sync_data()
    }
}

/// Capacity in whole sectors, a sector in whole program units.
fn check_geometry(capacity: usize, erase_size: usize, write_size: usize) -> io::Result<()> {
    if erase_size == 0
        || write_size == 0
        || !capacity.is_multiple_of(erase_size)
        || !erase_size.is_multiple_of(write_size)
    {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "flash geometry: capacity must be whole sectors, a sector whole write units",
        ));
    }
    Ok(())
}

impl NonVolatile for FileFlash {
    fn capacity(&self) -> usize {
        self.capacity
    }

    fn erase_size(&self) -> usize {
        self.erase_size
    }

    fn write_size(&self) -> usize {
        self.write_size
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        let start = check_range(offset, buf.len(), 1, self.capacity)?;
        if self.wrong_size {
            buf.fill(0);
            return Ok(());
        }
        self.read_at(start, buf).map_err(|_| NvError::Device)
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        let start = check_range(offset, data.len(), self.write_size, self.capacity)?;
        self.restore_size().map_err(|_| NvError::Device)?;
        // NOR: programming only clears bits.
        let mut merged = vec![0u8; data.len()];
        self.read_at(start, &mut merged).map_err(|_| NvError::Device)?;
        merged.iter_mut().zip(data).for_each(|(m, d)| *m &= d);
        self.write_at(start, &merged).map_err(|_| NvError::Device)
    }

    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        let len = (to as usize).checked_sub(from as usize).ok_or(NvError::OutOfBounds)?;
        let start = check_range(from, len, self.erase_size, self.capacity)?;
        self.restore_size().map_err(|_| NvError::Device)?;
        self.write_at(start, &vec![0xFF; len]).map_err(|_| NvError::Device)
    }
}

#[cfg(test)]
mod tests {
    use canopen_drive::od::standard::COMMUNICATION;
    use canopen_drive::od::{DeviceInfo, Dictionary};
    use canopen_drive::storage::{Group, ImageState, Storage};

    use super::*;

    #[test]
    fn nor_rules() {
        let mut flash = SimFlash::new(1024, 256, 4);
        assert_eq!(flash.write(2, &[0; 4]), Err(NvError::NotAligned));
        assert_eq!(flash.write(0, &[0; 3]), Err(NvError::NotAligned));
        assert_eq!(flash.write(1024, &[0; 4]), Err(NvError::OutOfBounds));
        assert_eq!(flash.erase(0, 100), Err(NvError::NotAligned));
        assert_eq!(flash.erase(256, 0), Err(NvError::OutOfBounds));
        flash.write(8, &[0xAA; 8]).unwrap();
        assert_eq!(flash.steps(), 2);
        assert_eq!(flash.overwrites(), 0);
        flash.write(8, &[0x55; 4]).unwrap();
        assert_eq!(&flash.bytes()[8..16], &[0, 0, 0, 0, 0xAA, 0xAA, 0xAA, 0xAA]);
        assert_eq!(flash.overwrites(), 1);
        flash.erase(0, 512).unwrap();
        assert_eq!(flash.steps(), 5);
        assert!(flash.bytes().iter().all(|b| *b == 0xFF));
        assert_eq!(flash.sector_erases(), &[1, 1, 0, 0]);
    }

    #[test]
    fn a_cut_program_clears_only_some_bits_and_stops_everything() {
        for seed in 0..64 {
            let mut flash = SimFlash::new(1024, 256, 4);
            flash.set_seed(seed);
            flash.cut_after(2);
            assert_eq!(flash.write(0, &[0x00; 16]), Err(NvError::Device));
            assert_eq!(&flash.bytes()[..8], &[0; 8], "two units completed");
            assert!(flash.bytes()[12..].iter().all(|b| *b == 0xFF), "nothing after the cut unit");
            assert_eq!(flash.steps(), 2);
            assert!(!flash.is_powered());
            assert_eq!(flash.read(0, &mut [0; 1]), Err(NvError::Device));
            assert_eq!(flash.write(16, &[0; 4]), Err(NvError::Device));
            assert_eq!(flash.erase(0, 256), Err(NvError::Device));
            flash.power_on();
            flash.read(0, &mut [0; 1]).unwrap();
        }
    }

    #[test]
    fn cut_erases_leave_varied_partial_states() {
        let mut states = [false; 4];
        for seed in 0..64 {
            let mut flash = SimFlash::new(1024, 256, 4);
            flash.set_seed(seed);
            flash.write(0, &[0x5A; 256]).unwrap();
            flash.cut_after(0);
            assert_eq!(flash.erase(0, 512), Err(NvError::Device));
            let sector = &flash.bytes()[..256];
            let unchanged = sector.iter().all(|b| *b == 0x5A);
            let zero = sector.iter().all(|b| *b == 0);
            let head = sector.iter().take_while(|b| **b == 0xFF).count();
            let erased_prefix = head > 0 && sector[head..].iter().all(|b| *b == 0x5A);
            states[if unchanged {
                0
            } else if zero {
                1
            } else if erased_prefix {
                2
            } else {
                3
            }] = true;
            assert!(flash.bytes()[256..].iter().all(|b| *b == 0xFF));
            assert_eq!(flash.sector_erases(), &[0, 0, 0, 0]);
        }
        assert_eq!(states, [true; 4], "unchanged, zero, erased up to a byte, and mixed bits all occur");
    }

    fn temp_path(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("canopen-drive-{name}-{}.bin", std::process::id()))
    }

    #[test]
    fn file_flash_keeps_parameters_across_opens() {
        let path = temp_path("file-flash");
        let _ = std::fs::remove_file(&path);
        let device = DeviceInfo::servo_drive();
        {
            let flash = FileFlash::open_default(&path).unwrap();
            let mut storage = Storage::new(flash, 7).unwrap();
            let mut od = Dictionary::<512>::new(&[&COMMUNICATION], device, 3).unwrap();
            od.set::<u16>(0x1017, 0, 321).unwrap();
            storage.store(&od, Group::All).unwrap();
        }
        assert_eq!(std::fs::metadata(&path).unwrap().len(), FileFlash::DEFAULT_CAPACITY as u64);
        let mut storage = Storage::new(FileFlash::open_default(&path).unwrap(), 7).unwrap();
        let mut od = Dictionary::<512>::new(&[&COMMUNICATION], device, 3).unwrap();
        assert_eq!(storage.load(&mut od, Group::All).unwrap().image, ImageState::Found { sequence: 1 });
        assert_eq!(od.get::<u16>(0x1017, 0), Ok(321));
        // NOR semantics in the file too.
        let mut flash = storage.into_area();
        flash.write(8192, &[0xF0; 4]).unwrap();
        flash.write(8192, &[0x3C; 4]).unwrap();
        let mut back = [0u8; 4];
        flash.read(8192, &mut back).unwrap();
        assert_eq!(back, [0x30; 4]);
        assert!(FileFlash::open(&path, 8192, 4096, 4).is_err(), "another size is refused");
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_file_of_another_size_is_a_damaged_medium_kept_until_a_store() {
        let path = temp_path("file-flash-size");
        let device = DeviceInfo::servo_drive();
        for len in [0, 100, FileFlash::DEFAULT_CAPACITY + 1] {
            std::fs::write(&path, vec![0x5A; len]).unwrap();
            let (flash, damage) = FileFlash::open_default_tolerant(&path).unwrap();
            assert!(damage.unwrap().contains(&format!("{len} bytes")));
            let mut storage = Storage::new(flash, 7).unwrap();
            let mut od = Dictionary::<512>::new(&[&COMMUNICATION], device, 3).unwrap();
            assert_eq!(storage.load(&mut od, Group::All).unwrap().image, ImageState::Corrupt, "{len} bytes");
            assert!(std::fs::read(&path).unwrap() == vec![0x5A; len], "{len} bytes: untouched until a store");
            storage.store(&od, Group::All).unwrap();
            assert_eq!(std::fs::metadata(&path).unwrap().len(), FileFlash::DEFAULT_CAPACITY as u64);
            let (flash, damage) = FileFlash::open_default_tolerant(&path).unwrap();
            assert_eq!(damage, None);
            let mut storage = Storage::new(flash, 7).unwrap();
            assert_eq!(storage.load(&mut od, Group::All).unwrap().image, ImageState::Found { sequence: 1 });
        }
        let _ = std::fs::remove_file(&path);
        let (_, damage) = FileFlash::open_default_tolerant(&path).unwrap();
        assert_eq!(damage, None, "a missing file is created erased");
        let _ = std::fs::remove_file(&path);
    }
}

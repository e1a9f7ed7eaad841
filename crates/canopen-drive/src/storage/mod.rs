//! Parameter storage that survives power loss at any instant (CiA 301 §7.5.2, objects
//! 1010h "store parameters" and 1011h "restore default parameters"): after a power loss at any
//! instant of a store, the drive starts with the old set or the new one, never a mix.
//!
//! [`Storage`] keeps the dictionary's parameters (see [`crate::od::persist`]) in a board's
//! [`NonVolatile`] area with NOR-flash semantics, as a journal of two banks. After a reset
//! the drive holds the set of the last store that completed or, if a store was cut by a power
//! loss, the set before it: never a mix.
//!
//! ## Groups
//!
//! [`Group`] follows the sub-indices of 1010h/1011h: 1 = all parameters, 2 = communication
//! (1000h–1FFFh), 3 = application (6000h–9FFFh), 4 = manufacturer (2000h–5FFFh). One image
//! holds every group. [`Storage::store`] of one group writes a new image with that group's
//! current values and the other groups' records copied from the previous image;
//! [`Storage::restore_defaults`] of a group writes a new image without that group's records,
//! so that its defaults apply after the next reset (the RAM values do not change, as §11
//! says). [`Storage::store_entries`] does the same for single entries a firmware saves itself
//! (a [`Selection`]). The command objects themselves (their read values, the "save"/"load" signatures,
//! the SDO answers) are the caller's.
//!
//! ## Area layout
//!
//! The area is cut into two banks of `⌊sectors / 2⌋` erase sectors each (an odd last sector
//! is not used):
//!
//! ```text
//! offset 0                       bank size                    2 × bank size
//! | header | payload | unused    | header | payload | unused  |
//! ```
//!
//! A bank holds one image: a header of 32 bytes, padded with 0xFF to the write size, then the
//! payload. All numbers are little-endian.
//!
//! ```text
//! offset  size  field
//!      0     4  magic "COPJ" (43 4F 50 4A)
//!      4     2  format version (1)
//!      6     2  reserved (0)
//!      8     4  device signature, given to Storage::new
//!     12     4  sequence number: 1 + that of the image it replaces
//!     16     4  payload length in bytes
//!     20     4  payload CRC-32
//!     24     4  reserved (0)
//!     28     4  header CRC-32 of bytes 0..28
//! ```
//!
//! Both CRCs are the CRC-32 of zlib and Ethernet (reflected polynomial 0xEDB8_8320, initial
//! value and final XOR 0xFFFF_FFFF). The payload is a stream of records (index u16, sub-index
//! u8, data type u8, length u16, value) described in [`crate::od::persist`]. Every later format
//! keeps the magic, the version at offset 4 and the header CRC at offset 28, so that an image
//! of another format is recognised as such.
//!
//! A bank is *valid* when its magic and header CRC are right, the format version and the
//! device signature are this device's, the payload fits the bank and its CRC is right. A bank
//! with a correct header of another format version or device signature is *foreign* (another
//! product, or a firmware whose parameters mean something else) and is never loaded.
//!
//! ## Why a power loss cannot leave a mix
//!
//! A store writes a whole new image into the bank that does *not* hold the newest valid image:
//! it erases the sectors it needs, programs the payload, and programs the header last. The
//! header is the commit point: until all of it is programmed, the bank's header is blank,
//! partial or has a wrong CRC, so the bank is not valid and a load takes the other bank,
//! untouched, which holds the previous image. Once the header is complete, the new image is
//! valid and, its sequence number being one more, newer. A load validates both banks and
//! takes the valid one with the newer sequence number, compared with wrap-around (serial-number
//! arithmetic), so the count may roll over. A store reads the finished bank back before it
//! reports success.
//!
//! A store needs one buffer of 256 bytes and a few small ones on the stack; nothing is
//! allocated. The write size of the area must divide 256 (every power of two up to 256).

mod area;
mod crc32;
mod image;

pub use area::{NonVolatile, NorFlashArea, NvError, MAX_READ_SIZE};

use core::ops::RangeInclusive;

use crate::od::persist::{RecordEvent, RecordLoader, RecordParser};
use crate::od::{AbortCode, DeviceInfo, Dictionary};
pub(crate) use crc32::Crc32;
use image::{is_newer, Decoded, Header, FORMAT_VERSION, HEADER_LEN};

/// 1011h restore default parameters (write [`LOAD_SIGNATURE`] to sub `group.sub()`).
pub use crate::od::standard::RESTORE_DEFAULT_PARAMETERS;
/// 1010h store parameters (write [`SAVE_SIGNATURE`] to sub `group.sub()`).
pub use crate::od::standard::STORE_PARAMETERS;

/// Whether `index` is a command object of the storage, 1010h or 1011h (their subs 1..=4 read
/// the supported groups and take the signatures; nothing is stored in the dictionary).
pub const fn owns(index: u16) -> bool {
    matches!(index, STORE_PARAMETERS | RESTORE_DEFAULT_PARAMETERS)
}

/// The signature a command object takes: "save" for 1010h, "load" for 1011h.
pub const fn signature(index: u16) -> u32 {
    if index == STORE_PARAMETERS {
        SAVE_SIGNATURE
    } else {
        LOAD_SIGNATURE
    }
}
/// "save" (73 61 76 65 on the wire), the only value 1010h accepts (§11).
pub const SAVE_SIGNATURE: u32 = 0x6576_6173;
/// "load" (6C 6F 61 64 on the wire), the only value 1011h accepts (§11).
pub const LOAD_SIGNATURE: u32 = 0x6461_6F6C;

/// Largest write size of an area that [`Storage`] supports.
pub const MAX_WRITE_SIZE: usize = CHUNK;

/// Bytes programmed per write call (a multiple of every supported write size).
const CHUNK: usize = 256;
/// Bytes read per read call.
const READ_CHUNK: usize = 64;

/// A parameter group: the sub-index of 1010h/1011h it answers to is its discriminant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Group {
    /// Sub 1: all parameters.
    All = 1,
    /// Sub 2: communication parameters, 1000h–1FFFh.
    Communication = 2,
    /// Sub 3: application parameters (the device profile area), 6000h–9FFFh.
    Application = 3,
    /// Sub 4: manufacturer parameters, 2000h–5FFFh.
    Manufacturer = 4,
}

impl Group {
    /// Every group, in sub-index order.
    pub const ALL: [Group; 4] = [Group::All, Group::Communication, Group::Application, Group::Manufacturer];

    /// The group that sub-index `sub` of 1010h/1011h stands for.
    pub const fn from_sub(sub: u8) -> Option<Group> {
        match sub {
            1 => Some(Group::All),
            2 => Some(Group::Communication),
            3 => Some(Group::Application),
            4 => Some(Group::Manufacturer),
            _ => None,
        }
    }

    /// The sub-index of 1010h/1011h of the group.
    pub const fn sub(self) -> u8 {
        self as u8
    }

    /// The object indices of the group.
    pub const fn range(self) -> RangeInclusive<u16> {
        match self {
            Group::All => 0x0000..=0xFFFF,
            Group::Communication => 0x1000..=0x1FFF,
            Group::Application => 0x6000..=0x9FFF,
            Group::Manufacturer => 0x2000..=0x5FFF,
        }
    }

    /// True when object `index` belongs to the group.
    pub const fn contains(self, index: u16) -> bool {
        match self {
            Group::All => true,
            Group::Communication => 0x1000 <= index && index <= 0x1FFF,
            Group::Application => 0x6000 <= index && index <= 0x9FFF,
            Group::Manufacturer => 0x2000 <= index && index <= 0x5FFF,
        }
    }
}

/// Why a storage operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum StorageError {
    /// The non-volatile area failed an operation.
    Area(NvError),
    /// The area cannot hold the journal: fewer than two erase sectors (or banks smaller than a
    /// header), a write size that does not divide [`MAX_WRITE_SIZE`], or an erase size that is
    /// not a multiple of the write size.
    Geometry,
    /// The image does not fit in a bank. Nothing was written.
    NoSpace,
    /// What was read back is not what was written, or the same bytes read twice differ: the
    /// medium is failing. A store that ends so did not replace the previous image.
    Verify,
}

impl From<NvError> for StorageError {
    fn from(error: NvError) -> Self {
        StorageError::Area(error)
    }
}

/// The SDO abort code for a failed 1010h/1011h write (CiA 301 §7.5.2, 1010h/1011h): a failed medium is
/// 0x0606_0000, an image that cannot be stored at all 0x0800_0020.
impl From<StorageError> for AbortCode {
    fn from(error: StorageError) -> Self {
        match error {
            StorageError::Area(_) | StorageError::Verify => AbortCode::HardwareError,
            StorageError::Geometry | StorageError::NoSpace => AbortCode::CannotStore,
        }
    }
}

/// What the area holds, as seen by a load.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ImageState {
    /// A valid image of this device (the newer one if both banks are valid).
    Found {
        /// Its sequence number.
        sequence: u32,
    },
    /// Nothing was ever stored (both bank headers are erased): defaults apply.
    Empty,
    /// No valid image, and at least one bank holds damaged data (a failing medium, or the very
    /// first store was cut by a power loss): defaults apply.
    Corrupt,
    /// No valid image, and at least one bank holds an intact image of another format version or
    /// device signature: defaults apply.
    Foreign,
}

impl ImageState {
    /// True when stored parameters exist but cannot be used ([`Corrupt`](Self::Corrupt) or
    /// [`Foreign`](Self::Foreign)): worth an EMCY at boot.
    pub const fn is_lost(self) -> bool {
        matches!(self, ImageState::Corrupt | ImageState::Foreign)
    }
}

/// The outcome of [`Storage::load`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoadReport {
    /// What the area holds.
    pub image: ImageState,
    /// Records of the group written into the dictionary.
    pub applied: u32,
    /// Records of the group refused (see [`crate::od::persist`]): entries the firmware no
    /// longer has, or whose type, size or limits changed.
    pub skipped: u32,
}

/// A device signature for [`Storage::new`]: the CRC-32 of the vendor-ID, the product code and
/// `layout`, a number the firmware changes whenever stored parameters would change meaning.
/// Images stored by another product, or under another `layout`, are then
/// [`ImageState::Foreign`].
pub fn device_signature(device: &DeviceInfo, layout: u16) -> u32 {
    let mut crc = Crc32::new();
    crc.update(&device.vendor_id.to_le_bytes());
    crc.update(&device.product_code.to_le_bytes());
    crc.update(&layout.to_le_bytes());
    crc.value()
}

/// The log line of a store or a restore of defaults (not built without a logging feature).
#[cfg(any(feature = "defmt", feature = "log"))]
fn log_write(_what: &str, _group: Group, _result: Result<(), StorageError>) {
    match _result {
        Ok(()) => crate::fmt::info!("storage: {} of {:?} done", _what, _group),
        Err(_error) => crate::fmt::warning!("storage: {} of {:?} failed: {:?}", _what, _group, _error),
    }
}

/// What a bank holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Bank {
    Blank,
    Corrupt,
    Foreign,
    Valid(Header),
}

/// Both banks.
#[derive(Clone, Copy, Debug)]
struct Scan([Bank; 2]);

impl Scan {
    /// The bank holding the newest valid image, and its header.
    fn newest(&self) -> Option<(usize, Header)> {
        match self.0 {
            [Bank::Valid(a), Bank::Valid(b)] => {
                Some(if is_newer(b.sequence, a.sequence) { (1, b) } else { (0, a) })
            }
            [Bank::Valid(a), _] => Some((0, a)),
            [_, Bank::Valid(b)] => Some((1, b)),
            _ => None,
        }
    }

    fn state(&self) -> ImageState {
        if let Some((_, header)) = self.newest() {
            ImageState::Found { sequence: header.sequence }
        } else if self.0.contains(&Bank::Foreign) {
            ImageState::Foreign
        } else if self.0.contains(&Bank::Corrupt) {
            ImageState::Corrupt
        } else {
            ImageState::Empty
        }
    }
}

/// Programs a payload in whole write units, in order, and keeps its length and CRC.
struct Programmer {
    at: u32,
    limit: u32,
    unit: usize,
    buf: [u8; CHUNK],
    fill: usize,
    len: usize,
    crc: Crc32,
}

impl Programmer {
    fn new(at: u32, limit: u32, unit: usize) -> Self {
        Programmer { at, limit, unit, buf: [0xFF; CHUNK], fill: 0, len: 0, crc: Crc32::new() }
    }

    fn push<A: NonVolatile>(&mut self, area: &mut A, mut bytes: &[u8]) -> Result<(), StorageError> {
        self.crc.update(bytes);
        self.len += bytes.len();
        while !bytes.is_empty() {
            let n = (CHUNK - self.fill).min(bytes.len());
            let (head, rest) = bytes.split_at(n);
            if let Some(dst) = self.buf.get_mut(self.fill..self.fill + n) {
                dst.copy_from_slice(head);
            }
            self.fill += n;
            bytes = rest;
            if self.fill == CHUNK {
                self.flush(area, CHUNK)?;
            }
        }
        Ok(())
    }

    fn flush<A: NonVolatile>(&mut self, area: &mut A, n: usize) -> Result<(), StorageError> {
        let n32 = u32::try_from(n).map_err(|_| StorageError::NoSpace)?;
        // Never program outside the erased sectors: the data grew since they were counted.
        if self.at.checked_add(n32).is_none_or(|end| end > self.limit) {
            return Err(StorageError::Verify);
        }
        area.write(self.at, self.buf.get(..n).unwrap_or(&[]))?;
        self.at += n32;
        self.fill = 0;
        self.buf.fill(0xFF);
        Ok(())
    }

    /// Programs what is left, padded with 0xFF to whole units; gives the length and the CRC.
    fn finish<A: NonVolatile>(mut self, area: &mut A) -> Result<(usize, u32), StorageError> {
        if self.fill > 0 {
            let n = self.fill.div_ceil(self.unit) * self.unit;
            self.flush(area, n)?;
        }
        Ok((self.len, self.crc.value()))
    }
}

/// The parameter journal over a [`NonVolatile`] area (see the [module docs](self)).
///
/// ```
/// # use canopen_drive::storage::{NonVolatile, NvError};
/// # struct Ram([u8; 1024]);
/// # impl NonVolatile for Ram {
/// #     fn capacity(&self) -> usize { 1024 }
/// #     fn erase_size(&self) -> usize { 256 }
/// #     fn write_size(&self) -> usize { 4 }
/// #     fn read(&mut self, at: u32, buf: &mut [u8]) -> Result<(), NvError> {
/// #         let at = at as usize;
/// #         buf.copy_from_slice(self.0.get(at..at + buf.len()).ok_or(NvError::OutOfBounds)?);
/// #         Ok(())
/// #     }
/// #     fn write(&mut self, at: u32, data: &[u8]) -> Result<(), NvError> {
/// #         let at = at as usize;
/// #         let dst = self.0.get_mut(at..at + data.len()).ok_or(NvError::OutOfBounds)?;
/// #         dst.iter_mut().zip(data).for_each(|(d, s)| *d &= s);
/// #         Ok(())
/// #     }
/// #     fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
/// #         self.0.get_mut(from as usize..to as usize).ok_or(NvError::OutOfBounds)?.fill(0xFF);
/// #         Ok(())
/// #     }
/// # }
/// use canopen_drive::od::{standard::COMMUNICATION, DeviceInfo, Dictionary};
/// use canopen_drive::storage::{device_signature, Group, ImageState, Storage};
///
/// let device = DeviceInfo::servo_drive();
/// let mut od = Dictionary::<512>::new(&[&COMMUNICATION], device, 5).unwrap();
/// let mut storage = Storage::new(Ram([0xFF; 1024]), device_signature(&device, 1)).unwrap();
///
/// // 1010h sub 1 = "save": store everything.
/// od.set::<u16>(0x1017, 0, 100).unwrap();
/// storage.store(&od, Group::All).unwrap();
///
/// // After a reset: defaults, then what was stored.
/// let mut od = Dictionary::<512>::new(&[&COMMUNICATION], device, 5).unwrap();
/// let report = storage.load(&mut od, Group::All).unwrap();
/// assert_eq!(report.image, ImageState::Found { sequence: 1 });
/// assert_eq!(od.get::<u16>(0x1017, 0), Ok(100));
/// ```
#[derive(Debug)]
pub struct Storage<A> {
    area: A,
    signature: u32,
    bank_size: u32,
    header_len: u32,
    erase_size: u32,
    write_size: usize,
}

impl<A: NonVolatile> Storage<A> {
    /// The journal over `area`, for images carrying `signature` (see [`device_signature`]).
    /// Reads and writes nothing; refuses an area whose geometry does not fit
    /// ([`StorageError::Geometry`]).
    pub fn new(area: A, signature: u32) -> Result<Self, StorageError> {
        let write = area.write_size();
        let erase = area.erase_size();
        if write == 0 || !CHUNK.is_multiple_of(write) || erase == 0 || !erase.is_multiple_of(write) {
            return Err(StorageError::Geometry);
        }
        let header_len = HEADER_LEN.max(write);
        let bank_size = area.capacity() / erase / 2 * erase;
        if bank_size < header_len {
            return Err(StorageError::Geometry);
        }
        let total = bank_size.checked_mul(2).ok_or(StorageError::Geometry)?;
        u32::try_from(total).map_err(|_| StorageError::Geometry)?;
        Ok(Storage {
            area,
            signature,
            bank_size: bank_size as u32,
            header_len: header_len as u32,
            erase_size: erase as u32,
            write_size: write,
        })
    }

    /// The area.
    pub fn area(&self) -> &A {
        &self.area
    }

    /// The area, e.g. to inspect or to simulate a power cut. Writing to it behind the journal's
    /// back is at the caller's risk.
    pub fn area_mut(&mut self) -> &mut A {
        &mut self.area
    }

    /// Gives the area back.
    pub fn into_area(self) -> A {
        self.area
    }

    /// The device signature images are stored with.
    pub fn signature(&self) -> u32 {
        self.signature
    }

    /// Largest payload an image can have, in bytes (a bank minus the header).
    pub fn max_payload(&self) -> usize {
        (self.bank_size - self.header_len) as usize
    }

    /// Bytes of the payload [`store`](Self::store) of `group` would write now.
    pub fn payload_len<const BYTES: usize>(
        &mut self,
        od: &Dictionary<BYTES>,
        group: Group,
    ) -> Result<usize, StorageError> {
        let scan = self.scan()?;
        let fresh = od.records_len(group.range());
        let kept = match (group, scan.newest()) {
            (Group::All, _) | (_, None) => 0,
            (_, Some((bank, old))) => self.kept_len(bank, &old, Selection::Group(group))?,
        };
        Ok(fresh + kept)
    }

    /// What the area holds now (reads both banks, applies nothing).
    pub fn status(&mut self) -> Result<ImageState, StorageError> {
        Ok(self.scan()?.state())
    }

    /// Applies the stored parameters of `group` to `od`: validates both banks, takes the newest
    /// valid image and applies its records of the group (see [`crate::od::persist`] for which
    /// records are applied and which are skipped).
    ///
    /// Call it on a dictionary whose group is at its defaults: at boot for [`Group::All`],
    /// after NMT reset communication for [`Group::Communication`]. Without a valid image the
    /// dictionary is left as it is and the report says why ([`ImageState`]).
    ///
    /// On an error (the area failed while reading, or the image read differently from when
    /// it was validated) every object of the group is set back to its default before
    /// returning, so that the dictionary never holds part of an image.
    pub fn load<const BYTES: usize>(
        &mut self,
        od: &mut Dictionary<BYTES>,
        group: Group,
    ) -> Result<LoadReport, StorageError> {
        let scan = self.scan()?;
        let image = scan.state();
        let Some((bank, header)) = scan.newest() else {
            #[cfg(any(feature = "defmt", feature = "log"))]
            if image.is_lost() {
                crate::fmt::warning!("storage: no usable image ({:?}): defaults kept", image);
            } else {
                crate::fmt::info!("storage: nothing stored: defaults kept");
            }
            return Ok(LoadReport { image, applied: 0, skipped: 0 });
        };
        let mut loader = RecordLoader::new(group.range(), header.len as usize);
        let mut crc = Crc32::new();
        let read = self.read_payload(bank, header.len, |piece| {
            crc.update(piece);
            loader.feed(od, piece);
            Ok(())
        });
        let stats = loader.finish(od);
        let failure = match read {
            Err(error) => Some(error),
            Ok(()) if crc.value() != header.crc => Some(StorageError::Verify),
            Ok(()) => None,
        };
        if let Some(error) = failure {
            crate::fmt::error!("storage: load of {:?} failed ({:?}): defaults restored", group, error);
            od.reset(group.range());
            return Err(error);
        }
        crate::fmt::info!(
            "storage: {:?} loaded from image {:?}: {} records applied, {} skipped",
            group,
            image,
            stats.applied,
            stats.skipped
        );
        Ok(LoadReport { image, applied: stats.applied, skipped: stats.skipped })
    }

    /// Stores the current values of `group` (1010h sub `group.sub()`): writes a new image with
    /// the group's parameters from `od` and the other groups' records from the previous image.
    /// Returns once the new image is written and read back; on any error the previous image
    /// is still the one a load takes.
    ///
    /// The call blocks for the erase and programming time of the area (on an MCU with large
    /// flash sectors, hundreds of milliseconds): §11 wants the SDO answer sent after it, so
    /// size the banks' sectors with the master's SDO timeout in mind.
    pub fn store<const BYTES: usize>(
        &mut self,
        od: &Dictionary<BYTES>,
        group: Group,
    ) -> Result<(), StorageError> {
        let result = self.write_image(Some(od), Selection::Group(group));
        #[cfg(any(feature = "defmt", feature = "log"))]
        log_write("store", group, result);
        result
    }

    /// Stores the current values of single parameters (`entries`: index, sub-index) and keeps
    /// every other record of the previous image: a firmware's own saving of a few values (a
    /// drive that saves its homing results after each run). Entries that are not parameters
    /// are left out. Safe against power loss as [`store`](Self::store).
    pub fn store_entries<const BYTES: usize>(
        &mut self,
        od: &Dictionary<BYTES>,
        entries: &[(u16, u8)],
    ) -> Result<(), StorageError> {
        let result = self.write_image(Some(od), Selection::Entries(entries));
        #[cfg(any(feature = "defmt", feature = "log"))]
        match result {
            Ok(()) => crate::fmt::info!("storage: {} single entries stored", entries.len()),
            Err(_error) => crate::fmt::warning!("storage: store of single entries failed: {:?}", _error),
        }
        result
    }

    /// Restores the defaults of `group` (1011h sub `group.sub()`): writes a new image without
    /// the group's records, so that the group comes up with its defaults after the next reset.
    /// The dictionary's current values are not touched. On any error the previous image is
    /// still the one a load takes.
    pub fn restore_defaults(&mut self, group: Group) -> Result<(), StorageError> {
        let result = self.write_image::<0>(None, Selection::Group(group));
        #[cfg(any(feature = "defmt", feature = "log"))]
        log_write("restore defaults", group, result);
        result
    }

    fn bank_start(&self, bank: usize) -> u32 {
        if bank == 0 {
            0
        } else {
            self.bank_size
        }
    }

    /// Examines both banks. A bank that cannot be read counts as corrupt (an interrupted
    /// program can leave a word that fails its ECC check on some MCUs), unless neither can:
    /// then the area itself is failing.
    fn scan(&mut self) -> Result<Scan, StorageError> {
        match (self.examine(0), self.examine(1)) {
            (Ok(a), Ok(b)) => Ok(Scan([a, b])),
            (Ok(a), Err(_)) => Ok(Scan([a, Bank::Corrupt])),
            (Err(_), Ok(b)) => Ok(Scan([Bank::Corrupt, b])),
            (Err(error), Err(_)) => Err(error),
        }
    }

    /// Validates one bank.
    fn examine(&mut self, bank: usize) -> Result<Bank, StorageError> {
        let mut raw = [0u8; HEADER_LEN];
        self.area.read(self.bank_start(bank), &mut raw)?;
        let header = match Header::decode(&raw) {
            Decoded::Blank => return Ok(Bank::Blank),
            Decoded::Garbled => return Ok(Bank::Corrupt),
            Decoded::Header(header) => header,
        };
        if header.version != FORMAT_VERSION || header.signature != self.signature {
            return Ok(Bank::Foreign);
        }
        if header.len as usize > self.max_payload() {
            return Ok(Bank::Corrupt);
        }
        let mut crc = Crc32::new();
        self.read_payload(bank, header.len, |piece| {
            crc.update(piece);
            Ok(())
        })?;
        Ok(if crc.value() == header.crc { Bank::Valid(header) } else { Bank::Corrupt })
    }

    /// Reads the first `len` payload bytes of `bank` in pieces, handing each to `f`.
    fn read_payload(
        &mut self,
        bank: usize,
        len: u32,
        mut f: impl FnMut(&[u8]) -> Result<(), StorageError>,
    ) -> Result<(), StorageError> {
        let mut at = self.bank_start(bank) + self.header_len;
        let mut left = len as usize;
        let mut buf = [0u8; READ_CHUNK];
        while left > 0 {
            let n = left.min(READ_CHUNK);
            let piece = buf.get_mut(..n).unwrap_or(&mut []);
            self.area.read(at, piece)?;
            f(piece)?;
            at += n as u32;
            left -= n;
        }
        Ok(())
    }

    /// Streams the records of the image in `bank` that do not belong to `selection`, as they
    /// are stored, to `sink`; checks on the way that the payload still has its CRC.
    fn copy_kept(
        &mut self,
        bank: usize,
        old: &Header,
        selection: Selection<'_>,
        mut sink: impl FnMut(&mut A, &[u8]) -> Result<(), StorageError>,
    ) -> Result<(), StorageError> {
        let mut parser = RecordParser::new(old.len as usize);
        let mut crc = Crc32::new();
        let mut keep = false;
        let mut at = self.bank_start(bank) + self.header_len;
        let mut left = old.len as usize;
        let mut buf = [0u8; READ_CHUNK];
        while left > 0 {
            let n = left.min(READ_CHUNK);
            let piece = buf.get_mut(..n).unwrap_or(&mut []);
            self.area.read(at, piece)?;
            crc.update(piece);
            let mut input: &[u8] = piece;
            while let Some(event) = parser.next(&mut input) {
                match event {
                    RecordEvent::Start(header) => {
                        keep = !selection.contains(header.index, header.sub);
                        if keep {
                            sink(&mut self.area, &header.encode())?;
                        }
                    }
                    RecordEvent::Data(data) if keep => sink(&mut self.area, data)?,
                    RecordEvent::Data(_) => {}
                    RecordEvent::End | RecordEvent::Malformed => keep = false,
                }
            }
            at += n as u32;
            left -= n;
        }
        if crc.value() != old.crc {
            return Err(StorageError::Verify);
        }
        Ok(())
    }

    fn kept_len(
        &mut self,
        bank: usize,
        old: &Header,
        selection: Selection<'_>,
    ) -> Result<usize, StorageError> {
        let mut len = 0usize;
        self.copy_kept(bank, old, selection, |_, bytes| {
            len += bytes.len();
            Ok(())
        })?;
        Ok(len)
    }

    /// Writes a new image: the records of `selection` from `fresh` (none without a dictionary)
    /// and the other records of the newest valid image.
    fn write_image<const BYTES: usize>(
        &mut self,
        fresh: Option<&Dictionary<BYTES>>,
        selection: Selection<'_>,
    ) -> Result<(), StorageError> {
        let scan = self.scan()?;
        let old = match selection {
            // Nothing outside the selection to keep.
            Selection::Group(Group::All) => None,
            _ => scan.newest(),
        };
        let (target, sequence) = match scan.newest() {
            Some((bank, header)) => (1 - bank, header.sequence.wrapping_add(1)),
            None => (0, 1),
        };

        // How much to erase.
        let keep = |index, sub| selection.contains(index, sub);
        let fresh_len = fresh.map_or(0, |od| od.records_len_where(selection.range(), keep));
        let kept_len = match &old {
            Some((bank, header)) => self.kept_len(*bank, header, selection)?,
            None => 0,
        };
        let len = fresh_len + kept_len;
        if len > self.max_payload() {
            return Err(StorageError::NoSpace);
        }
        let start = self.bank_start(target);
        let used =
            (self.header_len as usize + len).div_ceil(self.erase_size as usize) * self.erase_size as usize;
        let end = start + used as u32;
        self.area.erase(start, end)?;

        // The payload.
        let mut program = Programmer::new(start + self.header_len, end, self.write_size);
        if let Some(od) = fresh {
            let area = &mut self.area;
            od.emit_records_where(selection.range(), keep, |bytes| program.push(area, bytes))?;
        }
        if let Some((bank, header)) = &old {
            self.copy_kept(*bank, header, selection, |area, bytes| program.push(area, bytes))?;
        }
        let (len, crc) = program.finish(&mut self.area)?;

        // The header, last: the commit point.
        let header = Header {
            version: FORMAT_VERSION,
            signature: self.signature,
            sequence,
            len: u32::try_from(len).map_err(|_| StorageError::NoSpace)?,
            crc,
        };
        let mut raw = [0xFF; CHUNK];
        if let Some(dst) = raw.get_mut(..HEADER_LEN) {
            dst.copy_from_slice(&header.encode());
        }
        self.area.write(start, raw.get(..self.header_len as usize).unwrap_or(&[]))?;

        match self.examine(target)? {
            Bank::Valid(written) if written == header => Ok(()),
            _ => Err(StorageError::Verify),
        }
    }
}

#[cfg(test)]
mod tests;

/// What a store takes from the dictionary: a group (1010h), or single entries (a firmware's own
/// saving of a few parameters, e.g. after a homing run). The records of everything else are
/// copied from the previous image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Selection<'a> {
    /// Every parameter of the group ([`Group::All`]: nothing is copied).
    Group(Group),
    /// These entries (index, sub-index); parameters only, others are ignored.
    Entries(&'a [(u16, u8)]),
}

impl Selection<'_> {
    /// Whether the entry belongs to the selection.
    pub fn contains(&self, index: u16, sub: u8) -> bool {
        match self {
            Selection::Group(group) => group.contains(index),
            Selection::Entries(entries) => entries.contains(&(index, sub)),
        }
    }

    /// The indices the selection lies in.
    fn range(&self) -> RangeInclusive<u16> {
        match self {
            Selection::Group(group) => group.range(),
            Selection::Entries(_) => 0x0000..=0xFFFF,
        }
    }
}

/// What the drive needs from parameter storage: implemented by [`Storage`] over any
/// [`NonVolatile`] area, and by `()` for a drive without storage (1010h/1011h then read 0 and
/// refuse their commands with 0x0800_0020).
pub trait Persistence {
    /// True when store and restore on command are supported.
    fn available(&self) -> bool;
    /// Applies the stored values of `group` on top of the dictionary.
    fn load<const B: usize>(
        &mut self,
        od: &mut Dictionary<B>,
        group: Group,
    ) -> Result<LoadReport, StorageError>;
    /// Stores the current values of `group`.
    fn store<const B: usize>(&mut self, od: &Dictionary<B>, group: Group) -> Result<(), StorageError>;
    /// Stores the current values of single parameters, keeping the rest of the stored set
    /// ([`Storage::store_entries`]).
    fn store_entries<const B: usize>(
        &mut self,
        od: &Dictionary<B>,
        entries: &[(u16, u8)],
    ) -> Result<(), StorageError>;
    /// Removes `group` from the stored set (its defaults apply after the next reset).
    fn restore_defaults(&mut self, group: Group) -> Result<(), StorageError>;
}

/// No storage.
impl Persistence for () {
    fn available(&self) -> bool {
        false
    }
    fn load<const B: usize>(
        &mut self,
        _od: &mut Dictionary<B>,
        _group: Group,
    ) -> Result<LoadReport, StorageError> {
        Ok(LoadReport { image: ImageState::Empty, applied: 0, skipped: 0 })
    }
    fn store<const B: usize>(&mut self, _od: &Dictionary<B>, _group: Group) -> Result<(), StorageError> {
        Err(StorageError::NoSpace)
    }
    fn store_entries<const B: usize>(
        &mut self,
        _od: &Dictionary<B>,
        _entries: &[(u16, u8)],
    ) -> Result<(), StorageError> {
        Err(StorageError::NoSpace)
    }
    fn restore_defaults(&mut self, _group: Group) -> Result<(), StorageError> {
        Err(StorageError::NoSpace)
    }
}

impl<A: NonVolatile> Persistence for Storage<A> {
    fn available(&self) -> bool {
        true
    }
    fn load<const B: usize>(
        &mut self,
        od: &mut Dictionary<B>,
        group: Group,
    ) -> Result<LoadReport, StorageError> {
        Storage::load(self, od, group)
    }
    fn store<const B: usize>(&mut self, od: &Dictionary<B>, group: Group) -> Result<(), StorageError> {
        Storage::store(self, od, group)
    }
    fn store_entries<const B: usize>(
        &mut self,
        od: &Dictionary<B>,
        entries: &[(u16, u8)],
    ) -> Result<(), StorageError> {
        Storage::store_entries(self, od, entries)
    }
    fn restore_defaults(&mut self, group: Group) -> Result<(), StorageError> {
        Storage::restore_defaults(self, group)
    }
}

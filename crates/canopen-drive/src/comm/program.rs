//! Program download (CiA 302-3): the objects a master uses to replace a device's program over
//! the bus, for program 1.
//!
//! | object | sub 1 | read | write |
//! |---|---|---|---|
//! | 1F50h program data | DOMAIN | never (write only) | the program image, by segmented or block transfer |
//! | 1F51h program control | UNSIGNED8 | 0 stopped, 1 started, 3 no program | 0 stop, 1 start, 2 reset, 3 clear |
//! | 1F56h program software identification | UNSIGNED32 | the CRC-32 of the program (0: none) | — |
//! | 1F57h flash status identification | UNSIGNED32 | bit 0 busy, bits 1–7 a [`FlashCode`] | — |
//!
//! Two types serve the two sides of an update:
//! - in a **bootloader**, [`ProgramDownload`] owns the program area, a [`NonVolatile`] area:
//!   clear erases it, a download streams the image into it, start asks the board to run the
//!   program once the image has been verified;
//! - in the **application**, [`RunningProgram`]: 1F51h reads 1 (started), stop and reset ask
//!   the board to reset (into the bootloader, or the program again), and clear or a download
//!   are refused (0800 0022h: not in this state), as the area is the bootloader's.
//!
//! What the device does is reported, never acted on in a call: a command the board must carry
//! out (leave for the bootloader, start the program) is a [`ProgramRequest`], taken by the
//! node once its answer is on the bus ([`ProgramDownload::take_request`],
//! [`RunningProgram::take_request`]). Work longer than a
//! frame (erasing, verifying) is done in bounded steps by [`ProgramDownload::poll`], with
//! 1F57h's busy bit set meanwhile.
//!
//! The image ([`ImageHeader`]): a 16-byte header (magic "CDPI", format version 1, payload
//! length, CRC-32 of the payload), then the payload, which lands in the area at
//! [`ProgramDownload::payload_offset`]. The header is written last, after the payload has been
//! read back and its CRC checked, so that a power cut at any point of a download leaves an area
//! without a valid header: the bootloader then reports "no valid program" (code 1) and 1F56h =
//! 0 until the next download.

use crate::od::{layout, AbortCode, Access, DataType, Object, Var};
use crate::storage::{Crc32, NonVolatile};

/// 1F50h program data (DOMAIN, write only).
pub const PROGRAM_DATA: u16 = 0x1F50;
/// 1F51h program control.
pub const PROGRAM_CONTROL: u16 = 0x1F51;
/// 1F56h program software identification.
pub const PROGRAM_SOFTWARE_IDENTIFICATION: u16 = 0x1F56;
/// 1F57h flash status identification.
pub const FLASH_STATUS_IDENTIFICATION: u16 = 0x1F57;

/// True for the objects this service owns.
pub const fn owns(index: u16) -> bool {
    matches!(
        index,
        PROGRAM_DATA | PROGRAM_CONTROL | PROGRAM_SOFTWARE_IDENTIFICATION | FLASH_STATUS_IDENTIFICATION
    )
}

/// Bytes of the value of sub 1 of `index` (one of the four objects): 1 for 1F51h, 4 for the
/// UNSIGNED32 entries.
pub const fn value_len(index: u16) -> usize {
    if index == PROGRAM_CONTROL {
        1
    } else {
        4
    }
}

/// The four objects, for program 1 (their values are the service's, not the store's).
pub static OBJECTS: [Object; 4] = layout([
    Object::array(
        PROGRAM_DATA,
        "Program data",
        1,
        &Var::new("Program number 1", DataType::Domain).access(Access::WriteOnly).capacity(0),
    ),
    Object::array(
        PROGRAM_CONTROL,
        "Program control",
        1,
        &Var::new("Program number 1", DataType::Unsigned8).access(Access::ReadWrite),
    ),
    Object::array(
        PROGRAM_SOFTWARE_IDENTIFICATION,
        "Program software identification",
        1,
        &Var::new("Program number 1", DataType::Unsigned32).access(Access::ReadOnly),
    ),
    Object::array(
        FLASH_STATUS_IDENTIFICATION,
        "Flash status identification",
        1,
        &Var::new("Program number 1", DataType::Unsigned32).access(Access::ReadOnly),
    ),
]);

/// The state of the program, as 1F51h:1 reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum ProgramState {
    /// A valid program is present and not running (the bootloader runs).
    Stopped = 0,
    /// The program runs (this is the application).
    Started = 1,
    /// No valid program is present.
    NoProgram = 3,
}

/// The code in bits 1–7 of 1F57h:1 (CiA 302-3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum FlashCode {
    /// No error.
    Ok = 0,
    /// No valid program.
    NoValidProgram = 1,
    /// The data format is unknown (not an image of [`ImageHeader`]'s format).
    DataFormatUnknown = 2,
    /// A data format error (an inconsistent header, a wrong length) or a CRC error.
    FormatOrCrcError = 3,
    /// The flash was not cleared before the download.
    NotCleared = 4,
    /// Programming the flash failed.
    WriteError = 5,
    /// The image does not fit the program area.
    AddressError = 6,
    /// The flash is secured (write protected).
    Secured = 7,
    /// An unspecified error.
    Unspecified = 63,
}

/// What the board is asked to do once the answer that asked for it is on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ProgramRequest {
    /// Stop the program: the application resets into its bootloader.
    Stop,
    /// Start the verified program (the bootloader hands over to it).
    Start,
    /// Reset the program: the application restarts.
    Reset,
}

/// Bytes of an image's header.
pub const HEADER_LEN: usize = 16;
/// The first four bytes of an image.
pub const IMAGE_MAGIC: [u8; 4] = *b"CDPI";
/// The image format this code reads.
pub const IMAGE_VERSION: u16 = 1;
/// Largest write unit of a program area this service handles.
pub const MAX_WRITE_SIZE: usize = 32;
/// Bytes read back and checked per [`ProgramDownload::poll`] while verifying.
pub const VERIFY_CHUNK: usize = 256;

/// The header that starts a program image (little-endian): magic "CDPI", format version
/// (u16), reserved (u16, 0), payload length (u32), CRC-32 of the payload (u32, the
/// ISO-HDLC / zlib CRC, which 1F56h:1 reads).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageHeader {
    /// Bytes of payload after the header.
    pub len: u32,
    /// CRC-32 of the payload.
    pub crc: u32,
}

impl ImageHeader {
    /// The header's bytes.
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let [m0, m1, m2, m3] = IMAGE_MAGIC;
        let [v0, v1] = IMAGE_VERSION.to_le_bytes();
        let [l0, l1, l2, l3] = self.len.to_le_bytes();
        let [c0, c1, c2, c3] = self.crc.to_le_bytes();
        [m0, m1, m2, m3, v0, v1, 0, 0, l0, l1, l2, l3, c0, c1, c2, c3]
    }

    /// Reads a header: `Err` with the code a master sees for bytes that are not one.
    pub fn decode(raw: &[u8; HEADER_LEN]) -> Result<Self, FlashCode> {
        let [m0, m1, m2, m3, v0, v1, r0, r1, l0, l1, l2, l3, c0, c1, c2, c3] = *raw;
        if [m0, m1, m2, m3] != IMAGE_MAGIC {
            return Err(FlashCode::DataFormatUnknown);
        }
        if u16::from_le_bytes([v0, v1]) != IMAGE_VERSION || [r0, r1] != [0, 0] {
            return Err(FlashCode::FormatOrCrcError);
        }
        Ok(ImageHeader {
            len: u32::from_le_bytes([l0, l1, l2, l3]),
            crc: u32::from_le_bytes([c0, c1, c2, c3]),
        })
    }
}

/// What the service is busy with (1F57h bit 0 is set in every state but `Idle`).
#[derive(Clone, Copy, Debug)]
enum Work {
    Idle,
    /// Clear: erasing sector by sector, `next` the first sector not yet erased.
    Erasing {
        next: u32,
    },
    /// A download is streaming in ([`Receiving`]).
    Receiving(Receiving),
    /// Reading the payload back and computing its CRC, `offset` the next byte to check; then
    /// `write_header`: a download's header still to be written (else the image was found
    /// in the area).
    Verifying {
        header: ImageHeader,
        offset: u32,
        crc: Crc32,
        write_header: bool,
    },
}

/// A download in progress.
#[derive(Clone, Copy, Debug)]
struct Receiving {
    /// The header's bytes, gathered as they arrive.
    header: [u8; HEADER_LEN],
    /// Bytes of the image received (header included).
    received: u32,
    /// Payload bytes not yet programmed (less than a write unit).
    pending: [u8; MAX_WRITE_SIZE],
    pending_len: u8,
    /// CRC-32 of the payload received.
    crc: Crc32,
    /// The image is not one this service can take: the rest is received and dropped.
    refused: Option<FlashCode>,
}

/// The program-download service over the program area `F`.
pub struct ProgramDownload<F> {
    area: F,
    state: ProgramState,
    code: FlashCode,
    work: Work,
    /// The area is erased since the last clear: a download may begin.
    cleared: bool,
    /// 1F56h:1.
    identification: u32,
    /// Where the payload starts in the area.
    payload_offset: u32,
    request: Option<ProgramRequest>,
}

/// Program download in the running application (1F51h reads 1, started): stop and reset are
/// requests for the board, clear and a download are refused, as they are the bootloader's.
#[derive(Clone, Copy, Debug)]
pub struct RunningProgram {
    /// 1F56h:1.
    identification: u32,
    /// 1F57h:1's code: 0, or 4 after a download that was refused.
    code: FlashCode,
    request: Option<ProgramRequest>,
}

impl RunningProgram {
    /// The running program whose image's CRC-32 is `identification` (the board reads it from
    /// the header its bootloader left, [`read_header`]).
    pub const fn new(identification: u32) -> Self {
        RunningProgram { identification, code: FlashCode::Ok, request: None }
    }

    /// The value of sub 1 of one of the four objects as read; `None` for 1F50h, which is
    /// write only.
    pub fn read(&self, index: u16) -> Option<u32> {
        match index {
            PROGRAM_CONTROL => Some(u32::from(ProgramState::Started as u8)),
            PROGRAM_SOFTWARE_IDENTIFICATION => Some(self.identification),
            FLASH_STATUS_IDENTIFICATION => Some(u32::from(self.code as u8) << 1),
            _ => None,
        }
    }

    /// A command written to 1F51h:1.
    pub fn command(&mut self, value: u8) -> Result<(), AbortCode> {
        match value {
            0 => self.request = Some(ProgramRequest::Stop),
            // Start: the program already runs.
            1 => {}
            2 => self.request = Some(ProgramRequest::Reset),
            3 => return Err(AbortCode::CannotStoreDeviceState),
            _ => return Err(AbortCode::InvalidValue),
        }
        Ok(())
    }

    /// A download to 1F50h:1: refused (code 4, not cleared), the area is the bootloader's.
    pub fn begin(&mut self) -> Result<(), AbortCode> {
        self.code = FlashCode::NotCleared;
        Err(AbortCode::CannotStoreDeviceState)
    }

    /// True while a request waits to be taken.
    pub fn has_request(&self) -> bool {
        self.request.is_some()
    }

    /// The request the last command left for the board, taken once.
    pub fn take_request(&mut self) -> Option<ProgramRequest> {
        self.request.take()
    }
}

/// Reads the header at the start of `area`, without checking the payload (for an application
/// to learn its own identification, or a bootloader to decide at power-on).
pub fn read_header<F: NonVolatile>(area: &mut F) -> Result<ImageHeader, FlashCode> {
    let mut raw = [0u8; HEADER_LEN];
    area.read(0, &mut raw).map_err(|_| FlashCode::Unspecified)?;
    ImageHeader::decode(&raw).map_err(|code| match code {
        FlashCode::DataFormatUnknown => FlashCode::NoValidProgram,
        code => code,
    })
}

impl<F: NonVolatile> ProgramDownload<F> {
    /// The service in a bootloader that owns `area`, with the payload at `payload_offset`
    /// (a multiple of the area's write size, at least [`HEADER_LEN`]; e.g. the alignment the
    /// program's vector table needs). The image found in the area is verified by
    /// [`poll`](Self::poll) (busy meanwhile): valid, the program is stopped; else there is none.
    pub fn bootloader(mut area: F, payload_offset: u32) -> Self {
        // A header whose payload would not fit is no program (a cut while it was written).
        let room = area.capacity().saturating_sub(payload_offset as usize);
        let work = match read_header(&mut area) {
            Ok(header) if header.len as usize <= room => {
                Work::Verifying { header, offset: 0, crc: Crc32::new(), write_header: false }
            }
            _ => Work::Idle,
        };
        ProgramDownload {
            area,
            state: ProgramState::NoProgram,
            code: FlashCode::NoValidProgram,
            work,
            cleared: false,
            identification: 0,
            payload_offset,
            request: None,
        }
    }
}

impl<F: NonVolatile> ProgramDownload<F> {
    /// 1F51h:1 as read.
    pub fn state(&self) -> ProgramState {
        self.state
    }

    /// 1F57h:1 as read: the code in bits 1–7, busy in bit 0.
    pub fn flash_status(&self) -> u32 {
        (u32::from(self.code as u8) << 1) | u32::from(!matches!(self.work, Work::Idle))
    }

    /// 1F56h:1 as read.
    pub fn identification(&self) -> u32 {
        self.identification
    }

    /// Where the payload lies in the area.
    pub fn payload_offset(&self) -> u32 {
        self.payload_offset
    }

    /// The program area (the board reads the verified program from it).
    pub fn area(&mut self) -> &mut F {
        &mut self.area
    }

    /// Gives the program area back (the board hands it to the program it starts).
    pub fn into_area(self) -> F {
        self.area
    }

    /// True while erasing, receiving or verifying: [`poll`](Self::poll) has work.
    pub fn is_busy(&self) -> bool {
        !matches!(self.work, Work::Idle)
    }

    /// True while [`poll`](Self::poll) has a step to do right away (erasing, verifying).
    pub fn has_work(&self) -> bool {
        matches!(self.work, Work::Erasing { .. } | Work::Verifying { .. })
    }

    /// True while a request waits to be taken.
    pub fn has_request(&self) -> bool {
        self.request.is_some()
    }

    /// The request the last command left for the board, taken once.
    pub fn take_request(&mut self) -> Option<ProgramRequest> {
        self.request.take()
    }

    /// The value of sub 1 of one of the four objects as read; `None` for 1F50h, which is
    /// write only.
    pub fn read(&self, index: u16) -> Option<u32> {
        match index {
            PROGRAM_CONTROL => Some(u32::from(self.state as u8)),
            PROGRAM_SOFTWARE_IDENTIFICATION => Some(self.identification),
            FLASH_STATUS_IDENTIFICATION => Some(self.flash_status()),
            _ => None,
        }
    }

    /// A command written to 1F51h:1.
    pub fn command(&mut self, value: u8) -> Result<(), AbortCode> {
        let not_now = Err(AbortCode::CannotStoreDeviceState);
        if self.is_busy() {
            return not_now;
        }
        match (value, self.state) {
            // Stop: the program is stopped already.
            (0, _) => {}
            // Start (or reset): a verified program is handed over to.
            (1 | 2, ProgramState::Stopped) => self.request = Some(ProgramRequest::Start),
            (1 | 2, ProgramState::NoProgram | ProgramState::Started) => return not_now,
            (3, _) => {
                self.state = ProgramState::NoProgram;
                self.identification = 0;
                self.code = FlashCode::NoValidProgram;
                self.cleared = false;
                self.work = Work::Erasing { next: 0 };
            }
            _ => return Err(AbortCode::InvalidValue),
        }
        Ok(())
    }

    /// A download of `size` bytes (when indicated) to 1F50h:1 begins.
    pub fn begin(&mut self, size: Option<usize>) -> Result<(), AbortCode> {
        let capacity = self.area.capacity();
        if !self.cleared || self.is_busy() {
            if !self.is_busy() {
                self.code = FlashCode::NotCleared;
            }
            return Err(AbortCode::CannotStoreDeviceState);
        }
        let room = capacity.saturating_sub(self.payload_offset as usize) + HEADER_LEN;
        if size.is_some_and(|s| s > room) {
            self.code = FlashCode::AddressError;
            return Err(AbortCode::LengthTooHigh);
        }
        self.cleared = false;
        self.code = FlashCode::NoValidProgram;
        self.work = Work::Receiving(Receiving {
            header: [0; HEADER_LEN],
            received: 0,
            pending: [0xFF; MAX_WRITE_SIZE],
            pending_len: 0,
            crc: Crc32::new(),
            refused: None,
        });
        Ok(())
    }

    /// The next piece of the image, at `offset`; `last`: the download is complete.
    pub fn piece(&mut self, offset: usize, data: &[u8], last: bool) -> Result<(), AbortCode> {
        let Work::Receiving(mut rx) = self.work else {
            return Err(AbortCode::CannotStoreDeviceState);
        };
        if offset != rx.received as usize {
            return self.fail(FlashCode::Unspecified, AbortCode::General);
        }
        let area = &mut self.area;
        let write_size = area.write_size().clamp(1, MAX_WRITE_SIZE);
        let mut data = data;
        // The header, kept until the payload has been checked.
        while (rx.received as usize) < HEADER_LEN {
            let Some((&byte, rest)) = data.split_first() else { break };
            if let Some(slot) = rx.header.get_mut(rx.received as usize) {
                *slot = byte;
            }
            rx.received += 1;
            data = rest;
            if rx.received as usize == HEADER_LEN {
                let room = area.capacity().saturating_sub(self.payload_offset as usize);
                rx.refused = match ImageHeader::decode(&rx.header) {
                    Ok(header) if header.len as usize > room => Some(FlashCode::AddressError),
                    Ok(_) => None,
                    Err(code) => Some(code),
                };
            }
        }
        let payload_at = (rx.received as usize).saturating_sub(HEADER_LEN);
        rx.received = rx.received.saturating_add(data.len() as u32);
        if rx.refused.is_none() {
            rx.crc.update(data);
            let base = self.payload_offset as usize + payload_at - usize::from(rx.pending_len);
            if let Err(code) = program(area, write_size, base as u32, &mut rx, data, last) {
                return self.fail(code, AbortCode::HardwareError);
            }
        }
        self.work = Work::Receiving(rx);
        if last {
            self.received(rx);
        }
        Ok(())
    }

    /// The download ended without its last piece.
    pub fn broken(&mut self) {
        if matches!(self.work, Work::Receiving(_)) {
            self.work = Work::Idle;
            self.code = FlashCode::NoValidProgram;
        }
    }

    /// A complete download: checked against its header, then read back in [`poll`].
    fn received(&mut self, rx: Receiving) {
        let header = match ImageHeader::decode(&rx.header) {
            Ok(header) => header,
            Err(code) => return self.settle(code),
        };
        if let Some(code) = rx.refused {
            return self.settle(code);
        }
        let payload = rx.received as usize - HEADER_LEN.min(rx.received as usize);
        if rx.received < HEADER_LEN as u32 || header.len as usize != payload || header.crc != rx.crc.value() {
            return self.settle(FlashCode::FormatOrCrcError);
        }
        self.work = Work::Verifying { header, offset: 0, crc: Crc32::new(), write_header: true };
    }

    /// Ends the work with `code` and no valid program.
    fn settle(&mut self, code: FlashCode) {
        self.work = Work::Idle;
        self.code = code;
        self.state = ProgramState::NoProgram;
        self.identification = 0;
    }

    fn fail(&mut self, code: FlashCode, abort: AbortCode) -> Result<(), AbortCode> {
        self.settle(code);
        Err(abort)
    }

    /// One bounded step of the work in progress: one sector erased, or [`VERIFY_CHUNK`] bytes
    /// read back. Returns true while more steps are due.
    pub fn poll(&mut self) -> bool {
        let area = &mut self.area;
        match self.work {
            Work::Idle | Work::Receiving(_) => return false,
            Work::Erasing { next } => {
                let sector = area.erase_size().max(1) as u32;
                let end = (area.capacity() as u32) / sector * sector;
                if next < end && area.erase(next, next + sector).is_err() {
                    self.settle(FlashCode::WriteError);
                } else if next + sector >= end {
                    self.work = Work::Idle;
                    self.cleared = true;
                } else {
                    self.work = Work::Erasing { next: next + sector };
                }
            }
            Work::Verifying { header, offset, mut crc, write_header } => {
                let mut chunk = [0u8; VERIFY_CHUNK];
                let n = (header.len - offset.min(header.len)).min(VERIFY_CHUNK as u32);
                let Some(buf) = chunk.get_mut(..n as usize) else { return false };
                if area.read(self.payload_offset + offset, buf).is_err() {
                    self.settle(FlashCode::Unspecified);
                    return false;
                }
                crc.update(buf);
                let offset = offset + n;
                if offset < header.len {
                    self.work = Work::Verifying { header, offset, crc, write_header };
                    return true;
                }
                if crc.value() != header.crc {
                    self.settle(if write_header { FlashCode::WriteError } else { FlashCode::NoValidProgram });
                    return false;
                }
                if write_header && write_header_unit(area, &header).is_err() {
                    self.settle(FlashCode::WriteError);
                    return false;
                }
                self.work = Work::Idle;
                self.code = FlashCode::Ok;
                self.state = ProgramState::Stopped;
                self.identification = header.crc;
            }
        }
        self.has_work()
    }
}

/// Programs `data` (payload bytes continuing `rx.pending`) from area offset `base` on, in
/// whole write units; the rest waits in `rx.pending`, flushed padded with 0xFF when `last`.
fn program<F: NonVolatile>(
    area: &mut F,
    write_size: usize,
    mut base: u32,
    rx: &mut Receiving,
    mut data: &[u8],
    last: bool,
) -> Result<(), FlashCode> {
    let write = |area: &mut F, at: u32, unit: &[u8]| {
        if at as usize + unit.len() > area.capacity() {
            return Err(FlashCode::AddressError);
        }
        area.write(at, unit).map_err(|_| FlashCode::WriteError)
    };
    // Complete the pending unit first.
    if rx.pending_len > 0 {
        let have = usize::from(rx.pending_len);
        let take = (write_size - have).min(data.len());
        if let (Some(dst), Some(src)) = (rx.pending.get_mut(have..have + take), data.get(..take)) {
            dst.copy_from_slice(src);
        }
        rx.pending_len += take as u8;
        data = data.get(take..).unwrap_or(&[]);
        if usize::from(rx.pending_len) == write_size {
            write(area, base, rx.pending.get(..write_size).unwrap_or(&[]))?;
            base += write_size as u32;
            rx.pending = [0xFF; MAX_WRITE_SIZE];
            rx.pending_len = 0;
        }
    }
    let whole = data.len() / write_size * write_size;
    if whole > 0 {
        write(area, base, data.get(..whole).unwrap_or(&[]))?;
        base += whole as u32;
    }
    let rest = data.get(whole..).unwrap_or(&[]);
    if !rest.is_empty() {
        if let Some(dst) =
            rx.pending.get_mut(usize::from(rx.pending_len)..usize::from(rx.pending_len) + rest.len())
        {
            dst.copy_from_slice(rest);
        }
        rx.pending_len += rest.len() as u8;
    }
    if last && rx.pending_len > 0 {
        write(area, base, rx.pending.get(..write_size).unwrap_or(&[]))?;
        rx.pending_len = 0;
    }
    Ok(())
}

/// Writes the header at the start of the area, padded with 0xFF to whole write units.
fn write_header_unit<F: NonVolatile>(area: &mut F, header: &ImageHeader) -> Result<(), ()> {
    let write_size = area.write_size().clamp(1, MAX_WRITE_SIZE);
    let mut unit = [0xFF; HEADER_LEN + MAX_WRITE_SIZE];
    if let Some(dst) = unit.get_mut(..HEADER_LEN) {
        dst.copy_from_slice(&header.encode());
    }
    let len = HEADER_LEN.div_ceil(write_size) * write_size;
    area.write(0, unit.get(..len).ok_or(())?).map_err(|_| ())
}

#[cfg(test)]
mod tests;

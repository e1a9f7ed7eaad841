//! The bootloader's measurements (issue 35): `canopen_drive::bootloader::Bootloader` over a
//! program area in RAM, set up as a master drives a program download (CiA 302-3), through the
//! node's public entry points only (`on_frame`, `poll`, `pop_tx`).
//!
//! Built alone (cargo feature `bootloader`): a bootloader is a firmware of its own, and an
//! image that also held the drive would inline the SDO server they share differently.

use canopen_drive::bootloader::Bootloader;
use canopen_drive::comm::program::{ImageHeader, FLASH_STATUS_IDENTIFICATION, PROGRAM_CONTROL};
use canopen_drive::comm::program::{PROGRAM_DATA, PROGRAM_SOFTWARE_IDENTIFICATION};
use canopen_drive::od::DeviceInfo;
use canopen_drive::storage::{NonVolatile, NvError};
use canopen_drive::wire::crc;
use canopen_drive::wire::nmt::NmtState;
use canopen_drive::{CanFrame, Instant};
use embedded_can::Frame as _;

use crate::rig::{SetupError, NODE_ID, SDO_RX, SDO_TX};
use crate::{Measurement, Prepared, Scratch};

/// Bytes of the program area: four sectors.
pub const AREA_BYTES: usize = 4 * SECTOR;
/// Bytes of an erase sector, as the 4 KiB sectors of a NOR flash.
pub const SECTOR: usize = 4096;
/// Bytes of a write unit (a double word, as the STM32G4's flash programs).
pub const WRITE_UNIT: usize = 8;
/// Where the payload lies in the area (after the header, a multiple of the write unit).
pub const PAYLOAD_OFFSET: u32 = 256;
/// Bytes of the downloaded program's payload: eight verify steps of 256 bytes.
pub const PAYLOAD_LEN: usize = 2048;
/// Bytes of the image: header and payload.
const IMAGE_LEN: usize = canopen_drive::comm::program::HEADER_LEN + PAYLOAD_LEN;
/// Bytes of a whole sub-block of the default SDO buffer: 127 segments of 7 bytes.
const SUB_BLOCK: usize = 127 * 7;

/// The measured bootloader: the crate's default SDO buffer (one 127-segment sub-block).
pub type BenchBoot = Bootloader<RamArea>;

/// A program area in RAM with the rules of a NOR flash's driver: erase whole sectors to 0xFF,
/// program whole write units; reads anywhere. Programming copies (no check that the bytes
/// were erased: the set-ups clear the area before a download, as the service demands).
#[derive(Clone, Copy)]
pub struct RamArea {
    bytes: [u8; AREA_BYTES],
}

impl RamArea {
    /// An area that holds no image: all zero, as a flash that was programmed over, so that
    /// an erase is seen.
    pub const fn used() -> Self {
        RamArea { bytes: [0; AREA_BYTES] }
    }

    /// The area's bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    fn range(&mut self, offset: u32, len: usize, unit: usize) -> Result<&mut [u8], NvError> {
        let start = offset as usize;
        if !start.is_multiple_of(unit) || !len.is_multiple_of(unit) {
            return Err(NvError::NotAligned);
        }
        self.bytes.get_mut(start..start.saturating_add(len)).ok_or(NvError::OutOfBounds)
    }
}

impl NonVolatile for RamArea {
    fn capacity(&self) -> usize {
        AREA_BYTES
    }

    fn erase_size(&self) -> usize {
        SECTOR
    }

    fn write_size(&self) -> usize {
        WRITE_UNIT
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        buf.copy_from_slice(self.range(offset, buf.len(), 1)?);
        Ok(())
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        self.range(offset, data.len(), WRITE_UNIT)?.copy_from_slice(data);
        Ok(())
    }

    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        let len = (to as usize).checked_sub(from as usize).ok_or(NvError::OutOfBounds)?;
        self.range(from, len, SECTOR)?.fill(0xFF);
        Ok(())
    }
}

/// The bootloader's measurements, in table order.
pub(crate) static ALL: &[Measurement] = &[
    m(
        "boot-block-first",
        "bootloader on_frame + pop_tx: block download to 1F50h:1, last segment of the first \
         sub-block (16-byte header + 873 bytes, 872 programmed)",
        block_first,
    ),
    m(
        "boot-block-next",
        "bootloader on_frame + pop_tx: block download to 1F50h:1, last segment of the second \
         sub-block (889 bytes, 888 programmed)",
        block_next,
    ),
    m("boot-erase", "bootloader poll: clear (1F51h:1 = 3), one 4 KiB sector erased", erase),
    m("boot-verify", "bootloader poll: verifying a download, 256 bytes read back + CRC-32", verify),
    m(
        "boot-verify-last",
        "bootloader poll: the last verify step, 256 bytes + CRC-32 checked, header programmed",
        verify_last,
    ),
    m(
        "boot-status-busy",
        "bootloader on_frame + pop_tx: SDO expedited upload of 1F57h:1 while erasing",
        status_busy,
    ),
];

const fn m(
    name: &'static str,
    label: &'static str,
    prepare: fn() -> Result<Prepared, SetupError>,
) -> Measurement {
    Measurement { name, label, prepare }
}

fn check(condition: bool, what: &'static str) -> Result<(), SetupError> {
    if condition {
        Ok(())
    } else {
        Err(SetupError::Unexpected(what))
    }
}

/// Byte `i` of the payload.
fn payload_byte(i: usize) -> u8 {
    (i.wrapping_mul(31) ^ (i >> 7)) as u8
}

/// The CRC-32 (ISO-HDLC, as zlib's) of the payload, bit by bit: the header's.
fn payload_crc() -> u32 {
    let mut crc = u32::MAX;
    for i in 0..PAYLOAD_LEN {
        crc ^= u32::from(payload_byte(i));
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// Byte `i` of the image a master downloads: header, then payload.
fn image_byte(header: &[u8; 16], i: usize) -> u8 {
    match header.get(i) {
        Some(&byte) => byte,
        None => payload_byte(i - header.len()),
    }
}

/// The bootloader, its time and the image it is given.
struct BootRig {
    node: BenchBoot,
    now: Instant,
    header: [u8; 16],
}

impl BootRig {
    /// A booted bootloader (Pre-operational, no program) over a used area.
    fn new() -> Result<Self, SetupError> {
        let device = DeviceInfo { software_version: "bootloader", ..DeviceInfo::servo_drive() };
        let node = Bootloader::new(device, NODE_ID, RamArea::used(), PAYLOAD_OFFSET)?;
        let header = ImageHeader { len: PAYLOAD_LEN as u32, crc: payload_crc() }.encode();
        let mut rig = BootRig { node, now: Instant::from_millis(1), header };
        rig.node.poll(rig.now);
        while rig.node.pop_tx().is_some() {}
        check(rig.node.nmt_state() == NmtState::PreOperational, "bootloader Pre-operational")?;
        check(rig.read(PROGRAM_CONTROL)? == 3, "no program (1F51h:1 = 3)")?;
        Ok(rig)
    }

    /// Sends an SDO request and returns the answer (none: an error).
    fn sdo(&mut self, request: [u8; 8]) -> Result<[u8; 8], SetupError> {
        let [_, lo, hi, sub, ..] = request;
        let refused = SetupError::Refused { index: u16::from_le_bytes([lo, hi]), sub, response: [0; 8] };
        self.reply_to(&request)?.ok_or(refused)
    }

    /// Sends an SDO request; the answer, if any (more than one frame: an error).
    fn reply_to(&mut self, request: &[u8]) -> Result<Option<[u8; 8]>, SetupError> {
        let frame = CanFrame::new_standard(SDO_RX, request).ok_or(SetupError::Unexpected("bad frame"))?;
        self.node.on_frame(&frame, self.now);
        let mut response = None;
        while let Some(reply) = self.node.pop_tx() {
            check(response.is_none() && reply.standard_id() == Some(SDO_TX), "one SDO answer")?;
            response = reply.data().try_into().ok();
        }
        Ok(response)
    }

    /// Sub 1 of a program download object (1F51h, 1F56h, 1F57h), by expedited upload.
    fn read(&mut self, index: u16) -> Result<u32, SetupError> {
        let [lo, hi] = index.to_le_bytes();
        let response = self.sdo([0x40, lo, hi, 1, 0, 0, 0, 0])?;
        match response {
            [command, _, _, _, a, b, c, d] if command & 0xE3 == 0x43 => Ok(u32::from_le_bytes([a, b, c, d])),
            _ => Err(SetupError::Refused { index, sub: 1, response }),
        }
    }

    /// A command to 1F51h:1.
    fn command(&mut self, value: u8) -> Result<(), SetupError> {
        let response = self.sdo([0x2F, 0x51, 0x1F, 1, value, 0, 0, 0])?;
        if response != [0x60, 0x51, 0x1F, 1, 0, 0, 0, 0] {
            return Err(SetupError::Refused { index: PROGRAM_CONTROL, sub: 1, response });
        }
        Ok(())
    }

    /// Polls while the node asks to be called at once; the steps made.
    fn poll_while_due(&mut self) -> Result<u32, SetupError> {
        let mut steps = 0;
        while self.node.poll(self.now).is_some_and(|due| due <= self.now) {
            steps += 1;
            check(steps <= 64, "the work ends")?;
        }
        check(self.node.pop_tx().is_none(), "poll sends nothing")?;
        Ok(steps + 1)
    }

    /// Clear, to the end: the area erased.
    fn clear(&mut self) -> Result<(), SetupError> {
        self.command(3)?;
        self.poll_while_due()?;
        check(self.read(FLASH_STATUS_IDENTIFICATION)? == 1 << 1, "cleared: not busy, no program")?;
        check(self.node.program().area().bytes().iter().all(|&b| b == 0xFF), "the area erased")
    }

    /// Initiates a block download of the image to 1F50h:1 (size indicated, CRC on).
    fn begin_download(&mut self) -> Result<(), SetupError> {
        let [lo, hi] = PROGRAM_DATA.to_le_bytes();
        let [s0, s1, s2, s3] = (IMAGE_LEN as u32).to_le_bytes();
        let response = self.sdo([0xC6, lo, hi, 1, s0, s1, s2, s3])?;
        check(response[0] & 0xE3 == 0xA0 && response[4] == 127, "block download initiated, 127 segments")
    }

    /// Segment `seq` (1..=127) of the sub-block that starts at image byte `start`.
    fn segment(&self, start: usize, seq: u8) -> [u8; 8] {
        let at = start + 7 * usize::from(seq - 1);
        let last = at + 7 >= IMAGE_LEN;
        let mut data = [if last { 0x80 | seq } else { seq }, 0, 0, 0, 0, 0, 0, 0];
        for (k, slot) in data.iter_mut().skip(1).enumerate() {
            if at + k < IMAGE_LEN {
                *slot = image_byte(&self.header, at + k);
            }
        }
        data
    }

    /// Sends segments `1..=last` of the sub-block at image byte `start`; the answer to the
    /// last one.
    fn sub_block(&mut self, start: usize, last: u8) -> Result<Option<[u8; 8]>, SetupError> {
        for seq in 1..last {
            check(self.reply_to(&self.segment(start, seq))?.is_none(), "no answer within a sub-block")?;
        }
        self.reply_to(&self.segment(start, last))
    }

    /// A whole download of the image; the node then verifies it (its next polls).
    fn download(&mut self) -> Result<(), SetupError> {
        self.clear()?;
        self.begin_download()?;
        let mut start = 0;
        while start < IMAGE_LEN {
            let segments = (IMAGE_LEN - start).div_ceil(7).min(127) as u8;
            let ack = self.sub_block(start, segments)?;
            check(ack.is_some_and(|a| a[0] == 0xA2 && a[1] == segments), "sub-block acknowledged")?;
            start += usize::from(segments) * 7;
        }
        let unused = (start - IMAGE_LEN) as u8;
        let [c0, c1] = crc::update(0, &image(&self.header)).to_le_bytes();
        let response = self.sdo([0xC1 | (unused << 2), c0, c1, 0, 0, 0, 0, 0])?;
        check(response[0] == 0xA1, "block download ended")?;
        check(self.read(FLASH_STATUS_IDENTIFICATION)? & 1 == 1, "busy verifying")
    }
}

/// The whole image (for the block transfer's CRC-16).
fn image(header: &[u8; 16]) -> [u8; IMAGE_LEN] {
    let mut image = [0; IMAGE_LEN];
    for (i, byte) in image.iter_mut().enumerate() {
        *byte = image_byte(header, i);
    }
    image
}

/// The area bytes `from..to` hold the payload's bytes from `at` on.
fn holds_payload(area: &RamArea, from: usize, to: usize, at: usize) -> bool {
    let bytes = area.bytes().get(from..to).unwrap_or(&[]);
    bytes.len() == to - from && bytes.iter().enumerate().all(|(k, &b)| b == payload_byte(at + k))
}

/// The frames the measured operation sent and the node after it (tried on a copy).
fn trial(rig: &BootRig, operation: impl FnOnce(&mut BenchBoot) -> Option<Instant>) -> Trial {
    let mut scratch = Scratch::new();
    let copy = scratch.copy_of_boot(&rig.node);
    let deadline = operation(copy);
    let mut answer = None;
    let mut sent = 0;
    while let Some(frame) = copy.pop_tx() {
        if sent == 0 && frame.standard_id() == Some(SDO_TX) {
            answer = frame.data().try_into().ok();
        }
        sent += 1;
    }
    let status = copy.program().flash_status();
    let state = copy.program().read(PROGRAM_CONTROL).unwrap_or(u32::MAX);
    let identification = copy.program().read(PROGRAM_SOFTWARE_IDENTIFICATION).unwrap_or(u32::MAX);
    Trial { deadline, sent, answer, status, state, identification, area: *copy.program().area() }
}

/// What a trial saw.
struct Trial {
    deadline: Option<Instant>,
    sent: usize,
    /// The first frame's data, if an SDO answer.
    answer: Option<[u8; 8]>,
    /// 1F57h:1, 1F51h:1 and 1F56h:1 afterwards.
    status: u32,
    state: u32,
    identification: u32,
    area: RamArea,
}

/// The last segment of a sub-block as the measured frame, its segments before it sent.
fn block_frame(rig: &mut BootRig, start: usize) -> Result<CanFrame, SetupError> {
    check(rig.sub_block(start, 126)?.is_none(), "no answer before the sub-block's last segment")?;
    let last = rig.segment(start, 127);
    check(last[0] == 127, "not the transfer's last segment")?;
    CanFrame::new_standard(SDO_RX, &last).ok_or(SetupError::Unexpected("bad frame"))
}

/// The frame ends the sub-block: the acknowledgement of 127 segments (next sub-block 127), the
/// payload up to `to` programmed in the area (and nothing after it), still receiving.
fn programmed_to(rig: &BootRig, frame: &CanFrame, to: usize) -> Result<(), SetupError> {
    let t = trial(rig, |node| {
        node.on_frame(frame, rig.now);
        None
    });
    check(t.sent == 1 && t.answer == Some([0xA2, 127, 127, 0, 0, 0, 0, 0]), "sub-block acknowledged")?;
    let at = PAYLOAD_OFFSET as usize;
    check(holds_payload(&t.area, at, at + to, 0), "the sub-block programmed")?;
    check(t.area.bytes().get(at + to..).is_some_and(|rest| rest.iter().all(|&b| b == 0xFF)), "nothing more")?;
    check(t.status == 0b11, "busy receiving")
}

fn block_first() -> Result<Prepared, SetupError> {
    let mut rig = BootRig::new()?;
    rig.clear()?;
    rig.begin_download()?;
    let frame = block_frame(&mut rig, 0)?;
    // 873 payload bytes: 109 write units, one byte waits for the next sub-block.
    programmed_to(&rig, &frame, 872)?;
    Ok(Prepared::BootFrame { node: rig.node, frame, now: rig.now })
}

fn block_next() -> Result<Prepared, SetupError> {
    let mut rig = BootRig::new()?;
    rig.clear()?;
    rig.begin_download()?;
    let ack = rig.sub_block(0, 127)?;
    check(ack == Some([0xA2, 127, 127, 0, 0, 0, 0, 0]), "first sub-block acknowledged")?;
    let frame = block_frame(&mut rig, SUB_BLOCK)?;
    // 1 + 889 payload bytes: 111 write units, two bytes wait.
    programmed_to(&rig, &frame, 1760)?;
    Ok(Prepared::BootFrame { node: rig.node, frame, now: rig.now })
}

fn erase() -> Result<Prepared, SetupError> {
    let mut rig = BootRig::new()?;
    rig.command(3)?;
    let t = trial(&rig, |node| node.poll(rig.now));
    check(t.deadline.is_some_and(|due| due <= rig.now), "more sectors to erase at once")?;
    check(t.sent == 0 && t.status == 0b11, "nothing sent, busy")?;
    let bytes = t.area.bytes();
    let (first, rest) = bytes.split_at(SECTOR);
    check(first.iter().all(|&b| b == 0xFF) && rest.iter().all(|&b| b == 0), "one sector erased")?;
    Ok(Prepared::BootPoll { node: rig.node, now: rig.now })
}

fn status_busy() -> Result<Prepared, SetupError> {
    let mut rig = BootRig::new()?;
    rig.command(3)?;
    let request = [0x40, 0x57, 0x1F, 1, 0, 0, 0, 0];
    let frame = CanFrame::new_standard(SDO_RX, &request).ok_or(SetupError::Unexpected("bad frame"))?;
    let t = trial(&rig, |node| {
        node.on_frame(&frame, rig.now);
        None
    });
    // Busy (bit 0), no valid program (code 1).
    check(t.sent == 1 && t.answer == Some([0x43, 0x57, 0x1F, 1, 3, 0, 0, 0]), "1F57h:1 = 3, busy")?;
    Ok(Prepared::BootFrame { node: rig.node, frame, now: rig.now })
}

fn verify() -> Result<Prepared, SetupError> {
    let mut rig = BootRig::new()?;
    rig.download()?;
    let t = trial(&rig, |node| node.poll(rig.now));
    check(t.deadline.is_some_and(|due| due <= rig.now), "more to verify at once")?;
    check(t.sent == 0 && t.status == 0b11, "nothing sent, still busy")?;
    Ok(Prepared::BootPoll { node: rig.node, now: rig.now })
}

fn verify_last() -> Result<Prepared, SetupError> {
    let mut rig = BootRig::new()?;
    rig.download()?;
    // Seven steps of 256 bytes; the eighth is measured.
    for _ in 0..PAYLOAD_LEN / 256 - 1 {
        check(rig.node.poll(rig.now).is_some_and(|due| due <= rig.now), "verifying")?;
    }
    check(rig.node.pop_tx().is_none(), "poll sends nothing")?;
    let t = trial(&rig, |node| node.poll(rig.now));
    check(t.deadline.is_none_or(|due| due > rig.now) && t.sent == 0, "done, nothing sent")?;
    let crc = payload_crc();
    check(
        t.status == 0 && t.state == 0 && t.identification == crc,
        "verified: 1F57h 0, 1F51h 0, 1F56h the CRC",
    )?;
    check(t.area.bytes().get(..16) == Some(&rig.header[..]), "the header programmed")?;
    let at = PAYLOAD_OFFSET as usize;
    check(holds_payload(&t.area, at, at + PAYLOAD_LEN, 0), "the payload in the area")?;
    Ok(Prepared::BootPoll { node: rig.node, now: rig.now })
}

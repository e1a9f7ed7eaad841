extern crate std;

use super::*;
use crate::storage::NvError;
use std::vec;
use std::vec::Vec;

/// NOR flash in RAM: 16 KiB, 1 KiB sectors, 8-byte write units; a unit is programmed once
/// between erases (the test fails otherwise).
struct RamFlash {
    bytes: Vec<u8>,
    programmed: Vec<bool>,
}

const CAPACITY: usize = 16 * 1024;
const SECTOR: usize = 1024;
const UNIT: usize = 8;
const PAYLOAD_AT: u32 = 64;

impl RamFlash {
    fn new() -> Self {
        RamFlash { bytes: vec![0xFF; CAPACITY], programmed: vec![false; CAPACITY / UNIT] }
    }
}

impl NonVolatile for RamFlash {
    fn capacity(&self) -> usize {
        CAPACITY
    }
    fn erase_size(&self) -> usize {
        SECTOR
    }
    fn write_size(&self) -> usize {
        UNIT
    }
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        let at = offset as usize;
        buf.copy_from_slice(self.bytes.get(at..at + buf.len()).ok_or(NvError::OutOfBounds)?);
        Ok(())
    }
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        let at = offset as usize;
        assert!(
            at.is_multiple_of(UNIT) && data.len().is_multiple_of(UNIT),
            "unaligned write at {at}, {} bytes",
            data.len()
        );
        for unit in at / UNIT..(at + data.len()) / UNIT {
            assert!(!self.programmed[unit], "unit {unit} programmed twice");
            self.programmed[unit] = true;
        }
        self.bytes.get_mut(at..at + data.len()).ok_or(NvError::OutOfBounds)?.copy_from_slice(data);
        Ok(())
    }
    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        let (from, to) = (from as usize, to as usize);
        assert!(from.is_multiple_of(SECTOR) && to.is_multiple_of(SECTOR));
        self.bytes[from..to].fill(0xFF);
        self.programmed[from / UNIT..to / UNIT].fill(false);
        Ok(())
    }
}

fn crc32(data: &[u8]) -> u32 {
    let mut crc = Crc32::new();
    crc.update(data);
    crc.value()
}

fn payload(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i * 31 + i / 97) as u8).collect()
}

/// The image of `payload`: header, then payload.
fn image(payload: &[u8]) -> Vec<u8> {
    let header = ImageHeader { len: payload.len() as u32, crc: crc32(payload) };
    let mut image = header.encode().to_vec();
    image.extend_from_slice(payload);
    image
}

fn finish(service: &mut ProgramDownload<RamFlash>) -> usize {
    let mut steps = 0;
    while service.poll() {
        steps += 1;
        assert!(steps < 10_000, "work never ends");
    }
    steps
}

/// A bootloader with an erased area, cleared.
fn cleared() -> ProgramDownload<RamFlash> {
    let mut service = ProgramDownload::bootloader(RamFlash::new(), PAYLOAD_AT);
    assert_eq!(service.command(3), Ok(()));
    finish(&mut service);
    service
}

/// Downloads `image` in pieces of `piece` bytes.
fn download(service: &mut ProgramDownload<RamFlash>, image: &[u8], piece: usize) -> Result<(), AbortCode> {
    service.begin(Some(image.len()))?;
    let pieces: Vec<&[u8]> = image.chunks(piece).collect();
    for (n, data) in pieces.iter().enumerate() {
        service.piece(n * piece, data, n + 1 == pieces.len())?;
    }
    Ok(())
}

#[test]
fn the_four_objects_are_arrays_of_one_program() {
    let indices: Vec<u16> = OBJECTS.iter().map(|o| o.index).collect();
    assert_eq!(indices, [0x1F50, 0x1F51, 0x1F56, 0x1F57]);
    let data = OBJECTS[0].sub(1).unwrap().0;
    assert_eq!((data.data_type, data.access), (DataType::Domain, Access::WriteOnly));
    assert_eq!(OBJECTS[1].sub(1).unwrap().0.access, Access::ReadWrite);
    assert!(OBJECTS.iter().all(|o| o.highest_sub() == 1));
}

#[test]
fn clear_is_busy_until_every_sector_is_erased_then_a_download_verifies_and_stops() {
    let mut flash = RamFlash::new();
    flash.bytes[5000] = 0x00;
    let mut service = ProgramDownload::bootloader(flash, PAYLOAD_AT);
    assert_eq!((service.read(PROGRAM_CONTROL), service.flash_status()), (Some(3), 1 << 1));
    assert_eq!(service.command(3), Ok(()));
    assert_eq!(service.flash_status() & 1, 1, "busy while erasing");
    assert_eq!(service.read(PROGRAM_SOFTWARE_IDENTIFICATION), Some(0));
    assert_eq!(finish(&mut service), CAPACITY / SECTOR - 1, "one sector per step");
    assert_eq!(service.flash_status() & 1, 0);
    assert_eq!(service.area().bytes[5000], 0xFF);

    let payload = payload(5000);
    assert_eq!(download(&mut service, &image(&payload), 889), Ok(()));
    assert_eq!(service.flash_status() & 1, 1, "busy while reading the program back");
    assert_eq!(service.read(PROGRAM_CONTROL), Some(3));
    let steps = finish(&mut service);
    assert_eq!(steps + 1, 5000usize.div_ceil(VERIFY_CHUNK));
    assert_eq!(service.flash_status(), 0, "not busy, code 0");
    assert_eq!(service.read(PROGRAM_CONTROL), Some(0), "stopped: a valid program");
    assert_eq!(service.read(PROGRAM_SOFTWARE_IDENTIFICATION), Some(crc32(&payload)));
    let area = service.area();
    assert_eq!(&area.bytes[PAYLOAD_AT as usize..PAYLOAD_AT as usize + 5000], &payload[..]);
    assert_eq!(read_header(area), Ok(ImageHeader { len: 5000, crc: crc32(&payload) }));
}

#[test]
fn pieces_of_any_length_land_in_whole_write_units() {
    for piece in [1, 7, 8, 13, 63, 889] {
        let mut service = cleared();
        let payload = payload(1001);
        assert_eq!(download(&mut service, &image(&payload), piece), Ok(()));
        finish(&mut service);
        assert_eq!(service.flash_status(), 0, "pieces of {piece}");
        let area = service.area();
        assert_eq!(&area.bytes[64..64 + 1001], &payload[..]);
        assert!(area.bytes[64 + 1001..64 + 1008].iter().all(|b| *b == 0xFF), "padded with 0xFF");
    }
}

#[test]
fn start_hands_over_a_verified_program_and_is_refused_without_one() {
    let mut service = cleared();
    assert_eq!(service.command(1), Err(AbortCode::CannotStoreDeviceState), "nothing to start");
    assert_eq!(service.take_request(), None);
    download(&mut service, &image(&payload(300)), 100).unwrap();
    assert_eq!(service.command(1), Err(AbortCode::CannotStoreDeviceState), "still verifying");
    finish(&mut service);
    assert_eq!(service.command(0), Ok(()), "stop: already stopped");
    assert_eq!(service.take_request(), None);
    assert_eq!(service.command(1), Ok(()));
    assert_eq!(service.take_request(), Some(ProgramRequest::Start));
    assert_eq!(service.take_request(), None, "taken once");
}

#[test]
fn a_download_without_a_clear_is_refused_with_code_4() {
    let mut service = ProgramDownload::bootloader(RamFlash::new(), PAYLOAD_AT);
    assert_eq!(service.begin(Some(100)), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(service.flash_status(), 4 << 1);
    // A clear allows one download; the next needs its own clear.
    let mut service = cleared();
    download(&mut service, &image(&payload(40)), 16).unwrap();
    finish(&mut service);
    assert_eq!(service.begin(Some(100)), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(service.flash_status(), 4 << 1);
}

#[test]
fn a_value_of_1f51h_that_is_no_command_is_out_of_range() {
    let mut service = cleared();
    for value in [4, 5, 0x80, 0xFF] {
        assert_eq!(service.command(value), Err(AbortCode::InvalidValue), "{value}");
    }
}

#[test]
fn a_corrupt_image_gives_code_3_and_cannot_be_started() {
    // The payload does not match the CRC of its header.
    let mut service = cleared();
    let mut bad = image(&payload(500));
    bad[100] ^= 0x01;
    assert_eq!(download(&mut service, &bad, 64), Ok(()), "the transfer itself succeeds");
    finish(&mut service);
    assert_eq!(service.flash_status(), 3 << 1);
    assert_eq!(service.read(PROGRAM_CONTROL), Some(3));
    assert_eq!(service.read(PROGRAM_SOFTWARE_IDENTIFICATION), Some(0));
    assert_eq!(service.command(1), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(read_header(service.area()), Err(FlashCode::NoValidProgram), "no header written");

    // A header of this format in a version this code does not read.
    let mut service = cleared();
    let mut unknown = image(&payload(500));
    unknown[4] = 2;
    download(&mut service, &unknown, 64).unwrap();
    finish(&mut service);
    assert_eq!(service.flash_status(), 3 << 1);

    // A length that differs from the bytes sent.
    let mut service = cleared();
    let mut short = image(&payload(500));
    short.truncate(400);
    download(&mut service, &short, 64).unwrap();
    assert_eq!(service.flash_status(), 3 << 1);
    assert_eq!(service.command(1), Err(AbortCode::CannotStoreDeviceState));
}

#[test]
fn bytes_that_are_no_image_give_code_2() {
    let mut service = cleared();
    let mut other = image(&payload(500));
    other[0] = b'X';
    download(&mut service, &other, 64).unwrap();
    finish(&mut service);
    assert_eq!(service.flash_status(), 2 << 1);
    assert_eq!(service.command(1), Err(AbortCode::CannotStoreDeviceState));
    // Nothing of it was programmed.
    assert!(service.area().bytes.iter().all(|b| *b == 0xFF));
}

#[test]
fn an_image_larger_than_the_area_is_an_address_error() {
    let mut service = cleared();
    let room = CAPACITY - PAYLOAD_AT as usize;
    assert_eq!(service.begin(Some(HEADER_LEN + room + 1)), Err(AbortCode::LengthTooHigh));
    assert_eq!(service.flash_status(), 6 << 1);
    // Size not indicated: the header's length says it.
    let mut service = cleared();
    let big = image(&payload(room + 8));
    service.begin(None).unwrap();
    service.piece(0, &big[..64], false).unwrap();
    service.piece(64, &big[64..128], true).unwrap();
    assert_eq!(service.flash_status(), 6 << 1);
}

#[test]
fn a_broken_download_leaves_no_program_and_needs_a_new_clear() {
    let mut service = cleared();
    service.begin(None).unwrap();
    service.piece(0, &image(&payload(500))[..200], false).unwrap();
    service.broken();
    assert_eq!(service.flash_status(), 1 << 1, "not busy, no valid program");
    assert_eq!(service.read(PROGRAM_CONTROL), Some(3));
    assert_eq!(service.begin(None), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(service.command(3), Ok(()));
    finish(&mut service);
    assert_eq!(download(&mut service, &image(&payload(500)), 100), Ok(()));
    finish(&mut service);
    assert_eq!(service.flash_status(), 0);
}

#[test]
fn the_bootloader_verifies_the_program_it_finds_at_power_on() {
    let mut service = cleared();
    let payload = payload(3000);
    download(&mut service, &image(&payload), 500).unwrap();
    finish(&mut service);
    let flash = service.into_area();

    let mut service = ProgramDownload::bootloader(flash, PAYLOAD_AT);
    assert_eq!(service.flash_status(), (1 << 1) | 1, "busy verifying, no program yet");
    assert_eq!(service.command(1), Err(AbortCode::CannotStoreDeviceState));
    finish(&mut service);
    assert_eq!((service.read(PROGRAM_CONTROL), service.flash_status()), (Some(0), 0));
    assert_eq!(service.read(PROGRAM_SOFTWARE_IDENTIFICATION), Some(crc32(&payload)));

    // One flipped bit of the program: none.
    let mut flash = service.into_area();
    flash.bytes[PAYLOAD_AT as usize + 2999] ^= 0x80;
    let mut service = ProgramDownload::bootloader(flash, PAYLOAD_AT);
    finish(&mut service);
    assert_eq!((service.read(PROGRAM_CONTROL), service.flash_status()), (Some(3), 1 << 1));
    assert_eq!(service.read(PROGRAM_SOFTWARE_IDENTIFICATION), Some(0));
}

#[test]
fn the_application_runs_stops_into_the_bootloader_and_refuses_clear_and_download() {
    let mut app = RunningProgram::new(0xCAFE_F00D);
    assert_eq!(app.read(PROGRAM_CONTROL), Some(1));
    assert_eq!(app.read(PROGRAM_SOFTWARE_IDENTIFICATION), Some(0xCAFE_F00D));
    assert_eq!(app.read(FLASH_STATUS_IDENTIFICATION), Some(0));
    assert_eq!(app.read(PROGRAM_DATA), None, "write only");
    assert_eq!(app.command(1), Ok(()), "start: already started");
    assert_eq!(app.take_request(), None);
    assert_eq!(app.command(3), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(app.begin(), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(app.read(FLASH_STATUS_IDENTIFICATION), Some(4 << 1));
    assert_eq!(app.command(4), Err(AbortCode::InvalidValue));
    assert_eq!(app.command(2), Ok(()));
    assert!(app.has_request());
    assert_eq!(app.take_request(), Some(ProgramRequest::Reset));
    assert_eq!(app.command(0), Ok(()));
    assert_eq!(app.take_request(), Some(ProgramRequest::Stop));
    assert!(!app.has_request());
}

#[test]
fn a_header_whose_payload_would_not_fit_is_no_program() {
    let mut flash = RamFlash::new();
    let header = ImageHeader { len: u32::MAX - 3, crc: 0x1234_5678 };
    flash.bytes[..HEADER_LEN].copy_from_slice(&header.encode());
    let mut service = ProgramDownload::bootloader(flash, PAYLOAD_AT);
    assert_eq!(finish(&mut service), 0);
    assert_eq!((service.read(PROGRAM_CONTROL), service.flash_status()), (Some(3), 1 << 1));
}

//! `--program-area PATH`: the node as a device with a bootloader (CiA 302-3 program download).
//!
//! The program area is a NOR flash kept in a file ([`FileFlash`], 512 KiB, 4 KiB sectors,
//! 8-byte units): the image's header at offset 0, its payload from [`PAYLOAD_AT`] on
//! ([`canopen_drive::comm::program`]). At start, and after every stop or start a master
//! commands, the program decides what runs, as a bootloader at power-on does:
//! - the area holds a valid program (header, CRC-32 over the payload) and no stop asked to
//!   stay: the application, the drive with 1F50h–1F57h;
//! - otherwise the bootloader node ([`Bootloader`]), until a master downloads a program and
//!   starts it.
//!
//! A host cannot run the downloaded image as code. What the application takes from it is its
//! identity: a payload whose first line is `canopen-drive-linux build VERSION REVISION` (hex)
//! runs as that build (100h software version, 1018h:3 revision), any other payload as the
//! profile's own build. 1F56h:1 is the payload's CRC-32 either way.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration as StdDuration;

use canopen_drive::bootloader::Bootloader;
use canopen_drive::comm::program::{read_header, ImageHeader, ProgramDownload, ProgramRequest, ProgramState};
use canopen_drive::od::DeviceInfo;
use canopen_drive::storage::NonVolatile;
use canopen_drive::Instant;
use canopen_drive_sim::flash::FileFlash;

use crate::bus::Bus;
use crate::monitor::Direction;

/// Bytes of the program area.
pub const CAPACITY: usize = 512 * 1024;
/// Sector size of the program area.
pub const ERASE_SIZE: usize = 4096;
/// Program unit of the program area.
pub const WRITE_SIZE: usize = 8;
/// Where the payload lies in the area.
pub const PAYLOAD_AT: u32 = 64;
/// The first words of a payload's line that names its build.
const BUILD_LINE: &str = "canopen-drive-linux build ";

/// Opens (or creates, erased) the program area in `path`.
pub fn open(path: &Path) -> Result<FileFlash, String> {
    FileFlash::open(path, CAPACITY, ERASE_SIZE, WRITE_SIZE)
        .map_err(|e| format!("cannot open the program area {}: {e}", path.display()))
}

/// Bytes of the payload's start read for its build line.
const BUILD_LINE_LEN: usize = 128;

/// Checks the program in `area` as the bootloader does at power-on (the core's service, run
/// to the end at once): the area back, with the program's header and the start of its payload
/// when it is valid.
pub fn check_program(area: FileFlash) -> (FileFlash, Option<(ImageHeader, Vec<u8>)>) {
    let mut service = ProgramDownload::bootloader(area, PAYLOAD_AT);
    while service.poll() {}
    let valid = service.state() == ProgramState::Stopped;
    let mut area = service.into_area();
    let program = valid.then(|| read_header(&mut area).ok()).flatten().map(|header| {
        let mut start = vec![0; BUILD_LINE_LEN.min(header.len as usize)];
        let _ = area.read(PAYLOAD_AT, &mut start);
        (header, start)
    });
    (area, program)
}

/// The identity the program `payload` runs as: `device` with the version and revision its
/// build line names, if it has one.
pub fn build_identity(mut device: DeviceInfo, payload: &[u8]) -> DeviceInfo {
    let first = payload.split(|b| *b == b'\n').next().unwrap_or_default();
    let Some(rest) = std::str::from_utf8(first).ok().and_then(|line| line.strip_prefix(BUILD_LINE)) else {
        return device;
    };
    let mut words = rest.split_whitespace();
    if let (Some(version), Some(revision)) = (words.next(), words.next()) {
        if let Ok(revision) = u32::from_str_radix(revision.trim_start_matches("0x"), 16) {
            device.software_version = Box::leak(version.to_string().into_boxed_str());
            device.revision_number = revision;
        }
    }
    device
}

/// Runs the bootloader node on `area` until a master starts a verified program (returns the
/// area to start it from) or `stop` is set (returns `None`).
pub fn run_bootloader(
    area: FileFlash,
    device: DeviceInfo,
    node_id: u8,
    bus: &Bus,
    stop: &AtomicBool,
    observer: &dyn Fn(Direction, &canopen_drive::CanFrame),
    started: impl FnOnce(),
) -> Result<Option<FileFlash>, String> {
    let mut boot: Bootloader<FileFlash> = Bootloader::new(device, node_id, area, PAYLOAD_AT)
        .map_err(|e| format!("invalid bootloader configuration: {e}"))?;
    let clock = std::time::Instant::now();
    let now = || Instant::from_micros(u64::try_from(clock.elapsed().as_micros()).unwrap_or(u64::MAX));
    let transmit = |boot: &mut Bootloader<FileFlash>| {
        while let Some(frame) = boot.pop_tx() {
            observer(Direction::Tx, &frame);
            bus.send_from_drive(&frame);
        }
    };
    let mut deadline = boot.poll(now());
    transmit(&mut boot);
    started();
    while !stop.load(Ordering::Relaxed) {
        // At most a second without a frame: `stop` is looked at.
        let wake = deadline.unwrap_or(now() + canopen_drive::Duration::from_millis(1000));
        let timeout = StdDuration::from_micros(wake.saturating_since(now()).as_micros());
        if let Some(frame) = bus.receive(timeout) {
            observer(Direction::Rx, &frame);
            boot.on_frame(&frame, now());
            transmit(&mut boot);
        }
        deadline = boot.poll(now());
        transmit(&mut boot);
        if boot.take_request() == Some(ProgramRequest::Start) {
            return Ok(Some(boot.into_area()));
        }
    }
    Ok(None)
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    #[test]
    fn a_build_line_names_the_identity() {
        let device = DeviceInfo::servo_drive();
        let built = build_identity(device, b"canopen-drive-linux build 2.0.1 00020001\nrest");
        assert_eq!((built.software_version, built.revision_number), ("2.0.1", 0x0002_0001));
        let other = build_identity(device, b"\x7fELF...");
        assert_eq!(other.software_version, device.software_version);
    }
}

//! Program download (CiA 302-3) on the virtual bus: a simulated device that runs either its
//! bootloader ([`Bootloader`]) or the application ([`Drive`] with `program_download`), as a
//! board with a bootloader does, replaced by a master in the sequence real masters use (read
//! the identity, stop, clear, download by block or segmented transfer, poll 1F57h, compare
//! 1F56h, start), with every device-side rule and a power cut at every write to the flash.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

use canopen_drive::bootloader::Bootloader;
use canopen_drive::comm::program::{read_header, ImageHeader, ProgramRequest, HEADER_LEN};
use canopen_drive::od::DeviceInfo;
use canopen_drive::storage::NonVolatile;
use canopen_drive::wire::nmt::NmtCommand;
use canopen_drive::{AbortCode, CanFrame, Config, Drive, Duration, Instant};
use canopen_drive_sim::bus::{Handle, Node};
use canopen_drive_sim::flash::SimFlash;
use canopen_drive_sim::{Master, SdoError, VirtualBus};
use embedded_can::Frame;

const NODE: u8 = 9;
const AREA: usize = 8 * 1024;
const SECTOR: usize = 1024;
const UNIT: usize = 8;
/// Where the program lies in the area (after its header's unit).
const PAYLOAD_AT: u32 = 64;
/// Time the simulated flash takes for a sector erase or a read-back step.
const FLASH_STEP: Duration = Duration::from_millis(5);

const PROGRAM_DATA: u16 = 0x1F50;
const PROGRAM_CONTROL: u16 = 0x1F51;
const IDENTIFICATION: u16 = 0x1F56;
const FLASH_STATUS: u16 = 0x1F57;

/// A build of the application: what its program (the image's payload) says of it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Build {
    version: &'static str,
    revision: u32,
}

const FIRST: Build = Build { version: "1.0.0", revision: 0x0001_0000 };
const SECOND: Build = Build { version: "2.1.0", revision: 0x0002_0001 };

/// The payload of `build`'s image: a line the simulated device reads its identity from, and
/// `len` bytes in all.
fn program(build: Build, len: usize) -> Vec<u8> {
    let mut bytes = format!("build {} {:08x}\n", build.version, build.revision).into_bytes();
    bytes.extend((bytes.len()..len).map(|i| (i * 13 + i / 7) as u8));
    bytes
}

fn crc32(data: &[u8]) -> u32 {
    // The ISO-HDLC / zlib CRC-32, bit by bit, as a master computes it.
    let mut crc = 0xFFFF_FFFFu32;
    for &byte in data {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

fn image(payload: &[u8]) -> Vec<u8> {
    let mut image = ImageHeader { len: payload.len() as u32, crc: crc32(payload) }.encode().to_vec();
    image.extend_from_slice(payload);
    image
}

/// A flash whose area holds `payload`'s image, as a finished download leaves it.
fn flash_with(payload: &[u8]) -> SimFlash {
    let mut flash = SimFlash::new(AREA, SECTOR, UNIT);
    let mut header = [0xFF; UNIT * 2];
    header[..HEADER_LEN].copy_from_slice(&image(payload)[..HEADER_LEN]);
    let mut padded = payload.to_vec();
    padded.resize(payload.len().div_ceil(UNIT) * UNIT, 0xFF);
    flash.write(PAYLOAD_AT, &padded).unwrap();
    flash.write(0, &header).unwrap();
    flash
}

/// The identity both the bootloader and every build show (1000h, 1018h:1–2).
fn device(software_version: &'static str, revision: u32) -> DeviceInfo {
    DeviceInfo {
        vendor_id: 0x0000_04D2,
        product_code: 0x0402_0001,
        revision_number: revision,
        software_version,
        ..DeviceInfo::servo_drive()
    }
}

enum Running {
    Boot(Box<Bootloader<SimFlash>>),
    App(Box<Drive>, SimFlash),
    /// Between a power cut and the next power-on.
    Off(SimFlash),
}

/// A board with a bootloader: at power-on it starts the program in its area when that is
/// valid, else stays in the bootloader; stop resets into the bootloader, start hands over.
struct Device {
    running: Running,
    /// Boot-ups seen (each reset is one).
    resets: u32,
}

impl Device {
    fn power_on(mut flash: SimFlash) -> Self {
        flash.power_on();
        let running = match valid_program(&mut flash) {
            Some(payload) => Running::App(Box::new(application(&payload, &mut flash)), flash),
            None => Running::Boot(Box::new(bootloader(flash))),
        };
        Device { running, resets: 0 }
    }

    fn state(&self) -> &'static str {
        match self.running {
            Running::Boot(_) => "bootloader",
            Running::App(..) => "application",
            Running::Off(_) => "off",
        }
    }

    fn flash(&mut self) -> &mut SimFlash {
        match &mut self.running {
            Running::Boot(boot) => boot.program().area(),
            Running::App(_, flash) | Running::Off(flash) => flash,
        }
    }

    /// Carries out what the running program asked for, once its answer has left.
    fn requests(&mut self) {
        let running = std::mem::replace(&mut self.running, Running::Off(SimFlash::new(0, 1, 1)));
        self.running = match running {
            Running::Boot(mut boot) => match boot.take_request() {
                Some(ProgramRequest::Start | ProgramRequest::Reset) => {
                    let mut flash = boot.into_area();
                    let payload = valid_program(&mut flash).expect("start only with a verified program");
                    self.resets += 1;
                    Running::App(Box::new(application(&payload, &mut flash)), flash)
                }
                Some(ProgramRequest::Stop) | None => Running::Boot(boot),
            },
            Running::App(mut app, mut flash) => match app.take_program_request() {
                Some(ProgramRequest::Stop) => {
                    self.resets += 1;
                    Running::Boot(Box::new(bootloader(flash)))
                }
                Some(ProgramRequest::Reset) => {
                    self.resets += 1;
                    let payload = valid_program(&mut flash).unwrap();
                    Running::App(Box::new(application(&payload, &mut flash)), flash)
                }
                Some(ProgramRequest::Start) | None => Running::App(app, flash),
            },
            off => off,
        };
    }

    /// The power fails: whatever runs stops, the flash keeps what it holds.
    fn cut_power(&mut self) {
        let running = std::mem::replace(&mut self.running, Running::Off(SimFlash::new(0, 1, 1)));
        self.running = Running::Off(match running {
            Running::Boot(boot) => boot.into_area(),
            Running::App(_, flash) | Running::Off(flash) => flash,
        });
    }
}

/// The program of a valid image in `flash` (header, then a payload whose CRC matches), as a
/// bootloader checks it at power-on.
fn valid_program(flash: &mut SimFlash) -> Option<Vec<u8>> {
    let header = read_header(flash).ok()?;
    let mut payload = vec![0; header.len as usize];
    flash.read(PAYLOAD_AT, &mut payload).ok()?;
    (crc32(&payload) == header.crc).then_some(payload)
}

fn bootloader(flash: SimFlash) -> Bootloader<SimFlash> {
    Bootloader::new(device("bootloader 1", 0x00FF_0001), NODE, flash, PAYLOAD_AT).unwrap()
}

/// The application the program `payload` is: its first line names its build.
fn application(payload: &[u8], flash: &mut SimFlash) -> Drive {
    let line = String::from_utf8_lossy(payload.split(|b| *b == b'\n').next().unwrap()).into_owned();
    let mut words = line.split(' ').skip(1);
    let version: &'static str = Box::leak(words.next().unwrap().to_string().into_boxed_str());
    let revision = u32::from_str_radix(words.next().unwrap(), 16).unwrap();
    let config = Config { device: device(version, revision), program_download: true, ..Config::new(NODE) };
    let mut drive = Drive::new(config).unwrap();
    drive.set_program_identification(read_header(flash).unwrap().crc);
    drive
}

impl Node for Device {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        match &mut self.running {
            Running::Boot(boot) => boot.on_frame(frame, now),
            Running::App(app, _) => app.on_frame(frame, now),
            Running::Off(_) => {}
        }
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        self.requests();
        let next = match &mut self.running {
            // A step of erasing or verifying takes the flash some time: the board polls again
            // when it is done.
            Running::Boot(boot) => {
                let next = boot.poll(now);
                if boot.program().has_work() {
                    Some(now + FLASH_STEP)
                } else {
                    next
                }
            }
            Running::App(app, _) => app.poll(now),
            Running::Off(_) => None,
        };
        // A request waits for its answer to leave the queue: the board comes back for it.
        let waiting = match &self.running {
            Running::Boot(boot) => boot.has_request(),
            Running::App(app, _) => app.has_program_request(),
            Running::Off(_) => false,
        };
        let next = if waiting { Some(now) } else { next };
        // The simulated power fails when the flash lost it.
        if matches!(self.running, Running::Boot(_)) && !self.flash().is_powered() {
            self.cut_power();
            return None;
        }
        next
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        match &mut self.running {
            Running::Boot(boot) => boot.pop_tx(),
            Running::App(app, _) => app.pop_tx(),
            Running::Off(_) => None,
        }
    }
}

struct Rig {
    master: Master,
    device: Handle<Device>,
}

impl Rig {
    fn new(flash: SimFlash) -> Self {
        let mut bus = VirtualBus::new();
        let device = bus.add_drive(Device::power_on(flash));
        let mut master = Master::new(bus);
        master.advance(Duration::from_millis(10)).unwrap();
        Rig { master, device }
    }

    fn device(&mut self) -> &mut Device {
        self.master.bus_mut().drive_mut(self.device).unwrap()
    }

    fn u32(&mut self, index: u16, sub: u8) -> u32 {
        let bytes = self.master.sdo_upload(NODE, index, sub).unwrap();
        let mut value = [0u8; 4];
        value[..bytes.len()].copy_from_slice(&bytes);
        u32::from_le_bytes(value)
    }

    fn text(&mut self, index: u16) -> String {
        String::from_utf8(self.master.sdo_upload(NODE, index, 0).unwrap()).unwrap()
    }

    fn upload_abort(&mut self, index: u16, sub: u8) -> Option<AbortCode> {
        match self.master.sdo_upload(NODE, index, sub) {
            Err(SdoError::Abort(code)) => Some(code),
            _ => None,
        }
    }

    fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match self.master.sdo_download(NODE, index, sub, data) {
            Ok(()) => Ok(()),
            Err(SdoError::Abort(code)) => Err(code),
            Err(other) => panic!("{index:04X}h:{sub}: {other:?}"),
        }
    }

    /// Polls 1F57h:1 every 100 ms until its busy bit clears; returns its code.
    fn wait_flash_status(&mut self) -> u32 {
        for _ in 0..100 {
            let status = self.u32(FLASH_STATUS, 1);
            if status & 1 == 0 {
                return status >> 1;
            }
            self.master.advance(Duration::from_millis(100)).unwrap();
        }
        panic!("1F57h stays busy");
    }

    /// Polls 1F51h:1 every 100 ms until it reads `state`.
    fn wait_program_control(&mut self, state: u32) {
        for _ in 0..50 {
            if self.master.sdo_upload(NODE, PROGRAM_CONTROL, 1).ok().map(|b| b[0] as u32) == Some(state) {
                return;
            }
            self.master.advance(Duration::from_millis(100)).unwrap();
        }
        panic!("1F51h:1 never reads {state}");
    }

    /// 1000h and 1018h:1–4.
    fn identity(&mut self) -> [u32; 5] {
        [
            self.u32(0x1000, 0),
            self.u32(0x1018, 1),
            self.u32(0x1018, 2),
            self.u32(0x1018, 3),
            self.u32(0x1018, 4),
        ]
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Transfer {
    Block,
    Segmented,
}

/// The boot-slave update sequence of a master, from the running application to the started
/// new one; returns the 1F56h:1 values read in the bootloader and in the new application.
fn update(rig: &mut Rig, image: &[u8], transfer: Transfer) -> (u32, u32) {
    // 1-3: identity, software identification, program control.
    let identity = rig.identity();
    assert_eq!(rig.u32(PROGRAM_CONTROL, 1), 1, "the application runs");
    let frames_before = rig.master.bus().trace().len();
    rig.download(PROGRAM_CONTROL, 1, &[0]).unwrap();
    rig.master.advance(Duration::from_millis(20)).unwrap();
    assert_eq!(rig.device().state(), "bootloader");
    // The answer to stop is on the bus before the boot-up of the bootloader.
    let after: Vec<CanFrame> = rig.master.bus().trace()[frames_before..].iter().map(|r| r.frame).collect();
    let answer = after.iter().position(|f| f.standard_id() == Some(0x580 + NODE as u16)).unwrap();
    let boot_up = after.iter().position(|f| f.standard_id() == Some(0x700 + NODE as u16) && f.data() == [0]);
    assert!(boot_up.is_some_and(|b| b > answer), "{after:?}");

    // The bootloader answers with the application's identity, but for its own revision.
    let boot_identity = rig.identity();
    assert_eq!(boot_identity[..3], identity[..3], "1000h, 1018h:1-2");
    assert_eq!(rig.wait_flash_status(), 0, "the program found is verified");
    assert_eq!(rig.u32(PROGRAM_CONTROL, 1), 0, "stopped, with a valid program");
    // 4: clear, busy while erasing.
    rig.download(PROGRAM_CONTROL, 1, &[3]).unwrap();
    assert_eq!(rig.u32(FLASH_STATUS, 1) & 1, 1, "busy erasing");
    assert_eq!(rig.u32(IDENTIFICATION, 1), 0);
    assert_eq!(rig.wait_flash_status(), 1, "cleared: no valid program");
    // 5: the image.
    match transfer {
        Transfer::Block => rig.master.sdo_block_download(NODE, PROGRAM_DATA, 1, image).unwrap(),
        Transfer::Segmented => rig.master.sdo_download_segmented(NODE, PROGRAM_DATA, 1, image).unwrap(),
    }
    // 6-7: flash status, identification.
    assert_eq!(rig.wait_flash_status(), 0);
    let in_bootloader = rig.u32(IDENTIFICATION, 1);
    // 8: start, poll until started.
    rig.download(PROGRAM_CONTROL, 1, &[1]).unwrap();
    rig.wait_program_control(1);
    assert_eq!(rig.device().state(), "application");
    let app_identity = rig.identity();
    assert_eq!(app_identity[..3], identity[..3], "1000h, 1018h:1-2");
    (in_bootloader, rig.u32(IDENTIFICATION, 1))
}

#[test]
fn a_master_replaces_the_application_by_block_and_by_segmented_transfer() {
    for transfer in [Transfer::Block, Transfer::Segmented] {
        let first = program(FIRST, 3000);
        let mut rig = Rig::new(flash_with(&first));
        assert_eq!(rig.device().state(), "application");
        assert_eq!(rig.text(0x100A), FIRST.version);
        assert_eq!(rig.u32(0x1018, 3), FIRST.revision);
        assert_eq!(rig.u32(IDENTIFICATION, 1), crc32(&first));

        let second = program(SECOND, 5000);
        let (in_bootloader, in_application) = update(&mut rig, &image(&second), transfer);
        assert_eq!(in_bootloader, crc32(&second), "{transfer:?}");
        assert_eq!(in_application, crc32(&second), "{transfer:?}");
        assert_eq!(rig.text(0x100A), SECOND.version, "{transfer:?}");
        assert_eq!(rig.u32(0x1018, 3), SECOND.revision, "{transfer:?}");
        assert_eq!(rig.device().resets, 2, "stop, then start");
    }
}

#[test]
fn the_program_data_is_write_only_and_needs_a_clear() {
    let mut rig = Rig::new(flash_with(&program(FIRST, 500)));
    // The application: 1F50h:1 refuses reads; a download and a clear are the bootloader's.
    assert_eq!(rig.upload_abort(PROGRAM_DATA, 1), Some(AbortCode::ReadOfWriteOnly));
    assert_eq!(rig.download(PROGRAM_DATA, 1, &[1, 2, 3]), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(rig.u32(FLASH_STATUS, 1), 4 << 1, "code 4: not cleared");
    assert_eq!(rig.download(PROGRAM_CONTROL, 1, &[3]), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(rig.download(IDENTIFICATION, 1, &[0; 4]), Err(AbortCode::WriteOfReadOnly));
    assert_eq!(rig.download(FLASH_STATUS, 1, &[0; 4]), Err(AbortCode::WriteOfReadOnly));

    rig.download(PROGRAM_CONTROL, 1, &[0]).unwrap();
    rig.master.advance(Duration::from_millis(20)).unwrap();
    assert_eq!(rig.device().state(), "bootloader");
    rig.wait_flash_status();
    // The bootloader: a download without a clear, by segmented and by block transfer.
    assert_eq!(rig.upload_abort(PROGRAM_DATA, 1), Some(AbortCode::ReadOfWriteOnly));
    let image = image(&program(SECOND, 500));
    assert_eq!(
        rig.master.sdo_download_segmented(NODE, PROGRAM_DATA, 1, &image).err(),
        Some(SdoError::Abort(AbortCode::CannotStoreDeviceState))
    );
    assert_eq!(rig.u32(FLASH_STATUS, 1), 4 << 1);
    assert_eq!(
        rig.master.sdo_block_download(NODE, PROGRAM_DATA, 1, &image).err(),
        Some(SdoError::Abort(AbortCode::CannotStoreDeviceState))
    );
    // The program found is still there and can be started.
    assert_eq!(rig.u32(PROGRAM_CONTROL, 1), 0);
}

#[test]
fn program_control_refuses_values_that_are_no_command_and_commands_not_possible_now() {
    let mut rig = Rig::new(SimFlash::new(AREA, SECTOR, UNIT));
    assert_eq!(rig.device().state(), "bootloader", "no program: the bootloader stays");
    assert_eq!(rig.u32(PROGRAM_CONTROL, 1), 3, "no program");
    assert_eq!(rig.u32(FLASH_STATUS, 1), 1 << 1, "code 1: no valid program");
    assert_eq!(rig.u32(IDENTIFICATION, 1), 0);
    for value in [4u8, 0x7F, 0xFF] {
        assert_eq!(rig.download(PROGRAM_CONTROL, 1, &[value]), Err(AbortCode::InvalidValue), "{value}");
    }
    assert_eq!(
        rig.download(PROGRAM_CONTROL, 1, &[1]),
        Err(AbortCode::CannotStoreDeviceState),
        "no program to start"
    );
    assert_eq!(rig.download(PROGRAM_CONTROL, 1, &[0]), Ok(()), "stop: already stopped");
    // While erasing: every command waits, 1F57h answers.
    rig.download(PROGRAM_CONTROL, 1, &[3]).unwrap();
    assert_eq!(rig.download(PROGRAM_CONTROL, 1, &[3]), Err(AbortCode::CannotStoreDeviceState));
    assert_eq!(rig.u32(FLASH_STATUS, 1) & 1, 1);
    assert_eq!(rig.wait_flash_status(), 1);
    assert_eq!(rig.device().state(), "bootloader");
}

#[test]
fn a_corrupt_image_gives_code_3_an_unknown_format_code_2_and_neither_starts() {
    let mut rig = Rig::new(SimFlash::new(AREA, SECTOR, UNIT));
    let good = image(&program(SECOND, 1000));
    let cases: [(&str, Vec<u8>, u32); 3] = [
        (
            "wrong CRC",
            {
                let mut i = good.clone();
                i[700] ^= 0x10;
                i
            },
            3,
        ),
        (
            "unknown version",
            {
                let mut i = good.clone();
                i[4] = 9;
                i
            },
            3,
        ),
        (
            "not an image",
            {
                let mut i = good.clone();
                i[..4].copy_from_slice(b"\x7FELF");
                i
            },
            2,
        ),
    ];
    for (what, bad, code) in cases {
        rig.download(PROGRAM_CONTROL, 1, &[3]).unwrap();
        rig.wait_flash_status();
        rig.master.sdo_block_download(NODE, PROGRAM_DATA, 1, &bad).unwrap();
        assert_eq!(rig.wait_flash_status(), code, "{what}");
        assert_eq!(rig.u32(PROGRAM_CONTROL, 1), 3, "{what}");
        assert_eq!(rig.u32(IDENTIFICATION, 1), 0, "{what}");
        assert_eq!(rig.download(PROGRAM_CONTROL, 1, &[1]), Err(AbortCode::CannotStoreDeviceState), "{what}");
        assert_eq!(rig.device().state(), "bootloader");
    }
}

#[test]
fn a_power_cut_at_any_write_of_a_download_leaves_the_bootloader_with_code_1() {
    let image = image(&program(SECOND, 1500));
    // The flash operations of one whole update: erase, download, read-back, header.
    let steps = {
        let mut rig = Rig::new(SimFlash::new(AREA, SECTOR, UNIT));
        let before = rig.device().flash().steps();
        rig.download(PROGRAM_CONTROL, 1, &[3]).unwrap();
        rig.wait_flash_status();
        rig.master.sdo_block_download(NODE, PROGRAM_DATA, 1, &image).unwrap();
        assert_eq!(rig.wait_flash_status(), 0);
        rig.device().flash().steps() - before
    };
    assert!(steps > (AREA / SECTOR + 1500 / UNIT) as u64, "{steps} steps");
    for cut in 0..steps {
        let mut rig = Rig::new(flash_with(&program(FIRST, 800)));
        rig.download(PROGRAM_CONTROL, 1, &[0]).unwrap();
        rig.master.advance(Duration::from_millis(20)).unwrap();
        rig.wait_flash_status();
        rig.device().flash().cut_after(cut);
        // The update runs until the power fails (the master then sees no more answers).
        let _ = rig.master.sdo_download(NODE, PROGRAM_CONTROL, 1, &[3]);
        for _ in 0..20 {
            if rig.device().state() == "off" {
                break;
            }
            rig.master.advance(Duration::from_millis(100)).unwrap();
        }
        if rig.device().state() != "off" {
            let _ = rig.master.sdo_block_download(NODE, PROGRAM_DATA, 1, &image);
            for _ in 0..20 {
                rig.master.advance(Duration::from_millis(100)).unwrap();
            }
        }
        assert_eq!(rig.device().state(), "off", "cut after {cut} of {steps} steps");

        // Power on again on the same flash.
        let mut flash =
            match std::mem::replace(&mut rig.device().running, Running::Off(SimFlash::new(0, 1, 1))) {
                Running::Off(flash) => flash,
                _ => unreachable!(),
            };
        flash.power_on();
        let mut rig = Rig::new(flash);
        assert_eq!(rig.device().state(), "bootloader", "cut after {cut}");
        assert_eq!(rig.wait_flash_status(), 1, "code 1 after a cut after {cut}");
        assert_eq!(rig.u32(IDENTIFICATION, 1), 0);
        assert_eq!(rig.u32(PROGRAM_CONTROL, 1), 3);
        // The master's next update succeeds.
        rig.download(PROGRAM_CONTROL, 1, &[3]).unwrap();
        rig.wait_flash_status();
        rig.master.sdo_block_download(NODE, PROGRAM_DATA, 1, &image).unwrap();
        assert_eq!(rig.wait_flash_status(), 0, "after a cut after {cut}");
        rig.download(PROGRAM_CONTROL, 1, &[1]).unwrap();
        rig.wait_program_control(1);
        assert_eq!(rig.text(0x100A), SECOND.version);
    }
}

#[test]
fn nmt_reset_of_the_bootloader_boots_it_again_and_drops_a_download() {
    let mut rig = Rig::new(SimFlash::new(AREA, SECTOR, UNIT));
    rig.download(PROGRAM_CONTROL, 1, &[3]).unwrap();
    rig.wait_flash_status();
    let image = image(&program(SECOND, 2000));
    // A segmented download interrupted by a reset of the node.
    let [lo, hi] = PROGRAM_DATA.to_le_bytes();
    let size = (image.len() as u32).to_le_bytes();
    let initiate = [0x21, lo, hi, 1, size[0], size[1], size[2], size[3]];
    rig.master.sdo_request(NODE, &initiate).unwrap();
    rig.master.nmt(NmtCommand::ResetNode, NODE).unwrap();
    rig.master.advance(Duration::from_millis(10)).unwrap();
    assert_eq!(rig.u32(FLASH_STATUS, 1), 1 << 1, "not busy, no program");
    assert_eq!(
        rig.master.sdo_block_download(NODE, PROGRAM_DATA, 1, &image).err(),
        Some(SdoError::Abort(AbortCode::CannotStoreDeviceState)),
        "the area is no longer clear"
    );
}

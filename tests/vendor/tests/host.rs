//! The vendor's host test: the board's drive (parameter storage, 8 + 8 PDOs, own and generated
//! objects) run through `can_io::service` with a CAN driver of its own, and on the simulated
//! bus through the scripted master, ticked against the simulated motor.

use std::collections::VecDeque;

use canopen_drive::od::{AbortCode, DeviceInfo};
use canopen_drive::storage::{device_signature, Storage};
use canopen_drive::{can_io, CanFrame, Config, ConfigError, Drive, Duration, Instant};
use canopen_drive_sim::flash::SimFlash;
use canopen_drive_sim::{DriveNode, Master, SdoError, VirtualBus};
use embedded_can::Frame;
use vendor_firmware_check::{build, BoardDrive, GENERATED, VENDOR};

const NODE: u8 = 9;

fn storage(flash: SimFlash) -> Storage<SimFlash> {
    Storage::new(flash, device_signature(&DeviceInfo::servo_drive(), 1)).unwrap()
}

/// The board's CAN driver, as a HAL gives one: receive queue in, transmit log out.
#[derive(Default)]
struct Can {
    rx: VecDeque<CanFrame>,
    tx: Vec<CanFrame>,
}

impl embedded_can::nb::Can for Can {
    type Frame = CanFrame;
    type Error = embedded_can::ErrorKind;
    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
        self.tx.push(*frame);
        Ok(None)
    }
    fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

/// One SDO request through `can_io::service`; the response frame's data.
fn sdo(can: &mut Can, drive: &mut BoardDrive<Storage<SimFlash>>, now: Instant, request: [u8; 8]) -> [u8; 8] {
    can.rx.push_back(CanFrame::new_standard(0x600 + u16::from(NODE), &request).unwrap());
    can_io::service(can, drive, now).unwrap();
    let response = can.tx.iter().rev().find(|f| f.standard_id() == Some(0x580 + u16::from(NODE))).unwrap();
    response.data().try_into().unwrap()
}

#[test]
fn the_board_drive_through_can_io_service_stores_its_parameters() {
    let mut drive = build(NODE, storage(SimFlash::new(32768, 512, 4))).unwrap();
    let mut can = Can::default();
    let now = Instant::from_millis(1);
    let deadline = can_io::service(&mut can, &mut drive, now).unwrap();
    assert_eq!(can.tx[0].standard_id(), Some(0x700 + u16::from(NODE)), "boot-up");
    assert_eq!(deadline, None, "no heartbeat, nothing due");

    // The hand-written object and a generated one, with their defaults.
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x40, 0x00, 0x20, 0, 0, 0, 0, 0]),
        [0x4F, 0x00, 0x20, 0, 4, 0, 0, 0]
    );
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x40, 0x01, 0x20, 0, 0, 0, 0, 0]),
        [0x4B, 0x01, 0x20, 0, 0x20, 0x03, 0, 0]
    );
    // The hook refuses odd pole pairs, the generated limits a current above 2000.
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x2F, 0x00, 0x20, 0, 5, 0, 0, 0]),
        [0x80, 0x00, 0x20, 0, 0x30, 0x00, 0x09, 0x06],
        "0609 0030h"
    );
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x2B, 0x01, 0x20, 0, 0xD1, 0x07, 0, 0]),
        [0x80, 0x01, 0x20, 0, 0x31, 0x00, 0x09, 0x06],
        "0609 0031h"
    );
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x2F, 0x00, 0x20, 0, 6, 0, 0, 0]),
        [0x60, 0x00, 0x20, 0, 0, 0, 0, 0]
    );
    assert_eq!(drive.hooks_mut().pole_pair_writes, 1);
    // A heartbeat every 100 ms: the deadline service returns is the next one.
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x2B, 0x17, 0x10, 0, 100, 0, 0, 0]),
        [0x60, 0x17, 0x10, 0, 0, 0, 0, 0]
    );
    let deadline = can_io::service(&mut can, &mut drive, now).unwrap();
    assert_eq!(deadline, Some(now + Duration::from_millis(100)));
    // PDO 8 exists (1407h and 1A07h): 8 + 8.
    assert_eq!(sdo(&mut can, &mut drive, now, [0x40, 0x07, 0x14, 0, 0, 0, 0, 0])[0], 0x4F);
    assert_eq!(sdo(&mut can, &mut drive, now, [0x40, 0x07, 0x1A, 0, 0, 0, 0, 0])[0], 0x4F);
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x40, 0x08, 0x14, 0, 0, 0, 0, 0]),
        [0x80, 0x08, 0x14, 0, 0x00, 0x00, 0x02, 0x06],
        "no ninth RPDO: 0602 0000h"
    );

    // 1010h sub 1 "save", then a power cycle over the same flash keeps 6 pole pairs.
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x23, 0x10, 0x10, 1, b's', b'a', b'v', b'e']),
        [0x60, 0x10, 0x10, 1, 0, 0, 0, 0]
    );
    let flash = drive.storage_mut().area().clone();
    let mut drive = build(NODE, storage(flash)).unwrap();
    assert_eq!(drive.od().get::<u8>(0x2000, 0), Ok(6));
    assert_eq!(
        sdo(&mut can, &mut drive, now, [0x40, 0x00, 0x20, 0, 0, 0, 0, 0]),
        [0x4F, 0x00, 0x20, 0, 6, 0, 0, 0]
    );
}

#[test]
fn the_board_drive_on_the_simulated_bus_enables_and_moves() {
    let drive = build(NODE, storage(SimFlash::new(32768, 512, 4))).unwrap();
    let mut bus = VirtualBus::new();
    let node = bus.add_drive(DriveNode::new(drive, Duration::from_micros(500)));
    let mut master = Master::new(bus);

    assert_eq!(master.sdo_upload(NODE, 0x2010, 0).unwrap(), [20], "a generated default");
    assert_eq!(
        master.sdo_download(NODE, 0x3000, 0, &[1, 0]),
        Err(SdoError::Abort(AbortCode::WriteOfReadOnly))
    );
    let mut axis = master.axis(NODE, 0);
    assert_eq!(axis.enable().unwrap() & 0x6F, 0x27, "Operation enabled");
    axis.pp_move(25_000, Duration::from_millis(6_000)).unwrap();
    // Target reached: the position actual value within the position window (6067h, 100).
    let position = axis.read_i32(0x6064).unwrap();
    assert!((position - 25_000).abs() <= 100, "{position}");
    axis.disable().unwrap();
    let sim = master.bus_mut().drive_mut(node).unwrap();
    assert!((sim.motor.position() - 25_000.0).abs() <= 100.0, "{}", sim.motor.position());
    assert!(!sim.demand.drive_enabled, "no energy after shutdown");
    assert_eq!(sim.drive.hooks_mut().pole_pair_writes, 0);
}

#[test]
fn a_table_that_is_wrong_is_refused_with_its_reason() {
    assert_eq!(GENERATED.len() + 1, VENDOR.len());
    static LOW: [canopen_drive::od::Object; 1] = canopen_drive::od::layout([canopen_drive::od::Object::var(
        0x1234,
        "Misplaced",
        canopen_drive::od::Var::new("Misplaced", canopen_drive::od::DataType::Unsigned8),
    )]);
    let error = Drive::new(Config { manufacturer_objects: &LOW, ..Config::new(NODE) }).err().unwrap();
    assert_eq!(error, ConfigError::NotManufacturer { index: 0x1234 });
    assert_eq!(error.to_string(), "object 1234h: a manufacturer object outside 2000h–5FFFh");
}

//! Store (1010h) and restore (1011h) parameters through SDO, with the drive restarted on the
//! same simulated flash (CiA 301 §7.5.2.13–14, digest §11).

mod common;

use common::*;

use canopen_drive::od::DeviceInfo;
use canopen_drive::storage::{device_signature, Storage};
use canopen_drive::{Config, Drive, Instant};
use canopen_drive_sim::flash::SimFlash;
use embedded_can::Frame;

type StoredDrive = Drive<TestHooks, { canopen_drive::drive::DEFAULT_OD_BYTES }, 4, 4, Storage<SimFlash>>;

const SAVE: [u8; 4] = *b"save";
const LOAD: [u8; 4] = *b"load";
const EMCY: u16 = 0x80 + NODE as u16;

/// A drive on `flash` (as after a power-on), booted; returns it and its boot frames.
fn power_on(flash: SimFlash) -> (StoredDrive, Vec<canopen_drive::CanFrame>) {
    power_on_with(flash, |config| config)
}

/// [`power_on`] with the configuration `adjust` changed.
fn power_on_with(
    flash: SimFlash,
    adjust: impl FnOnce(Config) -> Config,
) -> (StoredDrive, Vec<canopen_drive::CanFrame>) {
    let device = DeviceInfo::servo_drive();
    let storage = Storage::new(flash, device_signature(&device, 1)).unwrap();
    let config = adjust(Config { manufacturer_objects: &TEST_OBJECTS, ..Config::new(NODE) });
    let mut drive = Drive::with_storage(config, TestHooks::default(), storage).unwrap();
    drive.poll(Instant::ZERO);
    let frames = std::iter::from_fn(|| drive.pop_tx()).collect();
    (drive, frames)
}

fn blank() -> SimFlash {
    SimFlash::new(8192, 512, 4)
}

/// One SDO request, one response.
fn sdo(drive: &mut StoredDrive, request: [u8; 8]) -> [u8; 8] {
    drive.on_frame(&frame(SDO_RX, &request), Instant::from_millis(1));
    let frames: Vec<_> =
        std::iter::from_fn(|| drive.pop_tx()).filter(|f| f.standard_id() == Some(SDO_TX)).collect();
    assert_eq!(frames.len(), 1, "{request:02X?}");
    frames[0].data().try_into().unwrap()
}

fn flash_of(drive: &mut StoredDrive) -> SimFlash {
    drive.storage_mut().area().clone()
}

#[test]
fn read_values_say_what_is_supported() {
    let (mut drive, _) = power_on(blank());
    for index in [0x1010, 0x1011] {
        assert_eq!(sdo(&mut drive, req(0x40, index, 0, [0; 4])), req(0x4F, index, 0, [4, 0, 0, 0]));
        for sub in 1..=4 {
            assert_eq!(sdo(&mut drive, req(0x40, index, sub, [0; 4])), req(0x43, index, sub, [1, 0, 0, 0]));
        }
        assert_eq!(sdo(&mut drive, req(0x40, index, 5, [0; 4])), abort(index, 5, 0x0609_0011));
        assert_eq!(sdo(&mut drive, req(0x2F, index, 0, [4, 0, 0, 0])), abort(index, 0, 0x0601_0002));
    }
    // Without storage: 0, and the commands are refused.
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x1010, 1, [0; 4])), req(0x43, 0x1010, 1, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x23, 0x1010, 1, SAVE)), abort(0x1010, 1, 0x0800_0020));
}

#[test]
fn a_drive_may_store_only_some_groups() {
    use canopen_drive::storage::Group;
    static GROUPS: [Group; 3] = [Group::All, Group::Communication, Group::Manufacturer];
    let (mut drive, _) = power_on_with(blank(), |c| Config { store_groups: &GROUPS, ..c });
    for index in [0x1010, 0x1011] {
        for (sub, capable) in [(1, 1), (2, 1), (3, 0), (4, 1)] {
            assert_eq!(
                sdo(&mut drive, req(0x40, index, sub, [0; 4])),
                req(0x43, index, sub, [capable, 0, 0, 0])
            );
        }
    }
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 3, SAVE)), abort(0x1010, 3, 0x0800_0020));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1011, 3, LOAD)), abort(0x1011, 3, 0x0800_0020));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 2, SAVE)), req(0x60, 0x1010, 2, [0; 4]));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 1, SAVE)), req(0x60, 0x1010, 1, [0; 4]));
}

#[test]
fn stored_values_survive_a_restart() {
    let (mut drive, _) = power_on(blank());
    assert_eq!(sdo(&mut drive, req(0x2B, 0x1017, 0, [250, 0, 0, 0])), req(0x60, 0x1017, 0, [0; 4]));
    assert_eq!(sdo(&mut drive, req(0x2F, LIMITED, 0, [12, 0, 0, 0])), req(0x60, LIMITED, 0, [0; 4]));
    // Wrong signature, wrong length.
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 1, *b"SAVE")), abort(0x1010, 1, 0x0800_0020));
    assert_eq!(sdo(&mut drive, req(0x2B, 0x1010, 1, SAVE)), abort(0x1010, 1, 0x0607_0013));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 1, SAVE)), req(0x60, 0x1010, 1, [0; 4]));
    // Changed after the store: not kept.
    sdo(&mut drive, req(0x2F, LIMITED, 0, [13, 0, 0, 0]));
    let (mut drive, _) = power_on(flash_of(&mut drive));
    assert_eq!(drive.od().get::<u16>(0x1017, 0), Ok(250));
    assert_eq!(drive.od().get::<u8>(LIMITED, 0), Ok(12));
    // The stored heartbeat runs from boot on.
    assert_eq!(drive.poll(Instant::ZERO), Some(Instant::from_millis(250)));
}

#[test]
fn groups_store_separately_and_resets_reload_them() {
    let (mut drive, _) = power_on(blank());
    sdo(&mut drive, req(0x2B, 0x1017, 0, [100, 0, 0, 0]));
    sdo(&mut drive, req(0x2F, LIMITED, 0, [12, 0, 0, 0]));
    // Communication only (sub 2).
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 2, SAVE)), req(0x60, 0x1010, 2, [0; 4]));
    let (mut drive, _) = power_on(flash_of(&mut drive));
    assert_eq!(drive.od().get::<u16>(0x1017, 0), Ok(100));
    assert_eq!(drive.od().get::<u8>(LIMITED, 0), Ok(15), "manufacturer group not stored");
    // Reset communication brings back the stored communication values, not the defaults.
    sdo(&mut drive, req(0x2B, 0x1017, 0, [7, 0, 0, 0]));
    drive.on_frame(&frame(0x000, &[0x82, NODE]), Instant::from_millis(2));
    assert_eq!(drive.od().get::<u16>(0x1017, 0), Ok(100));
    // Manufacturer (sub 4) stored; reset node reloads it.
    sdo(&mut drive, req(0x2F, LIMITED, 0, [19, 0, 0, 0]));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 4, SAVE)), req(0x60, 0x1010, 4, [0; 4]));
    sdo(&mut drive, req(0x2F, LIMITED, 0, [11, 0, 0, 0]));
    drive.on_frame(&frame(0x000, &[0x81, NODE]), Instant::from_millis(3));
    assert_eq!(drive.od().get::<u8>(LIMITED, 0), Ok(19));
    assert_eq!(drive.od().get::<u16>(0x1017, 0), Ok(100), "communication set kept");
}

#[test]
fn restore_defaults_takes_effect_after_the_next_reset() {
    let (mut drive, _) = power_on(blank());
    sdo(&mut drive, req(0x2B, 0x1017, 0, [100, 0, 0, 0]));
    sdo(&mut drive, req(0x2F, LIMITED, 0, [12, 0, 0, 0]));
    sdo(&mut drive, req(0x23, 0x1010, 1, SAVE));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1011, 1, *b"save")), abort(0x1011, 1, 0x0800_0020));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1011, 1, LOAD)), req(0x60, 0x1011, 1, [0; 4]));
    // RAM values unchanged until the reset.
    assert_eq!(drive.od().get::<u16>(0x1017, 0), Ok(100));
    drive.on_frame(&frame(0x000, &[0x81, NODE]), Instant::from_millis(2));
    assert_eq!(drive.od().get::<u16>(0x1017, 0), Ok(0));
    assert_eq!(drive.od().get::<u8>(LIMITED, 0), Ok(15));
    let (drive, _) = power_on(flash_of(&mut { drive }));
    assert_eq!(drive.od().get::<u16>(0x1017, 0), Ok(0));
}

/// A drive powered on over an image (1017h = 100) whose payload is damaged.
fn power_on_damaged() -> (StoredDrive, Vec<canopen_drive::CanFrame>) {
    let (mut drive, _) = power_on(blank());
    sdo(&mut drive, req(0x2B, 0x1017, 0, [100, 0, 0, 0]));
    sdo(&mut drive, req(0x23, 0x1010, 1, SAVE));
    let mut flash = flash_of(&mut drive);
    // Damage the payload of the only image.
    let byte = flash.bytes()[40];
    flash.bytes_mut()[40] = byte ^ 0x01;
    power_on(flash)
}

#[test]
fn a_corrupt_image_is_ignored_with_an_emcy() {
    let (mut drive, boot) = power_on_damaged();
    assert_eq!(drive.od().get::<u16>(0x1017, 0), Ok(0), "defaults, never the damaged set");
    assert_eq!(boot[0], frame(0x700 + u16::from(NODE), &[0]));
    assert_eq!(boot[1].standard_id(), Some(EMCY));
    assert_eq!(boot[1].data()[..2], [0x00, 0x63]);
    // A successful store clears the error.
    sdo(&mut drive, req(0x23, 0x1010, 1, SAVE));
    drive.poll(Instant::from_millis(5));
    let frames: Vec<_> = std::iter::from_fn(|| drive.pop_tx()).collect();
    assert_eq!(frames, vec![frame(EMCY, &[0; 8])]);
}

/// Damage is an active error (CiA 301 §7.2.7): it stays in 1001h and 1003h and a reset node,
/// which forgets the errors as a power-on would, finds it again and sends its EMCY again.
#[test]
fn a_damaged_image_stays_reported_across_a_reset_node() {
    let (mut drive, boot) = power_on_damaged();
    let emcys = |frames: &[canopen_drive::CanFrame]| -> Vec<Vec<u8>> {
        frames.iter().filter(|f| f.standard_id() == Some(EMCY)).map(|f| f.data().to_vec()).collect()
    };
    assert_eq!(emcys(&boot).len(), 1);
    for when in ["after boot", "after a reset node"] {
        let register = sdo(&mut drive, req(0x40, 0x1001, 0, [0; 4]));
        assert_ne!(register[4], 0, "1001h {when}");
        assert_eq!(sdo(&mut drive, req(0x40, 0x1003, 0, [0; 4]))[4], 1, "1003h count {when}");
        assert_eq!(sdo(&mut drive, req(0x40, 0x1003, 1, [0; 4]))[4..6], [0x00, 0x63], "1003h {when}");
        if when == "after boot" {
            drive.on_frame(&frame(0x000, &[0x81, NODE]), Instant::from_millis(2));
            drive.poll(Instant::from_millis(3));
            let frames: Vec<_> = std::iter::from_fn(|| drive.pop_tx()).collect();
            assert_eq!(frames[0], frame(0x700 + u16::from(NODE), &[0]), "boot-up first");
            let sent = emcys(&frames);
            assert_eq!(sent.len(), 1, "one EMCY after the reset node: {sent:02X?}");
            assert_eq!(sent[0][..2], [0x00, 0x63]);
        }
    }
}

#[test]
fn a_failing_flash_answers_hardware_error() {
    let mut flash = blank();
    flash.cut_after(3);
    let (mut drive, _) = power_on(flash);
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 1, SAVE)), abort(0x1010, 1, 0x0606_0000));
}

#[test]
fn the_firmware_may_store_a_group_itself() {
    use canopen_drive::storage::Group;
    let (mut drive, _) = power_on(blank());
    // 1017h (communication) changed by the master, then stored by the device, not by SDO.
    assert_eq!(sdo(&mut drive, req(0x2B, 0x1017, 0, [0x34, 0x12, 0, 0])), req(0x60, 0x1017, 0, [0; 4]));
    assert_eq!(drive.store_parameters(Group::Communication), Ok(()));
    let (mut restarted, _) = power_on(flash_of(&mut drive));
    assert_eq!(sdo(&mut restarted, req(0x40, 0x1017, 0, [0; 4])), req(0x4B, 0x1017, 0, [0x34, 0x12, 0, 0]));
    // A group the drive does not store, and a drive without storage: refused.
    static GROUPS: [Group; 1] = [Group::All];
    let (mut some, _) = power_on_with(blank(), |c| Config { store_groups: &GROUPS, ..c });
    assert_eq!(some.store_parameters(Group::Communication), Err(canopen_drive::AbortCode::CannotStore));
    let mut bench = Bench::new();
    assert_eq!(bench.drive().store_parameters(Group::All), Err(canopen_drive::AbortCode::CannotStore));
}

#[test]
fn the_firmware_may_store_single_parameters_and_keep_the_rest() {
    let (mut drive, _) = power_on(blank());
    // Stored by the master: 1017h = 0x1234.
    assert_eq!(sdo(&mut drive, req(0x2B, 0x1017, 0, [0x34, 0x12, 0, 0])), req(0x60, 0x1017, 0, [0; 4]));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 1, *b"save")), req(0x60, 0x1010, 1, [0; 4]));
    // Changed by the master, not stored: 1017h again and 6081h; 607Dh sub 2 is what the
    // firmware saves itself (a homing result).
    assert_eq!(sdo(&mut drive, req(0x2B, 0x1017, 0, [0x78, 0x56, 0, 0])), req(0x60, 0x1017, 0, [0; 4]));
    assert_eq!(sdo(&mut drive, req(0x23, 0x6081, 0, 777u32.to_le_bytes())), req(0x60, 0x6081, 0, [0; 4]));
    assert_eq!(sdo(&mut drive, req(0x23, 0x607D, 2, 5000u32.to_le_bytes())), req(0x60, 0x607D, 2, [0; 4]));
    assert_eq!(drive.store_entries(&[(0x607D, 2)]), Ok(()));
    let (mut restarted, _) = power_on(flash_of(&mut drive));
    assert_eq!(
        sdo(&mut restarted, req(0x40, 0x607D, 2, [0; 4])),
        req(0x43, 0x607D, 2, 5000u32.to_le_bytes())
    );
    assert_eq!(sdo(&mut restarted, req(0x40, 0x1017, 0, [0; 4])), req(0x4B, 0x1017, 0, [0x34, 0x12, 0, 0]));
    assert_eq!(
        sdo(&mut restarted, req(0x40, 0x6081, 0, [0; 4])),
        req(0x43, 0x6081, 0, 10_000u32.to_le_bytes())
    );
    // Without storage: refused.
    let mut bench = Bench::new();
    assert_eq!(bench.drive().store_entries(&[(0x607D, 2)]), Err(canopen_drive::AbortCode::CannotStore));
}

#[test]
fn stored_node_id_relative_cob_ids_follow_a_new_node_id() {
    // Issue 18 (8): a communication set stored at node 5 and loaded at node 7 (an LSS or vendor
    // node-ID change, then a restart or a reset) keeps the `$NODEID` COB-IDs relative; a COB-ID
    // the master chose stays as it is.
    let (mut drive, _) = power_on(blank());
    assert_eq!(
        sdo(&mut drive, req(0x23, 0x1801, 1, 0xC000_0299u32.to_le_bytes())),
        req(0x60, 0x1801, 1, [0; 4])
    );
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 2, SAVE)), req(0x60, 0x1010, 2, [0; 4]));
    // At once (NMT reset node with a node-ID configured since) ...
    drive.configure_node_id(7).unwrap();
    drive.on_frame(&frame(0x000, &[0x81, NODE]), Instant::from_millis(2));
    let boot: Vec<_> = std::iter::from_fn(|| drive.pop_tx()).collect();
    assert!(boot.iter().any(|f| f.standard_id() == Some(0x707) && f.data() == [0]), "{boot:02X?}");
    let read = |drive: &mut StoredDrive, index: u16, sub: u8| {
        let request = req(0x40, index, sub, [0; 4]);
        drive.on_frame(&frame(0x607, &request), Instant::from_millis(3));
        let frames: Vec<_> =
            std::iter::from_fn(|| drive.pop_tx()).filter(|f| f.standard_id() == Some(0x587)).collect();
        u32::from_le_bytes(frames[0].data()[4..8].try_into().unwrap())
    };
    assert_eq!(read(&mut drive, 0x1014, 0), 0x87);
    assert_eq!(read(&mut drive, 0x1800, 1), 0x4000_0187);
    assert_eq!(read(&mut drive, 0x1400, 1), 0x207);
    assert_eq!(read(&mut drive, 0x1801, 1), 0xC000_0299, "the master's own COB-ID");
    // ... and after a power cycle at node 7.
    let flash = flash_of(&mut drive);
    let (mut drive, _) = power_on_with(flash, |c| Config { node_id: 7, ..c });
    assert_eq!(read(&mut drive, 0x1800, 1), 0x4000_0187);
    assert_eq!(read(&mut drive, 0x1801, 1), 0xC000_0299);
}

/// Stored heartbeat-consumer entries (1016h) supervise from the start, as the stored producer
/// time does: a power-on with a stored entry for node 9 reports its lost heartbeat (EMCY 8130h),
/// without a master writing 1016h again.
#[test]
fn stored_heartbeat_consumer_entries_supervise_from_boot() {
    let (mut drive, _) = power_on(blank());
    let entry = (9u32 << 16) | 100;
    assert_eq!(sdo(&mut drive, req(0x23, 0x1016, 1, entry.to_le_bytes())), req(0x60, 0x1016, 1, [0; 4]));
    assert_eq!(sdo(&mut drive, req(0x23, 0x1010, 2, SAVE)), req(0x60, 0x1010, 2, [0; 4]));
    let (mut drive, _) = power_on(flash_of(&mut drive));
    assert_eq!(drive.od().get::<u32>(0x1016, 1), Ok(entry));
    // Node 9's first heartbeat starts the supervision; none follows within 100 ms.
    drive.on_frame(&frame(0x709, &[0x05]), Instant::from_millis(10));
    drive.poll(Instant::from_millis(200));
    let frames: Vec<_> = std::iter::from_fn(|| drive.pop_tx()).collect();
    let timeout =
        frames.iter().any(|f| f.standard_id() == Some(EMCY) && f.data().get(..2) == Some(&[0x30, 0x81]));
    assert!(timeout, "no heartbeat-timeout EMCY: {frames:02X?}");
}

//! EMCY producer, error register 1001h and error history 1003h on the virtual bus
//! (CiA 301 §7.2.7, digest §9).

mod common;

use common::*;

use canopen_drive::comm::emcy::ErrorRegister;
use canopen_drive::{CanFrame, Duration};

const EMCY: u16 = 0x080 + NODE as u16;

fn emcy(data: [u8; 8]) -> CanFrame {
    frame(EMCY, &data)
}

#[test]
fn raise_and_clear_send_the_documented_frames() {
    let mut bench = Bench::new();
    bench.drive().raise_error(0x8130, ErrorRegister::COMMUNICATION, [0; 5]);
    assert_eq!(bench.advance(Duration::ZERO), vec![emcy([0x30, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    // The same error again: no frame.
    bench.drive().raise_error(0x8130, ErrorRegister::COMMUNICATION, [0; 5]);
    assert!(bench.advance(Duration::ZERO).is_empty());
    bench.drive().raise_error(0x4310, ErrorRegister::TEMPERATURE, [0xAA, 0xBB, 1, 2, 3]);
    assert_eq!(bench.advance(Duration::ZERO), vec![emcy([0x10, 0x43, 0x19, 0xAA, 0xBB, 1, 2, 3])]);
    assert_eq!(bench.sdo1(&req(0x40, 0x1001, 0, [0; 4])), req(0x4F, 0x1001, 0, [0x19, 0, 0, 0]));
    // One error goes: "error reset" with the register that remains; then the last one.
    bench.drive().clear_error(0x8130);
    assert_eq!(bench.advance(Duration::ZERO), vec![emcy([0, 0, 0x09, 0, 0, 0, 0, 0])]);
    bench.drive().clear_error(0x4310);
    assert_eq!(bench.advance(Duration::ZERO), vec![emcy([0, 0, 0x00, 0, 0, 0, 0, 0])]);
    assert_eq!(bench.sdo1(&req(0x40, 0x1001, 0, [0; 4])), req(0x4F, 0x1001, 0, [0, 0, 0, 0]));
}

#[test]
fn history_is_newest_first_and_cleared_by_writing_zero() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 0, [0; 4])), req(0x4F, 0x1003, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 1, [0; 4])), abort(0x1003, 1, 0x0800_0024));
    for code in [0x2310u16, 0x3210, 0x4210] {
        bench.drive().raise_error(code, ErrorRegister::empty(), [0x34, 0x12, 0, 0, 0]);
    }
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 0, [0; 4])), req(0x4F, 0x1003, 0, [3, 0, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 1, [0; 4])), req(0x43, 0x1003, 1, [0x10, 0x42, 0x34, 0x12]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 3, [0; 4])), req(0x43, 0x1003, 3, [0x10, 0x23, 0x34, 0x12]));
    // The history keeps the newest 8.
    for code in 0x5001u16..=0x5008 {
        bench.drive().raise_error(code, ErrorRegister::empty(), [0; 5]);
    }
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 0, [0; 4])), req(0x4F, 0x1003, 0, [8, 0, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 1, [0; 4])), req(0x43, 0x1003, 1, [0x08, 0x50, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 8, [0; 4])), req(0x43, 0x1003, 8, [0x01, 0x50, 0, 0]));
    // Only 0 may be written.
    assert_eq!(bench.sdo1(&req(0x2F, 0x1003, 0, [1, 0, 0, 0])), abort(0x1003, 0, 0x0609_0030));
    assert_eq!(bench.sdo1(&req(0x2F, 0x1003, 0, [0, 0, 0, 0])), req(0x60, 0x1003, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 0, [0; 4])), req(0x4F, 0x1003, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 1, [0; 4])), abort(0x1003, 1, 0x0800_0024));
    assert_eq!(bench.sdo1(&req(0x23, 0x1003, 1, [0; 4])), abort(0x1003, 1, 0x0601_0002));
}

#[test]
fn cob_id_emcy_rules() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x1014, 0, [0; 4])), req(0x43, 0x1014, 0, [0x85, 0, 0, 0]));
    // The CAN-ID changes only while invalid; restricted identifiers and 29-bit are refused.
    assert_eq!(bench.sdo1(&req(0x23, 0x1014, 0, [0x90, 0, 0, 0])), abort(0x1014, 0, 0x0609_0030));
    assert_eq!(bench.sdo1(&req(0x23, 0x1014, 0, [0x85, 0, 0, 0x20])), abort(0x1014, 0, 0x0609_0030));
    assert_eq!(bench.sdo1(&req(0x23, 0x1014, 0, [0x85, 0x05, 0, 0x80])), abort(0x1014, 0, 0x0609_0030));
    assert_eq!(bench.sdo1(&req(0x23, 0x1014, 0, [0x00, 0, 0, 0])), abort(0x1014, 0, 0x0609_0030));
    // Invalid: errors produce no frame.
    assert_eq!(bench.sdo1(&req(0x23, 0x1014, 0, [0x85, 0, 0, 0x80])), req(0x60, 0x1014, 0, [0; 4]));
    bench.drive().raise_error(0x1000, ErrorRegister::empty(), [0; 5]);
    assert!(bench.advance(Duration::from_millis(10)).is_empty());
    // Move it to 0x0F0 and validate it.
    assert_eq!(bench.sdo1(&req(0x23, 0x1014, 0, [0xF0, 0, 0, 0x80])), req(0x60, 0x1014, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x23, 0x1014, 0, [0xF0, 0, 0, 0])), req(0x60, 0x1014, 0, [0; 4]));
    bench.drive().raise_error(0x2000, ErrorRegister::CURRENT, [0; 5]);
    assert_eq!(bench.advance(Duration::ZERO), vec![frame(0x0F0, &[0x00, 0x20, 0x03, 0, 0, 0, 0, 0])]);
}

#[test]
fn inhibit_time_spaces_frames_and_stopped_holds_them() {
    let mut bench = Bench::new();
    // 1015h = 50 × 100 µs = 5 ms.
    bench.sdo1(&req(0x2B, 0x1015, 0, [50, 0, 0, 0]));
    bench.drive().raise_error(0x1000, ErrorRegister::empty(), [0; 5]);
    bench.drive().raise_error(0x2000, ErrorRegister::CURRENT, [0; 5]);
    let start = bench.now();
    assert_eq!(bench.advance(Duration::ZERO).len(), 1);
    assert!(bench.advance(Duration::from_micros(4999)).is_empty());
    assert_eq!(bench.advance(Duration::from_micros(1)).len(), 1);
    assert_eq!(bench.now() - start, Duration::from_millis(5));
    // Stopped: the error is recorded but its EMCY waits for Pre-operational.
    bench.send(frame(0x000, &[0x02, NODE]));
    bench.drive().raise_error(0x3000, ErrorRegister::VOLTAGE, [0; 5]);
    assert!(bench.advance(Duration::from_millis(100)).is_empty());
    assert_eq!(bench.drive().error_register().bits(), 0x07);
    let frames = bench.send(frame(0x000, &[0x80, NODE]));
    assert_eq!(frames, vec![emcy([0x00, 0x30, 0x07, 0, 0, 0, 0, 0])]);
}

#[test]
fn a_reset_node_forgets_the_active_errors_and_a_fault_after_it_is_reported_again() {
    use canopen_drive::hal::HardwareFaults;
    use common::profile::{enable, node};
    let emcys = |frames: &[CanFrame]| {
        frames.iter().filter(|f| f.standard_id() == Some(0x80 + u16::from(NODE))).count()
    };
    let mut bench = Bench::new();
    enable(&mut bench, 3);
    node(&mut bench).motor.inject_fault(HardwareFaults::OVER_CURRENT);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(5))), 1, "the fault's EMCY");
    node(&mut bench).motor.clear_faults();
    bench.send(frame(0x000, &[0x81, NODE])); // reset node, the fault not reset
    bench.advance(Duration::from_millis(5));
    assert_eq!(
        bench.sdo1(&req(0x40, 0x1001, 0, [0; 4])),
        req(0x4F, 0x1001, 0, [0; 4]),
        "1001h after the reset"
    );
    enable(&mut bench, 3);
    node(&mut bench).motor.inject_fault(HardwareFaults::OVER_CURRENT);
    let frames = bench.advance(Duration::from_millis(5));
    assert_eq!(emcys(&frames), 1, "the same fault again: its EMCY again");
}

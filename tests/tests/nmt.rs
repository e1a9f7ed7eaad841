//! NMT slave and heartbeat producer on the virtual bus (CiA 301 §7.3, digest §3–4.1).

mod common;

use common::*;
use embedded_can::Frame;

use canopen_drive::comm::NmtState;
use canopen_drive::{CanFrame, Duration};

fn nmt(bench: &mut Bench, command: u8, node: u8) -> Vec<CanFrame> {
    bench.send(frame(0x000, &[command, node]))
}

fn heartbeat(state: u8) -> CanFrame {
    frame(ERROR_CONTROL, &[state])
}

#[test]
fn boot_up_then_pre_operational_and_silent_without_heartbeat() {
    let mut bench = Bench::new(); // checks the boot-up frame 0x705 [00], DLC 1
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
    assert!(bench.advance(Duration::from_millis(5000)).is_empty(), "1017h = 0: no heartbeat");
}

#[test]
fn heartbeat_at_the_configured_period_with_the_state_byte() {
    let mut bench = Bench::new();
    // Writing 1017h takes effect at once: the response, then the first heartbeat.
    let frames = bench.send(frame(SDO_RX, &req(0x2B, 0x1017, 0, [100, 0, 0, 0])));
    assert_eq!(frames, vec![frame(SDO_TX, &req(0x60, 0x1017, 0, [0; 4])), heartbeat(0x7F)]);
    let start = bench.now();
    let mut times = Vec::new();
    for _ in 0..5 {
        let frames = bench.advance(Duration::from_millis(100));
        assert_eq!(frames, vec![heartbeat(0x7F)]);
        times.push(bench.now() - start);
    }
    assert_eq!(times.last(), Some(&Duration::from_millis(500)));
    // 1017h = 0 stops it.
    bench.sdo1(&req(0x2B, 0x1017, 0, [0, 0, 0, 0]));
    assert!(bench.advance(Duration::from_millis(1000)).is_empty());
}

#[test]
fn commands_change_state_and_the_heartbeat_reports_it() {
    let mut bench = Bench::new();
    bench.sdo1(&req(0x2B, 0x1017, 0, [50, 0, 0, 0]));
    bench.advance(Duration::ZERO);
    // Each state change is reported at once; entering Operational also sends the
    // event-driven TPDOs once (TPDO1 statusword, TPDO2 statusword + mode display).
    let tpdos = [frame(0x185, &[0x40, 0x02]), frame(0x285, &[0x40, 0x02, 0x00])];
    assert_eq!(nmt(&mut bench, 0x01, NODE), [&tpdos[..], &[heartbeat(0x05)]].concat());
    assert_eq!(bench.drive().nmt_state(), NmtState::Operational);
    assert_eq!(bench.advance(Duration::from_millis(50)), vec![heartbeat(0x05)]);
    assert_eq!(nmt(&mut bench, 0x02, 0), vec![heartbeat(0x04)], "broadcast stop");
    assert_eq!(bench.drive().nmt_state(), NmtState::Stopped);
    assert_eq!(bench.advance(Duration::from_millis(50)), vec![heartbeat(0x04)]);
    // Stopped: no SDO answer at all, not even an abort.
    assert!(bench.sdo(&req(0x40, 0x1000, 0, [0; 4])).is_empty());
    assert!(bench.sdo(&req(0x40, 0x3000, 0, [0; 4])).is_empty());
    assert_eq!(nmt(&mut bench, 0x80, NODE), vec![heartbeat(0x7F)]);
    assert_eq!(bench.sdo1(&req(0x40, 0x1000, 0, [0; 4]))[0], 0x43);
    assert_eq!(nmt(&mut bench, 0x01, NODE), [&tpdos[..], &[heartbeat(0x05)]].concat());
    assert_eq!(nmt(&mut bench, 0x80, 0), vec![heartbeat(0x7F)]);
    // The same state again: nothing happens.
    assert!(nmt(&mut bench, 0x80, NODE).is_empty());
}

#[test]
fn commands_for_others_and_malformed_frames_are_ignored() {
    let mut bench = Bench::new();
    nmt(&mut bench, 0x01, NODE + 1);
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
    bench.send(frame(0x000, &[0x01]));
    bench.send(frame(0x000, &[0x01, NODE, 0]));
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
    bench.send(frame(0x000, &[0x42, NODE]));
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
    // A remote frame on the NMT identifier is not a command either.
    bench.send(CanFrame::new_remote_standard(0x000, 2).unwrap());
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
}

#[test]
fn reset_communication_restores_only_the_communication_area() {
    let mut bench = Bench::new();
    bench.sdo1(&req(0x2B, 0x1017, 0, [100, 0, 0, 0]));
    bench.sdo1(&req(0x2F, LIMITED, 0, [12, 0, 0, 0]));
    nmt(&mut bench, 0x01, NODE);
    bench.advance(Duration::ZERO);
    let frames = nmt(&mut bench, 0x82, NODE);
    assert_eq!(frames, vec![frame(ERROR_CONTROL, &[0x00])], "boot-up, no heartbeat");
    assert_eq!(frames[0].dlc(), 1);
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
    assert_eq!(bench.drive().od().get::<u16>(0x1017, 0), Ok(0));
    assert!(bench.advance(Duration::from_millis(500)).is_empty());
    assert_eq!(bench.drive().od().get::<u8>(LIMITED, 0), Ok(12), "2000h–5FFFh kept");
}

#[test]
fn reset_node_restores_the_whole_dictionary() {
    let mut bench = Bench::new();
    bench.sdo1(&req(0x2B, 0x1017, 0, [100, 0, 0, 0]));
    bench.sdo1(&req(0x2F, LIMITED, 0, [12, 0, 0, 0]));
    let frames = nmt(&mut bench, 0x81, 0);
    assert_eq!(frames, vec![frame(ERROR_CONTROL, &[0x00])]);
    assert_eq!(bench.drive().od().get::<u16>(0x1017, 0), Ok(0));
    assert_eq!(bench.drive().od().get::<u8>(LIMITED, 0), Ok(15));
    assert_eq!(
        bench.sdo1(&req(0x40, TEXT, 0, [0; 4]))[..5],
        [0x41, 0x00, 0x20, 0x00, DEFAULT_TEXT.len() as u8]
    );
}

#[test]
fn leaving_the_sdo_states_drops_a_transfer_without_a_frame() {
    let mut bench = Bench::new();
    bench.sdo1(&req(0x21, TEXT, 0, [10, 0, 0, 0]));
    assert!(sdo_data(&nmt(&mut bench, 0x02, NODE)).is_empty());
    nmt(&mut bench, 0x80, NODE);
    // No transfer any more: a segment is a protocol error, and no timeout follows.
    assert_eq!(bench.sdo1(&[0x00, 1, 2, 3, 4, 5, 6, 7]), abort(0, 0, 0x0504_0001));
    assert!(sdo_data(&bench.advance(Duration::from_millis(2000))).is_empty());
}

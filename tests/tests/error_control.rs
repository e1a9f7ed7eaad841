//! Heartbeat consumer, node/life guarding, error behaviour 1029h and CAN controller states on
//! the virtual bus (CiA 301 §7.2.8, digest §4).

mod common;

use common::*;

use canopen_drive::comm::NmtState;
use canopen_drive::drive::{CanState, ConnectionEvent};
use canopen_drive::{CanFrame, Duration};

const EMCY: u16 = 0x080 + NODE as u16;

fn emcy(data: [u8; 8]) -> CanFrame {
    frame(EMCY, &data)
}

fn operational(bench: &mut Bench) {
    bench.send(frame(0x000, &[0x01, NODE]));
    assert_eq!(bench.drive().nmt_state(), NmtState::Operational);
}

fn consume_node_3(bench: &mut Bench, ms: u16) {
    let [lo, hi] = ms.to_le_bytes();
    assert_eq!(bench.sdo1(&req(0x23, 0x1016, 1, [lo, hi, 3, 0])), req(0x60, 0x1016, 1, [0; 4]));
}

#[test]
fn heartbeat_timeout_raises_8130_and_enters_pre_operational() {
    let mut bench = Bench::new();
    consume_node_3(&mut bench, 100);
    operational(&mut bench);
    // Not supervised before the first heartbeat.
    assert!(bench.advance(Duration::from_millis(1000)).is_empty());
    assert!(bench.send(frame(0x703, &[0x05])).is_empty());
    assert!(bench.advance(Duration::from_millis(99)).is_empty());
    assert!(bench.send(frame(0x703, &[0x05])).is_empty());
    // Silence for 100 ms: EMCY with the node-ID in the manufacturer field, 1029h = 0 → Pre-op.
    assert!(bench.advance(Duration::from_millis(99)).is_empty());
    assert_eq!(bench.advance(Duration::from_millis(1)), vec![emcy([0x30, 0x81, 0x11, 3, 0, 0, 0, 0])]);
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
    assert_eq!(bench.drive().take_connection_event(), Some(ConnectionEvent::HeartbeatLost));
    // The node is heard again: error reset.
    assert_eq!(bench.send(frame(0x703, &[0x7F])), vec![emcy([0, 0, 0, 0, 0, 0, 0, 0])]);
    // Other nodes' heartbeats do not feed it.
    assert!(bench.send(frame(0x704, &[0x05])).is_empty());
    assert_eq!(bench.advance(Duration::from_millis(100)), vec![emcy([0x30, 0x81, 0x11, 3, 0, 0, 0, 0])]);
}

#[test]
fn remote_reset_of_a_supervised_node_is_reported() {
    let mut bench = Bench::new();
    consume_node_3(&mut bench, 100);
    bench.send(frame(0x703, &[0x05]));
    assert_eq!(bench.send(frame(0x703, &[0x00])), vec![emcy([0x30, 0x81, 0x11, 3, 0, 0, 0, 0])]);
    // Waiting for the next heartbeat: no timeout meanwhile.
    assert!(bench.advance(Duration::from_millis(500)).is_empty());
}

#[test]
fn duplicate_consumer_entries_are_refused() {
    let mut bench = Bench::new();
    consume_node_3(&mut bench, 100);
    assert_eq!(bench.sdo1(&req(0x23, 0x1016, 2, [200, 0, 3, 0])), abort(0x1016, 2, 0x0604_0043));
    // Rewriting the same entry, or node 3 with time 0 elsewhere, is fine.
    assert_eq!(bench.sdo1(&req(0x23, 0x1016, 1, [200, 0, 3, 0])), req(0x60, 0x1016, 1, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x23, 0x1016, 2, [0, 0, 3, 0])), req(0x60, 0x1016, 2, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1016, 0, [0; 4])), req(0x4F, 0x1016, 0, [4, 0, 0, 0]));
}

#[test]
fn error_behaviour_selects_the_nmt_reaction() {
    // 1029h sub 1: 0 = Pre-op (only from Operational), 1 = no change, 2 = Stopped.
    for (value, from, expected) in [
        (0u8, NmtState::Operational, NmtState::PreOperational),
        (0, NmtState::PreOperational, NmtState::PreOperational),
        (1, NmtState::Operational, NmtState::Operational),
        (2, NmtState::Operational, NmtState::Stopped),
        (2, NmtState::PreOperational, NmtState::Stopped),
        (0x80, NmtState::Operational, NmtState::Operational),
    ] {
        let mut bench = Bench::new();
        assert_eq!(bench.sdo1(&req(0x2F, 0x1029, 1, [value, 0, 0, 0])), req(0x60, 0x1029, 1, [0; 4]));
        consume_node_3(&mut bench, 50);
        if from == NmtState::Operational {
            operational(&mut bench);
        }
        bench.send(frame(0x703, &[0x05]));
        bench.advance(Duration::from_millis(60));
        assert_eq!(bench.drive().nmt_state(), expected, "1029h = {value:#x} from {from:?}");
    }
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x2F, 0x1029, 1, [3, 0, 0, 0])), abort(0x1029, 1, 0x0609_0030));
    assert_eq!(bench.sdo1(&req(0x40, 0x1029, 0, [0; 4])), req(0x4F, 0x1029, 0, [1, 0, 0, 0]));
}

#[test]
fn node_guarding_answers_with_toggle_and_life_guarding_supervises() {
    let mut bench = Bench::new();
    let rtr = CanFrame::new_remote_standard(ERROR_CONTROL, 1).unwrap();
    assert_eq!(bench.send(rtr), vec![frame(ERROR_CONTROL, &[0x7F])]);
    assert_eq!(bench.send(rtr), vec![frame(ERROR_CONTROL, &[0xFF])]);
    operational(&mut bench);
    assert_eq!(bench.send(rtr), vec![frame(ERROR_CONTROL, &[0x05])]);
    // Life time = 100 ms × 3.
    bench.sdo1(&req(0x2B, 0x100C, 0, [100, 0, 0, 0]));
    bench.sdo1(&req(0x2F, 0x100D, 0, [3, 0, 0, 0]));
    assert_eq!(bench.send(rtr), vec![frame(ERROR_CONTROL, &[0x85])]);
    assert!(bench.advance(Duration::from_millis(299)).is_empty());
    assert_eq!(bench.advance(Duration::from_millis(1)), vec![emcy([0x30, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(bench.drive().take_connection_event(), Some(ConnectionEvent::LifeGuardingLost));
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational);
    // The next request clears the error.
    assert_eq!(bench.send(rtr), vec![frame(ERROR_CONTROL, &[0x7F]), emcy([0; 8])]);
    // With a heartbeat producer configured, guarding requests are not answered.
    bench.sdo1(&req(0x2B, 0x1017, 0, [0xE8, 0x03, 0, 0]));
    bench.advance(Duration::ZERO);
    assert!(bench.send(rtr).is_empty());
    // Reset communication returns the toggle to 0.
    bench.send(frame(0x000, &[0x82, NODE]));
    assert_eq!(bench.send(rtr), vec![frame(ERROR_CONTROL, &[0x7F])]);
}

#[test]
fn can_controller_states() {
    let mut bench = Bench::new();
    operational(&mut bench);
    let now = bench.now();
    bench.drive().on_can_state(CanState::ErrorPassive, now);
    assert_eq!(bench.advance(Duration::ZERO), vec![emcy([0x20, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    let now = bench.now();
    bench.drive().on_can_state(CanState::BusOff, now);
    assert_eq!(bench.drive().take_connection_event(), Some(ConnectionEvent::BusOff));
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational, "1029h = 0");
    assert!(bench.advance(Duration::ZERO).is_empty(), "nothing while bus-off");
    let now = bench.now();
    bench.drive().on_can_state(CanState::ErrorActive, now);
    assert_eq!(
        bench.advance(Duration::ZERO),
        vec![emcy([0, 0, 0, 0, 0, 0, 0, 0]), emcy([0x40, 0x81, 0x11, 0, 0, 0, 0, 0]), emcy([0; 8])]
    );
    let now = bench.now();
    bench.drive().on_can_state(CanState::Overrun, now);
    assert_eq!(bench.advance(Duration::ZERO), vec![emcy([0x10, 0x81, 0x11, 0, 0, 0, 0, 0]), emcy([0; 8])]);
}

#[test]
fn nmt_events_reach_the_connection_reaction() {
    let mut bench = Bench::new();
    assert_eq!(bench.drive().take_connection_event(), None);
    bench.send(frame(0x000, &[0x02, 0]));
    assert_eq!(bench.drive().take_connection_event(), Some(ConnectionEvent::NmtStopped));
    bench.send(frame(0x000, &[0x82, 0]));
    assert_eq!(bench.drive().take_connection_event(), Some(ConnectionEvent::ResetCommunication));
    bench.send(frame(0x000, &[0x81, 0]));
    assert_eq!(bench.drive().take_connection_event(), Some(ConnectionEvent::ResetApplication));
}

/// The frames of the node's EMCY identifier among `frames`, as data.
fn emcy_data(frames: &[CanFrame]) -> Vec<Vec<u8>> {
    frames
        .iter()
        .filter(|f| f.standard_id() == Some(EMCY))
        .map(|f| embedded_can::Frame::data(f).to_vec())
        .collect()
}

#[test]
fn the_heartbeat_timeout_emcy_goes_out_before_a_reaction_into_stopped() {
    // Issue 18 (11): the error happens while the node is Operational; its EMCY goes out before
    // 1029h = 2 (Stopped) silences the node, not after the next NMT Pre-operational.
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x2F, 0x1029, 1, [2, 0, 0, 0])), req(0x60, 0x1029, 1, [0; 4]));
    consume_node_3(&mut bench, 100);
    operational(&mut bench);
    bench.send(frame(0x703, &[0x05]));
    let frames = bench.advance(Duration::from_millis(100));
    assert_eq!(emcy_data(&frames), vec![vec![0x30, 0x81, 0x11, 3, 0, 0, 0, 0]]);
    assert_eq!(bench.drive().nmt_state(), NmtState::Stopped);
    // Nothing is left over for the node's return.
    bench.send(frame(0x000, &[0x80, NODE]));
    assert!(emcy_data(&bench.advance(Duration::from_millis(5))).is_empty());
}

#[test]
fn the_fault_of_a_lost_connection_is_reported_and_its_reset_sends_0000h() {
    // Issue 18 (10): 6007h = 1 faults the axis; the fault has its EMCY (8100h, 1003h) and the
    // fault reset its "error reset", as any fault. In Stopped the EMCY waits for the node to
    // be allowed to send again.
    use canopen_drive::cia402::fsa::State;
    use common::profile::{cw, enable_pv};
    let mut bench = Bench::new();
    operational(&mut bench);
    enable_pv(&mut bench);
    bench.send(frame(0x000, &[0x02, NODE]));
    let frames = bench.advance(Duration::from_millis(20));
    assert_eq!(bench.drive().state(), State::Fault);
    assert!(emcy_data(&frames).is_empty(), "Stopped: no EMCY yet");
    let mut frames = bench.send(frame(0x000, &[0x80, NODE]));
    frames.extend(bench.advance(Duration::from_millis(5)));
    // Error register: generic, communication, device profile.
    assert_eq!(emcy_data(&frames), vec![vec![0x00, 0x81, 0x31, 0, 0, 0, 0, 0]]);
    assert_eq!(bench.sdo1(&req(0x40, 0x1003, 1, [0; 4])), req(0x43, 0x1003, 1, [0x00, 0x81, 0, 0]));
    write_controlword_and_collect(&mut bench, &mut frames);
    assert_eq!(emcy_data(&frames), vec![vec![0; 8]], "fault reset: 0000h");
    cw(&mut bench, 0x0000, 2);
}

/// Fault reset (controlword 80h); the frames of the next ticks into `frames` (cleared first).
fn write_controlword_and_collect(bench: &mut Bench, frames: &mut Vec<CanFrame>) {
    frames.clear();
    frames.extend(bench.send(frame(0x600 + u16::from(NODE), &req(0x2B, 0x6040, 0, [0x80, 0, 0, 0]))));
    frames.extend(bench.advance(Duration::from_millis(5)));
}

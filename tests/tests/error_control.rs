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

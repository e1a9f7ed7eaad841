//! The CiA 303-3 indicators of a drive on the virtual bus: the RUN and ERR patterns a board
//! drives its LEDs with, after the frames and controller states that change them.

mod common;

use common::*;

use canopen_drive::comm::indicators::{Leds, Pattern};
use canopen_drive::drive::CanState;
use canopen_drive::{Duration, Instant};

/// The (RUN, ERR) patterns the drive shows now.
fn patterns(bench: &mut Bench) -> (Pattern, Pattern) {
    let status = bench.drive().node_status();
    (status.run(), status.err())
}

#[test]
fn run_follows_the_nmt_state() {
    let mut bench = Bench::new();
    assert_eq!(patterns(&mut bench), (Pattern::Blinking, Pattern::Off), "pre-operational after boot-up");
    bench.send(frame(0x000, &[0x01, NODE]));
    assert_eq!(patterns(&mut bench), (Pattern::On, Pattern::Off));
    bench.send(frame(0x000, &[0x02, NODE]));
    assert_eq!(patterns(&mut bench), (Pattern::SingleFlash, Pattern::Off));
    bench.send(frame(0x000, &[0x80, NODE]));
    assert_eq!(patterns(&mut bench), (Pattern::Blinking, Pattern::Off));
    // What the LEDs show, sampled with the drive's clock: blinking, 200 ms on, 200 ms off.
    let status = bench.drive().node_status();
    let at = |ms| status.leds(Instant::from_millis(ms));
    assert_eq!([at(10_000), at(10_199), at(10_200), at(10_399)].map(|l| l.run), [true, true, false, false]);
    assert_eq!(at(10_000), Leds { run: true, err: false });
}

#[test]
fn lss_configuration_flickers_run() {
    let mut bench = Bench::new();
    // LSS switch state global: configuration.
    bench.send(frame(0x7E5, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]));
    assert_eq!(patterns(&mut bench), (Pattern::Flickering, Pattern::Off));
    bench.send(frame(0x7E5, &[0x04, 0x00, 0, 0, 0, 0, 0, 0]));
    assert_eq!(patterns(&mut bench), (Pattern::Blinking, Pattern::Off));
}

#[test]
fn err_shows_controller_states() {
    let mut bench = Bench::new();
    let report = |bench: &mut Bench, state| {
        let now = bench.now();
        bench.drive().on_can_state(state, now);
        bench.advance(Duration::ZERO);
        patterns(bench).1
    };
    assert_eq!(report(&mut bench, CanState::WarningLimit), Pattern::SingleFlash);
    assert_eq!(report(&mut bench, CanState::ErrorPassive), Pattern::SingleFlash);
    assert_eq!(report(&mut bench, CanState::WarningLimit), Pattern::SingleFlash);
    assert_eq!(report(&mut bench, CanState::BusOff), Pattern::On);
    assert_eq!(report(&mut bench, CanState::ErrorActive), Pattern::Off);
}

#[test]
fn warning_limit_sends_no_emcy_and_clears_error_passive() {
    let mut bench = Bench::new();
    let now = bench.now();
    bench.drive().on_can_state(CanState::WarningLimit, now);
    assert!(bench.advance(Duration::ZERO).is_empty());
    bench.drive().on_can_state(CanState::ErrorPassive, now);
    assert_eq!(bench.advance(Duration::ZERO), vec![frame(0x085, &[0x20, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    // Down to the warning limit: error passive is over (error reset), the warning stays.
    let now = bench.now();
    bench.drive().on_can_state(CanState::WarningLimit, now);
    assert_eq!(bench.advance(Duration::ZERO), vec![frame(0x085, &[0; 8])]);
    assert_eq!(patterns(&mut bench).1, Pattern::SingleFlash);
}

#[test]
fn err_shows_error_control_sync_and_rpdo_timeouts_while_they_last() {
    let mut bench = Bench::new();
    // Heartbeat of node 3 consumed with 100 ms, SYNC expected every 10 ms, RPDO 1 within
    // 100 ms (event timer).
    assert_eq!(bench.sdo1(&req(0x23, 0x1016, 1, [100, 0, 3, 0])), req(0x60, 0x1016, 1, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x23, 0x1006, 0, [0x10, 0x27, 0, 0])), req(0x60, 0x1006, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x2B, 0x1400, 5, [100, 0, 0, 0])), req(0x60, 0x1400, 5, [0; 4]));
    // 1029h sub 1 = 1: no change of the NMT state on a communication error.
    assert_eq!(bench.sdo1(&req(0x2F, 0x1029, 1, [1, 0, 0, 0])), req(0x60, 0x1029, 1, [0; 4]));
    bench.send(frame(0x000, &[0x01, NODE]));
    bench.send(frame(0x703, &[0x05]));
    bench.send(frame(0x080, &[]));
    assert_eq!(patterns(&mut bench), (Pattern::On, Pattern::Off));
    // SYNC silent for more than 1.5 periods: lost.
    bench.advance(Duration::from_millis(16));
    assert_eq!(patterns(&mut bench).1, Pattern::TripleFlash);
    bench.send(frame(0x080, &[]));
    assert_eq!(patterns(&mut bench).1, Pattern::Off, "SYNC back");
    // The RPDO, 16 ms after the heartbeat. The heartbeat silent for 100 ms (the SYNC kept
    // up): an error control event.
    bench.send(frame(0x205, &[0, 0]));
    for _ in 0..9 {
        bench.advance(Duration::from_millis(10));
        bench.send(frame(0x080, &[]));
    }
    assert_eq!(patterns(&mut bench).1, Pattern::DoubleFlash);
    // The RPDO's event time passed as well: its timeout has the higher priority.
    bench.advance(Duration::from_millis(10));
    bench.send(frame(0x080, &[]));
    assert_eq!(patterns(&mut bench).1, Pattern::QuadrupleFlash);
    // The RPDO again (its error reset), then the heartbeat.
    bench.send(frame(0x205, &[0, 0]));
    assert_eq!(patterns(&mut bench).1, Pattern::DoubleFlash);
    bench.send(frame(0x703, &[0x05]));
    assert_eq!(patterns(&mut bench), (Pattern::On, Pattern::Off));
}

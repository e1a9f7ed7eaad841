//! The board's part of LSS and CAN error handling, through `run_until_bit_rate_change` and its
//! hooks, on the host: a mock CAN driver, embassy-time's mock clock and a hand-turned
//! executor. An LSS store reaches the board, an LSS bit-rate activation ends the runner
//! before anything else is sent (and the runner picks up again when called again), the
//! controller's error states reach the drive as their EMCYs, and the plain `run` leaves the
//! LSS requests in the drive.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

use std::cell::{Cell, RefCell};
use std::future::Future;
use std::pin::{pin, Pin};
use std::rc::Rc;
use std::sync::Mutex;
use std::task::{Context, Poll, Waker};

use canopen_drive::drive::BitRateChange;
use canopen_drive::wire::lss::{BitRate, BitTiming};
use canopen_drive::{CanFrame, Config, Drive};
use canopen_drive_embassy::{
    run, run_until_bit_rate_change, BusState, RunnerHooks, SharedDrive, BUS_STATE_PERIOD,
};
use embassy_time::{Duration, MockDriver};

/// The mock clock is global: one test at a time.
static CLOCK: Mutex<()> = Mutex::new(());

mod common;
use common::Wire;

const NODE: u8 = 4;
const LSS_REQUEST: u16 = 0x7E5;
const LSS_RESPONSE: u16 = 0x7E4;
const EMCY: u16 = 0x80 + NODE as u16;
const HEARTBEAT: u16 = 0x700 + NODE as u16;

/// An LSS store as the board gets it: node-ID and bit timing.
type LssStore = (u8, Option<BitTiming>);

/// The board: a controller state the test sets, and the LSS stores it was given.
#[derive(Clone, Default)]
struct Board {
    state: Rc<Cell<Option<BusState>>>,
    asked: Rc<Cell<usize>>,
    stored: Rc<RefCell<Vec<LssStore>>>,
}

impl RunnerHooks for Board {
    fn bus_state(&mut self) -> Option<BusState> {
        self.asked.set(self.asked.get() + 1);
        self.state.get()
    }

    fn store_lss(&mut self, node_id: u8, bit_timing: Option<BitTiming>) {
        self.stored.borrow_mut().push((node_id, bit_timing));
    }
}

fn drive() -> SharedDrive<Drive> {
    let shared = SharedDrive::new();
    shared.put(Drive::new(Config { lss_store: true, ..Config::new(NODE) }).unwrap());
    shared
}

/// Turns `runner` once per ms of mock time for `ms` ms; its output if it ended.
fn step<F: Future>(runner: &mut Pin<&mut F>, ms: u64) -> Option<F::Output> {
    let mut cx = Context::from_waker(Waker::noop());
    for _ in 0..ms {
        if let Poll::Ready(out) = runner.as_mut().poll(&mut cx) {
            return Some(out);
        }
        MockDriver::get().advance(Duration::from_millis(1));
    }
    match runner.as_mut().poll(&mut cx) {
        Poll::Ready(out) => Some(out),
        Poll::Pending => None,
    }
}

fn lss(cs: u8, bytes: &[u8]) -> [u8; 8] {
    let mut frame = [0u8; 8];
    frame[0] = cs;
    frame[1..1 + bytes.len()].copy_from_slice(bytes);
    frame
}

#[test]
fn an_lss_store_reaches_the_board_and_a_bit_rate_activation_ends_the_runner() {
    let _clock = CLOCK.lock().unwrap_or_else(|e| e.into_inner());
    MockDriver::get().reset();
    let shared = drive();
    let wire = Wire::default();
    let board = Board::default();
    let (mut rx, mut tx, mut hooks) = (wire.clone(), wire.clone(), board.clone());
    {
        let mut runner = pin!(run_until_bit_rate_change(&shared, &mut rx, &mut tx, &mut hooks));
        assert_eq!(step(&mut runner, 1), None);
        assert_eq!(wire.take(HEARTBEAT), vec![vec![0u8]], "boot-up");
        // Heartbeat every 10 ms, so that the drive has something to send at any moment.
        wire.send(0x600 + u16::from(NODE), &[0x2B, 0x17, 0x10, 0x00, 10, 0, 0, 0]);
        assert_eq!(step(&mut runner, 1), None);
        assert_eq!(wire.take(0x580 + u16::from(NODE)), vec![vec![0x60, 0x17, 0x10, 0, 0, 0, 0, 0]]);

        // Configuration state, node-ID 9, 250 kbit/s, store.
        wire.send(LSS_REQUEST, &lss(0x04, &[1]));
        wire.send(LSS_REQUEST, &lss(0x11, &[9]));
        wire.send(LSS_REQUEST, &lss(0x13, &[0, BitRate::Kbit250.index()]));
        wire.send(LSS_REQUEST, &lss(0x17, &[]));
        assert_eq!(step(&mut runner, 5), None);
        assert_eq!(wire.take(LSS_RESPONSE), vec![lss(0x11, &[0]), lss(0x13, &[0]), lss(0x17, &[0])]);
        let timing = BitTiming::standard(BitRate::Kbit250);
        assert_eq!(*board.stored.borrow(), vec![(9, Some(timing))]);
        assert!(!wire.take(HEARTBEAT).is_empty());

        // Activate bit timing: the runner ends at the frame, with nothing sent after it.
        wire.send(LSS_REQUEST, &lss(0x15, &100u16.to_le_bytes()));
        let change = step(&mut runner, 50);
        assert_eq!(change, Some(BitRateChange { bit_timing: timing, switch_delay_ms: 100 }));
        assert_eq!(wire.take_all(), Vec::<CanFrame>::new());
    }

    // The board switches (here: nothing to do) and calls the runner again: the node goes on,
    // at its old node-ID until a reset communication.
    MockDriver::get().advance(Duration::from_millis(200));
    let mut runner = pin!(run_until_bit_rate_change(&shared, &mut rx, &mut tx, &mut hooks));
    assert_eq!(step(&mut runner, 50), None);
    let beats = wire.take(HEARTBEAT);
    assert!((4..=6).contains(&beats.len()), "{} heartbeats in 50 ms at 10 ms", beats.len());
    assert_eq!(board.stored.borrow().len(), 1);
}

#[test]
fn bus_states_reach_the_drive_as_their_emcys() {
    let _clock = CLOCK.lock().unwrap_or_else(|e| e.into_inner());
    MockDriver::get().reset();
    let shared = drive();
    let wire = Wire::default();
    let board = Board::default();
    board.state.set(Some(BusState::ErrorActive));
    let (mut rx, mut tx, mut hooks) = (wire.clone(), wire.clone(), board.clone());
    let mut runner = pin!(run_until_bit_rate_change(&shared, &mut rx, &mut tx, &mut hooks));
    assert_eq!(step(&mut runner, 10), None);
    wire.take(HEARTBEAT);
    assert_eq!(wire.take(EMCY), Vec::<Vec<u8>>::new(), "error active: nothing to report");
    let asked = board.asked.get();
    let expected = 10 / BUS_STATE_PERIOD.as_millis() as usize;
    assert!((expected..=expected + 2).contains(&asked), "asked {asked} times in 10 ms");

    let code = |frames: Vec<Vec<u8>>| -> Vec<u16> {
        frames.iter().map(|f| u16::from_le_bytes([f[0], f[1]])).collect()
    };
    board.state.set(Some(BusState::ErrorPassive));
    assert_eq!(step(&mut runner, 2), None);
    assert_eq!(code(wire.take(EMCY)), vec![0x8120], "CAN in error passive");
    assert_eq!(step(&mut runner, 5), None);
    assert_eq!(wire.take(EMCY), Vec::<Vec<u8>>::new(), "reported once");

    board.state.set(Some(BusState::BusOff));
    assert_eq!(step(&mut runner, 2), None);
    board.state.set(Some(BusState::ErrorActive));
    assert_eq!(step(&mut runner, 2), None);
    // Back to error active: 8120h is reset, then the recovery from bus-off is reported.
    let codes = code(wire.take(EMCY));
    assert!(codes.contains(&0x8140), "recovered from bus-off: {codes:04X?}");
    assert_eq!(codes.last(), Some(&0x0000), "every error reset: {codes:04X?}");
}

#[test]
fn a_driver_that_cannot_tell_its_state_is_asked_once() {
    let _clock = CLOCK.lock().unwrap_or_else(|e| e.into_inner());
    MockDriver::get().reset();
    let shared = drive();
    let wire = Wire::default();
    let board = Board::default();
    let (mut rx, mut tx, mut hooks) = (wire.clone(), wire.clone(), board.clone());
    let mut runner = pin!(run_until_bit_rate_change(&shared, &mut rx, &mut tx, &mut hooks));
    assert_eq!(step(&mut runner, 20), None);
    assert_eq!(board.asked.get(), 1);
}

#[test]
fn run_leaves_the_lss_requests_in_the_drive() {
    let _clock = CLOCK.lock().unwrap_or_else(|e| e.into_inner());
    MockDriver::get().reset();
    let shared = drive();
    let wire = Wire::default();
    let mut runner = pin!(run(&shared, wire.clone(), wire.clone()));
    let mut cx = Context::from_waker(Waker::noop());
    for request in [lss(0x04, &[1]), lss(0x13, &[0, 2]), lss(0x17, &[]), lss(0x15, &[50, 0])] {
        wire.send(LSS_REQUEST, &request);
        assert!(runner.as_mut().poll(&mut cx).is_pending());
        MockDriver::get().advance(Duration::from_millis(1));
    }
    assert!(runner.as_mut().poll(&mut cx).is_pending(), "run does not end");
    let timing = BitTiming::standard(BitRate::Kbit500);
    assert_eq!(shared.with(|d| d.take_lss_store()), Some(Some((NODE, Some(timing)))));
    let change = BitRateChange { bit_timing: timing, switch_delay_ms: 50 };
    assert_eq!(shared.with(|d| d.take_bit_rate_change()), Some(Some(change)));
}

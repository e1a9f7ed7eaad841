//! The runner on the host: a mock CAN driver, embassy-time's mock clock, and a hand-turned
//! executor. Checks that frames flow both ways, that `poll` runs at its deadline, that the tick
//! wakes the runner, and the discipline the crate docs promise: every critical section is one
//! call whose work is bounded, even in the middle of a long block upload, so a tick is never
//! held off by more than one such call (boards/qemu-mps2 turns this bound into microseconds).

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

use std::collections::VecDeque;
use std::future::Future;
use std::pin::pin;
use std::sync::Mutex;
use std::task::{Context, Waker};

use canopen_drive::comm::sdo_server::MAX_BLOCK_SIZE;
use canopen_drive::drive::TX_QUEUE;
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::{layout, AbortCode, DataType, Object, ObjectHooks, Var};
use canopen_drive::wire::crc;
use canopen_drive::{CanFrame, Config, Drive, Instant};
use canopen_drive_embassy::{run, Endpoints, SharedDrive, Tick};
use embassy_time::{Duration, MockDriver};

/// The mock clock is global: one test at a time.
static CLOCK: Mutex<()> = Mutex::new(());

mod common;
use common::Wire;

const NODE: u8 = 4;
const PATTERN: u16 = 0x2F10;
const PATTERN_LEN: usize = 16 * 1024;

static OBJECTS: [Object; 1] =
    layout([Object::var(PATTERN, "Test pattern", Var::new("Test pattern", DataType::Domain))]);

fn pattern_byte(i: usize) -> u8 {
    (i.wrapping_mul(7) ^ (i >> 8)) as u8
}

/// Serves 2F10h, a long read-only DOMAIN computed on the fly, and counts the bytes read.
#[derive(Default)]
struct PatternHooks {
    bytes_read: usize,
}

impl ObjectHooks for PatternHooks {
    fn read_len(&mut self, index: u16, _sub: u8) -> Option<Result<usize, AbortCode>> {
        (index == PATTERN).then_some(Ok(PATTERN_LEN))
    }

    fn read(&mut self, _index: u16, _sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let n = buf.len().min(PATTERN_LEN.saturating_sub(offset));
        for (i, b) in buf[..n].iter_mut().enumerate() {
            *b = pattern_byte(offset + i);
        }
        self.bytes_read += n;
        Ok(n)
    }
}

/// The drive, metered: each `Endpoints` call is one critical section of `SharedDrive`; the
/// frames a call queues are moved to `out` at once, so each call's output is counted exactly.
struct Metered {
    drive: Drive<PatternHooks>,
    out: VecDeque<CanFrame>,
    calls: usize,
    most_frames_per_call: usize,
    most_bytes_per_call: usize,
    ticks: usize,
}

impl Metered {
    fn new() -> Self {
        let config = Config { manufacturer_objects: &OBJECTS, ..Config::new(NODE) };
        Metered {
            drive: Drive::with_hooks(config, PatternHooks::default()).unwrap(),
            out: VecDeque::new(),
            calls: 0,
            most_frames_per_call: 0,
            most_bytes_per_call: 0,
            ticks: 0,
        }
    }

    fn metered<R>(&mut self, f: impl FnOnce(&mut Drive<PatternHooks>) -> R) -> R {
        self.calls += 1;
        let bytes_before = self.drive.hooks_mut().bytes_read;
        let result = f(&mut self.drive);
        let mut frames = 0;
        while let Some(frame) = self.drive.pop_tx() {
            self.out.push_back(frame);
            frames += 1;
        }
        let bytes = self.drive.hooks_mut().bytes_read - bytes_before;
        self.most_frames_per_call = self.most_frames_per_call.max(frames);
        self.most_bytes_per_call = self.most_bytes_per_call.max(bytes);
        result
    }
}

impl Endpoints for Metered {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.metered(|d| d.on_frame(frame, now));
    }
    fn poll(&mut self, now: Instant) -> Option<Instant> {
        self.metered(|d| d.poll(now))
    }
    fn pop_tx(&mut self) -> Option<CanFrame> {
        self.out.pop_front()
    }
    fn has_tx(&self) -> bool {
        !self.out.is_empty()
    }
}

impl Tick for Metered {
    fn tick_axes(&mut self, now: Instant, samples: &[Sample; 1]) -> [Demand; 1] {
        self.ticks += 1;
        self.metered(|d| d.tick_axes(now, samples))
    }
}

/// Polls `run` once per step of `dt` mock time, for `steps` steps or until `done` says so.
struct Harness<'a> {
    wire: Wire,
    drive: &'a SharedDrive<Metered>,
}

fn sdo_rx() -> u16 {
    0x600 + u16::from(NODE)
}
fn sdo_tx() -> u16 {
    0x580 + u16::from(NODE)
}

#[test]
fn frames_flow_and_poll_runs_at_its_deadline() {
    let _clock = CLOCK.lock().unwrap_or_else(|e| e.into_inner());
    MockDriver::get().reset();
    let shared = SharedDrive::new();
    shared.put(Metered::new());
    let h = Harness { wire: Wire::default(), drive: &shared };
    let mut runner = pin!(run(h.drive, h.wire.clone(), h.wire.clone()));
    let mut cx = Context::from_waker(Waker::noop());
    let mut step = |ms: u64| {
        for _ in 0..ms {
            assert!(runner.as_mut().poll(&mut cx).is_pending());
            MockDriver::get().advance(Duration::from_millis(1));
        }
        assert!(runner.as_mut().poll(&mut cx).is_pending());
    };

    step(1);
    assert_eq!(h.wire.take(0x700 + u16::from(NODE)), vec![vec![0u8]], "boot-up");

    // Expedited upload of 1000h, then heartbeat every 50 ms.
    h.wire.send(sdo_rx(), &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]);
    step(1);
    assert_eq!(h.wire.take(sdo_tx()), vec![vec![0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]]);
    h.wire.send(sdo_rx(), &[0x2B, 0x17, 0x10, 0x00, 50, 0, 0, 0]);
    step(1);
    assert_eq!(h.wire.take(sdo_tx()), vec![vec![0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]]);
    h.wire.take(0x700 + u16::from(NODE));
    // Nothing arrives; only the deadline of `poll` can make these heartbeats.
    step(500);
    let beats = h.wire.take(0x700 + u16::from(NODE));
    assert!((9..=11).contains(&beats.len()), "{} heartbeats in 500 ms at 50 ms", beats.len());
    assert!(beats.iter().all(|b| b == &[0x7F]), "pre-operational heartbeats: {beats:?}");

    // A frame queued by the tick (an EMCY from a hardware fault) is sent without any frame
    // arriving: the tick wakes the runner.
    h.wire.take(0x80 + u16::from(NODE));
    let fault = Sample { faults: canopen_drive::hal::HardwareFaults::OVER_CURRENT, ..Sample::default() };
    h.drive.tick(canopen_drive_embassy::now(), &fault);
    assert!(runner.as_mut().poll(&mut cx).is_pending());
    assert!(!h.wire.take(0x80 + u16::from(NODE)).is_empty(), "EMCY sent after the tick");
    assert_eq!(h.drive.with(|m| m.ticks), Some(1));
}

#[test]
fn a_long_block_upload_is_many_short_critical_sections() {
    let _clock = CLOCK.lock().unwrap_or_else(|e| e.into_inner());
    MockDriver::get().reset();
    let shared = SharedDrive::new();
    shared.put(Metered::new());
    let h = Harness { wire: Wire::default(), drive: &shared };
    let mut runner = pin!(run(h.drive, h.wire.clone(), h.wire.clone()));
    let mut cx = Context::from_waker(Waker::noop());
    let mut turn = || {
        assert!(runner.as_mut().poll(&mut cx).is_pending());
        MockDriver::get().advance(Duration::from_micros(100));
    };
    turn();
    h.wire.take(0x700 + u16::from(NODE));

    // Block upload of 2F10h, CRC on, 127 segments per block, no protocol switch.
    let [lo, hi] = PATTERN.to_le_bytes();
    h.wire.send(sdo_rx(), &[0xA4, lo, hi, 0, 127, 0, 0, 0]);
    turn();
    let initiate = h.wire.take(sdo_tx());
    assert_eq!(initiate.len(), 1);
    assert_eq!(initiate[0][0] & 0xE3, 0xC2, "block upload initiate with size: {:02X?}", initiate[0]);
    assert_eq!(u32::from_le_bytes(initiate[0][4..8].try_into().unwrap()) as usize, PATTERN_LEN);
    h.wire.send(sdo_rx(), &[0xA3, 0, 0, 0, 0, 0, 0, 0]);

    let mut data = Vec::new();
    let mut block = Vec::new();
    let mut expect_end = false;
    let mut ticks = 0;
    let end = loop {
        turn();
        // The tick keeps running, once per turn, between the runner's critical sections.
        h.drive.tick(canopen_drive_embassy::now(), &Sample::default());
        ticks += 1;
        assert!(ticks < 100_000, "transfer stalled");
        let mut end = None;
        for f in h.wire.take(sdo_tx()) {
            if expect_end {
                end = Some(f);
                break;
            }
            assert_eq!(usize::from(f[0] & 0x7F), block.len() + 1, "segments in order");
            block.push(f[1..8].to_vec());
            let last_segment = f[0] & 0x80 != 0;
            if last_segment || block.len() == 127 {
                let acked = block.len() as u8;
                data.extend(block.drain(..).flatten());
                h.wire.send(sdo_rx(), &[0xA2, acked, 127, 0, 0, 0, 0, 0]);
                expect_end = last_segment;
            }
        }
        if let Some(end) = end {
            break end;
        }
    };
    assert_eq!(end[0] & 0xE3, 0xC1, "end block upload");
    let unused = usize::from((end[0] >> 2) & 7);
    data.truncate(data.len() - unused);
    assert_eq!(data.len(), PATTERN_LEN);
    assert!(data.iter().enumerate().all(|(i, b)| *b == pattern_byte(i)));
    assert_eq!(u16::from_le_bytes([end[1], end[2]]), crc::update(0, &data));
    h.wire.send(sdo_rx(), &[0xA1, 0, 0, 0, 0, 0, 0, 0]);
    turn();

    let (calls, frames, bytes) =
        h.drive.with(|m| (m.calls, m.most_frames_per_call, m.most_bytes_per_call)).unwrap();
    println!("{PATTERN_LEN} bytes in {calls} critical sections; at most {frames} frames and {bytes} value bytes per section");
    // The bound: no critical section queues more than the transmit queue holds, nor reads
    // more value bytes than one acknowledged sub-block (folded into the CRC at its
    // acknowledgement) and the segments it queues.
    assert!(frames <= TX_QUEUE, "{frames} frames in one call");
    assert!(bytes <= (usize::from(MAX_BLOCK_SIZE) + TX_QUEUE) * 7, "{bytes} bytes read in one call");
    assert!(calls > PATTERN_LEN / 7 / TX_QUEUE, "the transfer is split into many calls");
    assert_eq!(h.drive.with(|m| m.drive.tx_dropped()), Some(0));
}

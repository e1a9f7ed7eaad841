//! The runner yields to the executor while `poll` asks to be called at once, run by `run` on
//! the host with a mock CAN driver, embassy-time's mock clock (never advanced here) and a
//! hand-turned executor whose waker counts its wake-ups: each poll of the runner's future is
//! one turn of the executor, after which its other tasks run.
//!
//! - A bootloader node (the crate's `Bootloader` over a program area in RAM) erasing its area
//!   sector by sector: one sector a turn, and a frame that arrives meanwhile is answered
//!   while the clear goes on.
//! - A drive sending a block upload's sub-block while its tick interrupt comes during every
//!   transmission (the tick wakes the runner, as it may have queued frames): at most one
//!   transmit queue's worth of segments a turn. Before the runner yielded when `poll` asked at
//!   once, the tick's wake-up made its wait ready at once, and the whole sub-block (127
//!   segments) went out in one turn: no other task ran meanwhile.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

use std::collections::VecDeque;
use std::future::Future;
use std::pin::pin;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Wake, Waker};

use canopen_drive::bootloader::Bootloader;
use canopen_drive::drive::TX_QUEUE;
use canopen_drive::hal::Sample;
use canopen_drive::od::{layout, AbortCode, DataType, DeviceInfo, Object, ObjectHooks, Var};
use canopen_drive::storage::{NonVolatile, NvError};
use canopen_drive::{CanFrame, Config, Drive, Instant};
use canopen_drive_embassy::{run, CanTx, Endpoints, SharedDrive};
use embassy_time::MockDriver;

/// The mock clock is global: one test at a time.
static CLOCK: Mutex<()> = Mutex::new(());

mod common;
use common::Wire;

const NODE: u8 = 4;
const SECTOR: usize = 256;
const SECTORS: usize = 8;

/// A program area in RAM: 8 sectors of 256 bytes, 8-byte write units; all zero at first (a
/// used flash), so that each erased sector is seen.
struct RamArea(Vec<u8>);

impl NonVolatile for RamArea {
    fn capacity(&self) -> usize {
        self.0.len()
    }
    fn erase_size(&self) -> usize {
        SECTOR
    }
    fn write_size(&self) -> usize {
        8
    }
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), NvError> {
        let at = offset as usize;
        buf.copy_from_slice(self.0.get(at..at + buf.len()).ok_or(NvError::OutOfBounds)?);
        Ok(())
    }
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), NvError> {
        let at = offset as usize;
        self.0.get_mut(at..at + data.len()).ok_or(NvError::OutOfBounds)?.copy_from_slice(data);
        Ok(())
    }
    fn erase(&mut self, from: u32, to: u32) -> Result<(), NvError> {
        self.0.get_mut(from as usize..to as usize).ok_or(NvError::OutOfBounds)?.fill(0xFF);
        Ok(())
    }
}

/// The bootloader as the runner drives it; the frames it queues move to `out` after each
/// call (the bootloader has no look at its queue, which `has_tx` needs).
struct Node {
    boot: Bootloader<RamArea>,
    out: VecDeque<CanFrame>,
}

impl Node {
    /// Sectors of the area that read erased.
    fn erased_sectors(&mut self) -> usize {
        let area = self.boot.program().area();
        area.0.chunks(SECTOR).filter(|sector| sector.iter().all(|&b| b == 0xFF)).count()
    }

    fn queued(&mut self) {
        while let Some(frame) = self.boot.pop_tx() {
            self.out.push_back(frame);
        }
    }
}

impl Endpoints for Node {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.boot.on_frame(frame, now);
        self.queued();
    }
    fn poll(&mut self, now: Instant) -> Option<Instant> {
        let next = self.boot.poll(now);
        self.queued();
        next
    }
    fn pop_tx(&mut self) -> Option<CanFrame> {
        self.out.pop_front()
    }
    fn has_tx(&self) -> bool {
        !self.out.is_empty()
    }
}

/// The executor's side of the waker: how often the runner asked to be polled again.
#[derive(Default)]
struct WakeCount(AtomicUsize);

impl Wake for WakeCount {
    fn wake(self: Arc<Self>) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }
}

#[test]
fn a_clear_erases_one_sector_per_turn_and_a_frame_is_answered_between() {
    let _clock = CLOCK.lock().unwrap_or_else(|e| e.into_inner());
    MockDriver::get().reset();
    let area = RamArea(vec![0; SECTOR * SECTORS]);
    let device = DeviceInfo { software_version: "bootloader", ..DeviceInfo::servo_drive() };
    let shared: SharedDrive<Node> = SharedDrive::new();
    let boot = Bootloader::new(device, NODE, area, 64).unwrap();
    shared.put(Node { boot, out: VecDeque::new() });
    let wire = Wire::default();
    let mut runner = pin!(run(&shared, wire.clone(), wire.clone()));
    let wakes = Arc::new(WakeCount::default());
    let waker = Waker::from(wakes.clone());
    let mut cx = Context::from_waker(&waker);
    let woken = || wakes.0.load(Ordering::SeqCst);
    let erased = || shared.with(Node::erased_sectors).unwrap();
    let (sdo_rx, sdo_tx) = (0x600 + u16::from(NODE), 0x580 + u16::from(NODE));

    assert!(runner.as_mut().poll(&mut cx).is_pending());
    assert_eq!(wire.take(0x700 + u16::from(NODE)), vec![vec![0u8]], "boot-up");
    assert_eq!(erased(), 0);

    // Clear (1F51h:1 = 3): answered, then the area is erased by `poll`, one sector a pass.
    wire.send(sdo_rx, &[0x2F, 0x51, 0x1F, 1, 3, 0, 0, 0]);
    let before = woken();
    assert!(runner.as_mut().poll(&mut cx).is_pending());
    assert_eq!(wire.take(sdo_tx), vec![vec![0x60, 0x51, 0x1F, 1, 0, 0, 0, 0]], "clear accepted");
    assert!(erased() < SECTORS, "the runner returned to the executor before the clear ended");
    assert!(woken() > before, "and asked to be polled again at once");

    // A read of 1F57h:1 that arrives meanwhile is answered while the clear goes on: busy
    // (bit 0) and no valid program (code 1 in bits 1-7).
    wire.send(sdo_rx, &[0x40, 0x57, 0x1F, 1, 0, 0, 0, 0]);
    let before = (woken(), erased());
    assert!(runner.as_mut().poll(&mut cx).is_pending());
    assert_eq!(wire.take(sdo_tx), vec![vec![0x43, 0x57, 0x1F, 1, 3, 0, 0, 0]], "1F57h:1 busy");
    assert!(erased() < SECTORS && erased() <= before.1 + 1, "at most one sector more");
    assert!(woken() > before.0);

    // Turned only because it asked (no time passes): each turn erases at most one sector, and
    // the clear ends.
    let mut turns = 0;
    while erased() < SECTORS {
        let (wakes_before, erased_before) = (woken(), erased());
        assert!(runner.as_mut().poll(&mut cx).is_pending());
        assert!(erased() <= erased_before + 1, "one sector a turn");
        if erased() < SECTORS {
            assert!(woken() > wakes_before, "work left: the runner asks to be polled again");
        }
        turns += 1;
        assert!(turns <= SECTORS, "the clear ends");
    }
    wire.send(sdo_rx, &[0x40, 0x57, 0x1F, 1, 0, 0, 0, 0]);
    assert!(runner.as_mut().poll(&mut cx).is_pending());
    assert_eq!(wire.take(sdo_tx), vec![vec![0x43, 0x57, 0x1F, 1, 2, 0, 0, 0]], "cleared, idle");

    // Idle again: the runner sleeps until something arrives (it no longer wakes itself).
    let before = woken();
    assert!(runner.as_mut().poll(&mut cx).is_pending());
    assert_eq!(woken(), before, "nothing due: no wake-up");
}

const PATTERN: u16 = 0x2F10;
const PATTERN_LEN: usize = 4096;

static OBJECTS: [Object; 1] =
    layout([Object::var(PATTERN, "Test pattern", Var::new("Test pattern", DataType::Domain))]);

/// Serves 2F10h, a read-only DOMAIN of 4 KiB computed on the fly.
struct PatternHooks;

impl ObjectHooks for PatternHooks {
    fn read_len(&mut self, index: u16, _sub: u8) -> Option<Result<usize, AbortCode>> {
        (index == PATTERN).then_some(Ok(PATTERN_LEN))
    }

    fn read(&mut self, _index: u16, _sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let n = buf.len().min(PATTERN_LEN.saturating_sub(offset));
        for (i, b) in buf[..n].iter_mut().enumerate() {
            *b = (offset + i) as u8;
        }
        Ok(n)
    }
}

/// The transmitting half of the mock driver, during each of whose transmissions the tick
/// interrupt comes (a tick of the drive through the shared drive, with the lock free).
struct TickingTx<'a> {
    wire: Wire,
    drive: &'a SharedDrive<Drive<PatternHooks>>,
    ticks: usize,
}

impl CanTx for TickingTx<'_> {
    type Frame = CanFrame;
    type Error = embedded_can::ErrorKind;
    async fn transmit(&mut self, frame: &CanFrame) -> Result<(), Self::Error> {
        self.drive.tick(canopen_drive_embassy::now(), &Sample::default());
        self.ticks += 1;
        self.wire.clone().transmit(frame).await
    }
}

#[test]
fn a_block_upload_sends_at_most_a_queue_of_segments_a_turn_while_ticks_come() {
    let _clock = CLOCK.lock().unwrap_or_else(|e| e.into_inner());
    MockDriver::get().reset();
    const NODE_ID: u8 = 6;
    let config = Config { manufacturer_objects: &OBJECTS, ..Config::new(NODE_ID) };
    let shared: SharedDrive<Drive<PatternHooks>> = SharedDrive::new();
    shared.put(Drive::with_hooks(config, PatternHooks).unwrap());
    let wire = Wire::default();
    let tx = TickingTx { wire: wire.clone(), drive: &shared, ticks: 0 };
    let mut runner = pin!(run(&shared, wire.clone(), tx));
    let wakes = Arc::new(WakeCount::default());
    let waker = Waker::from(wakes.clone());
    let mut cx = Context::from_waker(&waker);
    let woken = || wakes.0.load(Ordering::SeqCst);
    let (sdo_rx, sdo_tx) = (0x600 + u16::from(NODE_ID), 0x580 + u16::from(NODE_ID));

    assert!(runner.as_mut().poll(&mut cx).is_pending());
    assert_eq!(wire.take(0x700 + u16::from(NODE_ID)), vec![vec![0u8]], "boot-up");

    // Block upload of 2F10h, CRC on, 127 segments a sub-block.
    let [lo, hi] = PATTERN.to_le_bytes();
    wire.send(sdo_rx, &[0xA4, lo, hi, 0, 127, 0, 0, 0]);
    assert!(runner.as_mut().poll(&mut cx).is_pending());
    let initiated = wire.take(sdo_tx);
    assert_eq!(initiated.len(), 1);
    assert_eq!(initiated[0][0] & 0xE1, 0xC0, "block upload initiated: {initiated:?}");

    // Start: the sub-block's segments, turn by turn, as the runner asks to be polled again.
    wire.send(sdo_rx, &[0xA3, 0, 0, 0, 0, 0, 0, 0]);
    let mut segments = Vec::new();
    let mut turns = 0;
    while segments.len() < 127 {
        let before = woken();
        assert!(runner.as_mut().poll(&mut cx).is_pending());
        let sent = wire.take(sdo_tx);
        assert!(sent.len() <= TX_QUEUE, "{} segments in one turn of the executor", sent.len());
        segments.extend(sent);
        if segments.len() < 127 {
            assert!(woken() > before, "segments left: the runner asks to be polled again");
        }
        turns += 1;
        assert!(turns <= 127, "the sub-block ends");
    }
    assert!(turns >= 127usize.div_ceil(TX_QUEUE), "{turns} turns");
    let numbers: Vec<u8> = segments.iter().map(|s| s[0] & 0x7F).collect();
    assert_eq!(numbers, (1..=127).collect::<Vec<u8>>(), "the segments in order");
    assert_eq!(segments[0][1..], [0, 1, 2, 3, 4, 5, 6], "the pattern's first bytes");
}

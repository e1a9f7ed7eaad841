//! # Footprint of canopen-drive on Cortex-M
//!
//! Five bare-metal images share this harness and differ only in the node they run:
//!
//! | image | node |
//! |---|---|
//! | `baseline` | none: the harness alone (start-up, the scripted "CAN controller", the stack probe) |
//! | `node301` | [`node301::Node301`]: a CiA 301-only node built from the crate's services |
//! | `bootloader` | [`boot::BootNode`]: the crate's bootloader node for program download |
//! | `drive-full` | `canopen_drive::Drive` with every CiA 402 mode (the default configuration) |
//! | `drive-two-axes` | the same drive with two axes (`Drive<…, AXES = 2>`, 4 + 4 PDOs per axis) |
//!
//! The library's share of an image is the image minus `baseline`. `scripts/footprint.sh`
//! builds them for thumbv7em-none-eabihf and thumbv6m-none-eabi (opt-level "s", LTO), reads
//! their sections, runs each in QEMU to measure the stack, and writes `docs/footprint.md`.
//!
//! ## The run (stack measurement)
//!
//! The harness plays a scripted master against the node — one frame per entry of a
//! [`Step`] table read with volatile loads, so the optimiser cannot specialise the node for
//! it — for `SCRIPT_MS` simulated milliseconds: each millisecond it delivers the frames due,
//! runs the control tick (a trivial motor follows the demand), runs `poll` and drains the
//! transmit queue. Before each call it paints the stack below the caller with a known word,
//! after it finds the deepest overwritten word: so it knows the deepest communication call
//! (`on_frame`, `poll`) and the deepest tick separately. Worst case on a board, where the
//! tick interrupt can preempt the deepest communication call, is their sum plus the
//! exception frame. Construction of the node (before interrupts run) is measured from the
//! start-up paint. It prints `init=… comm=… tick=…` (bytes) on the semihosting console.
#![no_std]
#![deny(missing_docs)]

use canopen_drive::hal::{Demand, Sample, Setpoint};
use canopen_drive::{CanFrame, Instant};
use embedded_can::Frame as _;

pub mod boot;
pub mod node301;

/// What the harness drives: the entry points of a node.
pub trait Node {
    /// One received frame.
    fn on_frame(&mut self, frame: &CanFrame, now: Instant);
    /// Timers; the next deadline.
    fn poll(&mut self, now: Instant) -> Option<Instant>;
    /// The next frame to send.
    fn pop_tx(&mut self) -> Option<CanFrame>;
    /// The control tick (a CiA 301-only node has none).
    fn tick(&mut self, now: Instant, sample: &Sample) -> Demand;
}

impl<H, const OD: usize, const R: usize, const T: usize, S> Node for canopen_drive::Drive<H, OD, R, T, S>
where
    H: canopen_drive::od::ObjectHooks,
    S: canopen_drive::storage::Persistence,
{
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        canopen_drive::Drive::on_frame(self, frame, now);
    }
    fn poll(&mut self, now: Instant) -> Option<Instant> {
        canopen_drive::Drive::poll(self, now)
    }
    fn pop_tx(&mut self) -> Option<CanFrame> {
        canopen_drive::Drive::pop_tx(self)
    }
    fn tick(&mut self, now: Instant, sample: &Sample) -> Demand {
        canopen_drive::Drive::tick(self, now, sample)
    }
}

/// One scripted frame from the master.
#[derive(Clone, Copy, Debug)]
pub struct Step {
    /// When (ms after start).
    pub at_ms: u16,
    /// CAN-ID.
    pub id: u16,
    /// Data length.
    pub len: u8,
    /// Data.
    pub data: [u8; 8],
}

const fn step(at_ms: u16, id: u16, data: [u8; 8]) -> Step {
    Step { at_ms, id, len: 8, data }
}

const fn nmt(at_ms: u16, command: u8) -> Step {
    Step { at_ms, id: 0, len: 2, data: [command, NODE_ID, 0, 0, 0, 0, 0, 0] }
}

/// Node-ID of the measured nodes.
pub const NODE_ID: u8 = 5;
const RX: u16 = 0x600 + NODE_ID as u16;

/// Length of the run.
pub const SCRIPT_MS: u16 = 2600;

/// The master's script: every SDO transfer type, NMT, heartbeat, and (for a drive) the CiA 402
/// state machine to Operation enabled, a profile position move (a trapezoid) ended by a quick
/// stop, then a jerk-limited one with a change-immediately set-point and a halt. A 301-only
/// node answers the 6xxxh requests with aborts, which is a path too.
pub static SCRIPT: [Step; 42] = [
    // Expedited upload 1000h, expedited download 1017h = 100 ms.
    step(2, RX, [0x40, 0x00, 0x10, 0, 0, 0, 0, 0]),
    step(4, RX, [0x2B, 0x17, 0x10, 0, 100, 0, 0, 0]),
    // Segmented upload of 1008h (device name): initiate + three segments.
    step(6, RX, [0x40, 0x08, 0x10, 0, 0, 0, 0, 0]),
    step(8, RX, [0x60, 0, 0, 0, 0, 0, 0, 0]),
    step(10, RX, [0x70, 0, 0, 0, 0, 0, 0, 0]),
    step(12, RX, [0x60, 0, 0, 0, 0, 0, 0, 0]),
    // Block upload of 1008h: initiate (CRC, 127 per block, no switch), start, ack 2, end.
    step(14, RX, [0xA4, 0x08, 0x10, 0, 127, 0, 0, 0]),
    step(16, RX, [0xA3, 0, 0, 0, 0, 0, 0, 0]),
    step(18, RX, [0xA2, 2, 127, 0, 0, 0, 0, 0]),
    step(20, RX, [0xA1, 0, 0, 0, 0, 0, 0, 0]),
    // Block download of 4 bytes to 1017h: initiate (CRC, size 2), one segment, end.
    step(22, RX, [0xC6, 0x17, 0x10, 0, 2, 0, 0, 0]),
    step(24, RX, [0x81, 200, 0, 0, 0, 0, 0, 0]),
    step(26, RX, [0xD5, 0x00, 0x00, 0, 0, 0, 0, 0]),
    // NMT: operational, pre-operational, reset communication.
    nmt(30, 0x01),
    nmt(40, 0x80),
    nmt(50, 0x82),
    // CiA 402: profile position, profile velocity and acceleration, target, then
    // shutdown / switch on / enable operation / new set-point.
    step(60, RX, [0x2F, 0x60, 0x60, 0, 1, 0, 0, 0]),
    step(62, RX, [0x23, 0x81, 0x60, 0, 0x20, 0x4E, 0, 0]),
    step(64, RX, [0x23, 0x83, 0x60, 0, 0xA0, 0x86, 0x01, 0]),
    step(66, RX, [0x23, 0x84, 0x60, 0, 0xA0, 0x86, 0x01, 0]),
    step(68, RX, [0x23, 0x7A, 0x60, 0, 0x88, 0x13, 0, 0]),
    step(70, RX, [0x2B, 0x40, 0x60, 0, 0x06, 0, 0, 0]),
    step(80, RX, [0x2B, 0x40, 0x60, 0, 0x07, 0, 0, 0]),
    step(90, RX, [0x2B, 0x40, 0x60, 0, 0x0F, 0, 0, 0]),
    step(100, RX, [0x2B, 0x40, 0x60, 0, 0x1F, 0, 0, 0]),
    step(110, RX, [0x2B, 0x40, 0x60, 0, 0x0F, 0, 0, 0]),
    // Statusword and position during the move; quick stop near the end.
    step(400, RX, [0x40, 0x41, 0x60, 0, 0, 0, 0, 0]),
    step(800, RX, [0x40, 0x64, 0x60, 0, 0, 0, 0, 0]),
    step(1300, RX, [0x2B, 0x40, 0x60, 0, 0x02, 0, 0, 0]),
    step(1400, RX, [0x40, 0x41, 0x60, 0, 0, 0, 0, 0]),
    // Jerk-limited (6086h = 3): enabled again, a set-point, a change-immediately set-point
    // while it moves, a halt and its release.
    step(1500, RX, [0x2B, 0x86, 0x60, 0, 3, 0, 0, 0]),
    step(1502, RX, [0x23, 0x7A, 0x60, 0, 0x10, 0x27, 0, 0]),
    step(1510, RX, [0x2B, 0x40, 0x60, 0, 0x06, 0, 0, 0]),
    step(1520, RX, [0x2B, 0x40, 0x60, 0, 0x07, 0, 0, 0]),
    step(1530, RX, [0x2B, 0x40, 0x60, 0, 0x0F, 0, 0, 0]),
    step(1540, RX, [0x2B, 0x40, 0x60, 0, 0x1F, 0, 0, 0]),
    step(1550, RX, [0x2B, 0x40, 0x60, 0, 0x0F, 0, 0, 0]),
    step(1700, RX, [0x23, 0x7A, 0x60, 0, 0xD0, 0x07, 0, 0]),
    step(1702, RX, [0x2B, 0x40, 0x60, 0, 0x3F, 0, 0, 0]),
    step(1712, RX, [0x2B, 0x40, 0x60, 0, 0x0F, 0, 0, 0]),
    step(1900, RX, [0x2B, 0x40, 0x60, 0, 0x0F, 0x01, 0, 0]),
    step(2200, RX, [0x2B, 0x40, 0x60, 0, 0x0F, 0, 0, 0]),
];

/// A motor that follows the demand exactly (enough to exercise the drive's loops).
#[derive(Debug, Default)]
struct Follower {
    position: i32,
    velocity: i32,
}

impl Follower {
    fn sample(&self) -> Sample {
        Sample {
            position: self.position,
            velocity: self.velocity,
            dc_link_millivolts: 48_000,
            ..Sample::default()
        }
    }

    fn step(&mut self, demand: &Demand) {
        if !demand.drive_enabled {
            self.velocity = 0;
            return;
        }
        match demand.setpoint {
            Setpoint::Position(p) => {
                self.velocity = p.wrapping_sub(self.position).saturating_mul(1000);
                self.position = p;
            }
            Setpoint::Velocity(v) => {
                self.velocity = v;
                self.position = self.position.wrapping_add(v / 1000);
            }
            Setpoint::Torque(_) | Setpoint::None => self.velocity = 0,
        }
    }
}

/// Stack depths (bytes) seen by the harness.
#[derive(Clone, Copy, Debug, Default)]
pub struct StackUse {
    /// Deepest `on_frame` / `poll` / `pop_tx` call.
    pub comm: u32,
    /// Deepest `tick` call.
    pub tick: u32,
}

/// Runs the script against `node`; returns the stack depths and a checksum of every frame
/// the node sent (written to a volatile sink, so nothing is optimised away).
pub fn run<N: Node>(node: &mut N, probe: &mut impl FnMut(&mut dyn FnMut()) -> u32) -> StackUse {
    let mut depth = StackUse::default();
    let mut motor = Follower::default();
    let mut checksum = 0u32;
    let mut next = 0usize;
    for ms in 0..SCRIPT_MS {
        let now = Instant::from_millis(u64::from(ms));
        // The script is data the optimiser must not see through.
        while let Some(step) = SCRIPT.get(next).map(opaque) {
            if step.at_ms > ms {
                break;
            }
            next += 1;
            let Some(frame) =
                CanFrame::new_standard(step.id, step.data.get(..usize::from(step.len)).unwrap_or(&[]))
            else {
                continue;
            };
            depth.comm = depth.comm.max(probe(&mut || node.on_frame(&frame, now)));
        }
        let sample = motor.sample();
        let mut demand = Demand::OFF;
        depth.tick = depth.tick.max(probe(&mut || demand = node.tick(now, &sample)));
        motor.step(&demand);
        depth.comm = depth.comm.max(probe(&mut || {
            let _ = node.poll(now);
        }));
        while let Some(frame) = node.pop_tx() {
            let id = u32::from(frame.standard_id().unwrap_or(0));
            checksum = frame
                .data()
                .iter()
                .fold(checksum.rotate_left(5) ^ id, |c, b| c.rotate_left(3) ^ u32::from(*b));
        }
    }
    sink(checksum);
    depth
}

/// A copy of a script step the optimiser cannot predict.
fn opaque(step: &Step) -> Step {
    core::hint::black_box(*step)
}

/// Hands a value to the outside world so the work that made it stays in the image.
pub fn sink(value: u32) {
    core::hint::black_box(value);
}

#[cfg(target_os = "none")]
pub mod target;

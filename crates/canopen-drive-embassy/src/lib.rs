//! # canopen-drive-embassy
//!
//! Runs a [`canopen_drive::Drive`] under [embassy]: an async runner that moves frames between
//! a CAN driver and the drive and calls `poll` when its deadline comes, and the fixed-rate
//! control tick on a timer interrupt (a bare handler, or a task on embassy's
//! `InterruptExecutor`).
//!
//! The core never awaits and never reads a clock; this crate is the thin layer that does, with
//! `embassy-time` as the clock and `critical-section` as the only lock.
//!
//! ## Concurrency discipline
//!
//! | context | priority | runs | touches the drive through |
//! |---|---|---|---|
//! | tick | a timer interrupt (or an `InterruptExecutor`), the highest that calls into the drive | [`SharedDrive::tick`] at the fixed rate | one critical section per tick |
//! | communication | thread mode (embassy's thread executor) or a low-priority interrupt | [`run`]: `on_frame` for each received frame, `poll` at its deadline, `pop_tx` to the driver | one critical section per call |
//! | CAN driver interrupts | whatever the HAL uses | the HAL's own buffers and wakers | nothing |
//!
//! - **What is shared:** the one [`Drive`](canopen_drive::Drive) value, and nothing else. It
//!   lives in a [`SharedDrive`]: a `critical_section::Mutex<RefCell<Option<D>>>` plus a
//!   [`Signal`](embassy_sync::signal::Signal) with which the tick wakes the runner after each
//!   tick (the tick may have queued a TPDO, or raised an error whose EMCY `poll` sends).
//! - **What protects it:** a critical section (on a single-core Cortex-M: interrupts masked)
//!   around every single call into the drive. No lock is ever held across an `.await`, and no
//!   call takes more than one step of work: one received frame, one `poll`, one frame out of
//!   the transmit queue. The driver's `transmit().await` runs with the lock released.
//! - **Why the tick is never late by more than one call:** the core bounds each call (the SDO
//!   server answers one request per frame and queues at most a transmit queue's worth —
//!   [`TX_QUEUE`](canopen_drive::drive::TX_QUEUE) — of block-upload segments per call; `poll`
//!   does the same). So the time a tick interrupt can be held off is the longest single
//!   `on_frame`/`poll` (plus the interrupt entry), whatever the master does: a 16 KiB block
//!   upload is hundreds of short critical sections, never a long one.
//! - **The bound, measured:** `boards/qemu-mps2`'s `tick-bound` firmware runs this runner, a
//!   drive and a 1 kHz tick with an SDO client inside the firmware under QEMU's instruction
//!   counting. During a 16 KiB block upload (127-segment sub-blocks) no critical section
//!   outside the tick lasts longer than about 75 000 instructions on thumbv7em (102 000 on
//!   thumbv6m): the sub-block acknowledgement, at which the SDO server folds the 889
//!   acknowledged bytes into the CRC. That is roughly half a millisecond on a 170 MHz
//!   Cortex-M4; the bound checked in CI is 100 000 instructions (130 000 on thumbv6m). Other
//!   long calls: an NMT reset (about 95 000 instructions). An SDO request takes at most about
//!   2 500.
//! - **Re-entrance:** a hook of the drive (an [`ObjectHooks`](canopen_drive::od::ObjectHooks)
//!   method) must not call back into the [`SharedDrive`]; if it does, the inner call finds the
//!   drive borrowed and does nothing ([`SharedDrive::with`] returns `None`, [`SharedDrive::tick`]
//!   returns [`Demand::OFF`](canopen_drive::hal::Demand::OFF)) instead of panicking.
//! - **Multi-core parts:** the discipline holds with any `critical-section` implementation; on
//!   a multi-core part the critical section is a spin lock, and the bound above is the same.
//!
//! Firmware that does not use embassy keeps the same discipline with a
//! `critical_section::Mutex<RefCell<Option<Drive>>>` of its own and two interrupt handlers:
//! see `boards/qemu-mps2/src/bin/bare_interrupts.rs`.
//!
//! ## Use
//!
//! ```ignore
//! static DRIVE: SharedDrive<MyDrive> = SharedDrive::new();
//!
//! #[embassy_executor::task]
//! async fn can_task(rx: MyCanRx, tx: MyCanTx) -> ! {
//!     canopen_drive_embassy::run(&DRIVE, rx, tx).await
//! }
//!
//! #[interrupt]
//! fn TIM1_UP() {
//!     let now = canopen_drive_embassy::now();
//!     let demand = DRIVE.tick(now, &board::sample());
//!     board::apply(&demand);
//! }
//! ```
//!
//! ## LSS and CAN errors: the board's part
//!
//! Some of what a CANopen node does needs the board: switching the CAN controller to the
//! bit rate an LSS master activated, keeping an LSS "store configuration" (node-ID and bit
//! rate) for the next start, and telling the drive when the controller goes error passive
//! or bus-off. [`run_until_bit_rate_change`] does the runner's share and asks the board
//! through [`RunnerHooks`] (every method has a default that does nothing):
//!
//! ```ignore
//! #[embassy_executor::task]
//! async fn can_task(mut can: CanPeripherals, mut board: Board, mut bit_rate: u32) -> ! {
//!     let mut quiet = Duration::from_ticks(0);
//!     loop {
//!         let (mut rx, mut tx, status) = board::open_can(&mut can, bit_rate);
//!         board.status = Some(status); // read by Board::bus_state
//!         Timer::after(quiet).await; // silent for a switch delay at the new rate (CiA 305)
//!         let change = run_until_bit_rate_change(&DRIVE, &mut rx, &mut tx, &mut board).await;
//!         quiet = Duration::from_millis(change.switch_delay_ms.into());
//!         Timer::after(quiet).await; // the other nodes finish at the old rate
//!         bit_rate = board::bit_rate_of(change.bit_timing);
//!     } // rx and tx dropped here: the controller is closed, to be reopened at the new rate
//! }
//! ```
//!
//! The drive answers a bit timing the controller cannot run "not supported" when
//! `Config::bit_rates` lists only those it can, and a store "stored" only with
//! `Config::lss_store` set.
//!
//! ## Features
//!
//! - `stm32-fdcan`: embassy-stm32's FDCAN behind [`CanRx`]/[`CanTx`], its error state for
//!   [`RunnerHooks::bus_state`] and bit timings from its kernel clock (module `fdcan`). The
//!   firmware enables its chip's feature on its own embassy-stm32 dependency; this crate
//!   picks no chip.
//!
//! [embassy]: https://embassy.dev
#![no_std]
#![deny(missing_docs)]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

#[cfg(any(test, feature = "stm32-fdcan"))]
mod bit_timing;
#[cfg(feature = "stm32-fdcan")]
pub mod fdcan;
mod runner;
mod shared;
mod tick;

pub use runner::{run, run_until_bit_rate_change, BusState, CanRx, CanTx, RunnerHooks, BUS_STATE_PERIOD};
pub use shared::{Endpoints, SharedDrive};
pub use tick::{run_tick, TickMonitor};

/// Now, as the core counts time: µs since embassy-time's epoch.
pub fn now() -> canopen_drive::Instant {
    canopen_drive::Instant::from_micros(embassy_time::Instant::now().as_micros())
}

/// A core instant as an embassy-time instant (for timers).
pub fn to_embassy(at: canopen_drive::Instant) -> embassy_time::Instant {
    embassy_time::Instant::from_micros(at.as_micros())
}

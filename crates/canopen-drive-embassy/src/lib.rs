//! # canopen-drive-embassy
//!
//! Runs a [`canopen_drive::Drive`] under [embassy]: an async runner that moves frames between
//! a CAN driver and the drive and calls `poll` when its deadline comes, and the fixed-rate
//! control tick on a timer interrupt (a bare handler, or a task on embassy's
//! `InterruptExecutor`).
//!
//! The core never awaits and never reads a clock; this crate is the thin layer that does, with
//! `embassy-time` as the clock and one lock between the tick and the communication side: a
//! critical section, or on Cortex-M a priority ceiling that leaves every interrupt above the
//! tick (a motor's current loop) alone ([the lock](#the-lock)).
//!
//! ## Concurrency discipline
//!
//! | context | priority | runs | touches the drive through |
//! |---|---|---|---|
//! | current loop, PWM, over-current trip (the board's) | above the tick | the board's fastest work | nothing; with [`PriorityCeiling`] the drive never holds them off |
//! | tick | a timer interrupt (or an `InterruptExecutor`), the most urgent context that calls into the drive | [`SharedDrive::tick`] at the fixed rate | one hold of the lock per tick |
//! | communication | thread mode (embassy's thread executor) or a less urgent interrupt | [`run`]: `on_frame` for each received frame, `poll` at its deadline, `pop_tx` to the driver | one hold of the lock per call |
//! | CAN driver interrupts | whatever the HAL uses | the HAL's own buffers and wakers | nothing |
//!
//! - **What is shared:** the one [`Drive`](canopen_drive::Drive) value, and the runner's
//!   waker, with which the tick wakes the runner after each tick (the tick may have queued a
//!   TPDO, or raised an error whose EMCY `poll` sends). Both live in a [`SharedDrive`], under
//!   one lock.
//! - **What protects it:** the lock around every single call into the drive. No lock is ever
//!   held across an `.await`, and no call takes more than one step of work: one received
//!   frame, one `poll`, one frame out of the transmit queue. The driver's `transmit().await`
//!   runs with the lock released.
//! - **Why the tick is never late by more than one call:** the core bounds each call (the SDO
//!   server answers one request per frame and queues at most a transmit queue's worth —
//!   [`TX_QUEUE`](canopen_drive::drive::TX_QUEUE) — of block-upload segments per call; `poll`
//!   does the same). So the time a tick interrupt can be held off is the longest single
//!   `on_frame`/`poll` (plus the interrupt entry), whatever the master does: a 16 KiB block
//!   upload is hundreds of short holds of the lock, never a long one.
//! - **The bound, measured:** `boards/qemu-mps2`'s `tick-bound` firmware runs this runner, a
//!   drive and a 1 kHz tick with an SDO client inside the firmware under QEMU's instruction
//!   counting. During a 16 KiB block upload (127-segment sub-blocks) no hold of the lock
//!   outside the tick lasts longer than about 85 000 instructions on thumbv7em (112 000 on
//!   thumbv6m): the sub-block acknowledgement, at which the SDO server folds the 889
//!   acknowledged bytes into the CRC. That is roughly half a millisecond on a 170 MHz
//!   Cortex-M4; the bound checked in CI is 100 000 instructions (130 000 on thumbv6m). Other
//!   long calls: an NMT reset (about 91 000 instructions). An SDO request takes at most about
//!   2 500.
//! - **Re-entrance:** a hook of the drive (an [`ObjectHooks`](canopen_drive::od::ObjectHooks)
//!   method) must not call back into the [`SharedDrive`]; if it does, the inner call finds the
//!   drive borrowed and does nothing ([`SharedDrive::with`] returns `None`, [`SharedDrive::tick`]
//!   returns [`Demand::OFF`](canopen_drive::hal::Demand::OFF)) instead of panicking.
//! - **Multi-core parts:** [`CriticalSection`] holds with any `critical-section`
//!   implementation; on a multi-core part it is a spin lock, and the bound above is the same.
//!   [`PriorityCeiling`] is for a single core.
//!
//! Firmware that does not use embassy keeps the same discipline with a [`SharedDrive`] (it
//! needs no executor) and two interrupt handlers: see
//! `boards/qemu-mps2/src/bin/bare_interrupts.rs`.
//!
//! ## The lock
//!
//! [`SharedDrive<D, L>`](SharedDrive) takes its lock as a type parameter ([`Lock`]):
//!
//! - [`CriticalSection`], the default: every interrupt masked for each call (the
//!   `critical-section` crate). It works on every target, hosts and tests included, but while
//!   the drive works nothing else runs: a block-upload acknowledgement (85 000 Cortex-M4
//!   instructions) or a profile-position set-point's tick (as long, while the tick plans the
//!   move) is as long a gap in a motor's current loop.
//! - [`PriorityCeiling<P>`](PriorityCeiling) (single-core Cortex-M): a lock at a priority
//!   ceiling `P`, the tick's priority, as RTIC locks its resources. A call from the
//!   communication side raises BASEPRI to `P` for its duration (ARMv7-M, ARMv7E-M, ARMv8-M
//!   Mainline), or disables the NVIC lines at or below `P` (ARMv6-M, which has no BASEPRI); the
//!   tick runs at `P`, where nothing that takes the lock can preempt it, and masks nothing.
//!   **Every interrupt more urgent than `P` is never masked by the drive.** A call of the
//!   communication side costs about 8 instructions on a Cortex-M4, about 100 on ARMv6-M.
//!
//! Choosing the ceiling, for firmware authors:
//!
//! 1. Give the interrupts that must never wait for the drive — the current loop, the PWM
//!    update, an over-current trip, an encoder capture — the most urgent priorities. They must
//!    not call into the [`SharedDrive`] (a call from above the ceiling is refused:
//!    [`SharedDrive::with`] returns `None`, [`SharedDrive::tick`] `Demand::OFF`); they share
//!    data with the tick through atomics.
//! 2. The tick comes next: its priority is `P`. `P` is the priority byte as the NVIC holds it
//!    (the implemented upper bits): on an STM32 (4 bits), the current loop at `0x00`, the PWM
//!    and the trip at `0x10` and `0x20`, the tick at `0x30`: `PriorityCeiling<0x30>`, and
//!    `0x00`–`0x20` stay free. `P` = 0 would leave nothing above it and does not compile.
//! 3. Everything else that calls into the drive (a CAN receive interrupt that calls
//!    `on_frame`, the executor the runner runs on) at `P` or less urgent; thread mode always
//!    qualifies. With PRIGROUP splitting sub-priorities, what counts is the group priority:
//!    interrupts of the ceiling's group are masked too.
//! 4. On ARMv6-M, the tick and the communication side run in NVIC interrupts or thread mode
//!    (SysTick and PendSV have no NVIC line the lock could disable), and nothing enables or
//!    disables those lines while the drive runs.
//! 5. The critical sections of the rest of the firmware still mask everything: embassy's
//!    timer queue, channels and (on ARMv6-M) run queue, a board's clock, a `defmt` logger
//!    while it encodes a line. They are short: in `boards/qemu-mps2` the longest is 165
//!    instructions on thumbv7em and 215 on thumbv6m, about 900 while the drive logs a line.
//!
//! Measured in `boards/qemu-mps2` (the `tick-bound` firmware under `-icount`, where every
//! count is exact): a 20 kHz current loop above `PriorityCeiling<0x40>` (period 6 250
//! instructions) never missed a run during a 16 KiB block upload or a profile-position
//! set-point whose tick ran 86 000 instructions; it started at most 100 instructions late
//! during the upload and 745 during the set-point (a `defmt` line). With [`CriticalSection`]
//! instead, the same firmware lost 290 of the upload's 903 runs (gaps of up to 89 000
//! instructions). The board's README has every number.
//!
//! ## Use
//!
//! ```ignore
//! /// The tick's priority, and the drive's ceiling: 0x00–0x20 stay free for the current loop.
//! const TICK_PRIORITY: u8 = 0x30;
//! static DRIVE: SharedDrive<MyDrive, PriorityCeiling<TICK_PRIORITY>> = SharedDrive::new();
//!
//! #[embassy_executor::task]
//! async fn can_task(rx: MyCanRx, tx: MyCanTx) -> ! {
//!     canopen_drive_embassy::run(&DRIVE, rx, tx).await
//! }
//!
//! #[interrupt] // at TICK_PRIORITY (set before it is unmasked)
//! fn TIM1_UP() {
//!     let now = canopen_drive_embassy::now();
//!     let demand = DRIVE.tick(now, &board::sample());
//!     board::apply(&demand);
//! }
//! ```
//!
//! (`SharedDrive<MyDrive>` is the same with [`CriticalSection`].)
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
mod lock;
mod runner;
mod shared;
mod tick;

pub use lock::{CriticalSection, Lock, PriorityCeiling};
pub use runner::{run, run_until_bit_rate_change, BusState, CanRx, CanTx, RunnerHooks, BUS_STATE_PERIOD};
pub use shared::{Endpoints, SharedDrive, Tick};
pub use tick::{run_tick, TickMonitor};

/// Now, as the core counts time: µs since embassy-time's epoch.
pub fn now() -> canopen_drive::Instant {
    canopen_drive::Instant::from_micros(embassy_time::Instant::now().as_micros())
}

/// A core instant as an embassy-time instant (for timers).
pub fn to_embassy(at: canopen_drive::Instant) -> embassy_time::Instant {
    embassy_time::Instant::from_micros(at.as_micros())
}

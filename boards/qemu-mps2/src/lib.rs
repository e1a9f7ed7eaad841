//! # canopen-drive on QEMU's mps2-an386 (Cortex-M4F) and mps2-an385
//!
//! The drive with a simulated motor on an emulated Cortex-M, talking CANopen to a real master
//! over SLCAN on UART0 (QEMU exposes the UART as a TCP socket, see `run.sh`). No QEMU
//! Cortex-M board has a CAN controller, so the UART carries the frames in the text form
//! USB-CAN adapters use; the line codec is the crate `canopen-drive-slcan`, which the Linux
//! program serves over TCP too.
//!
//! Four firmwares share this library:
//!
//! - `qemu-mps2` (`src/main.rs`): embassy. The communication runner of
//!   `canopen-drive-embassy` in a thread-mode executor that sleeps with WFI, embassy-time on
//!   SysTick, the control tick in the TIMER0 interrupt, defmt logging over semihosting.
//! - `bare-interrupts` (`src/bin/bare_interrupts.rs`): no async at all. The drive in a
//!   `SharedDrive`, fed by two interrupt handlers (UART receive standing in for CAN receive,
//!   and the TIMER0 tick) and a main loop that runs `poll` and transmits.
//! - `tick-bound` (`src/bin/tick_bound.rs`): the embassy runner with an SDO client inside the
//!   firmware, run under `-icount`: how long the drive holds off the tick, and that the
//!   current loop above the drive's lock keeps its period.
//! - `bootloader` (`src/bin/bootloader.rs`): CiA 302-3 program download. A bare loop around
//!   `canopen_drive::bootloader::Bootloader` that starts the program in its program area, or
//!   takes a new one; `qemu-mps2` built with the feature `application-image` is that program
//!   (layout in [`boot`]).
//!
//! In each drive firmware, the drive's lock is a priority ceiling at the tick's priority
//! (`PriorityCeiling`, through `board::DriveLock`), and a stand-in current loop (the dual
//! timer's interrupt) runs above it: see `board` for the priorities.
//!
//! | module | what |
//! |---|---|
//! | [`node`] | the drive's configuration (node-ID 5, identity shared with the bootloader, tick rate) |
//! | [`boot`] | program download: the layout of bootloader, program area and application, the area as NOR flash, the hand-over word, the jump between images |
//! | [`objects`] | manufacturer objects 2F00h–2F11h: test exit, tick lateness, lock and masked stretches, the current loop, stack use, test data |
//! | [`motor`] | a no_std motor model: inertia + friction, velocity/position loops |
//! | `mps2` | UART0, TIMER0, TIMER1, dual timer, the user LEDs, SysTick, the NVIC and VTOR for a hand-over; semihosting exit (bare-metal targets only) |
//! | `board` | priorities and the drive's lock, the µs clock, the tick body and the current loop shared by the firmwares, the measurements |
#![no_std]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod boot;
pub mod motor;
pub mod node;
pub mod objects;

#[cfg(target_os = "none")]
pub mod board;
#[cfg(target_os = "none")]
pub mod mps2;

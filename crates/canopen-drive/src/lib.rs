//! # canopen-drive
//!
//! A `#![no_std]`, allocation-free CANopen slave (CiA 301) and CiA 402 drive profile for
//! motor-controller firmware.
//!
//! ## Layers (lowest first)
//!
//! A module uses only the modules of its own layer and of the layers below it (checked by
//! `tests/layers.rs`).
//!
//! 1. [`time`], [`frame`]: microsecond instants handed in by the caller; the CAN frame type and
//!    its conversion to and from any `embedded_can::Frame`. (With them, two private utilities:
//!    128-bit division and the logging shim.)
//! 2. [`wire`], [`motion`]: stateless codecs of the CANopen frames (NMT, SDO, COB-IDs, LSS,
//!    block CRC); CANopen-agnostic motion math: the exact fixed-point trapezoid and
//!    jerk-limited trajectory planner behind profile position and homing, re-planned from any
//!    state.
//! 3. [`hal`]: what a board hands the tick (the feedback [`hal::Sample`]) and gets back (the
//!    [`hal::Demand`] for the power stage).
//! 4. [`od`]: the object dictionary: a `static` description, a byte store, exact SDO abort
//!    codes, hooks for manufacturer objects, parameter records and the EDS generated from the
//!    same description.
//! 5. [`storage`], [`control`]: parameters kept across power loss (1010h/1011h) in a two-bank
//!    journal on any NOR flash (`embedded-storage`); the optional cascaded position (P) and
//!    velocity (PI, anti-windup, feed-forward) loops, for boards that close only a current
//!    loop.
//! 6. [`comm`]: the CiA 301/305 services: NMT slave, SDO server (expedited, segmented, block),
//!    PDOs with dynamic mapping, SYNC, EMCY, heartbeat producer and consumer, node guarding,
//!    error behaviour 1029h, LSS slave, program download (CiA 302-3), and the CiA 303-3
//!    indicators.
//! 7. [`cia402`]: the CiA 402 drive profile: the state machine with every transition and the
//!    option codes (605Ah–605Eh, 6007h), faults with their EMCY and 603Fh, mode switching
//!    (6060h/6061h/6502h), the factor group and polarity, the limits applied to every demand,
//!    the position control function, and the modes: profile position (pp), profile velocity
//!    (pv), profile torque (tq), homing (hm), interpolated position (ip), velocity mode (vl),
//!    cyclic synchronous position, velocity and torque (csp, csv, cst), and the touch probe.
//! 8. [`drive`]: [`Drive`], which composes everything behind the entry points;
//!    [`bootloader`]: the CiA 301 node a bootloader runs to take a new program.
//! 9. [`can_io`], [`prelude`]: moving frames between a drive and an `embedded_can` driver; the
//!    re-exports a firmware starts from.
//!
//! ## Two entry points, two rates
//!
//! - Communication: [`Drive::on_frame`] for every received frame, [`Drive::poll`] when the
//!   deadline it returned has come, [`Drive::pop_tx`] to drain frames to the CAN controller.
//!   Each call does bounded work.
//! - Control: [`Drive::tick`] at the fixed control-loop rate, O(1).
//!
//! Nothing here reads a clock, awaits, allocates or touches a peripheral: time and I/O are
//! arguments. The [`can_io`] helper moves frames between the drive and any
//! `embedded_can::nb::Can` driver.
//!
//! ## Features
//!
//! - `names` (default): parameter and object names in the tables, for the EDS. An MCU build
//!   that never writes its EDS turns default features off and saves the names' flash: 5.0 KiB
//!   with only the always-built modes, 6.6 KiB with every mode (measured on thumbv7em,
//!   `opt-level = "s"`, LTO, in `examples/firmware`). This is the one place that figure is
//!   given.
//! - `all-modes` (default): `pp`, `hm`, `ip`, `vl` and `touch-probe`. csp, csv, cst, pv and tq
//!   are always built; a mode left out is not in 6502h, 6060h refuses it, its objects do not
//!   exist and its code is not in the image (the drive with only the always-built modes needs
//!   a little over half the flash of the full one).
//! - `eds-object`: the device's EDS as object 1021h, with its storage format 1022h (0: plain
//!   ASCII) (implies `names`).
//! - `defmt`: log through `defmt`, and `defmt::Format` for the public types a firmware logs
//!   (frames, samples, demands, states, events, errors).
//! - `log`: log through the `log` facade, for host programs (the Linux drive shows it with
//!   `-vv`).
//!
//! ## Logging
//!
//! With `defmt` or `log` on, the core logs its CiA 402 state changes and modes, faults, and
//! storage events (loads, stores, restores, damaged images). With neither, the log calls
//! expand to nothing: no code, no strings in the image.
//!
//! ## Panic contract
//!
//! No input (frame, time, sample, dictionary write) makes the core panic: the crate denies
//! `unwrap`, `expect`, `panic!` and unchecked indexing, and every refused access is answered
//! with its SDO abort code.
//!
//! ## Example
//!
//! ```
//! use canopen_drive::{CanFrame, Config, Drive, Instant};
//!
//! let mut drive = Drive::new(Config::new(5)).unwrap();
//! let now = Instant::from_millis(0);
//! drive.poll(now); // boot-up: sends 0x705 [00] and enters Pre-operational
//! assert_eq!(drive.pop_tx().unwrap().standard_id(), Some(0x705));
//!
//! // A master reads 1000h (device type) with an expedited upload.
//! let request = CanFrame::new_standard(0x605, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).unwrap();
//! drive.on_frame(&request, now);
//! let response = drive.pop_tx().unwrap();
//! assert_eq!(response.standard_id(), Some(0x585));
//! assert_eq!(embedded_can::Frame::data(&response), &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]);
//! ```
#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

mod fmt;

pub mod bootloader;
pub mod can_io;
pub mod cia402;
pub mod comm;
pub mod control;
pub mod drive;
pub mod frame;
pub mod hal;
pub mod motion;
pub mod od;
pub mod prelude;
pub mod storage;
#[cfg(test)]
mod testing;
pub mod time;
mod wide;
pub mod wire;

pub use drive::{Config, Drive, MultiAxisDrive, PdoDrive, StoredDrive};
pub use frame::CanFrame;
pub use od::{AbortCode, ConfigError};
pub use time::{Duration, Instant};

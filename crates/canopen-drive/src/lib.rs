//! # canopen-drive
//!
//! A `#![no_std]`, allocation-free CANopen slave (CiA 301) and CiA 402 drive profile for
//! motor-controller firmware.
//!
//! ## Layers (lowest first)
//!
//! - [`time`], [`frame`]: microsecond instants handed in by the caller; the CAN frame type and
//!   its conversion to and from any `embedded_can::Frame`.
//! - [`wire`]: stateless codecs of the CANopen frames (NMT, SDO, COB-IDs, LSS, block CRC).
//! - [`od`]: the object dictionary: a `static` description, a byte store, exact SDO abort codes,
//!   hooks for manufacturer objects, parameter records and the EDS generated from the same
//!   description.
//! - [`storage`]: parameters kept across power loss (1010h/1011h) in a two-bank journal on any
//!   NOR flash (`embedded-storage`).
//! - [`comm`]: the CiA 301/305 services: NMT slave, SDO server (expedited, segmented, block),
//!   PDOs with dynamic mapping, SYNC, EMCY, heartbeat producer and consumer, node guarding,
//!   error behaviour 1029h, LSS slave.
//! - [`cia402`]: the drive profile (so far the process-data objects of the default mapping).
//! - [`hal`]: what a board hands the tick (feedback) and gets back (a demand).
//! - [`drive`]: [`Drive`], which composes everything behind the entry points.
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
//!   that never writes its EDS turns default features off and saves some 4 KiB of flash.
//! - `eds-object`: the device's EDS as object 1021h (implies `names`).
//! - `defmt`: `defmt::Format` for the public types.
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
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

mod fmt;

pub mod can_io;
pub mod cia402;
pub mod comm;
pub mod control;
pub mod drive;
pub mod frame;
pub mod hal;
pub mod motion;
pub mod od;
pub mod storage;
pub mod time;
mod wide;
pub mod wire;

pub use drive::{Config, Drive};
pub use frame::CanFrame;
pub use od::AbortCode;
pub use time::{Duration, Instant};

//! # canopen-drive-sim
//!
//! Host-side test support for `canopen-drive`: everything needed to run whole drives without
//! hardware, wall-clock time or threads, so that a test reads like a bus trace and gives the
//! same result on every run.
//!
//! ## Parts
//!
//! - [`bus`]: [`VirtualBus`], a CAN bus with a virtual clock. Nodes (anything implementing
//!   [`Node`], e.g. a [`canopen_drive::Drive`]) transmit frames that the bus delivers to every
//!   other node and to one external port for the test (the "master port"). The clock only
//!   moves when the test says so, stepping through every node deadline in order.
//! - [`fault`]: rules that drop, delay or duplicate frames on the bus, chosen by a predicate
//!   on the frame and its sender and/or by a seeded pseudo-random rate.
//! - [`trace`]: a record of every frame on the bus, rendered like `candump -ta` output.
//! - [`invariants`]: checks of the DESIGN invariants (dictionary consistency, energy, demand
//!   limits, one SDO answer per request) for fuzz targets and robustness tests.
//! - [`master`]: [`Master`], a scripted CANopen master on the master port: NMT commands and an
//!   SDO client (expedited, segmented and block transfer, both directions), plus raw
//!   request helpers for tests that assert exact frames.
//! - [`node`]: [`DriveNode`], a drive ticked at a fixed rate against a [`SimMotor`].
//! - [`motor`]: [`SimMotor`], a small simulated motor that turns a drive's
//!   [`Demand`](canopen_drive::hal::Demand) into the next feedback
//!   [`Sample`](canopen_drive::hal::Sample).
//!
//! ## Example
//!
//! ```
//! use canopen_drive::{Config, Drive};
//! use canopen_drive_sim::{Master, VirtualBus};
//!
//! let mut bus = VirtualBus::new();
//! bus.add_node(Drive::new(Config::new(5)).unwrap());
//! let mut master = Master::new(bus);
//! assert_eq!(master.sdo_upload(5, 0x1000, 0).unwrap(), [0x92, 0x01, 0x02, 0x00]);
//! assert!(master.bus().render_trace().contains("705   [1]  00"));
//! ```
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod bus;
pub mod fault;
pub mod flash;
pub mod invariants;
pub mod master;
pub mod motor;
pub mod node;
pub mod trace;

pub use bus::{BusError, Node, NodeHandle, Port, VirtualBus};
pub use fault::{FaultAction, FaultRule};
pub use master::{Master, SdoError};
pub use motor::SimMotor;
pub use node::DriveNode;
pub use trace::{Fate, TraceRecord};

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
//! - [`invariants`]: checks of the invariants the core promises (dictionary consistency, energy, demand
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
//!
//! ## Testing a firmware's object hooks
//!
//! A firmware's own objects (its table of manufacturer objects and its
//! [`ObjectHooks`](canopen_drive::od::ObjectHooks)) are plain Rust values, so the host test
//! links the very ones the MCU image links, puts the drive on the virtual bus and lets the
//! scripted master read and write them as a real master would: every refusal arrives as the
//! abort code on the bus, and the hooks' own state can be inspected afterwards.
//!
//! ```
//! use canopen_drive::od::{layout, AbortCode, Access, DataType, DefaultValue, Object, ObjectHooks, Var};
//! use canopen_drive::{Config, Drive};
//! use canopen_drive_sim::{Master, SdoError, VirtualBus};
//!
//! // In the firmware crate: a parameter with limits and a value the firmware measures.
//! static VENDOR: [Object; 2] = layout([
//!     Object::var(
//!         0x2000,
//!         "Pole pairs",
//!         Var::new("Pole pairs", DataType::Unsigned8)
//!             .access(Access::ReadWrite)
//!             .default(DefaultValue::Unsigned(4))
//!             .limits_unsigned(1, 32),
//!     ),
//!     Object::var(0x2001, "Board temperature", Var::new("Board temperature", DataType::Integer16)),
//! ]);
//!
//! struct Board {
//!     temperature_decidegrees: i16,
//!     motor_reconfigured: u32,
//! }
//!
//! impl ObjectHooks for Board {
//!     // The motor family has an even number of pole pairs.
//!     fn validate(&mut self, index: u16, _sub: u8, data: &[u8]) -> Result<(), AbortCode> {
//!         match (index, data) {
//!             (0x2000, [pairs]) if pairs % 2 == 1 => Err(AbortCode::InvalidValue),
//!             _ => Ok(()),
//!         }
//!     }
//!
//!     fn written(&mut self, index: u16, _sub: u8, _data: &[u8]) {
//!         if index == 0x2000 {
//!             self.motor_reconfigured += 1;
//!         }
//!     }
//!
//!     // 2001h is served from the sensor, not from the dictionary's store.
//!     fn read_len(&mut self, index: u16, _sub: u8) -> Option<Result<usize, AbortCode>> {
//!         (index == 0x2001).then_some(Ok(2))
//!     }
//!
//!     fn read(&mut self, _index: u16, _sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
//!         let bytes = self.temperature_decidegrees.to_le_bytes();
//!         let rest = bytes.get(offset..).unwrap_or(&[]);
//!         let n = rest.len().min(buf.len());
//!         buf[..n].copy_from_slice(&rest[..n]);
//!         Ok(n)
//!     }
//! }
//!
//! // In its host test: the drive with those hooks as node 5, a master on the bus.
//! let config = Config { manufacturer_objects: &VENDOR, ..Config::new(5) };
//! let board = Board { temperature_decidegrees: 412, motor_reconfigured: 0 };
//! let mut bus = VirtualBus::new();
//! let node = bus.add_node(Drive::with_hooks(config, board).unwrap());
//! let mut master = Master::new(bus);
//!
//! assert_eq!(master.sdo_upload(5, 0x2000, 0).unwrap(), [4]);
//! master.sdo_download(5, 0x2000, 0, &[8]).unwrap();
//! // Refused by the hook, and by the limits of the table before the hook is asked.
//! assert_eq!(master.sdo_download(5, 0x2000, 0, &[7]), Err(SdoError::Abort(AbortCode::InvalidValue)));
//! assert_eq!(master.sdo_download(5, 0x2000, 0, &[40]), Err(SdoError::Abort(AbortCode::ValueTooHigh)));
//! assert_eq!(master.sdo_upload(5, 0x2000, 0).unwrap(), [8]);
//! assert_eq!(master.sdo_upload(5, 0x2001, 0).unwrap(), 412i16.to_le_bytes());
//!
//! let drive = master.bus_mut().node_mut::<Drive<Board>>(node).unwrap();
//! assert_eq!(drive.hooks_mut().motor_reconfigured, 1);
//! ```
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

pub mod bus;
pub mod cia402;
pub mod fault;
pub mod flash;
pub mod invariants;
pub mod master;
pub mod motor;
pub mod node;
pub mod trace;

pub use bus::{BusError, Handle, Node, NodeHandle, Port, VirtualBus};
pub use cia402::{AxisMaster, MotionError};
pub use fault::{FaultAction, FaultRule};
pub use master::{Master, SdoError};
pub use motor::SimMotor;
pub use node::DriveNode;
pub use trace::{Fate, TraceRecord};

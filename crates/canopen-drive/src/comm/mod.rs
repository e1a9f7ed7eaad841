//! The CiA 301 communication services of a slave: NMT, SDO server, heartbeat producer.

pub mod emcy;
pub mod error_control;
pub mod heartbeat;
pub mod lss;
pub mod nmt;
pub mod pdo;
pub mod sdo_server;
pub mod sync;

pub use crate::wire::nmt::NmtState;

//! The communication services of a slave: the CiA 301 ones (NMT, SDO server, PDOs, SYNC, EMCY,
//! heartbeat producer, heartbeat consumer and node guarding with the error behaviour 1029h),
//! the CiA 305 LSS slave, CiA 302-3 program download and the CiA 303-3 indicators.

pub mod emcy;
pub mod error_control;
pub mod heartbeat;
pub mod indicators;
pub mod lss;
pub mod nmt;
pub mod pdo;
pub mod program;
pub mod sdo_server;
pub mod sync;

pub use crate::wire::nmt::NmtState;

/// Events that break the connection to the master; the CiA 402 layer reacts to them as the
/// abort connection option code 6007h says (CiA 402-2 §8.4.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConnectionEvent {
    /// The CAN controller went bus-off.
    BusOff,
    /// A consumed heartbeat timed out.
    HeartbeatLost,
    /// Life guarding failed.
    LifeGuardingLost,
    /// NMT Stopped was entered.
    NmtStopped,
    /// NMT reset application.
    ResetApplication,
    /// NMT reset communication.
    ResetCommunication,
}

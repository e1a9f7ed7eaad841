//! Stateless codecs of CANopen frames: each format is parsed from a received frame's bytes
//! into a `Repr`-style value and emitted into bytes for transmission. No state, no I/O.

mod abort;
pub mod cob_id;
pub mod crc;
pub mod lss;
pub mod nmt;
pub mod sdo;

/// Function code base of the NMT node-control frame (CiA 301 §7.2.8.3.1).
pub const NMT_COB_ID: u16 = 0x000;
/// Function code base of the NMT error-control frames (boot-up, heartbeat, guarding).
pub const ERROR_CONTROL_BASE: u16 = 0x700;
/// Function code base of the default SDO server's responses.
pub const SDO_TX_BASE: u16 = 0x580;
/// Function code base of the default SDO server's requests.
pub const SDO_RX_BASE: u16 = 0x600;

pub use abort::AbortCode;

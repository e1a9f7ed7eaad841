//! The CiA 402 procedures a master runs on a drive, over SDO, for host tests: the enable
//! sequence through the state machine (CiA 402-2 §8.2) and a profile position move
//! (CiA 402-2 §10), each waiting in virtual time for the statusword to say it is done.
//!
//! [`Master::axis`] gives an [`AxisMaster`] for one axis of one node (axis n's objects at
//! 6000h + n × 800h):
//!
//! ```
//! use canopen_drive::{Config, Drive, Duration};
//! use canopen_drive_sim::{DriveNode, Master, VirtualBus};
//!
//! let mut bus = VirtualBus::new();
//! bus.add_node(DriveNode::new(Drive::new(Config::new(5)).unwrap(), Duration::from_millis(1)));
//! let mut master = Master::new(bus);
//! let mut axis = master.axis(5, 0);
//! assert_eq!(axis.enable().unwrap() & 0x6F, 0x27, "Operation enabled");
//! axis.pp_move(-2_000, Duration::from_millis(2_000)).unwrap();
//! // Target reached: the position actual value 6064h within the position window 6067h.
//! assert!((axis.read_i32(0x6064).unwrap() + 2_000).abs() <= 100);
//! axis.disable().unwrap();
//! ```

use std::fmt;

use canopen_drive::Duration;

use crate::master::{Master, SdoError};

/// The statusword bits of the state (CiA 402-2 §8.4.2) and the state each procedure waits for.
const STATE_MASK: u16 = 0x006F;
const READY_TO_SWITCH_ON: u16 = 0x0021;
const SWITCHED_ON: u16 = 0x0023;
const OPERATION_ENABLED: u16 = 0x0027;
/// Fault and Fault reaction active share bit 3.
const FAULT_BIT: u16 = 0x0008;
/// Statusword bit 10 (target reached) and 12 (pp: set-point acknowledge).
const TARGET_REACHED: u16 = 1 << 10;
const SET_POINT_ACKNOWLEDGE: u16 = 1 << 12;

/// Controlword commands (CiA 402-2 §8.4.1): shutdown, switch on, enable operation, fault reset;
/// bit 4 is pp's new set-point.
const SHUTDOWN: u16 = 0x0006;
const SWITCH_ON: u16 = 0x0007;
const ENABLE_OPERATION: u16 = 0x000F;
const FAULT_RESET: u16 = 0x0080;
const NEW_SET_POINT: u16 = 0x0010;

/// How long a state change may take before [`MotionError::Timeout`] (virtual time).
const STATE_TIMEOUT: Duration = Duration::from_millis(200);

const CONTROLWORD: u16 = 0x6040;
const STATUSWORD: u16 = 0x6041;
const MODES_OF_OPERATION: u16 = 0x6060;
const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
const TARGET_POSITION: u16 = 0x607A;
/// 6060h's value of profile position.
const PROFILE_POSITION: i8 = 1;

/// Why a CiA 402 procedure did not finish.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotionError {
    /// An SDO transfer failed (e.g. the drive refused a value with an abort code).
    Sdo(SdoError),
    /// The drive did not get there in time; the statusword (6041h) it showed last.
    Timeout {
        /// What the procedure waited for.
        waiting_for: &'static str,
        /// 6041h as last read.
        statusword: u16,
    },
    /// The drive is in Fault (or Fault reaction active) and stayed there after a fault reset.
    Fault {
        /// 6041h as last read.
        statusword: u16,
    },
}

impl From<SdoError> for MotionError {
    fn from(error: SdoError) -> Self {
        MotionError::Sdo(error)
    }
}

impl fmt::Display for MotionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MotionError::Sdo(error) => write!(f, "{error}"),
            MotionError::Timeout { waiting_for, statusword } => {
                write!(f, "no {waiting_for} in time (statusword {statusword:04X}h)")
            }
            MotionError::Fault { statusword } => {
                write!(f, "the drive stays in Fault (statusword {statusword:04X}h)")
            }
        }
    }
}

impl std::error::Error for MotionError {}

impl Master {
    /// The CiA 402 procedures for axis `axis` (0 for the first, or only, one) of node `node`.
    pub fn axis(&mut self, node: u8, axis: u8) -> AxisMaster<'_> {
        AxisMaster { master: self, node, offset: u16::from(axis.min(7)) * 0x800 }
    }
}

/// One axis of one node, driven through SDO by the scripted [`Master`] (see the
/// [module docs](self)).
#[derive(Debug)]
pub struct AxisMaster<'a> {
    master: &'a mut Master,
    node: u8,
    /// The axis's distance from the first axis's objects (n × 800h).
    offset: u16,
}

impl AxisMaster<'_> {
    /// Reads the statusword 6041h.
    pub fn statusword(&mut self) -> Result<u16, SdoError> {
        let bytes = self.master.sdo_upload(self.node, STATUSWORD + self.offset, 0)?;
        Ok(u16::from_le_bytes(array(&bytes)))
    }

    /// Writes the controlword 6040h.
    pub fn controlword(&mut self, value: u16) -> Result<(), SdoError> {
        self.master.sdo_download(self.node, CONTROLWORD + self.offset, 0, &value.to_le_bytes())
    }

    /// Reads a 4-byte object of the axis given by its first axis's index (e.g. 6064h, the
    /// position actual value).
    pub fn read_i32(&mut self, index: u16) -> Result<i32, SdoError> {
        let bytes = self.master.sdo_upload(self.node, index + self.offset, 0)?;
        Ok(i32::from_le_bytes(array(&bytes)))
    }

    /// Brings the axis to Operation enabled: a fault reset first when it is in Fault, then
    /// shutdown, switch on, enable operation, each step waiting for its state. Returns the
    /// statusword in Operation enabled.
    pub fn enable(&mut self) -> Result<u16, MotionError> {
        let statusword = self.statusword()?;
        if statusword & FAULT_BIT != 0 {
            self.controlword(0)?;
            self.controlword(FAULT_RESET)?;
            let after = self.wait(|sw| sw & FAULT_BIT == 0, "fault reset", STATE_TIMEOUT);
            if let Err(MotionError::Timeout { statusword, .. }) = after {
                return Err(MotionError::Fault { statusword });
            }
            after?;
        }
        self.command(SHUTDOWN, READY_TO_SWITCH_ON, "Ready to switch on")?;
        self.command(SWITCH_ON, SWITCHED_ON, "Switched on")?;
        self.command(ENABLE_OPERATION, OPERATION_ENABLED, "Operation enabled")
    }

    /// Takes the energy away: shutdown, waiting for Ready to switch on.
    pub fn disable(&mut self) -> Result<u16, MotionError> {
        self.command(SHUTDOWN, READY_TO_SWITCH_ON, "Ready to switch on")
    }

    /// Selects the mode of operation (6060h) and waits until 6061h shows it.
    pub fn set_mode(&mut self, mode: i8) -> Result<(), MotionError> {
        self.master.sdo_download(self.node, MODES_OF_OPERATION + self.offset, 0, &mode.to_le_bytes())?;
        let deadline = self.master.now() + STATE_TIMEOUT;
        loop {
            let shown = self.master.sdo_upload(self.node, MODES_OF_OPERATION_DISPLAY + self.offset, 0)?;
            if shown.first().map(|b| *b as i8) == Some(mode) {
                return Ok(());
            }
            if self.master.now() >= deadline {
                let statusword = self.statusword()?;
                return Err(MotionError::Timeout { waiting_for: "mode of operation (6061h)", statusword });
            }
            self.master.advance(self.master.step()).map_err(SdoError::from)?;
        }
    }

    /// An absolute profile position move to `target` (user units) from Operation enabled:
    /// selects pp, writes 607Ah, raises the new set-point bit until the drive acknowledges it
    /// (statusword bit 12), lowers it, and waits for target reached (bit 10) for at most
    /// `timeout` of virtual time. Speeds and ramps are the axis's 6081h/6083h/6084h.
    pub fn pp_move(&mut self, target: i32, timeout: Duration) -> Result<u16, MotionError> {
        self.set_mode(PROFILE_POSITION)?;
        self.master.sdo_download(self.node, TARGET_POSITION + self.offset, 0, &target.to_le_bytes())?;
        self.controlword(ENABLE_OPERATION)?;
        self.controlword(ENABLE_OPERATION | NEW_SET_POINT)?;
        self.wait(|sw| sw & SET_POINT_ACKNOWLEDGE != 0, "set-point acknowledge", STATE_TIMEOUT)?;
        self.controlword(ENABLE_OPERATION)?;
        self.wait(|sw| sw & TARGET_REACHED != 0 && sw & SET_POINT_ACKNOWLEDGE == 0, "target reached", timeout)
    }

    /// Writes `command` and waits for the state `state`.
    fn command(&mut self, command: u16, state: u16, name: &'static str) -> Result<u16, MotionError> {
        self.controlword(command)?;
        self.wait(|sw| sw & STATE_MASK == state, name, STATE_TIMEOUT)
    }

    /// Reads the statusword every step of the master until `done` holds, for at most `timeout`.
    fn wait(
        &mut self,
        done: impl Fn(u16) -> bool,
        waiting_for: &'static str,
        timeout: Duration,
    ) -> Result<u16, MotionError> {
        let deadline = self.master.now() + timeout;
        loop {
            let statusword = self.statusword()?;
            if done(statusword) {
                return Ok(statusword);
            }
            if self.master.now() >= deadline {
                return Err(MotionError::Timeout { waiting_for, statusword });
            }
            self.master.advance(self.master.step()).map_err(SdoError::from)?;
        }
    }
}

/// The first `N` bytes of `bytes`, zero-extended.
fn array<const N: usize>(bytes: &[u8]) -> [u8; N] {
    let mut out = [0u8; N];
    for (o, b) in out.iter_mut().zip(bytes) {
        *o = *b;
    }
    out
}

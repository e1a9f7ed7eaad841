//! EMCY producer (CiA 301 §7.2.7): the one path every error of the drive takes.
//!
//! ```text
//! COB-ID 1014h (default 0x80+id), DLC 8:
//! [code LSB, code MSB, error register 1001h, 5 bytes manufacturer-specific]
//! ```
//!
//! The producer keeps the set of active errors. Raising an error that is not active yet sends
//! its EMCY (raising it again sends it once more, for a condition met again while the error
//! lasts); clearing one sends the "error reset" EMCY (code 0x0000) with the register that
//! remains. The error register is derived from the active set (bit 0 whenever any error is
//! active), so it can never disagree with it. Frames are queued and leave no closer together
//! than the inhibit time 1015h (100 µs units): delayed, never dropped, unless the queue
//! overflows, which is counted.

use bitflags::bitflags;
use heapless::{Deque, Vec};

use crate::od::standard::COB_ID_EMCY;
use crate::od::{le_u32, AbortCode, Dictionary};
use crate::time::{Duration, Instant};
use crate::wire::cob_id::{self, CobId};

/// Whether `index` is an object of the EMCY producer (1014h's rules: [`check_write`]).
pub const fn owns(index: u16) -> bool {
    matches!(index, COB_ID_EMCY | crate::od::standard::INHIBIT_TIME_EMCY)
}

/// The error history 1003h ([`check_history_write`], [`check_history_read`]).
pub const HISTORY: u16 = crate::od::standard::PRE_DEFINED_ERROR_FIELD;

/// The value rules of the EMCY objects (CiA 301 §7.2.7, §7.5.2): 1014h holds an unrestricted CAN-ID
/// without bit 30 that changes only while the EMCY is invalid (before or after the write).
pub fn check_write<const B: usize>(od: &Dictionary<B>, index: u16, data: &[u8]) -> Result<(), AbortCode> {
    if index != COB_ID_EMCY {
        return Ok(());
    }
    let new = CobId::parse(le_u32(data)).map_err(|_| AbortCode::InvalidValue)?;
    let old = od.get::<u32>(COB_ID_EMCY, 0).ok().and_then(|r| CobId::parse(r).ok());
    if new.bit30 || cob_id::is_restricted(new.can_id) {
        return Err(AbortCode::InvalidValue);
    }
    match old {
        Some(old) if old.valid && new.valid && old.can_id != new.can_id => Err(AbortCode::InvalidValue),
        _ => Ok(()),
    }
}

/// Where and how often the EMCY producer sends (1014h, 1015h), as the dictionary holds them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmcySettings {
    /// The CAN-ID of a valid 1014h; `None`: the EMCY is invalid (nothing is sent).
    pub can_id: Option<u16>,
    /// 1015h, 100 µs units.
    pub inhibit_100us: u16,
}

impl EmcySettings {
    /// The settings 1014h and 1015h hold.
    pub fn read<const B: usize>(od: &Dictionary<B>) -> Self {
        let cob = od.get::<u32>(COB_ID_EMCY, 0).ok().and_then(|raw| CobId::parse(raw).ok());
        EmcySettings {
            can_id: cob.filter(|c| c.valid).map(|c| c.can_id),
            inhibit_100us: od.get::<u16>(crate::od::standard::INHIBIT_TIME_EMCY, 0).unwrap_or(0),
        }
    }
}

/// Shows `register` in 1001h.
pub fn show_register<const B: usize>(od: &mut Dictionary<B>, register: ErrorRegister) {
    // 1001h is in the crate's own table: the write cannot fail.
    let _ = od.set::<u8>(crate::od::standard::ERROR_REGISTER, 0, register.bits());
}

/// Records an error in the history 1003h: newest first, the oldest falls off when full
/// (CiA 301 §7.5.2, 1001h/1003h); the entry holds the code and the first two additional bytes.
pub fn record_history<const B: usize>(od: &mut Dictionary<B>, code: u16, info: [u8; 5]) {
    use crate::od::standard::ERROR_HISTORY_LEN;
    let count = od.get::<u8>(HISTORY, 0).unwrap_or(0).min(ERROR_HISTORY_LEN);
    for sub in (1..ERROR_HISTORY_LEN).rev() {
        if let Ok(older) = od.get::<u32>(HISTORY, sub) {
            let _ = od.set::<u32>(HISTORY, sub + 1, older);
        }
    }
    let entry = u32::from(code) | (u32::from(u16::from_le_bytes([info[0], info[1]])) << 16);
    let _ = od.set::<u32>(HISTORY, 1, entry);
    let _ = od.set::<u8>(HISTORY, 0, (count + 1).min(ERROR_HISTORY_LEN));
}

/// The rule of the error history 1003h: only 0 may be written to the number of errors (it
/// clears the history).
pub fn check_history_write(data: &[u8]) -> Result<(), AbortCode> {
    if le_u32(data) == 0 {
        Ok(())
    } else {
        Err(AbortCode::InvalidValue)
    }
}

/// The read rule of the error history 1003h: an entry beyond the number of errors holds no
/// data (0x0800_0024).
pub fn check_history_read<const B: usize>(od: &Dictionary<B>, index: u16, sub: u8) -> Result<(), AbortCode> {
    if sub > od.get::<u8>(index, 0).unwrap_or(0) {
        Err(AbortCode::NoDataAvailable)
    } else {
        Ok(())
    }
}

bitflags! {
    /// Error register 1001h (CiA 301 §7.5.2, 1001h/1003h).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub struct ErrorRegister: u8 {
        /// Bit 0: generic error (set whenever any error is active).
        const GENERIC = 0x01;
        /// Bit 1: current.
        const CURRENT = 0x02;
        /// Bit 2: voltage.
        const VOLTAGE = 0x04;
        /// Bit 3: temperature.
        const TEMPERATURE = 0x08;
        /// Bit 4: communication error.
        const COMMUNICATION = 0x10;
        /// Bit 5: device-profile specific.
        const DEVICE_PROFILE = 0x20;
        /// Bit 7: manufacturer-specific.
        const MANUFACTURER = 0x80;
    }
}

// `defmt::Format`: the raw bits (a bitflags type cannot derive it).
#[cfg(feature = "defmt")]
impl defmt::Format for ErrorRegister {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "ErrorRegister({=u8:#x})", self.bits());
    }
}

/// EMCY error codes the communication layer raises (CiA 301 §7.2.7).
pub mod code {
    /// Error reset or no error.
    pub const NO_ERROR: u16 = 0x0000;
    /// Communication – generic (SYNC loss, as documented in `comm::sync`).
    pub const COMMUNICATION: u16 = 0x8100;
    /// CAN overrun (objects lost).
    pub const CAN_OVERRUN: u16 = 0x8110;
    /// CAN in error passive mode.
    pub const CAN_ERROR_PASSIVE: u16 = 0x8120;
    /// Life guard error or heartbeat error.
    pub const LIFE_GUARD_OR_HEARTBEAT: u16 = 0x8130;
    /// Recovered from bus off.
    pub const RECOVERED_FROM_BUS_OFF: u16 = 0x8140;
    /// Protocol error – generic (e.g. unusable PDO mapping).
    pub const PROTOCOL: u16 = 0x8200;
    /// PDO not processed due to length error.
    pub const PDO_LENGTH: u16 = 0x8210;
    /// PDO length exceeded.
    pub const PDO_LENGTH_EXCEEDED: u16 = 0x8220;
    /// Unexpected SYNC data length.
    pub const SYNC_LENGTH: u16 = 0x8240;
    /// RPDO timeout.
    pub const RPDO_TIMEOUT: u16 = 0x8250;
    /// Device software: data set (e.g. corrupt parameter storage).
    pub const DATA_SET: u16 = 0x6300;
}

/// One active error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActiveError {
    /// EMCY error code.
    pub code: u16,
    /// Error register bits the error sets.
    pub register: ErrorRegister,
    /// The logical device (CiA 402 axis) the error is of: 0 for the node's own errors and a
    /// single-axis drive's (the same code may be active for two axes at once).
    pub device: u8,
}

/// The EMCY producer with room for `ACTIVE` (at most 255) simultaneous errors and `QUEUE`
/// pending frames.
pub struct EmcyProducer<const ACTIVE: usize = 8, const QUEUE: usize = 8> {
    /// (A one-byte length: `ACTIVE` is at most 255.)
    active: Vec<ActiveError, ACTIVE, u8>,
    queue: Deque<[u8; 8], QUEUE>,
    next_allowed: Instant,
    /// Saturates at 65 535 (two bytes: with them the producer is 120 bytes, not 128).
    lost: u16,
}

impl<const ACTIVE: usize, const QUEUE: usize> Default for EmcyProducer<ACTIVE, QUEUE> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const ACTIVE: usize, const QUEUE: usize> EmcyProducer<ACTIVE, QUEUE> {
    /// No active error, nothing queued.
    pub const fn new() -> Self {
        EmcyProducer { active: Vec::new(), queue: Deque::new(), next_allowed: Instant::ZERO, lost: 0 }
    }

    /// The error register derived from the active errors.
    pub fn register(&self) -> ErrorRegister {
        let bits = self.active.iter().fold(ErrorRegister::empty(), |acc, e| acc | e.register);
        if self.active.is_empty() {
            bits
        } else {
            bits | ErrorRegister::GENERIC
        }
    }

    /// The active errors, oldest first.
    pub fn active(&self) -> &[ActiveError] {
        &self.active
    }

    /// True when `code` is active.
    pub fn is_active(&self, code: u16) -> bool {
        self.active.iter().any(|e| e.code == code)
    }

    /// Frames lost because the queue or the active set was full (saturating at 65 535).
    pub fn lost(&self) -> u32 {
        u32::from(self.lost)
    }

    /// Raises `code`; returns the EMCY frame data when the error was not active yet (the frame
    /// is also queued for transmission).
    pub fn raise(&mut self, code: u16, register: ErrorRegister, info: [u8; 5]) -> Option<[u8; 8]> {
        self.raise_of(0, code, register, info)
    }

    /// [`Self::raise`] for logical device `device` (an error active for one axis is raised
    /// again for another).
    pub fn raise_of(
        &mut self,
        device: u8,
        code: u16,
        register: ErrorRegister,
        info: [u8; 5],
    ) -> Option<[u8; 8]> {
        if self.active.iter().any(|e| e.code == code && e.device == device) {
            return None;
        }
        if self.active.push(ActiveError { code, register, device }).is_err() {
            // Still reported on the bus; the register keeps what fits.
            self.lost = self.lost.saturating_add(1);
        }
        Some(self.enqueue(code, info))
    }

    /// Raises `code` for `device` as [`Self::raise_of`] does; when it is active already, queues
    /// its EMCY once more (the condition met again while the error lasts, e.g. a limit switch
    /// touched again) without changing the active set. Returns the EMCY frame data.
    pub fn raise_again_of(
        &mut self,
        device: u8,
        code: u16,
        register: ErrorRegister,
        info: [u8; 5],
    ) -> [u8; 8] {
        match self.raise_of(device, code, register, info) {
            Some(frame) => frame,
            None => self.enqueue(code, info),
        }
    }

    /// Clears `code`; when it was active, queues the "error reset" EMCY and returns true.
    pub fn clear(&mut self, code: u16) -> bool {
        self.clear_of(0, code)
    }

    /// [`Self::clear`] for logical device `device`.
    pub fn clear_of(&mut self, device: u8, code: u16) -> bool {
        let Some(pos) = self.active.iter().position(|e| e.code == code && e.device == device) else {
            return false;
        };
        self.active.remove(pos);
        self.enqueue(code::NO_ERROR, [0; 5]);
        true
    }

    /// Forgets every active error and pending frame (reset communication).
    pub fn reset(&mut self) {
        self.active.clear();
        self.queue.clear();
    }

    /// Drops pending frames without forgetting the errors (EMCY invalid via 1014h).
    pub fn discard_pending(&mut self) {
        self.queue.clear();
    }

    fn enqueue(&mut self, code: u16, info: [u8; 5]) -> [u8; 8] {
        let [lo, hi] = code.to_le_bytes();
        let [i0, i1, i2, i3, i4] = info;
        let frame = [lo, hi, self.register().bits(), i0, i1, i2, i3, i4];
        if self.queue.push_back(frame).is_err() {
            self.lost = self.lost.saturating_add(1);
        }
        frame
    }

    /// The next frame to send at `now`, respecting the inhibit time (100 µs units).
    pub fn pop_due(&mut self, now: Instant, inhibit_100us: u16) -> Option<[u8; 8]> {
        if now < self.next_allowed {
            return None;
        }
        let frame = self.queue.pop_front()?;
        self.next_allowed = now + Duration::from_micros(u64::from(inhibit_100us) * 100);
        Some(frame)
    }

    /// When a queued frame may be sent.
    pub fn deadline(&self) -> Option<Instant> {
        (!self.queue.is_empty()).then_some(self.next_allowed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn register_follows_the_active_errors() {
        let mut emcy = EmcyProducer::<4, 8>::new();
        let f = emcy.raise(0x8130, ErrorRegister::COMMUNICATION, [0; 5]).unwrap();
        assert_eq!(f, [0x30, 0x81, 0x11, 0, 0, 0, 0, 0]);
        assert_eq!(emcy.raise(0x8130, ErrorRegister::COMMUNICATION, [0; 5]), None, "already active");
        emcy.raise(0x4210, ErrorRegister::TEMPERATURE, [1, 2, 3, 4, 5]);
        assert_eq!(emcy.register().bits(), 0x19);
        assert!(emcy.clear(0x8130));
        assert!(!emcy.clear(0x8130));
        assert_eq!(emcy.register().bits(), 0x09);
        emcy.clear(0x4210);
        assert_eq!(emcy.register().bits(), 0);
        let now = Instant::ZERO;
        let sent: std::vec::Vec<[u8; 8]> = std::iter::from_fn(|| emcy.pop_due(now, 0)).collect();
        assert_eq!(
            sent,
            [
                [0x30, 0x81, 0x11, 0, 0, 0, 0, 0],
                [0x10, 0x42, 0x19, 1, 2, 3, 4, 5],
                [0x00, 0x00, 0x09, 0, 0, 0, 0, 0],
                [0x00, 0x00, 0x00, 0, 0, 0, 0, 0],
            ]
        );
    }

    #[test]
    fn an_active_error_may_be_reported_again() {
        let mut emcy = EmcyProducer::<4, 8>::new();
        let first = emcy.raise_again_of(0, 0xFF01, ErrorRegister::MANUFACTURER, [3, 0, 0, 0, 0]);
        assert_eq!(first, [0x01, 0xFF, 0x81, 3, 0, 0, 0, 0], "not active yet: raised");
        let again = emcy.raise_again_of(0, 0xFF01, ErrorRegister::MANUFACTURER, [4, 0, 0, 0, 0]);
        assert_eq!(again, [0x01, 0xFF, 0x81, 4, 0, 0, 0, 0], "active: the EMCY once more");
        assert_eq!(emcy.active().len(), 1, "still one active error");
        assert!(emcy.clear(0xFF01));
        assert_eq!(emcy.register(), ErrorRegister::empty());
        let sent: std::vec::Vec<[u8; 8]> = std::iter::from_fn(|| emcy.pop_due(Instant::ZERO, 0)).collect();
        assert_eq!(sent, [first, again, [0; 8]]);
    }

    #[test]
    fn inhibit_time_delays_without_dropping() {
        let mut emcy = EmcyProducer::<4, 8>::new();
        emcy.raise(0x1000, ErrorRegister::empty(), [0; 5]);
        emcy.raise(0x2000, ErrorRegister::CURRENT, [0; 5]);
        let t0 = Instant::from_millis(10);
        assert!(emcy.pop_due(t0, 50).is_some());
        assert_eq!(emcy.deadline(), Some(t0 + Duration::from_millis(5)));
        assert!(emcy.pop_due(t0 + Duration::from_micros(4999), 50).is_none());
        assert_eq!(emcy.pop_due(t0 + Duration::from_millis(5), 50).unwrap()[..2], [0x00, 0x20]);
        assert_eq!(emcy.deadline(), None);
    }

    extern crate std;
}

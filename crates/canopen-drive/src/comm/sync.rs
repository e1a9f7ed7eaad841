//! SYNC consumer and producer (CiA 301 §7.2.5).
//!
//! ```text
//! COB-ID 1005h (default 0x080): DLC 0, or DLC 1 = [counter] when 1019h ≠ 0
//! 1005h bit 30 = this device produces SYNC every 1006h µs
//! ```
//!
//! The counter runs 1..=1019h and starts again at 1; it restarts at 1 after boot-up and when
//! the node leaves Stopped. A consumer that was receiving SYNC and hears none for 1.5 × 1006h
//! raises EMCY 0x8100 (communication, generic; the reaction is left to the manufacturer by
//! CiA 301), cleared by the next SYNC. A SYNC of the wrong length raises EMCY 0x8240 and is not
//! processed.

use crate::od::standard::{
    COB_ID_SYNC, COMMUNICATION_CYCLE_PERIOD, SYNCHRONOUS_COUNTER_OVERFLOW, SYNCHRONOUS_WINDOW_LENGTH,
};
use crate::od::{le_u32, AbortCode, Dictionary, Slot};
use crate::time::{Duration, Instant};
use crate::wire::cob_id::{self, CobId};

/// Whether `index` is an object of SYNC: its rules ([`check_write`]), and a restart of SYNC
/// when it is written.
pub const fn owns(index: u16) -> bool {
    matches!(index, COB_ID_SYNC | COMMUNICATION_CYCLE_PERIOD | SYNCHRONOUS_COUNTER_OVERFLOW)
}

/// The value rules of the SYNC objects (CiA 301 §7.2.5, §7.5.2): 1005h holds a valid, unrestricted
/// CAN-ID that does not change while this device produces SYNC; 1019h is 0 or 2..=240 and
/// changes only while 1006h is 0.
pub fn check_write<const B: usize>(od: &Dictionary<B>, index: u16, data: &[u8]) -> Result<(), AbortCode> {
    let raw = le_u32(data);
    match index {
        COB_ID_SYNC => {
            let new = CobId::parse(raw).map_err(|_| AbortCode::InvalidValue)?;
            if raw & cob_id::INVALID != 0 || cob_id::is_restricted(new.can_id) {
                return Err(AbortCode::InvalidValue);
            }
            let old = od.get::<u32>(COB_ID_SYNC, 0).unwrap_or(0x80);
            // The CAN-ID must not change while this device produces SYNC.
            if old & cob_id::BIT30 != 0 && (old & 0x7FF) as u16 != new.can_id {
                return Err(AbortCode::InvalidValue);
            }
            Ok(())
        }
        SYNCHRONOUS_COUNTER_OVERFLOW => {
            if od.get::<u32>(COMMUNICATION_CYCLE_PERIOD, 0).unwrap_or(0) != 0 {
                Err(AbortCode::CannotStoreDeviceState)
            } else if raw == 1 || raw > 240 {
                Err(AbortCode::InvalidValue)
            } else {
                Ok(())
            }
        }
        _ => Ok(()),
    }
}

/// The SYNC entries read on every frame or poll, resolved once ([`Dictionary::slot`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncSlots {
    cob_id: Slot<u32>,
    period: Slot<u32>,
    overflow: Slot<u8>,
    window: Slot<u32>,
}

impl SyncSlots {
    /// Slots that look their entries up (before the dictionary has its tables).
    pub const LOOKUP: SyncSlots = SyncSlots {
        cob_id: Slot::lookup(COB_ID_SYNC, 0),
        period: Slot::lookup(COMMUNICATION_CYCLE_PERIOD, 0),
        overflow: Slot::lookup(SYNCHRONOUS_COUNTER_OVERFLOW, 0),
        window: Slot::lookup(SYNCHRONOUS_WINDOW_LENGTH, 0),
    };

    /// The slots of `od`.
    pub fn resolve<const B: usize>(od: &Dictionary<B>) -> Self {
        SyncSlots {
            cob_id: od.slot(COB_ID_SYNC, 0),
            period: od.slot(COMMUNICATION_CYCLE_PERIOD, 0),
            overflow: od.slot(SYNCHRONOUS_COUNTER_OVERFLOW, 0),
            window: od.slot(SYNCHRONOUS_WINDOW_LENGTH, 0),
        }
    }

    /// The synchronous window 1007h in µs (0: none): synchronous RPDOs received later after a
    /// SYNC are discarded.
    #[inline]
    pub fn window_us<const B: usize>(&self, od: &Dictionary<B>) -> u32 {
        od.load(self.window)
    }

    /// The SYNC CAN-ID (1005h bits 10..0).
    #[inline]
    pub fn can_id<const B: usize>(&self, od: &Dictionary<B>) -> u16 {
        (od.load_or(self.cob_id, 0x80) & 0x7FF) as u16
    }

    /// The configuration 1005h/1006h/1019h hold.
    pub fn config<const B: usize>(&self, od: &Dictionary<B>) -> SyncConfig {
        SyncConfig {
            producer: od.load_or(self.cob_id, 0x80) & cob_id::BIT30 != 0,
            period_us: od.load(self.period),
            overflow: od.load(self.overflow),
        }
    }
}

/// A SYNC the node processes (received, or produced by itself).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SyncEvent {
    /// The counter, when 1019h ≠ 0.
    pub counter: Option<u8>,
    /// When it happened.
    pub at: Instant,
}

/// What a received SYNC frame means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SyncReception {
    /// A valid SYNC.
    Sync(SyncEvent),
    /// Wrong data length for the configured counter (EMCY 0x8240).
    WrongLength,
}

/// SYNC configuration read from 1005h/1006h/1019h.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncConfig {
    /// Bit 30 of 1005h.
    pub producer: bool,
    /// 1006h in µs (0 = not used).
    pub period_us: u32,
    /// 1019h (0 = no counter).
    pub overflow: u8,
}

/// SYNC state of the node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sync {
    counter: u8,
    last: Option<Instant>,
    next_production: Option<Instant>,
    lost: bool,
}

impl Default for Sync {
    fn default() -> Self {
        Sync { counter: 1, last: None, next_production: None, lost: false }
    }
}

/// What the supervision found at a poll.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SyncPoll {
    /// Nothing due.
    Idle,
    /// The node produces a SYNC now: send `data` and process the event.
    Produce(SyncEvent),
    /// SYNC lost (EMCY 0x8100).
    Lost,
}

impl Sync {
    /// Counter back to 1, supervision and production restart (boot-up, leaving Stopped, a new
    /// configuration).
    pub fn restart(&mut self, now: Instant, config: SyncConfig) {
        self.counter = 1;
        self.last = None;
        self.next_production = (config.producer && config.period_us != 0)
            .then(|| now + Duration::from_micros(u64::from(config.period_us)));
    }

    /// A frame on the SYNC COB-ID with `data`, at `now`.
    pub fn on_frame(&mut self, data: &[u8], now: Instant, config: SyncConfig) -> SyncReception {
        let counter = match (config.overflow, data) {
            (0, []) => None,
            (1..=255, [counter]) => Some(*counter),
            _ => return SyncReception::WrongLength,
        };
        self.last = Some(now);
        SyncReception::Sync(SyncEvent { counter, at: now })
    }

    /// True while the SYNC is lost (from the missed window until it comes back).
    pub fn is_lost(&self) -> bool {
        self.lost
    }

    /// Takes the "lost" flag when SYNC came back (the caller clears EMCY 0x8100).
    pub fn take_recovered(&mut self) -> bool {
        self.last.is_some() && core::mem::take(&mut self.lost)
    }

    /// Production and supervision due at `now`.
    pub fn poll(&mut self, now: Instant, config: SyncConfig) -> SyncPoll {
        if let Some(at) = self.next_production {
            if now >= at {
                let period = Duration::from_micros(u64::from(config.period_us.max(1)));
                let next = at + period;
                self.next_production = Some(if next > now { next } else { now + period });
                let counter = (config.overflow >= 2).then(|| self.advance_counter(config.overflow));
                self.last = Some(now);
                return SyncPoll::Produce(SyncEvent { counter, at: now });
            }
            return SyncPoll::Idle;
        }
        match self.supervision_deadline(config) {
            Some(deadline) if now >= deadline && !self.lost => {
                self.lost = true;
                SyncPoll::Lost
            }
            _ => SyncPoll::Idle,
        }
    }

    fn advance_counter(&mut self, overflow: u8) -> u8 {
        let value = self.counter;
        self.counter = if value >= overflow { 1 } else { value + 1 };
        value
    }

    fn supervision_deadline(&self, config: SyncConfig) -> Option<Instant> {
        if config.producer || config.period_us == 0 {
            return None;
        }
        let limit = Duration::from_micros(u64::from(config.period_us) * 3 / 2);
        self.last.map(|last| last + limit)
    }

    /// When [`poll`](Self::poll) has something to do.
    pub fn deadline(&self, config: SyncConfig) -> Option<Instant> {
        self.next_production.or(if self.lost { None } else { self.supervision_deadline(config) })
    }

    /// The last SYNC (received or produced).
    pub fn last(&self) -> Option<Instant> {
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CONSUMER: SyncConfig = SyncConfig { producer: false, period_us: 1000, overflow: 0 };

    #[test]
    fn consumer_checks_length_and_supervises() {
        let mut s = Sync::default();
        let t = Instant::from_millis(10);
        assert_eq!(s.on_frame(&[1], t, CONSUMER), SyncReception::WrongLength);
        assert_eq!(s.poll(t + Duration::from_millis(100), CONSUMER), SyncPoll::Idle, "not started");
        assert!(matches!(s.on_frame(&[], t, CONSUMER), SyncReception::Sync(SyncEvent { counter: None, .. })));
        assert_eq!(s.poll(t + Duration::from_micros(1499), CONSUMER), SyncPoll::Idle);
        assert_eq!(s.poll(t + Duration::from_micros(1500), CONSUMER), SyncPoll::Lost);
        assert_eq!(s.poll(t + Duration::from_micros(9000), CONSUMER), SyncPoll::Idle, "reported once");
        s.on_frame(&[], t + Duration::from_millis(10), CONSUMER);
        assert!(s.take_recovered());
        let counted = SyncConfig { overflow: 5, ..CONSUMER };
        assert_eq!(s.on_frame(&[], t, counted), SyncReception::WrongLength);
        assert!(matches!(
            s.on_frame(&[3], t, counted),
            SyncReception::Sync(SyncEvent { counter: Some(3), .. })
        ));
    }

    #[test]
    fn producer_counts_one_to_overflow() {
        let config = SyncConfig { producer: true, period_us: 1000, overflow: 3 };
        let mut s = Sync::default();
        let t0 = Instant::ZERO;
        s.restart(t0, config);
        let mut counters = std::vec::Vec::new();
        for ms in 1..=7 {
            match s.poll(Instant::from_millis(ms), config) {
                SyncPoll::Produce(e) => counters.push(e.counter),
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(counters, [1, 2, 3, 1, 2, 3, 1].map(Some));
        assert_eq!(s.poll(Instant::from_micros(7500), config), SyncPoll::Idle);
        assert_eq!(s.deadline(config), Some(Instant::from_millis(8)));
    }

    extern crate std;
}

//! Heartbeat producer (CiA 301 §7.2.8.3.2.2): every 1017h ms the frame
//! `0x700+id [state]`. A period of 0 disables it. A change of period or of NMT state sends a
//! heartbeat at once and restarts the period from there.

use crate::od::standard::PRODUCER_HEARTBEAT_TIME;
use crate::od::{Dictionary, Slot};
use crate::time::{Duration, Instant};

/// The producer heartbeat time 1017h, resolved once (read at every poll).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PeriodSlot(Slot<u16>);

impl PeriodSlot {
    /// A slot that looks 1017h up (before the dictionary has its tables).
    pub const LOOKUP: PeriodSlot = PeriodSlot(Slot::lookup(PRODUCER_HEARTBEAT_TIME, 0));

    /// The slot of `od`.
    pub fn resolve<const B: usize>(od: &Dictionary<B>) -> Self {
        PeriodSlot(od.slot(PRODUCER_HEARTBEAT_TIME, 0))
    }

    /// 1017h in ms (0: no heartbeat).
    #[inline]
    pub fn period_ms<const B: usize>(&self, od: &Dictionary<B>) -> u16 {
        od.load(self.0)
    }
}

/// Heartbeat producer timing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HeartbeatProducer {
    next: Option<Instant>,
}

impl HeartbeatProducer {
    /// Schedules a heartbeat at `now` (state or period changed) if the period is not 0.
    pub fn restart(&mut self, now: Instant, period_ms: u16) {
        self.next = (period_ms != 0).then_some(now);
    }

    /// Stops producing (period 0, or before boot-up).
    pub fn stop(&mut self) {
        self.next = None;
    }

    /// True when a heartbeat is due at `now`; schedules the next one.
    pub fn due(&mut self, now: Instant, period_ms: u16) -> bool {
        match self.next {
            Some(at) if period_ms != 0 && now >= at => {
                let period = Duration::from_millis(u64::from(period_ms));
                // Keep the grid when polled late, but never schedule into the past.
                let next = at + period;
                self.next = Some(if next > now { next } else { now + period });
                true
            }
            Some(_) if period_ms == 0 => {
                self.next = None;
                false
            }
            _ => false,
        }
    }

    /// When the next heartbeat is due.
    pub fn deadline(&self) -> Option<Instant> {
        self.next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_period_grid() {
        let mut hb = HeartbeatProducer::default();
        hb.restart(Instant::from_millis(0), 100);
        assert!(hb.due(Instant::from_millis(0), 100));
        assert!(!hb.due(Instant::from_millis(99), 100));
        assert!(hb.due(Instant::from_millis(103), 100));
        assert_eq!(hb.deadline(), Some(Instant::from_millis(200)));
        // Polled very late: the next one is a full period later, not a burst.
        assert!(hb.due(Instant::from_millis(1000), 100));
        assert_eq!(hb.deadline(), Some(Instant::from_millis(1100)));
    }

    #[test]
    fn period_zero_disables() {
        let mut hb = HeartbeatProducer::default();
        hb.restart(Instant::from_millis(0), 0);
        assert_eq!(hb.deadline(), None);
        hb.restart(Instant::from_millis(0), 10);
        assert!(!hb.due(Instant::from_millis(5), 0));
        assert_eq!(hb.deadline(), None);
    }
}

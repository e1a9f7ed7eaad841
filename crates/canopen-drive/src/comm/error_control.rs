//! Error control consumers (CiA 301 §7.2.8.3): heartbeat consumer (1016h),
//! node guarding / life guarding (100Ch, 100Dh) and the error behaviour 1029h.
//!
//! ```text
//! heartbeat of node n   COB-ID 0x700+n, DLC 1: [state]  (0x00 = boot-up)
//! guarding request      remote frame COB-ID 0x700+id, DLC 1
//! guarding response     COB-ID 0x700+id, DLC 1: [toggle << 7 | state]
//! ```
//!
//! Supervision of a heartbeat entry starts with the first heartbeat received from its node,
//! never at configuration (a consumer configured before its producer boots does not time out). A boot-up from a node that was being supervised is
//! a "remote reset" event; the entry then waits for the node's next heartbeat. Life guarding
//! starts with the first guarding request and is active only while 1017h = 0.

use crate::od::standard::{CONSUMER_HEARTBEAT_TIME, GUARD_TIME, HEARTBEAT_CONSUMERS, LIFE_TIME_FACTOR};
use crate::od::{le_u32, AbortCode, Dictionary};
use crate::time::{Duration, Instant};
use crate::wire::nmt::NmtState;

/// State of one heartbeat-consumer entry (CiA 301 §7.2.8.3.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Supervision {
    /// Node-ID or time is 0: not used.
    Unconfigured,
    /// Configured; no heartbeat seen yet (not supervised).
    Waiting,
    /// Heartbeat seen; a timeout is due at `deadline`.
    Active {
        /// When the entry times out without a new heartbeat.
        deadline: Instant,
    },
    /// The heartbeat stopped; waiting for it to come back.
    TimedOut,
}

/// What the consumer tells the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ConsumerEvent {
    /// An active entry timed out (EMCY 0x8130, 1029h reaction).
    Timeout {
        /// The node that went silent.
        node_id: u8,
    },
    /// A supervised node sent a boot-up (it reset).
    RemoteReset {
        /// The node that reset.
        node_id: u8,
    },
    /// A timed-out node is heard again.
    Recovered {
        /// The node that came back.
        node_id: u8,
    },
}

/// Splits a 1016h entry into (node-ID, time in ms); `None` when unused.
pub fn parse_entry(raw: u32) -> Option<(u8, u16)> {
    let node = ((raw >> 16) & 0xFF) as u8;
    let time = (raw & 0xFFFF) as u16;
    (node != 0 && time != 0).then_some((node, time))
}

/// The heartbeat consumer's object ([`check_consumer_write`]; a write configures the entry).
pub const CONSUMER_OBJECT: u16 = CONSUMER_HEARTBEAT_TIME;

/// The heartbeat producer's object (a write restarts the producer and ends life guarding).
pub const PRODUCER_OBJECT: u16 = crate::od::standard::PRODUCER_HEARTBEAT_TIME;

/// Whether `index` is an object of node guarding (a zero in either ends life guarding:
/// [`guarding_configured`]).
pub const fn guarding_owns(index: u16) -> bool {
    matches!(index, GUARD_TIME | LIFE_TIME_FACTOR)
}

/// The error behaviour 1029h ([`ErrorBehaviour::check_write`]).
pub const ERROR_BEHAVIOUR_OBJECT: u16 = crate::od::standard::ERROR_BEHAVIOUR;

/// The rule of the heartbeat consumer 1016h (CiA 301 §7.2.8.3.2.2): two entries must not supervise the
/// same node.
pub fn check_consumer_write<const B: usize>(
    od: &Dictionary<B>,
    sub: u8,
    data: &[u8],
) -> Result<(), AbortCode> {
    let Some((node, _)) = parse_entry(le_u32(data)) else { return Ok(()) };
    let duplicate = (1..=HEARTBEAT_CONSUMERS).filter(|&s| s != sub).any(|s| {
        od.get::<u32>(CONSUMER_HEARTBEAT_TIME, s).ok().and_then(parse_entry).is_some_and(|(n, _)| n == node)
    });
    if duplicate {
        Err(AbortCode::ParameterIncompatible)
    } else {
        Ok(())
    }
}

/// The life time in ms: guard time 100Ch × life time factor 100Dh.
pub fn life_time_ms<const B: usize>(od: &Dictionary<B>) -> u32 {
    u32::from(od.get::<u16>(GUARD_TIME, 0).unwrap_or(0))
        * u32::from(od.get::<u8>(LIFE_TIME_FACTOR, 0).unwrap_or(0))
}

/// Whether guard time 100Ch and life time factor 100Dh both enable life guarding (a zero in
/// either ends it).
pub fn guarding_configured<const B: usize>(od: &Dictionary<B>) -> bool {
    od.get::<u16>(GUARD_TIME, 0).unwrap_or(0) != 0 && od.get::<u8>(LIFE_TIME_FACTOR, 0).unwrap_or(0) != 0
}

/// The heartbeat consumer with `N` entries.
#[derive(Clone, Debug)]
pub struct HeartbeatConsumer<const N: usize> {
    entries: [(u32, Supervision); N],
}

impl<const N: usize> Default for HeartbeatConsumer<N> {
    fn default() -> Self {
        HeartbeatConsumer { entries: [(0, Supervision::Unconfigured); N] }
    }
}

impl<const N: usize> HeartbeatConsumer<N> {
    /// Sets entry `sub` (1-based) from its raw 1016h value; supervision restarts (waits for the
    /// first heartbeat).
    pub fn configure(&mut self, sub: u8, raw: u32) {
        if let Some(slot) = usize::from(sub).checked_sub(1).and_then(|i| self.entries.get_mut(i)) {
            let state =
                if parse_entry(raw).is_some() { Supervision::Waiting } else { Supervision::Unconfigured };
            *slot = (raw, state);
        }
    }

    /// Every entry from the 1016h the dictionary holds (at power-on and reset communication:
    /// the stored entries supervise as the written ones do); supervision waits for the first
    /// heartbeat of each node.
    pub fn configure_all<const B: usize>(&mut self, od: &Dictionary<B>) {
        for sub in (1..=N).filter_map(|n| u8::try_from(n).ok()) {
            self.configure(sub, od.get::<u32>(CONSUMER_HEARTBEAT_TIME, sub).unwrap_or(0));
        }
    }

    /// The state of entry `sub` (1-based).
    pub fn state(&self, sub: u8) -> Option<Supervision> {
        usize::from(sub).checked_sub(1).and_then(|i| self.entries.get(i)).map(|(_, s)| *s)
    }

    /// A heartbeat or boot-up `state_byte` from `node_id` at `now`.
    pub fn on_heartbeat(&mut self, node_id: u8, state_byte: u8, now: Instant) -> Option<ConsumerEvent> {
        let mut event = None;
        for (raw, state) in self.entries.iter_mut() {
            let Some((node, time)) = parse_entry(*raw) else { continue };
            if node != node_id {
                continue;
            }
            let deadline = now + Duration::from_millis(u64::from(time));
            *state = match (*state, state_byte) {
                (Supervision::Active { .. }, 0x00) => {
                    event = Some(ConsumerEvent::RemoteReset { node_id });
                    Supervision::Waiting
                }
                (Supervision::TimedOut, 0x00) => {
                    event = Some(ConsumerEvent::Recovered { node_id });
                    Supervision::Waiting
                }
                (Supervision::TimedOut, _) => {
                    event = Some(ConsumerEvent::Recovered { node_id });
                    Supervision::Active { deadline }
                }
                // A boot-up is not a heartbeat: supervision starts with the next one.
                (Supervision::Waiting, 0x00) => Supervision::Waiting,
                (Supervision::Waiting | Supervision::Active { .. }, _) => Supervision::Active { deadline },
                (Supervision::Unconfigured, _) => Supervision::Unconfigured,
            };
        }
        event
    }

    /// Checks the deadlines at `now`; returns the first entry that timed out.
    pub fn poll(&mut self, now: Instant) -> Option<ConsumerEvent> {
        for (raw, state) in self.entries.iter_mut() {
            if let Supervision::Active { deadline } = *state {
                if now >= deadline {
                    *state = Supervision::TimedOut;
                    let node_id = parse_entry(*raw).map_or(0, |(n, _)| n);
                    return Some(ConsumerEvent::Timeout { node_id });
                }
            }
        }
        None
    }

    /// The nodes whose heartbeats are supervised.
    pub fn nodes(&self) -> impl Iterator<Item = u8> + '_ {
        self.entries.iter().filter_map(|(raw, _)| parse_entry(*raw).map(|(node, _)| node))
    }

    /// True while any entry is timed out.
    pub fn any_timed_out(&self) -> bool {
        self.entries.iter().any(|(_, s)| *s == Supervision::TimedOut)
    }

    /// The earliest deadline.
    pub fn deadline(&self) -> Option<Instant> {
        self.entries
            .iter()
            .filter_map(|(_, s)| match s {
                Supervision::Active { deadline } => Some(*deadline),
                _ => None,
            })
            .min()
    }
}

/// Node guarding responder and life guarding supervisor.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeGuarding {
    toggle: bool,
    deadline: Option<Instant>,
    failed: bool,
}

/// What a guarding request or the life-guarding timer tells the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum GuardingEvent {
    /// No guarding request within the node life time (EMCY 0x8130, 1029h reaction).
    LifeGuardingFailed,
    /// Guarding requests arrive again after a failure.
    Resumed,
}

impl NodeGuarding {
    /// Answers a guarding request at `now`: the response byte, and an event if guarding
    /// resumed. `life_time_ms` = 100Ch × 100Dh (0 = no life guarding).
    pub fn on_request(
        &mut self,
        state: NmtState,
        life_time_ms: u32,
        now: Instant,
    ) -> (u8, Option<GuardingEvent>) {
        let byte = (u8::from(self.toggle) << 7) | (state.heartbeat_byte() & 0x7F);
        self.toggle = !self.toggle;
        self.deadline = (life_time_ms != 0).then(|| now + Duration::from_millis(u64::from(life_time_ms)));
        let event = core::mem::take(&mut self.failed).then_some(GuardingEvent::Resumed);
        (byte, event)
    }

    /// Checks the life time at `now`.
    pub fn poll(&mut self, now: Instant) -> Option<GuardingEvent> {
        match self.deadline {
            Some(deadline) if now >= deadline => {
                self.deadline = None;
                self.failed = true;
                Some(GuardingEvent::LifeGuardingFailed)
            }
            _ => None,
        }
    }

    /// Stops supervision (life time set to 0, or heartbeat producer enabled).
    pub fn stop(&mut self) {
        self.deadline = None;
    }

    /// Back to the power-on state (reset communication): toggle 0, no supervision.
    pub fn reset(&mut self) {
        *self = NodeGuarding::default();
    }

    /// True after a life-guarding failure until requests resume.
    pub fn failed(&self) -> bool {
        self.failed
    }

    /// When life guarding fails without a request.
    pub fn deadline(&self) -> Option<Instant> {
        self.deadline
    }
}

/// Communication-error reaction of 1029h sub 1 (CiA 301 §7.5.2, 1029h).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorBehaviour {
    /// 0: enter Pre-operational, only if currently Operational.
    PreOperational,
    /// 1: no change of NMT state.
    NoChange,
    /// 2: enter Stopped.
    Stopped,
    /// 0x80..=0xFF: manufacturer-specific (no NMT change here).
    Manufacturer(u8),
}

impl ErrorBehaviour {
    /// The values of CiA 301 (§7.5.2.32): 0 Pre-operational (from Operational), 1 no change,
    /// 2 Stopped; the default of [`crate::Config::error_behaviour_values`].
    pub const CIA_301: [(u8, ErrorBehaviour); 3] =
        [(0, ErrorBehaviour::PreOperational), (1, ErrorBehaviour::NoChange), (2, ErrorBehaviour::Stopped)];

    /// The reaction for a 1029h value under a device's own table of values (`table`, e.g.
    /// [`ErrorBehaviour::CIA_301`]); 80h..=FFh are manufacturer-specific in any table, the other
    /// values the table lacks are `None`.
    pub fn lookup(table: &[(u8, ErrorBehaviour)], value: u8) -> Option<Self> {
        match table.iter().find(|(v, _)| *v == value) {
            Some((_, behaviour)) => Some(*behaviour),
            None if value >= 0x80 => Some(ErrorBehaviour::Manufacturer(value)),
            None => None,
        }
    }

    /// The rule of 1029h: a value `table` (the device's values) has, or a manufacturer-specific
    /// one.
    pub fn check_write(table: &[(u8, ErrorBehaviour)], data: &[u8]) -> Result<(), AbortCode> {
        match ErrorBehaviour::lookup(table, le_u32(data) as u8) {
            Some(_) => Ok(()),
            None => Err(AbortCode::InvalidValue),
        }
    }

    /// The reaction 1029h configures for error class `class` (sub-index), under the device's
    /// table of values.
    pub fn of_class<const B: usize>(
        od: &Dictionary<B>,
        table: &[(u8, ErrorBehaviour)],
        class: u8,
    ) -> Option<Self> {
        ErrorBehaviour::lookup(table, od.get::<u8>(ERROR_BEHAVIOUR_OBJECT, class).ok()?)
    }

    /// The reaction for a 1029h value; reserved values (3..=0x7F) are `None`.
    pub const fn from_value(value: u8) -> Option<Self> {
        match value {
            0 => Some(ErrorBehaviour::PreOperational),
            1 => Some(ErrorBehaviour::NoChange),
            2 => Some(ErrorBehaviour::Stopped),
            0x80..=0xFF => Some(ErrorBehaviour::Manufacturer(value)),
            _ => None,
        }
    }

    /// The NMT state to enter from `current`, if any.
    pub fn next_state(self, current: NmtState) -> Option<NmtState> {
        match (self, current) {
            (ErrorBehaviour::PreOperational, NmtState::Operational) => Some(NmtState::PreOperational),
            (ErrorBehaviour::Stopped, NmtState::PreOperational | NmtState::Operational) => {
                Some(NmtState::Stopped)
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Instant {
        Instant::from_millis(v)
    }

    #[test]
    fn supervision_starts_with_the_first_heartbeat() {
        let mut c = HeartbeatConsumer::<2>::default();
        c.configure(1, 0x0003_0064); // node 3, 100 ms
        assert_eq!(c.state(1), Some(Supervision::Waiting));
        assert_eq!(c.poll(ms(10_000)), None, "never heard: not supervised");
        assert_eq!(c.on_heartbeat(3, 0x00, ms(10_000)), None, "boot-up does not start it");
        assert_eq!(c.on_heartbeat(3, 0x7F, ms(10_010)), None);
        assert_eq!(c.deadline(), Some(ms(10_110)));
        assert_eq!(c.poll(ms(10_109)), None);
        assert_eq!(c.poll(ms(10_110)), Some(ConsumerEvent::Timeout { node_id: 3 }));
        assert!(c.any_timed_out());
        assert_eq!(c.poll(ms(20_000)), None, "reported once");
        assert_eq!(c.on_heartbeat(3, 0x05, ms(20_000)), Some(ConsumerEvent::Recovered { node_id: 3 }));
        assert_eq!(c.on_heartbeat(3, 0x00, ms(20_050)), Some(ConsumerEvent::RemoteReset { node_id: 3 }));
        assert_eq!(c.state(1), Some(Supervision::Waiting));
    }

    #[test]
    fn guarding_toggles_and_life_time_expires() {
        let mut g = NodeGuarding::default();
        assert_eq!(g.on_request(NmtState::PreOperational, 300, ms(0)), (0x7F, None));
        assert_eq!(g.on_request(NmtState::PreOperational, 300, ms(100)), (0xFF, None));
        assert_eq!(g.on_request(NmtState::Operational, 300, ms(200)), (0x05, None));
        assert_eq!(g.poll(ms(499)), None);
        assert_eq!(g.poll(ms(500)), Some(GuardingEvent::LifeGuardingFailed));
        assert_eq!(g.on_request(NmtState::Operational, 300, ms(600)), (0x85, Some(GuardingEvent::Resumed)));
        g.reset();
        assert_eq!(g.on_request(NmtState::Stopped, 0, ms(700)), (0x04, None));
        assert_eq!(g.deadline(), None);
    }

    #[test]
    fn error_behaviour_values() {
        use NmtState::*;
        assert_eq!(ErrorBehaviour::from_value(0).unwrap().next_state(Operational), Some(PreOperational));
        assert_eq!(ErrorBehaviour::from_value(0).unwrap().next_state(PreOperational), None);
        assert_eq!(ErrorBehaviour::from_value(1).unwrap().next_state(Operational), None);
        assert_eq!(ErrorBehaviour::from_value(2).unwrap().next_state(PreOperational), Some(Stopped));
        assert_eq!(ErrorBehaviour::from_value(3), None);
        assert_eq!(ErrorBehaviour::from_value(0x7F), None);
        assert_eq!(ErrorBehaviour::from_value(0x80), Some(ErrorBehaviour::Manufacturer(0x80)));
    }

    #[test]
    fn a_device_may_give_1029h_values_other_meanings() {
        for value in 0..=255u8 {
            assert_eq!(
                ErrorBehaviour::lookup(&ErrorBehaviour::CIA_301, value),
                ErrorBehaviour::from_value(value),
                "the CiA table is the standard's"
            );
        }
        let own = [(0, ErrorBehaviour::Stopped), (1, ErrorBehaviour::NoChange)];
        assert_eq!(ErrorBehaviour::lookup(&own, 0), Some(ErrorBehaviour::Stopped));
        assert_eq!(ErrorBehaviour::lookup(&own, 1), Some(ErrorBehaviour::NoChange));
        assert_eq!(ErrorBehaviour::lookup(&own, 2), None);
        assert_eq!(ErrorBehaviour::lookup(&own, 0x81), Some(ErrorBehaviour::Manufacturer(0x81)));
    }
}

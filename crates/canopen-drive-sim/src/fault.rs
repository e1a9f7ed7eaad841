//! Fault injection: rules that drop, delay or duplicate frames on the [`VirtualBus`].
//!
//! A [`FaultRule`] is an [`FaultAction`] plus a selection of the frames it hits:
//!
//! - filters on the frame and its sender ([`FaultRule::when`], [`FaultRule::from_port`],
//!   [`FaultRule::with_id`]); every filter must match;
//! - [`FaultRule::skip`]: let the first `n` matching frames pass;
//! - [`FaultRule::times`]: hit at most `n` frames;
//! - [`FaultRule::rate`]: hit a matching frame with a given probability, drawn from a seeded
//!   xorshift generator, so a run is repeatable.
//!
//! The bus applies the rules when it puts a transmitted frame on the wire, once per frame (a
//! dropped frame is lost for every receiver, as when a gateway or a driver queue loses it). Rules
//! are tried in the order they were added; the first that hits decides the frame's fate. Frames
//! that a rule delays or duplicates are not offered to the rules a second time.
//!
//! ```
//! use canopen_drive_sim::{FaultRule, Port};
//!
//! // Lose the first block segment (seq 1) the node answering on 0x585 sends, once.
//! let rule = FaultRule::drop()
//!     .with_id(0x585)
//!     .when(|frame, _from| embedded_can::Frame::data(frame).first() == Some(&0x01))
//!     .times(1);
//! # let _ = rule;
//! // Delay 10 % of the master's frames by 3 ms, repeatably.
//! let rule = FaultRule::delay(canopen_drive::Duration::from_millis(3))
//!     .from_port(Port::Master)
//!     .rate(0.1, 42);
//! # let _ = rule;
//! ```
//!
//! [`VirtualBus`]: crate::VirtualBus

use std::fmt;

use canopen_drive::{CanFrame, Duration};

use crate::bus::Port;

/// What a rule does to a frame it hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultAction {
    /// The frame never reaches any receiver.
    Drop,
    /// The frame reaches the receivers this much later than it would have (later frames may
    /// overtake it).
    Delay(Duration),
    /// The frame reaches the receivers twice, one copy right after the other.
    Duplicate,
}

/// A filter on a frame and its sender.
type Filter = Box<dyn Fn(&CanFrame, Port) -> bool>;

/// One fault-injection rule: an action and the frames it hits (see the [module docs](self)).
pub struct FaultRule {
    action: FaultAction,
    filters: Vec<Filter>,
    rate: Option<(f64, XorShift64)>,
    skip: usize,
    times: Option<usize>,
    matched: usize,
    applied: usize,
}

impl fmt::Debug for FaultRule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("FaultRule")
            .field("action", &self.action)
            .field("filters", &self.filters.len())
            .field("rate", &self.rate.as_ref().map(|(p, _)| *p))
            .field("skip", &self.skip)
            .field("times", &self.times)
            .field("matched", &self.matched)
            .field("applied", &self.applied)
            .finish()
    }
}

impl FaultRule {
    /// A rule that applies `action` to every frame (narrow it down with the builder methods).
    pub fn new(action: FaultAction) -> Self {
        FaultRule { action, filters: Vec::new(), rate: None, skip: 0, times: None, matched: 0, applied: 0 }
    }

    /// A rule that drops frames.
    pub fn drop() -> Self {
        FaultRule::new(FaultAction::Drop)
    }

    /// A rule that delays frames by `by`.
    pub fn delay(by: Duration) -> Self {
        FaultRule::new(FaultAction::Delay(by))
    }

    /// A rule that duplicates frames.
    pub fn duplicate() -> Self {
        FaultRule::new(FaultAction::Duplicate)
    }

    /// Only frames for which `filter(frame, sender)` is true.
    pub fn when(mut self, filter: impl Fn(&CanFrame, Port) -> bool + 'static) -> Self {
        self.filters.push(Box::new(filter));
        self
    }

    /// Only frames sent from `port`.
    pub fn from_port(self, port: Port) -> Self {
        self.when(move |_, from| from == port)
    }

    /// Only frames with the 11-bit identifier `id`.
    pub fn with_id(self, id: u16) -> Self {
        self.when(move |frame, _| frame.standard_id() == Some(id))
    }

    /// Hits each matching frame with `probability` (0.0..=1.0), drawn from a xorshift
    /// generator seeded with `seed`: the same seed hits the same frames on every run.
    pub fn rate(mut self, probability: f64, seed: u64) -> Self {
        self.rate = Some((probability, XorShift64::new(seed)));
        self
    }

    /// Lets the first `n` matching frames pass.
    pub fn skip(mut self, n: usize) -> Self {
        self.skip = n;
        self
    }

    /// Hits at most `n` frames.
    pub fn times(mut self, n: usize) -> Self {
        self.times = Some(n);
        self
    }

    /// The rule's action.
    pub fn action(&self) -> FaultAction {
        self.action
    }

    /// Frames that passed the filters so far.
    pub fn matched(&self) -> usize {
        self.matched
    }

    /// Frames the rule hit so far.
    pub fn applied(&self) -> usize {
        self.applied
    }

    /// Decides whether the rule hits `frame` sent from `from`, and counts it.
    pub(crate) fn hits(&mut self, frame: &CanFrame, from: Port) -> bool {
        if !self.filters.iter().all(|filter| filter(frame, from)) {
            return false;
        }
        self.matched = self.matched.saturating_add(1);
        if self.matched <= self.skip || self.times.is_some_and(|n| self.applied >= n) {
            return false;
        }
        if let Some((probability, rng)) = self.rate.as_mut() {
            if !rng.chance(*probability) {
                return false;
            }
        }
        self.applied = self.applied.saturating_add(1);
        true
    }
}

/// The xorshift64 pseudo-random generator (Marsaglia 2003, shifts 13/7/17): tiny, fast and
/// fully determined by its seed. Not for cryptography.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct XorShift64 {
    state: u64,
}

impl XorShift64 {
    /// A generator seeded with `seed` (0, which would stay 0 forever, is replaced by a fixed
    /// non-zero constant).
    pub fn new(seed: u64) -> Self {
        XorShift64 { state: if seed == 0 { 0x9E37_79B9_7F4A_7C15 } else { seed } }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.state;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.state = x;
        x
    }

    /// A number uniformly distributed in `0.0..1.0` (53 random bits).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// True with `probability` (values outside 0..=1 act as 0 or 1).
    pub fn chance(&mut self, probability: f64) -> bool {
        self.next_f64() < probability
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::NodeHandle;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new_standard(id, data).unwrap()
    }

    #[test]
    fn xorshift_is_repeatable_and_never_stuck() {
        let mut a = XorShift64::new(7);
        let mut b = XorShift64::new(7);
        let xs: Vec<u64> = (0..5).map(|_| a.next_u64()).collect();
        let ys: Vec<u64> = (0..5).map(|_| b.next_u64()).collect();
        assert_eq!(xs, ys);
        assert!(xs.iter().all(|&x| x != 0));
        let mut zero = XorShift64::new(0);
        assert_ne!(zero.next_u64(), 0);
        // First value of the reference generator for seed 1.
        assert_eq!(XorShift64::new(1).next_u64(), 0x4082_2041);
    }

    #[test]
    fn rate_hits_about_the_requested_share() {
        let mut rng = XorShift64::new(12345);
        let hits = (0..10_000).filter(|_| rng.chance(0.25)).count();
        assert!((2300..2700).contains(&hits), "{hits}");
        let mut rng = XorShift64::new(1);
        assert!((0..100).all(|_| !rng.chance(0.0)));
        assert!((0..100).all(|_| rng.chance(1.0)));
    }

    #[test]
    fn filters_must_all_match() {
        let node = Port::Node(NodeHandle::from_index(0));
        let mut rule = FaultRule::drop().with_id(0x585).from_port(node);
        assert!(!rule.hits(&frame(0x585, &[1]), Port::Master));
        assert!(!rule.hits(&frame(0x586, &[1]), node));
        assert!(rule.hits(&frame(0x585, &[1]), node));
        assert_eq!((rule.matched(), rule.applied()), (1, 1));
        let mut rule = FaultRule::duplicate().when(|f, _| f.standard_id().is_some_and(|id| id >= 0x700));
        assert!(rule.hits(&frame(0x705, &[0]), node));
        assert!(!rule.hits(&frame(0x605, &[0]), node));
        assert_eq!(rule.action(), FaultAction::Duplicate);
    }

    #[test]
    fn skip_and_times_pick_exact_frames() {
        let mut rule = FaultRule::delay(Duration::from_millis(1)).skip(2).times(2);
        let f = frame(0x100, &[]);
        let hits: Vec<bool> = (0..6).map(|_| rule.hits(&f, Port::Master)).collect();
        assert_eq!(hits, [false, false, true, true, false, false]);
        assert_eq!((rule.matched(), rule.applied()), (6, 2));
    }

    #[test]
    fn rate_rule_is_repeatable() {
        let f = frame(0x100, &[]);
        let run = |seed| {
            let mut rule = FaultRule::drop().rate(0.5, seed);
            (0..64).map(|_| rule.hits(&f, Port::Master)).collect::<Vec<bool>>()
        };
        assert_eq!(run(99), run(99));
        assert_ne!(run(99), run(100));
        let hits = run(99).iter().filter(|&&h| h).count();
        assert!((16..48).contains(&hits), "{hits}");
    }
}

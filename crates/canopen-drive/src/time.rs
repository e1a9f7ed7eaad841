//! Time as the core sees it: plain microsecond counts handed in by the caller.
//!
//! The core never reads a clock. Every entry point takes `now: Instant`; the board derives it
//! from whatever timer it has. The counter is 64 bits wide, so it does not wrap in the life of a
//! machine (≈ 584 000 years), and all arithmetic on it saturates.

use core::fmt;
use core::num::NonZeroU64;
use core::ops::{Add, Sub};

/// A point in time, in microseconds since an arbitrary epoch chosen by the board (at most
/// 2⁶³ − 1, ≈ 292 000 years: later instants saturate there).
///
/// Stored with the top bit set, so never zero: `Option<Instant>` is then as small as `Instant`
/// (8 bytes, not 16), and every timer of the node is one.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Instant(NonZeroU64);

/// The top bit that marks a stored instant.
const MARK: u64 = 1 << 63;

/// The stored form of `micros`, saturated at `MARK − 1`.
const fn marked(micros: u64) -> NonZeroU64 {
    let micros = if micros >= MARK { MARK - 1 } else { micros };
    match NonZeroU64::new(micros | MARK) {
        Some(stored) => stored,
        None => NonZeroU64::MAX,
    }
}

/// A span of time, in microseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Duration(u64);

impl Instant {
    /// The epoch.
    pub const ZERO: Instant = Instant(marked(0));

    /// The latest instant (where every later one saturates).
    pub const MAX: Instant = Instant(marked(u64::MAX));

    /// An instant `micros` µs after the epoch.
    pub const fn from_micros(micros: u64) -> Self {
        Instant(marked(micros))
    }

    /// An instant `millis` ms after the epoch (saturating).
    pub const fn from_millis(millis: u64) -> Self {
        Instant::from_micros(millis.saturating_mul(1000))
    }

    /// Microseconds since the epoch.
    pub const fn as_micros(self) -> u64 {
        self.0.get() & !MARK
    }

    /// Time elapsed from `earlier` to `self`, zero if `earlier` is later.
    pub const fn saturating_since(self, earlier: Instant) -> Duration {
        // The marks cancel out.
        Duration(self.0.get().saturating_sub(earlier.0.get()))
    }
}

impl Duration {
    /// No time at all.
    pub const ZERO: Duration = Duration(0);

    /// A span of `micros` µs.
    pub const fn from_micros(micros: u64) -> Self {
        Duration(micros)
    }

    /// A span of `millis` ms (saturating).
    pub const fn from_millis(millis: u64) -> Self {
        Duration(millis.saturating_mul(1000))
    }

    /// The span in microseconds.
    pub const fn as_micros(self) -> u64 {
        self.0
    }
}

impl Default for Instant {
    fn default() -> Self {
        Instant::ZERO
    }
}

impl fmt::Debug for Instant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_tuple("Instant").field(&self.as_micros()).finish()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Instant {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "Instant({=u64})", self.as_micros());
    }
}

impl Add<Duration> for Instant {
    type Output = Instant;
    fn add(self, rhs: Duration) -> Instant {
        // Added to the stored form: the mark stays, and the sum saturates at the stored form of
        // the latest instant (u64::MAX), as the count would at 2⁶³ − 1.
        Instant(self.0.saturating_add(rhs.0))
    }
}

impl Sub<Instant> for Instant {
    type Output = Duration;
    fn sub(self, rhs: Instant) -> Duration {
        self.saturating_since(rhs)
    }
}

impl Add<Duration> for Duration {
    type Output = Duration;
    fn add(self, rhs: Duration) -> Duration {
        Duration(self.0.saturating_add(rhs.0))
    }
}

/// The earlier of two optional deadlines (`None` = no deadline).
/// A span of at most `u32::MAX` µs (≈ 71 minutes) in four bytes, for the timers a node keeps
/// one per PDO (event timers, inhibit times: at most 65 535 ms in CiA 301) and the SDO timeout.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct ShortDuration(u32);

impl ShortDuration {
    pub(crate) const ZERO: ShortDuration = ShortDuration(0);

    /// `span`, saturated at `u32::MAX` µs.
    pub(crate) const fn saturating(span: Duration) -> Self {
        ShortDuration(if span.0 > u32::MAX as u64 { u32::MAX } else { span.0 as u32 })
    }
}

impl Add<ShortDuration> for Instant {
    type Output = Instant;
    fn add(self, rhs: ShortDuration) -> Instant {
        self + Duration(u64::from(rhs.0))
    }
}

pub(crate) fn earliest(a: Option<Instant>, b: Option<Instant>) -> Option<Instant> {
    match (a, b) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, None) => x,
        (None, y) => y,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_saturates() {
        let end = Instant::from_micros(u64::MAX);
        assert_eq!(end + Duration::from_millis(5), end);
        assert_eq!(Instant::ZERO - end, Duration::ZERO);
        assert_eq!(Instant::from_millis(3) - Instant::from_millis(1), Duration::from_micros(2000));
    }

    #[test]
    fn earliest_ignores_missing() {
        let a = Some(Instant::from_micros(5));
        assert_eq!(earliest(a, None), a);
        assert_eq!(earliest(None, a), a);
        assert_eq!(earliest(a, Some(Instant::from_micros(3))), Some(Instant::from_micros(3)));
        assert_eq!(earliest(None, None), None);
    }

    #[test]
    fn an_optional_instant_takes_no_more_room() {
        assert_eq!(core::mem::size_of::<Option<Instant>>(), core::mem::size_of::<Instant>());
        assert!(Instant::from_micros(7) < Instant::from_micros(9));
        assert_eq!(Instant::from_micros(u64::MAX).as_micros(), (1 << 63) - 1);
        assert_eq!(Instant::default(), Instant::ZERO);
        let mut text = heapless::String::<32>::new();
        core::fmt::Write::write_fmt(&mut text, format_args!("{:?}", Instant::from_millis(2))).unwrap();
        assert_eq!(text.as_str(), "Instant(2000)");
    }
}

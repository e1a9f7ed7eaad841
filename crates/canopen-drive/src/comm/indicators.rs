//! The CiA 303-3 indicators: a green RUN LED for the node's NMT and LSS state and a red ERR LED
//! for its communication errors, each showing one of eight patterns.
//!
//! | pattern | on, off (ms) | period (ms) |
//! |---|---|---:|
//! | flickering | 50, 50 | 100 |
//! | blinking | 200, 200 | 400 |
//! | single flash | 200, 1 000 | 1 200 |
//! | double flash | 200, 200, 200, 1 000 | 1 600 |
//! | triple flash | (200, 200) × 2, 200, 1 000 | 2 000 |
//! | quadruple flash | (200, 200) × 3, 200, 1 000 | 2 400 |
//!
//! The patterns are a pure function of the node's state ([`NodeStatus`]) and of a clock both
//! LEDs share, so they start together and a board only samples [`NodeStatus::leds`] at any
//! rate (every 50 ms or faster shows every on and off; 10 ms keeps each within 20 % of its
//! length). When both LEDs flicker, they do so in antiphase.
//!
//! The RUN LED, by priority: flickering while LSS configures the node, triple flash while a
//! program is downloaded, then the NMT state: on in Operational, blinking in Pre-operational,
//! single flash in Stopped, off while initialising. The ERR LED shows the condition of highest
//! priority: on at bus-off, quadruple flash after an RPDO timed out, triple flash while the
//! SYNC is lost, double flash after an error control event (a consumed heartbeat or life
//! guarding lost), single flash when a CAN error counter reached its warning limit, blinking
//! for an invalid configuration, flickering while the node has no node-ID (LSS needed), else
//! off.

use crate::time::Instant;
use crate::wire::nmt::NmtState;

/// What an indicator shows (CiA 303-3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Pattern {
    /// Constantly off.
    Off,
    /// On and off for 50 ms each (10 Hz).
    Flickering,
    /// On and off for 200 ms each (2.5 Hz).
    Blinking,
    /// One 200 ms flash, then 1 000 ms off.
    SingleFlash,
    /// Two 200 ms flashes 200 ms apart, then 1 000 ms off.
    DoubleFlash,
    /// Three 200 ms flashes 200 ms apart, then 1 000 ms off.
    TripleFlash,
    /// Four 200 ms flashes 200 ms apart, then 1 000 ms off.
    QuadrupleFlash,
    /// Constantly on.
    On,
}

impl Pattern {
    /// Whether the indicator is lit `ms` milliseconds into the clock the two indicators share.
    pub const fn lit(self, ms: u64) -> bool {
        match self {
            Pattern::Off => false,
            Pattern::On => true,
            Pattern::Flickering => ms % 100 < 50,
            Pattern::Blinking => ms % 400 < 200,
            Pattern::SingleFlash => flash(ms, 1),
            Pattern::DoubleFlash => flash(ms, 2),
            Pattern::TripleFlash => flash(ms, 3),
            Pattern::QuadrupleFlash => flash(ms, 4),
        }
    }
}

/// `flashes` flashes of 200 ms, 200 ms apart, then 1 000 ms off: lit at `ms`?
const fn flash(ms: u64, flashes: u64) -> bool {
    let t = ms % (400 * flashes + 800);
    t < 400 * flashes - 200 && t % 400 < 200
}

/// The two indicators at one moment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Leds {
    /// The green RUN LED is lit.
    pub run: bool,
    /// The red ERR LED is lit.
    pub err: bool,
}

/// What the indicators show: the node's state as CiA 303-3 reads it. A drive fills it from its
/// own state (`Drive::node_status`); a board may add what only it knows (e.g. an invalid
/// configuration, or a program download its bootloader runs) before [`Self::leds`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NodeStatus {
    /// The NMT state.
    pub nmt: NmtState,
    /// LSS configuration state: an LSS master configures the node.
    pub lss_configuration: bool,
    /// The node has no node-ID (255: waiting for an LSS master to assign one).
    pub node_id_unconfigured: bool,
    /// A program download is running.
    pub program_download: bool,
    /// The configuration is invalid (e.g. parameters that could not be restored).
    pub invalid_configuration: bool,
    /// A CAN error counter reached the warning limit (or error passive).
    pub warning_limit: bool,
    /// A consumed heartbeat or life guarding was lost and has not come back.
    pub error_control_event: bool,
    /// The SYNC is lost (not received within its window) and has not come back.
    pub sync_lost: bool,
    /// An RPDO was not received within its event time (an active RPDO timeout error).
    pub rpdo_timeout: bool,
    /// The CAN controller is bus-off.
    pub bus_off: bool,
}

impl NodeStatus {
    /// A node in `nmt` without any condition to show.
    pub const fn new(nmt: NmtState) -> Self {
        NodeStatus {
            nmt,
            lss_configuration: false,
            node_id_unconfigured: false,
            program_download: false,
            invalid_configuration: false,
            warning_limit: false,
            error_control_event: false,
            sync_lost: false,
            rpdo_timeout: false,
            bus_off: false,
        }
    }

    /// The RUN LED's pattern.
    pub const fn run(&self) -> Pattern {
        if self.lss_configuration {
            return Pattern::Flickering;
        }
        if self.program_download {
            return Pattern::TripleFlash;
        }
        match self.nmt {
            NmtState::Initialising => Pattern::Off,
            NmtState::PreOperational => Pattern::Blinking,
            NmtState::Operational => Pattern::On,
            NmtState::Stopped => Pattern::SingleFlash,
        }
    }

    /// The ERR LED's pattern: the condition of highest priority.
    pub fn err(&self) -> Pattern {
        // From the highest priority down.
        let conditions = [
            (self.bus_off, Pattern::On),
            (self.rpdo_timeout, Pattern::QuadrupleFlash),
            (self.sync_lost, Pattern::TripleFlash),
            (self.error_control_event, Pattern::DoubleFlash),
            (self.warning_limit, Pattern::SingleFlash),
            (self.invalid_configuration, Pattern::Blinking),
            (self.node_id_unconfigured, Pattern::Flickering),
        ];
        conditions.into_iter().find(|(holds, _)| *holds).map_or(Pattern::Off, |(_, pattern)| pattern)
    }

    /// The two LEDs at `now` (the same clock as the drive's, whatever its origin).
    pub fn leds(&self, now: Instant) -> Leds {
        let ms = now.as_micros() / 1000;
        let (run, err) = (self.run(), self.err());
        let run_lit = run.lit(ms);
        // Both flickering: in antiphase.
        let err_lit = if matches!((run, err), (Pattern::Flickering, Pattern::Flickering)) {
            !run_lit
        } else {
            err.lit(ms)
        };
        Leds { run: run_lit, err: err_lit }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    /// The lit and unlit stretches of `pattern` over its first `ms` milliseconds, as
    /// `(lit, length)` runs.
    fn runs(pattern: Pattern, ms: u64) -> std::vec::Vec<(bool, u64)> {
        let mut out = std::vec::Vec::<(bool, u64)>::new();
        for t in 0..ms {
            let lit = pattern.lit(t);
            match out.last_mut() {
                Some((last, length)) if *last == lit => *length += 1,
                _ => out.push((lit, 1)),
            }
        }
        out
    }

    #[test]
    fn every_pattern_has_its_timing() {
        assert_eq!(runs(Pattern::Off, 5000), [(false, 5000)]);
        assert_eq!(runs(Pattern::On, 5000), [(true, 5000)]);
        assert_eq!(runs(Pattern::Flickering, 300), [(true, 50), (false, 50)].repeat(3));
        assert_eq!(runs(Pattern::Blinking, 1200), [(true, 200), (false, 200)].repeat(3));
        assert_eq!(runs(Pattern::SingleFlash, 2400), [(true, 200), (false, 1000)].repeat(2));
        let double = [(true, 200), (false, 200), (true, 200), (false, 1000)];
        assert_eq!(runs(Pattern::DoubleFlash, 3200), double.repeat(2));
        let triple = [(true, 200), (false, 200), (true, 200), (false, 200), (true, 200), (false, 1000)];
        assert_eq!(runs(Pattern::TripleFlash, 4000), triple.repeat(2));
        let quadruple = [
            (true, 200),
            (false, 200),
            (true, 200),
            (false, 200),
            (true, 200),
            (false, 200),
            (true, 200),
            (false, 1000),
        ];
        assert_eq!(runs(Pattern::QuadrupleFlash, 4800), quadruple.repeat(2));
    }

    #[test]
    fn run_led_shows_lss_download_and_every_nmt_state() {
        let cases = [
            (NmtState::Initialising, Pattern::Off),
            (NmtState::PreOperational, Pattern::Blinking),
            (NmtState::Operational, Pattern::On),
            (NmtState::Stopped, Pattern::SingleFlash),
        ];
        for (nmt, pattern) in cases {
            assert_eq!(NodeStatus::new(nmt).run(), pattern, "{nmt:?}");
            let downloading = NodeStatus { program_download: true, ..NodeStatus::new(nmt) };
            assert_eq!(downloading.run(), Pattern::TripleFlash, "{nmt:?}");
            let lss = NodeStatus { lss_configuration: true, ..downloading };
            assert_eq!(lss.run(), Pattern::Flickering, "{nmt:?}");
        }
    }

    #[test]
    fn err_led_shows_the_condition_of_highest_priority() {
        let none = NodeStatus::new(NmtState::Operational);
        assert_eq!(none.err(), Pattern::Off);
        // From the lowest priority to the highest: each one added wins over those before.
        type Step = (fn(&mut NodeStatus), Pattern);
        let steps: [Step; 7] = [
            (|s| s.node_id_unconfigured = true, Pattern::Flickering),
            (|s| s.invalid_configuration = true, Pattern::Blinking),
            (|s| s.warning_limit = true, Pattern::SingleFlash),
            (|s| s.error_control_event = true, Pattern::DoubleFlash),
            (|s| s.sync_lost = true, Pattern::TripleFlash),
            (|s| s.rpdo_timeout = true, Pattern::QuadrupleFlash),
            (|s| s.bus_off = true, Pattern::On),
        ];
        let mut status = none;
        for (set, pattern) in steps {
            set(&mut status);
            assert_eq!(status.err(), pattern);
            // Alone, too.
            let mut alone = none;
            set(&mut alone);
            assert_eq!(alone.err(), pattern);
        }
        // The ERR LED does not depend on the NMT state.
        for nmt in [NmtState::Initialising, NmtState::PreOperational, NmtState::Stopped] {
            assert_eq!(NodeStatus { nmt, ..status }.err(), Pattern::On);
        }
    }

    #[test]
    fn leds_are_sampled_from_a_shared_clock() {
        let at = |ms: u64| Instant::from_millis(ms);
        // Pre-operational with an error control event: both LEDs start their pattern together.
        let status = NodeStatus { error_control_event: true, ..NodeStatus::new(NmtState::PreOperational) };
        assert_eq!(status.leds(at(0)), Leds { run: true, err: true });
        assert_eq!(status.leds(at(200)), Leds { run: false, err: false });
        assert_eq!(status.leds(at(400)), Leds { run: true, err: true });
        assert_eq!(status.leds(at(800)), Leds { run: true, err: false });
        assert_eq!(status.leds(at(1600)), Leds { run: true, err: true });
        // LSS configuration of a node without a node-ID: both flicker, in antiphase.
        let lss = NodeStatus {
            lss_configuration: true,
            node_id_unconfigured: true,
            ..NodeStatus::new(NmtState::PreOperational)
        };
        for ms in (0..1000).step_by(10) {
            let leds = lss.leds(at(ms));
            assert_ne!(leds.run, leds.err, "at {ms} ms");
            assert_eq!(leds.run, ms % 100 < 50, "at {ms} ms");
        }
        // Sub-millisecond times belong to their millisecond.
        assert!(NodeStatus::new(NmtState::Stopped).leds(Instant::from_micros(199_999)).run);
        assert!(!NodeStatus::new(NmtState::Stopped).leds(Instant::from_micros(200_000)).run);
    }
}

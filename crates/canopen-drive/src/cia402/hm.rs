//! Homing mode (hm, 6060h = 6; CiA 402-2 §11).
//!
//! A homing run is a short program of *searches*: move in a direction at the switch-search
//! speed (6099h sub 1) or the zero-search speed (6099h sub 2), with the homing acceleration
//! 609Ah, until an event — a switch turns on or off, an index pulse, the torque of a hard stop —
//! then the next search. The event of the last search is the home position. The axis then stops
//! and moves back onto the home position (statusword "homing attained", bits 13/12/10 = 0/1/0);
//! at rest there the run is complete (0/1/1).
//!
//! # The home position and 607Ch
//!
//! The drive keeps the encoder count it is given (6063h) and moves its user zero instead:
//! after homing, 6064h at the home position reads **−607Ch** (CiA 402-2 §11.5.1: zero position = home
//! position + home offset), so a pp move to 0 then goes +607Ch from home, and the software
//! limits 607Dh corrected by 607Ch keep their meaning. The offset is applied when a run
//! completes. Polarity 607Eh plays no part in homing directions.
//!
//! # Methods (CiA 402-2 §11.3; the left/right assignment is this crate's reading of the method figures)
//!
//! - **1, 2, 17, 18** — limit switch: move towards it (switch speed), then away at zero speed
//!   until it releases; 17/18 home there, 1/2 at the next index pulse.
//! - **3–6, 19–22** — one-sided home switch: 3, 4, 19, 20 a *positive* home switch (active on the
//!   positive side of its edge), 5, 6, 21, 22 a *negative* one. The edge is crossed slowly in the
//!   final direction of the table (index left of the edge → crossing moving negative, right →
//!   moving positive); the start direction follows from the switch state. 19–22 home on the
//!   edge, 3–6 at the next index pulse after it.
//! - **7–14, 23–30** — home switch active over a zone: search in the method's direction (7–10,
//!   23–26 positive; 11–14, 27–30 negative) for the zone, reversing once on the limit switch in
//!   that direction; then cross the sought edge slowly in the final direction, and for 7–14
//!   continue to the index pulse.
//! - **33, 34** — the first index pulse moving negative / positive.
//! - **35** — the current position is home; no motion, and it also works outside Operation
//!   enabled (on the bit 4 edge in Switched on, say). **37** is the later editions' number for
//!   the same thing, accepted when [`HomingConfig::method_37`] is set.
//! - **36** — touch probe: moves positive at the zero-search speed until touch probe 1
//!   (60B8h, enabled and configured by the master: input or index pulse, edge) latches; home is
//!   the latched position (the probe's own capture, so as exact as the board's capture).
//! - **Negative numbers** — the vendor's, from [`HomingConfig::vendor_methods`]: drive into a
//!   mechanical stop until |torque| ≥ the threshold for the set time while the shaft moves at
//!   less than half the search speed, back off, optionally search
//!   the index pulse; or home midway between the two stops, or between the two limit switches.
//!   Thresholds, time and back-off are the RECORD at [`HomingConfig::hard_stop_object`]
//!   ([`hard_stop_object`]).
//!
//! # Errors (status 1/0/0 while stopping, 1/0/1 at rest; EMCY 8613h)
//!
//! A limit switch in the direction of travel that the search does not expect (a switch that
//! never came), both limit switches active, a search that ends without its event (it runs for at
//! most ten minutes at its speed), the time limit [`HomingConfig::timeout`], and a following
//! error (6065h/6066h). A halt (bit 8) or bit 4 going back to 0 stops the run: 0/0/0 while
//! stopping, then 0/0/1 (interrupted). A quick stop or a fault ends the run the same way.
//!
//! An event is taken at the position of the tick that saw it (the switch state or the index
//! flag of [`crate::hal::Sample::inputs`]), so the home position is exact to the distance moved
//! in one tick at the zero-search speed.

use super::objects::Rule;
use super::objects::HOMING_METHOD;
use super::objects::{highest_sub, setting, HOMING_ACCELERATION, HOMING_SPEEDS, SUPPORTED_HOMING_METHODS};
use super::words::{Controlword, Statusword};
use crate::hal::DigitalInputs;
use crate::motion::{Limits, PositionPlanner};
use crate::od::{Access, DataType, DefaultValue, Dictionary, Object, Var};
use crate::od::{DeviceField, PdoMapping};
use crate::time::{Duration, Instant};

/// EMCY code of a homing error (CiA 402-2 §11.4).
pub const HOMING_ERROR: u16 = 0x8613;

/// A homing method a vendor adds under a negative number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum VendorMethod {
    /// Into the mechanical stop in `positive` (or negative) direction; home is the stop, the axis
    /// rests backed off; with `index`, home is the first index pulse after backing off.
    HardStop {
        /// Search direction.
        positive: bool,
        /// Then search the index pulse moving away from the stop.
        index: bool,
    },
    /// Both mechanical stops, negative first; home is midway.
    MidpointOfHardStops,
    /// Both limit switches' release points, negative first; home is midway.
    MidpointOfLimitSwitches,
    /// Both mechanical stops, positive first; home is midway.
    MidpointOfHardStopsPositiveFirst,
    /// Both limit switches' release points, positive first; home is midway.
    MidpointOfLimitSwitchesPositiveFirst,
    /// The middle of the home switch: searched moving `positive` (or negative) first, reversing
    /// once on a limit switch; both edges are then crossed slowly, home is midway.
    MidpointOfHomeSwitch {
        /// The first search direction.
        positive: bool,
    },
    /// As [`Self::MidpointOfHomeSwitch`], reversing once on a mechanical stop (detected as
    /// for [`Self::HardStop`]) instead of a limit switch.
    MidpointOfHomeSwitchHardStop {
        /// The first search direction.
        positive: bool,
    },
    /// Into the mechanical stop in `positive` (or negative) direction, then back off: home is
    /// the backed-off position (the axis rests there), and the software position limit on that
    /// side (607Dh sub 2 after a positive stop, sub 1 after a negative one) is set to it.
    HardStopLimit {
        /// Search direction.
        positive: bool,
    },
    /// Both mechanical stops, the positive one first when `positive_first`, each followed by a
    /// back-off: home is the position backed off from the second stop, and 607Dh is set to the
    /// two backed-off positions (the travel between the stops, less the back-offs).
    HardStopRange {
        /// The first search direction.
        positive_first: bool,
    },
}

/// Where a device keeps the hard-stop homing parameters in its own layout (instead of the
/// RECORD of [`hard_stop_object`]): each is an entry (index, sub-index) of the dictionary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HardStopEntries {
    /// Torque threshold, ‰ of rated torque (UNSIGNED16).
    pub threshold: (u16, u8),
    /// Time the torque must stay above the threshold, ms (UNSIGNED16); `None`: 50 ms.
    pub time: Option<(u16, u8)>,
    /// Back-off distance from a positive stop, increments (UNSIGNED32).
    pub back_off_positive: (u16, u8),
    /// Back-off distance from a negative stop, increments (UNSIGNED32).
    pub back_off_negative: (u16, u8),
}

/// Homing configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HomingConfig {
    /// Accept 6098h = 37 as "current position" (as 35).
    pub method_37: bool,
    /// The standard methods 6098h accepts: bit `n` set = method `n` (default: every bit set,
    /// so every method this crate runs: 1–14, 17–30, 33–36, and 37 with
    /// [`HomingConfig::method_37`]). A device that offers fewer clears the others.
    pub standard_methods: u64,
    /// Vendor methods by their (negative) 6098h numbers.
    pub vendor_methods: &'static [(i8, VendorMethod)],
    /// Index of the hard-stop parameter RECORD ([`hard_stop_object`]) in the manufacturer
    /// objects; needed by the hard-stop methods.
    pub hard_stop_object: Option<u16>,
    /// The hard-stop parameters in a device's own objects; when set, they are used instead of
    /// [`HomingConfig::hard_stop_object`].
    pub hard_stop_entries: Option<HardStopEntries>,
    /// A search for a hard stop passes the limit switch in its way (it drives on to the
    /// mechanical stop). Default false: the limit switch ends the run with a homing error.
    pub hard_stop_passes_limit_switches: bool,
    /// A run that takes longer fails (0 = no limit).
    pub timeout: Duration,
    /// What 607Ch means at home (default [`HomeOffset::ZeroBeforeHome`], CiA 402).
    pub home_offset: HomeOffset,
    /// Homing on the current position (method 35, or 37) also moves the zero of the internal
    /// position 6063h to the user zero: 6062h, 6063h and 6064h all read 0 there (with 607Ch
    /// = 0), and 6063h then reads what 6064h reads, in increments. Default false: 6063h keeps
    /// the encoder count (CiA 402 leaves the internal value unreferenced).
    pub rebase_internal_position: bool,
}

/// The meaning of the home offset 607Ch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HomeOffset {
    /// CiA 402: the zero position is the home position plus 607Ch, so 6064h reads −607Ch at
    /// home; the software position limits 607Dh count from home (607Dh − 607Ch in 6064h's
    /// terms).
    #[default]
    ZeroBeforeHome,
    /// 607Ch is the position value the home position gets: 6064h reads +607Ch at home; the
    /// software position limits 607Dh are position values as 6064h reads them.
    HomeValue,
}

impl HomingConfig {
    /// The standard methods only.
    pub const fn new() -> Self {
        HomingConfig {
            method_37: false,
            standard_methods: u64::MAX,
            vendor_methods: &[],
            hard_stop_object: None,
            hard_stop_entries: None,
            hard_stop_passes_limit_switches: false,
            timeout: Duration::ZERO,
            home_offset: HomeOffset::ZeroBeforeHome,
            rebase_internal_position: false,
        }
    }

    /// The hard-stop parameters now: (threshold ‰, time ms, back-off from a positive stop,
    /// back-off from a negative stop).
    fn hard_stop_parameters<const B: usize>(&self, od: &Dictionary<B>) -> (u16, u16, i64, i64) {
        if let Some(e) = self.hard_stop_entries {
            let threshold = od.get::<u16>(e.threshold.0, e.threshold.1).unwrap_or(500);
            let time = e.time.and_then(|(i, s)| od.get::<u16>(i, s).ok()).unwrap_or(50);
            let positive = od.get::<u32>(e.back_off_positive.0, e.back_off_positive.1).map_or(100, i64::from);
            let negative = od.get::<u32>(e.back_off_negative.0, e.back_off_negative.1).map_or(100, i64::from);
            return (threshold, time, positive, negative);
        }
        let index = self.hard_stop_object;
        let threshold = index.and_then(|i| od.get::<u16>(i, 1).ok()).unwrap_or(500);
        let time = index.and_then(|i| od.get::<u16>(i, 2).ok()).unwrap_or(50);
        let back_off = index.and_then(|i| od.get::<u32>(i, 3).ok()).map_or(100, i64::from);
        (threshold, time, back_off, back_off)
    }

    fn vendor(&self, method: i8) -> Option<VendorMethod> {
        self.vendor_methods.iter().find(|(number, _)| *number == method).map(|(_, m)| *m)
    }

    /// Whether 6098h may hold `method`.
    pub fn supports(&self, method: i8) -> bool {
        let offered = (1..=63).contains(&method) && self.standard_methods & (1u64 << method) != 0;
        method == 0
            || (matches!(method, 1..=14 | 17..=30 | 33..=35) && offered)
            || (method == 36 && super::PROBE && offered)
            || (method == 37 && self.method_37 && offered)
            || (method < 0 && self.vendor(method).is_some())
    }

    /// The methods 60E3h lists: every method 6098h accepts except 0, ascending (vendor methods
    /// first), at most [`MAX_LISTED_METHODS`].
    pub fn listed_methods(&self) -> impl Iterator<Item = i8> + '_ {
        (i8::MIN..=i8::MAX)
            .filter(move |m| *m != 0 && self.supports(*m))
            .take(usize::from(MAX_LISTED_METHODS))
    }

    /// The methods 60E3h lists ([`HomingConfig::listed_methods`]), as the dictionary keeps them.
    pub fn method_list(&self) -> crate::od::MethodList {
        self.listed_methods().fold(crate::od::MethodList::EMPTY, crate::od::MethodList::with)
    }
}

/// The most methods 60E3h (supported homing methods) lists: the 33 standard methods this crate
/// runs and up to 31 vendor methods.
pub const MAX_LISTED_METHODS: u8 = 64;

impl Default for HomingConfig {
    fn default() -> Self {
        HomingConfig::new()
    }
}

const fn stop_sub(name: &'static str, data_type: DataType, default: u64) -> Var {
    Var::new(name, data_type).access(Access::ReadWrite).default(DefaultValue::Unsigned(default))
}

static HARD_STOP_SUBS: [(u8, Var); 4] = [
    (
        0,
        Var::new("Highest sub-index supported", DataType::Unsigned8)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(3)),
    ),
    (1, stop_sub("Torque threshold", DataType::Unsigned16, 500)),
    (2, stop_sub("Detection time", DataType::Unsigned16, 50)),
    (3, stop_sub("Back-off distance", DataType::Unsigned32, 100)),
];

/// The hard-stop parameter RECORD at `index`: sub 1 torque threshold (‰ of rated torque,
/// default 500), sub 2 time the torque must stay above it (ms, default 50), sub 3 back-off
/// distance (increments, default 100).
pub const fn hard_stop_object(index: u16) -> Object {
    Object::record(index, "Hard stop homing", &HARD_STOP_SUBS)
}

/// What ends a search.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Until {
    On(Signal),
    Off(Signal),
    Index,
    HardStop,
    /// Touch probe 1 latched a position.
    Probe,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Signal {
    NegativeLimit,
    PositiveLimit,
    Home,
}

impl Signal {
    fn active(self, inputs: DigitalInputs) -> bool {
        inputs.contains(match self {
            Signal::NegativeLimit => DigitalInputs::NEGATIVE_LIMIT,
            Signal::PositiveLimit => DigitalInputs::POSITIVE_LIMIT,
            Signal::Home => DigitalInputs::HOME,
        })
    }
}

/// What to do with the position where a search ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mark {
    None,
    /// It is the home position.
    Home,
    /// First of two positions whose middle is home.
    First,
    /// Second of two: home is midway.
    Midpoint,
    /// A software position limit (607Dh sub 2 when `positive`, sub 1 otherwise).
    Limit {
        positive: bool,
    },
    /// The home position, and a software position limit.
    HomeAndLimit {
        positive: bool,
    },
}

/// What turns a search around once (instead of failing it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reverse {
    Never,
    /// A limit switch ahead.
    OnLimitSwitch,
    /// A mechanical stop (limit switches ahead are passed, as the stop lies beyond them).
    OnHardStop,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    /// Move at the switch speed (`fast`) or zero speed until the event.
    Search { positive: bool, fast: bool, until: Until, mark: Mark, reverse: Reverse },
    /// Move by a distance (increments) at the zero speed; the end is marked.
    BackOff { distance: i64, mark: Mark },
}

const MAX_STEPS: usize = 6;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Program {
    steps: [Option<Step>; MAX_STEPS],
    len: usize,
    /// Where the axis rests relative to home (hard stops: backed off).
    rest_offset: i64,
}

impl Program {
    fn push(&mut self, step: Step) {
        if let Some(slot) = self.steps.get_mut(self.len) {
            *slot = Some(step);
            self.len += 1;
        }
    }

    fn get(&self, n: usize) -> Option<Step> {
        self.steps.get(n).copied().flatten()
    }

    fn search(&mut self, positive: bool, fast: bool, until: Until, mark: Mark) {
        self.push(Step::Search { positive, fast, until, mark, reverse: Reverse::Never });
    }

    /// A switch with one edge, active on the `active_positive` side: cross the edge slowly
    /// moving `approach_positive`, then optionally on to the index pulse.
    fn edge(
        &mut self,
        signal: Signal,
        active: bool,
        active_positive: bool,
        approach_positive: bool,
        index: bool,
    ) {
        let mark = if index { Mark::None } else { Mark::Home };
        if approach_positive != active_positive {
            // Leaving the active side.
            if !active {
                self.search(active_positive, true, Until::On(signal), Mark::None);
            }
            self.search(approach_positive, false, Until::Off(signal), mark);
        } else {
            if active {
                self.search(!approach_positive, true, Until::Off(signal), Mark::None);
            }
            self.search(approach_positive, false, Until::On(signal), mark);
        }
        if index {
            self.search(approach_positive, false, Until::Index, Mark::Home);
        }
    }

    /// A home switch zone searched moving `positive` (reversing on the limit switch), whose
    /// `upper` (or lower) edge is crossed moving `approach_positive`.
    fn zone(&mut self, active: bool, positive: bool, upper: bool, approach_positive: bool, index: bool) {
        if !active {
            self.push(Step::Search {
                positive,
                fast: true,
                until: Until::On(Signal::Home),
                mark: Mark::None,
                reverse: Reverse::OnLimitSwitch,
            });
        }
        let mark = if index { Mark::None } else { Mark::Home };
        // Leaving the zone through the sought edge in the approach direction, or entering.
        if approach_positive == upper {
            self.search(approach_positive, false, Until::Off(Signal::Home), mark);
        } else {
            self.search(!approach_positive, true, Until::Off(Signal::Home), Mark::None);
            self.search(approach_positive, false, Until::On(Signal::Home), mark);
        }
        if index {
            self.search(approach_positive, false, Until::Index, Mark::Home);
        }
    }

    /// Makes this the program of `method`, from the switch states at the start; `None` for
    /// a method without motion (35, 37) or one this build does not run.
    /// `back_off`: the distances to back off from a positive and from a negative stop.
    fn fill(
        &mut self,
        method: i8,
        inputs: DigitalInputs,
        vendor: Option<VendorMethod>,
        back_off: (i64, i64),
    ) -> Option<()> {
        *self = Program::default();
        let away_from = |positive: bool| if positive { -back_off.0 } else { back_off.1 };
        let p = self;
        let home = Signal::Home.active(inputs);
        let negative_limit = Signal::NegativeLimit.active(inputs);
        let positive_limit = Signal::PositiveLimit.active(inputs);
        match method {
            1 | 17 => p.edge(Signal::NegativeLimit, negative_limit, false, true, method == 1),
            2 | 18 => p.edge(Signal::PositiveLimit, positive_limit, true, false, method == 2),
            3 | 19 => p.edge(Signal::Home, home, true, false, method == 3),
            4 | 20 => p.edge(Signal::Home, home, true, true, method == 4),
            5 | 21 => p.edge(Signal::Home, home, false, true, method == 5),
            6 | 22 => p.edge(Signal::Home, home, false, false, method == 6),
            7..=14 | 23..=30 => {
                let n = if method > 14 { method - 16 } else { method };
                let positive = n <= 10;
                // (upper edge, final approach positive) of 7..10 and 11..14.
                let (upper, approach) = match n {
                    7 => (false, false),
                    8 => (false, true),
                    9 => (true, false),
                    10 => (true, true),
                    11 => (true, true),
                    12 => (true, false),
                    13 => (false, true),
                    _ => (false, false),
                };
                p.zone(home, positive, upper, approach, method <= 14);
            }
            33 => p.search(false, false, Until::Index, Mark::Home),
            36 => p.search(true, false, Until::Probe, Mark::Home),
            34 => p.search(true, false, Until::Index, Mark::Home),
            _ => match vendor? {
                VendorMethod::HardStop { positive, index } => {
                    let away = away_from(positive);
                    p.search(positive, false, Until::HardStop, if index { Mark::None } else { Mark::Home });
                    p.push(Step::BackOff { distance: away, mark: Mark::None });
                    if index {
                        p.search(!positive, false, Until::Index, Mark::Home);
                    } else {
                        p.rest_offset = away;
                    }
                }
                VendorMethod::MidpointOfHardStops => {
                    p.search(false, false, Until::HardStop, Mark::First);
                    p.push(Step::BackOff { distance: away_from(false), mark: Mark::None });
                    p.search(true, false, Until::HardStop, Mark::Midpoint);
                }
                VendorMethod::MidpointOfHardStopsPositiveFirst => {
                    p.search(true, false, Until::HardStop, Mark::First);
                    p.push(Step::BackOff { distance: away_from(true), mark: Mark::None });
                    p.search(false, false, Until::HardStop, Mark::Midpoint);
                }
                VendorMethod::MidpointOfLimitSwitchesPositiveFirst => {
                    if !positive_limit {
                        p.search(true, true, Until::On(Signal::PositiveLimit), Mark::None);
                    }
                    p.search(false, false, Until::Off(Signal::PositiveLimit), Mark::First);
                    p.search(false, true, Until::On(Signal::NegativeLimit), Mark::None);
                    p.search(true, false, Until::Off(Signal::NegativeLimit), Mark::Midpoint);
                }
                VendorMethod::MidpointOfHomeSwitch { positive }
                | VendorMethod::MidpointOfHomeSwitchHardStop { positive } => {
                    let reverse = if matches!(vendor, Some(VendorMethod::MidpointOfHomeSwitch { .. })) {
                        Reverse::OnLimitSwitch
                    } else {
                        Reverse::OnHardStop
                    };
                    if !home {
                        p.push(Step::Search {
                            positive,
                            fast: true,
                            until: Until::On(Signal::Home),
                            mark: Mark::None,
                            reverse,
                        });
                    }
                    // Leaving the switch one way, then crossing it the other way: its two edges.
                    p.search(!positive, false, Until::Off(Signal::Home), Mark::First);
                    p.search(positive, false, Until::Off(Signal::Home), Mark::Midpoint);
                }
                VendorMethod::HardStopLimit { positive } => {
                    p.search(positive, false, Until::HardStop, Mark::None);
                    p.push(Step::BackOff {
                        distance: away_from(positive),
                        mark: Mark::HomeAndLimit { positive },
                    });
                }
                VendorMethod::HardStopRange { positive_first } => {
                    p.search(positive_first, false, Until::HardStop, Mark::None);
                    let first = Mark::Limit { positive: positive_first };
                    p.push(Step::BackOff { distance: away_from(positive_first), mark: first });
                    p.search(!positive_first, false, Until::HardStop, Mark::None);
                    let second = Mark::HomeAndLimit { positive: !positive_first };
                    p.push(Step::BackOff { distance: away_from(!positive_first), mark: second });
                }
                VendorMethod::MidpointOfLimitSwitches => {
                    if !negative_limit {
                        p.search(false, true, Until::On(Signal::NegativeLimit), Mark::None);
                    }
                    p.search(true, false, Until::Off(Signal::NegativeLimit), Mark::First);
                    p.search(true, true, Until::On(Signal::PositiveLimit), Mark::None);
                    p.search(false, false, Until::Off(Signal::PositiveLimit), Mark::Midpoint);
                }
            },
        }
        Some(())
    }
}

/// Homing status (statusword bits 13, 12, 10; CiA 402-2 §11.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Status {
    /// 0/0/0.
    InProgress,
    /// 0/0/1.
    Interrupted,
    /// 0/1/0: home found, still moving onto it.
    Attained,
    /// 0/1/1.
    Completed,
    /// 1/0/0.
    ErrorMoving,
    /// 1/0/1.
    ErrorAtRest,
}

impl Status {
    /// Bits 10, 12, 13 of the statusword.
    pub const fn statusword(self) -> Statusword {
        const REACHED: Statusword = Statusword::TARGET_REACHED;
        const ATTAINED: Statusword = Statusword::HOMING_ATTAINED;
        const ERROR: Statusword = Statusword::HOMING_ERROR;
        match self {
            Status::InProgress => Statusword::empty(),
            Status::Interrupted => REACHED,
            Status::Attained => ATTAINED,
            Status::Completed => ATTAINED.union(REACHED),
            Status::ErrorMoving => ERROR,
            Status::ErrorAtRest => ERROR.union(REACHED),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Idle,
    /// Running step `n` of the program.
    Running(usize),
    /// Home found: stopping, then moving onto the rest position.
    Finishing,
    /// Stopping because of a halt, bit 4 = 0, or an error.
    Stopping {
        error: bool,
    },
    Done,
    Failed,
}

/// What the profile hands homing each tick.
pub struct Inputs<'a, const B: usize> {
    /// The dictionary.
    pub od: &'a Dictionary<B>,
    /// Controlword.
    pub controlword: Controlword,
    /// Bit 4 rose (not with the enabling command).
    pub start: bool,
    /// 6098h, the homing method (read by the caller when a run starts, else 0).
    pub method: i8,
    /// Actual position (encoder count, increments).
    pub actual: i64,
    /// Torque actual (‰).
    pub torque: i16,
    /// Velocity actual (increments/s).
    pub velocity: i32,
    /// Switches and index pulse.
    pub inputs: DigitalInputs,
    /// The drive function is enabled (Operation enabled).
    pub enabled: bool,
    /// 6099h/609Ah converted to increments: (switch speed, zero speed, acceleration).
    pub speeds: (u32, u32, u32),
    /// The position touch probe 1 latched in this tick (method 36).
    pub probe: Option<i64>,
    /// The following error condition of the position control function.
    pub following_error: bool,
    /// Now.
    pub now: Instant,
    /// The axis whose objects these are.
    pub axis: super::Axis,
}

/// What homing tells the profile after a tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Outcome {
    /// The home position was found: the encoder count at home.
    pub home: Option<i64>,
    /// A homing error to report (EMCY 8613h).
    pub error: bool,
    /// Software position limits the run found, encoder counts (607Dh sub 1, sub 2); given with
    /// the home position.
    pub limits: (Option<i64>, Option<i64>),
}

/// Homing run-time state.
#[derive(Clone, Debug)]
pub struct Homing {
    config: HomingConfig,
    phase: Phase,
    program: Program,
    /// The direction of the present search, after a reversal.
    positive: bool,
    reversed: bool,
    previous_inputs: DigitalInputs,
    first_mark: Option<i64>,
    home: Option<i64>,
    /// Software position limits marked so far (min, max).
    limits: (Option<i64>, Option<i64>),
    homed: bool,
    started_at: Option<Instant>,
    above_threshold_since: Option<Instant>,
    /// The run found home without motion (method 35/37).
    motionless: bool,
    /// The shaft came to rest on home after the run ([`Self::status`] said complete).
    rested: bool,
}

/// A search runs at most this long at its speed before it counts as "the switch never came".
const SEARCH_SECONDS: i64 = 600;

impl Homing {
    /// Idle at `position`.
    pub fn new(config: HomingConfig) -> Self {
        Homing {
            config,
            phase: Phase::Idle,
            program: Program::default(),
            positive: true,
            reversed: false,
            previous_inputs: DigitalInputs::empty(),
            first_mark: None,
            home: None,
            limits: (None, None),
            homed: false,
            started_at: None,
            above_threshold_since: None,
            motionless: false,
            rested: false,
        }
    }

    /// The demand holds `position`; a run in progress is interrupted (mode switch, the drive
    /// function disabled). Whether the axis is homed is kept.
    pub fn reset(&mut self, planner: &mut PositionPlanner, position: i64) {
        planner.reset(position);
        self.interrupt();
    }

    /// A run in progress is interrupted (mode switch, transition 4, a coasting stop); the
    /// result of the last run is kept.
    pub fn interrupt(&mut self) {
        if !matches!(self.phase, Phase::Done | Phase::Failed | Phase::Idle) {
            self.phase = Phase::Idle;
        }
    }

    /// The reference is lost (e.g. an encoder fault).
    pub fn forget(&mut self) {
        self.homed = false;
    }

    /// Whether a homing run has completed since the reference was last lost.
    pub fn is_homed(&self) -> bool {
        self.homed
    }

    /// Whether a run has ended and waits for the shaft to rest on home (the only phase whose
    /// status [`Self::status`] asks `on_home` for).
    pub fn run_ended(&self) -> bool {
        self.phase == Phase::Done && !self.rested
    }

    /// Whether the last run found home where the axis stood, without motion (method 35).
    pub fn was_motionless(&self) -> bool {
        self.motionless
    }

    /// The demand state (increments, encoder count).
    pub fn state(&self, planner: &PositionPlanner) -> crate::motion::MotionState {
        planner.state()
    }

    /// Stops with `deceleration` (quick stop, fault reaction): the run is interrupted.
    pub fn stop(&mut self, planner: &mut PositionPlanner, deceleration: u32, limits: &Limits) {
        let _ = planner.request_stop(deceleration.max(1), limits);
        if matches!(self.phase, Phase::Running(_) | Phase::Finishing) {
            self.phase = Phase::Stopping { error: false };
        }
    }

    /// The statusword bits 10/12/13 now; `moving`: the demand moves; `on_home`: the shaft
    /// rests on the position the run ended at (a run is complete only then, CiA 402-2 §11.4; once it was, it stays so).
    pub fn status(&mut self, moving: bool, on_home: bool) -> Status {
        if self.phase == Phase::Done && !moving && on_home {
            self.rested = true;
        }
        match self.phase {
            Phase::Running(_) => Status::InProgress,
            Phase::Finishing => Status::Attained,
            Phase::Stopping { error: true } => Status::ErrorMoving,
            Phase::Stopping { error: false } => Status::InProgress,
            Phase::Failed if moving => Status::ErrorMoving,
            Phase::Failed => Status::ErrorAtRest,
            Phase::Done if moving || !self.rested => Status::Attained,
            Phase::Done if self.homed => Status::Completed,
            Phase::Done | Phase::Idle if self.homed => Status::Completed,
            Phase::Done | Phase::Idle => Status::Interrupted,
        }
    }

    fn limits(&self, speed: u32, acceleration: u32) -> Limits {
        Limits::new(speed.max(1), acceleration.max(1), acceleration.max(1))
    }

    fn search(
        &mut self,
        planner: &mut PositionPlanner,
        positive: bool,
        speed: u32,
        acceleration: u32,
    ) -> bool {
        let here = planner.state().position;
        let reach = i64::from(speed).saturating_mul(SEARCH_SECONDS);
        let target = if positive { here.saturating_add(reach) } else { here.saturating_sub(reach) };
        self.positive = positive;
        planner.request(target, 0, &self.limits(speed, acceleration)).is_ok()
    }

    /// Starts step `n` (or finishes when the program is done).
    fn begin<const B: usize>(
        &mut self,
        planner: &mut PositionPlanner,
        n: usize,
        input: &Inputs<'_, B>,
    ) -> bool {
        let (fast, slow, acceleration) = input.speeds;
        self.above_threshold_since = None;
        match self.program.get(n) {
            Some(Step::Search { positive, fast: quick, .. }) => {
                self.phase = Phase::Running(n);
                self.reversed = false;
                self.search(planner, positive, if quick { fast } else { slow }, acceleration)
            }
            Some(Step::BackOff { distance, .. }) => {
                self.phase = Phase::Running(n);
                let target = planner.state().position.saturating_add(distance);
                planner.request(target, 0, &self.limits(slow, acceleration)).is_ok()
            }
            None => {
                self.phase = Phase::Finishing;
                let rest = self.home.unwrap_or(input.actual).saturating_add(self.program.rest_offset);
                planner.request(rest, 0, &self.limits(slow, acceleration)).is_ok()
            }
        }
    }

    fn fail(&mut self, planner: &mut PositionPlanner, acceleration: u32, outcome: &mut Outcome) {
        let limits = self.limits(u32::MAX, acceleration);
        let _ = planner.request_stop(acceleration.max(1), &limits);
        self.phase = Phase::Stopping { error: true };
        outcome.error = true;
    }

    /// One tick of homing; returns the demand position (increments) and what happened.
    pub fn tick<const B: usize>(
        &mut self,
        planner: &mut PositionPlanner,
        input: &Inputs<'_, B>,
        halt_deceleration: u32,
    ) -> (i64, Outcome) {
        let mut outcome = Outcome::default();
        let (_, _, acceleration) = input.speeds;
        let bit4 = input.controlword.contains(Controlword::HOMING_START);
        let halt = input.controlword.contains(Controlword::HALT);
        let inputs = input.inputs;
        let previous = core::mem::replace(&mut self.previous_inputs, inputs);

        if input.start && !halt {
            self.start(planner, input, &mut outcome);
        }
        if !input.enabled {
            // Only method 35 completes outside Operation enabled; nothing moves here.
            planner.reset(input.actual);
            if matches!(self.phase, Phase::Running(_) | Phase::Finishing | Phase::Stopping { .. }) {
                self.phase = Phase::Idle;
            }
            return (input.actual, outcome);
        }

        let running = matches!(self.phase, Phase::Running(_) | Phase::Finishing);
        if running && (halt || !bit4) {
            let limits = self.limits(u32::MAX, halt_deceleration);
            let _ = planner.request_stop(halt_deceleration.max(1), &limits);
            self.phase = Phase::Stopping { error: false };
        }
        if running && input.following_error {
            self.fail(planner, acceleration, &mut outcome);
        }
        if let (Some(since), true) = (self.started_at, running) {
            if self.config.timeout != Duration::ZERO && input.now - since > self.config.timeout {
                self.fail(planner, acceleration, &mut outcome);
            }
        }
        if matches!(self.phase, Phase::Running(_))
            && Signal::NegativeLimit.active(inputs)
            && Signal::PositiveLimit.active(inputs)
        {
            self.fail(planner, acceleration, &mut outcome);
        }

        if let Phase::Running(n) = self.phase {
            self.run_step(planner, n, input, previous, &mut outcome);
        }

        let state = planner.follow();
        if planner.is_finished() {
            match self.phase {
                Phase::Finishing => {
                    self.phase = Phase::Done;
                    self.homed = true;
                }
                Phase::Stopping { error } => self.phase = if error { Phase::Failed } else { Phase::Idle },
                Phase::Running(n) => match self.program.get(n) {
                    Some(Step::BackOff { mark, .. }) => {
                        self.mark(mark, state.position, &mut outcome);
                        if !self.begin(planner, n + 1, input) {
                            self.fail(planner, acceleration, &mut outcome);
                        }
                    }
                    // A search that ran out of road: its event never came.
                    _ => self.fail(planner, acceleration, &mut outcome),
                },
                _ => {}
            }
        }
        (state.position, outcome)
    }

    fn start<const B: usize>(
        &mut self,
        planner: &mut PositionPlanner,
        input: &Inputs<'_, B>,
        outcome: &mut Outcome,
    ) {
        let method = input.method;
        self.homed = false;
        self.home = None;
        self.first_mark = None;
        self.limits = (None, None);
        self.started_at = Some(input.now);
        self.motionless = matches!(method, 35) || (method == 37 && self.config.method_37);
        self.rested = false;
        if self.motionless {
            // The current position is home: no motion, also outside Operation enabled.
            planner.reset(input.actual);
            self.home = Some(input.actual);
            outcome.home = self.home;
            self.homed = true;
            self.phase = Phase::Done;
            return;
        }
        if !input.enabled {
            return;
        }
        let (_, _, positive, negative) = self.config.hard_stop_parameters(input.od);
        let back_off = (positive, negative);
        // Filled in place: a program is some 160 bytes to copy.
        match self.program.fill(method, input.inputs, self.config.vendor(method), back_off) {
            Some(()) if method != 0 => {
                planner.reset(input.actual);
                if !self.begin(planner, 0, input) {
                    self.fail(planner, input.speeds.2, outcome);
                }
            }
            _ => self.fail(planner, input.speeds.2, outcome),
        }
    }

    fn run_step<const B: usize>(
        &mut self,
        planner: &mut PositionPlanner,
        n: usize,
        input: &Inputs<'_, B>,
        previous: DigitalInputs,
        outcome: &mut Outcome,
    ) {
        let Some(Step::Search { until, mark, reverse, .. }) = self.program.get(n) else { return };
        let inputs = input.inputs;
        let acceleration = input.speeds.2;
        let rose = |s: Signal| s.active(inputs) && !s.active(previous);
        let fell = |s: Signal| !s.active(inputs) && s.active(previous);
        // Where the event happened: the probe's latch, else the position of this tick.
        let at = match until {
            Until::Probe => input.probe.unwrap_or(input.actual),
            _ => input.actual,
        };
        let event = match until {
            Until::On(s) => rose(s),
            Until::Off(s) => fell(s),
            Until::Index => inputs.contains(DigitalInputs::INDEX),
            Until::HardStop => self.hard_stop(input),
            Until::Probe => input.probe.is_some(),
        };
        if event {
            self.mark(mark, at, outcome);
            if matches!(until, Until::HardStop) {
                // Stop pushing: the demand jumps back to where the shaft is.
                planner.reset(input.actual);
            }
            if !self.begin(planner, n + 1, input) {
                self.fail(planner, acceleration, outcome);
            }
            return;
        }
        let turn = |this: &mut Self, planner: &mut PositionPlanner, outcome: &mut Outcome| {
            let (fast, _, _) = input.speeds;
            this.reversed = true;
            if !this.search(planner, !this.positive, fast, acceleration) {
                this.fail(planner, acceleration, outcome);
            }
        };
        if reverse == Reverse::OnHardStop && !self.reversed && self.hard_stop(input) {
            // Stop pushing, as at a sought stop, and turn around.
            planner.reset(input.actual);
            turn(self, planner, outcome);
            return;
        }
        // A limit switch ahead that the search does not look for.
        let ahead = if self.positive { Signal::PositiveLimit } else { Signal::NegativeLimit };
        let towards_stop = until == Until::HardStop || reverse == Reverse::OnHardStop;
        let sought = matches!(until, Until::On(s) | Until::Off(s) if s == ahead)
            || (towards_stop && self.config.hard_stop_passes_limit_switches);
        if rose(ahead) && !sought {
            if reverse == Reverse::OnLimitSwitch && !self.reversed {
                turn(self, planner, outcome);
            } else {
                self.fail(planner, acceleration, outcome);
            }
        }
    }

    /// Records the position `at` as `mark` says; a home position goes into `outcome`, with the
    /// software limits found so far.
    fn mark(&mut self, mark: Mark, at: i64, outcome: &mut Outcome) {
        match mark {
            Mark::Home => self.home = Some(at),
            Mark::First => self.first_mark = Some(at),
            Mark::Midpoint => {
                let first = self.first_mark.unwrap_or(at);
                self.home = Some(first + (at - first) / 2);
            }
            Mark::Limit { positive } | Mark::HomeAndLimit { positive } => {
                if positive {
                    self.limits.1 = Some(at);
                } else {
                    self.limits.0 = Some(at);
                }
                if matches!(mark, Mark::HomeAndLimit { .. }) {
                    self.home = Some(at);
                }
            }
            Mark::None => {}
        }
        if matches!(mark, Mark::Home | Mark::Midpoint | Mark::HomeAndLimit { .. }) {
            outcome.home = self.home;
            outcome.limits = self.limits;
        }
    }

    /// |torque| at or above the threshold for the detection time while the shaft is held back
    /// (below half the search speed: accelerating to the search speed needs torque too).
    fn hard_stop<const B: usize>(&mut self, input: &Inputs<'_, B>) -> bool {
        let (threshold, time, _, _) = self.config.hard_stop_parameters(input.od);
        let blocked = i64::from(input.velocity).unsigned_abs() * 2 < u64::from(input.speeds.1);
        if input.torque.unsigned_abs() < threshold || !blocked {
            self.above_threshold_since = None;
            return false;
        }
        let since = *self.above_threshold_since.get_or_insert(input.now);
        input.now - since >= Duration::from_millis(u64::from(time))
    }
}

/// 6099h.
const HOMING_SPEED_SUBS: [(u8, Var); 3] = [
    (0, highest_sub(2)),
    (
        1,
        Var::new("Speed during search for switch", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .pdo(PdoMapping::Rpdo)
            .default(DefaultValue::Unsigned(10_000)),
    ),
    (
        2,
        Var::new("Speed during search for zero", DataType::Unsigned32)
            .access(Access::ReadWrite)
            .pdo(PdoMapping::Rpdo)
            .default(DefaultValue::Unsigned(1_000)),
    ),
];

/// Homing's objects (6098h, 6099h, 609Ah, 60E3h) with their CiA 402 defaults, in
/// [`super::registry::PROFILE`] when the build runs hm.
pub(crate) const OBJECTS: [Object; 4] = [
    setting(HOMING_METHOD, "Homing method", DataType::Integer8, DefaultValue::Zero),
    Object::record(HOMING_SPEEDS, "Homing speeds", &HOMING_SPEED_SUBS),
    setting(
        HOMING_ACCELERATION,
        "Homing acceleration",
        DataType::Unsigned32,
        DefaultValue::Unsigned(100_000),
    ),
    Object::array_with_sub0(
        SUPPORTED_HOMING_METHODS,
        "Supported homing methods",
        MAX_LISTED_METHODS,
        Var::new("Highest sub-index supported", DataType::Unsigned8)
            .access(Access::Const)
            .default(DefaultValue::Device(DeviceField::HomingMethodCount)),
        &Var::new("Supported homing method", DataType::Integer8)
            .access(Access::Const)
            .default(DefaultValue::Device(DeviceField::HomingMethods)),
    ),
];

/// The value rule of homing's object `index` ([`super::registry::rule`]): 6098h takes the methods
/// the configuration supports ([`HomingConfig::supports`]).
pub(crate) fn rule(index: u16) -> Option<Rule> {
    (super::HM && index == HOMING_METHOD).then_some(Rule::HomingMethod)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_may_offer_fewer_standard_methods() {
        let all = HomingConfig::new();
        assert!([0, 1, 14, 17, 30, 33, 36].iter().all(|&m| all.supports(m)));
        assert!(![15, 16, 31, 32, 37, 38, -1].iter().any(|&m| all.supports(m)));
        let few = HomingConfig {
            standard_methods: (1 << 17) | (1 << 18) | (1 << 35) | (1 << 37),
            method_37: true,
            vendor_methods: &[(-1, VendorMethod::HardStop { positive: true, index: false })],
            ..HomingConfig::new()
        };
        let offered: [i8; 6] = [0, 17, 18, 35, 37, -1];
        for method in -128..=127i8 {
            assert_eq!(few.supports(method), offered.contains(&method), "method {method}");
        }
    }
}

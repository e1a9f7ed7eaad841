//! The power drive system state machine (CiA 402-2 §8.1–8.2).
//!
//! ```text
//!  Start ─0─▶ Not ready to switch on ─1─▶ Switch on disabled ◀─────────────7,9,10,12,15─┐
//!                                          │ 2 ▲ 7                                          │
//!                                          ▼   │                                            │
//!                                     Ready to switch on ◀─6,8─┐                            │
//!                                          │ 3 ▲ 6             │                            │
//!                                          ▼   │               │                            │
//!                                       Switched on ◀─5─┐      │                            │
//!                                          │ 4          │      │                            │
//!                                          ▼            │      │                            │
//!                                    Operation enabled ─┴──────┘──11──▶ Quick stop active ──┘
//!                                                   ▲──────────────16───────┘
//!  any ─13─▶ Fault reaction active ─14─▶ Fault ─15─▶ Switch on disabled
//! ```
//!
//! [`Fsa::step`] runs once per control tick with the controlword, the fault signal and whether
//! the axis is at rest; it returns what the power stage and the motion layer must do. The
//! transition function [`next`] is pure and follows the transition table of CiA 402-2 §8.2 line by line.
//!
//! Decisions (CiA 402-2 §8.2, where its text leaves room):
//! - Commands other than Fault reset are decoded only while controlword bit 7 = 0; Fault reset
//!   is the 0→1 edge of bit 7 (CiA 402-2 §8.2).
//! - "An action is completed before the transition is reported": Disable operation with 605Ch = 1
//!   and Shutdown with 605Bh = 1 keep Operation enabled while the axis ramps down; Quick stop
//!   keeps Quick stop active until at rest; Fault reaction active lasts until at rest.
//! - 605Ah = 0 (disable drive function) leads to Switch on disabled at once, like 1–4.
//! - In Quick stop active, Shutdown and Switch on are ignored (the state stays).
//! - Transition 16 (Quick stop active → Operation enabled) is allowed for 605Ah = 5–8 once at
//!   rest, unless [`Options::transition_16`] is false.

use super::words::{Controlword, Statusword};

/// The states of the FSA (CiA 402-2 §8.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum State {
    /// Self-test and initialisation (left automatically).
    NotReadyToSwitchOn,
    /// Power stage off, waiting for Shutdown.
    SwitchOnDisabled,
    /// Ready: waiting for Switch on.
    ReadyToSwitchOn,
    /// High-level power on, drive function disabled.
    SwitchedOn,
    /// Drive function enabled; `leaving` while a stop requested by 605Bh/605Ch runs.
    OperationEnabled {
        /// The state reached once the stop ramp is done.
        leaving: Option<Leaving>,
    },
    /// Quick stop running or done.
    QuickStopActive,
    /// The fault reaction of 605Eh runs.
    FaultReactionActive,
    /// Drive function disabled after a fault.
    Fault,
}

/// Where a ramped exit from Operation enabled ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Leaving {
    /// Disable operation (transition 5).
    ToSwitchedOn,
    /// Shutdown (transition 8).
    ToReadyToSwitchOn,
}

/// Controlword commands (CiA 402-2 §8.2, Table 27).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// `0xxx x110`.
    Shutdown,
    /// `0xxx 0111`: Switch on, also Disable operation.
    SwitchOn,
    /// `0xxx 1111`: Switch on + Enable operation.
    EnableOperation,
    /// `0xxx xx0x`.
    DisableVoltage,
    /// `0xxx x01x` (quick stop is active-low).
    QuickStop,
    /// 0→1 edge of bit 7.
    FaultReset,
}

/// Decodes the controlword: Fault reset on the rising edge of bit 7, the other commands only
/// while bit 7 = 0. `None` while bit 7 stays 1.
pub fn decode(controlword: Controlword, previous: Controlword) -> Option<Command> {
    if controlword.contains(Controlword::FAULT_RESET) {
        return (!previous.contains(Controlword::FAULT_RESET)).then_some(Command::FaultReset);
    }
    Some(if !controlword.contains(Controlword::ENABLE_VOLTAGE) {
        Command::DisableVoltage
    } else if !controlword.contains(Controlword::QUICK_STOP) {
        Command::QuickStop
    } else if !controlword.contains(Controlword::SWITCH_ON) {
        Command::Shutdown
    } else if !controlword.contains(Controlword::ENABLE_OPERATION) {
        Command::SwitchOn
    } else {
        Command::EnableOperation
    })
}

/// How the axis is brought to rest (605Ah/605Bh/605Ch/605Dh/605Eh values, CiA 402-2 §8.4.4–§8.4.9).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StopKind {
    /// Disable the drive function at once; the motor coasts.
    Coast,
    /// The slow-down ramp (the mode's deceleration, e.g. 6084h).
    SlowDown,
    /// The quick-stop ramp (6085h).
    QuickStopRamp,
    /// Stop at the current (torque) limit.
    CurrentLimit,
    /// Stop at the voltage limit.
    VoltageLimit,
    /// Disable the drive function at once and brake the motor by short-circuiting its windings
    /// ([`Demand::dynamic_brake`](crate::hal::Demand)): the manufacturer-specific option code
    /// value −1 some drives document.
    DynamicBrake,
}

impl StopKind {
    /// The drive function goes off at once (no ramp): [`Self::Coast`], [`Self::DynamicBrake`].
    pub const fn at_once(self) -> bool {
        matches!(self, StopKind::Coast | StopKind::DynamicBrake)
    }

    /// 605Ah value → (stop, stay in Quick stop active); `None` for reserved values.
    pub const fn quick_stop(code: i16) -> Option<(StopKind, bool)> {
        Some(match code {
            -1 => (StopKind::DynamicBrake, false),
            0 => (StopKind::Coast, false),
            1 => (StopKind::SlowDown, false),
            2 => (StopKind::QuickStopRamp, false),
            3 => (StopKind::CurrentLimit, false),
            4 => (StopKind::VoltageLimit, false),
            5 => (StopKind::SlowDown, true),
            6 => (StopKind::QuickStopRamp, true),
            7 => (StopKind::CurrentLimit, true),
            8 => (StopKind::VoltageLimit, true),
            _ => return None,
        })
    }

    /// 605Bh/605Ch value → stop; `None` for reserved values.
    pub const fn disable(code: i16) -> Option<StopKind> {
        match code {
            -1 => Some(StopKind::DynamicBrake),
            0 => Some(StopKind::Coast),
            1 => Some(StopKind::SlowDown),
            _ => None,
        }
    }

    /// 605Dh/605Eh value → stop (605Dh has no 0); `None` for reserved values.
    pub const fn halt_or_fault(code: i16) -> Option<StopKind> {
        match code {
            -1 => Some(StopKind::DynamicBrake),
            0 => Some(StopKind::Coast),
            1 => Some(StopKind::SlowDown),
            2 => Some(StopKind::QuickStopRamp),
            3 => Some(StopKind::CurrentLimit),
            4 => Some(StopKind::VoltageLimit),
            _ => None,
        }
    }
}

/// The option codes the FSA consults (values already validated).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Options {
    /// 605Ah quick stop option code.
    pub quick_stop: i16,
    /// 605Bh shutdown option code.
    pub shutdown: i16,
    /// 605Ch disable operation option code.
    pub disable_operation: i16,
    /// 605Eh fault reaction option code.
    pub fault_reaction: i16,
    /// Transition 16 (Quick stop active → Operation enabled) supported.
    pub transition_16: bool,
}

impl Default for Options {
    /// The CiA 402 defaults: 605Ah = 2, 605Bh = 0, 605Ch = 1, 605Eh = 2.
    fn default() -> Self {
        Options { quick_stop: 2, shutdown: 0, disable_operation: 1, fault_reaction: 2, transition_16: true }
    }
}

/// What happens to the FSA in one tick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// Nothing new.
    None,
    /// A controlword command.
    Command(Command),
    /// A fault appeared (transition 13).
    Fault,
}

/// The transition function: the state after `event` in `state`, before automatic transitions.
/// `fault_present`: a fault cause is still there (blocks Fault reset, transition 15).
pub fn next(state: State, event: Event, options: &Options, at_rest: bool, fault_present: bool) -> State {
    use Command::*;
    use State::*;
    let stays_in_quick_stop = StopKind::quick_stop(options.quick_stop).is_some_and(|(_, stay)| stay);
    match (state, event) {
        // 13: a fault pre-empts everything but the fault states.
        (FaultReactionActive | Fault, Event::Fault) => state,
        (_, Event::Fault) => FaultReactionActive,

        (NotReadyToSwitchOn, Event::Command(_) | Event::None) => state,

        (SwitchOnDisabled, Event::Command(Shutdown)) => ReadyToSwitchOn, // 2
        (SwitchOnDisabled, Event::Command(_) | Event::None) => state,

        (ReadyToSwitchOn, Event::Command(SwitchOn)) => SwitchedOn, // 3
        (ReadyToSwitchOn, Event::Command(EnableOperation)) => OperationEnabled { leaving: None }, // 3 + 4
        (ReadyToSwitchOn, Event::Command(DisableVoltage | QuickStop)) => SwitchOnDisabled, // 7
        (ReadyToSwitchOn, Event::Command(Shutdown | FaultReset) | Event::None) => state,

        (SwitchedOn, Event::Command(Shutdown)) => ReadyToSwitchOn, // 6
        (SwitchedOn, Event::Command(EnableOperation)) => OperationEnabled { leaving: None }, // 4
        (SwitchedOn, Event::Command(DisableVoltage | QuickStop)) => SwitchOnDisabled, // 10
        (SwitchedOn, Event::Command(SwitchOn | FaultReset) | Event::None) => state,

        // 5 and 8 happen once the stop of 605Ch/605Bh is done (see `settle`).
        (OperationEnabled { .. }, Event::Command(SwitchOn)) => {
            OperationEnabled { leaving: Some(Leaving::ToSwitchedOn) }
        }
        (OperationEnabled { .. }, Event::Command(Shutdown)) => {
            OperationEnabled { leaving: Some(Leaving::ToReadyToSwitchOn) }
        }
        (OperationEnabled { .. }, Event::Command(DisableVoltage)) => SwitchOnDisabled, // 9
        (OperationEnabled { .. }, Event::Command(QuickStop)) => QuickStopActive,       // 11
        // Enable operation during a ramped exit cancels the exit.
        (OperationEnabled { .. }, Event::Command(EnableOperation)) => OperationEnabled { leaving: None },
        (OperationEnabled { .. }, Event::Command(FaultReset) | Event::None) => state,

        (QuickStopActive, Event::Command(DisableVoltage)) => SwitchOnDisabled, // 12
        (QuickStopActive, Event::Command(EnableOperation))
            if stays_in_quick_stop && options.transition_16 && at_rest =>
        {
            OperationEnabled { leaving: None } // 16
        }
        (QuickStopActive, Event::Command(_) | Event::None) => state,

        (FaultReactionActive, Event::Command(_) | Event::None) => state,

        (Fault, Event::Command(FaultReset)) if !fault_present => SwitchOnDisabled, // 15
        (Fault, Event::Command(_) | Event::None) => state,
    }
}

/// Automatic transitions (1, 5/8 after their ramp, 12, 14), given whether the stop is done.
pub fn settle(state: State, options: &Options, stopped: bool) -> State {
    use State::*;
    match state {
        NotReadyToSwitchOn => SwitchOnDisabled, // 1
        OperationEnabled { leaving: Some(leaving) } => {
            let kind = match leaving {
                Leaving::ToSwitchedOn => StopKind::disable(options.disable_operation),
                Leaving::ToReadyToSwitchOn => StopKind::disable(options.shutdown),
            };
            if stopped || kind.is_some_and(StopKind::at_once) {
                match leaving {
                    Leaving::ToSwitchedOn => SwitchedOn,           // 5
                    Leaving::ToReadyToSwitchOn => ReadyToSwitchOn, // 8
                }
            } else {
                state
            }
        }
        QuickStopActive => match StopKind::quick_stop(options.quick_stop) {
            Some((kind, _)) if kind.at_once() => SwitchOnDisabled,
            Some((_, false)) if stopped => SwitchOnDisabled, // 12
            _ => state,
        },
        FaultReactionActive => {
            if stopped || StopKind::halt_or_fault(options.fault_reaction).is_some_and(StopKind::at_once) {
                Fault // 14
            } else {
                state
            }
        }
        SwitchOnDisabled | ReadyToSwitchOn | SwitchedOn | OperationEnabled { leaving: None } | Fault => state,
    }
}

impl State {
    /// The state bits of the statusword (0, 1, 2, 3, 5, 6; CiA 402-2 §8.4.2), typed.
    pub const fn statusword(self) -> Statusword {
        Statusword::from_raw(self.statusword_bits())
    }

    /// The state bits of the statusword (0, 1, 2, 3, 5, 6; CiA 402-2 §8.4.2), raw.
    pub const fn statusword_bits(self) -> u16 {
        match self {
            State::NotReadyToSwitchOn => 0x0000,
            State::SwitchOnDisabled => 0x0040,
            State::ReadyToSwitchOn => 0x0021,
            State::SwitchedOn => 0x0023,
            State::OperationEnabled { .. } => 0x0027,
            State::QuickStopActive => 0x0007,
            State::FaultReactionActive => 0x000F,
            State::Fault => 0x0008,
        }
    }

    /// The state a statusword reports, through the masks of CiA 402-2 §8.4.2.
    pub fn from_statusword(statusword: u16) -> Option<State> {
        Some(match (statusword & 0x004F, statusword & 0x006F) {
            (0x0000, _) => State::NotReadyToSwitchOn,
            (0x0040, _) => State::SwitchOnDisabled,
            (_, 0x0021) => State::ReadyToSwitchOn,
            (_, 0x0023) => State::SwitchedOn,
            (_, 0x0027) => State::OperationEnabled { leaving: None },
            (_, 0x0007) => State::QuickStopActive,
            (0x000F, _) => State::FaultReactionActive,
            (0x0008, _) => State::Fault,
            _ => return None,
        })
    }

    /// Energy may reach the motor: only in Operation enabled, Quick stop active and Fault reaction
    /// active (CiA 402-2 §8.2).
    pub const fn drive_function_enabled(self) -> bool {
        matches!(self, State::OperationEnabled { .. } | State::QuickStopActive | State::FaultReactionActive)
    }

    /// High-level power is switched on (transition 3 switches it on; 6, 7, 9, 10, 12, 14 off).
    pub const fn high_voltage(self) -> bool {
        matches!(
            self,
            State::SwitchedOn
                | State::OperationEnabled { .. }
                | State::QuickStopActive
                | State::FaultReactionActive
        )
    }
}

/// The stop the motion layer runs in `state`, if any.
pub fn stop_in(state: State, options: &Options) -> Option<StopKind> {
    match state {
        State::OperationEnabled { leaving: Some(Leaving::ToSwitchedOn) } => {
            StopKind::disable(options.disable_operation)
        }
        State::OperationEnabled { leaving: Some(Leaving::ToReadyToSwitchOn) } => {
            StopKind::disable(options.shutdown)
        }
        State::QuickStopActive => StopKind::quick_stop(options.quick_stop).map(|(kind, _)| kind),
        State::FaultReactionActive => StopKind::halt_or_fault(options.fault_reaction),
        State::NotReadyToSwitchOn
        | State::SwitchOnDisabled
        | State::ReadyToSwitchOn
        | State::SwitchedOn
        | State::OperationEnabled { leaving: None }
        | State::Fault => None,
    }
}

/// The FSA with its memory of the previous controlword.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fsa {
    state: State,
    previous_controlword: Controlword,
}

impl Default for Fsa {
    fn default() -> Self {
        Fsa { state: State::NotReadyToSwitchOn, previous_controlword: Controlword::empty() }
    }
}

/// What one step of the FSA asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Step {
    /// The state to report.
    pub state: State,
    /// The state changed into Operation enabled from outside it (transition 4 or 16): clear
    /// the internal set-points.
    pub entered_operation: bool,
    /// The stop the motion layer must run.
    pub stop: Option<StopKind>,
    /// The state passed through a dynamic-brake stop in this tick (such a stop takes no time,
    /// so the state may already be past it): short the windings until the shaft is at rest.
    pub dynamic_brake: bool,
}

impl Fsa {
    /// The current state.
    pub fn state(&self) -> State {
        self.state
    }

    /// One tick: the controlword (`None`: local control, no command processed), whether a fault
    /// is present (a new one triggers transition 13; one still present blocks Fault reset), and
    /// whether the stop running in the previous tick has brought the axis to rest.
    pub fn step(
        &mut self,
        controlword: Option<Controlword>,
        fault: bool,
        at_rest: bool,
        options: &Options,
    ) -> Step {
        let before = self.state;
        let command =
            controlword.and_then(|cw| decode(cw, core::mem::replace(&mut self.previous_controlword, cw)));
        let event = match (fault, command) {
            (true, _) if !matches!(before, State::FaultReactionActive | State::Fault) => Event::Fault,
            (_, Some(command)) => Event::Command(command),
            (_, None) => Event::None,
        };
        let after = next(before, event, options, at_rest, fault);
        // A stop that was already running may complete now; one that starts in this tick needs a
        // tick of motion first, unless it coasts.
        let settled = settle(after, options, at_rest && after == before);
        self.state = settled;
        let was_enabled = matches!(before, State::OperationEnabled { .. });
        Step {
            state: settled,
            entered_operation: matches!(settled, State::OperationEnabled { .. }) && !was_enabled,
            stop: stop_in(settled, options),
            dynamic_brake: after != settled && stop_in(after, options) == Some(StopKind::DynamicBrake),
        }
    }

    /// Forces the state (power-on and reset application start over).
    pub fn reset(&mut self) {
        *self = Fsa::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`super::decode`] of raw words.
    fn decode(controlword: u16, previous: u16) -> Option<Command> {
        super::decode(Controlword::from_raw(controlword), Controlword::from_raw(previous))
    }

    fn cw(raw: u16) -> Option<Controlword> {
        Some(Controlword::from_raw(raw))
    }

    #[test]
    fn e_48_decoder_matches_the_masks_for_every_word() {
        for cw in 0u16..=0xFFFF {
            if cw & 0x80 != 0 {
                continue;
            }
            let expected = [
                ((cw & 0x0087) == 0x0006, Command::Shutdown),
                ((cw & 0x008F) == 0x0007, Command::SwitchOn),
                ((cw & 0x008F) == 0x000F, Command::EnableOperation),
                ((cw & 0x0082) == 0x0000, Command::DisableVoltage),
                ((cw & 0x0086) == 0x0002, Command::QuickStop),
            ];
            let matching: std::vec::Vec<Command> =
                expected.iter().filter(|(m, _)| *m).map(|(_, c)| *c).collect();
            assert_eq!(matching.len(), 1, "{cw:#06x}");
            assert_eq!(decode(cw, 0), Some(matching[0]), "{cw:#06x}");
        }
        assert_eq!(decode(0x0080, 0x0000), Some(Command::FaultReset));
        assert_eq!(decode(0x0080, 0x0080), None);
        assert_eq!(decode(0x0086, 0x0080), None, "other commands need bit 7 = 0");
        assert_eq!(decode(0xF80F, 0), Some(Command::EnableOperation));
    }

    #[test]
    fn e_49_statusword_decoder_round_trips_the_masks() {
        let states = [
            State::NotReadyToSwitchOn,
            State::SwitchOnDisabled,
            State::ReadyToSwitchOn,
            State::SwitchedOn,
            State::OperationEnabled { leaving: None },
            State::QuickStopActive,
            State::FaultReactionActive,
            State::Fault,
        ];
        for state in states {
            for extra in [0x0000u16, 0x0010, 0xFF90, 0x0200] {
                assert_eq!(State::from_statusword(state.statusword_bits() | extra), Some(state));
            }
        }
        for sw in 0u16..=0xFFFF {
            if let Some(state) = State::from_statusword(sw) {
                let mask = if matches!(
                    state,
                    State::ReadyToSwitchOn
                        | State::SwitchedOn
                        | State::OperationEnabled { .. }
                        | State::QuickStopActive
                ) {
                    0x006F
                } else {
                    0x004F
                };
                assert_eq!(sw & mask, state.statusword_bits(), "{sw:#06x}");
            }
        }
    }

    fn run(fsa: &mut Fsa, cw: u16, options: &Options) -> State {
        fsa.step(Some(Controlword::from_raw(cw)), false, true, options).state
    }

    #[test]
    fn enable_sequence_and_shortcut() {
        let o = Options::default();
        let mut fsa = Fsa::default();
        assert_eq!(fsa.step(None, false, true, &o).state, State::SwitchOnDisabled);
        assert_eq!(run(&mut fsa, 0x0007, &o), State::SwitchOnDisabled);
        assert_eq!(run(&mut fsa, 0x0006, &o), State::ReadyToSwitchOn);
        assert_eq!(run(&mut fsa, 0x000F, &o), State::OperationEnabled { leaving: None }, "3 + 4");
        assert_eq!(run(&mut fsa, 0x000B, &o), State::QuickStopActive);
        // 605Ah = 2: at rest → Switch on disabled (12) in the next tick.
        assert_eq!(run(&mut fsa, 0x000B, &o), State::SwitchOnDisabled);
    }

    #[test]
    fn fault_reset_needs_an_edge_and_no_cause() {
        let o = Options::default();
        let mut fsa = Fsa::default();
        run(&mut fsa, 0x0006, &o);
        assert_eq!(fsa.step(cw(0x0006), true, false, &o).state, State::FaultReactionActive);
        assert_eq!(fsa.step(cw(0x0006), true, true, &o).state, State::Fault);
        assert_eq!(fsa.step(cw(0x0080), true, true, &o).state, State::Fault, "cause present");
        assert_eq!(fsa.step(cw(0x0080), false, true, &o).state, State::Fault, "no new edge");
        assert_eq!(fsa.step(cw(0x0000), false, true, &o).state, State::Fault);
        assert_eq!(fsa.step(cw(0x0080), false, true, &o).state, State::SwitchOnDisabled);
    }

    /// A reference model written from a state × command table derived from CiA 402-2 §8.2, with its own
    /// encoding: state codes are statusword patterns, a ramped exit is a separate flag, and a
    /// stop completes on the first tick at rest after the tick that started it.
    #[derive(Clone, Copy, Debug)]
    struct Reference {
        code: u16,
        exit_to: Option<u16>,
        stop_started: bool,
    }

    const NRTSO: u16 = 0x00;
    const SOD: u16 = 0x40;
    const RTSO: u16 = 0x21;
    const SO: u16 = 0x23;
    const OE: u16 = 0x27;
    const QSA: u16 = 0x07;
    const FRA: u16 = 0x0F;
    const FAULT: u16 = 0x08;

    impl Reference {
        fn tick(&mut self, cw: u16, prev: u16, fault: bool, at_rest: bool, o: &Options) {
            let edge = cw & 0x80 != 0 && prev & 0x80 == 0;
            let command = if cw & 0x80 != 0 {
                None
            } else if cw & 0x02 == 0 {
                Some("dv")
            } else if cw & 0x04 == 0 {
                Some("qs")
            } else if cw & 0x01 == 0 {
                Some("sd")
            } else if cw & 0x08 == 0 {
                Some("so")
            } else {
                Some("eo")
            };
            let (qs_stop, qs_stay) = StopKind::quick_stop(o.quick_stop).unwrap();
            let old = (self.code, self.exit_to);
            if fault && self.code != FRA && self.code != FAULT {
                *self = Reference { code: FRA, exit_to: None, stop_started: false };
            } else {
                match (self.code, command) {
                    (SOD, Some("sd")) => self.code = RTSO,
                    (RTSO, Some("so")) => self.code = SO,
                    (RTSO, Some("eo")) => self.code = OE,
                    (RTSO, Some("dv" | "qs")) => self.code = SOD,
                    (SO, Some("sd")) => self.code = RTSO,
                    (SO, Some("eo")) => self.code = OE,
                    (SO, Some("dv" | "qs")) => self.code = SOD,
                    (OE, Some("so")) => self.exit_to = Some(SO),
                    (OE, Some("sd")) => self.exit_to = Some(RTSO),
                    (OE, Some("eo")) => self.exit_to = None,
                    (OE, Some("dv")) => *self = Reference { code: SOD, exit_to: None, stop_started: false },
                    (OE, Some("qs")) => *self = Reference { code: QSA, exit_to: None, stop_started: false },
                    (QSA, Some("dv")) => self.code = SOD,
                    (QSA, Some("eo")) if qs_stay && o.transition_16 && at_rest => self.code = OE,
                    (FAULT, _) if edge && !fault => self.code = SOD,
                    _ => {}
                }
            }
            let started_now = (self.code, self.exit_to) != old;
            let done = at_rest && !started_now;
            match (self.code, self.exit_to) {
                (NRTSO, _) => self.code = SOD,
                (OE, Some(target)) => {
                    let code = if target == SO { o.disable_operation } else { o.shutdown };
                    if code == 0 || done {
                        *self = Reference { code: target, exit_to: None, stop_started: false };
                    }
                }
                (QSA, _) if qs_stop == StopKind::Coast || (!qs_stay && done) => self.code = SOD,
                (FRA, _) if o.fault_reaction == 0 || done => self.code = FAULT,
                _ => {}
            }
            self.stop_started = false;
        }
    }

    #[test]
    fn random_controlwords_agree_with_the_reference_model() {
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut rand = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let interesting = [0x0000u16, 0x0002, 0x0006, 0x0007, 0x000F, 0x000B, 0x0080, 0x0086, 0x000D, 0xF80F];
        let mut steps = 0;
        for options_round in 0..20u64 {
            let o = Options {
                quick_stop: (options_round % 9) as i16,
                shutdown: (options_round % 2) as i16,
                disable_operation: ((options_round / 2) % 2) as i16,
                fault_reaction: (options_round % 5) as i16,
                transition_16: options_round % 3 != 0,
            };
            let mut fsa = Fsa::default();
            let mut reference = Reference { code: NRTSO, exit_to: None, stop_started: false };
            let mut prev = 0u16;
            for _ in 0..5_000 {
                let r = rand();
                let cw = if r % 4 == 0 {
                    r as u16 >> 3
                } else {
                    interesting[(r >> 8) as usize % interesting.len()]
                };
                let fault = (r >> 20) % 50 == 0;
                let at_rest = (r >> 30) % 3 != 0;
                let step = fsa.step(Some(Controlword::from_raw(cw)), fault, at_rest, &o);
                reference.tick(cw, prev, fault, at_rest, &o);
                prev = cw;
                steps += 1;
                assert_eq!(step.state.statusword_bits(), reference.code, "step {steps}, cw {cw:#06x}, {o:?}");
                // Energy only in Operation enabled, Quick stop active, Fault reaction active.
                let energised = step.state.drive_function_enabled();
                assert_eq!(energised, matches!(reference.code, OE | QSA | FRA));
            }
        }
        assert!(steps >= 100_000);
    }

    extern crate std;
}

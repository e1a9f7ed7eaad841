//! NMT slave (CiA 301 §7.3.2): the state machine driven by node-control commands.
//!
//! ```text
//!  power-on ─▶ Initialising ──(boot-up 0x700+id [00])──▶ Pre-operational
//!  Pre-operational ⇄ Operational (0x01 / 0x80);  any ─0x02─▶ Stopped;  Stopped ─0x01/0x80─▶
//!  0x81 reset node: reset application + reset communication ─▶ Initialising
//!  0x82 reset communication ─▶ Initialising
//! ```

use crate::wire::nmt::{NmtCommand, NmtState};

/// What the node does on a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NmtAction {
    /// Nothing (unknown command, or a command while still initialising).
    None,
    /// Enter the given operating state.
    Enter(NmtState),
    /// Reset the application (2000h–9FFFh), then the communication.
    ResetApplication,
    /// Reset the communication (1000h–1FFFh).
    ResetCommunication,
}

/// The transition function of the NMT slave (CiA 301 §7.2.8.3.1).
pub fn transition(state: NmtState, command: NmtCommand) -> NmtAction {
    match (state, command) {
        // Commands are not processed during initialisation.
        (NmtState::Initialising, _) => NmtAction::None,
        (_, NmtCommand::Start) => NmtAction::Enter(NmtState::Operational),
        (_, NmtCommand::Stop) => NmtAction::Enter(NmtState::Stopped),
        (_, NmtCommand::EnterPreOperational) => NmtAction::Enter(NmtState::PreOperational),
        (_, NmtCommand::ResetNode) => NmtAction::ResetApplication,
        (_, NmtCommand::ResetCommunication) => NmtAction::ResetCommunication,
        (_, NmtCommand::Unknown(_)) => NmtAction::None,
    }
}

/// Which services a state serves (CiA 301 §7.3.2).
pub trait Services {
    /// SDO server answers.
    fn serves_sdo(self) -> bool;
    /// PDOs move.
    fn serves_pdo(self) -> bool;
    /// EMCY and SYNC are active.
    fn serves_emcy(self) -> bool;
}

impl Services for NmtState {
    fn serves_sdo(self) -> bool {
        matches!(self, NmtState::PreOperational | NmtState::Operational)
    }
    fn serves_pdo(self) -> bool {
        matches!(self, NmtState::Operational)
    }
    fn serves_emcy(self) -> bool {
        matches!(self, NmtState::PreOperational | NmtState::Operational)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use NmtState::*;

    #[test]
    fn transition_table() {
        for state in [PreOperational, Operational, Stopped] {
            assert_eq!(transition(state, NmtCommand::Start), NmtAction::Enter(Operational));
            assert_eq!(transition(state, NmtCommand::Stop), NmtAction::Enter(Stopped));
            assert_eq!(transition(state, NmtCommand::EnterPreOperational), NmtAction::Enter(PreOperational));
            assert_eq!(transition(state, NmtCommand::ResetNode), NmtAction::ResetApplication);
            assert_eq!(transition(state, NmtCommand::ResetCommunication), NmtAction::ResetCommunication);
            assert_eq!(transition(state, NmtCommand::Unknown(0x55)), NmtAction::None);
        }
        assert_eq!(transition(Initialising, NmtCommand::Start), NmtAction::None);
    }

    #[test]
    fn services_per_state() {
        assert!(!Stopped.serves_sdo());
        assert!(PreOperational.serves_sdo() && !PreOperational.serves_pdo());
        assert!(Operational.serves_pdo());
        assert!(!Initialising.serves_sdo());
    }
}

//! NMT node control and NMT error-control frames (CiA 301 §7.2.8).
//!
//! ```text
//! node control  COB-ID 0x000, DLC 2: [command specifier, node-ID (0 = all)]
//! boot-up       COB-ID 0x700+id, DLC 1: [0x00]
//! heartbeat     COB-ID 0x700+id, DLC 1: [state]   (0x04 Stopped, 0x05 Operational, 0x7F Pre-op)
//! ```

/// NMT state of a node, with the byte it reports in heartbeats (CiA 301 §7.3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NmtState {
    /// Initialisation (boot-up frame carries 0x00).
    Initialising,
    /// Pre-operational (0x7F): SDO yes, PDO no.
    PreOperational,
    /// Operational (0x05): everything runs.
    Operational,
    /// Stopped (0x04): only NMT and error control.
    Stopped,
}

impl NmtState {
    /// The state byte of a heartbeat or boot-up frame.
    pub const fn heartbeat_byte(self) -> u8 {
        match self {
            NmtState::Initialising => 0x00,
            NmtState::PreOperational => 0x7F,
            NmtState::Operational => 0x05,
            NmtState::Stopped => 0x04,
        }
    }
}

/// An NMT node-control command specifier (CiA 301 §7.2.8.3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NmtCommand {
    /// 0x01 start remote node.
    Start,
    /// 0x02 stop remote node.
    Stop,
    /// 0x80 enter pre-operational.
    EnterPreOperational,
    /// 0x81 reset node (reset application).
    ResetNode,
    /// 0x82 reset communication.
    ResetCommunication,
    /// Any other value (ignored by slaves).
    Unknown(u8),
}

impl NmtCommand {
    /// The command specifier byte.
    pub const fn code(self) -> u8 {
        match self {
            NmtCommand::Start => 0x01,
            NmtCommand::Stop => 0x02,
            NmtCommand::EnterPreOperational => 0x80,
            NmtCommand::ResetNode => 0x81,
            NmtCommand::ResetCommunication => 0x82,
            NmtCommand::Unknown(raw) => raw,
        }
    }

    /// The command for a command specifier byte.
    pub const fn from_code(raw: u8) -> Self {
        match raw {
            0x01 => NmtCommand::Start,
            0x02 => NmtCommand::Stop,
            0x80 => NmtCommand::EnterPreOperational,
            0x81 => NmtCommand::ResetNode,
            0x82 => NmtCommand::ResetCommunication,
            other => NmtCommand::Unknown(other),
        }
    }
}

/// A parsed node-control frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NodeControl {
    /// The command.
    pub command: NmtCommand,
    /// Addressed node-ID; 0 addresses every node.
    pub node_id: u8,
}

impl NodeControl {
    /// Parses the data of a frame on COB-ID 0x000; frames whose DLC is not 2 are ignored
    /// (CiA 301 §7.2.8.3.1).
    pub fn parse(data: &[u8]) -> Option<Self> {
        match data {
            [cs, node] => Some(NodeControl { command: NmtCommand::from_code(*cs), node_id: *node }),
            _ => None,
        }
    }

    /// True when the frame addresses `node_id` (directly or by broadcast).
    pub fn addresses(&self, node_id: u8) -> bool {
        self.node_id == 0 || self.node_id == node_id
    }

    /// The two data bytes.
    pub fn emit(&self) -> [u8; 2] {
        [self.command.code(), self.node_id]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_requires_dlc_two() {
        assert_eq!(
            NodeControl::parse(&[0x01, 0x05]),
            Some(NodeControl { command: NmtCommand::Start, node_id: 5 })
        );
        assert_eq!(NodeControl::parse(&[0x01]), None);
        assert_eq!(NodeControl::parse(&[0x01, 0x05, 0x00]), None);
    }

    #[test]
    fn command_codes_round_trip() {
        for raw in 0..=255u8 {
            assert_eq!(NmtCommand::from_code(raw).code(), raw);
        }
        let c = NodeControl { command: NmtCommand::ResetCommunication, node_id: 0 };
        assert_eq!(NodeControl::parse(&c.emit()), Some(c));
        assert!(c.addresses(17));
    }
}

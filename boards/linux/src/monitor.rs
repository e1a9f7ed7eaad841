//! What `-v` and `-vv` print: the drive's state changes and the bus events an operator looks
//! for, as one line each on stderr.
//!
//! - `-v`: NMT state and CiA 402 state changes of the drive, the mode of operation it shows
//!   (6061h), every EMCY on the bus (the drive's and other nodes'), every SDO abort (sent by
//!   the drive or by a client), and what the core logs at warning level and above (storage
//!   failures, faults).
//! - `-vv`: also every frame in both directions (`rx` into the drive, `tx` out of it, in
//!   candump's `ID#DATA` notation), NMT commands, and every log record of the core (state
//!   transitions, storage events).
//!
//! The bus events are decoded from the frames alone, with the predefined connection set of
//! CiA 301 (EMCY on 081h–0FFh, SDO on 581h–5FFh / 601h–67Fh), so they describe any node on the
//! bus, not only this drive.

use canopen_drive::cia402::fsa::State;
use canopen_drive::wire::nmt::NmtState;
use canopen_drive::{AbortCode, CanFrame};
use embedded_can::Frame;

/// Which way a frame went, seen from the drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Into the drive (sent by a client or another node on the bus).
    Rx,
    /// Out of the drive.
    Tx,
}

/// The frame in candump's notation: `605#4000100000000000`, `1FFFFFFF#11`, `705#R1`.
pub fn candump_text(frame: &CanFrame) -> String {
    let mut text = match frame.id() {
        embedded_can::Id::Standard(id) => format!("{:03X}#", id.as_raw()),
        embedded_can::Id::Extended(id) => format!("{:08X}#", id.as_raw()),
    };
    if frame.is_remote_frame() {
        text.push_str(&format!("R{}", frame.dlc()));
    } else {
        for byte in frame.data() {
            text.push_str(&format!("{byte:02X}"));
        }
    }
    text
}

/// The `-v` line a frame deserves, if any: an EMCY, an SDO abort or (`-vv` only, see
/// [`Monitor`]) an NMT command.
pub fn describe(direction: Direction, frame: &CanFrame) -> Option<String> {
    let id = frame.standard_id()?;
    if frame.is_remote_frame() {
        return None;
    }
    let data = frame.data();
    let by = |node: u16| match direction {
        Direction::Tx => format!("node {node} (this drive)"),
        Direction::Rx => format!("node {node}"),
    };
    match id {
        0x081..=0x0FF => {
            let node = id - 0x080;
            match data {
                [low, high, register, info @ ..] if data.len() == 8 => {
                    let code = u16::from_le_bytes([*low, *high]);
                    if code == 0 {
                        Some(format!("EMCY from {}: error reset (register {register:02X}h)", by(node)))
                    } else {
                        let info: Vec<String> = info.iter().map(|b| format!("{b:02X}")).collect();
                        Some(format!(
                            "EMCY from {}: error code {code:04X}h, register {register:02X}h, data {}",
                            by(node),
                            info.join(" ")
                        ))
                    }
                }
                _ => None,
            }
        }
        0x581..=0x5FF | 0x601..=0x67F => match data {
            [0x80, index_low, index_high, sub, a, b, c, d] => {
                let code = u32::from_le_bytes([*a, *b, *c, *d]);
                let index = u16::from_le_bytes([*index_low, *index_high]);
                let (sender, node) =
                    if id >= 0x601 { ("client of", id - 0x600) } else { ("server", id - 0x580) };
                Some(format!(
                    "SDO abort {code:08X}h ({:?}) of {index:04X}h sub {sub}, sent by the {sender} node {node}",
                    AbortCode::from_code(code)
                ))
            }
            _ => None,
        },
        _ => None,
    }
}

/// The `-vv` line of an NMT command on the bus.
fn describe_nmt(frame: &CanFrame) -> Option<String> {
    if frame.standard_id()? != 0 {
        return None;
    }
    let [command, node] = frame.data() else { return None };
    let what = match command {
        0x01 => "start",
        0x02 => "stop",
        0x80 => "enter pre-operational",
        0x81 => "reset node",
        0x82 => "reset communication",
        _ => "unknown command",
    };
    let whom = if *node == 0 { "all nodes".to_string() } else { format!("node {node}") };
    Some(format!("NMT command {command:02X}h ({what}) for {whom}"))
}

/// The state of one `-v`/`-vv` session: what was last reported.
pub struct Monitor {
    level: u8,
    nmt: Option<NmtState>,
    fsa: Option<State>,
    mode: Option<i8>,
}

impl Monitor {
    /// A monitor at verbosity `level` (0: silent, 1: `-v`, 2: `-vv`).
    pub fn new(level: u8) -> Monitor {
        Monitor { level, nmt: None, fsa: None, mode: None }
    }

    /// True when it prints anything at all.
    pub fn active(&self) -> bool {
        self.level > 0
    }

    /// The lines a frame on the bus gives.
    pub fn frame(&self, direction: Direction, frame: &CanFrame) -> Vec<String> {
        let mut lines = Vec::new();
        if self.level >= 2 {
            let arrow = match direction {
                Direction::Rx => "rx",
                Direction::Tx => "tx",
            };
            lines.push(format!("{arrow} {}", candump_text(frame)));
            lines.extend(describe_nmt(frame));
        }
        if self.level >= 1 {
            lines.extend(describe(direction, frame));
        }
        lines
    }

    /// The lines of the drive's state, reported when it changed since the last call.
    pub fn states(&mut self, nmt: NmtState, fsa: State, mode: i8) -> Vec<String> {
        let mut lines = Vec::new();
        if self.level == 0 {
            return lines;
        }
        if self.nmt != Some(nmt) {
            lines.push(match self.nmt {
                Some(before) => format!("NMT {before:?} -> {nmt:?}"),
                None => format!("NMT {nmt:?}"),
            });
            self.nmt = Some(nmt);
        }
        if self.fsa != Some(fsa) {
            lines.push(match self.fsa {
                Some(before) => format!("CiA 402 {before:?} -> {fsa:?}"),
                None => format!("CiA 402 {fsa:?}"),
            });
            self.fsa = Some(fsa);
        }
        if self.mode != Some(mode) {
            lines.push(format!("mode of operation (6061h) {mode}"));
            self.mode = Some(mode);
        }
        lines
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new_standard(id, data).unwrap()
    }

    #[test]
    fn candump_notation() {
        assert_eq!(candump_text(&frame(0x605, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0])), "605#4000100000000000");
        assert_eq!(candump_text(&frame(0x080, &[])), "080#");
        assert_eq!(candump_text(&CanFrame::new_remote_standard(0x705, 1).unwrap()), "705#R1");
        let extended = canopen_drive::frame::extended(0x1234_5678, &[0xAB]).unwrap();
        assert_eq!(candump_text(&extended), "12345678#AB");
    }

    #[test]
    fn emcy_and_aborts_are_described() {
        let emcy = frame(0x085, &[0x10, 0x23, 0x03, 0, 0, 0, 0, 0]);
        assert_eq!(
            describe(Direction::Tx, &emcy).unwrap(),
            "EMCY from node 5 (this drive): error code 2310h, register 03h, data 00 00 00 00 00"
        );
        let reset = frame(0x091, &[0, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(describe(Direction::Rx, &reset).unwrap(), "EMCY from node 17: error reset (register 00h)");
        let abort = frame(0x585, &[0x80, 0x00, 0x20, 0x01, 0x00, 0x00, 0x02, 0x06]);
        assert_eq!(
            describe(Direction::Tx, &abort).unwrap(),
            "SDO abort 06020000h (ObjectDoesNotExist) of 2000h sub 1, sent by the server node 5"
        );
        let client_abort = frame(0x605, &[0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]);
        assert!(describe(Direction::Rx, &client_abort).unwrap().contains("sent by the client of node 5"));
        // Not events: an SDO answer, a heartbeat, a SYNC, a short EMCY-range frame (a TPDO of
        // another layout would be 18xh, not here).
        for quiet in [
            frame(0x585, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]),
            frame(0x705, &[0x05]),
            frame(0x080, &[]),
            frame(0x085, &[0x10, 0x23]),
        ] {
            assert_eq!(describe(Direction::Tx, &quiet), None, "{quiet:?}");
        }
    }

    #[test]
    fn levels_and_state_changes() {
        let nmt_start = frame(0x000, &[0x01, 0x05]);
        assert!(Monitor::new(1).frame(Direction::Rx, &nmt_start).is_empty());
        assert_eq!(
            Monitor::new(2).frame(Direction::Rx, &nmt_start),
            ["rx 000#0105", "NMT command 01h (start) for node 5"]
        );
        assert!(Monitor::new(0)
            .frame(Direction::Tx, &frame(0x085, &[0x10, 0x23, 0x03, 0, 0, 0, 0, 0]))
            .is_empty());

        let mut monitor = Monitor::new(1);
        let first = monitor.states(NmtState::PreOperational, State::SwitchOnDisabled, 0);
        assert_eq!(first, ["NMT PreOperational", "CiA 402 SwitchOnDisabled", "mode of operation (6061h) 0"]);
        assert!(monitor.states(NmtState::PreOperational, State::SwitchOnDisabled, 0).is_empty());
        assert_eq!(
            monitor.states(NmtState::Operational, State::ReadyToSwitchOn, 1),
            [
                "NMT PreOperational -> Operational",
                "CiA 402 SwitchOnDisabled -> ReadyToSwitchOn",
                "mode of operation (6061h) 1"
            ]
        );
        assert!(Monitor::new(0).states(NmtState::Operational, State::Fault, 1).is_empty());
    }
}

//! The bus trace: every frame the [`VirtualBus`](crate::VirtualBus) carried, with its time,
//! sender and fate, rendered like `candump -ta` so a failing test prints a readable log.
//!
//! ```text
//! (000.000000)  vcan0  705   [1]  00                       ; node5
//! (000.001000)  vcan0  605   [8]  40 00 10 00 00 00 00 00  ; master
//! (000.001000)  vcan0  585   [8]  43 00 10 00 92 01 02 00  ; node5
//! (000.002000)  vcan0  585   [8]  01 63 61 6E 6F 70 65 6E  ; node5 (dropped)
//! (000.003000)  vcan0  70A   [1]  R                        ; master
//! ```
//!
//! Columns: time in seconds since the epoch of the virtual clock, interface name, identifier
//! (3 hex digits standard, 8 extended), `[dlc]`, data bytes in hex (`R` for a remote frame),
//! then after `;` the sender and what fault injection did to the frame, if anything. A frame
//! is recorded when it reaches the wire: a delayed frame at its late time; a dropped frame at
//! the time it was sent.

use std::fmt::{self, Write};

use canopen_drive::{CanFrame, Duration, Instant};
use embedded_can::{Frame, Id};

use crate::bus::Port;

/// What happened to a frame on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fate {
    /// Delivered to every other node and the master port.
    Delivered,
    /// Lost by a fault rule: nobody received it.
    Dropped,
    /// Delivered late by a fault rule, by this much.
    Delayed(Duration),
    /// The extra copy a duplicating fault rule put on the bus.
    Duplicate,
}

/// One frame of the bus trace.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TraceRecord {
    /// When the frame was on the wire (or, if dropped, when it was sent).
    pub time: Instant,
    /// Where it came from.
    pub from: Port,
    /// The sender's name (`"master"` for the master port).
    pub sender: String,
    /// The frame.
    pub frame: CanFrame,
    /// What fault injection did to it.
    pub fate: Fate,
}

impl TraceRecord {
    /// The record as one candump-style line (no newline) on interface `interface`.
    pub fn to_line(&self, interface: &str) -> String {
        let micros = self.time.as_micros();
        let mut line = format!("({:03}.{:06})  {interface}  ", micros / 1_000_000, micros % 1_000_000);
        let data = if self.frame.is_remote_frame() { "R".to_string() } else { hex_bytes(self.frame.data()) };
        let id = match self.frame.id() {
            Id::Standard(id) => format!("{:03X}", id.as_raw()),
            Id::Extended(id) => format!("{:08X}", id.as_raw()),
        };
        // Writing into a String cannot fail.
        let _ = write!(line, "{id}   [{}]  {data:<23}  ; {}", self.frame.dlc(), self.sender);
        match self.fate {
            Fate::Delivered => {}
            Fate::Dropped => line.push_str(" (dropped)"),
            Fate::Delayed(by) => {
                let _ = write!(line, " (delayed {} us)", by.as_micros());
            }
            Fate::Duplicate => line.push_str(" (duplicate)"),
        }
        line
    }
}

impl fmt::Display for TraceRecord {
    /// The record as a line on `vcan0`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_line("vcan0"))
    }
}

/// Renders records as candump-style lines, one per record, each ending in a newline.
pub fn render<'a>(records: impl IntoIterator<Item = &'a TraceRecord>, interface: &str) -> String {
    let mut out = String::new();
    for record in records {
        out.push_str(&record.to_line(interface));
        out.push('\n');
    }
    out
}

/// Bytes as upper-case hex pairs separated by spaces (`"40 00 10"`).
pub fn hex_bytes(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len() * 3);
    for (i, byte) in bytes.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{byte:02X}");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::NodeHandle;

    fn record(time_us: u64, frame: CanFrame, fate: Fate) -> TraceRecord {
        TraceRecord {
            time: Instant::from_micros(time_us),
            from: Port::Master,
            sender: "master".into(),
            frame,
            fate,
        }
    }

    #[test]
    fn data_frame_line() {
        let f = CanFrame::new_standard(0x605, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(
            record(1000, f, Fate::Delivered).to_string(),
            "(000.001000)  vcan0  605   [8]  40 00 10 00 00 00 00 00  ; master"
        );
    }

    #[test]
    fn short_remote_and_extended_frames() {
        let boot = CanFrame::new_standard(0x705, &[0x00]).unwrap();
        let mut r = record(12_345_678, boot, Fate::Delivered);
        r.from = Port::Node(NodeHandle::from_index(0));
        r.sender = "node5".into();
        assert_eq!(r.to_line("can1"), "(012.345678)  can1  705   [1]  00                       ; node5");
        let remote = CanFrame::new_remote_standard(0x70A, 1).unwrap();
        assert_eq!(
            record(0, remote, Fate::Delivered).to_string(),
            "(000.000000)  vcan0  70A   [1]  R                        ; master"
        );
        let ext = canopen_drive::frame::extended(0x1234_5678, &[1, 2]).unwrap();
        assert_eq!(
            record(0, ext, Fate::Delivered).to_string(),
            "(000.000000)  vcan0  12345678   [2]  01 02                    ; master"
        );
    }

    #[test]
    fn fates_are_annotated() {
        let f = CanFrame::new_standard(0x80, &[]).unwrap();
        assert!(record(0, f, Fate::Dropped).to_string().ends_with("; master (dropped)"));
        assert!(record(0, f, Fate::Duplicate).to_string().ends_with("(duplicate)"));
        let late = record(0, f, Fate::Delayed(Duration::from_millis(2))).to_string();
        assert!(late.ends_with("(delayed 2000 us)"), "{late}");
        let text = render([&record(0, f, Fate::Delivered), &record(5, f, Fate::Delivered)], "vcan0");
        assert_eq!(text.lines().count(), 2);
        assert!(text.ends_with('\n'));
        assert_eq!(hex_bytes(&[0xAB, 0x01]), "AB 01");
        assert_eq!(hex_bytes(&[]), "");
    }
}

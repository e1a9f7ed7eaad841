//! SLCAN (Lawicel ASCII) as the firmware speaks it over UART0: one command per line, lines end
//! with `\r`. Enough for python-can's `slcan` interface and USB-CAN adapters' host tools.
//!
//! | line (host → device) | meaning | reply |
//! |---|---|---|
//! | empty, `O`, `L`, `C`, `S0`–`S8` | no-op, open, listen-only, close, bit rate | `\r` |
//! | `V` / `N` | version / serial number | `V1013\r` / `N0001\r` |
//! | `tIIIL<data>` / `rIIIL` | 11-bit data / remote frame | `z\r` |
//! | `TIIIIIIIIL<data>` / `RIIIIIIIIL` | 29-bit data / remote frame | `Z\r` |
//! | anything else | – | BEL (0x07) |
//!
//! Frames to the host: `tIIIL<DATA>\r` (and `T`, `r`, `R`), upper-case hex, no time stamp.

use canopen_drive::CanFrame;
use embedded_can::{ExtendedId, Frame, Id, StandardId};

/// Longest line accepted (an extended frame with 8 data bytes has 26 characters).
pub const MAX_LINE: usize = 32;
/// Longest line [`encode`] writes, with its `\r`.
pub const MAX_ENCODED: usize = 27;
/// The refusal of a line.
pub const BEL: u8 = 0x07;

/// One line from the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// A frame to put on the bus.
    Frame(CanFrame),
    /// A command that needs only its reply.
    Control(&'static [u8]),
}

impl Command {
    /// The reply to the host.
    pub fn reply(&self) -> &'static [u8] {
        match self {
            Command::Frame(f) if f.is_extended() => b"Z\r",
            Command::Frame(_) => b"z\r",
            Command::Control(reply) => reply,
        }
    }
}

/// Parses one line without its `\r`; `None`: refused (answer [`BEL`]).
pub fn parse(line: &[u8]) -> Option<Command> {
    let Some((&first, rest)) = line.split_first() else {
        return Some(Command::Control(b"\r"));
    };
    match (first, rest) {
        (b'O' | b'L' | b'C', []) => Some(Command::Control(b"\r")),
        (b'S', [b'0'..=b'8']) => Some(Command::Control(b"\r")),
        (b'V', []) => Some(Command::Control(b"V1013\r")),
        (b'N', []) => Some(Command::Control(b"N0001\r")),
        (b't' | b'T' | b'r' | b'R', _) => parse_frame(first, rest).map(Command::Frame),
        _ => None,
    }
}

fn parse_frame(kind: u8, rest: &[u8]) -> Option<CanFrame> {
    let extended = kind.is_ascii_uppercase();
    let remote = matches!(kind, b'r' | b'R');
    let id_len = if extended { 8 } else { 3 };
    let raw_id = hex(rest.get(..id_len)?)?;
    let id: Id = if extended {
        ExtendedId::new(raw_id).map(Id::Extended)?
    } else {
        StandardId::new(u16::try_from(raw_id).ok()?).map(Id::Standard)?
    };
    let dlc = match rest.get(id_len) {
        Some(d @ b'0'..=b'8') => usize::from(d - b'0'),
        _ => return None,
    };
    let digits = rest.get(id_len + 1..)?;
    if remote {
        return if digits.is_empty() { CanFrame::new_remote(id, dlc) } else { None };
    }
    if digits.len() != 2 * dlc {
        return None;
    }
    let mut data = [0u8; 8];
    for (byte, pair) in data.iter_mut().zip(digits.chunks_exact(2)) {
        *byte = hex(pair).and_then(|v| u8::try_from(v).ok())?;
    }
    CanFrame::new(id, data.get(..dlc)?)
}

fn hex(digits: &[u8]) -> Option<u32> {
    digits.iter().try_fold(0u32, |acc, &d| {
        let v = match d {
            b'0'..=b'9' => d - b'0',
            b'a'..=b'f' => d - b'a' + 10,
            b'A'..=b'F' => d - b'A' + 10,
            _ => return None,
        };
        Some((acc << 4) | u32::from(v))
    })
}

/// Writes `frame` as an SLCAN line (with its `\r`) into `out`; returns the length.
pub fn encode(frame: &CanFrame, out: &mut [u8; MAX_ENCODED]) -> usize {
    let hex = |nibble: u32| b"0123456789ABCDEF".get((nibble & 0xF) as usize).copied().unwrap_or(b'0');
    let mut n = 0;
    let mut push = |b: u8, out: &mut [u8; MAX_ENCODED]| {
        if let Some(slot) = out.get_mut(n) {
            *slot = b;
            n += 1;
        }
    };
    let (kind, raw, digits) = match frame.id() {
        Id::Standard(id) => (if frame.is_remote_frame() { b'r' } else { b't' }, u32::from(id.as_raw()), 3),
        Id::Extended(id) => (if frame.is_remote_frame() { b'R' } else { b'T' }, id.as_raw(), 8),
    };
    push(kind, out);
    for shift in (0..digits).rev() {
        push(hex(raw >> (4 * shift)), out);
    }
    push(b'0' + frame.dlc() as u8, out);
    if !frame.is_remote_frame() {
        for &b in frame.data() {
            push(hex(u32::from(b >> 4)), out);
            push(hex(u32::from(b)), out);
        }
    }
    push(b'\r', out);
    n
}

/// Collects bytes into lines.
#[derive(Debug, Default)]
pub struct LineBuffer {
    line: heapless::Vec<u8, MAX_LINE>,
    overflow: bool,
}

impl LineBuffer {
    /// An empty buffer (for a `static`).
    pub const fn new() -> Self {
        LineBuffer { line: heapless::Vec::new(), overflow: false }
    }

    /// Takes one byte. `None`: the line goes on; `Some(parsed)`: a line ended, with its
    /// command or `None` when it is refused (answer [`BEL`]). A `\n` at the start of a line
    /// is skipped (`\r\n` line ends).
    pub fn push(&mut self, byte: u8) -> Option<Option<Command>> {
        match byte {
            b'\r' => {
                let parsed = if self.overflow { None } else { parse(&self.line) };
                self.line.clear();
                self.overflow = false;
                Some(parsed)
            }
            b'\n' if self.line.is_empty() => None,
            _ => {
                if self.line.push(byte).is_err() {
                    self.overflow = true;
                }
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn lines(input: &[u8]) -> Vec<Option<Command>> {
        let mut buffer = LineBuffer::default();
        input.iter().filter_map(|&b| buffer.push(b)).collect()
    }

    #[test]
    fn python_can_opening_sequence_is_acknowledged() {
        let replies: Vec<_> =
            lines(b"C\rS6\r\rO\rV\rN\r").into_iter().map(|c| c.map(|c| c.reply())).collect();
        let expected: [&[u8]; 6] = [b"\r", b"\r", b"\r", b"\r", b"V1013\r", b"N0001\r"];
        assert_eq!(replies, expected.map(Some));
    }

    #[test]
    fn frames_round_trip() {
        for line in
            [&b"t60584000100000000000"[..], b"t705100", b"r7050", b"T1234567820102", b"R1FFFFFFF8", b"t0000"]
        {
            let line: Vec<u8> = line.to_vec();
            let Some(Command::Frame(frame)) = parse(&line) else { panic!("{:?} refused", line) };
            let mut out = [0; MAX_ENCODED];
            let n = encode(&frame, &mut out);
            assert_eq!(&out[..n - 1], &line[..], "{frame:?}");
            assert_eq!(out[n - 1], b'\r');
        }
    }

    #[test]
    fn bad_lines_are_refused() {
        for line in [
            &b"t80000"[..],
            b"t7059",
            b"t70510",
            b"t7051000",
            b"tXYZ0",
            b"S9",
            b"O1",
            b"x",
            b"T2000000000",
            b"r7051AA",
        ] {
            assert_eq!(parse(line), None, "{:?}", core::str::from_utf8(line));
        }
        // Too long, then fine again.
        let mut input = Vec::from([b't'; 40]);
        input.extend_from_slice(b"\rO\r");
        assert_eq!(lines(&input), [None, Some(Command::Control(b"\r"))]);
    }

    #[test]
    fn crlf_line_ends_work() {
        assert_eq!(lines(b"O\r\nt7050\r\n").len(), 2);
    }
}

//! # canopen-drive-slcan
//!
//! The SLCAN (Lawicel ASCII) line codec: CAN frames as text lines over a serial port or a TCP
//! stream, the protocol of USB-CAN adapters and of python-can's `slcan` interface. `no_std`,
//! no allocation, generic over any [`embedded_can::Frame`]. Both boards of canopen-drive that
//! have no CAN controller speak it: the Linux program over TCP and the QEMU firmware over its
//! UART.
//!
//! ## Lines understood (host → device)
//!
//! Every line ends with `\r`.
//!
//! | line                    | meaning                                    | reply       |
//! |-------------------------|--------------------------------------------|-------------|
//! | (empty)                 | no-op, used to flush a half-sent command   | `\r`        |
//! | `O`, `L`, `C`           | open, open listen-only, close              | `\r`        |
//! | `S0` … `S8`             | select one of the standard bit rates       | `\r`        |
//! | `V`                     | hardware/software version                  | `V1013\r`   |
//! | `N`                     | serial number                              | `N0001\r`   |
//! | `tIIIL<data>`           | 11-bit data frame, DLC `L`, 2·L hex digits | `z\r`       |
//! | `TIIIIIIIIL<data>`      | 29-bit data frame                          | `Z\r`       |
//! | `rIIIL`                 | 11-bit remote frame                        | `z\r`       |
//! | `RIIIIIIIIL`            | 29-bit remote frame                        | `Z\r`       |
//!
//! Hex digits are accepted in either case. Anything else — an unknown command, an argument
//! where none belongs, a bad hex digit, an identifier out of range, a DLC above 8, too few or
//! too many data digits, a line longer than [`MAX_LINE`] — is a [`ParseError`], to be answered
//! with [`BEL`] and otherwise ignored. A `\n` at the start of a line is skipped, so `\r\n` line
//! ends (a terminal, `nc`) work too.
//!
//! ## Frames out (device → host)
//!
//! `tIIIL<DATA>\r`, `TIIIIIIIIL<DATA>\r`, `rIIIL\r`, `RIIIIIIIIL\r`, hex in upper case, no
//! time stamp (the Lawicel `Z` time-stamp option is not supported): [`encode`].
//!
//! ## Example
//!
//! ```
//! use canopen_drive_slcan::{encode, Command, LineDecoder, BEL};
//! # mod test_frame { include!(concat!(env!("CARGO_MANIFEST_DIR"), "/src/test_frame.rs")); }
//! # use test_frame::TestFrame;
//! use embedded_can::{Frame, Id, StandardId};
//!
//! // `TestFrame` stands for the firmware's CAN frame type: any `embedded_can::Frame`.
//! let mut decoder = LineDecoder::<TestFrame>::new();
//! let mut replies = Vec::new();
//! let mut frames = Vec::new();
//! for &byte in b"O\rt60584000100000000000\rbogus\r" {
//!     match decoder.push(byte) {
//!         None => {}
//!         Some(Ok(command)) => {
//!             replies.extend_from_slice(command.reply());
//!             if let Command::Frame(frame) = command {
//!                 frames.push(frame);
//!             }
//!         }
//!         Some(Err(_)) => replies.push(BEL),
//!     }
//! }
//! assert_eq!(replies, b"\rz\r\x07");
//! assert_eq!(frames[0].id(), Id::Standard(StandardId::new(0x605).unwrap()));
//!
//! let answer = TestFrame::new(StandardId::new(0x585).unwrap(), &[0x60, 0x00, 0x10]).unwrap();
//! assert_eq!(encode(&answer).as_bytes(), b"t5853600010\r");
//! ```
#![no_std]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]

use core::fmt;
use core::marker::PhantomData;

use embedded_can::{ExtendedId, Frame, Id, StandardId};

/// The byte that refuses a line.
pub const BEL: u8 = 0x07;
/// The byte that ends every line.
pub const CR: u8 = b'\r';
/// Longest line accepted (the longest valid one, an extended frame with 8 bytes, has 26).
pub const MAX_LINE: usize = 32;
/// Longest line [`encode`] writes, with its `\r`.
pub const MAX_ENCODED: usize = 27;

/// A parsed line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command<F> {
    /// An empty line.
    Empty,
    /// `O`: open the channel.
    Open,
    /// `L`: open the channel listen-only.
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `Sn`: standard bit rate `n` (0 = 10 kbit/s … 8 = 1 Mbit/s).
    Bitrate(u8),
    /// `V`: version query.
    Version,
    /// `N`: serial number query.
    SerialNumber,
    /// `t`, `T`, `r` or `R`: a frame to put on the bus.
    Frame(F),
}

impl<F: Frame> Command<F> {
    /// The bytes the device answers this command with.
    pub fn reply(&self) -> &'static [u8] {
        match self {
            Command::Empty | Command::Open | Command::ListenOnly | Command::Close | Command::Bitrate(_) => {
                b"\r"
            }
            Command::Version => b"V1013\r",
            Command::SerialNumber => b"N0001\r",
            Command::Frame(frame) if frame.is_extended() => b"Z\r",
            Command::Frame(_) => b"z\r",
        }
    }
}

/// Why a line was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParseError {
    /// The first byte is no command this device knows.
    UnknownCommand(u8),
    /// A command that takes no argument was given one (e.g. `O1`).
    UnexpectedArgument,
    /// `S` without a digit 0–8 after it.
    InvalidBitrate,
    /// The line ends before the identifier and DLC are complete.
    Truncated,
    /// A character that is not a hex digit where one is needed.
    InvalidHex,
    /// An 11-bit identifier above 0x7FF or a 29-bit one above 0x1FFF_FFFF.
    IdOutOfRange,
    /// A DLC that is not a digit 0–8.
    InvalidDlc,
    /// The number of data digits is not twice the DLC (or a remote frame carries data).
    DataLengthMismatch,
    /// The line is longer than [`MAX_LINE`].
    LineTooLong,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParseError::UnknownCommand(byte) => write!(f, "unknown command 0x{byte:02X}"),
            ParseError::UnexpectedArgument => f.write_str("command takes no argument"),
            ParseError::InvalidBitrate => f.write_str("bit rate is not S0..S8"),
            ParseError::Truncated => f.write_str("frame line ends early"),
            ParseError::InvalidHex => f.write_str("not a hex digit"),
            ParseError::IdOutOfRange => f.write_str("identifier out of range"),
            ParseError::InvalidDlc => f.write_str("DLC is not 0..8"),
            ParseError::DataLengthMismatch => f.write_str("data digits do not match the DLC"),
            ParseError::LineTooLong => f.write_str("line too long"),
        }
    }
}

impl core::error::Error for ParseError {}

/// Parses one line, without its `\r`.
pub fn parse_line<F: Frame>(line: &[u8]) -> Result<Command<F>, ParseError> {
    let Some((&first, rest)) = line.split_first() else {
        return Ok(Command::Empty);
    };
    let bare = |command: Command<F>| {
        if rest.is_empty() {
            Ok(command)
        } else {
            Err(ParseError::UnexpectedArgument)
        }
    };
    match first {
        b'O' => bare(Command::Open),
        b'L' => bare(Command::ListenOnly),
        b'C' => bare(Command::Close),
        b'V' => bare(Command::Version),
        b'N' => bare(Command::SerialNumber),
        b'S' => match rest {
            [digit @ b'0'..=b'8'] => Ok(Command::Bitrate(digit - b'0')),
            _ => Err(ParseError::InvalidBitrate),
        },
        b't' | b'T' | b'r' | b'R' => parse_frame(first, rest).map(Command::Frame),
        other => Err(ParseError::UnknownCommand(other)),
    }
}

fn parse_frame<F: Frame>(kind: u8, rest: &[u8]) -> Result<F, ParseError> {
    let extended = kind.is_ascii_uppercase();
    let remote = kind == b'r' || kind == b'R';
    let id_digits = if extended { 8 } else { 3 };
    let id = hex_number(rest.get(..id_digits).ok_or(ParseError::Truncated)?)?;
    let dlc = match rest.get(id_digits) {
        Some(digit @ b'0'..=b'8') => usize::from(digit - b'0'),
        Some(_) => return Err(ParseError::InvalidDlc),
        None => return Err(ParseError::Truncated),
    };
    let data_text = rest.get(id_digits + 1..).unwrap_or(&[]);
    let id = if extended {
        Id::Extended(ExtendedId::new(id).ok_or(ParseError::IdOutOfRange)?)
    } else {
        let id = u16::try_from(id).map_err(|_| ParseError::IdOutOfRange)?;
        Id::Standard(StandardId::new(id).ok_or(ParseError::IdOutOfRange)?)
    };
    if remote {
        if !data_text.is_empty() {
            return Err(ParseError::DataLengthMismatch);
        }
        return F::new_remote(id, dlc).ok_or(ParseError::InvalidDlc);
    }
    if data_text.len() != 2 * dlc {
        return Err(ParseError::DataLengthMismatch);
    }
    let mut data = [0u8; 8];
    for (byte, pair) in data.iter_mut().zip(data_text.chunks_exact(2)) {
        // `pair` has two digits, so the value fits in a byte.
        *byte = hex_number(pair)? as u8;
    }
    F::new(id, data.get(..dlc).ok_or(ParseError::InvalidDlc)?).ok_or(ParseError::InvalidDlc)
}

/// The value of up to 8 hex digits.
fn hex_number(digits: &[u8]) -> Result<u32, ParseError> {
    digits.iter().try_fold(0u32, |value, &digit| {
        let nibble = char::from(digit).to_digit(16).ok_or(ParseError::InvalidHex)?;
        Ok((value << 4) | nibble)
    })
}

/// One frame as an SLCAN line, with its `\r`: what [`encode`] returns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Encoded {
    bytes: [u8; MAX_ENCODED],
    len: usize,
}

impl Encoded {
    /// The line's bytes, `\r` included.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&self.bytes)
    }

    /// Appends one byte; the longest line fits, so nothing is ever cut.
    fn push(&mut self, byte: u8) {
        if let Some(slot) = self.bytes.get_mut(self.len) {
            *slot = byte;
            self.len += 1;
        }
    }

    /// Appends the `digits` lowest hex digits of `value`, upper case.
    fn push_hex(&mut self, value: u32, digits: u32) {
        const HEX: &[u8; 16] = b"0123456789ABCDEF";
        for shift in (0..digits).rev() {
            let nibble = (value >> (4 * shift)) & 0xF;
            self.push(HEX.get(nibble as usize).copied().unwrap_or(b'0'));
        }
    }
}

/// The SLCAN line of `frame`: kind letter, identifier, DLC, data bytes (none for a remote
/// frame), `\r`.
pub fn encode<F: Frame>(frame: &F) -> Encoded {
    let remote = frame.is_remote_frame();
    let (kind, id, digits) = match (frame.id(), remote) {
        (Id::Standard(id), false) => (b't', u32::from(id.as_raw()), 3),
        (Id::Standard(id), true) => (b'r', u32::from(id.as_raw()), 3),
        (Id::Extended(id), false) => (b'T', id.as_raw(), 8),
        (Id::Extended(id), true) => (b'R', id.as_raw(), 8),
    };
    let mut line = Encoded { bytes: [0; MAX_ENCODED], len: 0 };
    line.push(kind);
    line.push_hex(id, digits);
    // A classic CAN frame has a DLC of at most 8, one decimal digit.
    line.push(b'0' + frame.dlc().min(8) as u8);
    if !remote {
        for &byte in frame.data() {
            line.push_hex(u32::from(byte), 2);
        }
    }
    line.push(CR);
    line
}

/// Splits a byte stream into lines and parses each. Holds one line ([`MAX_LINE`] bytes), so
/// it can live in a `static`.
#[derive(Debug)]
pub struct LineDecoder<F> {
    line: heapless::Vec<u8, MAX_LINE>,
    overflow: bool,
    frame: PhantomData<fn() -> F>,
}

impl<F> Default for LineDecoder<F> {
    fn default() -> Self {
        Self::new()
    }
}

impl<F> LineDecoder<F> {
    /// An empty decoder.
    pub const fn new() -> Self {
        LineDecoder { line: heapless::Vec::new(), overflow: false, frame: PhantomData }
    }
}

impl<F: Frame> LineDecoder<F> {
    /// Takes one received byte; returns the parsed line when `byte` ends one (a refused line
    /// is to be answered with [`BEL`]).
    pub fn push(&mut self, byte: u8) -> Option<Result<Command<F>, ParseError>> {
        match byte {
            CR => {
                let result =
                    if self.overflow { Err(ParseError::LineTooLong) } else { parse_line(&self.line) };
                self.line.clear();
                self.overflow = false;
                Some(result)
            }
            b'\n' if self.line.is_empty() && !self.overflow => None,
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
mod test_frame;

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::test_frame::TestFrame;
    use std::string::String;
    use std::vec::Vec;
    use std::{format, vec};

    fn standard(id: u16, data: &[u8]) -> TestFrame {
        TestFrame::new(StandardId::new(id).unwrap(), data).unwrap()
    }

    fn extended(id: u32, data: &[u8]) -> TestFrame {
        TestFrame::new(ExtendedId::new(id).unwrap(), data).unwrap()
    }

    fn standard_id(frame: &TestFrame) -> Option<u16> {
        match frame.id() {
            Id::Standard(id) => Some(id.as_raw()),
            Id::Extended(_) => None,
        }
    }

    fn parse(line: &[u8]) -> Result<Command<TestFrame>, ParseError> {
        parse_line(line)
    }

    fn frame(line: &str) -> TestFrame {
        match parse(line.as_bytes()) {
            Ok(Command::Frame(frame)) => frame,
            other => panic!("{line:?} parsed as {other:?}"),
        }
    }

    fn encoded(frame: &TestFrame) -> String {
        String::from_utf8(encode(frame).as_bytes().to_vec()).unwrap()
    }

    fn decode_all(bytes: &[u8]) -> Vec<Result<Command<TestFrame>, ParseError>> {
        let mut decoder = LineDecoder::new();
        bytes.iter().filter_map(|&b| decoder.push(b)).collect()
    }

    #[test]
    fn control_commands_and_replies() {
        let cases: [(&str, Command<TestFrame>, &[u8]); 7] = [
            ("", Command::Empty, b"\r"),
            ("O", Command::Open, b"\r"),
            ("L", Command::ListenOnly, b"\r"),
            ("C", Command::Close, b"\r"),
            ("V", Command::Version, b"V1013\r"),
            ("N", Command::SerialNumber, b"N0001\r"),
            ("S6", Command::Bitrate(6), b"\r"),
        ];
        for (line, command, reply) in cases {
            assert_eq!(parse(line.as_bytes()), Ok(command), "{line:?}");
            assert_eq!(command.reply(), reply, "{line:?}");
        }
        for n in 0..=8u8 {
            assert_eq!(parse(&[b'S', b'0' + n]), Ok(Command::Bitrate(n)));
        }
    }

    #[test]
    fn python_can_opening_sequence_is_acknowledged() {
        let replies: Vec<&[u8]> =
            decode_all(b"C\rS6\r\rO\rV\rN\r").iter().map(|line| line.unwrap().reply()).collect();
        let expected: [&[u8]; 6] = [b"\r", b"\r", b"\r", b"\r", b"V1013\r", b"N0001\r"];
        assert_eq!(replies, expected);
    }

    #[test]
    fn frames_parse() {
        let f = frame("t60584000100000000000");
        assert_eq!(standard_id(&f), Some(0x605));
        assert_eq!(f.data(), &[0x40, 0x00, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00]);
        assert_eq!(Command::Frame(f).reply(), b"z\r");

        let f = frame("t0000");
        assert_eq!(standard_id(&f), Some(0));
        assert!(f.data().is_empty());

        let f = frame("t7ff2abCD");
        assert_eq!(standard_id(&f), Some(0x7FF));
        assert_eq!(f.data(), &[0xAB, 0xCD]);

        let f = frame("T1FFFFFFF3010203");
        assert_eq!(f, extended(0x1FFF_FFFF, &[1, 2, 3]));
        assert_eq!(Command::Frame(f).reply(), b"Z\r");

        let f = frame("r7051");
        assert!(f.is_remote_frame());
        assert_eq!(f.dlc(), 1);
        assert_eq!(standard_id(&f), Some(0x705));
        assert_eq!(Command::Frame(f).reply(), b"z\r");

        let f = frame("R000001238");
        assert!(f.is_remote_frame() && f.is_extended());
        assert_eq!(f.dlc(), 8);
        assert_eq!(Command::Frame(f).reply(), b"Z\r");
    }

    #[test]
    fn frames_encode_in_upper_case() {
        let f = standard(0x585, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]);
        assert_eq!(encoded(&f), "t58584300100092010200\r");
        assert_eq!(encoded(&standard(0x705, &[0x7F])), "t70517F\r");
        assert_eq!(encoded(&standard(0x0, &[])), "t0000\r");
        let remote = TestFrame::new_remote(StandardId::new(0x70A).unwrap(), 1).unwrap();
        assert_eq!(encoded(&remote), "r70A1\r");
        assert_eq!(encoded(&extended(0xABCDE, &[0xFF])), "T000ABCDE1FF\r");
        let remote = TestFrame::new_remote(ExtendedId::new(0x1234_5678).unwrap(), 0).unwrap();
        assert_eq!(encoded(&remote), "R123456780\r");
        // The longest line fills the buffer exactly.
        let longest = extended(0x1FFF_FFFF, &[0xFF; 8]);
        assert_eq!(encode(&longest).as_bytes().len(), MAX_ENCODED);
    }

    #[test]
    fn round_trips() {
        let mut frames = vec![
            TestFrame::new_remote(StandardId::new(0x7FF).unwrap(), 8).unwrap(),
            TestFrame::new_remote(ExtendedId::new(0).unwrap(), 3).unwrap(),
        ];
        for len in 0..=8usize {
            let data: Vec<u8> = (0..len as u8).map(|i| i.wrapping_mul(37).wrapping_add(0xA5)).collect();
            frames.push(standard(0x123 + len as u16, &data));
            frames.push(extended(0x1ABC_DE00 + len as u32, &data));
        }
        for f in frames {
            let line = encoded(&f);
            assert!(line.ends_with('\r'));
            assert_eq!(parse(line.trim_end_matches('\r').as_bytes()), Ok(Command::Frame(f)), "{line:?}");
            // The lower-case spelling of the hex parses to the same frame.
            let lower: String = line
                .chars()
                .enumerate()
                .map(|(i, c)| if i == 0 { c } else { c.to_ascii_lowercase() })
                .collect();
            assert_eq!(parse(lower.trim_end_matches('\r').as_bytes()), Ok(Command::Frame(f)));
        }
    }

    #[test]
    fn every_malformed_case_is_refused() {
        use ParseError::*;
        let cases: [(&str, ParseError); 29] = [
            ("x", UnknownCommand(b'x')),
            ("F", UnknownCommand(b'F')),
            ("\u{7f}", UnknownCommand(0x7F)),
            ("o", UnknownCommand(b'o')),
            ("O1", UnexpectedArgument),
            ("L ", UnexpectedArgument),
            ("Cx", UnexpectedArgument),
            ("V2", UnexpectedArgument),
            ("NN", UnexpectedArgument),
            ("S", InvalidBitrate),
            ("S9", InvalidBitrate),
            ("S66", InvalidBitrate),
            ("Sa", InvalidBitrate),
            ("t", Truncated),
            ("t12", Truncated),
            ("t123", Truncated),
            ("T1234567", Truncated),
            ("t12g0", InvalidHex),
            ("t 120", InvalidHex),
            ("tXYZ0", InvalidHex),
            ("t8000", IdOutOfRange),
            ("TFFFFFFFF0", IdOutOfRange),
            ("T200000000", IdOutOfRange),
            ("t1239", InvalidDlc),
            ("t123x", InvalidDlc),
            ("t1232AA", DataLengthMismatch),
            ("t1231AABB", DataLengthMismatch),
            ("t70510", DataLengthMismatch),
            ("r1231AA", DataLengthMismatch),
        ];
        for (line, error) in cases {
            assert_eq!(parse(line.as_bytes()), Err(error), "{line:?}");
        }
        assert_eq!(parse(b"t1231Ag"), Err(InvalidHex));
        assert_eq!(parse(b"t1232AA\xFF\xFF"), Err(InvalidHex));
        assert_eq!(parse(b"R1234567"), Err(Truncated));
        assert_eq!(parse(b"R123456789"), Err(InvalidDlc));
        assert_eq!(parse(b"R12345678"), Err(Truncated));
    }

    #[test]
    fn decoder_splits_lines_and_recovers_after_garbage() {
        let results = decode_all(b"C\rS6\r\rO\rV\rN\rt1232AABB\rbogus\rt0000\r");
        assert_eq!(
            results,
            vec![
                Ok(Command::Close),
                Ok(Command::Bitrate(6)),
                Ok(Command::Empty),
                Ok(Command::Open),
                Ok(Command::Version),
                Ok(Command::SerialNumber),
                Ok(Command::Frame(standard(0x123, &[0xAA, 0xBB]))),
                Err(ParseError::UnknownCommand(b'b')),
                Ok(Command::Frame(standard(0, &[]))),
            ]
        );
    }

    #[test]
    fn decoder_accepts_crlf_and_partial_input() {
        let mut decoder = LineDecoder::<TestFrame>::new();
        assert_eq!(decoder.push(b'V'), None);
        assert_eq!(decoder.push(CR), Some(Ok(Command::Version)));
        assert_eq!(decoder.push(b'\n'), None);
        assert_eq!(decoder.push(b'O'), None);
        assert_eq!(decoder.push(CR), Some(Ok(Command::Open)));
        assert_eq!(decode_all(b"O\r\nt7050\r\n").len(), 2);
        // A line feed inside a line is an error, not a terminator.
        assert_eq!(decode_all(b"O\nX\r"), vec![Err(ParseError::UnexpectedArgument)]);
    }

    #[test]
    fn decoder_refuses_long_lines_once_and_goes_on() {
        let mut input = vec![b't'; 100];
        input.push(CR);
        input.extend_from_slice(b"O\r");
        assert_eq!(decode_all(&input), vec![Err(ParseError::LineTooLong), Ok(Command::Open)]);
        // The longest valid line fits.
        let longest = b"T1FFFFFFF80011223344556677\r";
        assert_eq!(longest.len() - 1, 26);
        assert!(matches!(decode_all(longest).as_slice(), [Ok(Command::Frame(_))]));
    }

    #[test]
    fn errors_display() {
        assert_eq!(format!("{}", ParseError::UnknownCommand(b'x')), "unknown command 0x78");
        assert_eq!(format!("{}", ParseError::LineTooLong), "line too long");
    }
}

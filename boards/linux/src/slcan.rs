//! SLCAN (Lawicel ASCII) codec: one command per line, lines end with `\r`.
//!
//! ## Lines understood (host → device)
//!
//! | line                    | meaning                                  | reply       |
//! |-------------------------|------------------------------------------|-------------|
//! | (empty)                 | no-op, used to flush a half-sent command | `\r`        |
//! | `O`, `L`, `C`           | open, open listen-only, close            | `\r`        |
//! | `S0` … `S8`             | select one of the standard bit rates     | `\r`        |
//! | `V`                     | hardware/software version                | `V1013\r`   |
//! | `N`                     | serial number                            | `N0001\r`   |
//! | `tIIIL<data>`           | 11-bit data frame, DLC `L`, 2·L hex digits | `z\r`     |
//! | `TIIIIIIIIL<data>`      | 29-bit data frame                        | `Z\r`       |
//! | `rIIIL`                 | 11-bit remote frame                      | `z\r`       |
//! | `RIIIIIIIIL`            | 29-bit remote frame                      | `Z\r`       |
//!
//! Hex digits are accepted in either case. Anything else — an unknown command, an argument
//! where none belongs, a bad hex digit, an identifier out of range, a DLC above 8, too few or
//! too many data digits, a line longer than [`MAX_LINE`] — is a [`ParseError`], answered with
//! BEL (0x07) and otherwise ignored. A `\n` at the start of a line is skipped, so `\r\n`
//! line ends (a terminal, `nc`) work too.
//!
//! ## Frames out (device → host)
//!
//! `tIIIL<DATA>\r`, `TIIIIIIIIL<DATA>\r`, `rIIIL\r`, `RIIIIIIIIL\r`, hex in upper case, no
//! time stamp (the Lawicel `Z` time-stamp option is not supported).

use core::fmt;

use canopen_drive::CanFrame;
use embedded_can::{ExtendedId, Frame, Id};

/// The byte that refuses a line.
pub const BEL: u8 = 0x07;
/// The byte that ends every line.
pub const CR: u8 = b'\r';
/// Longest line accepted (the longest valid one, an extended frame with 8 bytes, has 26).
pub const MAX_LINE: usize = 32;

/// A parsed line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
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
    Frame(CanFrame),
}

impl Command {
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

/// Parses one line, without its `\r`.
pub fn parse_line(line: &[u8]) -> Result<Command, ParseError> {
    let Some((&first, rest)) = line.split_first() else {
        return Ok(Command::Empty);
    };
    let bare = |command: Command| {
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

fn parse_frame(kind: u8, rest: &[u8]) -> Result<CanFrame, ParseError> {
    let extended = kind.is_ascii_uppercase();
    let remote = kind == b'r' || kind == b'R';
    let id_digits = if extended { 8 } else { 3 };
    let id_text = rest.get(..id_digits).ok_or(ParseError::Truncated)?;
    let id = hex_number(id_text)?;
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
        Id::Standard(embedded_can::StandardId::new(id).ok_or(ParseError::IdOutOfRange)?)
    };
    if remote {
        if !data_text.is_empty() {
            return Err(ParseError::DataLengthMismatch);
        }
        return CanFrame::new_remote(id, dlc).ok_or(ParseError::InvalidDlc);
    }
    if data_text.len() != 2 * dlc {
        return Err(ParseError::DataLengthMismatch);
    }
    let mut data = [0u8; 8];
    for (byte, pair) in data.iter_mut().zip(data_text.chunks_exact(2)) {
        // `pair` has two digits, so the value fits in a byte.
        *byte = hex_number(pair)? as u8;
    }
    let data = data.get(..dlc).ok_or(ParseError::InvalidDlc)?;
    CanFrame::new(id, data).ok_or(ParseError::InvalidDlc)
}

/// The value of up to 8 hex digits.
fn hex_number(digits: &[u8]) -> Result<u32, ParseError> {
    digits.iter().try_fold(0u32, |value, &digit| {
        let nibble = char::from(digit).to_digit(16).ok_or(ParseError::InvalidHex)?;
        Ok((value << 4) | nibble)
    })
}

/// Appends the SLCAN line of `frame` (with its `\r`) to `out`.
pub fn encode_frame(frame: &CanFrame, out: &mut Vec<u8>) {
    let (kind, id, digits) = match (frame.id(), frame.is_remote_frame()) {
        (Id::Standard(id), false) => (b't', u32::from(id.as_raw()), 3),
        (Id::Standard(id), true) => (b'r', u32::from(id.as_raw()), 3),
        (Id::Extended(id), false) => (b'T', id.as_raw(), 8),
        (Id::Extended(id), true) => (b'R', id.as_raw(), 8),
    };
    out.push(kind);
    push_hex(out, id, digits);
    // A classic CAN frame has a DLC of at most 8, one decimal digit.
    out.push(b'0' + frame.dlc().min(8) as u8);
    for &byte in frame.data() {
        push_hex(out, u32::from(byte), 2);
    }
    out.push(CR);
}

/// Appends the `digits` lowest hex digits of `value`, upper case.
fn push_hex(out: &mut Vec<u8>, value: u32, digits: u32) {
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    for shift in (0..digits).rev() {
        let nibble = (value >> (4 * shift)) & 0xF;
        out.push(HEX.get(nibble as usize).copied().unwrap_or(b'0'));
    }
}

/// Splits a byte stream into lines and parses each.
#[derive(Debug, Default)]
pub struct LineDecoder {
    line: Vec<u8>,
    overflow: bool,
}

impl LineDecoder {
    /// An empty decoder.
    pub fn new() -> Self {
        LineDecoder { line: Vec::with_capacity(MAX_LINE), overflow: false }
    }

    /// Takes one received byte; returns the parsed line when `byte` ends one.
    pub fn push(&mut self, byte: u8) -> Option<Result<Command, ParseError>> {
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
                if self.line.len() < MAX_LINE {
                    self.line.push(byte);
                } else {
                    self.overflow = true;
                }
                None
            }
        }
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;
    use canopen_drive::frame::extended;

    fn frame(line: &str) -> CanFrame {
        match parse_line(line.as_bytes()) {
            Ok(Command::Frame(frame)) => frame,
            other => panic!("{line:?} parsed as {other:?}"),
        }
    }

    fn encoded(frame: &CanFrame) -> String {
        let mut out = Vec::new();
        encode_frame(frame, &mut out);
        String::from_utf8(out).unwrap()
    }

    fn decode_all(bytes: &[u8]) -> Vec<Result<Command, ParseError>> {
        let mut decoder = LineDecoder::new();
        bytes.iter().filter_map(|&b| decoder.push(b)).collect()
    }

    #[test]
    fn control_commands_and_replies() {
        let cases: [(&str, Command, &[u8]); 7] = [
            ("", Command::Empty, b"\r"),
            ("O", Command::Open, b"\r"),
            ("L", Command::ListenOnly, b"\r"),
            ("C", Command::Close, b"\r"),
            ("V", Command::Version, b"V1013\r"),
            ("N", Command::SerialNumber, b"N0001\r"),
            ("S6", Command::Bitrate(6), b"\r"),
        ];
        for (line, command, reply) in cases {
            assert_eq!(parse_line(line.as_bytes()), Ok(command), "{line:?}");
            assert_eq!(command.reply(), reply, "{line:?}");
        }
        for n in 0..=8u8 {
            assert_eq!(parse_line(&[b'S', b'0' + n]), Ok(Command::Bitrate(n)));
        }
    }

    #[test]
    fn frames_parse() {
        let f = frame("t60584000100000000000");
        assert_eq!(f.standard_id(), Some(0x605));
        assert_eq!(f.data(), &[0x40, 0x00, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00]);
        assert_eq!(Command::Frame(f).reply(), b"z\r");

        let f = frame("t0000");
        assert_eq!(f.standard_id(), Some(0));
        assert!(f.data().is_empty());

        let f = frame("t7ff2abCD");
        assert_eq!(f.standard_id(), Some(0x7FF));
        assert_eq!(f.data(), &[0xAB, 0xCD]);

        let f = frame("T1FFFFFFF3010203");
        assert_eq!(f, extended(0x1FFF_FFFF, &[1, 2, 3]).unwrap());
        assert_eq!(Command::Frame(f).reply(), b"Z\r");

        let f = frame("r7051");
        assert!(f.is_remote_frame());
        assert_eq!(f.dlc(), 1);
        assert_eq!(f.standard_id(), Some(0x705));
        assert_eq!(Command::Frame(f).reply(), b"z\r");

        let f = frame("R000001238");
        assert!(f.is_remote_frame() && f.is_extended());
        assert_eq!(f.dlc(), 8);
        assert_eq!(Command::Frame(f).reply(), b"Z\r");
    }

    #[test]
    fn frames_encode_in_upper_case() {
        let f = CanFrame::new_standard(0x585, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]).unwrap();
        assert_eq!(encoded(&f), "t58584300100092010200\r");
        assert_eq!(encoded(&CanFrame::new_standard(0x705, &[0x7F]).unwrap()), "t70517F\r");
        assert_eq!(encoded(&CanFrame::new_standard(0x0, &[]).unwrap()), "t0000\r");
        assert_eq!(encoded(&CanFrame::new_remote_standard(0x70A, 1).unwrap()), "r70A1\r");
        assert_eq!(encoded(&extended(0xABCDE, &[0xFF]).unwrap()), "T000ABCDE1FF\r");
        let remote = CanFrame::new_remote(Id::Extended(ExtendedId::new(0x1234_5678).unwrap()), 0).unwrap();
        assert_eq!(encoded(&remote), "R123456780\r");
    }

    #[test]
    fn round_trips() {
        let mut frames = vec![
            CanFrame::new_remote_standard(0x7FF, 8).unwrap(),
            CanFrame::new_remote(Id::Extended(ExtendedId::new(0).unwrap()), 3).unwrap(),
        ];
        for len in 0..=8usize {
            let data: Vec<u8> = (0..len as u8).map(|i| i.wrapping_mul(37).wrapping_add(0xA5)).collect();
            frames.push(CanFrame::new_standard(0x123 + len as u16, &data).unwrap());
            frames.push(extended(0x1ABC_DE00 + len as u32, &data).unwrap());
        }
        for f in frames {
            let line = encoded(&f);
            assert!(line.ends_with('\r'));
            assert_eq!(parse_line(line.trim_end_matches('\r').as_bytes()), Ok(Command::Frame(f)), "{line:?}");
            // The lower-case spelling of the hex parses to the same frame.
            let lower: String = line
                .chars()
                .enumerate()
                .map(|(i, c)| if i == 0 { c } else { c.to_ascii_lowercase() })
                .collect();
            assert_eq!(parse_line(lower.trim_end_matches('\r').as_bytes()), Ok(Command::Frame(f)));
        }
    }

    #[test]
    fn every_malformed_case_is_refused() {
        use ParseError::*;
        let cases: [(&str, ParseError); 27] = [
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
            ("t8000", IdOutOfRange),
            ("TFFFFFFFF0", IdOutOfRange),
            ("T200000000", IdOutOfRange),
            ("t1239", InvalidDlc),
            ("t123x", InvalidDlc),
            ("t1232AA", DataLengthMismatch),
            ("t1231AABB", DataLengthMismatch),
            ("r1231AA", DataLengthMismatch),
        ];
        for (line, error) in cases {
            assert_eq!(parse_line(line.as_bytes()), Err(error), "{line:?}");
        }
        assert_eq!(parse_line(b"t1231Ag"), Err(InvalidHex));
        assert_eq!(parse_line(b"t1232AA\xFF\xFF"), Err(InvalidHex));
        assert_eq!(parse_line(b"R1234567"), Err(Truncated));
        assert_eq!(parse_line(b"R123456789"), Err(InvalidDlc));
        assert_eq!(parse_line(b"R12345678"), Err(Truncated));
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
                Ok(Command::Frame(CanFrame::new_standard(0x123, &[0xAA, 0xBB]).unwrap())),
                Err(ParseError::UnknownCommand(b'b')),
                Ok(Command::Frame(CanFrame::new_standard(0, &[]).unwrap())),
            ]
        );
    }

    #[test]
    fn decoder_accepts_crlf_and_partial_input() {
        let mut decoder = LineDecoder::new();
        assert_eq!(decoder.push(b'V'), None);
        assert_eq!(decoder.push(CR), Some(Ok(Command::Version)));
        assert_eq!(decoder.push(b'\n'), None);
        assert_eq!(decoder.push(b'O'), None);
        assert_eq!(decoder.push(CR), Some(Ok(Command::Open)));
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
        assert_eq!(ParseError::UnknownCommand(b'x').to_string(), "unknown command 0x78");
        assert_eq!(ParseError::LineTooLong.to_string(), "line too long");
    }
}

//! SDO frames (CiA 301 §7.2.4.3).
//!
//! ```text
//! byte 0      command specifier: ccs/scs in bits 7..5, then t/n/e/s/c/cc/sc per service
//! bytes 1..2  index (LE)          ┐ initiate, abort and block
//! byte  3     sub-index           ┘ initiate/end frames
//! bytes 4..7  data, size, block size/pst or abort code (LE)
//! segments    byte 0 = command (or c|seqno in block sub-blocks), bytes 1..7 data
//! ```
//!
//! Requests are parsed from the bytes actually received: a request shorter than eight bytes is
//! accepted when the bytes its command needs are there (as CANopenNode and python-canopen do). Responses are
//! always eight bytes.

use super::AbortCode;

/// Object address of an SDO transfer: index and sub-index (the "multiplexer").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mux {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
}

impl Mux {
    fn parse(data: &[u8]) -> Option<Self> {
        match data {
            [_, lo, hi, sub, ..] => Some(Mux { index: u16::from_le_bytes([*lo, *hi]), sub: *sub }),
            _ => None,
        }
    }

    fn emit(self, out: &mut [u8; 8]) {
        let [lo, hi] = self.index.to_le_bytes();
        out[1] = lo;
        out[2] = hi;
        out[3] = self.sub;
    }
}

/// How an initiate-download request carries its data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Download {
    /// Expedited, with the number of valid bytes when indicated (s = 1).
    Expedited {
        /// Bytes 4..8 as received (zero-padded).
        data: [u8; 4],
        /// Valid bytes when the size is indicated; `None` when e = 1, s = 0.
        len: Option<u8>,
        /// Data bytes actually present in the frame.
        present: u8,
    },
    /// Segmented, with the total size when indicated.
    Segmented {
        /// Total size when s = 1.
        size: Option<u32>,
    },
}

/// A request from an SDO client, as far as the frame alone tells.
///
/// Block-download sub-block segments carry no command specifier; they are parsed with
/// [`BlockSegment::parse`] while a block download is in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u32)]
pub enum Request {
    /// ccs 1: initiate download.
    InitiateDownload {
        /// Addressed entry.
        mux: Mux,
        /// Data or size.
        kind: Download,
    },
    /// ccs 0: download segment.
    DownloadSegment {
        /// Toggle bit.
        toggle: bool,
        /// Data bytes (up to 7) and their count.
        data: [u8; 7],
        /// Number of data bytes.
        len: u8,
        /// c: last segment.
        last: bool,
    },
    /// ccs 2: initiate upload.
    InitiateUpload {
        /// Addressed entry.
        mux: Mux,
    },
    /// ccs 3: upload segment.
    UploadSegment {
        /// Toggle bit.
        toggle: bool,
    },
    /// ccs 4: abort transfer.
    Abort {
        /// Entry named by the client.
        mux: Mux,
        /// Reason, as received ([`AbortCode::from_code`] names it; the server only needs to
        /// know that the transfer ended, and a firmware is spared the decoding table).
        code: u32,
    },
    /// ccs 5, cs 0: initiate block upload.
    BlockUploadInitiate {
        /// Addressed entry.
        mux: Mux,
        /// cc: the client supports CRC.
        crc: bool,
        /// Segments per sub-block (valid 1..=127; checked by the server).
        block_size: u8,
        /// Protocol switch threshold (0 = no switch).
        pst: u8,
    },
    /// ccs 5, cs 3: start sending.
    BlockUploadStart,
    /// ccs 5, cs 2: sub-block acknowledged.
    BlockUploadAck {
        /// Last sequence number received in order.
        ack_seq: u8,
        /// Segments in the next sub-block.
        block_size: u8,
    },
    /// ccs 5, cs 1: end of block upload confirmed.
    BlockUploadEnd,
    /// ccs 6, cs 0: initiate block download.
    BlockDownloadInitiate {
        /// Addressed entry.
        mux: Mux,
        /// cc: the client supports CRC.
        crc: bool,
        /// Total size when s = 1.
        size: Option<u32>,
    },
    /// ccs 6, cs 1: end of block download.
    BlockDownloadEnd {
        /// Bytes of the last segment that carried no data.
        unused: u8,
        /// CRC of the whole data (if negotiated).
        crc: u16,
    },
    /// A command specifier that does not exist (ccs 7).
    Unknown {
        /// The command byte.
        command: u8,
        /// Bytes 1..4 read as a multiplexer (echoed in the abort), zero when missing.
        mux: Mux,
    },
}

fn u32_at(data: &[u8]) -> Option<u32> {
    match data.get(4..8) {
        Some([a, b, c, d]) => Some(u32::from_le_bytes([*a, *b, *c, *d])),
        _ => None,
    }
}

impl Request {
    /// Parses a request frame's data; `None` when bytes the command needs are missing.
    pub fn parse(data: &[u8]) -> Option<Self> {
        let command = *data.first()?;
        let ccs = command >> 5;
        Some(match ccs {
            0 => {
                let len = 7 - ((command >> 1) & 0x07);
                let mut bytes = [0u8; 7];
                let body = data.get(1..1 + usize::from(len))?;
                bytes.get_mut(..body.len())?.copy_from_slice(body);
                Request::DownloadSegment {
                    toggle: command & 0x10 != 0,
                    data: bytes,
                    len,
                    last: command & 0x01 != 0,
                }
            }
            1 => {
                let mux = Mux::parse(data)?;
                let expedited = command & 0x02 != 0;
                let sized = command & 0x01 != 0;
                let kind = if expedited {
                    let mut bytes = [0u8; 4];
                    let present = data.get(4..).unwrap_or(&[]);
                    let present = present.get(..present.len().min(4)).unwrap_or(&[]);
                    bytes.get_mut(..present.len())?.copy_from_slice(present);
                    let len = sized.then_some(4 - ((command >> 2) & 0x03));
                    Download::Expedited { data: bytes, len, present: present.len() as u8 }
                } else {
                    Download::Segmented { size: if sized { Some(u32_at(data)?) } else { None } }
                };
                Request::InitiateDownload { mux, kind }
            }
            2 => Request::InitiateUpload { mux: Mux::parse(data)? },
            3 => Request::UploadSegment { toggle: command & 0x10 != 0 },
            4 => Request::Abort { mux: Mux::parse(data)?, code: u32_at(data).unwrap_or(0) },
            5 => match command & 0x03 {
                0 => Request::BlockUploadInitiate {
                    mux: Mux::parse(data)?,
                    crc: command & 0x04 != 0,
                    block_size: *data.get(4)?,
                    pst: data.get(5).copied().unwrap_or(0),
                },
                1 => Request::BlockUploadEnd,
                2 => Request::BlockUploadAck { ack_seq: *data.get(1)?, block_size: *data.get(2)? },
                _ => Request::BlockUploadStart,
            },
            6 => match command & 0x01 {
                0 => Request::BlockDownloadInitiate {
                    mux: Mux::parse(data)?,
                    crc: command & 0x04 != 0,
                    size: if command & 0x02 != 0 { Some(u32_at(data)?) } else { None },
                },
                _ => Request::BlockDownloadEnd {
                    unused: (command >> 2) & 0x07,
                    crc: u16::from_le_bytes([
                        data.get(1).copied().unwrap_or(0),
                        data.get(2).copied().unwrap_or(0),
                    ]),
                },
            },
            _ => Request::Unknown { command, mux: Mux::parse(data).unwrap_or(Mux { index: 0, sub: 0 }) },
        })
    }
}

/// One segment of a block-download sub-block: `c sssssss` then seven data bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BlockSegment {
    /// Sequence number (1..=127 when valid).
    pub seq: u8,
    /// c: last segment of the whole transfer.
    pub last: bool,
    /// The seven data bytes (trailing ones unused on the last segment).
    pub data: [u8; 7],
}

impl BlockSegment {
    /// Parses a sub-block segment (missing bytes read as zero: the end frame says how many
    /// bytes of the last segment count).
    pub fn parse(data: &[u8]) -> Option<Self> {
        let head = *data.first()?;
        let body = data.get(1..).unwrap_or(&[]);
        let bytes = match body.first_chunk::<7>() {
            // A whole segment: a fixed-size copy (no memcpy call).
            Some(whole) => *whole,
            None => {
                let mut bytes = [0u8; 7];
                bytes.get_mut(..body.len())?.copy_from_slice(body);
                bytes
            }
        };
        Some(BlockSegment { seq: head & 0x7F, last: head & 0x80 != 0, data: bytes })
    }

    /// The frame data of the segment.
    pub fn emit(&self) -> [u8; 8] {
        let mut out = [0u8; 8];
        out[0] = self.seq | if self.last { 0x80 } else { 0 };
        out[1..].copy_from_slice(&self.data);
        out
    }
}

/// A response of the SDO server.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u32)]
pub enum Response {
    /// scs 3: initiate download response.
    DownloadInitiated {
        /// Entry.
        mux: Mux,
    },
    /// scs 1: download segment response.
    DownloadSegmentAck {
        /// Toggle bit echoed.
        toggle: bool,
    },
    /// scs 2 with e = 1, s = 1: expedited upload.
    UploadExpedited {
        /// Entry.
        mux: Mux,
        /// Data (1..=4 valid bytes).
        data: [u8; 4],
        /// Valid bytes.
        len: u8,
    },
    /// scs 2 with e = 0, s = 1: segmented upload follows.
    UploadSegmented {
        /// Entry.
        mux: Mux,
        /// Total size.
        size: u32,
    },
    /// scs 0: upload segment.
    UploadSegment {
        /// Toggle bit echoed.
        toggle: bool,
        /// Data bytes.
        data: [u8; 7],
        /// Valid bytes.
        len: u8,
        /// c: last segment.
        last: bool,
    },
    /// scs 4: abort.
    Abort {
        /// Entry.
        mux: Mux,
        /// Reason.
        code: AbortCode,
    },
    /// scs 5, ss 0: block download initiated.
    BlockDownloadInitiated {
        /// Entry.
        mux: Mux,
        /// sc: server supports CRC.
        crc: bool,
        /// Segments per sub-block.
        block_size: u8,
    },
    /// scs 5, ss 2: sub-block acknowledged.
    BlockDownloadAck {
        /// Last sequence number received in order.
        ack_seq: u8,
        /// Segments in the next sub-block.
        block_size: u8,
    },
    /// scs 5, ss 1: block download complete.
    BlockDownloadEnd,
    /// scs 6, ss 0: block upload initiated.
    BlockUploadInitiated {
        /// Entry.
        mux: Mux,
        /// sc: server supports CRC.
        crc: bool,
        /// Total size.
        size: u32,
    },
    /// A block-upload sub-block segment.
    BlockUploadSegment(BlockSegment),
    /// scs 6, ss 1: block upload end.
    BlockUploadEnd {
        /// Unused bytes in the last segment.
        unused: u8,
        /// CRC over all data.
        crc: u16,
    },
}

impl Response {
    /// The eight bytes of the response frame.
    pub fn emit(&self) -> [u8; 8] {
        let mut out = [0u8; 8];
        match *self {
            Response::DownloadInitiated { mux } => {
                out[0] = 0x60;
                mux.emit(&mut out);
            }
            Response::DownloadSegmentAck { toggle } => out[0] = 0x20 | (u8::from(toggle) << 4),
            Response::UploadExpedited { mux, data, len } => {
                out[0] = 0x43 | ((4 - len.clamp(1, 4)) << 2);
                mux.emit(&mut out);
                out[4..].copy_from_slice(&data);
            }
            Response::UploadSegmented { mux, size } => {
                out[0] = 0x41;
                mux.emit(&mut out);
                out[4..].copy_from_slice(&size.to_le_bytes());
            }
            Response::UploadSegment { toggle, data, len, last } => {
                out[0] = (u8::from(toggle) << 4) | ((7 - len.min(7)) << 1) | u8::from(last);
                out[1..].copy_from_slice(&data);
            }
            Response::Abort { mux, code } => {
                out[0] = 0x80;
                mux.emit(&mut out);
                out[4..].copy_from_slice(&code.code().to_le_bytes());
            }
            Response::BlockDownloadInitiated { mux, crc, block_size } => {
                out[0] = 0xA0 | (u8::from(crc) << 2);
                mux.emit(&mut out);
                out[4] = block_size;
            }
            Response::BlockDownloadAck { ack_seq, block_size } => {
                out[0] = 0xA2;
                out[1] = ack_seq;
                out[2] = block_size;
            }
            Response::BlockDownloadEnd => out[0] = 0xA1,
            Response::BlockUploadInitiated { mux, crc, size } => {
                out[0] = 0xC2 | (u8::from(crc) << 2);
                mux.emit(&mut out);
                out[4..].copy_from_slice(&size.to_le_bytes());
            }
            Response::BlockUploadSegment(segment) => out = segment.emit(),
            Response::BlockUploadEnd { unused, crc } => {
                out[0] = 0xC1 | ((unused & 0x07) << 2);
                out[1..3].copy_from_slice(&crc.to_le_bytes());
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MUX: Mux = Mux { index: 0x1017, sub: 0 };

    #[test]
    fn parses_expedited_download_with_size() {
        let r = Request::parse(&[0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0]).unwrap();
        assert_eq!(
            r,
            Request::InitiateDownload {
                mux: MUX,
                kind: Download::Expedited { data: [0xE8, 0x03, 0, 0], len: Some(2), present: 4 }
            }
        );
    }

    #[test]
    fn short_frames_are_accepted_when_complete() {
        // A 6-byte expedited write of a 2-byte value (old PLCs do this).
        let r = Request::parse(&[0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03]).unwrap();
        assert!(matches!(r, Request::InitiateDownload { kind: Download::Expedited { present: 2, .. }, .. }));
        // An upload request needs the multiplexer.
        assert_eq!(Request::parse(&[0x40, 0x17]), None);
        // A segment announcing 7 bytes must carry them.
        assert_eq!(Request::parse(&[0x00, 1, 2]), None);
    }

    #[test]
    fn responses_have_the_documented_command_bytes() {
        assert_eq!(Response::DownloadInitiated { mux: MUX }.emit(), [0x60, 0x17, 0x10, 0, 0, 0, 0, 0]);
        assert_eq!(Response::DownloadSegmentAck { toggle: true }.emit()[0], 0x30);
        let up = Response::UploadExpedited { mux: MUX, data: [0xE8, 0x03, 0, 0], len: 2 };
        assert_eq!(up.emit(), [0x4B, 0x17, 0x10, 0, 0xE8, 0x03, 0, 0]);
        let seg = Response::UploadSegment { toggle: true, data: [1, 2, 3, 0, 0, 0, 0], len: 3, last: true };
        assert_eq!(seg.emit(), [0x19, 1, 2, 3, 0, 0, 0, 0]);
        let abort = Response::Abort { mux: MUX, code: AbortCode::ObjectDoesNotExist };
        assert_eq!(abort.emit(), [0x80, 0x17, 0x10, 0, 0x00, 0x00, 0x02, 0x06]);
        assert_eq!(
            Response::BlockUploadEnd { unused: 3, crc: 0x31C3 }.emit(),
            [0xCD, 0xC3, 0x31, 0, 0, 0, 0, 0]
        );
    }

    #[test]
    fn block_commands_parse() {
        assert_eq!(
            Request::parse(&[0xA4, 0x21, 0x10, 0, 127, 0, 0, 0]),
            Some(Request::BlockUploadInitiate {
                mux: Mux { index: 0x1021, sub: 0 },
                crc: true,
                block_size: 127,
                pst: 0
            })
        );
        assert_eq!(Request::parse(&[0xA3, 0, 0, 0, 0, 0, 0, 0]), Some(Request::BlockUploadStart));
        assert_eq!(
            Request::parse(&[0xA2, 5, 10, 0, 0, 0, 0, 0]),
            Some(Request::BlockUploadAck { ack_seq: 5, block_size: 10 })
        );
        assert_eq!(Request::parse(&[0xA1, 0, 0, 0, 0, 0, 0, 0]), Some(Request::BlockUploadEnd));
        assert_eq!(
            Request::parse(&[0xC6, 0x00, 0x20, 1, 10, 0, 0, 0]),
            Some(Request::BlockDownloadInitiate {
                mux: Mux { index: 0x2000, sub: 1 },
                crc: true,
                size: Some(10)
            })
        );
        assert_eq!(
            Request::parse(&[0xC1 | (3 << 2), 0xC3, 0x31, 0, 0, 0, 0, 0]),
            Some(Request::BlockDownloadEnd { unused: 3, crc: 0x31C3 })
        );
        assert_eq!(
            Request::parse(&[0xE0, 0, 0, 0, 0, 0, 0, 0]),
            Some(Request::Unknown { command: 0xE0, mux: Mux { index: 0, sub: 0 } })
        );
    }
}

//! SDO server (CiA 301 §7.2.4): expedited, segmented and block transfer in both
//! directions, on the default server channel (requests 0x600+id, responses 0x580+id).
//!
//! The server is an explicit state enum. [`SdoServer::on_request`] advances it by one received
//! frame and returns at most one response; [`SdoServer::poll`] yields the frames the server
//! sends on its own (block-upload segments, timeout aborts), one per call, so the caller decides
//! how many fit in its transmit queue. The server never touches the dictionary directly: it
//! goes through [`ObjectAccess`], which the drive implements with its access rules.
//!
//! Decisions where the standard leaves room (CiA 301 §7.2.4):
//! - A download is written to the dictionary only when complete (atomic; a refused write leaves
//!   the old value). Its data is staged in a `BUF`-byte buffer; larger transfers are refused with
//!   0x0504_0005 (out of memory).
//! - An expedited download without size (e = 1, s = 0) takes the entry's size, at most 4 bytes.
//! - Values of 1..=4 bytes are uploaded expedited; longer and empty values segmented, always
//!   with the size indicated (an empty value: size 0, then one segment with c = 1, n = 7).
//! - Block upload honours the protocol switch threshold: when the client allows it (pst > 0)
//!   and the value is no longer than pst, the server answers with a normal upload.
//! - Block download: a segment out of sequence is ignored; the sub-block acknowledgement names
//!   the last segment received in order, so the client repeats from there (CiA 301 §7.2.4.3).
//! - A new initiate while a transfer is in progress aborts it with 0x0504_0001.
//! - Timeouts (default 1 s between frames of a transfer) abort with 0x0504_0000.

use super::super::time::{Duration, Instant, ShortDuration};
use crate::od::AbortCode;
use crate::wire::crc;
use crate::wire::sdo::{BlockSegment, Download, Mux, Request, Response};

/// Largest number of segments per block-download sub-block this server asks for.
pub const MAX_BLOCK_SIZE: u8 = 127;

/// The dictionary as the SDO server sees it: the drive implements this with its access rules
/// (existence, access rights, NMT state, hooks).
pub trait ObjectAccess {
    /// Checks that `mux` may be uploaded and returns the length of its value.
    fn upload_len(&mut self, mux: Mux) -> Result<usize, AbortCode>;
    /// Copies value bytes from `offset` on into `buf`; returns the bytes copied.
    fn read(&mut self, mux: Mux, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode>;
    /// Checks that `mux` may be downloaded (with `size` bytes when known) and returns the size
    /// of the entry's value when it has a fixed size.
    fn download_check(&mut self, mux: Mux, size: Option<usize>) -> Result<Option<usize>, AbortCode>;
    /// Writes a complete value.
    fn write(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode>;

    /// The upload of a value of 1..=4 bytes in one call (the expedited case): `Ok(Some(n))` with
    /// the value in `buf[..n]`, `Ok(None)` when the value has another length (the server then
    /// starts a segmented upload with [`upload_len`](Self::upload_len)). The default is
    /// `upload_len` then `read`; an implementation may answer both from one look-up.
    fn upload_expedited(&mut self, mux: Mux, buf: &mut [u8; 4]) -> Result<Option<usize>, AbortCode> {
        upload_in_two_steps(self, mux, buf)
    }

    /// The download of a complete value of the size the client indicated (the expedited case).
    /// The default is [`download_check`](Self::download_check) then [`write`](Self::write); an
    /// implementation whose `write` refuses every size `download_check` refuses may write
    /// directly.
    fn download_expedited(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode> {
        self.download_check(mux, Some(data.len()))?;
        self.write(mux, data)
    }
}

/// [`ObjectAccess::upload_expedited`] by [`ObjectAccess::upload_len`] then
/// [`ObjectAccess::read`] (its default, for implementations that specialise only some entries).
#[inline(never)]
pub fn upload_in_two_steps<A: ObjectAccess + ?Sized>(
    od: &mut A,
    mux: Mux,
    buf: &mut [u8; 4],
) -> Result<Option<usize>, AbortCode> {
    let size = od.upload_len(mux)?;
    let Some(value) = buf.get_mut(..size).filter(|_| size > 0) else {
        return Ok(None);
    };
    match od.read(mux, 0, value)? {
        0 => Err(AbortCode::NoDataAvailable),
        n => Ok(Some(n)),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct BlockUpload {
    mux: Mux,
    crc_on: bool,
    size: usize,
    block_size: u8,
    /// Offset of the first byte of the current sub-block.
    base: usize,
    /// Last sequence number sent in the current sub-block.
    sent: u8,
    /// CRC over the acknowledged bytes.
    crc: u16,
}

impl BlockUpload {
    fn segments_left(&self) -> usize {
        self.size.saturating_sub(self.base).div_ceil(7).max(1)
    }
    /// Sequence number of the last segment of this sub-block.
    fn last_seq(&self) -> u8 {
        self.segments_left().min(usize::from(self.block_size)) as u8
    }
}

/// Where the server is in a transfer. (A `u32` tag moves the state as words, not bytes; with
/// it the fields are laid out in the order written, so each variant lists its words first.)
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
enum State {
    Idle,
    SegmentedDownload {
        size: Option<usize>,
        len: usize,
        mux: Mux,
        toggle: bool,
    },
    SegmentedUpload {
        size: usize,
        offset: usize,
        mux: Mux,
        toggle: bool,
    },
    BlockDownload {
        size: Option<usize>,
        len: usize,
        mux: Mux,
        crc_on: bool,
        seq: u8,
        block_size: u8,
        done: bool,
    },
    BlockDownloadEnd {
        size: Option<usize>,
        len: usize,
        mux: Mux,
        crc_on: bool,
    },
    BlockUploadInitiated(BlockUpload),
    BlockUploadSending(BlockUpload),
    BlockUploadAwaitAck(BlockUpload),
    BlockUploadEnd {
        mux: Mux,
    },
}

/// The SDO server with a `BUF`-byte download buffer.
pub struct SdoServer<const BUF: usize> {
    state: State,
    deadline: Option<Instant>,
    timeout: ShortDuration,
    /// Block transfers offered (CiA 301 makes them optional).
    block: bool,
    buf: [u8; BUF],
}

/// The two requests of nearly every exchange, answered in place without the state machine (the
/// server stays idle): an upload of a value of 1..=4 bytes, and an expedited download with its
/// size indicated and all of its bytes in the frame. `None` for any other request, or when the
/// value turns out longer: the state machine takes it from the start.
fn expedited(data: &[u8], od: &mut impl ObjectAccess) -> Option<[u8; 8]> {
    let &[command, lo, hi, sub, ref rest @ ..] = data else {
        return None;
    };
    let mux = Mux { index: u16::from_le_bytes([lo, hi]), sub };
    let result = match command >> 5 {
        // Initiate upload (its other bits are reserved and ignored, as by the state machine).
        2 => {
            let mut value = [0u8; 4];
            match od.upload_expedited(mux, &mut value) {
                Ok(None) => return None,
                Ok(Some(n)) => {
                    let [a, b, c, d] = value;
                    Ok([0x43 | ((4 - n.min(4) as u8) << 2), lo, hi, sub, a, b, c, d])
                }
                Err(code) => Err(code),
            }
        }
        // Initiate download, expedited (e = 1) with the size indicated (s = 1).
        1 if command & 0x03 == 0x03 => {
            let value = rest.get(..4 - usize::from((command >> 2) & 0x03))?;
            od.download_expedited(mux, value).map(|()| [0x60, lo, hi, sub, 0, 0, 0, 0])
        }
        _ => return None,
    };
    Some(result.unwrap_or_else(|code| refusal(mux, code).emit()))
}

/// What a step of the state machine produces.
type Step = (State, Option<Response>);

// Out of line: a refusal is the rare path of some twenty places.
#[inline(never)]
fn abort(mux: Mux, code: AbortCode) -> Step {
    (State::Idle, Some(refusal(mux, code)))
}

/// The abort frame the server sends for `code`.
fn refusal(mux: Mux, code: AbortCode) -> Response {
    crate::fmt::debug!("SDO: {:?} aborted: {:?}", mux, code);
    Response::Abort { mux, code }
}

impl<const BUF: usize> SdoServer<BUF> {
    /// An idle server whose transfers time out after `timeout` without a frame.
    pub const fn new(timeout: Duration) -> Self {
        SdoServer {
            state: State::Idle,
            deadline: None,
            timeout: ShortDuration::saturating(timeout),
            block: true,
            buf: [0; BUF],
        }
    }

    /// The same server without block transfers: their initiate requests are answered with
    /// abort 0x0504_0001 (command specifier not valid), as by a server that has none.
    pub const fn without_block_transfer(mut self) -> Self {
        self.block = false;
        self
    }

    /// True when no transfer is in progress.
    pub fn is_idle(&self) -> bool {
        self.state == State::Idle
    }

    /// Drops any transfer without a frame (NMT reset, leaving the states that serve SDO).
    pub fn reset(&mut self) {
        self.state = State::Idle;
        self.deadline = None;
    }

    /// The instant at which [`poll`](Self::poll) has something to do.
    pub fn deadline(&self) -> Option<Instant> {
        self.deadline
    }

    /// Handles one request frame's data received at `now`; returns the response to send.
    pub fn on_request(&mut self, data: &[u8], now: Instant, od: &mut impl ObjectAccess) -> Option<[u8; 8]> {
        // Only between transfers: in one, the same bytes are a segment or a protocol error.
        if matches!(self.state, State::Idle) {
            if let Some(response) = expedited(data, od) {
                return Some(response);
            }
        }
        let (state, response) = match self.state {
            // In a block download, every frame but an abort is a sub-block segment.
            State::BlockDownload { .. } if data.first() != Some(&0x80) => {
                let segment = BlockSegment::parse(data)?;
                self.block_segment(segment)
            }
            // Waiting for the end frame (ccs 6, cs 1): a repeated segment of the sub-block the
            // server already acknowledged is ignored (digest §5.5), not read as a command.
            State::BlockDownloadEnd { .. }
                if data.first().is_some_and(|&b| b != 0x80 && b & 0xE1 != 0xC1) =>
            {
                return None;
            }
            _ => {
                let request = Request::parse(data)?;
                self.step(request, od)
            }
        };
        self.enter(state, now);
        response.map(|r| r.emit())
    }

    /// Returns the next frame the server sends on its own at `now`, if any: a block-upload
    /// segment, or a timeout abort. Call again until it returns `None`.
    pub fn poll(&mut self, now: Instant, od: &mut impl ObjectAccess) -> Option<[u8; 8]> {
        if let State::BlockUploadSending(upload) = self.state {
            let (state, response) = self.send_segment(upload, od);
            self.enter(state, now);
            return response.map(|r| r.emit());
        }
        match self.deadline {
            Some(deadline) if now >= deadline => {
                let mux = self.mux()?;
                self.enter(State::Idle, now);
                crate::fmt::debug!("SDO: {:?} timed out", mux);
                Some(Response::Abort { mux, code: AbortCode::Timeout }.emit())
            }
            _ => None,
        }
    }

    fn enter(&mut self, state: State, now: Instant) {
        self.state = state;
        self.deadline = match state {
            State::Idle => None,
            // Sending is work to do right away.
            State::BlockUploadSending(_) => Some(now),
            _ => Some(now + self.timeout),
        };
    }

    fn mux(&self) -> Option<Mux> {
        match self.state {
            State::Idle => None,
            State::SegmentedDownload { mux, .. }
            | State::SegmentedUpload { mux, .. }
            | State::BlockDownload { mux, .. }
            | State::BlockDownloadEnd { mux, .. }
            | State::BlockUploadEnd { mux } => Some(mux),
            State::BlockUploadInitiated(u) | State::BlockUploadSending(u) | State::BlockUploadAwaitAck(u) => {
                Some(u.mux)
            }
        }
    }

    /// The transition function for frames with a command specifier.
    fn step(&mut self, request: Request, od: &mut impl ObjectAccess) -> Step {
        let current = self.mux().unwrap_or(Mux { index: 0, sub: 0 });
        match (self.state, request) {
            // An abort ends any transfer and is never answered.
            (_, Request::Abort { .. }) => {
                crate::fmt::debug!("SDO: {:?} aborted by the client", current);
                (State::Idle, None)
            }

            (State::Idle, Request::InitiateDownload { mux, kind }) => self.initiate_download(mux, kind, od),
            (State::Idle, Request::InitiateUpload { mux }) => self.initiate_upload(mux, od),
            (
                State::Idle,
                Request::BlockUploadInitiate { mux, .. } | Request::BlockDownloadInitiate { mux, .. },
            ) if !self.block => abort(mux, AbortCode::InvalidCommandSpecifier),
            (State::Idle, Request::BlockUploadInitiate { mux, crc, block_size, pst }) => {
                self.initiate_block_upload(mux, crc, block_size, pst, od)
            }
            (State::Idle, Request::BlockDownloadInitiate { mux, crc, size }) => {
                let size = size.map(|s| s as usize);
                match self.check_download(mux, size, od) {
                    Err(code) => abort(mux, code),
                    Ok(_) => (
                        State::BlockDownload {
                            mux,
                            crc_on: crc,
                            size,
                            len: 0,
                            seq: 0,
                            block_size: self.block_size(0),
                            done: false,
                        },
                        Some(Response::BlockDownloadInitiated {
                            mux,
                            crc: true,
                            block_size: self.block_size(0),
                        }),
                    ),
                }
            }
            (State::Idle, Request::Unknown { mux, .. }) => abort(mux, AbortCode::InvalidCommandSpecifier),
            // Segment or block continuation frames without a transfer.
            (State::Idle, _) => abort(current, AbortCode::InvalidCommandSpecifier),

            (
                State::SegmentedDownload { mux, toggle, size, len },
                Request::DownloadSegment { toggle: t, data, len: n, last },
            ) => {
                if t != toggle {
                    return abort(mux, AbortCode::ToggleBitNotAlternated);
                }
                let n = usize::from(n);
                let Some(dst) = self.buf.get_mut(len..len + n) else {
                    return abort(mux, AbortCode::OutOfMemory);
                };
                dst.copy_from_slice(data.get(..n).unwrap_or(&[]));
                let len = len + n;
                if size.is_some_and(|s| len > s) {
                    return abort(mux, AbortCode::LengthTooHigh);
                }
                if !last {
                    return (
                        State::SegmentedDownload { mux, toggle: !toggle, size, len },
                        Some(Response::DownloadSegmentAck { toggle }),
                    );
                }
                if size.is_some_and(|s| len < s) {
                    return abort(mux, AbortCode::LengthTooLow);
                }
                match self.finish_download(mux, len, od) {
                    Ok(()) => (State::Idle, Some(Response::DownloadSegmentAck { toggle })),
                    Err(code) => abort(mux, code),
                }
            }

            (State::SegmentedUpload { mux, toggle, size, offset }, Request::UploadSegment { toggle: t }) => {
                if t != toggle {
                    return abort(mux, AbortCode::ToggleBitNotAlternated);
                }
                let mut data = [0u8; 7];
                let want = size.saturating_sub(offset).min(7);
                let got = match od.read(mux, offset, data.get_mut(..want).unwrap_or(&mut [])) {
                    Ok(n) => n,
                    Err(code) => return abort(mux, code),
                };
                let offset = offset + got;
                let last = offset >= size || got < want;
                let response = Response::UploadSegment { toggle, data, len: got as u8, last };
                if last {
                    (State::Idle, Some(response))
                } else {
                    (State::SegmentedUpload { mux, toggle: !toggle, size, offset }, Some(response))
                }
            }

            (
                State::BlockDownloadEnd { mux, crc_on, size, len },
                Request::BlockDownloadEnd { unused, crc: client_crc },
            ) => {
                // The last segment always carried 7 bytes; `unused` of them were padding.
                let len = len.saturating_sub(usize::from(unused));
                if len > BUF {
                    return abort(mux, AbortCode::OutOfMemory);
                }
                if size.is_some_and(|s| len > s) {
                    return abort(mux, AbortCode::LengthTooHigh);
                }
                if size.is_some_and(|s| len < s) {
                    return abort(mux, AbortCode::LengthTooLow);
                }
                if crc_on && crc::update(0, self.buf.get(..len).unwrap_or(&[])) != client_crc {
                    return abort(mux, AbortCode::CrcError);
                }
                match self.finish_download(mux, len, od) {
                    Ok(()) => (State::Idle, Some(Response::BlockDownloadEnd)),
                    Err(code) => abort(mux, code),
                }
            }

            (State::BlockUploadInitiated(upload), Request::BlockUploadStart) => {
                (State::BlockUploadSending(BlockUpload { sent: 0, ..upload }), None)
            }
            (State::BlockUploadAwaitAck(upload), Request::BlockUploadAck { ack_seq, block_size }) => {
                self.block_upload_ack(upload, ack_seq, block_size, od)
            }
            // The client may acknowledge early (while segments are still being sent).
            (State::BlockUploadSending(upload), Request::BlockUploadAck { ack_seq, block_size }) => {
                self.block_upload_ack(upload, ack_seq, block_size, od)
            }
            (State::BlockUploadEnd { .. }, Request::BlockUploadEnd) => (State::Idle, None),

            // Anything else in the middle of a transfer is a protocol error (digest §5.9 item 7).
            (
                State::SegmentedDownload { .. }
                | State::SegmentedUpload { .. }
                | State::BlockDownload { .. }
                | State::BlockDownloadEnd { .. }
                | State::BlockUploadInitiated(_)
                | State::BlockUploadSending(_)
                | State::BlockUploadAwaitAck(_)
                | State::BlockUploadEnd { .. },
                _,
            ) => abort(current, AbortCode::InvalidCommandSpecifier),
        }
    }

    fn block_size(&self, len: usize) -> u8 {
        (BUF.saturating_sub(len) / 7).clamp(1, usize::from(MAX_BLOCK_SIZE)) as u8
    }

    fn check_download(
        &self,
        mux: Mux,
        size: Option<usize>,
        od: &mut impl ObjectAccess,
    ) -> Result<Option<usize>, AbortCode> {
        let fixed = od.download_check(mux, size)?;
        if size.is_some_and(|s| s > BUF) {
            return Err(AbortCode::OutOfMemory);
        }
        Ok(fixed)
    }

    fn finish_download(&mut self, mux: Mux, len: usize, od: &mut impl ObjectAccess) -> Result<(), AbortCode> {
        od.write(mux, self.buf.get(..len).unwrap_or(&[]))
    }

    fn initiate_download(&mut self, mux: Mux, kind: Download, od: &mut impl ObjectAccess) -> Step {
        match kind {
            Download::Expedited { data, len, present } => {
                let size = len.map(usize::from);
                let fixed = match self.check_download(mux, size, od) {
                    Ok(fixed) => fixed,
                    Err(code) => return abort(mux, code),
                };
                // Without a size, the entry's own size says how many bytes count (at most 4).
                let n = size.unwrap_or(fixed.unwrap_or(4).min(4));
                if n > usize::from(present) {
                    return abort(mux, AbortCode::LengthTooLow);
                }
                match od.write(mux, data.get(..n).unwrap_or(&[])) {
                    Ok(()) => (State::Idle, Some(Response::DownloadInitiated { mux })),
                    Err(code) => abort(mux, code),
                }
            }
            Download::Segmented { size } => {
                let size = size.map(|s| s as usize);
                match self.check_download(mux, size, od) {
                    Ok(_) => (
                        State::SegmentedDownload { mux, toggle: false, size, len: 0 },
                        Some(Response::DownloadInitiated { mux }),
                    ),
                    Err(code) => abort(mux, code),
                }
            }
        }
    }

    fn initiate_upload(&mut self, mux: Mux, od: &mut impl ObjectAccess) -> Step {
        let mut data = [0u8; 4];
        match od.upload_expedited(mux, &mut data) {
            Ok(Some(n)) => return (State::Idle, Some(Response::UploadExpedited { mux, data, len: n as u8 })),
            Ok(None) => {}
            Err(code) => return abort(mux, code),
        }
        let size = match od.upload_len(mux) {
            Ok(size) => size,
            Err(code) => return abort(mux, code),
        };
        let Ok(wire_size) = u32::try_from(size) else {
            return abort(mux, AbortCode::General);
        };
        (
            State::SegmentedUpload { mux, toggle: false, size, offset: 0 },
            Some(Response::UploadSegmented { mux, size: wire_size }),
        )
    }

    fn initiate_block_upload(
        &mut self,
        mux: Mux,
        crc_on: bool,
        block_size: u8,
        pst: u8,
        od: &mut impl ObjectAccess,
    ) -> Step {
        let size = match od.upload_len(mux) {
            Ok(size) => size,
            Err(code) => return abort(mux, code),
        };
        if !(1..=MAX_BLOCK_SIZE).contains(&block_size) {
            return abort(mux, AbortCode::InvalidBlockSize);
        }
        if pst > 0 && size <= usize::from(pst) {
            return self.initiate_upload(mux, od);
        }
        let Ok(wire_size) = u32::try_from(size) else {
            return abort(mux, AbortCode::General);
        };
        let upload = BlockUpload { mux, crc_on, size, block_size, base: 0, sent: 0, crc: 0 };
        (
            State::BlockUploadInitiated(upload),
            Some(Response::BlockUploadInitiated { mux, crc: true, size: wire_size }),
        )
    }

    fn send_segment(&mut self, upload: BlockUpload, od: &mut impl ObjectAccess) -> Step {
        let seq = upload.sent + 1;
        let offset = upload.base + usize::from(upload.sent) * 7;
        let mut data = [0u8; 7];
        let want = upload.size.saturating_sub(offset).min(7);
        if let Err(code) = od.read(upload.mux, offset, data.get_mut(..want).unwrap_or(&mut [])) {
            return abort(upload.mux, code);
        }
        let last = offset + 7 >= upload.size;
        let segment = BlockSegment { seq, last, data };
        let next = BlockUpload { sent: seq, ..upload };
        let state = if seq >= upload.last_seq() {
            State::BlockUploadAwaitAck(next)
        } else {
            State::BlockUploadSending(next)
        };
        (state, Some(Response::BlockUploadSegment(segment)))
    }

    fn block_upload_ack(
        &mut self,
        upload: BlockUpload,
        ack_seq: u8,
        block_size: u8,
        od: &mut impl ObjectAccess,
    ) -> Step {
        if ack_seq > upload.sent {
            return abort(upload.mux, AbortCode::InvalidSequenceNumber);
        }
        if !(1..=MAX_BLOCK_SIZE).contains(&block_size) {
            return abort(upload.mux, AbortCode::InvalidBlockSize);
        }
        // Feed the acknowledged bytes to the CRC once, in order.
        let acked = (usize::from(ack_seq) * 7).min(upload.size.saturating_sub(upload.base));
        let mut crc = upload.crc;
        let mut offset = upload.base;
        let mut chunk = [0u8; 7];
        while offset < upload.base + acked {
            let want = (upload.base + acked - offset).min(7);
            match od.read(upload.mux, offset, chunk.get_mut(..want).unwrap_or(&mut [])) {
                Ok(n) if n > 0 => {
                    crc = crc::update(crc, chunk.get(..n).unwrap_or(&[]));
                    offset += n;
                }
                Ok(_) => return abort(upload.mux, AbortCode::General),
                Err(code) => return abort(upload.mux, code),
            }
        }
        let next = BlockUpload { base: upload.base + acked, sent: 0, crc, block_size, ..upload };
        if next.base >= upload.size && (acked > 0 || upload.size == 0) && ack_seq == upload.last_seq() {
            let last_len = match upload.size % 7 {
                0 if upload.size > 0 => 7,
                rest => rest,
            };
            let unused = (7 - last_len) as u8;
            let crc = if upload.crc_on { crc } else { 0 };
            return (
                State::BlockUploadEnd { mux: upload.mux },
                Some(Response::BlockUploadEnd { unused, crc }),
            );
        }
        (State::BlockUploadSending(next), None)
    }

    /// A block-download sub-block segment.
    fn block_segment(&mut self, segment: BlockSegment) -> Step {
        let State::BlockDownload { mux, crc_on, size, len, seq, block_size, done } = self.state else {
            return (self.state, None);
        };
        if segment.seq == 0 || segment.seq > MAX_BLOCK_SIZE {
            return abort(mux, AbortCode::InvalidSequenceNumber);
        }
        let (mut len, mut seq, mut done) = (len, seq, done);
        if !done && segment.seq == seq + 1 {
            // The last segment may carry up to 6 padding bytes beyond the buffer; only the end
            // frame tells how many, so keep what fits and check the real length there.
            let room = BUF.saturating_sub(len).min(7);
            if room < 7 && !segment.last {
                return abort(mux, AbortCode::OutOfMemory);
            }
            if let Some(dst) = self.buf.get_mut(len..).and_then(|b| b.first_chunk_mut::<7>()) {
                // A whole segment: a fixed-size copy (no memcpy call).
                *dst = segment.data;
            } else if let (Some(dst), Some(src)) =
                (self.buf.get_mut(len..len + room), segment.data.get(..room))
            {
                dst.copy_from_slice(src);
            }
            len += 7;
            seq = segment.seq;
            done = segment.last;
            if size.is_some_and(|s| len > s + 6) {
                return abort(mux, AbortCode::LengthTooHigh);
            }
        }
        // End of the sub-block: the client sent its last segment (in order or not).
        if segment.seq >= block_size || segment.last {
            let ack = Response::BlockDownloadAck { ack_seq: seq, block_size: self.block_size(len) };
            if done {
                return (State::BlockDownloadEnd { mux, crc_on, size, len }, Some(ack));
            }
            return (
                State::BlockDownload {
                    mux,
                    crc_on,
                    size,
                    len,
                    seq: 0,
                    block_size: self.block_size(len),
                    done,
                },
                Some(ack),
            );
        }
        (State::BlockDownload { mux, crc_on, size, len, seq, block_size, done }, None)
    }
}

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
//! - Except to an entry that takes its value as a stream ([`ObjectAccess::begin_stream`], e.g.
//!   the program data 1F50h of CiA 302-3): a segmented or block download to it is passed on in
//!   pieces of up to `BUF` bytes as they arrive, so its size is not bounded by the buffer. A
//!   block download's pieces are whole sub-blocks; the last piece is passed on only after the
//!   transfer's CRC has been checked.
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
use super::NmtState;
use crate::od::{AbortCode, Var, WriteRule};
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

    /// A segmented or block download of `size` bytes (when indicated) to `mux` is starting,
    /// after [`download_check`](Self::download_check) passed: `Ok(true)` when the entry takes
    /// its value as a stream, in pieces through [`write_piece`](Self::write_piece) (an
    /// expedited download to it still goes to [`write`](Self::write)). The default: no entry
    /// streams.
    fn begin_stream(&mut self, _mux: Mux, _size: Option<usize>) -> Result<bool, AbortCode> {
        Ok(false)
    }

    /// The next piece of a streamed download: `data` belongs at `offset` of the value, pieces
    /// come in order and without gaps; `last` marks the final one, after which the transfer is
    /// complete (its length and, for block transfer, its CRC checked). An error aborts the
    /// transfer with that code.
    fn write_piece(&mut self, _mux: Mux, _offset: usize, _data: &[u8], _last: bool) -> Result<(), AbortCode> {
        Err(AbortCode::General)
    }

    /// A streamed download ended without its last piece: aborted by either side (a refused
    /// piece included), timed out, or replaced by a new request.
    fn stream_broken(&mut self, _mux: Mux) {}
}

/// The access rule of an upload from the bus: a write-only entry is refused (0x0601_0001).
/// Every [`ObjectAccess`] of the crate's nodes checks it before the owner's own rules.
#[inline]
pub fn check_upload(var: &Var) -> Result<(), AbortCode> {
    if var.access.readable() {
        Ok(())
    } else {
        Err(AbortCode::ReadOfWriteOnly)
    }
}

/// The access rules of a download from the bus, before the owner's own: a read-only entry is
/// refused (0x0601_0002), and an entry whose [`WriteRule`] the device's state does not allow
/// now with 0x0800_0022: [`WriteRule::NotOperational`] in NMT Operational,
/// [`WriteRule::SwitchOnDisabled`] unless `switched_off()` (the drive function is off where
/// the value takes effect; asked only for such an entry).
#[inline]
pub fn check_download(
    var: &Var,
    nmt: NmtState,
    switched_off: impl FnOnce() -> bool,
) -> Result<(), AbortCode> {
    if !var.access.writable() {
        return Err(AbortCode::WriteOfReadOnly);
    }
    let allowed = match var.rule {
        WriteRule::Always => true,
        WriteRule::NotOperational => nmt != NmtState::Operational,
        WriteRule::SwitchOnDisabled => switched_off(),
    };
    if allowed {
        Ok(())
    } else {
        Err(AbortCode::CannotStoreDeviceState)
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
        /// The CRC of the download's bytes but the last segment's (those of the pieces a
        /// stream passed on included): each segment folds the one before it into it, so no
        /// frame computes it over a whole buffer.
        crc: u16,
    },
    BlockDownloadEnd {
        size: Option<usize>,
        len: usize,
        mux: Mux,
        crc_on: bool,
        /// As in `BlockDownload`: all but the last segment's bytes.
        crc: u16,
    },
    BlockUploadInitiated(BlockUpload),
    BlockUploadSending(BlockUpload),
    BlockUploadAwaitAck(BlockUpload),
    BlockUploadEnd {
        mux: Mux,
    },
}

/// A download being passed on in pieces ([`ObjectAccess::begin_stream`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Stream {
    mux: Mux,
    /// Offset in the value of the buffer's first byte (the bytes before it are passed on).
    base: usize,
    /// The last piece was taken: the transfer ends complete.
    complete: bool,
}

/// The SDO server with a `BUF`-byte download buffer.
pub struct SdoServer<const BUF: usize> {
    state: State,
    /// The download in progress is streamed: its buffer holds the bytes after `base`.
    stream: Option<Stream>,
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
    if let Some(mux) = upload_request(data) {
        let mut value = [0u8; 4];
        return match od.upload_expedited(mux, &mut value) {
            Ok(None) => None,
            Ok(Some(n)) => Some(upload_response(mux, value, n)),
            Err(code) => Some(refusal(mux, code).emit()),
        };
    }
    let (mux, value) = download_request(data)?;
    Some(download_response(mux, od.download_expedited(mux, value)))
}

/// The index and sub-index of an initiate upload request (its other bits are reserved and
/// ignored, as by the state machine), or `None` for any other frame.
#[inline]
pub(crate) fn upload_request(data: &[u8]) -> Option<Mux> {
    match data {
        &[command, lo, hi, sub, ..] if command >> 5 == 2 => {
            Some(Mux { index: u16::from_le_bytes([lo, hi]), sub })
        }
        _ => None,
    }
}

/// The expedited upload response of `mux` with the value `value[..n]` (1..=4 bytes).
#[inline]
pub(crate) fn upload_response(mux: Mux, value: [u8; 4], n: usize) -> [u8; 8] {
    let [lo, hi] = mux.index.to_le_bytes();
    let [a, b, c, d] = value;
    [0x43 | ((4 - n.min(4) as u8) << 2), lo, hi, mux.sub, a, b, c, d]
}

/// The index and sub-index of an expedited download request with its size indicated (e = 1,
/// s = 1), and the value, or `None` for any other frame (or one that lacks bytes of the value).
#[inline]
fn download_request(data: &[u8]) -> Option<(Mux, &[u8])> {
    let &[command, lo, hi, sub, ref rest @ ..] = data else {
        return None;
    };
    if command >> 5 != 1 || command & 0x03 != 0x03 {
        return None;
    }
    let value = rest.get(..4 - usize::from((command >> 2) & 0x03))?;
    Some((Mux { index: u16::from_le_bytes([lo, hi]), sub }, value))
}

/// The response to an expedited download of `mux`: its acknowledgement, or the abort with the
/// code that refused it.
fn download_response(mux: Mux, result: Result<(), AbortCode>) -> [u8; 8] {
    match result {
        Ok(()) => {
            let [lo, hi] = mux.index.to_le_bytes();
            [0x60, lo, hi, mux.sub, 0, 0, 0, 0]
        }
        Err(code) => refusal(mux, code).emit(),
    }
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
            stream: None,
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
        self.stream = None;
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
                self.block_segment(segment, od)
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
        self.enter(state, now, od);
        response.map(|r| r.emit())
    }

    /// Returns the next frame the server sends on its own at `now`, if any: a block-upload
    /// segment, or a timeout abort. Call again until it returns `None`.
    pub fn poll(&mut self, now: Instant, od: &mut impl ObjectAccess) -> Option<[u8; 8]> {
        if let State::BlockUploadSending(upload) = self.state {
            let (state, response) = self.send_segment(upload, od);
            self.enter(state, now, od);
            return response.map(|r| r.emit());
        }
        match self.deadline {
            Some(deadline) if now >= deadline => {
                let mux = self.mux()?;
                self.enter(State::Idle, now, od);
                crate::fmt::debug!("SDO: {:?} timed out", mux);
                Some(Response::Abort { mux, code: AbortCode::Timeout }.emit())
            }
            _ => None,
        }
    }

    fn enter(&mut self, state: State, now: Instant, od: &mut impl ObjectAccess) {
        if state == State::Idle {
            // A streamed download that ends here without its last piece is broken.
            if let Some(stream) = self.stream.take().filter(|s| !s.complete) {
                od.stream_broken(stream.mux);
            }
        }
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
                match self.begin_download(mux, size, od) {
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
                            crc: 0,
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
                let mut len = len;
                if len + n > BUF {
                    // A full buffer: a stream passes it on, anything else is too long.
                    if let Err(code) = self.pass_on(len, false, od) {
                        return abort(mux, code);
                    }
                    len = 0;
                }
                let Some(dst) = self.buf.get_mut(len..len + n) else {
                    return abort(mux, AbortCode::OutOfMemory);
                };
                dst.copy_from_slice(data.get(..n).unwrap_or(&[]));
                let len = len + n;
                if size.is_some_and(|s| self.streamed() + len > s) {
                    return abort(mux, AbortCode::LengthTooHigh);
                }
                if !last {
                    return (
                        State::SegmentedDownload { mux, toggle: !toggle, size, len },
                        Some(Response::DownloadSegmentAck { toggle }),
                    );
                }
                if size.is_some_and(|s| self.streamed() + len < s) {
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
                State::BlockDownloadEnd { mux, crc_on, size, len, crc },
                Request::BlockDownloadEnd { unused, crc: client_crc },
            ) => {
                // The last segment always carried 7 bytes; `unused` of them were padding.
                let last = len.saturating_sub(7);
                let len = len.saturating_sub(usize::from(unused));
                if len > BUF {
                    return abort(mux, AbortCode::OutOfMemory);
                }
                let total = self.streamed() + len;
                if size.is_some_and(|s| total > s) {
                    return abort(mux, AbortCode::LengthTooHigh);
                }
                if size.is_some_and(|s| total < s) {
                    return abort(mux, AbortCode::LengthTooLow);
                }
                // The last segment's bytes are the only ones the CRC lacks.
                if crc_on && crc::update(crc, self.buf.get(last..len).unwrap_or(&[])) != client_crc {
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

    /// A segmented or block download to `mux` of `size` bytes (when indicated) may begin: the
    /// entry's checks, then either a stream or a value that fits the buffer.
    fn begin_download(
        &mut self,
        mux: Mux,
        size: Option<usize>,
        od: &mut impl ObjectAccess,
    ) -> Result<(), AbortCode> {
        od.download_check(mux, size)?;
        if od.begin_stream(mux, size)? {
            self.stream = Some(Stream { mux, base: 0, complete: false });
            return Ok(());
        }
        if size.is_some_and(|s| s > BUF) {
            return Err(AbortCode::OutOfMemory);
        }
        Ok(())
    }

    /// Bytes of a streamed download already passed on (0 for a staged one).
    fn streamed(&self) -> usize {
        self.stream.map_or(0, |s| s.base)
    }

    /// Passes the buffer's first `len` bytes on as the stream's next piece. Without a stream,
    /// the value does not fit the buffer.
    fn pass_on(&mut self, len: usize, last: bool, od: &mut impl ObjectAccess) -> Result<(), AbortCode> {
        let Some(stream) = self.stream.as_mut() else {
            return Err(AbortCode::OutOfMemory);
        };
        let data = self.buf.get(..len).unwrap_or(&[]);
        od.write_piece(stream.mux, stream.base, data, last)?;
        stream.base += len;
        stream.complete = last;
        Ok(())
    }

    /// The download's last `len` bytes are in the buffer and checked: the value is written, or
    /// the stream's last piece passed on.
    fn finish_download(&mut self, mux: Mux, len: usize, od: &mut impl ObjectAccess) -> Result<(), AbortCode> {
        if self.stream.is_some() {
            return self.pass_on(len, true, od);
        }
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
                match self.begin_download(mux, size, od) {
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
    fn block_segment(&mut self, segment: BlockSegment, od: &mut impl ObjectAccess) -> Step {
        let State::BlockDownload { mux, crc_on, size, len, seq, block_size, done, crc } = self.state else {
            return (self.state, None);
        };
        if segment.seq == 0 || segment.seq > MAX_BLOCK_SIZE {
            return abort(mux, AbortCode::InvalidSequenceNumber);
        }
        let (mut len, mut seq, mut done, mut crc) = (len, seq, done, crc);
        if !done && segment.seq == seq + 1 {
            // The segment before this one is final: into the CRC with it (a segment is 7 bytes;
            // the buffer holds whole segments, or a stream's piece restarts it at 0).
            if crc_on {
                crc = crc::update(crc, self.buf.get(len.saturating_sub(7)..len).unwrap_or(&[]));
            }
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
            if size.is_some_and(|s| self.streamed() + len > s + 6) {
                return abort(mux, AbortCode::LengthTooHigh);
            }
        }
        // End of the sub-block: the client sent its last segment (in order or not).
        if segment.seq >= block_size || segment.last {
            if done {
                let ack = Response::BlockDownloadAck { ack_seq: seq, block_size: self.block_size(len) };
                return (State::BlockDownloadEnd { mux, crc_on, size, len, crc }, Some(ack));
            }
            // Every byte of a sub-block before the last is data: a stream passes them on.
            if self.stream.is_some() {
                if crc_on {
                    crc = crc::update(crc, self.buf.get(len.saturating_sub(7)..len).unwrap_or(&[]));
                }
                if let Err(code) = self.pass_on(len, false, od) {
                    return abort(mux, code);
                }
                len = 0;
            }
            let ack = Response::BlockDownloadAck { ack_seq: seq, block_size: self.block_size(len) };
            return (
                State::BlockDownload {
                    mux,
                    crc_on,
                    size,
                    len,
                    seq: 0,
                    block_size: self.block_size(len),
                    done,
                    crc,
                },
                Some(ack),
            );
        }
        (State::BlockDownload { mux, crc_on, size, len, seq, block_size, done, crc }, None)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    const STREAM: Mux = Mux { index: 0x1F50, sub: 1 };

    /// The access rules every node's SDO path applies before an owner's: the abort codes of
    /// CiA 301 for a write-only, a read-only and a state-bound entry.
    #[test]
    fn the_access_rules_give_their_abort_codes() {
        use crate::od::{Access, DataType};
        let var = |access| Var::new("x", DataType::Unsigned8).access(access);
        assert_eq!(check_upload(&var(Access::WriteOnly)), Err(AbortCode::ReadOfWriteOnly));
        assert_eq!(check_upload(&var(Access::ReadOnly)), Ok(()));
        let never = || panic!("asked for an entry without the rule");
        assert_eq!(
            check_download(&var(Access::ReadOnly), NmtState::PreOperational, never),
            Err(AbortCode::WriteOfReadOnly)
        );
        assert_eq!(
            check_download(&var(Access::Const), NmtState::PreOperational, never),
            Err(AbortCode::WriteOfReadOnly)
        );
        assert_eq!(check_download(&var(Access::ReadWrite), NmtState::Operational, never), Ok(()));
        let not_operational = var(Access::ReadWrite).rule(WriteRule::NotOperational);
        assert_eq!(check_download(&not_operational, NmtState::PreOperational, never), Ok(()));
        assert_eq!(
            check_download(&not_operational, NmtState::Operational, never),
            Err(AbortCode::CannotStoreDeviceState)
        );
        let switched_off = var(Access::ReadWrite).rule(WriteRule::SwitchOnDisabled);
        assert_eq!(check_download(&switched_off, NmtState::Operational, || true), Ok(()));
        assert_eq!(
            check_download(&switched_off, NmtState::PreOperational, || false),
            Err(AbortCode::CannotStoreDeviceState)
        );
    }

    const SMALL: Mux = Mux { index: 0x2000, sub: 0 };

    /// An entry that streams (1F50h:1) and a small staged one (2000h, up to 32 bytes): records
    /// what the server passes on.
    #[derive(Default)]
    struct Sink {
        pieces: Vec<(usize, Vec<u8>, bool)>,
        broken: usize,
        refuse_at: Option<usize>,
        small: Vec<u8>,
    }

    impl Sink {
        fn streamed(&self) -> Vec<u8> {
            self.pieces.iter().flat_map(|(_, data, _)| data.iter().copied()).collect()
        }
    }

    impl ObjectAccess for Sink {
        fn upload_len(&mut self, _: Mux) -> Result<usize, AbortCode> {
            Err(AbortCode::ReadOfWriteOnly)
        }
        fn read(&mut self, _: Mux, _: usize, _: &mut [u8]) -> Result<usize, AbortCode> {
            Err(AbortCode::ReadOfWriteOnly)
        }
        fn download_check(&mut self, mux: Mux, size: Option<usize>) -> Result<Option<usize>, AbortCode> {
            match mux {
                SMALL if size.is_some_and(|s| s > 32) => Err(AbortCode::LengthTooHigh),
                SMALL | STREAM => Ok(None),
                _ => Err(AbortCode::ObjectDoesNotExist),
            }
        }
        fn write(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode> {
            assert_eq!(mux, SMALL, "a streamed entry is never written whole");
            self.small = data.to_vec();
            Ok(())
        }
        fn begin_stream(&mut self, mux: Mux, _: Option<usize>) -> Result<bool, AbortCode> {
            Ok(mux == STREAM)
        }
        fn write_piece(&mut self, mux: Mux, offset: usize, data: &[u8], last: bool) -> Result<(), AbortCode> {
            assert_eq!(mux, STREAM);
            if self.refuse_at.is_some_and(|at| offset >= at) {
                return Err(AbortCode::HardwareError);
            }
            self.pieces.push((offset, data.to_vec(), last));
            Ok(())
        }
        fn stream_broken(&mut self, mux: Mux) {
            assert_eq!(mux, STREAM);
            self.broken += 1;
        }
    }

    fn image(len: usize) -> Vec<u8> {
        (0..len).map(|i| (i * 7 + i / 251) as u8).collect()
    }

    fn at(ms: u64) -> Instant {
        Instant::from_micros(ms * 1000)
    }

    fn mux_bytes(mux: Mux) -> [u8; 3] {
        let [lo, hi] = mux.index.to_le_bytes();
        [lo, hi, mux.sub]
    }

    /// Segmented download of `data` to `mux` (size indicated as `size`); the server's answers.
    fn segmented(
        server: &mut SdoServer<16>,
        sink: &mut Sink,
        mux: Mux,
        data: &[u8],
        size: u32,
    ) -> Vec<[u8; 8]> {
        let [lo, hi, sub] = mux_bytes(mux);
        let [a, b, c, d] = size.to_le_bytes();
        let mut answers = Vec::new();
        answers.extend(server.on_request(&[0x21, lo, hi, sub, a, b, c, d], at(0), sink));
        for (n, chunk) in data.chunks(7).enumerate() {
            let last = (n + 1) * 7 >= data.len();
            let mut frame = [0u8; 8];
            frame[0] = ((n as u8 & 1) << 4) | ((7 - chunk.len() as u8) << 1) | u8::from(last);
            frame[1..1 + chunk.len()].copy_from_slice(chunk);
            answers.extend(server.on_request(&frame, at(1), sink));
            if answers.last().is_some_and(|r| r[0] == 0x80) {
                break;
            }
        }
        answers
    }

    #[test]
    fn a_segmented_download_to_a_stream_is_passed_on_in_buffer_sized_pieces() {
        let (mut server, mut sink) = (SdoServer::<16>::new(Duration::from_millis(1000)), Sink::default());
        let data = image(200);
        let answers = segmented(&mut server, &mut sink, STREAM, &data, 200);
        assert_eq!(answers.len(), 1 + 29, "an answer to the initiate and to every segment");
        assert!(answers.iter().all(|r| r[0] != 0x80), "no abort: {answers:02x?}");
        assert_eq!(sink.streamed(), data);
        assert!(sink.pieces.iter().all(|(_, piece, _)| piece.len() <= 16));
        let offsets: Vec<usize> = sink.pieces.iter().map(|(o, _, _)| *o).collect();
        let mut expected = 0;
        for (offset, (_, piece, _)) in offsets.iter().zip(&sink.pieces) {
            assert_eq!(*offset, expected, "pieces in order, without gaps");
            expected += piece.len();
        }
        let lasts: Vec<bool> = sink.pieces.iter().map(|(_, _, last)| *last).collect();
        assert_eq!(lasts.iter().filter(|l| **l).count(), 1);
        assert_eq!(lasts.last(), Some(&true));
        assert_eq!(sink.broken, 0);
        assert!(server.is_idle());
    }

    #[test]
    fn a_staged_value_longer_than_the_buffer_is_still_out_of_memory() {
        let (mut server, mut sink) = (SdoServer::<16>::new(Duration::from_millis(1000)), Sink::default());
        // Size indicated: refused at the initiate.
        let answers = segmented(&mut server, &mut sink, SMALL, &image(20), 20);
        assert_eq!(answers[0], [0x80, 0x00, 0x20, 0x00, 0x05, 0x00, 0x04, 0x05]);
        // Size not indicated: refused at the segment that does not fit.
        let mut server = SdoServer::<16>::new(Duration::from_millis(1000));
        assert_eq!(
            server.on_request(&[0x20, 0x00, 0x20, 0x00, 0, 0, 0, 0], at(0), &mut sink),
            Some([0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0])
        );
        for (n, chunk) in image(21).chunks(7).enumerate() {
            let mut frame = [(n as u8 & 1) << 4, 0, 0, 0, 0, 0, 0, 0];
            frame[1..8].copy_from_slice(chunk);
            let answer = server.on_request(&frame, at(1), &mut sink);
            if n == 2 {
                assert_eq!(answer, Some([0x80, 0x00, 0x20, 0x00, 0x05, 0x00, 0x04, 0x05]));
            }
        }
        assert!(sink.small.is_empty() && sink.pieces.is_empty());
    }

    /// Block download of `data` to the stream with sub-blocks as the server asks; `crc` is what
    /// the client claims at the end. The server's answers.
    fn block(server: &mut SdoServer<64>, sink: &mut Sink, data: &[u8], crc: u16) -> Vec<[u8; 8]> {
        let [lo, hi, sub] = mux_bytes(STREAM);
        let [a, b, c, d] = (data.len() as u32).to_le_bytes();
        let mut answers = Vec::new();
        let first = server.on_request(&[0xC6, lo, hi, sub, a, b, c, d], at(0), sink).unwrap();
        answers.push(first);
        let mut block_size = usize::from(first[4]);
        let segments: Vec<&[u8]> = data.chunks(7).collect();
        let mut next = 0;
        while next < segments.len() {
            let mut seq = 0u8;
            while usize::from(seq) < block_size && next < segments.len() {
                seq += 1;
                let last = next + 1 == segments.len();
                let mut frame = [0u8; 8];
                frame[0] = seq | if last { 0x80 } else { 0 };
                frame[1..1 + segments[next].len()].copy_from_slice(segments[next]);
                next += 1;
                if let Some(answer) = server.on_request(&frame, at(1), sink) {
                    answers.push(answer);
                    if answer[0] == 0x80 {
                        return answers;
                    }
                    block_size = usize::from(answer[2]);
                }
            }
        }
        let unused = (7 - data.len() % 7) % 7;
        let [c0, c1] = crc.to_le_bytes();
        answers.extend(server.on_request(&[0xC1 | (unused as u8) << 2, c0, c1, 0, 0, 0, 0, 0], at(2), sink));
        answers
    }

    #[test]
    fn a_block_download_to_a_stream_passes_on_whole_sub_blocks_and_the_last_piece_after_the_crc() {
        let (mut server, mut sink) = (SdoServer::<64>::new(Duration::from_millis(1000)), Sink::default());
        let data = image(1000);
        let answers = block(&mut server, &mut sink, &data, crc::update(0, &data));
        assert_eq!(answers.last(), Some(&[0xA1, 0, 0, 0, 0, 0, 0, 0]), "end confirmed: {answers:02x?}");
        assert_eq!(sink.streamed(), data);
        // A sub-block of 9 segments is 63 bytes: every piece but the last is one.
        let (last, whole) = sink.pieces.split_last().unwrap();
        assert!(whole.iter().all(|(_, piece, last)| piece.len() == 63 && !last));
        assert!(last.2);
        assert_eq!(sink.broken, 0);
    }

    #[test]
    fn a_block_download_to_a_stream_with_a_wrong_crc_is_aborted_without_its_last_piece() {
        let (mut server, mut sink) = (SdoServer::<64>::new(Duration::from_millis(1000)), Sink::default());
        let data = image(500);
        let answers = block(&mut server, &mut sink, &data, crc::update(0, &data) ^ 1);
        assert_eq!(answers.last(), Some(&[0x80, 0x50, 0x1F, 0x01, 0x04, 0x00, 0x04, 0x05]));
        assert!(sink.pieces.iter().all(|(_, _, last)| !last));
        assert_eq!(sink.broken, 1);
        assert!(server.is_idle());
    }

    #[test]
    fn a_refused_piece_aborts_the_transfer_with_its_code() {
        let (mut server, mut sink) = (SdoServer::<64>::new(Duration::from_millis(1000)), Sink::default());
        sink.refuse_at = Some(100);
        let data = image(500);
        let answers = block(&mut server, &mut sink, &data, crc::update(0, &data));
        assert_eq!(answers.last(), Some(&[0x80, 0x50, 0x1F, 0x01, 0x00, 0x00, 0x06, 0x06]));
        assert_eq!(sink.streamed(), data[..126]);
        assert_eq!(sink.broken, 1);
    }

    #[test]
    fn a_stream_broken_by_the_client_or_a_timeout_is_reported_once() {
        let (mut server, mut sink) = (SdoServer::<16>::new(Duration::from_millis(1000)), Sink::default());
        let [lo, hi, sub] = mux_bytes(STREAM);
        server.on_request(&[0x21, lo, hi, sub, 100, 0, 0, 0], at(0), &mut sink);
        server.on_request(&[0x00, 1, 2, 3, 4, 5, 6, 7], at(1), &mut sink);
        assert_eq!(server.on_request(&[0x80, lo, hi, sub, 0, 0, 0x04, 0x05], at(2), &mut sink), None);
        assert_eq!(sink.broken, 1);

        server.on_request(&[0x21, lo, hi, sub, 100, 0, 0, 0], at(10), &mut sink);
        assert_eq!(server.poll(at(500), &mut sink), None);
        assert_eq!(server.poll(at(1010), &mut sink), Some([0x80, lo, hi, sub, 0x00, 0x00, 0x04, 0x05]));
        assert_eq!(sink.broken, 2);
        assert_eq!(server.poll(at(3000), &mut sink), None);
        assert_eq!(sink.broken, 2);
    }

    #[test]
    fn a_stream_longer_than_its_indicated_size_is_refused() {
        let (mut server, mut sink) = (SdoServer::<16>::new(Duration::from_millis(1000)), Sink::default());
        let answers = segmented(&mut server, &mut sink, STREAM, &image(60), 50);
        assert_eq!(answers.last(), Some(&[0x80, 0x50, 0x1F, 0x01, 0x12, 0x00, 0x07, 0x06]));
        assert_eq!(sink.broken, 1);
        assert!(sink.pieces.iter().all(|(_, _, last)| !last));
    }
}

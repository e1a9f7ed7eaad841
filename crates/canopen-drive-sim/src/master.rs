//! A scripted CANopen master on the master port of a [`VirtualBus`], so that tests read like
//! bus traces: NMT commands, an SDO client, and raw request helpers.
//!
//! ## Timing
//!
//! The master owns the bus and moves its clock. After sending, it advances the bus by one
//! [step](Master::set_step) (default 1 ms) and looks at what arrived; it repeats until the
//! answer is there or the [timeout](Master::set_timeout) (default 500 ms of virtual time
//! without an answer) has passed. With the bus's default zero latency an answer carries the
//! timestamp of its request, and the master's next frame goes out one step later.
//!
//! ## SDO client (CiA 301 §7.2.4, default channel 0x600+id / 0x580+id)
//!
//! | service | client frames |
//! |---|---|
//! | [`sdo_upload`](Master::sdo_upload) | `40`; then `60`/`70` per segment if the server answers segmented |
//! | [`sdo_download`](Master::sdo_download) | `23`/`27`/`2B`/`2F` (1–4 bytes), else segmented |
//! | [`sdo_download_segmented`](Master::sdo_download_segmented) | `21` + size, segments `0t nnn c` |
//! | [`sdo_block_upload`](Master::sdo_block_upload) | `A4` (CRC, blksize, pst), `A3`, `A2` acks, `A1` |
//! | [`sdo_block_download`](Master::sdo_block_download) | `C6` (CRC, size), sub-blocks, `C1`–`DD` end |
//!
//! Block transfers always offer CRC. On a block upload the client acknowledges each sub-block
//! with the last sequence number received in order (segments out of order are ignored), so the
//! server repeats from there. On a block download the client repeats from the server's
//! `ackseq + 1`. Every response is checked (command specifier, multiplexer, toggle, sequence,
//! size, CRC); a wrong one ends the transfer with an abort frame from the client and
//! [`SdoError::Protocol`]. An abort from the server gives [`SdoError::Abort`]; no answer in
//! time gives [`SdoError::Timeout`] after the client sent abort 0x0504_0000.
//!
//! ```
//! use canopen_drive::{AbortCode, Config, Drive};
//! use canopen_drive_sim::{Master, SdoError, VirtualBus};
//!
//! let mut bus = VirtualBus::new();
//! bus.add_node(Drive::new(Config::new(5)).unwrap());
//! let mut master = Master::new(bus);
//! master.sdo_download(5, 0x1017, 0, &100u16.to_le_bytes()).unwrap();
//! assert_eq!(master.sdo_upload(5, 0x1017, 0).unwrap(), 100u16.to_le_bytes());
//! assert_eq!(master.sdo_upload(5, 0x1234, 0), Err(SdoError::Abort(AbortCode::ObjectDoesNotExist)));
//! ```

use std::fmt;

use canopen_drive::wire::crc;
use canopen_drive::wire::nmt::NmtCommand;
use canopen_drive::{AbortCode, CanFrame, Duration, Instant};
use embedded_can::Frame;

use crate::bus::{BusError, VirtualBus};

/// Default time the master advances the bus between looks at the master port.
pub const DEFAULT_STEP: Duration = Duration::from_millis(1);
/// Default virtual time the SDO client waits for an answer.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(500);

/// Why an SDO transfer failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoError {
    /// The server aborted the transfer with this code.
    Abort(AbortCode),
    /// No answer within the timeout; the client sent abort 0x0504_0000.
    Timeout,
    /// The server's answer did not fit the protocol; the client aborted with `code` (unless
    /// the server had already ended the transfer).
    Protocol {
        /// The abort code the client sent.
        code: AbortCode,
        /// The offending frame.
        frame: CanFrame,
    },
    /// The request cannot be sent: node-ID outside 1..=127, block size outside 1..=127, a
    /// value longer than 4 GiB, or more than 8 bytes of frame data.
    InvalidRequest,
    /// The bus stopped (see [`BusError`]).
    Bus(BusError),
}

impl From<BusError> for SdoError {
    fn from(error: BusError) -> Self {
        SdoError::Bus(error)
    }
}

impl fmt::Display for SdoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SdoError::Abort(code) => write!(f, "SDO aborted by the server: 0x{:08X}", code.code()),
            SdoError::Timeout => f.write_str("SDO timeout"),
            SdoError::Protocol { code, frame } => write!(
                f,
                "unexpected SDO response {:02X?}; client aborted with 0x{:08X}",
                frame.data(),
                code.code()
            ),
            SdoError::InvalidRequest => f.write_str("invalid SDO request"),
            SdoError::Bus(error) => write!(f, "bus: {error}"),
        }
    }
}

impl std::error::Error for SdoError {}

/// Index and sub-index of a transfer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Mux {
    index: u16,
    sub: u8,
}

impl Mux {
    fn matches(self, d: &[u8; 8]) -> bool {
        u16::from_le_bytes([d[1], d[2]]) == self.index && d[3] == self.sub
    }
}

/// The eight data bytes of a frame, zero-padded.
fn bytes8(frame: &CanFrame) -> [u8; 8] {
    let mut out = [0u8; 8];
    for (dst, src) in out.iter_mut().zip(frame.data()) {
        *dst = *src;
    }
    out
}

/// An initiate-style request: command, multiplexer, four bytes.
fn initiate(command: u8, mux: Mux, tail: [u8; 4]) -> [u8; 8] {
    let [lo, hi] = mux.index.to_le_bytes();
    [command, lo, hi, mux.sub, tail[0], tail[1], tail[2], tail[3]]
}

/// A segment-style request: command, then up to seven bytes.
fn segment(command: u8, data: &[u8]) -> [u8; 8] {
    let mut out = [command, 0, 0, 0, 0, 0, 0, 0];
    for (dst, src) in out.iter_mut().skip(1).zip(data) {
        *dst = *src;
    }
    out
}

fn u32_at(d: &[u8; 8]) -> u32 {
    u32::from_le_bytes([d[4], d[5], d[6], d[7]])
}

/// Data split into 7-byte segments; empty data is one empty segment.
fn segments(data: &[u8]) -> Vec<&[u8]> {
    if data.is_empty() {
        vec![&[]]
    } else {
        data.chunks(7).collect()
    }
}

/// The scripted master (see the [module docs](self)). It owns the bus; reach it with
/// [`bus`](Master::bus) / [`bus_mut`](Master::bus_mut).
#[derive(Debug)]
pub struct Master {
    bus: VirtualBus,
    step: Duration,
    timeout: Duration,
}

impl Master {
    /// A master on `bus`, with the default step and timeout.
    pub fn new(bus: VirtualBus) -> Self {
        Master { bus, step: DEFAULT_STEP, timeout: DEFAULT_TIMEOUT }
    }

    /// The bus.
    pub fn bus(&self) -> &VirtualBus {
        &self.bus
    }

    /// The bus, mutable (add nodes or fault rules, inspect nodes).
    pub fn bus_mut(&mut self) -> &mut VirtualBus {
        &mut self.bus
    }

    /// Gives the bus back.
    pub fn into_bus(self) -> VirtualBus {
        self.bus
    }

    /// Sets how far the master advances the bus between looks at the master port.
    pub fn set_step(&mut self, step: Duration) {
        self.step = step;
    }

    /// How far the master advances the bus between looks at the master port.
    pub fn step(&self) -> Duration {
        self.step
    }

    /// Sets how long the SDO client waits for an answer.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// How long the SDO client waits for an answer.
    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    /// The virtual time.
    pub fn now(&self) -> Instant {
        self.bus.now()
    }

    /// Runs the bus for `span`.
    pub fn advance(&mut self, span: Duration) -> Result<(), BusError> {
        self.bus.advance(span)
    }

    /// Puts `frame` on the bus now, without running it.
    pub fn send(&mut self, frame: CanFrame) {
        self.bus.send(frame);
    }

    /// Sends `frame`, runs the bus for one step and returns every frame the master port
    /// received meanwhile (including any received earlier and not yet taken).
    pub fn request(&mut self, frame: CanFrame) -> Result<Vec<CanFrame>, BusError> {
        self.bus.send(frame);
        self.bus.advance(self.step)?;
        Ok(self.bus.drain_received_frames())
    }

    /// Sends `data` on node `node`'s SDO request channel (0x600+id), runs the bus for one
    /// step and returns the frames received on its response channel (0x580+id); other frames
    /// stay in [`VirtualBus::received`].
    pub fn sdo_request(&mut self, node: u8, data: &[u8]) -> Result<Vec<CanFrame>, SdoError> {
        let frame = CanFrame::new_standard(request_id(node)?, data).ok_or(SdoError::InvalidRequest)?;
        self.bus.send(frame);
        self.bus.advance(self.step)?;
        let response = response_id(node)?;
        let mut out = Vec::new();
        while let Some(r) = self.bus.take_received(|r| r.frame.standard_id() == Some(response)) {
            out.push(r.frame);
        }
        Ok(out)
    }

    /// Sends NMT node control `command` to `node` (0 = all nodes) and runs the bus one step.
    pub fn nmt(&mut self, command: NmtCommand, node: u8) -> Result<(), BusError> {
        if let Some(frame) = CanFrame::new_standard(0x000, &[command.code(), node]) {
            self.bus.send(frame);
        }
        self.bus.advance(self.step)
    }

    /// Reads an entry; the server chooses expedited or segmented transfer.
    pub fn sdo_upload(&mut self, node: u8, index: u16, sub: u8) -> Result<Vec<u8>, SdoError> {
        self.upload(node, Mux { index, sub }, false)
    }

    /// Reads an entry and insists on a segmented transfer: an expedited answer is returned as
    /// [`SdoError::Protocol`] (without an abort: the server has finished).
    pub fn sdo_upload_segmented(&mut self, node: u8, index: u16, sub: u8) -> Result<Vec<u8>, SdoError> {
        self.upload(node, Mux { index, sub }, true)
    }

    /// Writes an entry: expedited for 1 to 4 bytes, segmented otherwise.
    pub fn sdo_download(&mut self, node: u8, index: u16, sub: u8, data: &[u8]) -> Result<(), SdoError> {
        if (1..=4).contains(&data.len()) {
            self.download_expedited(node, Mux { index, sub }, data)
        } else {
            self.download_segmented(node, Mux { index, sub }, data)
        }
    }

    /// Writes an entry with a segmented transfer, whatever its length.
    pub fn sdo_download_segmented(
        &mut self,
        node: u8,
        index: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<(), SdoError> {
        self.download_segmented(node, Mux { index, sub }, data)
    }

    /// Reads an entry with a block upload of `block_size` (1..=127) segments per sub-block, CRC
    /// on, no protocol switch (pst = 0).
    pub fn sdo_block_upload(
        &mut self,
        node: u8,
        index: u16,
        sub: u8,
        block_size: u8,
    ) -> Result<Vec<u8>, SdoError> {
        self.block_upload(node, Mux { index, sub }, block_size, 0)
    }

    /// Like [`sdo_block_upload`](Self::sdo_block_upload) with a protocol switch threshold:
    /// the server may answer a value of at most `pst` bytes with a normal upload, which the
    /// client then follows.
    pub fn sdo_block_upload_pst(
        &mut self,
        node: u8,
        index: u16,
        sub: u8,
        block_size: u8,
        pst: u8,
    ) -> Result<Vec<u8>, SdoError> {
        self.block_upload(node, Mux { index, sub }, block_size, pst)
    }

    /// Writes an entry with a block download, CRC on and the size indicated. The number of
    /// segments per sub-block is the server's choice (its initiate response and every
    /// acknowledgement name it), so the client has no block size parameter.
    pub fn sdo_block_download(&mut self, node: u8, index: u16, sub: u8, data: &[u8]) -> Result<(), SdoError> {
        self.block_download(node, Mux { index, sub }, data)
    }

    fn upload(&mut self, node: u8, mux: Mux, segmented_only: bool) -> Result<Vec<u8>, SdoError> {
        self.discard_stale(node)?;
        self.sdo_send(node, initiate(0x40, mux, [0; 4]))?;
        let response = self.sdo_wait(node, mux)?;
        self.upload_after_initiate(node, mux, response, segmented_only)
    }

    /// Continues an upload after the server's initiate response (also after a block upload
    /// the server switched to a normal upload).
    fn upload_after_initiate(
        &mut self,
        node: u8,
        mux: Mux,
        response: CanFrame,
        segmented_only: bool,
    ) -> Result<Vec<u8>, SdoError> {
        let d = bytes8(&response);
        if d[0] & 0xE0 != 0x40 || !mux.matches(&d) {
            return Err(self.protocol(node, mux, AbortCode::InvalidCommandSpecifier, response));
        }
        let expedited = d[0] & 0x02 != 0;
        let sized = d[0] & 0x01 != 0;
        if expedited {
            if segmented_only {
                return Err(SdoError::Protocol { code: AbortCode::InvalidCommandSpecifier, frame: response });
            }
            let len = if sized { 4 - usize::from((d[0] >> 2) & 0x03) } else { 4 };
            return Ok(d.iter().skip(4).take(len).copied().collect());
        }
        let size = sized.then(|| u32_at(&d) as usize);
        let mut data = Vec::new();
        let mut toggle = false;
        loop {
            self.sdo_send(node, segment(0x60 | (u8::from(toggle) << 4), &[]))?;
            let frame = self.sdo_wait(node, mux)?;
            let d = bytes8(&frame);
            if d[0] & 0xE0 != 0x00 {
                return Err(self.protocol(node, mux, AbortCode::InvalidCommandSpecifier, frame));
            }
            if (d[0] & 0x10 != 0) != toggle {
                return Err(self.protocol(node, mux, AbortCode::ToggleBitNotAlternated, frame));
            }
            let len = 7 - usize::from((d[0] >> 1) & 0x07);
            data.extend(d.iter().skip(1).take(len));
            if size.is_some_and(|s| data.len() > s) {
                return Err(self.protocol(node, mux, AbortCode::LengthTooHigh, frame));
            }
            if d[0] & 0x01 != 0 {
                if size.is_some_and(|s| data.len() < s) {
                    return Err(self.protocol(node, mux, AbortCode::LengthTooLow, frame));
                }
                return Ok(data);
            }
            toggle = !toggle;
        }
    }

    fn download_expedited(&mut self, node: u8, mux: Mux, data: &[u8]) -> Result<(), SdoError> {
        let mut tail = [0u8; 4];
        for (dst, src) in tail.iter_mut().zip(data) {
            *dst = *src;
        }
        let unused = 4u8.saturating_sub(u8::try_from(data.len()).unwrap_or(4));
        self.discard_stale(node)?;
        self.sdo_send(node, initiate(0x23 | (unused << 2), mux, tail))?;
        let response = self.sdo_wait(node, mux)?;
        self.expect_download_initiated(node, mux, response)
    }

    fn expect_download_initiated(&mut self, node: u8, mux: Mux, response: CanFrame) -> Result<(), SdoError> {
        let d = bytes8(&response);
        if d[0] != 0x60 || !mux.matches(&d) {
            return Err(self.protocol(node, mux, AbortCode::InvalidCommandSpecifier, response));
        }
        Ok(())
    }

    fn download_segmented(&mut self, node: u8, mux: Mux, data: &[u8]) -> Result<(), SdoError> {
        let size = u32::try_from(data.len()).map_err(|_| SdoError::InvalidRequest)?;
        self.discard_stale(node)?;
        self.sdo_send(node, initiate(0x21, mux, size.to_le_bytes()))?;
        let response = self.sdo_wait(node, mux)?;
        self.expect_download_initiated(node, mux, response)?;
        let parts = segments(data);
        let mut toggle = false;
        for (i, part) in parts.iter().enumerate() {
            let last = i + 1 == parts.len();
            let unused = 7 - part.len() as u8;
            let command = (u8::from(toggle) << 4) | (unused << 1) | u8::from(last);
            self.sdo_send(node, segment(command, part))?;
            let frame = self.sdo_wait(node, mux)?;
            let d = bytes8(&frame);
            if d[0] & 0xE0 != 0x20 {
                return Err(self.protocol(node, mux, AbortCode::InvalidCommandSpecifier, frame));
            }
            if (d[0] & 0x10 != 0) != toggle {
                return Err(self.protocol(node, mux, AbortCode::ToggleBitNotAlternated, frame));
            }
            toggle = !toggle;
        }
        Ok(())
    }

    fn block_upload(&mut self, node: u8, mux: Mux, block_size: u8, pst: u8) -> Result<Vec<u8>, SdoError> {
        if !(1..=127).contains(&block_size) {
            return Err(SdoError::InvalidRequest);
        }
        self.discard_stale(node)?;
        // ccs 5, cc = 1 (CRC), cs 0: initiate.
        self.sdo_send(node, initiate(0xA4, mux, [block_size, pst, 0, 0]))?;
        let response = self.sdo_wait(node, mux)?;
        let d = bytes8(&response);
        if pst > 0 && d[0] & 0xE0 == 0x40 {
            return self.upload_after_initiate(node, mux, response, false);
        }
        if d[0] & 0xE1 != 0xC0 || !mux.matches(&d) {
            return Err(self.protocol(node, mux, AbortCode::InvalidCommandSpecifier, response));
        }
        let server_crc = d[0] & 0x04 != 0;
        let size = (d[0] & 0x02 != 0).then(|| u32_at(&d) as usize);
        self.sdo_send(node, segment(0xA3, &[]))?;

        let mut data = Vec::new();
        // Last sequence number received in order in the current sub-block.
        let mut in_order = 0u8;
        // The segment with c = 1 arrived in order: only the end frame is missing.
        let mut complete = false;
        // The frame that ended the previous sub-block (a late duplicate of it is ignored).
        let mut previous_end: Option<[u8; 8]> = None;
        loop {
            for frame in self.sdo_wait_all(node, mux)? {
                let d = bytes8(&frame);
                if complete {
                    if d[0] & 0xE3 == 0xC1 {
                        return self.finish_block_upload(node, mux, frame, data, size, server_crc);
                    }
                    // A late copy of a segment already acknowledged.
                    continue;
                }
                if in_order == 0 && previous_end == Some(d) {
                    continue;
                }
                let seq = d[0] & 0x7F;
                let last = d[0] & 0x80 != 0;
                if seq == in_order + 1 {
                    data.extend(d.iter().skip(1));
                    in_order = seq;
                    complete = last;
                }
                if seq >= block_size || last {
                    // ccs 5, cs 2: acknowledge the last segment received in order.
                    self.sdo_send(node, segment(0xA2, &[in_order, block_size]))?;
                    previous_end = Some(d);
                    in_order = 0;
                }
            }
        }
    }

    fn finish_block_upload(
        &mut self,
        node: u8,
        mux: Mux,
        end: CanFrame,
        mut data: Vec<u8>,
        size: Option<usize>,
        server_crc: bool,
    ) -> Result<Vec<u8>, SdoError> {
        let d = bytes8(&end);
        let unused = usize::from((d[0] >> 2) & 0x07);
        data.truncate(data.len().saturating_sub(unused));
        match size {
            Some(s) if data.len() > s => return Err(self.protocol(node, mux, AbortCode::LengthTooHigh, end)),
            Some(s) if data.len() < s => return Err(self.protocol(node, mux, AbortCode::LengthTooLow, end)),
            _ => {}
        }
        if server_crc && crc::update(0, &data) != u16::from_le_bytes([d[1], d[2]]) {
            return Err(self.protocol(node, mux, AbortCode::CrcError, end));
        }
        // ccs 5, cs 1: end confirmed.
        self.sdo_send(node, segment(0xA1, &[]))?;
        self.bus.settle()?;
        Ok(data)
    }

    fn block_download(&mut self, node: u8, mux: Mux, data: &[u8]) -> Result<(), SdoError> {
        let size = u32::try_from(data.len()).map_err(|_| SdoError::InvalidRequest)?;
        self.discard_stale(node)?;
        // ccs 6, cc = 1 (CRC), s = 1 (size), cs 0: initiate.
        self.sdo_send(node, initiate(0xC6, mux, size.to_le_bytes()))?;
        let response = self.sdo_wait(node, mux)?;
        let d = bytes8(&response);
        if d[0] & 0xE3 != 0xA0 || !mux.matches(&d) {
            return Err(self.protocol(node, mux, AbortCode::InvalidCommandSpecifier, response));
        }
        let server_crc = d[0] & 0x04 != 0;
        let mut block_size = d[4];
        if !(1..=127).contains(&block_size) {
            return Err(self.protocol(node, mux, AbortCode::InvalidBlockSize, response));
        }
        let parts = segments(data);
        // Segments the server has acknowledged.
        let mut acked = 0usize;
        while acked < parts.len() {
            let count = usize::from(block_size).min(parts.len() - acked);
            for (k, part) in parts.iter().enumerate().skip(acked).take(count) {
                let seq = (k - acked + 1) as u8;
                let last = k + 1 == parts.len();
                self.sdo_send(node, segment(seq | if last { 0x80 } else { 0 }, part))?;
            }
            let frame = self.sdo_wait(node, mux)?;
            let d = bytes8(&frame);
            if d[0] & 0xE3 != 0xA2 {
                return Err(self.protocol(node, mux, AbortCode::InvalidCommandSpecifier, frame));
            }
            let ack_seq = usize::from(d[1]);
            if ack_seq > count {
                return Err(self.protocol(node, mux, AbortCode::InvalidSequenceNumber, frame));
            }
            acked += ack_seq;
            block_size = d[2];
            if !(1..=127).contains(&block_size) {
                return Err(self.protocol(node, mux, AbortCode::InvalidBlockSize, frame));
            }
        }
        let unused = (parts.len() * 7 - data.len()) as u8;
        let crc = if server_crc { crc::update(0, data) } else { 0 };
        let [lo, hi] = crc.to_le_bytes();
        // ccs 6, cs 1: end, with the unused bytes of the last segment and the CRC.
        self.sdo_send(node, segment(0xC1 | (unused << 2), &[lo, hi]))?;
        let frame = self.sdo_wait(node, mux)?;
        if bytes8(&frame)[0] & 0xE3 != 0xA1 {
            return Err(self.protocol(node, mux, AbortCode::InvalidCommandSpecifier, frame));
        }
        Ok(())
    }

    /// Forgets SDO responses of `node` left over from earlier raw requests.
    fn discard_stale(&mut self, node: u8) -> Result<(), SdoError> {
        let response = response_id(node)?;
        while self.bus.take_received(|r| r.frame.standard_id() == Some(response)).is_some() {}
        Ok(())
    }

    fn sdo_send(&mut self, node: u8, data: [u8; 8]) -> Result<(), SdoError> {
        let frame = CanFrame::new_standard(request_id(node)?, &data).ok_or(SdoError::InvalidRequest)?;
        self.bus.send(frame);
        Ok(())
    }

    /// Waits for the next response of `node`; a server abort becomes [`SdoError::Abort`].
    fn sdo_wait(&mut self, node: u8, mux: Mux) -> Result<CanFrame, SdoError> {
        let frames = self.wait(node, mux, false)?;
        frames.into_iter().next().ok_or(SdoError::Timeout)
    }

    /// Waits for responses of `node` and takes every one that arrived in the same step.
    fn sdo_wait_all(&mut self, node: u8, mux: Mux) -> Result<Vec<CanFrame>, SdoError> {
        self.wait(node, mux, true)
    }

    fn wait(&mut self, node: u8, mux: Mux, all: bool) -> Result<Vec<CanFrame>, SdoError> {
        let response = response_id(node)?;
        let start = self.bus.now();
        loop {
            self.bus.advance(self.step)?;
            let mut frames = Vec::new();
            while let Some(r) = self
                .bus
                .take_received(|r| r.frame.standard_id() == Some(response) && !r.frame.is_remote_frame())
            {
                frames.push(r.frame);
                if !all {
                    break;
                }
            }
            if let Some(abort) = frames.iter().map(bytes8).find(|d| d[0] == 0x80) {
                return Err(SdoError::Abort(AbortCode::from_code(u32_at(&abort))));
            }
            if !frames.is_empty() {
                return Ok(frames);
            }
            if self.bus.now() - start >= self.timeout {
                self.send_abort(node, mux, AbortCode::Timeout)?;
                return Err(SdoError::Timeout);
            }
        }
    }

    fn send_abort(&mut self, node: u8, mux: Mux, code: AbortCode) -> Result<(), SdoError> {
        self.sdo_send(node, initiate(0x80, mux, code.code().to_le_bytes()))?;
        self.bus.settle()?;
        Ok(())
    }

    /// Aborts the transfer because of `frame` and returns the error to report.
    fn protocol(&mut self, node: u8, mux: Mux, code: AbortCode, frame: CanFrame) -> SdoError {
        match self.send_abort(node, mux, code) {
            Ok(()) => SdoError::Protocol { code, frame },
            Err(error) => error,
        }
    }
}

fn check_node(node: u8) -> Result<u16, SdoError> {
    if (1..=127).contains(&node) {
        Ok(u16::from(node))
    } else {
        Err(SdoError::InvalidRequest)
    }
}

/// COB-ID of the default SDO server's requests (client → server).
fn request_id(node: u8) -> Result<u16, SdoError> {
    Ok(0x600 + check_node(node)?)
}

/// COB-ID of the default SDO server's responses (server → client).
fn response_id(node: u8) -> Result<u16, SdoError> {
    Ok(0x580 + check_node(node)?)
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;

    use super::*;
    use crate::bus::{Node, Port};
    use crate::fault::FaultRule;

    fn frame(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::new_standard(id, data).unwrap()
    }

    /// Answers the n-th request on 0x605 with the n-th list of replies on 0x585, and records
    /// every request.
    struct Scripted {
        replies: VecDeque<Vec<Vec<u8>>>,
        requests: Vec<Vec<u8>>,
        tx: VecDeque<CanFrame>,
    }

    impl Scripted {
        fn new(replies: Vec<Vec<Vec<u8>>>) -> Self {
            Scripted { replies: replies.into(), requests: Vec::new(), tx: VecDeque::new() }
        }
    }

    impl Node for Scripted {
        fn on_frame(&mut self, f: &CanFrame, _: Instant) {
            if f.standard_id() == Some(0x605) {
                self.requests.push(f.data().to_vec());
                for reply in self.replies.pop_front().unwrap_or_default() {
                    self.tx.push_back(frame(0x585, &reply));
                }
            }
        }
        fn poll(&mut self, _: Instant) -> Option<Instant> {
            None
        }
        fn pop_tx(&mut self) -> Option<CanFrame> {
            self.tx.pop_front()
        }
    }

    fn scripted(replies: Vec<Vec<Vec<u8>>>) -> (Master, crate::bus::NodeHandle) {
        let mut bus = VirtualBus::new();
        let node = bus.add_named_node("server", Scripted::new(replies));
        (Master::new(bus), node)
    }

    fn requests(master: &Master, node: crate::bus::NodeHandle) -> Vec<Vec<u8>> {
        master.bus().node::<Scripted>(node).unwrap().requests.clone()
    }

    /// A block-download server: asks for `block_sizes[0]` segments, then cycles through the
    /// list on every acknowledgement.
    struct BlockSink {
        block_sizes: Vec<u8>,
        acks: usize,
        receiving: bool,
        in_order: u8,
        done: bool,
        buf: Vec<u8>,
        stored: Option<Vec<u8>>,
        tx: VecDeque<CanFrame>,
    }

    impl BlockSink {
        fn new(block_sizes: &[u8]) -> Self {
            BlockSink {
                block_sizes: block_sizes.to_vec(),
                acks: 0,
                receiving: false,
                in_order: 0,
                done: false,
                buf: Vec::new(),
                stored: None,
                tx: VecDeque::new(),
            }
        }
        fn block_size(&self) -> u8 {
            self.block_sizes[self.acks % self.block_sizes.len()]
        }
        fn reply(&mut self, data: [u8; 8]) {
            self.tx.push_back(frame(0x585, &data));
        }
    }

    impl Node for BlockSink {
        fn on_frame(&mut self, f: &CanFrame, _: Instant) {
            if f.standard_id() != Some(0x605) {
                return;
            }
            let d = bytes8(f);
            if self.receiving && !self.done {
                let seq = d[0] & 0x7F;
                if seq == self.in_order + 1 {
                    self.buf.extend(&d[1..]);
                    self.in_order = seq;
                    self.done = d[0] & 0x80 != 0;
                }
                if seq >= self.block_size() || d[0] & 0x80 != 0 {
                    let ack = [0xA2, self.in_order, 0, 0, 0, 0, 0, 0];
                    self.acks += 1;
                    let mut ack = ack;
                    ack[2] = self.block_size();
                    self.reply(ack);
                    self.in_order = 0;
                }
            } else if d[0] == 0xC6 {
                self.receiving = true;
                self.reply([0xA4, d[1], d[2], d[3], self.block_size(), 0, 0, 0]);
            } else if self.done && d[0] & 0xE3 == 0xC1 {
                let unused = usize::from((d[0] >> 2) & 7);
                self.buf.truncate(self.buf.len() - unused);
                if crc::update(0, &self.buf) == u16::from_le_bytes([d[1], d[2]]) {
                    self.stored = Some(std::mem::take(&mut self.buf));
                    self.reply([0xA1, 0, 0, 0, 0, 0, 0, 0]);
                } else {
                    self.reply([0x80, 0, 0x20, 0, 0x04, 0x00, 0x04, 0x05]);
                }
                self.receiving = false;
                self.done = false;
            }
        }
        fn poll(&mut self, _: Instant) -> Option<Instant> {
            None
        }
        fn pop_tx(&mut self) -> Option<CanFrame> {
            self.tx.pop_front()
        }
    }

    fn sink(block_sizes: &[u8]) -> (Master, crate::bus::NodeHandle) {
        let mut bus = VirtualBus::new();
        let node = bus.add_named_node("sink", BlockSink::new(block_sizes));
        (Master::new(bus), node)
    }

    fn stored(master: &Master, node: crate::bus::NodeHandle) -> Option<Vec<u8>> {
        master.bus().node::<BlockSink>(node).unwrap().stored.clone()
    }

    fn master_frames(master: &Master) -> Vec<Vec<u8>> {
        master
            .bus()
            .trace()
            .iter()
            .filter(|r| r.from == Port::Master)
            .map(|r| r.frame.data().to_vec())
            .collect()
    }

    #[test]
    fn block_download_sends_sub_blocks_of_the_servers_size() {
        let (mut master, node) = sink(&[4]);
        let data: Vec<u8> = (0..40).collect();
        master.sdo_block_download(5, 0x2000, 1, &data).unwrap();
        assert_eq!(stored(&master, node), Some(data.clone()));
        let sent = master_frames(&master);
        assert_eq!(sent[0], [0xC6, 0x00, 0x20, 0x01, 40, 0, 0, 0]);
        let heads: Vec<u8> = sent[1..7].iter().map(|d| d[0]).collect();
        assert_eq!(heads, [1, 2, 3, 4, 1, 0x82]);
        assert_eq!(sent[6], [0x82, 35, 36, 37, 38, 39, 0, 0]);
        // 40 = 5·7 + 5: two bytes of the last segment are unused.
        let [lo, hi] = crc::update(0, &data).to_le_bytes();
        assert_eq!(sent[7], [0xC1 | (2 << 2), lo, hi, 0, 0, 0, 0, 0]);
        assert_eq!(sent.len(), 8);
    }

    #[test]
    fn block_download_repeats_from_ackseq_after_a_lost_segment() {
        let (mut master, node) = sink(&[4]);
        // Lose the second segment of the first sub-block.
        let rule = master.bus_mut().add_fault(
            FaultRule::drop().from_port(Port::Master).when(|f, _| f.data().first() == Some(&0x02)).times(1),
        );
        let data: Vec<u8> = (100..150).collect();
        master.sdo_block_download(5, 0x2000, 1, &data).unwrap();
        assert_eq!(stored(&master, node), Some(data.clone()));
        assert_eq!(master.bus().fault(rule).unwrap().applied(), 1);
        let sent = master_frames(&master);
        // After the ack naming segment 1, the next sub-block starts with the bytes of
        // segment 2, numbered 1 again.
        let repeat = sent.iter().skip(5).find(|d| d[0] == 0x01).unwrap();
        assert_eq!(repeat[1..], data[7..14]);
        let acks: Vec<(u8, u8)> = master
            .bus()
            .trace()
            .iter()
            .filter(|r| r.frame.data().first() == Some(&0xA2))
            .map(|r| (r.frame.data()[1], r.frame.data()[2]))
            .collect();
        // 50 bytes = 8 segments: [1 ✗ 3 4] → ack 1; [2..5] → 4; [6 7 8] → 3.
        assert_eq!(acks, [(1, 4), (4, 4), (3, 4)]);
    }

    #[test]
    fn block_download_follows_a_changing_block_size() {
        let (mut master, node) = sink(&[3, 1, 2]);
        let data: Vec<u8> = (0..=255).collect();
        master.sdo_block_download(5, 0x2000, 0, &data).unwrap();
        assert_eq!(stored(&master, node), Some(data));
        let (mut master, node) = sink(&[127]);
        master.sdo_block_download(5, 0x2000, 0, &[]).unwrap();
        assert_eq!(stored(&master, node), Some(Vec::new()));
        let sent = master_frames(&master);
        assert_eq!(sent[1][0], 0x81);
        assert_eq!(sent[2][0], 0xC1 | (7 << 2));
    }

    #[test]
    fn expedited_upload_without_size_takes_four_bytes() {
        let (mut master, node) = scripted(vec![vec![vec![0x42, 0x00, 0x10, 0x00, 1, 2, 3, 4]]]);
        assert_eq!(master.sdo_upload(5, 0x1000, 0).unwrap(), [1, 2, 3, 4]);
        assert_eq!(requests(&master, node), [vec![0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]]);
        assert_eq!(master.now(), Instant::from_millis(1));
    }

    #[test]
    fn segmented_upload_checks_the_toggle_bit() {
        let (mut master, node) = scripted(vec![
            vec![vec![0x41, 0x08, 0x10, 0x00, 10, 0, 0, 0]],
            vec![vec![0x00, 1, 2, 3, 4, 5, 6, 7]],
            vec![vec![0x05, 8, 9, 10, 0, 0, 0, 0]], // toggle 0 again: wrong
        ]);
        let error = master.sdo_upload(5, 0x1008, 0).unwrap_err();
        assert!(
            matches!(error, SdoError::Protocol { code: AbortCode::ToggleBitNotAlternated, .. }),
            "{error:?}"
        );
        let sent = requests(&master, node);
        assert_eq!(sent[1], [0x60, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(sent[2], [0x70, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(sent[3], [0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05]);
    }

    #[test]
    fn segmented_transfers_both_ways() {
        let (mut master, node) = scripted(vec![
            vec![vec![0x41, 0x08, 0x10, 0x00, 10, 0, 0, 0]],
            vec![vec![0x00, 1, 2, 3, 4, 5, 6, 7]],
            vec![vec![0x19, 8, 9, 10, 0, 0, 0, 0]],
        ]);
        assert_eq!(master.sdo_upload_segmented(5, 0x1008, 0).unwrap(), (1..=10).collect::<Vec<u8>>());
        assert_eq!(requests(&master, node).len(), 3);

        let (mut master, node) = scripted(vec![
            vec![vec![0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0]],
            vec![vec![0x20, 0, 0, 0, 0, 0, 0, 0]],
            vec![vec![0x30, 0, 0, 0, 0, 0, 0, 0]],
        ]);
        master.sdo_download(5, 0x2000, 0, b"hello world").unwrap();
        let sent = requests(&master, node);
        assert_eq!(sent[0], [0x21, 0x00, 0x20, 0x00, 11, 0, 0, 0]);
        assert_eq!(sent[1], *b"\x00hello w");
        assert_eq!(sent[2], [0x10 | (3 << 1) | 1, b'o', b'r', b'l', b'd', 0, 0, 0]);
    }

    #[test]
    fn upload_segmented_refuses_an_expedited_answer() {
        let (mut master, node) = scripted(vec![vec![vec![0x4B, 0x17, 0x10, 0x00, 1, 2, 0, 0]]]);
        let error = master.sdo_upload_segmented(5, 0x1017, 0).unwrap_err();
        assert!(matches!(error, SdoError::Protocol { .. }));
        // No abort: the server had finished.
        assert_eq!(requests(&master, node).len(), 1);
    }

    #[test]
    fn expedited_download_command_bytes() {
        let replies = (0..4).map(|_| vec![vec![0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]]).collect();
        let (mut master, node) = scripted(replies);
        for data in [&[1u8][..], &[1, 2], &[1, 2, 3], &[1, 2, 3, 4]] {
            master.sdo_download(5, 0x1017, 0, data).unwrap();
        }
        let heads: Vec<u8> = requests(&master, node).iter().map(|d| d[0]).collect();
        assert_eq!(heads, [0x2F, 0x2B, 0x27, 0x23]);
    }

    #[test]
    fn wrong_multiplexer_is_a_protocol_error() {
        let (mut master, _) = scripted(vec![vec![vec![0x60, 0x18, 0x10, 0x00, 0, 0, 0, 0]]]);
        let error = master.sdo_download(5, 0x1017, 0, &[1, 0]).unwrap_err();
        assert!(matches!(error, SdoError::Protocol { code: AbortCode::InvalidCommandSpecifier, .. }));
    }

    #[test]
    fn silence_times_out_with_an_abort() {
        let (mut master, node) = scripted(vec![]);
        master.set_timeout(Duration::from_millis(20));
        assert_eq!(master.sdo_upload(5, 0x1000, 0), Err(SdoError::Timeout));
        assert_eq!(master.now(), Instant::from_millis(20));
        assert_eq!(requests(&master, node)[1], [0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05]);
        assert_eq!(master.timeout(), Duration::from_millis(20));
    }

    #[test]
    fn server_abort_is_reported_with_its_code() {
        let (mut master, _) = scripted(vec![vec![vec![0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06]]]);
        assert_eq!(
            master.sdo_download(5, 0x1000, 0, &[0; 4]),
            Err(SdoError::Abort(AbortCode::WriteOfReadOnly))
        );
    }

    fn block_upload_script(data: &[u8], segments: Vec<Vec<u8>>, crc: u16) -> Vec<Vec<Vec<u8>>> {
        let n = data.len() as u8;
        let unused = ((7 - data.len() % 7) % 7) as u8;
        let [lo, hi] = crc.to_le_bytes();
        vec![
            vec![vec![0xC6, 0x08, 0x10, 0x00, n, 0, 0, 0]],
            segments,
            vec![vec![0xC1 | (unused << 2), lo, hi, 0, 0, 0, 0, 0]],
            vec![],
        ]
    }

    #[test]
    fn block_upload_checks_the_crc() {
        let data = b"0123456789";
        let segments = vec![b"\x010123456".to_vec(), b"\x82789\0\0\0\0".to_vec()];
        let good = crc::update(0, data);
        let (mut master, node) = scripted(block_upload_script(data, segments.clone(), good));
        assert_eq!(master.sdo_block_upload(5, 0x1008, 0, 2).unwrap(), data);
        let sent = requests(&master, node);
        assert_eq!(sent[0], [0xA4, 0x08, 0x10, 0x00, 2, 0, 0, 0]);
        assert_eq!(sent[1], [0xA3, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(sent[2], [0xA2, 2, 2, 0, 0, 0, 0, 0]);
        assert_eq!(sent[3], [0xA1, 0, 0, 0, 0, 0, 0, 0]);

        let (mut master, node) = scripted(block_upload_script(data, segments, good ^ 1));
        let error = master.sdo_block_upload(5, 0x1008, 0, 2).unwrap_err();
        assert!(matches!(error, SdoError::Protocol { code: AbortCode::CrcError, .. }), "{error:?}");
        assert_eq!(requests(&master, node)[3], [0x80, 0x08, 0x10, 0x00, 0x04, 0x00, 0x04, 0x05]);
    }

    #[test]
    fn block_upload_acknowledges_the_last_segment_in_order() {
        // Segment 2 of 3 is missing: the client acknowledges 1 and gets 2 and 3 again as 1, 2.
        let data = b"abcdefghijklmnopqrst";
        let script = vec![
            vec![vec![0xC6, 0x08, 0x10, 0x00, 20, 0, 0, 0]],
            vec![b"\x01abcdefg".to_vec(), b"\x83opqrst\0".to_vec()],
            vec![b"\x01hijklmn".to_vec(), b"\x82opqrst\0".to_vec()],
            vec![vec![0xC1 | (1 << 2), 0, 0, 0, 0, 0, 0, 0]],
        ];
        let mut script = script;
        let [lo, hi] = crc::update(0, data).to_le_bytes();
        script[3][0][1] = lo;
        script[3][0][2] = hi;
        let (mut master, node) = scripted(script);
        assert_eq!(master.sdo_block_upload(5, 0x1008, 0, 3).unwrap(), data);
        let sent = requests(&master, node);
        assert_eq!(sent[2], [0xA2, 1, 3, 0, 0, 0, 0, 0]);
        assert_eq!(sent[3], [0xA2, 2, 3, 0, 0, 0, 0, 0]);
        assert_eq!(sent[4][0], 0xA1);
    }

    #[test]
    fn block_upload_follows_a_protocol_switch() {
        let (mut master, _) = scripted(vec![vec![vec![0x4F, 0x01, 0x10, 0x00, 0x07, 0, 0, 0]]]);
        assert_eq!(master.sdo_block_upload_pst(5, 0x1001, 0, 127, 4).unwrap(), [7]);
    }

    #[test]
    fn invalid_requests_are_refused_before_sending() {
        let (mut master, _) = scripted(vec![]);
        assert_eq!(master.sdo_upload(0, 0x1000, 0), Err(SdoError::InvalidRequest));
        assert_eq!(master.sdo_upload(128, 0x1000, 0), Err(SdoError::InvalidRequest));
        assert_eq!(master.sdo_block_upload(5, 0x1000, 0, 0), Err(SdoError::InvalidRequest));
        assert_eq!(master.sdo_block_upload(5, 0x1000, 0, 128), Err(SdoError::InvalidRequest));
        assert_eq!(master.sdo_request(5, &[0; 9]), Err(SdoError::InvalidRequest));
        assert!(master.bus().trace().is_empty());
    }

    #[test]
    fn raw_helpers_return_what_came_back() {
        let (mut master, _) = scripted(vec![vec![vec![0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]]]);
        let answer = master.sdo_request(5, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]).unwrap();
        assert_eq!(answer, [frame(0x585, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])]);
        assert_eq!(master.request(frame(0x605, &[0x40])).unwrap(), []);
        master.nmt(NmtCommand::Start, 5).unwrap();
        let last = master.bus().trace().last().cloned().unwrap();
        assert_eq!((last.frame, last.time), (frame(0x000, &[0x01, 0x05]), Instant::from_millis(2)));
        master.set_step(Duration::from_millis(10));
        assert_eq!(master.step(), Duration::from_millis(10));
        master.advance(Duration::from_millis(5)).unwrap();
        assert_eq!(master.into_bus().now(), Instant::from_millis(8));
    }

    #[test]
    fn errors_display() {
        assert_eq!(
            SdoError::Abort(AbortCode::ObjectDoesNotExist).to_string(),
            "SDO aborted by the server: 0x06020000"
        );
        assert_eq!(SdoError::Timeout.to_string(), "SDO timeout");
        let e = SdoError::Protocol { code: AbortCode::CrcError, frame: frame(0x585, &[0xC1]) };
        assert!(e.to_string().contains("0x05040004"));
    }
}

//! A bootloader node: the CiA 301 services a master needs to replace the program (CiA 302-3),
//! and nothing of the drive.
//!
//! [`Bootloader`] answers with the same identity as the application (1000h, 1008h–100Ah,
//! 1018h, from the same [`DeviceInfo`]), so that a master that checks them accepts both:
//! - NMT slave with boot-up and the heartbeat producer (1017h);
//! - the SDO server with segmented and block transfer, the program data streaming from it to
//!   the program area in pieces of `BUF` bytes (a whole sub-block of up to 127 segments for
//!   the default `BUF`);
//! - the program download service ([`ProgramDownload`]) over the board's program area.
//!
//! It has the entry points of [`Drive`](crate::Drive)'s communication side: feed it frames
//! with [`on_frame`](Bootloader::on_frame), call [`poll`](Bootloader::poll) when it asks, send
//! what [`pop_tx`](Bootloader::pop_tx) gives. When the master starts the verified program,
//! [`take_request`](Bootloader::take_request) says so once the answer has left the queue:
//! the board then hands over to the program (on the reference boards: jumps to it).

use crate::comm::heartbeat::HeartbeatProducer;
use crate::comm::indicators::NodeStatus;
use crate::comm::nmt::{transition, NmtAction, Services};
use crate::comm::program::{self, ProgramDownload, ProgramRequest, PROGRAM_DATA};
use crate::comm::sdo_server::{self, ObjectAccess, SdoServer};
use crate::comm::NmtState;
use crate::od::standard::{BOOTLOADER_COMMUNICATION, PRODUCER_HEARTBEAT_TIME};
use crate::od::{storage_bytes, AbortCode, ConfigError, DeviceInfo, Dictionary, Entry, Object};
use crate::storage::NonVolatile;
use crate::wire::nmt::NodeControl;
use crate::wire::sdo::Mux;
use crate::{CanFrame, Duration, Instant};
use heapless::Deque;

/// Bytes of the bootloader's value store.
pub const BOOT_OD_BYTES: usize = storage_bytes(&[&BOOTLOADER_COMMUNICATION, &program::OBJECTS]);
/// The SDO server's buffer by default: a block-download sub-block of 127 segments.
pub const BOOT_SDO_BUFFER: usize = 127 * 7;
/// Frames waiting for the CAN controller.
const TX_QUEUE: usize = 8;

/// The bootloader node over the program area `F`, with an SDO buffer of `BUF` bytes.
pub struct Bootloader<F: NonVolatile, const BUF: usize = BOOT_SDO_BUFFER> {
    od: Dictionary<BOOT_OD_BYTES>,
    sdo: SdoServer<BUF>,
    nmt: NmtState,
    heartbeat: HeartbeatProducer,
    program: ProgramDownload<F>,
    tx: Deque<CanFrame, TX_QUEUE>,
}

impl<F: NonVolatile, const BUF: usize> Bootloader<F, BUF> {
    /// A bootloader at `node_id` (1..=127) identifying as `device`, over `area` with the
    /// program's payload at `payload_offset` ([`ProgramDownload::bootloader`]). It sends its
    /// boot-up at the first [`poll`](Self::poll).
    pub fn new(device: DeviceInfo, node_id: u8, area: F, payload_offset: u32) -> Result<Self, ConfigError> {
        let tables: [&'static [Object]; 2] = [&BOOTLOADER_COMMUNICATION, &program::OBJECTS];
        Ok(Bootloader {
            od: Dictionary::new(&tables, device, node_id)?,
            sdo: SdoServer::new(Duration::from_millis(1000)),
            nmt: NmtState::Initialising,
            heartbeat: HeartbeatProducer::default(),
            program: ProgramDownload::bootloader(area, payload_offset),
            tx: Deque::new(),
        })
    }

    /// The NMT state.
    pub fn nmt_state(&self) -> NmtState {
        self.nmt
    }

    /// The program download service (its state, its area).
    pub fn program(&mut self) -> &mut ProgramDownload<F> {
        &mut self.program
    }

    /// Gives the program area back, e.g. to read the program it is to start.
    pub fn into_area(self) -> F {
        self.program.into_area()
    }

    /// The object dictionary (device-side access).
    pub fn od(&self) -> &Dictionary<BOOT_OD_BYTES> {
        &self.od
    }

    /// The state the CiA 303-3 indicators show: the RUN LED flickers while the program area
    /// is being written.
    pub fn node_status(&self) -> NodeStatus {
        NodeStatus { program_download: self.program.is_busy(), ..NodeStatus::new(self.nmt) }
    }

    /// What the board is asked to do (start the program), once every frame before it has been
    /// taken from [`pop_tx`](Self::pop_tx): the answer that asked for it is then on its way.
    pub fn take_request(&mut self) -> Option<ProgramRequest> {
        if !self.tx.is_empty() {
            return None;
        }
        self.program.take_request()
    }

    /// True while a request waits to be taken ([`take_request`](Self::take_request)).
    pub fn has_request(&self) -> bool {
        self.program.has_request()
    }

    /// The next frame to send.
    pub fn pop_tx(&mut self) -> Option<CanFrame> {
        self.tx.pop_front()
    }

    /// A frame received at `now`.
    pub fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.boot_if_pending(now);
        let Some(id) = frame.standard_id() else { return };
        let data = embedded_can::Frame::data(frame);
        let node_id = self.od.node_id();
        if id == 0 {
            if let Some(control) = NodeControl::parse(data).filter(|c| c.addresses(node_id)) {
                self.nmt_action(transition(self.nmt, control.command), now);
            }
        } else if id == 0x600 + u16::from(node_id) && self.nmt.serves_sdo() {
            let mut access =
                Access { od: &mut self.od, program: &mut self.program, nmt: self.nmt, heartbeat: false };
            let response = self.sdo.on_request(data, now, &mut access);
            let heartbeat = access.heartbeat;
            if let Some(response) = response {
                self.send(0x580 + u16::from(node_id), &response);
            }
            if heartbeat {
                self.heartbeat.restart(now, self.heartbeat_period());
            }
            self.drain_sdo(now);
        }
    }

    /// Due work at `now`: boot-up, heartbeat, SDO time-outs, one step of erasing or
    /// verifying the program area. Returns when to call again.
    pub fn poll(&mut self, now: Instant) -> Option<Instant> {
        self.boot_if_pending(now);
        if self.heartbeat.due(now, self.heartbeat_period()) {
            let byte = self.nmt.heartbeat_byte();
            self.send(0x700 + u16::from(self.od.node_id()), &[byte]);
        }
        self.drain_sdo(now);
        // Erasing or verifying goes on at once.
        let work = self.program.poll().then_some(now);
        [self.heartbeat.deadline(), self.sdo.deadline(), work].into_iter().flatten().min()
    }

    fn heartbeat_period(&self) -> u16 {
        self.od.get::<u16>(PRODUCER_HEARTBEAT_TIME, 0).unwrap_or(0)
    }

    fn send(&mut self, id: u16, data: &[u8]) {
        if let Some(frame) = CanFrame::new_standard(id, data) {
            let _ = self.tx.push_back(frame);
        }
    }

    fn boot_if_pending(&mut self, now: Instant) {
        if self.nmt != NmtState::Initialising {
            return;
        }
        self.send(0x700 + u16::from(self.od.node_id()), &[0]);
        self.nmt = NmtState::PreOperational;
        let period = self.heartbeat_period();
        self.heartbeat.restart(now + Duration::from_millis(u64::from(period)), period);
    }

    fn nmt_action(&mut self, action: NmtAction, now: Instant) {
        match action {
            NmtAction::None => {}
            NmtAction::Enter(state) => {
                if !state.serves_sdo() {
                    self.sdo.reset();
                    self.program.broken();
                }
                self.nmt = state;
                self.heartbeat.restart(now, self.heartbeat_period());
            }
            NmtAction::ResetApplication | NmtAction::ResetCommunication => {
                self.od.reset(0x1000..=0xFFFF);
                self.sdo.reset();
                self.program.broken();
                self.heartbeat.stop();
                self.nmt = NmtState::Initialising;
                self.boot_if_pending(now);
            }
        }
    }

    fn drain_sdo(&mut self, now: Instant) {
        let id = 0x580 + u16::from(self.od.node_id());
        while self.sdo.deadline().is_some_and(|due| now >= due) && !self.tx.is_full() {
            let mut access =
                Access { od: &mut self.od, program: &mut self.program, nmt: self.nmt, heartbeat: false };
            match self.sdo.poll(now, &mut access) {
                Some(frame) => self.send(id, &frame),
                None => break,
            }
        }
    }
}

/// The dictionary and the program service as the SDO server sees them.
struct Access<'a, F: NonVolatile, const B: usize> {
    od: &'a mut Dictionary<B>,
    program: &'a mut ProgramDownload<F>,
    nmt: NmtState,
    /// 1017h was written.
    heartbeat: bool,
}

impl<F: NonVolatile, const B: usize> Access<'_, F, B> {
    /// `mux`'s entry, and whether the program service holds its value.
    fn entry(&self, mux: Mux) -> Result<(Entry, bool), AbortCode> {
        let entry = self.od.entry(mux.index, mux.sub)?;
        Ok((entry, program::owns(mux.index) && mux.sub == 1))
    }

    fn writable(&self, mux: Mux) -> Result<(Entry, bool), AbortCode> {
        let (entry, service) = self.entry(mux)?;
        // No entry of the bootloader's waits for the drive function: it has none.
        sdo_server::check_download(entry.var, self.nmt, || true)?;
        Ok((entry, service))
    }

    /// The service's value of sub 1 of its objects, as little-endian bytes and its length.
    fn service_value(&self, mux: Mux) -> ([u8; 4], usize) {
        let value = self.program.read(mux.index).unwrap_or(0);
        (value.to_le_bytes(), program::value_len(mux.index))
    }
}

impl<F: NonVolatile, const B: usize> ObjectAccess for Access<'_, F, B> {
    fn upload_len(&mut self, mux: Mux) -> Result<usize, AbortCode> {
        let (entry, service) = self.entry(mux)?;
        sdo_server::check_upload(entry.var)?;
        if service {
            return Ok(self.service_value(mux).1);
        }
        Ok(self.od.value_len(&entry))
    }

    fn read(&mut self, mux: Mux, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let (entry, service) = self.entry(mux)?;
        if !service {
            return Ok(self.od.read(&entry, offset, buf));
        }
        let (bytes, len) = self.service_value(mux);
        let value = bytes.get(offset..len).unwrap_or(&[]);
        let n = value.len().min(buf.len());
        if let (Some(dst), Some(src)) = (buf.get_mut(..n), value.get(..n)) {
            dst.copy_from_slice(src);
        }
        Ok(n)
    }

    fn download_check(&mut self, mux: Mux, size: Option<usize>) -> Result<Option<usize>, AbortCode> {
        let (entry, _) = self.writable(mux)?;
        let fixed = entry.var.data_type.fixed_size();
        match (fixed, size) {
            (Some(n), Some(s)) if s > n => Err(AbortCode::LengthTooHigh),
            (Some(n), Some(s)) if s < n => Err(AbortCode::LengthTooLow),
            // The program data has no size of its own: the service checks it.
            _ if mux.index == PROGRAM_DATA => Ok(None),
            (None, Some(s)) if s > usize::from(entry.var.capacity) => Err(AbortCode::LengthTooHigh),
            _ => Ok(fixed),
        }
    }

    fn write(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode> {
        let (entry, service) = self.writable(mux)?;
        if service && mux.index == PROGRAM_DATA {
            // An image of at most 4 bytes, expedited: the whole stream in one piece.
            self.program.begin(Some(data.len()))?;
            return self.program.piece(0, data, true);
        }
        self.od.check_write(&entry, data)?;
        if service {
            let &[command] = data else {
                return Err(AbortCode::LengthMismatch);
            };
            return self.program.command(command);
        }
        self.od.commit(&entry, data);
        self.heartbeat |= mux.index == PRODUCER_HEARTBEAT_TIME;
        Ok(())
    }

    fn begin_stream(&mut self, mux: Mux, size: Option<usize>) -> Result<bool, AbortCode> {
        if mux != (Mux { index: PROGRAM_DATA, sub: 1 }) {
            return Ok(false);
        }
        self.program.begin(size)?;
        Ok(true)
    }

    fn write_piece(&mut self, _mux: Mux, offset: usize, data: &[u8], last: bool) -> Result<(), AbortCode> {
        self.program.piece(offset, data, last)
    }

    fn stream_broken(&mut self, _mux: Mux) {
        self.program.broken();
    }
}

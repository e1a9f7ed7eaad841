//! A CiA 301-only node composed from the crate's public services, for the footprint of "the
//! communication profile without the drive": NMT slave with boot-up, SDO server (expedited,
//! segmented, block), heartbeat producer, EMCY producer, SYNC consumer, 4 + 4 PDOs with
//! dynamic mapping, and the standard communication objects (1000h–1029h, 1400h–1BFFh).
//!
//! `canopen_drive::Drive` always carries the CiA 402 profile, so a 301-only node is not one
//! of its configurations today; this is the composition a vendor would write (about what
//! `drive.rs` does without the profile, the LSS slave, node guarding, the heartbeat consumer
//! and parameter storage). The PDO records are the crate's default table, whose pre-defined
//! mappings name 6xxxh objects this node does not have: the PDOs stay unusable until the
//! master maps them, the code paths are the same.

use canopen_drive::comm::emcy::EmcyProducer;
use canopen_drive::comm::heartbeat::HeartbeatProducer;
use canopen_drive::comm::nmt::{transition, NmtAction, Services};
use canopen_drive::comm::pdo::{self, FrameSink, NoRules, PdoEvent, PdoRecord, PdoSet, RpdoFrame};
use canopen_drive::comm::sdo_server::{ObjectAccess, SdoServer};
use canopen_drive::comm::sync::{Sync, SyncConfig, SyncReception};
use canopen_drive::comm::NmtState;
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::standard::{
    COB_ID_EMCY, COB_ID_SYNC, COMMUNICATION, COMMUNICATION_CYCLE_PERIOD, INHIBIT_TIME_EMCY,
    PRODUCER_HEARTBEAT_TIME, SYNCHRONOUS_COUNTER_OVERFLOW,
};
use canopen_drive::od::{AbortCode, ConfigError, DeviceInfo, Dictionary, Entry, Object};
use canopen_drive::wire::nmt::NodeControl;
use canopen_drive::wire::sdo::Mux;
use canopen_drive::{CanFrame, Duration, Instant};
use core::mem::MaybeUninit;
use heapless::Deque;

/// Bytes of the value store: exactly what the communication objects and the PDO records need.
pub const OD_BYTES: usize = canopen_drive::od::storage_bytes(&[&COMMUNICATION, &pdo::DEFAULT_OBJECTS]);
/// Download staging buffer of the SDO server.
pub const SDO_BUFFER: usize = 64;
/// Frames waiting for the CAN controller.
pub const TX_QUEUE: usize = 16;

/// Identity of the node.
const DEVICE: DeviceInfo = DeviceInfo {
    device_type: 0x0000_0000,
    device_name: "canopen-drive 301 node",
    drive_modes: 0,
    ..DeviceInfo::servo_drive()
};

struct Tx(Deque<CanFrame, TX_QUEUE>);

impl FrameSink for Tx {
    fn send(&mut self, id: u16, data: &[u8]) -> bool {
        CanFrame::new_standard(id, data).is_some_and(|f| self.0.push_back(f).is_ok())
    }
}

/// The CiA 301-only node.
pub struct Node301 {
    od: Dictionary<OD_BYTES>,
    sdo: SdoServer<SDO_BUFFER>,
    nmt: NmtState,
    heartbeat: HeartbeatProducer,
    emcy: EmcyProducer,
    sync: Sync,
    pdos: PdoSet<4, 4>,
    tx: Tx,
}

impl Node301 {
    /// A node at `node_id` with the standard communication objects and 4 + 4 PDOs, built in
    /// `slot` (a static) without being moved, as `Drive::build_in` builds the drive.
    pub fn build_in(slot: &mut MaybeUninit<Self>, node_id: u8) -> Result<&mut Self, ConfigError> {
        let node = Self::unconfigured_in(slot, node_id);
        let tables: [&'static [Object]; 2] = [&COMMUNICATION, &pdo::DEFAULT_OBJECTS];
        node.od.attach(&tables)?;
        node.configure_pdos();
        Ok(node)
    }

    #[inline(never)]
    fn unconfigured_in(slot: &mut MaybeUninit<Self>, node_id: u8) -> &mut Self {
        slot.write(Node301 {
            od: Dictionary::empty(DEVICE, node_id),
            sdo: SdoServer::new(Duration::from_millis(1000)),
            nmt: NmtState::Initialising,
            heartbeat: HeartbeatProducer::default(),
            emcy: EmcyProducer::new(),
            sync: Sync::default(),
            pdos: PdoSet::default(),
            tx: Tx(Deque::new()),
        })
    }

    fn node_id(&self) -> u8 {
        self.od.node_id()
    }

    fn heartbeat_period(&self) -> u16 {
        self.od.get::<u16>(PRODUCER_HEARTBEAT_TIME, 0).unwrap_or(0)
    }

    fn sync_config(&self) -> (SyncConfig, u16) {
        let cob = self.od.get::<u32>(COB_ID_SYNC, 0).unwrap_or(0x80);
        let config = SyncConfig {
            producer: false,
            period_us: self.od.get::<u32>(COMMUNICATION_CYCLE_PERIOD, 0).unwrap_or(0),
            overflow: self.od.get::<u8>(SYNCHRONOUS_COUNTER_OVERFLOW, 0).unwrap_or(0),
        };
        (config, (cob & 0x7FF) as u16)
    }

    fn configure_pdos(&mut self) {
        if let Some(PdoEvent::Raise(code)) = self.pdos.configure_all(&self.od, &NoRules) {
            let _ = self.emcy.raise(code, canopen_drive::comm::emcy::ErrorRegister::COMMUNICATION, [0; 5]);
        }
    }

    fn boot_if_pending(&mut self, now: Instant) {
        if self.nmt != NmtState::Initialising {
            return;
        }
        let id = 0x700 + u16::from(self.node_id());
        self.tx.send(id, &[0]);
        self.nmt = NmtState::PreOperational;
        let period = self.heartbeat_period();
        self.heartbeat.restart(now + Duration::from_millis(u64::from(period)), period);
    }

    fn nmt_action(&mut self, action: NmtAction, now: Instant) {
        match action {
            NmtAction::None => {}
            NmtAction::Enter(state) => {
                if state == NmtState::Operational && self.nmt != NmtState::Operational {
                    self.pdos.start(now);
                }
                if !state.serves_sdo() {
                    self.sdo.reset();
                }
                self.nmt = state;
                self.heartbeat.restart(now, self.heartbeat_period());
            }
            NmtAction::ResetApplication | NmtAction::ResetCommunication => {
                if action == NmtAction::ResetApplication {
                    self.od.reset(0x2000..=0xFFFF);
                }
                self.od.reset(0x1000..=0x1FFF);
                self.emcy.discard_pending();
                self.sync.restart(now, self.sync_config().0);
                self.configure_pdos();
                self.sdo.reset();
                self.heartbeat.stop();
                self.nmt = NmtState::Initialising;
                self.boot_if_pending(now);
            }
        }
    }

    fn after_write(&mut self, mux: Mux, now: Instant) {
        if mux.index == PRODUCER_HEARTBEAT_TIME {
            self.heartbeat.restart(now, self.heartbeat_period());
        } else if matches!(mux.index, COB_ID_SYNC | COMMUNICATION_CYCLE_PERIOD | SYNCHRONOUS_COUNTER_OVERFLOW)
        {
            self.sync.restart(now, self.sync_config().0);
        } else if let Some(record) = PdoRecord::of(mux.index) {
            self.pdos.configure(&self.od, record, &NoRules);
            if self.nmt == NmtState::Operational {
                self.pdos.start(now);
            }
        }
    }

    fn drain_sdo(&mut self, now: Instant) {
        let id = 0x580 + u16::from(self.node_id());
        while !self.tx.0.is_full() {
            let mut access = Access { od: &mut self.od, written: None };
            match self.sdo.poll(now, &mut access) {
                Some(frame) => {
                    self.tx.send(id, &frame);
                }
                None => break,
            }
        }
    }

    fn send_emcy(&mut self, now: Instant) {
        let Ok(cob) = self.od.get::<u32>(COB_ID_EMCY, 0) else { return };
        if cob & 0x8000_0000 != 0 || !self.nmt.serves_emcy() {
            return;
        }
        let inhibit = self.od.get::<u16>(INHIBIT_TIME_EMCY, 0).unwrap_or(0);
        while !self.tx.0.is_full() {
            match self.emcy.pop_due(now, inhibit) {
                Some(data) => {
                    self.tx.send((cob & 0x7FF) as u16, &data);
                }
                None => break,
            }
        }
    }
}

impl crate::Node for Node301 {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.boot_if_pending(now);
        let Some(id) = frame.standard_id() else { return };
        let data = embedded_can_data(frame);
        let node_id = self.node_id();
        let (sync_config, sync_id) = self.sync_config();
        if id == 0 {
            if let Some(control) = NodeControl::parse(data).filter(|c| c.addresses(node_id)) {
                self.nmt_action(transition(self.nmt, control.command), now);
            }
        } else if id == sync_id && self.nmt.serves_emcy() {
            if let SyncReception::Sync(event) = self.sync.on_frame(data, now, sync_config) {
                if self.nmt.serves_pdo() {
                    self.pdos.on_sync(event.counter, now, &self.od, &mut self.tx);
                }
            }
        } else if id == 0x600 + u16::from(node_id) && self.nmt.serves_sdo() {
            let mut access = Access { od: &mut self.od, written: None };
            let response = self.sdo.on_request(data, now, &mut access);
            let written = access.written;
            if let Some(response) = response {
                self.tx.send(0x580 + u16::from(node_id), &response);
            }
            if let Some(mux) = written {
                self.after_write(mux, now);
            }
            self.drain_sdo(now);
        } else if self.nmt.serves_pdo() {
            let frame = RpdoFrame { can_id: id, data, now, late: false };
            self.pdos.on_frame(frame, &mut self.od, &mut (), &NoRules, &mut |_| {});
        }
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        self.boot_if_pending(now);
        if self.heartbeat.due(now, self.heartbeat_period()) {
            let id = 0x700 + u16::from(self.node_id());
            self.tx.send(id, &[self.nmt.heartbeat_byte()]);
        }
        let (sync_config, _) = self.sync_config();
        let _ = self.sync.poll(now, sync_config);
        if self.nmt.serves_pdo() {
            self.pdos.poll(now, &self.od, &mut self.tx, &mut |_| {});
        }
        self.drain_sdo(now);
        self.send_emcy(now);
        [self.heartbeat.deadline(), self.sdo.deadline(), self.emcy.deadline(), self.pdos.deadline()]
            .into_iter()
            .flatten()
            .min()
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        self.tx.0.pop_front()
    }

    /// The application's cycle: apply synchronous RPDOs, send TPDOs whose values changed.
    fn tick(&mut self, now: Instant, _sample: &Sample) -> Demand {
        if self.nmt.serves_pdo() {
            self.pdos.apply_ready(&mut self.od, &mut (), &NoRules, &mut |_| {});
            self.pdos.detect_changes(now, &self.od, &mut self.tx);
        }
        Demand::OFF
    }
}

fn embedded_can_data(frame: &CanFrame) -> &[u8] {
    embedded_can::Frame::data(frame)
}

/// The dictionary as the SDO server sees it: existence, access rights, sizes, limits, the
/// PDO rules.
struct Access<'a> {
    od: &'a mut Dictionary<OD_BYTES>,
    written: Option<Mux>,
}

impl Access<'_> {
    fn writable(&self, mux: Mux) -> Result<Entry, AbortCode> {
        let entry = self.od.entry(mux.index, mux.sub)?;
        if entry.var.access.writable() {
            Ok(entry)
        } else {
            Err(AbortCode::WriteOfReadOnly)
        }
    }
}

impl ObjectAccess for Access<'_> {
    fn upload_len(&mut self, mux: Mux) -> Result<usize, AbortCode> {
        let entry = self.od.entry(mux.index, mux.sub)?;
        if !entry.var.access.readable() {
            return Err(AbortCode::ReadOfWriteOnly);
        }
        Ok(self.od.value_len(&entry))
    }

    fn read(&mut self, mux: Mux, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let entry = self.od.entry(mux.index, mux.sub)?;
        Ok(self.od.read(&entry, offset, buf))
    }

    fn download_check(&mut self, mux: Mux, size: Option<usize>) -> Result<Option<usize>, AbortCode> {
        let entry = self.writable(mux)?;
        let fixed = entry.var.data_type.fixed_size();
        match (fixed, size) {
            (Some(n), Some(s)) if s > n => Err(AbortCode::LengthTooHigh),
            (Some(n), Some(s)) if s < n => Err(AbortCode::LengthTooLow),
            (None, Some(s)) if s > usize::from(entry.var.capacity) => Err(AbortCode::LengthTooHigh),
            _ => Ok(fixed),
        }
    }

    fn write(&mut self, mux: Mux, data: &[u8]) -> Result<(), AbortCode> {
        let entry = self.writable(mux)?;
        self.od.check_write(&entry, data)?;
        pdo::check_write(self.od, mux.index, mux.sub, data, false)?;
        self.od.commit(&entry, data);
        self.written = Some(mux);
        Ok(())
    }
}

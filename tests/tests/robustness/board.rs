//! The drive driven directly by a board loop (no bus: the fastest loop a board could run),
//! with the invariants of every tick and an SDO client on raw frames.

use canopen_drive::cia402::ProfileConfig;
use canopen_drive::hal::Demand;
use canopen_drive::motion::TickRate;
use canopen_drive::od::Entry;
use canopen_drive::{AbortCode, CanFrame, Config, Drive, Duration, Instant};
use canopen_drive_sim::invariants::{self, DemandLimits, DemandWatch};
use canopen_drive_sim::motor::MotorParams;
use canopen_drive_sim::SimMotor;
use embedded_can::Frame;

use crate::common::{TestHooks, NODE, TEST_OBJECTS};

const SDO_RX: u16 = 0x600 + NODE as u16;
const SDO_TX: u16 = 0x580 + NODE as u16;

/// What an SDO download came to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answer {
    /// Written.
    Done,
    /// Refused with this code.
    Abort(u32),
    /// No answer (SDO not served).
    Silent,
}

/// The drive of the soak, driven directly (no bus: the fastest loop a board could run).
pub struct Board {
    pub drive: Drive<TestHooks>,
    pub motor: SimMotor,
    pub now: Instant,
    period: Duration,
    profile: ProfileConfig,
    entries: Vec<Entry>,
    demands: DemandWatch,
    pub demand: Demand,
    deadline: Option<Instant>,
    pub sent: Vec<CanFrame>,
    pub ticks: u64,
    /// 6064h must equal the count (no factors, no home offset, no polarity).
    pub user_units_are_increments: bool,
    /// Re-read the limits of the demand from the dictionary every this many ticks (1: every
    /// tick; more for a long run whose limits do not change after the set-up).
    pub limits_every: u64,
    limits: Option<DemandLimits>,
}

impl Board {
    pub fn new(epoch: Instant, tick_hz: u32) -> Board {
        let mut config = Config { manufacturer_objects: &TEST_OBJECTS, ..Config::new(NODE) };
        config.profile.tick_rate = TickRate::new(tick_hz).expect("a tick rate");
        let drive = Drive::with_hooks(config, TestHooks::default()).expect("the drive builds");
        let entries = invariants::entries(drive.od());
        // 2 ms integration steps: 5 per tick keeps the simulated loops stable and the soak fast.
        let motor = SimMotor::with_params(MotorParams {
            max_step: Duration::from_millis(2),
            ..MotorParams::default()
        });
        let mut board = Board {
            drive,
            motor,
            now: epoch,
            period: Duration::from_micros(1_000_000 / u64::from(tick_hz)),
            profile: config.profile,
            entries,
            demands: DemandWatch::default(),
            demand: Demand::OFF,
            deadline: None,
            sent: Vec::new(),
            ticks: 0,
            user_units_are_increments: true,
            limits_every: 1,
            limits: None,
        };
        board.poll();
        board
    }

    pub fn poll(&mut self) {
        for _ in 0..64 {
            self.deadline = self.drive.poll(self.now);
            while let Some(frame) = self.drive.pop_tx() {
                self.sent.push(frame);
            }
            if self.deadline.is_none_or(|d| d > self.now) {
                return;
            }
        }
        panic!("poll keeps asking to be called at {:?}", self.now);
    }

    /// Hands a frame to the drive without polling it (a board polls at the drive's deadline;
    /// the frames it queued go out with the next tick or poll).
    pub fn deliver(&mut self, id: u16, data: &[u8]) {
        self.drive.on_frame(&CanFrame::new_standard(id, data).expect("a frame"), self.now);
    }

    pub fn frame(&mut self, id: u16, data: &[u8]) {
        self.drive.on_frame(&CanFrame::new_standard(id, data).expect("a frame"), self.now);
        self.poll();
    }

    pub fn sdo(&mut self, index: u16, sub: u8, value: &[u8]) {
        let command = [0x2F, 0x2B, 0x27, 0x23][value.len() - 1];
        let [lo, hi] = index.to_le_bytes();
        let mut data = vec![command, lo, hi, sub, 0, 0, 0, 0];
        data[4..4 + value.len()].copy_from_slice(value);
        self.frame(0x600 + u16::from(NODE), &data);
        let position = self.sent.iter().position(|f| f.standard_id() == Some(0x580 + u16::from(NODE)));
        let answer = self.sent.remove(position.expect("an SDO answer"));
        assert_eq!(answer.data()[0], 0x60, "write {index:04X}sub{sub}: {:02X?}", answer.data());
    }

    /// One tick at the current instant, with the invariants of the demand.
    pub fn tick(&mut self) {
        let sample = self.motor.sample();
        self.demand = self.drive.tick(self.now, &sample);
        self.motor.step(&self.demand, self.period);
        self.ticks += 1;
        let state = self.drive.state();
        let od = self.drive.od();
        let limits = match self.limits {
            Some(limits) if !self.ticks.is_multiple_of(self.limits_every.max(1)) => limits,
            _ => DemandLimits::of(od),
        };
        self.limits = Some(limits);
        let checked = invariants::check_energy(state, &self.demand)
            .and_then(|()| self.demands.check(&self.demand, limits, &sample))
            .and_then(|()| invariants::check_statusword(od, state));
        if let Err(e) = checked {
            panic!("tick at {:?}: {e}", self.now);
        }
        // Position bookkeeping: the internal value is the count; the user value too (factors
        // 1, no homing in these scenarios).
        assert_eq!(od.get::<i32>(0x6063, 0), Ok(sample.position), "6063h at {:?}", self.now);
        if self.user_units_are_increments {
            assert_eq!(od.get::<i32>(0x6064, 0), Ok(sample.position), "6064h at {:?}", self.now);
        }
        while let Some(frame) = self.drive.pop_tx() {
            self.sent.push(frame);
        }
    }

    /// Time passes to `until`: polls at the deadlines, ticks at every period boundary.
    pub fn run_until(&mut self, until: Instant, next_tick: &mut Instant) {
        loop {
            let next = self.deadline.map_or(*next_tick, |d| d.min(*next_tick));
            if next > until {
                break;
            }
            self.now = self.now.max(next);
            if self.now >= *next_tick {
                self.tick();
                *next_tick = *next_tick + self.period;
            }
            self.poll();
        }
        self.now = until;
    }

    pub fn check_dictionary(&self) {
        if let Err(e) = invariants::check_entries(self.drive.od(), &self.entries, &self.profile) {
            panic!("dictionary at {:?}: {e}", self.now);
        }
    }
}

impl Board {
    /// Lets `ms` milliseconds pass (ticks and polls).
    pub fn advance_ms(&mut self, ms: u64, next_tick: &mut Instant) {
        let until = self.now + Duration::from_millis(ms);
        self.run_until(until, next_tick);
    }

    /// The SDO frames the drive sent since the last call, taken out of `sent`.
    fn take_sdo(&mut self) -> Vec<[u8; 8]> {
        let mut out = Vec::new();
        self.sent.retain(|f| {
            if f.standard_id() == Some(SDO_TX) {
                let mut d = [0u8; 8];
                d[..f.data().len()].copy_from_slice(f.data());
                out.push(d);
                false
            } else {
                true
            }
        });
        out
    }

    /// Sends one SDO request; returns the answers (at most one is allowed).
    fn request(&mut self, data: &[u8; 8]) -> Option<[u8; 8]> {
        self.frame(SDO_RX, data);
        let answers = self.take_sdo();
        assert!(answers.len() <= 1, "{} answers to {data:02X?}", answers.len());
        answers.first().copied()
    }

    /// Writes `value` (any length) to `index`/`sub`: expedited for 1–4 bytes, segmented with
    /// the size indicated otherwise.
    pub fn download(&mut self, index: u16, sub: u8, value: &[u8]) -> Answer {
        let [lo, hi] = index.to_le_bytes();
        let abort = |d: [u8; 8]| Answer::Abort(u32::from_le_bytes([d[4], d[5], d[6], d[7]]));
        if (1..=4).contains(&value.len()) {
            let mut data = [0x23 | (((4 - value.len()) as u8) << 2), lo, hi, sub, 0, 0, 0, 0];
            data[4..4 + value.len()].copy_from_slice(value);
            return match self.request(&data) {
                None => Answer::Silent,
                Some(d) if d[0] == 0x60 => Answer::Done,
                Some(d) if d[0] == 0x80 => abort(d),
                Some(d) => panic!("unexpected answer {d:02X?}"),
            };
        }
        let size = (value.len() as u32).to_le_bytes();
        match self.request(&[0x21, lo, hi, sub, size[0], size[1], size[2], size[3]]) {
            None => return Answer::Silent,
            Some(d) if d[0] == 0x60 => {}
            Some(d) if d[0] == 0x80 => return abort(d),
            Some(d) => panic!("unexpected answer {d:02X?}"),
        }
        let mut chunks: Vec<&[u8]> = value.chunks(7).collect();
        if chunks.is_empty() {
            chunks.push(&[]);
        }
        let last = chunks.len() - 1;
        for (i, chunk) in chunks.iter().enumerate() {
            let toggle = ((i % 2) as u8) << 4;
            let unused = ((7 - chunk.len()) as u8) << 1;
            let mut data = [toggle | unused | u8::from(i == last), 0, 0, 0, 0, 0, 0, 0];
            data[1..1 + chunk.len()].copy_from_slice(chunk);
            match self.request(&data) {
                Some(d) if d[0] & 0xE0 == 0x20 => {}
                Some(d) if d[0] == 0x80 => return abort(d),
                other => panic!("unexpected answer {other:02X?} to segment {i}"),
            }
        }
        Answer::Done
    }

    /// Reads `index`/`sub` (expedited or segmented); `Err(code)` on an abort.
    pub fn upload(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, u32> {
        let [lo, hi] = index.to_le_bytes();
        let d = self.request(&[0x40, lo, hi, sub, 0, 0, 0, 0]).expect("an answer to an upload");
        if d[0] == 0x80 {
            return Err(u32::from_le_bytes([d[4], d[5], d[6], d[7]]));
        }
        if d[0] & 0x02 != 0 {
            let n = if d[0] & 0x01 != 0 { 4 - usize::from((d[0] >> 2) & 3) } else { 4 };
            return Ok(d[4..4 + n].to_vec());
        }
        let mut out = Vec::new();
        for i in 0.. {
            let toggle = ((i % 2) as u8) << 4;
            let s = self.request(&[0x60 | toggle, 0, 0, 0, 0, 0, 0, 0]).expect("a segment");
            if s[0] == 0x80 {
                return Err(u32::from_le_bytes([s[4], s[5], s[6], s[7]]));
            }
            let n = 7 - usize::from((s[0] >> 1) & 7);
            out.extend_from_slice(&s[1..1 + n]);
            if s[0] & 1 != 0 {
                break;
            }
        }
        Ok(out)
    }
}

/// The codes a value rule may refuse a write with (beyond access, size and limits).
pub const VALUE_RULE_CODES: [AbortCode; 10] = [
    AbortCode::InvalidValue,
    AbortCode::ValueTooHigh,
    AbortCode::ValueTooLow,
    AbortCode::ParameterIncompatible,
    AbortCode::UnsupportedAccess,
    AbortCode::ObjectNotMappable,
    AbortCode::PdoLengthExceeded,
    AbortCode::CannotStore,
    AbortCode::CannotStoreDeviceState,
    AbortCode::General,
];

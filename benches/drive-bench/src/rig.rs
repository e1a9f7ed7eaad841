//! The set-up of a measurement: one drive, its axis and a clock, driven as a master and a board
//! would drive them, through the public entry points only (`on_frame`, `poll`, `pop_tx`, `tick`).

use canopen_drive::cia402::fsa::State;
use canopen_drive::comm::pdo;
use canopen_drive::drive::DEFAULT_OD_BYTES;
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::{layout, ConfigError, Object};
use canopen_drive::{CanFrame, Config, Drive, Duration, Instant};
use embedded_can::Frame as _;

use crate::axis::Axis;
use crate::objects::BENCH_OBJECTS;

/// Node-ID of the measured drive.
pub const NODE_ID: u8 = 5;
/// The drive's SDO request identifier.
pub const SDO_RX: u16 = 0x600 + NODE_ID as u16;
/// The drive's SDO response identifier.
pub const SDO_TX: u16 = 0x580 + NODE_ID as u16;
/// The SYNC identifier.
pub const SYNC: u16 = 0x080;

/// The measured drive: the crate's default dictionary store, 4 + 4 PDOs, no hooks, no
/// parameter storage.
pub type BenchDrive = Drive;

/// The value store of the two-axis drive: the default and the second axis's profile objects.
pub const TWO_AXES_BYTES: usize = DEFAULT_OD_BYTES + canopen_drive::drive::AXIS_OD_BYTES + 1024;

/// The measured drive with two axes (issue 23): 4 + 4 PDOs per axis, otherwise as
/// [`BenchDrive`].
pub type TwoAxisDrive = Drive<(), TWO_AXES_BYTES, 8, 8, (), 2>;

/// 8 RPDOs and 8 TPDOs: PDOs 1–4 the first axis's, 5–8 the second's.
static PDOS_8: [Object; 32] = layout(pdo::objects::<32>(8));

/// Why a scenario could not be set up (the core changed under the benchmark, most likely).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetupError {
    /// The drive refused its configuration.
    Config(ConfigError),
    /// An SDO request of the set-up was answered with something else than success.
    Refused {
        /// Index of the request.
        index: u16,
        /// Sub-index of the request.
        sub: u8,
        /// What came back (an abort: code in bytes 4..8; all zero: nothing).
        response: [u8; 8],
    },
    /// The prepared state is not the one the measurement needs.
    Unexpected(&'static str),
}

impl From<ConfigError> for SetupError {
    fn from(error: ConfigError) -> Self {
        SetupError::Config(error)
    }
}

/// A drive of `AXES` axes with `B` bytes of store and `PDOS` + `PDOS` PDOs ([`BenchDrive`] by
/// default), its simulated axes and the time.
pub struct Rig<const B: usize = DEFAULT_OD_BYTES, const PDOS: usize = 4, const AXES: usize = 1> {
    /// The drive.
    pub drive: Drive<(), B, PDOS, PDOS, (), AXES>,
    /// The axes that give the feedback.
    pub axes: [Axis; AXES],
    /// The time of the next tick.
    pub now: Instant,
    /// Time between ticks.
    pub period: Duration,
    /// The last demand of each axis.
    pub demands: [Demand; AXES],
}

/// A [`TwoAxisDrive`] with its axes.
pub type TwoAxisRig = Rig<TWO_AXES_BYTES, 8, 2>;

/// The configuration of every scenario drive: the bench objects, the default profile at
/// `tick_hz`, the cascade controller when `cascade` is set.
pub fn config(tick_hz: u32, cascade: bool) -> Result<Config, SetupError> {
    let mut config = Config { manufacturer_objects: &BENCH_OBJECTS, ..Config::new(NODE_ID) };
    config.pdo_objects = &pdo::DEFAULT_OBJECTS;
    let rate = canopen_drive::motion::TickRate::new(tick_hz)
        .map_err(|_| SetupError::Unexpected("tick rate refused"))?;
    config.profile = config.profile.with_tick_rate(rate);
    if cascade {
        config.profile.cascade = Some(crate::objects::CASCADE);
    }
    Ok(config)
}

impl<const B: usize, const PDOS: usize, const AXES: usize> Rig<B, PDOS, AXES> {
    /// A booted drive (Pre-operational, Switch on disabled) ticked at `tick_hz`.
    pub fn new(tick_hz: u32, cascade: bool) -> Result<Self, SetupError> {
        let mut config = config(tick_hz, cascade)?;
        if AXES == 2 {
            config.pdo_objects = &PDOS_8;
        }
        let drive = Drive::build(config, (), ())?;
        let mut rig = Rig {
            drive,
            axes: [Axis::new(tick_hz); AXES],
            now: Instant::from_millis(1),
            period: Duration::from_micros(1_000_000 / u64::from(tick_hz.max(1))),
            demands: [Demand::OFF; AXES],
        };
        rig.drive.poll(rig.now);
        rig.drain();
        // Out of Not ready to switch on.
        rig.run(2);
        Ok(rig)
    }

    /// Drops every frame the drive has queued.
    pub fn drain(&mut self) {
        while self.drive.pop_tx().is_some() {}
    }

    /// Delivers `frame` now; drops what the drive sends.
    pub fn send(&mut self, id: u16, data: &[u8]) -> Result<(), SetupError> {
        let frame = CanFrame::new_standard(id, data).ok_or(SetupError::Unexpected("bad frame"))?;
        self.drive.on_frame(&frame, self.now);
        self.drain();
        Ok(())
    }

    /// Sends an SDO request now and returns the drive's response.
    pub fn sdo(&mut self, request: [u8; 8]) -> Result<[u8; 8], SetupError> {
        let frame = CanFrame::new_standard(SDO_RX, &request).ok_or(SetupError::Unexpected("bad frame"))?;
        self.drive.on_frame(&frame, self.now);
        let mut response = None;
        while let Some(reply) = self.drive.pop_tx() {
            if reply.standard_id() == Some(SDO_TX) {
                response = reply.data().try_into().ok();
            }
        }
        let [_, lo, hi, sub, ..] = request;
        let index = u16::from_le_bytes([lo, hi]);
        response.ok_or(SetupError::Refused { index, sub, response: [0; 8] })
    }

    /// Writes 1 to 4 bytes to `index`/`sub` with an expedited download; anything but success
    /// is an error.
    pub fn write(&mut self, index: u16, sub: u8, value: &[u8]) -> Result<(), SetupError> {
        let command = match value.len() {
            1 => 0x2F,
            2 => 0x2B,
            3 => 0x27,
            _ => 0x23,
        };
        let [lo, hi] = index.to_le_bytes();
        let mut request = [command, lo, hi, sub, 0, 0, 0, 0];
        for (slot, byte) in request.iter_mut().skip(4).zip(value) {
            *slot = *byte;
        }
        let response = self.sdo(request)?;
        if response != [0x60, lo, hi, sub, 0, 0, 0, 0] {
            return Err(SetupError::Refused { index, sub, response });
        }
        Ok(())
    }

    /// Reads a value of up to 4 bytes with an expedited upload.
    pub fn read(&mut self, index: u16, sub: u8) -> Result<u32, SetupError> {
        let [lo, hi] = index.to_le_bytes();
        let response = self.sdo([0x40, lo, hi, sub, 0, 0, 0, 0])?;
        match response {
            [command, _, _, _, a, b, c, d] if command & 0xE3 == 0x43 => Ok(u32::from_le_bytes([a, b, c, d])),
            _ => Err(SetupError::Refused { index, sub, response }),
        }
    }

    /// The statusword 6041h.
    pub fn statusword(&mut self) -> Result<u16, SetupError> {
        Ok(self.read(0x6041, 0)? as u16)
    }

    /// An NMT command to this node (01h start, 80h pre-operational, …).
    pub fn nmt(&mut self, command: u8) -> Result<(), SetupError> {
        self.send(0x000, &[command, NODE_ID])
    }

    /// Maps `entries` (index << 16 | sub << 8 | bits) into the PDO whose communication record is
    /// `communication` (1400h+n or 1800h+n) with transmission type `transmission`. The node must
    /// not be Operational.
    pub fn map_pdo(
        &mut self,
        communication: u16,
        transmission: u8,
        entries: &[u32],
    ) -> Result<(), SetupError> {
        let cob_id = self.read(communication, 1)?;
        let mapping = communication + 0x200;
        self.write(communication, 1, &(cob_id | 0x8000_0000).to_le_bytes())?;
        self.write(mapping, 0, &[0])?;
        for (sub, entry) in (1u8..).zip(entries) {
            self.write(mapping, sub, &entry.to_le_bytes())?;
        }
        self.write(mapping, 0, &[entries.len() as u8])?;
        self.write(communication, 2, &[transmission])?;
        self.write(communication, 1, &(cob_id & !0x8000_0000).to_le_bytes())
    }

    /// The feedback the next tick gets, of every axis.
    pub fn samples(&self) -> [Sample; AXES] {
        self.axes.map(|axis| axis.sample())
    }

    /// The last demand of the first axis.
    pub fn demand(&self) -> Demand {
        self.demands.first().copied().unwrap_or(Demand::OFF)
    }

    /// One control period: tick, the axes follow their demands, poll, frames dropped.
    pub fn step(&mut self) {
        let demands = self.drive.tick_axes(self.now, &self.samples());
        self.rest_of_period(demands);
    }

    /// What a control period does after the tick that gave `demands`.
    fn rest_of_period(&mut self, demands: [Demand; AXES]) {
        self.demands = demands;
        for (axis, demand) in self.axes.iter_mut().zip(&self.demands) {
            axis.follow(demand);
        }
        self.drive.poll(self.now);
        self.drain();
        self.now = self.now + self.period;
    }

    /// `ticks` control periods.
    pub fn run(&mut self, ticks: u32) {
        for _ in 0..ticks {
            self.step();
        }
    }

    /// Writes the controlword and lets two periods run.
    pub fn controlword(&mut self, value: u16) -> Result<(), SetupError> {
        self.axis_controlword(0, value)
    }

    /// Writes the controlword of axis `axis` (6040h + axis × 800h) and lets two periods run.
    pub fn axis_controlword(&mut self, axis: u16, value: u16) -> Result<(), SetupError> {
        self.write(0x6040 + axis * 0x800, 0, &value.to_le_bytes())?;
        self.run(2);
        Ok(())
    }

    /// Selects `mode` (6060h) and enables the drive: Operation enabled, or an error.
    pub fn enable(&mut self, mode: i8) -> Result<(), SetupError> {
        self.write(0x6060, 0, &mode.to_le_bytes())?;
        self.controlword(0x0006)?;
        self.controlword(0x000F)?;
        match self.drive.state() {
            State::OperationEnabled { .. } => Ok(()),
            _ => Err(SetupError::Unexpected("not in Operation enabled")),
        }
    }
}

impl Rig {
    /// The feedback the next tick gets.
    pub fn sample(&self) -> Sample {
        let [axis] = self.axes;
        axis.sample()
    }

    /// [`Self::step`] with the tick counted on its own: [`crate::counted_tick`].
    pub fn counted_step(&mut self) {
        let sample = self.sample();
        let demand = crate::counted_tick(&mut self.drive, self.now, &sample);
        self.rest_of_period([demand]);
    }
}

//! A whole drive with its simulated motor, run by [`Op`]s, with the invariants checked after
//! every step.
//!
//! The rig plays the board: it ticks the drive every millisecond with a sample of the simulated
//! motor and hands the demand back to the motor, polls the drive whenever its deadline comes,
//! and drains every frame the drive sends. After each tick it checks invariants 1 and 2 and
//! that the statusword reports the state; after each op it checks the dictionary (invariant
//! 3), and it counts the SDO answers to every request and the LSS answers to every LSS
//! request.

use canopen_drive::cia402::fsa::State;
use canopen_drive::cia402::{OptionCodes, ProfileConfig};
use canopen_drive::comm::NmtState;
use canopen_drive::drive::CanState;
use canopen_drive::hal::{Demand, DigitalInputs, HardwareFaults};
use canopen_drive::od::{
    layout, AbortCode, Access, DataType, DefaultValue, Entry, Object, ObjectHooks, PdoMapping, Span, Var,
};
use canopen_drive::{CanFrame, Config, Drive, Duration, Instant};
use canopen_drive_sim::invariants::{self, DemandLimits, DemandWatch, SdoWatch};
use canopen_drive_sim::SimMotor;
use embedded_can::Frame;

use std::cell::RefCell;
use std::rc::Rc;

use crate::ops::Op;

/// Bit 15 of a frame op's identifier: send it as an extended frame.
pub const EXTENDED: u16 = 0x8000;
/// The node-ID of a configured rig.
pub const NODE: u8 = 5;
/// The control-loop period.
pub const TICK: Duration = Duration::from_millis(1);
/// Ticks an `Advance` runs at most before the rest of the span passes in one jump (an
/// `Advance` spans at most 65 ms: never reached).
const MAX_TICKS_PER_STEP: u32 = 1000;
/// Ticks a `Jump` runs before the jump.
const TICKS_BEFORE_JUMP: u32 = 8;
/// The shortest time between two polls for a deadline within a span of time: a board polls
/// from its loop, not at every microsecond a drive asks for (a SYNC producer or an event timer
/// of a few microseconds would otherwise make one op thousands of polls).
const MIN_POLL_INTERVAL: Duration = Duration::from_micros(100);
/// Polls at one instant before the rig calls it a livelock.
const MAX_POLLS_PER_INSTANT: u32 = 64;

/// 2400h: the cascade's parameter record (used by [`Variant::Cascade`]).
pub const CASCADE: u16 = 0x2400;

/// The rig's manufacturer objects: one of each kind the RPDO and SDO paths treat differently.
pub static OBJECTS: [Object; 6] = layout([
    Object::var(
        0x2000,
        "Text",
        Var::new("Text", DataType::VisibleString)
            .access(Access::ReadWrite)
            .capacity(32)
            .default(DefaultValue::Text("fuzz")),
    ),
    Object::var(
        0x2001,
        "Limited",
        Var::new("Limited", DataType::Unsigned8)
            .access(Access::ReadWrite)
            .pdo(PdoMapping::Both)
            .default(DefaultValue::Unsigned(15))
            .limits_unsigned(10, 20),
    ),
    Object::var(
        0x2002,
        "Flag",
        Var::new("Flag", DataType::Boolean).access(Access::ReadWrite).pdo(PdoMapping::Both),
    ),
    Object::var(
        0x2003,
        "Signed",
        Var::new("Signed", DataType::Integer32)
            .access(Access::ReadWrite)
            .pdo(PdoMapping::Rpdo)
            .limits_signed(-1000, 1000),
    ),
    Object::var(
        0x2006,
        "Refused",
        Var::new("Refused", DataType::Unsigned32).access(Access::ReadWrite).pdo(PdoMapping::Rpdo),
    ),
    canopen_drive::control::object(CASCADE),
]);

/// The firmware side: 2006h refuses every write (as a hook may).
#[derive(Debug, Default)]
pub struct RigHooks;

impl ObjectHooks for RigHooks {
    fn validate(&mut self, index: u16, _sub: u8, _data: &[u8]) -> Result<(), AbortCode> {
        if index == 0x2006 {
            Err(AbortCode::General)
        } else {
            Ok(())
        }
    }
}

/// Drive configurations the fuzzers run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// The CiA defaults.
    Standard,
    /// Loops closed in the core, brake delays, following error as a fault, a deeper set-point
    /// buffer.
    Cascade,
    /// A vendor that narrowed everything: pp and pv only, a few option codes, no transition
    /// 16, no change on set-point, long RPDOs discarded.
    Narrow,
    /// Node-ID 255: LSS only until a master configures it.
    Unconfigured,
}

impl Variant {
    /// The variant a selector byte picks.
    pub fn from_byte(byte: u8) -> Self {
        match byte % 4 {
            0 => Variant::Standard,
            1 => Variant::Cascade,
            2 => Variant::Narrow,
            _ => Variant::Unconfigured,
        }
    }

    /// The drive's configuration.
    pub fn config(self) -> Config {
        let mut config = Config { manufacturer_objects: &OBJECTS, ..Config::new(NODE) };
        config.device.vendor_id = 0x0000_0ABC;
        config.device.product_code = 0x0004_0002;
        config.device.revision_number = 0x0001_0003;
        config.device.serial_number = 0x1234_5678;
        match self {
            Variant::Standard => {}
            Variant::Cascade => {
                config.profile.cascade = Some(CASCADE);
                config.profile.brake_release_delay = Duration::from_millis(20);
                config.profile.brake_engage_delay = Duration::from_millis(20);
                config.profile.following_error_fault = true;
                config.profile.setpoint_buffer = ProfileConfig::MAX_SETPOINT_BUFFER;
                config.lss_store = true;
            }
            Variant::Narrow => {
                config.device.drive_modes = 0b101;
                config.profile.option_codes = OptionCodes {
                    abort_connection: 0b0110,
                    quick_stop: 0b0000_0110,
                    shutdown: 0b01,
                    disable_operation: 0b10,
                    halt: 0b0010,
                    fault_reaction: 0b0100,
                };
                config.profile.transition_16 = false;
                config.profile.change_on_setpoint = false;
                config.long_rpdo = canopen_drive::comm::pdo::LongRpdo::DiscardAndReport;
            }
            Variant::Unconfigured => config.node_id = 0xFF,
        }
        config
    }
}

/// Where a run starts: the booted drive, or the drive a master has already brought into a state
/// worth exploring from (so that a short input starts deep: libFuzzer's throughput falls with
/// the length of its inputs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// Just booted: Pre-operational, Switch on disabled.
    Booted,
    /// Operational, Operation enabled in profile position, moving to 50 000 increments.
    PpMoving,
    /// Operational, Operation enabled in profile velocity, turning at 20 000 increments/s.
    PvTurning,
    /// Operational, Operation enabled in cyclic synchronous position, waiting for its stream.
    CspEnabled,
    /// Operational, homing method 17 (negative limit switch) running.
    Homing,
    /// In the LSS configuration state (switch state global), NMT as booted: for the LSS target,
    /// whose short programs then start with a node that takes configuration commands.
    LssConfiguration,
}

impl Start {
    /// Every start of the whole-drive target, in selector order.
    pub const ALL: [Start; 5] =
        [Start::Booted, Start::PpMoving, Start::PvTurning, Start::CspEnabled, Start::Homing];

    /// The start a selector picks (the value 0 picks [`Start::Booted`]).
    pub fn from_byte(byte: u8) -> Self {
        Start::ALL[usize::from(byte) % Start::ALL.len()]
    }

    /// What the master sends (and how long it waits) to bring a booted drive there.
    fn program(self) -> Vec<Op> {
        let write = |index: u16, size: u8, value: u32| Op::SdoWrite { index, sub: 0, size, value };
        let enable = |mode: i8| {
            vec![
                Op::Nmt { command: 0, node: 0 },
                write(0x6060, 1, u32::from(mode as u8)),
                Op::Controlword(0x06),
                Op::Advance(2000),
                Op::Controlword(0x07),
                Op::Advance(2000),
                Op::Controlword(0x0F),
                Op::Advance(5000),
            ]
        };
        let mut ops = match self {
            Start::Booted => return Vec::new(),
            // LSS_COMMANDS[0] is 0x04, switch state global; 1: configuration.
            Start::LssConfiguration => return vec![Op::Lss { command: 0, data: [1, 0, 0, 0, 0, 0, 0] }],
            Start::PpMoving => enable(1),
            Start::PvTurning => enable(3),
            Start::CspEnabled => enable(8),
            Start::Homing => enable(6),
        };
        match self {
            Start::PpMoving => ops.extend([
                write(0x607A, 4, 50_000),
                write(0x6081, 4, 20_000),
                Op::Controlword(0x1F),
                Op::Advance(20_000),
            ]),
            Start::PvTurning => ops.extend([write(0x60FF, 4, 20_000), Op::Advance(50_000)]),
            Start::Homing => ops.extend([write(0x6098, 1, 17), Op::Controlword(0x1F), Op::Advance(20_000)]),
            Start::Booted | Start::CspEnabled | Start::LssConfiguration => {}
        }
        ops
    }
}

/// Counters of one run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Ticks run.
    pub ticks: u64,
    /// Frames the drive sent.
    pub sent: u64,
    /// SDO requests and answers.
    pub sdo: (usize, usize),
}

/// The drive, its motor, the clock and the watchers (see the [module docs](self)).
pub struct Rig {
    /// The drive under test.
    pub drive: Drive<RigHooks>,
    /// Its motor.
    pub motor: SimMotor,
    profile: ProfileConfig,
    now: Instant,
    next_tick: Instant,
    deadline: Option<Instant>,
    /// When the drive was last polled.
    polled: Instant,
    demand: Demand,
    sdo: SdoWatch,
    demands: DemandWatch,
    /// The limits the parameters configure, computed at the first tick of an op (only a
    /// master's op changes a parameter).
    limits: Option<DemandLimits>,
    stats: Stats,
    /// Every entry of the dictionary that can change, resolved once (shared by the copies of a
    /// rig). Constants (`Access::Const`: computed from the configuration, no RAM) are checked
    /// once, when the rig is built.
    entries: Rc<[Entry]>,
    /// Where each of `entries` is stored, if it is a number (shared by the copies).
    spans: Rc<[Option<Span>]>,
    /// The numbers of `entries` as last checked (0 for the others).
    checked: Vec<u64>,
    /// Mappable entries (index << 16 | sub << 8 | bits) for RPDOs and TPDOs.
    mappable: Rc<(Vec<u32>, Vec<u32>)>,
    /// Frames the drive sent during the last op.
    pub sent: Vec<CanFrame>,
}

type Checked = Result<(), String>;

impl Rig {
    /// A booted drive of `variant` at time zero.
    pub fn new(variant: Variant) -> Result<Rig, String> {
        let config = variant.config();
        let drive = Drive::with_hooks(config, RigHooks).map_err(|e| format!("{e:?}"))?;
        let mappable = Rc::new(mappable_entries(&drive));
        let all = invariants::entries(drive.od());
        invariants::check_entries(drive.od(), &all, &config.profile)?;
        let entries: Rc<[Entry]> = all.into_iter().filter(|e| e.var.access != Access::Const).collect();
        let spans: Rc<[Option<Span>]> = entries.iter().map(|e| drive.od().span(e)).collect();
        let checked = vec![0; entries.len()];
        let mut rig = Rig {
            drive,
            motor: SimMotor::new(),
            profile: config.profile,
            now: Instant::ZERO,
            next_tick: Instant::ZERO,
            deadline: None,
            polled: Instant::ZERO,
            demand: Demand::OFF,
            sdo: SdoWatch::default(),
            demands: DemandWatch::default(),
            limits: None,
            stats: Stats::default(),
            entries,
            spans,
            checked,
            mappable,
            sent: Vec::new(),
        };
        rig.poll()?;
        rig.check_dictionary_fully()?;
        Ok(rig)
    }

    /// The drive of `variant` in state `start` (at the time its preparation took; an
    /// unconfigured drive only ever starts booted), copied from one prepared once per thread:
    /// a fuzz target runs thousands of inputs a second, and building a drive, resolving its
    /// dictionary and bringing it into a state would be most of each run.
    pub fn prepared(variant: Variant, start: Start) -> Result<Rig, String> {
        thread_local! {
            static PREPARED: RefCell<Vec<(Variant, Start, Rig)>> = const { RefCell::new(Vec::new()) };
        }
        let lss_only = matches!(start, Start::Booted | Start::LssConfiguration);
        let start = if variant == Variant::Unconfigured && !lss_only { Start::Booted } else { start };
        PREPARED.with(|prepared| {
            let mut prepared = prepared.borrow_mut();
            if let Some((_, _, rig)) = prepared.iter().find(|(v, s, _)| (*v, *s) == (variant, start)) {
                return Ok(rig.copy());
            }
            let mut rig = Rig::new(variant)?;
            for op in start.program() {
                rig.run(&op).map_err(|e| format!("preparing {start:?}: {e}"))?;
            }
            let enabled = matches!(rig.drive.state(), State::OperationEnabled { .. });
            if enabled != !matches!(start, Start::Booted | Start::LssConfiguration) {
                return Err(format!("preparing {start:?} of {variant:?} ended in {:?}", rig.drive.state()));
            }
            let copy = rig.copy();
            prepared.push((variant, start, rig));
            Ok(copy)
        })
    }

    /// An independent copy of the rig: the same drive, motor, clock and watchers.
    pub fn copy(&self) -> Rig {
        Rig {
            drive: copy_drive(&self.drive),
            motor: self.motor,
            profile: self.profile,
            now: self.now,
            next_tick: self.next_tick,
            deadline: self.deadline,
            polled: self.polled,
            demand: self.demand,
            sdo: self.sdo,
            demands: self.demands,
            limits: self.limits,
            stats: self.stats,
            entries: Rc::clone(&self.entries),
            spans: Rc::clone(&self.spans),
            checked: self.checked.clone(),
            mappable: Rc::clone(&self.mappable),
            sent: Vec::new(),
        }
    }

    /// The virtual time.
    pub fn now(&self) -> Instant {
        self.now
    }

    /// The demand of the last tick.
    pub fn demand(&self) -> Demand {
        self.demand
    }

    /// Counters so far.
    pub fn stats(&self) -> Stats {
        Stats { sdo: self.sdo.counts(), ..self.stats }
    }

    /// Invariant 3 now, every entry.
    pub fn check_dictionary_fully(&mut self) -> Checked {
        let od = self.drive.od();
        for (value, span) in self.checked.iter_mut().zip(self.spans.iter()) {
            *value = span.map_or(0, |span| od.load_span(span));
        }
        invariants::check_entries(od, &self.entries, &self.profile)
    }

    /// Invariant 3 now, as far as it can have changed since the last check: the entries whose
    /// number changed and those that are not numbers (strings, domains), and the rules across
    /// entries when an entry they read changed (PDO records, 1016h; 6060h when 6502h changed).
    /// The value rules of the other entries read only the entry itself and the configuration,
    /// so an entry that was valid at the last check and has not changed still is.
    pub fn check_dictionary(&mut self) -> Checked {
        let od = self.drive.od();
        let mut recheck = Vec::new();
        let (mut pdos, mut consumers, mut modes) = (false, false, false);
        for (i, (entry, span)) in self.entries.iter().zip(self.spans.iter()).enumerate() {
            let Some(span) = span else {
                recheck.push(*entry);
                continue;
            };
            let value = od.load_span(*span);
            if value != self.checked[i] {
                self.checked[i] = value;
                recheck.push(*entry);
                match entry.index() {
                    0x1400..=0x1BFF => pdos = true,
                    0x1016 => consumers = true,
                    0x6502 => modes = true,
                    _ => {}
                }
            }
        }
        if modes {
            recheck.extend(self.entries.iter().filter(|e| e.index() == 0x6060));
        }
        invariants::check_values(od, &recheck, &self.profile)?;
        if pdos {
            invariants::check_pdos(od)?;
        }
        if consumers {
            invariants::check_heartbeat_consumers(od)?;
        }
        Ok(())
    }

    /// Runs one op; then checks the dictionary.
    pub fn run(&mut self, op: &Op) -> Checked {
        self.sent.clear();
        self.limits = None;
        self.apply(op)?;
        self.check_dictionary().map_err(|e| format!("after {op:?}: {e}"))
    }

    fn apply(&mut self, op: &Op) -> Checked {
        let node = self.drive.node_id();
        match op {
            Op::Advance(us) => self.advance(Duration::from_micros(*us), MAX_TICKS_PER_STEP),
            Op::Jump(us) => self.advance(Duration::from_micros(*us), TICKS_BEFORE_JUMP),
            Op::Controlword(value) => {
                let v = value.to_le_bytes();
                self.frame(0x600 + u16::from(node), &[0x2B, 0x40, 0x60, 0, v[0], v[1], 0, 0], false)
            }
            Op::Rpdo { n, data } => {
                let index = 0x1400 + u16::from(n % 4);
                let cob = self.drive.od().get::<u32>(index, 1).unwrap_or(0);
                self.frame((cob & 0x7FF) as u16, data, false)
            }
            Op::Remote(n) => {
                let index = 0x1800 + u16::from(n % 4);
                let cob = self.drive.od().get::<u32>(index, 1).unwrap_or(0);
                self.frame((cob & 0x7FF) as u16, &[0; 8][..usize::from(n >> 4).min(8)], true)
            }
            Op::Sync(counter) => {
                let cob = self.drive.od().get::<u32>(0x1005, 0).unwrap_or(0x80);
                let data: Vec<u8> = counter.iter().copied().collect();
                self.frame((cob & 0x7FF) as u16, &data, false)
            }
            Op::PdoConfig { which, sub, kind, raw } => self.pdo_config(*which, *sub, *kind, *raw),
            Op::Motor { kind, arg } => {
                match kind % 6 {
                    0 => self.motor.inject_fault(HardwareFaults::from_bits_truncate(u32::from(*arg))),
                    1 => self.motor.clear_faults(),
                    2 => self.motor.set_input(DigitalInputs::from_bits_truncate(u32::from(*arg)), true),
                    3 => self.motor.set_input(DigitalInputs::all(), false),
                    4 => self.motor.set_load_torque(f64::from(*arg as i16) / 10.0),
                    _ => self.motor.set_local_control(arg & 1 != 0),
                }
                Ok(())
            }
            Op::CanState(state) => {
                let state = match state % 4 {
                    0 => CanState::BusOff,
                    1 => CanState::ErrorActive,
                    2 => CanState::ErrorPassive,
                    _ => CanState::Overrun,
                };
                self.drive.on_can_state(state, self.now);
                self.drain(Origin::Timer)?;
                self.poll()
            }
            other => match other.as_frame(node) {
                Some(Op::Frame { id, rtr, data }) => self.frame(id, &data, rtr),
                _ => match other {
                    Op::Frame { id, rtr, data } => self.frame(*id, data, *rtr),
                    _ => Ok(()),
                },
            },
        }
    }

    /// A write to a PDO record, its value chosen from `kind` and `raw` (see [`Op::PdoConfig`]).
    fn pdo_config(&mut self, which: u8, sub: u8, kind: u8, raw: u32) -> Checked {
        let tpdo = which & 1 != 0;
        let number = u16::from((which >> 1) & 3);
        let mapping = which & 8 != 0;
        let index = match (tpdo, mapping) {
            (false, false) => 0x1400,
            (false, true) => 0x1600,
            (true, false) => 0x1800,
            (true, true) => 0x1A00,
        } + number;
        let highest = self.drive.od().object(index).map_or(0, |(o, _)| o.highest_sub());
        let sub = sub % (highest + 1);
        let current = self.drive.od().get::<u32>(index, sub).unwrap_or(0);
        let value = if mapping {
            let list = if tpdo { &self.mappable.1 } else { &self.mappable.0 };
            match (sub, kind % 4) {
                (0, _) => raw % 9,
                (_, 0) => list.get(raw as usize % list.len().max(1)).copied().unwrap_or(0),
                (_, 1) => [0x0001_0001, 0x0002_0008, 0x0005_0008, 0x0003_0010, 0x0006_0010, 0x0007_0020]
                    [raw as usize % 6],
                (_, 2) => raw,
                _ => 0,
            }
        } else {
            match (sub, kind % 4) {
                (1, 0) => current | 0x8000_0000,
                (1, 1) => current & !0x8000_0000,
                (1, 3) => 0x8000_0000 | (current & 0x4000_0000) | (raw & 0x7FF),
                _ => raw,
            }
        };
        let size = match self.drive.od().entry(index, sub) {
            Ok(entry) => entry.var.data_type.fixed_size().unwrap_or(4).clamp(1, 4) as u8,
            Err(_) => 4,
        };
        let node = self.drive.node_id();
        let op = Op::SdoWrite { index, sub, size, value };
        match op.as_frame(node) {
            Some(Op::Frame { id, data, .. }) => self.frame(id, &data, false),
            _ => Ok(()),
        }
    }

    /// Delivers a frame to the drive at the current instant.
    pub fn frame(&mut self, id: u16, data: &[u8], rtr: bool) -> Checked {
        let frame = if id & EXTENDED != 0 {
            canopen_drive::frame::extended(u32::from(id & 0x7FF), data)
        } else if rtr {
            CanFrame::new_remote_standard(id, data.len() as u8)
        } else {
            CanFrame::new_standard(id, data)
        };
        let Some(frame) = frame else { return Ok(()) };
        let node = self.drive.node_id();
        let serves_sdo = matches!(self.drive.nmt_state(), NmtState::PreOperational | NmtState::Operational);
        let origin = if !rtr && self.drive.is_configured() && id == 0x600 + u16::from(node) && serves_sdo {
            self.sdo.request(data);
            Origin::SdoRequest(node)
        } else if !rtr && id == 0x7E5 {
            Origin::LssRequest
        } else {
            Origin::Other
        };
        self.drive.on_frame(&frame, self.now);
        self.drain(origin)?;
        self.poll()
    }

    /// Polls the drive at the current instant (again while it asks for it).
    fn poll(&mut self) -> Checked {
        self.polled = self.now;
        let mut polls = 0;
        loop {
            self.deadline = self.drive.poll(self.now);
            self.drain(Origin::Timer)?;
            polls += 1;
            match self.deadline {
                Some(d) if d <= self.now => {
                    if polls > MAX_POLLS_PER_INSTANT {
                        return Err(format!("poll livelock at {:?}: deadline {d:?}", self.now));
                    }
                }
                _ => return Ok(()),
            }
        }
    }

    /// Lets `span` pass: ticks every [`TICK`] and polls at every deadline (at most every
    /// [`MIN_POLL_INTERVAL`]); after `max_ticks` ticks the board stalls for the rest of the
    /// span (nothing runs until its end), then ticks and polls once at its end.
    fn advance(&mut self, span: Duration, max_ticks: u32) -> Checked {
        let end = self.now + span;
        let mut ticks = 0u32;
        loop {
            let next = match self.deadline {
                Some(d) => d.max(self.polled + MIN_POLL_INTERVAL).min(self.next_tick),
                None => self.next_tick,
            };
            if next > end {
                break;
            }
            self.now = self.now.max(next);
            if self.now >= self.next_tick {
                self.tick()?;
                ticks += 1;
                self.next_tick = self.now + TICK;
                if ticks >= max_ticks && self.now < end {
                    self.now = end;
                    self.next_tick = end;
                    continue;
                }
            }
            self.poll()?;
        }
        self.now = end;
        self.poll()
    }

    /// One control tick with the invariants of the demand.
    fn tick(&mut self) -> Checked {
        let sample = self.motor.sample();
        self.demand = self.drive.tick(self.now, &sample);
        self.stats.ticks += 1;
        self.motor.step(&self.demand, TICK);
        let state: State = self.drive.state();
        let od = self.drive.od();
        let limits = self.limits.get_or_insert_with(|| DemandLimits::configured(od)).at(od);
        if cfg!(feature = "tools") && std::env::var_os("FUZZ_TRACE_TICKS").is_some() {
            eprintln!(
                "tick {:?} {state:?} {:?} {limits:?} sample v {}",
                self.now, self.demand, sample.velocity
            );
            eprintln!(
                "   6061h {:?} 60B1h {:?} 6062h {:?} 6064h {:?} 607Ah {:?} 6041h {:04X?} 6040h {:04X?}",
                od.get::<i8>(0x6061, 0),
                od.get::<i32>(0x60B1, 0),
                od.get::<i32>(0x6062, 0),
                od.get::<i32>(0x6064, 0),
                od.get::<i32>(0x607A, 0),
                od.get::<u16>(0x6041, 0),
                od.get::<u16>(0x6040, 0)
            );
        }
        let demands = &mut self.demands;
        invariants::check_energy(state, &self.demand)
            .and_then(|()| demands.check(&self.demand, limits, &sample))
            .and_then(|()| invariants::check_statusword(od, state))
            .map_err(|e| format!("tick at {:?}: {e}", self.now))?;
        self.drain(Origin::Tick)
    }

    /// Takes every frame the drive queued and checks who may have sent it.
    fn drain(&mut self, origin: Origin) -> Checked {
        let node = self.drive.node_id();
        let mut sdo_answers = 0;
        let mut lss_answers = 0;
        while let Some(frame) = self.drive.pop_tx() {
            self.stats.sent += 1;
            let id = frame.standard_id().unwrap_or(0xFFFF);
            let data = frame.data();
            if id == 0x7E4 {
                lss_answers += 1;
            } else if !self.drive.is_configured() {
                return Err(format!("an unconfigured node sent {id:03X} {data:02X?}"));
            }
            match origin {
                Origin::SdoRequest(n) if id == 0x580 + u16::from(n) => sdo_answers += 1,
                _ if self.drive.is_configured() && id == 0x580 + u16::from(node) => {
                    if origin == Origin::Tick {
                        return Err(format!("an SDO frame from the tick: {data:02X?}"));
                    }
                    self.sdo.unsolicited(data)?;
                }
                _ => {}
            }
            self.sent.push(frame);
        }
        if origin != Origin::LssRequest && lss_answers > 0 {
            return Err("an LSS response without an LSS request".into());
        }
        if lss_answers > 1 {
            return Err(format!("{lss_answers} LSS responses to one request"));
        }
        if let Origin::SdoRequest(_) = origin {
            self.sdo.answered(sdo_answers)?;
        }
        Ok(())
    }
}

/// What made the drive send the frames being drained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Origin {
    /// An SDO request to node `n`.
    SdoRequest(u8),
    /// An LSS request.
    LssRequest,
    /// Any other frame.
    Other,
    /// `poll`, or a report of the board.
    Timer,
    /// `tick`.
    Tick,
}

/// A second drive with the state of `drive`.
///
/// `Drive` is not `Clone`. A `Drive<RigHooks>` holds its values inline (arrays, integers,
/// heapless queues of `Copy` frames; `RigHooks` and the storage `()` are empty) and shared
/// `&'static` tables: no heap, no `&mut`, no pointer into itself (the copy technique of
/// `benches/drive-bench`). Its bytes are therefore a second, independent drive, and dropping
/// both releases nothing twice: the destructors of heapless containers drop their elements,
/// and frames own nothing.
#[allow(unsafe_code)]
fn copy_drive(drive: &Drive<RigHooks>) -> Drive<RigHooks> {
    // SAFETY: `drive` is a valid, initialised value, read once; the bytes of this plain-data
    // type are a valid value of it, and neither value owns a resource the other could free
    // (see above).
    unsafe { core::ptr::read(drive) }
}

/// Every entry the dictionary lets map into an RPDO and a TPDO, as mapping values.
fn mappable_entries(drive: &Drive<RigHooks>) -> (Vec<u32>, Vec<u32>) {
    let od = drive.od();
    let mut rpdo = Vec::new();
    let mut tpdo = Vec::new();
    for entry in invariants::entries(od) {
        let var = entry.var;
        let Some(size) = var.data_type.fixed_size() else { continue };
        if var.is_fixed() {
            continue;
        }
        let value = (u32::from(entry.index()) << 16) | (u32::from(entry.sub) << 8) | (size as u32 * 8);
        if matches!(var.pdo, PdoMapping::Rpdo | PdoMapping::Both) && var.access.writable() {
            rpdo.push(value);
        }
        if matches!(var.pdo, PdoMapping::Tpdo | PdoMapping::Both) && var.access.readable() {
            tpdo.push(value);
        }
    }
    (rpdo, tpdo)
}

/// Runs a whole program: the ops of `data` decoded with `tags`, at most `max_ops` of them.
/// Panics with the description of the first violated invariant.
pub fn run_program(rig: &mut Rig, data: &[u8], tags: &[crate::ops::Tag], max_ops: usize) {
    let mut reader = crate::Reader::new(data);
    let mut count = 0;
    // `replay` with FUZZ_TRACE_OPS set prints the program as it runs.
    let trace = cfg!(feature = "tools") && std::env::var_os("FUZZ_TRACE_OPS").is_some();
    while !reader.is_empty() && count < max_ops {
        let op = Op::read(&mut reader, tags);
        if trace {
            eprintln!("{count:4}: {op:?}");
        }
        if let Err(violation) = rig.run(&op) {
            panic!("invariant violated: {violation}");
        }
        count += 1;
    }
}

//! A drive node for the virtual bus that checks the invariants at every tick: like
//! `canopen_drive_sim::DriveNode` (ticked at a fixed period against a `SimMotor`), plus
//! invariant 1 (energy), 2 (velocity/torque limits), the statusword, and invariant 3 (the
//! dictionary) every `od_check_every` ticks and on request. It can play a controller that is
//! bus-off (every frame the drive queues is lost) and records what the scenarios look at.

use canopen_drive::cia402::ProfileConfig;
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::Entry;
use canopen_drive::{CanFrame, Config, Drive, Duration, Instant};
use canopen_drive_sim::bus::Node;
use canopen_drive_sim::invariants::{self, DemandLimits, DemandWatch};
use canopen_drive_sim::SimMotor;

use crate::common::{TestHooks, NODE, TEST_OBJECTS};

/// One tick as the scenarios see it.
#[derive(Clone, Copy, Debug)]
pub struct TickRecord {
    pub at: Instant,
    pub demand: Demand,
    pub sample: Sample,
}

pub struct Watched {
    pub drive: Drive<TestHooks>,
    pub motor: SimMotor,
    pub demand: Demand,
    profile: ProfileConfig,
    entries: Vec<Entry>,
    demands: DemandWatch,
    period: Duration,
    next_tick: Option<Instant>,
    pub ticks: u64,
    /// Check the dictionary every this many ticks (0: never by itself).
    pub od_check_every: u64,
    pub od_checks: u64,
    /// The CAN controller is off the bus: queued frames are lost.
    pub bus_off: bool,
    pub lost_frames: u64,
    /// Keep a [`TickRecord`] of every tick.
    pub record: bool,
    pub records: Vec<TickRecord>,
    /// Frames received.
    pub received: u64,
    /// Longest wall time of one `on_frame` and one `tick` (printed, not asserted).
    pub max_frame_wall: std::time::Duration,
    pub max_tick_wall: std::time::Duration,
}

impl Watched {
    /// The test drive (node 5 with the test objects) as `adjust` configures it, ticked every
    /// `period` (the configuration's tick rate must agree).
    pub fn new(adjust: impl FnOnce(Config) -> Config, period: Duration) -> Self {
        let config = adjust(Config { manufacturer_objects: &TEST_OBJECTS, ..Config::new(NODE) });
        let drive = Drive::with_hooks(config, TestHooks::default()).expect("the test drive builds");
        let entries = invariants::entries(drive.od());
        Watched {
            drive,
            motor: SimMotor::new(),
            demand: Demand::OFF,
            profile: config.profile,
            entries,
            demands: DemandWatch::default(),
            period,
            next_tick: None,
            ticks: 0,
            od_check_every: 100,
            od_checks: 0,
            bus_off: false,
            lost_frames: 0,
            record: false,
            records: Vec::new(),
            received: 0,
            max_frame_wall: std::time::Duration::ZERO,
            max_tick_wall: std::time::Duration::ZERO,
        }
    }

    /// Invariant 3 now (panics with the violation).
    pub fn check_dictionary(&mut self) {
        self.od_checks += 1;
        if let Err(e) = invariants::check_entries(self.drive.od(), &self.entries, &self.profile) {
            panic!("dictionary inconsistent at {:?}: {e}", self.next_tick);
        }
    }

    fn tick(&mut self, now: Instant) {
        let sample = self.motor.sample();
        let started = std::time::Instant::now();
        self.demand = self.drive.tick(now, &sample);
        self.max_tick_wall = self.max_tick_wall.max(started.elapsed());
        self.motor.step(&self.demand, self.period);
        self.ticks += 1;
        let state = self.drive.state();
        let od = self.drive.od();
        let checked = invariants::check_energy(state, &self.demand)
            .and_then(|()| self.demands.check(&self.demand, DemandLimits::of(od), &sample))
            .and_then(|()| invariants::check_statusword(od, state));
        if let Err(e) = checked {
            panic!("tick at {now:?}: {e}");
        }
        if self.od_check_every != 0 && self.ticks.is_multiple_of(self.od_check_every) {
            self.check_dictionary();
        }
        if self.record {
            self.records.push(TickRecord { at: now, demand: self.demand, sample });
        }
    }
}

impl Node for Watched {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        let started = std::time::Instant::now();
        self.drive.on_frame(frame, now);
        self.max_frame_wall = self.max_frame_wall.max(started.elapsed());
        self.received += 1;
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        let due = *self.next_tick.get_or_insert(now);
        if now >= due {
            self.tick(now);
            self.next_tick = Some(due + self.period);
        }
        let next = self.drive.poll(now);
        match (next, self.next_tick) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        while self.bus_off {
            match self.drive.pop_tx() {
                Some(_) => self.lost_frames += 1,
                None => return None,
            }
        }
        self.drive.pop_tx()
    }

    fn name(&self) -> String {
        format!("node{}", self.drive.node_id())
    }
}

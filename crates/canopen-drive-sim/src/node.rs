//! A whole drive node for the virtual bus: a [`Drive`] ticked at a fixed rate against a
//! [`SimMotor`] per axis, as the board's control-loop interrupt would tick it.
//!
//! Any drive a firmware builds goes in as it is (its hooks, value store, PDO counts, parameter
//! storage and number of axes), so a host test runs the very configuration the MCU image
//! runs:
//!
//! ```
//! use canopen_drive::{Config, Drive, Duration};
//! use canopen_drive_sim::{DriveNode, Master, VirtualBus};
//!
//! let drive = Drive::new(Config::new(5)).unwrap();
//! let mut bus = VirtualBus::new();
//! let node = bus.add_drive(DriveNode::new(drive, Duration::from_micros(500)));
//! let mut master = Master::new(bus);
//! master.axis(5, 0).enable().unwrap();
//! master.axis(5, 0).pp_move(10_000, Duration::from_millis(5_000)).unwrap();
//! // The typed handle reaches the node without naming its type again: the shaft has arrived
//! // (within the position window 6067h, 100 increments by default).
//! let position = master.bus().drive(node).unwrap().motor.position();
//! assert!((position - 10_000.0).abs() <= 100.0, "{position}");
//! ```

use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::ObjectHooks;
use canopen_drive::storage::Persistence;
use canopen_drive::{CanFrame, Drive, Duration, Instant};

use crate::bus::Node;
use crate::motor::SimMotor;

/// A drive with its simulated motors and a fixed tick period.
pub struct DriveNode<
    H: ObjectHooks = (),
    const B: usize = { canopen_drive::drive::DEFAULT_OD_BYTES },
    const R: usize = 4,
    const T: usize = 4,
    S: Persistence = (),
    const AXES: usize = 1,
> {
    /// The drive.
    pub drive: Drive<H, B, R, T, S, AXES>,
    /// The motor of the first axis.
    pub motor: SimMotor,
    /// Demand of the last tick to the first axis.
    pub demand: Demand,
    /// The motors of the further axes and their last demands (axis n at `n − 1`; empty for a
    /// drive of one axis).
    pub more_axes: Vec<(SimMotor, Demand)>,
    period: Duration,
    next_tick: Option<Instant>,
    ticks: u64,
}

impl<H: ObjectHooks, const B: usize, const R: usize, const T: usize, S: Persistence, const AXES: usize>
    DriveNode<H, B, R, T, S, AXES>
{
    /// `drive` ticked every `period` (first tick at the first poll), each axis against a
    /// [`SimMotor::new`].
    pub fn new(drive: Drive<H, B, R, T, S, AXES>, period: Duration) -> Self {
        let more_axes = (1..AXES).map(|_| (SimMotor::new(), Demand::OFF)).collect();
        DriveNode {
            drive,
            motor: SimMotor::new(),
            demand: Demand::OFF,
            more_axes,
            period,
            next_tick: None,
            ticks: 0,
        }
    }

    /// Ticks run so far.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// The motor of axis `axis` (0 is [`DriveNode::motor`]).
    pub fn axis_motor(&self, axis: usize) -> Option<&SimMotor> {
        match axis {
            0 => Some(&self.motor),
            n => self.more_axes.get(n - 1).map(|(motor, _)| motor),
        }
    }

    /// One tick now: every axis's sample, the drive's tick, every motor stepped by the period.
    fn tick(&mut self, now: Instant) {
        let samples: [Sample; AXES] = core::array::from_fn(|n| match self.axis_motor(n) {
            Some(motor) => motor.sample(),
            None => Sample::default(),
        });
        let demands = self.drive.tick_axes(now, &samples);
        for (n, demand) in demands.iter().enumerate() {
            let (motor, last) = match n {
                0 => (&mut self.motor, &mut self.demand),
                n => match self.more_axes.get_mut(n - 1) {
                    Some((motor, last)) => (motor, last),
                    None => continue,
                },
            };
            motor.step(demand, self.period);
            *last = *demand;
        }
        self.ticks += 1;
    }
}

impl<
        H: ObjectHooks + 'static,
        const B: usize,
        const R: usize,
        const T: usize,
        S: Persistence + 'static,
        const AXES: usize,
    > Node for DriveNode<H, B, R, T, S, AXES>
{
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.drive.on_frame(frame, now);
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        let due = *self.next_tick.get_or_insert(now);
        if now >= due && self.period != Duration::ZERO {
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
        self.drive.pop_tx()
    }

    fn name(&self) -> String {
        format!("node{}", self.drive.node_id())
    }
}

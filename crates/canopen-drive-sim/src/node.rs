//! A whole drive node for the virtual bus: a [`Drive`] ticked at a fixed rate against a
//! [`SimMotor`], as the board's control-loop interrupt would tick it.

use canopen_drive::hal::Demand;
use canopen_drive::od::ObjectHooks;
use canopen_drive::storage::Persistence;
use canopen_drive::{CanFrame, Drive, Duration, Instant};

use crate::bus::Node;
use crate::motor::SimMotor;

/// A drive with its simulated motor and a fixed tick period.
pub struct DriveNode<
    H: ObjectHooks = (),
    const B: usize = { canopen_drive::drive::DEFAULT_OD_BYTES },
    const R: usize = 4,
    const T: usize = 4,
    S: Persistence = (),
> {
    /// The drive.
    pub drive: Drive<H, B, R, T, S>,
    /// The motor it controls.
    pub motor: SimMotor,
    /// Demand of the last tick.
    pub demand: Demand,
    period: Duration,
    next_tick: Option<Instant>,
    ticks: u64,
}

impl<H: ObjectHooks, const B: usize, const R: usize, const T: usize, S: Persistence>
    DriveNode<H, B, R, T, S>
{
    /// `drive` ticked every `period` (first tick at the first poll).
    pub fn new(drive: Drive<H, B, R, T, S>, period: Duration) -> Self {
        DriveNode { drive, motor: SimMotor::new(), demand: Demand::OFF, period, next_tick: None, ticks: 0 }
    }

    /// Ticks run so far.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }
}

impl<H: ObjectHooks + 'static, const B: usize, const R: usize, const T: usize> Node
    for DriveNode<H, B, R, T>
{
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        self.drive.on_frame(frame, now);
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        let due = *self.next_tick.get_or_insert(now);
        if now >= due && self.period != Duration::ZERO {
            let sample = self.motor.sample();
            self.demand = self.drive.tick(now, &sample);
            self.motor.step(&self.demand, self.period);
            self.ticks += 1;
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

//! The fixed-rate control tick: as an async task for embassy's `InterruptExecutor`, and a
//! monitor of how late ticks run (for either kind of tick).

use core::sync::atomic::{AtomicU32, Ordering};

use canopen_drive::hal::{Demand, Sample};
use embassy_time::{Duration, Instant, Timer};

use crate::lock::Lock;
use crate::shared::{SharedDrive, Tick};

/// How late the ticks ran: the time from when a tick was due to when it started, as the
/// board measures it (µs, or timer counts: the monitor does not care).
///
/// One writer (the tick context) calls [`TickMonitor::record`]; any context reads. Only plain
/// atomic loads and stores are used, so it works on thumbv6m too.
#[derive(Debug, Default)]
pub struct TickMonitor {
    ticks: AtomicU32,
    max_lateness: AtomicU32,
    total_lateness: AtomicU32,
}

impl TickMonitor {
    /// No ticks yet.
    pub const fn new() -> Self {
        TickMonitor {
            ticks: AtomicU32::new(0),
            max_lateness: AtomicU32::new(0),
            total_lateness: AtomicU32::new(0),
        }
    }

    /// Records one tick that started `lateness` after it was due. Call only from the tick.
    pub fn record(&self, lateness: u32) {
        self.ticks.store(self.ticks.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
        let total = self.total_lateness.load(Ordering::Relaxed).saturating_add(lateness);
        self.total_lateness.store(total, Ordering::Relaxed);
        if lateness > self.max_lateness.load(Ordering::Relaxed) {
            self.max_lateness.store(lateness, Ordering::Relaxed);
        }
    }

    /// Ticks recorded since the last reset.
    pub fn ticks(&self) -> u32 {
        self.ticks.load(Ordering::Relaxed)
    }

    /// The largest lateness since the last reset.
    pub fn max_lateness(&self) -> u32 {
        self.max_lateness.load(Ordering::Relaxed)
    }

    /// The mean lateness since the last reset (0 without ticks).
    pub fn mean_lateness(&self) -> u32 {
        self.total_lateness.load(Ordering::Relaxed).checked_div(self.ticks()).unwrap_or(0)
    }

    /// Starts a new measurement. From another context than the tick, a tick running at the
    /// same moment may keep its own record: fine for statistics.
    pub fn reset(&self) {
        self.ticks.store(0, Ordering::Relaxed);
        self.max_lateness.store(0, Ordering::Relaxed);
        self.total_lateness.store(0, Ordering::Relaxed);
    }
}

/// The control tick as a task: every `period`, `sample` the sensors, [`SharedDrive::tick`],
/// `apply` the demand. Spawn it on an `InterruptExecutor` whose interrupt has a higher
/// priority than the runner's. Lateness (µs) goes to `monitor`. After a stall the grid
/// restarts instead of catching up in a burst.
pub async fn run_tick<D: Tick, L: Lock>(
    drive: &SharedDrive<D, L>,
    period: Duration,
    monitor: &TickMonitor,
    mut sample: impl FnMut() -> Sample,
    mut apply: impl FnMut(&Demand),
) -> ! {
    let mut due = Instant::now() + period;
    loop {
        Timer::at(due).await;
        let started = Instant::now();
        let lateness = started.saturating_duration_since(due).as_micros();
        monitor.record(u32::try_from(lateness).unwrap_or(u32::MAX));
        let demand = drive.tick(crate::now(), &sample());
        apply(&demand);
        due += period;
        if due <= started {
            due = started + period;
        }
    }
}

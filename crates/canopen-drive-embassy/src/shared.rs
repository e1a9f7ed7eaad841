//! The drive shared between the tick interrupt and the communication context.

use core::cell::RefCell;

use canopen_drive::drive::{BitRateChange, CanState, Drive};
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::ObjectHooks;
use canopen_drive::storage::Persistence;
use canopen_drive::wire::lss::BitTiming;
use canopen_drive::{CanFrame, Instant};
use critical_section::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;

/// The entry points of a node, as the runner and the tick call them. Implemented for every
/// [`Drive`]; a firmware may implement it for a node of its own (a CiA 301-only node has a
/// `tick` that does nothing).
pub trait Endpoints {
    /// [`Drive::on_frame`].
    fn on_frame(&mut self, frame: &CanFrame, now: Instant);
    /// [`Drive::poll`].
    fn poll(&mut self, now: Instant) -> Option<Instant>;
    /// [`Drive::pop_tx`].
    fn pop_tx(&mut self) -> Option<CanFrame>;
    /// True when frames wait for transmission.
    fn has_tx(&self) -> bool;
    /// [`Drive::tick`].
    fn tick(&mut self, now: Instant, sample: &Sample) -> Demand;
    /// [`Drive::on_can_state`]; nodes without CAN error handling ignore it.
    fn on_can_state(&mut self, state: CanState, now: Instant) {
        let _ = (state, now);
    }
    /// [`Drive::take_bit_rate_change`]; nodes without LSS have none.
    fn take_bit_rate_change(&mut self) -> Option<BitRateChange> {
        None
    }
    /// [`Drive::take_lss_store`]; nodes without LSS have none.
    fn take_lss_store(&mut self) -> Option<(u8, Option<BitTiming>)> {
        None
    }
}

impl<H: ObjectHooks, const OD: usize, const R: usize, const T: usize, S: Persistence> Endpoints
    for Drive<H, OD, R, T, S>
{
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        Drive::on_frame(self, frame, now);
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        Drive::poll(self, now)
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        Drive::pop_tx(self)
    }

    fn has_tx(&self) -> bool {
        self.peek_tx().is_some()
    }

    fn tick(&mut self, now: Instant, sample: &Sample) -> Demand {
        Drive::tick(self, now, sample)
    }

    fn on_can_state(&mut self, state: CanState, now: Instant) {
        Drive::on_can_state(self, state, now);
    }

    fn take_bit_rate_change(&mut self) -> Option<BitRateChange> {
        Drive::take_bit_rate_change(self)
    }

    fn take_lss_store(&mut self) -> Option<(u8, Option<BitTiming>)> {
        Drive::take_lss_store(self)
    }
}

/// A node owned elsewhere (e.g. in a `StaticCell`, so that the shared `static` holds only a
/// pointer and starts zeroed in `.bss`).
impl<D: Endpoints + ?Sized> Endpoints for &mut D {
    fn on_frame(&mut self, frame: &CanFrame, now: Instant) {
        (**self).on_frame(frame, now);
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        (**self).poll(now)
    }

    fn pop_tx(&mut self) -> Option<CanFrame> {
        (**self).pop_tx()
    }

    fn has_tx(&self) -> bool {
        (**self).has_tx()
    }

    fn tick(&mut self, now: Instant, sample: &Sample) -> Demand {
        (**self).tick(now, sample)
    }

    fn on_can_state(&mut self, state: CanState, now: Instant) {
        (**self).on_can_state(state, now);
    }

    fn take_bit_rate_change(&mut self) -> Option<BitRateChange> {
        (**self).take_bit_rate_change()
    }

    fn take_lss_store(&mut self) -> Option<(u8, Option<BitTiming>)> {
        (**self).take_lss_store()
    }
}

/// A node behind a critical-section mutex, for a `static`: every method is one critical
/// section around one bounded call (see the crate docs for the discipline).
///
/// `D` is the drive itself, or `&'static mut` to a drive kept in a `StaticCell`: a `Drive` is
/// several KiB, and a `static SharedDrive<Drive>` starts as `None`, which the compiler may put
/// in `.data` (flash and RAM) rather than `.bss`.
pub struct SharedDrive<D> {
    drive: Mutex<RefCell<Option<D>>>,
    /// Raised when frames were queued outside the runner (by the tick): wakes the runner.
    kick: Signal<CriticalSectionRawMutex, ()>,
}

impl<D> Default for SharedDrive<D> {
    fn default() -> Self {
        Self::new()
    }
}

impl<D> SharedDrive<D> {
    /// An empty slot: until [`SharedDrive::put`] every call does nothing.
    pub const fn new() -> Self {
        SharedDrive { drive: Mutex::new(RefCell::new(None)), kick: Signal::new() }
    }

    /// Puts the drive in (replacing any previous one) and wakes the runner.
    pub fn put(&self, drive: D) {
        critical_section::with(|cs| {
            if let Ok(mut slot) = self.drive.borrow(cs).try_borrow_mut() {
                *slot = Some(drive);
            }
        });
        self.kick.signal(());
    }

    /// Runs `f` on the drive inside one critical section. `None` when the slot is empty or
    /// the drive is already borrowed (a hook calling back in).
    pub fn with<R>(&self, f: impl FnOnce(&mut D) -> R) -> Option<R> {
        critical_section::with(|cs| {
            let mut slot = self.drive.borrow(cs).try_borrow_mut().ok()?;
            slot.as_mut().map(f)
        })
    }

    /// Wakes the runner, e.g. after a [`SharedDrive::with`] that queued frames.
    pub fn wake_runner(&self) {
        self.kick.signal(());
    }

    /// Waits until something outside the runner queued frames.
    pub(crate) async fn kicked(&self) {
        self.kick.wait().await;
    }
}

impl<D: Endpoints> SharedDrive<D> {
    /// One received frame.
    pub fn on_frame(&self, frame: &CanFrame, now: Instant) {
        self.with(|d| d.on_frame(frame, now));
    }

    /// Timers and background work; the next deadline.
    pub fn poll(&self, now: Instant) -> Option<Instant> {
        self.with(|d| d.poll(now)).flatten()
    }

    /// The next frame for the CAN controller.
    pub fn pop_tx(&self) -> Option<CanFrame> {
        self.with(|d| d.pop_tx()).flatten()
    }

    /// The control-loop tick, then a wake-up of the runner: the tick may have queued frames
    /// (TPDOs) or made work that only `poll` does (an EMCY to send, an inhibit time to wait
    /// out), so the runner polls after every tick (one short `poll` per tick in the
    /// communication context; wake-ups that come while the runner is busy merge into one).
    /// Without a drive (or re-entered) the demand is [`Demand::OFF`]: no energy to the motor.
    pub fn tick(&self, now: Instant, sample: &Sample) -> Demand {
        let demand = self.with(|d| d.tick(now, sample));
        self.kick.signal(());
        demand.unwrap_or(Demand::OFF)
    }
}

//! The drive shared between the tick interrupt and the communication context.

use core::cell::{Cell, RefCell};
use core::future::poll_fn;
use core::task::{Poll, Waker};

use canopen_drive::drive::{BitRateChange, CanState, Drive};
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::ObjectHooks;
use canopen_drive::storage::Persistence;
use canopen_drive::wire::lss::BitTiming;
use canopen_drive::{CanFrame, Instant};

use crate::lock::{CriticalSection, Lock};

/// The communication entry points of a node, as the runner calls them. Implemented for every
/// [`Drive`] (any value store, PDO counts, storage and number of axes); a firmware may
/// implement it for a node of its own. The control tick is [`Tick`].
pub trait Endpoints {
    /// [`Drive::on_frame`].
    fn on_frame(&mut self, frame: &CanFrame, now: Instant);
    /// [`Drive::poll`].
    fn poll(&mut self, now: Instant) -> Option<Instant>;
    /// [`Drive::pop_tx`].
    fn pop_tx(&mut self) -> Option<CanFrame>;
    /// True when frames wait for transmission.
    fn has_tx(&self) -> bool;
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

/// The control tick of a node of `AXES` CiA 402 axes (one by default), as the tick task or
/// interrupt calls it: [`Drive::tick_axes`] (for one axis, [`Drive::tick`]). Implemented for
/// every [`Drive`] with its number of axes; a CiA 301-only node of a firmware's own has a tick
/// that does nothing.
pub trait Tick<const AXES: usize = 1>: Endpoints {
    /// One sample per axis in, one demand per axis out.
    fn tick_axes(&mut self, now: Instant, samples: &[Sample; AXES]) -> [Demand; AXES];
}

impl<H: ObjectHooks, const OD: usize, const R: usize, const T: usize, S: Persistence, const AXES: usize>
    Endpoints for Drive<H, OD, R, T, S, AXES>
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

impl<H: ObjectHooks, const OD: usize, const R: usize, const T: usize, S: Persistence, const AXES: usize>
    Tick<AXES> for Drive<H, OD, R, T, S, AXES>
{
    fn tick_axes(&mut self, now: Instant, samples: &[Sample; AXES]) -> [Demand; AXES] {
        Drive::tick_axes(self, now, samples)
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

impl<D: Tick<AXES> + ?Sized, const AXES: usize> Tick<AXES> for &mut D {
    fn tick_axes(&mut self, now: Instant, samples: &[Sample; AXES]) -> [Demand; AXES] {
        (**self).tick_axes(now, samples)
    }
}

/// A node shared by the tick and the communication side, for a `static`: every method is one
/// bounded call into the node under the lock `L` (see the crate docs for the discipline).
///
/// `L` is [`CriticalSection`] by default (every interrupt masked while the drive works: any
/// target). On a Cortex-M with a current loop above the tick, [`PriorityCeiling`](crate::PriorityCeiling) at the tick's
/// priority masks only what is at or below the tick.
///
/// `D` is the drive itself, or `&'static mut` to a drive kept in a `StaticCell`: a `Drive` is
/// several KiB, and a `static SharedDrive<Drive>` starts as `None`, which the compiler may put
/// in `.data` (flash and RAM) rather than `.bss`.
///
/// The runner needs no particular executor from it: a firmware without async calls
/// [`on_frame`](Self::on_frame), [`poll`](Self::poll), [`pop_tx`](Self::pop_tx) and
/// [`tick`](Self::tick) from its own handlers (`boards/qemu-mps2/src/bin/bare_interrupts.rs`).
pub struct SharedDrive<D, L = CriticalSection> {
    lock: L,
    /// The node; a `RefCell` so that a hook calling back in finds it borrowed.
    drive: RefCell<Option<D>>,
    /// Frames were queued outside the runner (by the tick): the runner should poll.
    kicked: Cell<bool>,
    /// The runner's waker while it waits for a kick.
    waker: Cell<Option<Waker>>,
}

// SAFETY: the cells are touched only inside `self.lock.lock`, which runs one context at a time
// (the contract of `Lock`); the node moves between contexts with them, hence `D: Send`.
#[allow(unsafe_code)]
unsafe impl<D: Send, L: Lock + Sync> Sync for SharedDrive<D, L> {}

impl<D, L: Lock> Default for SharedDrive<D, L> {
    fn default() -> Self {
        Self::new()
    }
}

impl<D, L: Lock> SharedDrive<D, L> {
    /// An empty slot: until [`SharedDrive::put`] every call does nothing.
    pub const fn new() -> Self {
        SharedDrive {
            lock: L::NEW,
            drive: RefCell::new(None),
            kicked: Cell::new(false),
            waker: Cell::new(None),
        }
    }

    /// Puts the drive in (replacing any previous one) and wakes the runner. Does nothing from a
    /// context the lock refuses.
    pub fn put(&self, drive: D) {
        let waker = self.lock.lock(|| {
            if let Ok(mut slot) = self.drive.try_borrow_mut() {
                *slot = Some(drive);
            }
            self.kick()
        });
        wake(waker);
    }

    /// Runs `f` on the drive under the lock. `None` when the slot is empty, the drive is
    /// already borrowed (a hook calling back in), or the lock refuses the calling context.
    pub fn with<R>(&self, f: impl FnOnce(&mut D) -> R) -> Option<R> {
        self.lock
            .lock(|| {
                let mut slot = self.drive.try_borrow_mut().ok()?;
                slot.as_mut().map(f)
            })
            .flatten()
    }

    /// Wakes the runner, e.g. after a [`SharedDrive::with`] that queued frames.
    pub fn wake_runner(&self) {
        wake(self.lock.lock(|| self.kick()));
    }

    /// Marks the kick; the runner's waker, to wake once the lock is let go. Call under the lock.
    fn kick(&self) -> Option<Waker> {
        self.kicked.set(true);
        self.waker.take()
    }

    /// Waits until something outside the runner queued frames. From a context the lock
    /// refuses it never waits (the runner then spins, doing nothing: the drive refuses it too).
    pub(crate) async fn kicked(&self) {
        poll_fn(|cx| {
            let waiting = self.lock.lock(|| {
                if self.kicked.replace(false) {
                    return (false, None);
                }
                let previous = self.waker.take();
                let stale = match previous {
                    Some(w) if w.will_wake(cx.waker()) => {
                        self.waker.set(Some(w));
                        None
                    }
                    other => {
                        self.waker.set(Some(cx.waker().clone()));
                        other
                    }
                };
                (true, stale)
            });
            match waiting {
                // A waker of another task is let go (dropped) outside the lock.
                Some((true, _stale)) => Poll::Pending,
                Some((false, _)) | None => Poll::Ready(()),
            }
        })
        .await;
    }
}

/// Wakes the runner, outside the lock (a wake may take the executor's own lock).
fn wake(waker: Option<Option<Waker>>) {
    if let Some(waker) = waker.flatten() {
        waker.wake();
    }
}

impl<D: Endpoints, L: Lock> SharedDrive<D, L> {
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

    /// The control-loop tick of a one-axis node ([`tick_axes`](Self::tick_axes)).
    pub fn tick(&self, now: Instant, sample: &Sample) -> Demand
    where
        D: Tick<1>,
    {
        let [demand] = self.tick_axes(now, core::array::from_ref(sample));
        demand
    }

    /// The control-loop tick, then a wake-up of the runner: the tick may have queued frames
    /// (TPDOs) or made work that only `poll` does (an EMCY to send, an inhibit time to wait
    /// out), so the runner polls after every tick (one short `poll` per tick in the
    /// communication context; wake-ups that come while the runner is busy merge into one).
    /// One hold of the lock for both. Without a drive, re-entered, or from a context the lock
    /// refuses, every demand is [`Demand::OFF`]: no energy to the motors.
    pub fn tick_axes<const AXES: usize>(&self, now: Instant, samples: &[Sample; AXES]) -> [Demand; AXES]
    where
        D: Tick<AXES>,
    {
        let result = self.lock.lock(|| {
            let demands = match self.drive.try_borrow_mut() {
                Ok(mut slot) => slot.as_mut().map(|d| d.tick_axes(now, samples)),
                Err(_) => None,
            };
            (demands, self.kick())
        });
        let (demands, waker) = result.unwrap_or((None, None));
        wake(Some(waker));
        demands.unwrap_or([Demand::OFF; AXES])
    }
}

#[cfg(test)]
#[allow(unsafe_code)] // test locks implement the unsafe trait
mod tests {
    extern crate std;

    use core::future::Future;
    use core::pin::pin;
    use core::sync::atomic::{AtomicUsize, Ordering};
    use core::task::Context;
    use std::sync::Arc;
    use std::task::Wake;

    use canopen_drive::hal::Setpoint;

    use super::*;

    /// A node whose tick always demands energy, so that `Demand::OFF` can only come from the
    /// shared drive.
    #[derive(Default)]
    struct Node {
        ticks: u32,
    }

    const ON: Demand = Demand { drive_enabled: true, setpoint: Setpoint::Torque(5), ..Demand::OFF };

    impl Endpoints for Node {
        fn on_frame(&mut self, _frame: &CanFrame, _now: Instant) {}
        fn poll(&mut self, _now: Instant) -> Option<Instant> {
            None
        }
        fn pop_tx(&mut self) -> Option<CanFrame> {
            None
        }
        fn has_tx(&self) -> bool {
            false
        }
    }

    impl Tick for Node {
        fn tick_axes(&mut self, _now: Instant, _samples: &[Sample; 1]) -> [Demand; 1] {
            self.ticks += 1;
            [ON]
        }
    }

    /// A lock that refuses every context, as `PriorityCeiling` refuses one above its ceiling.
    struct Refusing;
    // SAFETY: `f` never runs.
    unsafe impl Lock for Refusing {
        const NEW: Self = Refusing;
        fn lock<R>(&self, _f: impl FnOnce() -> R) -> Option<R> {
            None
        }
    }

    /// A lock for one thread that counts how often it is taken.
    struct Counting {
        holds: Cell<usize>,
    }
    // SAFETY: `Counting` is not `Sync`: one thread, so one context.
    unsafe impl Lock for Counting {
        const NEW: Self = Counting { holds: Cell::new(0) };
        fn lock<R>(&self, f: impl FnOnce() -> R) -> Option<R> {
            self.holds.set(self.holds.get() + 1);
            Some(f())
        }
    }

    #[derive(Default)]
    struct Wakes(AtomicUsize);
    impl Wake for Wakes {
        fn wake(self: Arc<Self>) {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
    }

    #[test]
    fn a_refused_context_changes_nothing_and_gives_the_motor_no_energy() {
        let shared: SharedDrive<Node, Refusing> = SharedDrive::new();
        shared.put(Node::default());
        assert_eq!(shared.with(|n| n.ticks), None);
        assert_eq!(shared.tick(Instant::from_micros(0), &Sample::default()), Demand::OFF);
        // The runner is not kept waiting on a lock it cannot take.
        let waker = Arc::new(Wakes::default()).into();
        let mut cx = Context::from_waker(&waker);
        assert!(pin!(shared.kicked()).poll(&mut cx).is_ready());
    }

    #[test]
    fn a_tick_is_one_hold_of_the_lock_and_wakes_the_waiting_runner() {
        let shared: SharedDrive<Node, Counting> = SharedDrive::new();
        shared.put(Node::default());
        let wakes = Arc::new(Wakes::default());
        let waker = wakes.clone().into();
        let mut cx = Context::from_waker(&waker);
        // The kick of `put` first.
        assert!(pin!(shared.kicked()).poll(&mut cx).is_ready());
        let mut waiting = pin!(shared.kicked());
        assert!(waiting.as_mut().poll(&mut cx).is_pending());

        let holds = shared.lock.holds.get();
        assert_eq!(shared.tick(Instant::from_micros(0), &Sample::default()), ON);
        assert_eq!(shared.lock.holds.get(), holds + 1);
        assert_eq!(wakes.0.load(Ordering::Relaxed), 1);
        assert!(waiting.as_mut().poll(&mut cx).is_ready());
        assert_eq!(shared.with(|n| n.ticks), Some(1));
    }

    #[test]
    fn a_hook_calling_back_in_finds_the_drive_borrowed() {
        let shared: SharedDrive<Node, Counting> = SharedDrive::new();
        shared.put(Node::default());
        let inner = shared
            .with(|_| (shared.with(|n| n.ticks), shared.tick(Instant::from_micros(0), &Sample::default())));
        assert_eq!(inner, Some((None, Demand::OFF)));
    }

    #[test]
    fn a_node_of_two_axes_with_8_plus_8_pdos_ticks_both() {
        use canopen_drive::comm::pdo;
        use canopen_drive::od::{layout, Object};
        use canopen_drive::{Config, MultiAxisDrive};
        static PDOS: [Object; 32] = layout(pdo::objects::<32>(8));
        type TwoAxes = MultiAxisDrive<2, 8, 8, (), (), 8192>;
        let shared: SharedDrive<TwoAxes, Counting> = SharedDrive::new();
        let now = Instant::from_micros(0);
        let samples = [Sample::default(); 2];
        assert_eq!(shared.tick_axes(now, &samples), [Demand::OFF; 2], "no drive yet");
        let config = Config { pdo_objects: &PDOS, ..Config::new(3) };
        shared.put(TwoAxes::build(config, (), ()).unwrap());
        shared.tick_axes(now, &samples);
        shared.poll(now);
        // Boot-up through the shared drive's communication side.
        assert_eq!(shared.pop_tx().and_then(|f| f.standard_id()), Some(0x703));
        assert_eq!(
            shared.with(|d| d.axis_state(1)),
            Some(canopen_drive::cia402::fsa::State::SwitchOnDisabled)
        );
    }
}

//! The async communication runner: CAN driver ⇄ drive, `poll` at its deadline, and the
//! board's part of LSS and CAN error handling.
//!
//! Two loops joined in one future, so a transmit that waits for a free mailbox never stops
//! reception, and with board hooks a third that watches the controller's error state:
//!
//! ```text
//!   receive loop:  rx.receive().await ─► on_frame ─► LSS store to the hooks; a bit-rate
//!                  change ends the runner ─► wake the service loop
//!   service loop:  poll ─► pop_tx ─► tx.transmit().await … ─► sleep until the deadline,
//!                  a received frame, or a tick that queued frames; a deadline already
//!                  reached: yield to the executor once, then poll again
//!   bus state:     every BUS_STATE_PERIOD: hooks.bus_state() ─► on_can_state on a change
//! ```

use core::cell::RefCell;
use core::future::Future;

use canopen_drive::drive::{BitRateChange, CanState};
use canopen_drive::wire::lss::BitTiming;
use canopen_drive::CanFrame;
use embassy_futures::join::join;
use embassy_futures::select::{select, Either};
use embassy_futures::yield_now;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Timer};
use embedded_can::{Error as _, ErrorKind};

use crate::lock::Lock;
use crate::shared::{Endpoints, SharedDrive};
use crate::{now, to_embassy};

/// The receiving half of a CAN driver (the `stm32-fdcan` feature adds embassy-stm32's FDCAN
/// in module `fdcan`; other drivers wrap into this in a few lines).
pub trait CanRx {
    /// The driver's frame type.
    type Frame: embedded_can::Frame;
    /// The driver's error type.
    type Error: embedded_can::Error;
    /// Waits for the next frame.
    fn receive(&mut self) -> impl Future<Output = Result<Self::Frame, Self::Error>>;
}

/// The transmitting half of a CAN driver.
pub trait CanTx {
    /// The driver's frame type.
    type Frame: embedded_can::Frame;
    /// The driver's error type.
    type Error: embedded_can::Error;
    /// Waits for a free mailbox and queues `frame`.
    fn transmit(&mut self, frame: &Self::Frame) -> impl Future<Output = Result<(), Self::Error>>;
}

/// The fault-confinement state of a CAN controller (ISO 11898-1), as its driver reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusState {
    /// Both error counters below 128: the controller takes full part in the bus.
    ErrorActive,
    /// An error counter at 128 or above: the controller signals errors passively only.
    ErrorPassive,
    /// The transmit error counter passed 255: the controller is off the bus until it
    /// recovers.
    BusOff,
}

impl From<BusState> for CanState {
    fn from(state: BusState) -> Self {
        match state {
            BusState::ErrorActive => CanState::ErrorActive,
            BusState::ErrorPassive => CanState::ErrorPassive,
            BusState::BusOff => CanState::BusOff,
        }
    }
}

/// How often [`run_until_bit_rate_change`] asks [`RunnerHooks::bus_state`]. A controller that
/// recovers from bus-off by itself (embassy-stm32's FDCAN does) is off the bus for at least
/// 128 × 11 bit times, 1.4 ms at 1 Mbit/s: a period below that sees every bus-off.
pub const BUS_STATE_PERIOD: Duration = Duration::from_millis(1);

/// What [`run_until_bit_rate_change`] asks of the board besides moving frames. Every method
/// has a default that does nothing, so `()` serves a board that has none of these.
///
/// The runner calls the hooks in its own context (the thread-mode executor), outside the
/// drive's critical section; a hook may block (a flash write) and may use the
/// [`SharedDrive`].
pub trait RunnerHooks {
    /// The CAN controller's error state now, when the driver can tell (e.g.
    /// `fdcan::FdcanStatus::bus_state` with the `stm32-fdcan` feature). Asked every
    /// [`BUS_STATE_PERIOD`]; each change goes to the drive (`Drive::on_can_state`: EMCY 8120h
    /// while error passive, the 1029h reaction at bus-off, EMCY 8140h once recovered). The
    /// default, `None`, means the driver cannot tell: the runner stops asking.
    fn bus_state(&mut self) -> Option<BusState> {
        None
    }

    /// An LSS master's "store configuration" that the drive accepted (it answers "stored" when
    /// `Config::lss_store` is set): make `node_id` (1..=127, or 0xFF: start unconfigured) and
    /// `bit_timing` (`None`: none configured since start-up, keep the stored one) persistent,
    /// for the firmware to read at its next start into `Config::node_id` and the bit rate it
    /// opens the controller with. The default forgets them.
    fn store_lss(&mut self, node_id: u8, bit_timing: Option<BitTiming>) {
        let _ = (node_id, bit_timing);
    }
}

impl RunnerHooks for () {}

impl<H: RunnerHooks + ?Sized> RunnerHooks for &mut H {
    fn bus_state(&mut self) -> Option<BusState> {
        (**self).bus_state()
    }

    fn store_lss(&mut self, node_id: u8, bit_timing: Option<BitTiming>) {
        (**self).store_lss(node_id, bit_timing);
    }
}

/// Moves frames between the CAN driver and the drive, forever. Spawn it as one task on the
/// thread-mode executor (the tick runs elsewhere, at a higher priority).
///
/// - every received frame goes to `on_frame` at once (one critical section);
/// - `poll` runs after every received frame, every tick that queued frames, and at the
///   deadline `poll` returned; when that deadline has already come (work to do at once: a
///   bootloader erasing sector by sector, a block upload's next segments), the runner yields
///   to the executor before it polls again, so that the other tasks run and a received
///   frame is taken between two such passes;
/// - queued frames go to the driver one by one, the lock released while the driver waits;
///   a frame the driver cannot represent is dropped.
///
/// Receive errors of kind [`ErrorKind::Overrun`] are reported to the drive
/// ([`CanState::Overrun`], EMCY 8110h); others are ignored. Transmit errors drop the frame.
/// Bit-rate changes and LSS stores stay in the drive (`Drive::take_bit_rate_change`,
/// `Drive::take_lss_store` through [`SharedDrive::with`]) and the controller's error state is
/// not watched: a board with a driver that can switch its bit rate or read its error state runs
/// [`run_until_bit_rate_change`] instead.
pub async fn run<D: Endpoints, L: Lock, R: CanRx, T: CanTx>(
    drive: &SharedDrive<D, L>,
    mut rx: R,
    mut tx: T,
) -> ! {
    serve::<D, L, R, T, ()>(drive, &mut rx, &mut tx, None).await;
    // Without hooks the runner does not end.
    loop {
        core::future::pending::<()>().await;
    }
}

/// [`run`], with the board's part of LSS and CAN error handling, until an LSS master
/// activates a new bit rate.
///
/// Besides what [`run`] does:
/// - the controller's error state ([`RunnerHooks::bus_state`]) is read every
///   [`BUS_STATE_PERIOD`], and every change is reported to the drive;
/// - an LSS "store configuration" goes to [`RunnerHooks::store_lss`];
/// - an LSS "activate bit timing" ends the runner at once, before anything else is sent,
///   and returns the change. The board then does what CiA 305 asks: it waits
///   `switch_delay_ms`, reopens its controller at the new bit rate, waits `switch_delay_ms`
///   again, and calls this function again. Frames the drive queues meanwhile wait in its
///   transmit queue.
///
/// The driver halves are borrowed, so that the board can close and reopen the controller
/// between two calls. The runner ends while it may be waiting in `receive` or `transmit`;
/// a frame the driver had not yet queued is then lost, which the switch-over makes moot.
pub async fn run_until_bit_rate_change<D, L, R, T, H>(
    drive: &SharedDrive<D, L>,
    rx: &mut R,
    tx: &mut T,
    hooks: &mut H,
) -> BitRateChange
where
    D: Endpoints,
    L: Lock,
    R: CanRx,
    T: CanTx,
    H: RunnerHooks,
{
    serve(drive, rx, tx, Some(hooks)).await
}

/// The runner; with `hooks`, the board's part too. Returns only with `hooks`, at a bit-rate
/// change.
async fn serve<D, L, R, T, H>(
    drive: &SharedDrive<D, L>,
    rx: &mut R,
    tx: &mut T,
    hooks: Option<&mut H>,
) -> BitRateChange
where
    D: Endpoints,
    L: Lock,
    R: CanRx,
    T: CanTx,
    H: RunnerHooks,
{
    let with_hooks = hooks.is_some();
    // Both the receive loop and the bus-state loop call hooks; neither holds the borrow
    // across an await, so the borrows never overlap.
    let hooks = RefCell::new(hooks);
    let received = Signal::<NoopRawMutex, ()>::new();
    let receive_loop = async {
        loop {
            let result = rx.receive().await;
            let events = drive.with(|d| {
                match &result {
                    Ok(frame) => d.on_frame(&CanFrame::from_frame(frame), now()),
                    Err(e) if e.kind() == ErrorKind::Overrun => d.on_can_state(CanState::Overrun, now()),
                    Err(_) => {}
                }
                if with_hooks {
                    (d.take_lss_store(), d.take_bit_rate_change())
                } else {
                    (None, None)
                }
            });
            let (store, change) = events.unwrap_or((None, None));
            if let Some((node_id, bit_timing)) = store {
                if let Ok(mut hooks) = hooks.try_borrow_mut() {
                    if let Some(hooks) = hooks.as_mut() {
                        hooks.store_lss(node_id, bit_timing);
                    }
                }
            }
            if let Some(change) = change {
                return change;
            }
            received.signal(());
        }
    };
    let service_loop = async {
        loop {
            let deadline = drive.poll(now());
            while let Some(frame) = drive.pop_tx() {
                if let Some(out) = frame.to_frame::<T::Frame>() {
                    let _ = tx.transmit(&out).await;
                }
            }
            match deadline {
                // Due already (now, or passed while transmitting): another pass, but after the
                // executor's other tasks and the receive loop have had their turn. A wait here
                // would be ready at once after a wake-up during the pass (a tick, a frame), and
                // the loop would not return to the executor while `poll` keeps asking at once.
                Some(at) if at <= now() => yield_now().await,
                Some(at) => {
                    let woken = select(received.wait(), drive.kicked());
                    select(woken, Timer::at(to_embassy(at))).await;
                }
                None => {
                    select(received.wait(), drive.kicked()).await;
                }
            }
        }
    };
    let bus_state_loop = async {
        let mut reported = None;
        loop {
            let state = match hooks.try_borrow_mut() {
                Ok(mut hooks) => hooks.as_mut().and_then(|h| h.bus_state()),
                Err(_) => reported,
            };
            let Some(state) = state else {
                // Unknown: nothing to watch.
                core::future::pending::<()>().await;
                continue;
            };
            if reported != Some(state) {
                drive.with(|d| d.on_can_state(state.into(), now()));
                reported = Some(state);
                // The drive may have queued an EMCY.
                received.signal(());
            }
            Timer::after(BUS_STATE_PERIOD).await;
        }
    };
    match select(receive_loop, join(service_loop, bus_state_loop)).await {
        Either::First(change) => change,
        Either::Second(_) => loop {
            // Neither loop ends.
            core::future::pending::<()>().await;
        },
    }
}

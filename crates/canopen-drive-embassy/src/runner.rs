//! The async communication runner: CAN driver ⇄ drive, `poll` at its deadline.
//!
//! Two loops joined in one future, so a transmit that waits for a free mailbox never stops
//! reception:
//!
//! ```text
//!   receive loop:  rx.receive().await ─► on_frame ─► wake the service loop
//!   service loop:  poll ─► pop_tx ─► tx.transmit().await … ─► sleep until the deadline,
//!                  a received frame, or a tick that queued frames
//! ```

use core::future::Future;

use canopen_drive::drive::CanState;
use canopen_drive::CanFrame;
use embassy_futures::join::join;
use embassy_futures::select::select;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::signal::Signal;
use embassy_time::Timer;
use embedded_can::{Error as _, ErrorKind};

use crate::shared::{Endpoints, SharedDrive};
use crate::{now, to_embassy};

/// The receiving half of a CAN driver (embassy-stm32's `CanRx`/`FdcanRx` wrap into this in a
/// few lines).
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

/// Moves frames between the CAN driver and the drive, forever. Spawn it as one task on the
/// thread-mode executor (the tick runs elsewhere, at a higher priority).
///
/// - every received frame goes to `on_frame` at once (one critical section);
/// - `poll` runs after every received frame, every tick that queued frames, and at the
///   deadline `poll` returned;
/// - queued frames go to the driver one by one, the lock released while the driver waits;
///   a frame the driver cannot represent is dropped.
///
/// Receive errors of kind [`ErrorKind::Overrun`] are reported to the drive
/// ([`CanState::Overrun`], EMCY 8110h); others are ignored (bus-off is the board's to report
/// through [`SharedDrive::with`] and `Drive::on_can_state`). Transmit errors drop the frame.
pub async fn run<D: Endpoints, R: CanRx, T: CanTx>(drive: &SharedDrive<D>, mut rx: R, mut tx: T) -> ! {
    let received = Signal::<NoopRawMutex, ()>::new();
    let receive_loop = async {
        loop {
            match rx.receive().await {
                Ok(frame) => drive.on_frame(&CanFrame::from_frame(&frame), now()),
                Err(e) if e.kind() == ErrorKind::Overrun => {
                    drive.with(|d| on_overrun(d));
                }
                Err(_) => {}
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
            let woken = select(received.wait(), drive.kicked());
            match deadline {
                Some(at) => {
                    select(woken, Timer::at(to_embassy(at))).await;
                }
                None => {
                    woken.await;
                }
            }
        }
    };
    join(receive_loop, service_loop).await;
    // Both loops run forever.
    loop {
        core::future::pending::<()>().await;
    }
}

/// Reports an overrun to a drive that knows about CAN states.
fn on_overrun<D: Endpoints>(drive: &mut D) {
    drive.on_can_state(CanState::Overrun, now());
}

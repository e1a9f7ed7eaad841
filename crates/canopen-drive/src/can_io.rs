//! Moving frames between a [`Drive`] and any `embedded_can::nb::Can` driver.
//!
//! For drivers with a non-blocking interface (most HALs' bxCAN/FDCAN wrappers): call
//! [`service`] from the CAN interrupt or the main loop. Async HALs that only implement
//! `embedded_can::Frame` use small rx/tx tasks around `on_frame` / `pop_tx` instead.

use embedded_can::nb::Can;

use crate::drive::Drive;
use crate::frame::CanFrame;
use crate::od::ObjectHooks;
use crate::time::Instant;

/// Most frames [`service`] takes from the driver per call, to keep its work bounded.
pub const MAX_RX_PER_CALL: usize = 32;

/// Receives up to [`MAX_RX_PER_CALL`] frames into the drive, runs [`Drive::poll`], and
/// transmits queued frames until the driver's mailboxes are full. Returns the drive's next
/// deadline.
pub fn service<C: Can, H: ObjectHooks, const B: usize>(
    can: &mut C,
    drive: &mut Drive<H, B>,
    now: Instant,
) -> Result<Option<Instant>, C::Error> {
    for _ in 0..MAX_RX_PER_CALL {
        match can.receive() {
            Ok(frame) => drive.on_frame(&CanFrame::from_frame(&frame), now),
            Err(nb::Error::WouldBlock) => break,
            Err(nb::Error::Other(e)) => return Err(e),
        }
    }
    let deadline = drive.poll(now);
    while let Some(frame) = drive.peek_tx() {
        let Some(out) = frame.to_frame::<C::Frame>() else {
            // The driver cannot represent the frame: drop it rather than block the queue.
            drive.pop_tx();
            continue;
        };
        match can.transmit(&out) {
            // A displaced lower-priority frame is lost to the driver's own policy.
            Ok(_) => {
                drive.pop_tx();
            }
            Err(nb::Error::WouldBlock) => break,
            Err(nb::Error::Other(e)) => return Err(e),
        }
    }
    Ok(deadline)
}

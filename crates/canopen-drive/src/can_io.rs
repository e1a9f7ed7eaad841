//! Moving frames between a [`Drive`] and any `embedded_can::nb::Can` driver.
//!
//! For drivers with a non-blocking interface (most HALs' bxCAN/FDCAN wrappers): call
//! [`service`] from the CAN interrupt or the main loop. Async HALs that only implement
//! `embedded_can::Frame` use small rx/tx tasks around `on_frame` / `pop_tx` instead.

use embedded_can::nb::Can;

use crate::drive::Drive;
use crate::frame::CanFrame;
use crate::od::ObjectHooks;
use crate::storage::Persistence;
use crate::time::Instant;

/// Most frames [`service`] takes from the driver per call, to keep its work bounded.
pub const MAX_RX_PER_CALL: usize = 32;

/// Receives up to [`MAX_RX_PER_CALL`] frames into the drive, runs [`Drive::poll`], and
/// transmits queued frames until the driver's mailboxes are full. Returns the drive's next
/// deadline: call again by then (or at the next frame), e.g. from a timer set to it.
///
/// Any drive: every value store size, PDO count, parameter storage and number of axes.
pub fn service<
    C: Can,
    H: ObjectHooks,
    const B: usize,
    const RPDOS: usize,
    const TPDOS: usize,
    S: Persistence,
    const AXES: usize,
>(
    can: &mut C,
    drive: &mut Drive<H, B, RPDOS, TPDOS, S, AXES>,
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

#[cfg(test)]
mod tests {
    extern crate std;
    use std::collections::VecDeque;
    use std::vec::Vec;

    use super::*;
    use crate::drive::Config;
    use embedded_can::Frame;

    /// A driver with `mailboxes` free transmit slots per call.
    struct Mock {
        rx: VecDeque<CanFrame>,
        tx: Vec<CanFrame>,
        mailboxes: usize,
    }

    impl Can for Mock {
        type Frame = CanFrame;
        type Error = embedded_can::ErrorKind;
        fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
            if self.mailboxes == 0 {
                return Err(nb::Error::WouldBlock);
            }
            self.mailboxes -= 1;
            self.tx.push(*frame);
            Ok(None)
        }
        fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
            self.rx.pop_front().ok_or(nb::Error::WouldBlock)
        }
    }

    #[test]
    fn frames_wait_in_the_drive_while_the_mailboxes_are_full() {
        let mut drive = Drive::new(Config::new(2)).unwrap();
        let upload = CanFrame::new_standard(0x602, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).unwrap();
        let mut can = Mock { rx: VecDeque::from([upload]), tx: Vec::new(), mailboxes: 1 };
        let now = Instant::from_millis(1);
        service(&mut can, &mut drive, now).unwrap();
        // Boot-up went out; the SDO response waits for a free mailbox.
        assert_eq!(can.tx.len(), 1);
        assert_eq!(can.tx[0].standard_id(), Some(0x702));
        can.mailboxes = 1;
        service(&mut can, &mut drive, now).unwrap();
        assert_eq!(can.tx[1].standard_id(), Some(0x582));
        assert_eq!(can.tx[1].data(), &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]);
    }
}

//! What the runner tests share: the mock CAN driver.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::future::poll_fn;
use std::rc::Rc;
use std::task::Poll;

use canopen_drive::CanFrame;
use canopen_drive_embassy::{CanRx, CanTx};
use embedded_can::{ErrorKind, Frame};

/// The CAN "peripheral": frames from the master, frames to the master.
#[derive(Clone, Default)]
pub struct Wire {
    to_drive: Rc<RefCell<VecDeque<CanFrame>>>,
    from_drive: Rc<RefCell<Vec<CanFrame>>>,
}

impl CanRx for Wire {
    type Frame = CanFrame;
    type Error = ErrorKind;
    async fn receive(&mut self) -> Result<CanFrame, ErrorKind> {
        poll_fn(|_| match self.to_drive.borrow_mut().pop_front() {
            Some(frame) => Poll::Ready(Ok(frame)),
            None => Poll::Pending,
        })
        .await
    }
}

impl CanTx for Wire {
    type Frame = CanFrame;
    type Error = ErrorKind;
    async fn transmit(&mut self, frame: &CanFrame) -> Result<(), ErrorKind> {
        self.from_drive.borrow_mut().push(*frame);
        Ok(())
    }
}

impl Wire {
    pub fn send(&self, id: u16, data: &[u8]) {
        self.to_drive.borrow_mut().push_back(CanFrame::new_standard(id, data).unwrap());
    }

    /// Frames from the drive with this CAN-ID, taken.
    pub fn take(&self, id: u16) -> Vec<Vec<u8>> {
        let mut all = self.from_drive.borrow_mut();
        let (mine, rest): (Vec<_>, Vec<_>) = all.drain(..).partition(|f| f.standard_id() == Some(id));
        *all = rest;
        mine.iter().map(|f| f.data().to_vec()).collect()
    }

    /// Every frame from the drive, taken.
    #[allow(dead_code)] // (not every test file reads every frame)
    pub fn take_all(&self) -> Vec<CanFrame> {
        self.from_drive.borrow_mut().drain(..).collect()
    }
}

//! FDCAN1 in classic CAN mode, adapted to `canopen-drive-embassy`'s driver traits.
//! embassy-stm32's FDCAN driver offers async `read`/`write` on split halves; these wrappers
//! only map its bus errors to `embedded_can::ErrorKind`.

use embassy_stm32::can::enums::BusError;
use embassy_stm32::can::{CanConfigurator, CanRx, CanTx, Frame, IT0InterruptHandler, IT1InterruptHandler};
use embassy_stm32::interrupt::typelevel::{Binding, FDCAN1_IT0, FDCAN1_IT1};
use embassy_stm32::peripherals::{FDCAN1, PA11, PB9};
use embassy_stm32::Peri;
use embedded_can::ErrorKind;

/// Bit rate of the bus.
pub const BITRATE: u32 = 500_000;

/// The receiving half.
pub struct FdcanRx(CanRx<'static>);
/// The transmitting half.
pub struct FdcanTx(CanTx<'static>);

/// Configures FDCAN1 (classic frames, `BITRATE`, normal mode) and splits it.
pub fn start(
    fdcan: Peri<'static, FDCAN1>,
    rx: Peri<'static, PA11>,
    tx: Peri<'static, PB9>,
    irqs: impl Binding<FDCAN1_IT0, IT0InterruptHandler<FDCAN1>>
        + Binding<FDCAN1_IT1, IT1InterruptHandler<FDCAN1>>
        + 'static,
) -> (FdcanRx, FdcanTx) {
    let mut can = CanConfigurator::new(fdcan, rx, tx, irqs);
    can.set_bitrate(BITRATE);
    let can = can.into_normal_mode();
    let (tx, rx, _properties) = can.split();
    (FdcanRx(rx), FdcanTx(tx))
}

fn kind(error: BusError) -> ErrorKind {
    match error {
        BusError::Stuff => ErrorKind::Stuff,
        BusError::Form => ErrorKind::Form,
        BusError::Acknowledge => ErrorKind::Acknowledge,
        BusError::BitRecessive | BusError::BitDominant => ErrorKind::Bit,
        BusError::Crc => ErrorKind::Crc,
        BusError::Software => ErrorKind::Other,
    }
}

impl canopen_drive_embassy::CanRx for FdcanRx {
    type Frame = Frame;
    type Error = ErrorKind;

    async fn receive(&mut self) -> Result<Frame, ErrorKind> {
        self.0.read().await.map(|envelope| envelope.frame).map_err(kind)
    }
}

impl canopen_drive_embassy::CanTx for FdcanTx {
    type Frame = Frame;
    type Error = ErrorKind;

    async fn transmit(&mut self, frame: &Frame) -> Result<(), ErrorKind> {
        // A displaced lower-priority frame is the controller's policy; the drive's own queue
        // keeps the order of what it sends.
        let _displaced = self.0.write(frame).await;
        Ok(())
    }
}

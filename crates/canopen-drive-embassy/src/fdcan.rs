//! embassy-stm32's FDCAN for the runner (feature `stm32-fdcan`): classic CAN frames on any
//! FDCAN instance and pins, the driver halves behind [`CanRx`]/[`CanTx`], bus errors as
//! [`embedded_can::ErrorKind`], the controller's error state for
//! [`RunnerHooks::bus_state`](crate::RunnerHooks::bus_state), and the bit timing of a bit rate
//! (a CiA 305 one after an LSS switch, say) from the controller's kernel clock.
//!
//! ## The chip is the firmware's
//!
//! embassy-stm32 compiles only with one chip feature, and this crate does not pick it: the
//! firmware depends on embassy-stm32 itself with its chip (and its time driver, `defmt`, …)
//! and cargo unifies the two. The chip must have an FDCAN (embassy-stm32's `can_fdcan_v1` or
//! `can_fdcan_h7` peripheral, as on the STM32G4 and H7 families); the crate's own checks and
//! its docs.rs page use the STM32G431CB.
//!
//! ```toml
//! [dependencies]
//! canopen-drive-embassy = { version = "0.1", features = ["stm32-fdcan"] }
//! embassy-stm32 = { version = "0.6", features = ["stm32g431cb", "time-driver-tim2"] }
//! ```
//!
//! embassy-stm32 0.6 needs Rust 1.88 (it uses let chains), above this crate's own minimum.
//!
//! ## Use
//!
//! ```ignore
//! bind_interrupts!(struct Irqs {
//!     FDCAN1_IT0 => embassy_stm32::can::IT0InterruptHandler<peripherals::FDCAN1>;
//!     FDCAN1_IT1 => embassy_stm32::can::IT1InterruptHandler<peripherals::FDCAN1>;
//! });
//!
//! let (mut rx, mut tx, status) = fdcan::start(p.FDCAN1, p.PA11, p.PB9, Irqs, 500_000)?;
//! // With the status in the board's RunnerHooks::bus_state:
//! let change = run_until_bit_rate_change(&DRIVE, &mut rx, &mut tx, &mut board).await;
//! ```
//!
//! To switch the bit rate, drop both halves (embassy-stm32 then turns the controller off) and
//! [`start`] again with `Peri::reborrow`ed peripherals. A controller configured by hand
//! (filters, another operating mode) goes to the runner through [`split`].

use embassy_stm32::can::enums::{BusError, BusErrorMode};
use embassy_stm32::can::{
    config::NominalBitTiming, Can, CanConfigurator, Frame, IT0InterruptHandler, IT1InterruptHandler,
    Instance, Properties, RxPin, TxPin,
};
use embassy_stm32::interrupt::typelevel::Binding;
use embassy_stm32::time::Hertz;
use embassy_stm32::Peri;
use embedded_can::ErrorKind;

use crate::bit_timing;
use crate::runner::{BusState, CanRx, CanTx};

/// The receiving half of an FDCAN controller, for the runner.
pub struct FdcanRx<'d>(embassy_stm32::can::CanRx<'d>);

/// The transmitting half of an FDCAN controller, for the runner.
pub struct FdcanTx<'d>(embassy_stm32::can::CanTx<'d>);

/// The error state and counters of an FDCAN controller, and its filters (the `Properties`
/// of embassy-stm32's split).
pub struct FdcanStatus(Properties);

/// No bit timing gives `bit_rate` exactly from the controller's kernel clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoBitTiming {
    /// The FDCAN kernel clock, Hz.
    pub kernel_clock: u32,
    /// The bit rate asked for, bit/s.
    pub bit_rate: u32,
}

/// Opens FDCAN instance `T` on its `rx` and `tx` pins in classic CAN mode at `bit_rate`
/// (bit/s), in normal operation, and splits it for the runner.
///
/// Everything else is embassy-stm32's default: every frame accepted into receive FIFO 0
/// (the drive filters), priority-ordered transmit buffers, automatic retransmission and
/// automatic recovery from bus-off. The timing is [`nominal_bit_timing`] of the kernel clock
/// embassy-stm32 reports for `T`; without one, nothing is touched and the error says why.
///
/// # Panics
///
/// Only where embassy-stm32's `CanConfigurator::new` panics: when the FDCAN kernel clock is
/// not running (the firmware's `embassy_stm32::Config` selects it, `rcc.mux.fdcansel`).
pub fn start<'d, T: Instance>(
    peripheral: Peri<'d, T>,
    rx: Peri<'d, impl RxPin<T>>,
    tx: Peri<'d, impl TxPin<T>>,
    irqs: impl Binding<T::IT0Interrupt, IT0InterruptHandler<T>>
        + Binding<T::IT1Interrupt, IT1InterruptHandler<T>>
        + 'd,
    bit_rate: u32,
) -> Result<(FdcanRx<'d>, FdcanTx<'d>, FdcanStatus), NoBitTiming> {
    let timing = nominal_bit_timing(embassy_stm32::rcc::frequency::<T>(), bit_rate)?;
    let mut can = CanConfigurator::new(peripheral, rx, tx, irqs);
    can.set_config(can.config().set_nominal_bit_timing(timing));
    Ok(split(can.into_normal_mode()))
}

/// Splits a started controller into the runner's halves and its status.
pub fn split(can: Can<'_>) -> (FdcanRx<'_>, FdcanTx<'_>, FdcanStatus) {
    let (tx, rx, properties) = can.split();
    (FdcanRx(rx), FdcanTx(tx), FdcanStatus(properties))
}

/// The nominal bit timing for `bit_rate` (bit/s) from an FDCAN kernel clock of
/// `kernel_clock`: the exact rate or none, the most time quanta per bit the registers take,
/// the sample point as near 87.5 % (CiA 301's recommendation) as they allow, the jump width
/// as long as phase segment 2.
///
/// From an 85 MHz kernel clock (the B-G431B-ESC1 board's) every fixed rate of the CiA 305
/// table but 800 kbit/s has one; from 80 or 160 MHz all eight do.
pub fn nominal_bit_timing(kernel_clock: Hertz, bit_rate: u32) -> Result<NominalBitTiming, NoBitTiming> {
    let refused = NoBitTiming { kernel_clock: kernel_clock.0, bit_rate };
    let timing = bit_timing::nominal(kernel_clock.0, bit_rate).ok_or(refused)?;
    Ok(NominalBitTiming {
        prescaler: core::num::NonZeroU16::new(timing.prescaler).ok_or(refused)?,
        seg1: core::num::NonZeroU8::new(timing.seg1).ok_or(refused)?,
        seg2: core::num::NonZeroU8::new(timing.seg2).ok_or(refused)?,
        sync_jump_width: core::num::NonZeroU8::new(timing.sync_jump_width).ok_or(refused)?,
    })
}

/// The `embedded_can` kind of an FDCAN protocol error (the last error code of the
/// controller).
pub fn error_kind(error: BusError) -> ErrorKind {
    match error {
        BusError::Stuff => ErrorKind::Stuff,
        BusError::Form => ErrorKind::Form,
        BusError::Acknowledge => ErrorKind::Acknowledge,
        BusError::BitRecessive | BusError::BitDominant => ErrorKind::Bit,
        BusError::Crc => ErrorKind::Crc,
        BusError::Software => ErrorKind::Other,
    }
}

impl<'d> FdcanRx<'d> {
    /// The embassy-stm32 half.
    pub fn into_inner(self) -> embassy_stm32::can::CanRx<'d> {
        self.0
    }
}

impl<'d> From<embassy_stm32::can::CanRx<'d>> for FdcanRx<'d> {
    fn from(rx: embassy_stm32::can::CanRx<'d>) -> Self {
        FdcanRx(rx)
    }
}

impl<'d> FdcanTx<'d> {
    /// The embassy-stm32 half.
    pub fn into_inner(self) -> embassy_stm32::can::CanTx<'d> {
        self.0
    }
}

impl<'d> From<embassy_stm32::can::CanTx<'d>> for FdcanTx<'d> {
    fn from(tx: embassy_stm32::can::CanTx<'d>) -> Self {
        FdcanTx(tx)
    }
}

impl CanRx for FdcanRx<'_> {
    type Frame = Frame;
    type Error = ErrorKind;

    /// The next frame; or the controller's last protocol error, which embassy-stm32 reports
    /// when it finds the receive FIFOs empty (the runner ignores those).
    async fn receive(&mut self) -> Result<Frame, ErrorKind> {
        self.0.read().await.map(|envelope| envelope.frame).map_err(error_kind)
    }
}

impl CanTx for FdcanTx<'_> {
    type Frame = Frame;
    type Error = ErrorKind;

    /// Queues `frame`, waiting for a free transmit buffer. When the buffers are full,
    /// embassy-stm32 takes the one of a lower-priority pending frame and hands that frame
    /// back; it is queued again here (taking in turn the buffer of a frame of still lower
    /// priority, or waiting), so that nothing the drive sends is lost.
    async fn transmit(&mut self, frame: &Frame) -> Result<(), ErrorKind> {
        let mut displaced = self.0.write(frame).await;
        while let Some(frame) = displaced {
            displaced = self.0.write(&frame).await;
        }
        Ok(())
    }
}

impl FdcanStatus {
    /// The controller's fault-confinement state (register PSR). Reading PSR also clears the
    /// controller's last error code, which [`FdcanRx`] would otherwise report once.
    pub fn bus_state(&self) -> BusState {
        match self.0.bus_error_mode() {
            BusErrorMode::ErrorActive => BusState::ErrorActive,
            BusErrorMode::ErrorPassive => BusState::ErrorPassive,
            BusErrorMode::BusOff => BusState::BusOff,
        }
    }

    /// The transmit and receive error counters.
    pub fn error_counters(&self) -> (u8, u8) {
        (self.0.tx_error_count(), self.0.rx_error_count())
    }

    /// embassy-stm32's properties of the controller: acceptance filters, error counters.
    pub fn properties(&self) -> &Properties {
        &self.0
    }
}

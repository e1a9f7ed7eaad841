//! The board's CAN: FDCAN1 on the CAN connector (PA11 RX, PB9 TX) in classic CAN mode, its
//! kernel clock 85 MHz (PLL Q, `power::clocks`), the bit rates that clock divides into. The
//! driver itself is `canopen-drive-embassy`'s (`fdcan`, feature `stm32-fdcan`).

use canopen_drive::wire::lss::{BitRate, BitTiming};
use canopen_drive_embassy::fdcan::{self, FdcanRx, FdcanStatus, FdcanTx, NoBitTiming};
use embassy_stm32::peripherals::{FDCAN1, PA11, PB9};
use embassy_stm32::{bind_interrupts, peripherals, Peri};

bind_interrupts!(struct Irqs {
    FDCAN1_IT0 => embassy_stm32::can::IT0InterruptHandler<peripherals::FDCAN1>;
    FDCAN1_IT1 => embassy_stm32::can::IT1InterruptHandler<peripherals::FDCAN1>;
});

/// The bit rate without a stored LSS configuration, bit/s.
pub const DEFAULT_BIT_RATE: u32 = 500_000;

/// The rates of the CiA 305 standard table the 85 MHz kernel clock divides into exactly
/// (`fdcan::nominal_bit_timing`): all fixed rates but 800 kbit/s (106.25 clock cycles per
/// bit). LSS configure bit timing refuses the others (`Config::bit_rates`).
pub const BIT_RATES: [BitRate; 7] = [
    BitRate::Kbit1000,
    BitRate::Kbit500,
    BitRate::Kbit250,
    BitRate::Kbit125,
    BitRate::Kbit50,
    BitRate::Kbit20,
    BitRate::Kbit10,
];

/// The controller and its pins, kept by the CAN task so that it can reopen the controller at
/// another bit rate.
pub struct Pins {
    /// The controller.
    pub fdcan: Peri<'static, FDCAN1>,
    /// FDCAN1_RX.
    pub rx: Peri<'static, PA11>,
    /// FDCAN1_TX.
    pub tx: Peri<'static, PB9>,
}

impl Pins {
    /// Opens FDCAN1 at `bit_rate` (classic frames, normal operation) and splits it for the
    /// runner. Dropping both halves closes it again.
    pub fn open(&mut self, bit_rate: u32) -> Result<(FdcanRx<'_>, FdcanTx<'_>, FdcanStatus), NoBitTiming> {
        fdcan::start(self.fdcan.reborrow(), self.rx.reborrow(), self.tx.reborrow(), Irqs, bit_rate)
    }
}

/// The bit rate (bit/s) of an LSS bit timing, if it is one of [`BIT_RATES`].
pub fn bit_rate(bit_timing: BitTiming) -> Option<u32> {
    let rate = bit_timing.standard_rate().filter(|rate| BIT_RATES.contains(rate))?;
    rate.kbit_per_s().map(|kbit| u32::from(kbit) * 1000)
}

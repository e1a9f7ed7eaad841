//! The board's user LED: red, on PC6, lit when the pin is driven high (ST's board support for
//! the B-G431B-ESC1 and its user manual UM2516 both name PC6 as the status LED; not yet
//! checked on a board here). One red LED: it shows the CiA 303-3 ERR indicator (bus-off, an
//! RPDO timeout, a lost SYNC, an error control event, a CAN error counter at the warning
//! limit, an invalid configuration, no node-ID), never the green RUN indicator, which the
//! board does not have.
//!
//! The pattern is the core's (`comm::indicators`): [`ErrLed::show`] samples it, every 10 ms
//! or so, which keeps each on and off time within 20 % of its length.

use canopen_drive::comm::indicators::NodeStatus;
use canopen_drive::Instant;
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::peripherals::PC6;
use embassy_stm32::Peri;

/// How often the pattern is sampled.
pub const PERIOD_MS: u64 = 10;

/// The red LED, as the ERR indicator.
pub struct ErrLed {
    pin: Output<'static>,
}

impl ErrLed {
    /// PC6 as a push-pull output, the LED off.
    pub fn new(pin: Peri<'static, PC6>) -> Self {
        ErrLed { pin: Output::new(pin, Level::Low, Speed::Low) }
    }

    /// Shows the ERR indicator of `status` at `now` (the node's clock).
    pub fn show(&mut self, status: &NodeStatus, now: Instant) {
        self.pin.set_level(if status.leds(now).err { Level::High } else { Level::Low });
    }
}

//! The peripherals of QEMU's mps2-an385/an386 this firmware uses: CMSDK APB UART0 (the SLCAN
//! link), CMSDK APB TIMER0 (the control tick), TIMER1 (the stopwatch), the first timer of the
//! CMSDK APB dual timer (the stand-in current loop), the FPGA I/O block's user LEDs (the
//! CiA 303-3 indicators), the Cortex-M SysTick (embassy-time), and the NVIC and VTOR for a
//! hand-over from one image to another (`boot`).
//!
//! | peripheral | base | interrupt | clock |
//! |---|---|---|---|
//! | UART0 | 0x4000_4000 | 0 (RX), 1 (TX) | 25 MHz (BAUDDIV must be ≥ 16 for QEMU to move data) |
//! | TIMER0 | 0x4000_0000 | 8 | 25 MHz, counts down, reloads at 0 |
//! | TIMER1 | 0x4000_1000 | 9 (not used) | 25 MHz, free-running |
//! | dual timer, timer 1 | 0x4000_2000 | 10 | 25 MHz, periodic |
//! | FPGA I/O, LED0 | 0x4002_8000 | – | – |
//! | SysTick | core | exception 15 | 25 MHz (CLKSOURCE = processor clock) |
//! | NVIC ICER0/ICPR0, SCB ICSR/VTOR | core | – | – |
//!
//! Register access is volatile through raw addresses, here only.

use core::ptr::{read_volatile, write_volatile};

/// The system clock of the board (and of every timer here).
pub const SYSCLK_HZ: u32 = 25_000_000;
/// Timer counts per µs.
pub const COUNTS_PER_US: u32 = SYSCLK_HZ / 1_000_000;

/// Interrupt numbers (NVIC positions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum Irq {
    /// UART0 receive.
    Uart0Rx = 0,
    /// UART0 transmit.
    Uart0Tx = 1,
    /// TIMER0.
    Timer0 = 8,
    /// The dual timer.
    DualTimer = 10,
}

// SAFETY: the numbers are the mps2-an385/an386 NVIC lines of these peripherals.
unsafe impl cortex_m::interrupt::InterruptNumber for Irq {
    fn number(self) -> u16 {
        self as u16
    }
}

fn read(addr: usize) -> u32 {
    // SAFETY: only called with the addresses of the registers below, which QEMU maps.
    unsafe { read_volatile(addr as *const u32) }
}

fn write(addr: usize, value: u32) {
    // SAFETY: as for `read`.
    unsafe { write_volatile(addr as *mut u32, value) }
}

/// CMSDK APB UART0.
pub mod uart0 {
    use super::{read, write};

    const BASE: usize = 0x4000_4000;
    const DATA: usize = BASE;
    const STATE: usize = BASE + 0x04;
    const CTRL: usize = BASE + 0x08;
    const INTSTATUS: usize = BASE + 0x0C;
    const BAUDDIV: usize = BASE + 0x10;

    const STATE_TX_FULL: u32 = 1 << 0;
    const STATE_RX_FULL: u32 = 1 << 1;
    const CTRL_TX_EN: u32 = 1 << 0;
    const CTRL_RX_EN: u32 = 1 << 1;
    const CTRL_RX_INT_EN: u32 = 1 << 3;
    const INT_RX: u32 = 1 << 1;

    /// Enables transmitter and receiver (no interrupts yet).
    pub fn init() {
        write(BAUDDIV, 16);
        write(CTRL, CTRL_TX_EN | CTRL_RX_EN);
    }

    /// Sends one byte, waiting while the transmit buffer is full.
    pub fn write_byte(byte: u8) {
        while read(STATE) & STATE_TX_FULL != 0 {}
        write(DATA, u32::from(byte));
    }

    /// Sends all bytes.
    pub fn write_all(bytes: &[u8]) {
        for &b in bytes {
            write_byte(b);
        }
    }

    /// The received byte, if one waits. Reading it frees the receiver for the next one (QEMU
    /// holds further bytes back until then: nothing is lost).
    pub fn read_byte() -> Option<u8> {
        if read(STATE) & STATE_RX_FULL != 0 {
            Some((read(DATA) & 0xFF) as u8)
        } else {
            None
        }
    }

    /// Turns the receive interrupt on or off. Call with interrupts masked (it is a
    /// read-modify-write of CTRL). A byte already waiting raises no interrupt when it is
    /// turned on (the interrupt is the edge of the byte's arrival): pend the handler once.
    pub fn set_rx_interrupt(on: bool) {
        let ctrl = read(CTRL);
        write(CTRL, if on { ctrl | CTRL_RX_INT_EN } else { ctrl & !CTRL_RX_INT_EN });
    }

    /// Acknowledges the receive interrupt.
    pub fn clear_rx_interrupt() {
        write(INTSTATUS, INT_RX);
    }

    /// Waits until the transmitter has taken the last byte written (QEMU hands each byte to
    /// the TCP socket as it is written, unless the socket is full).
    pub fn flush() {
        while read(STATE) & STATE_TX_FULL != 0 {}
    }

    /// Turns every interrupt of the UART off and acknowledges those raised (before another
    /// image takes over the UART).
    pub fn disable_interrupts() {
        write(CTRL, read(CTRL) & (CTRL_TX_EN | CTRL_RX_EN));
        write(INTSTATUS, 0xF);
    }
}

/// CMSDK APB TIMER0: the periodic control tick.
pub mod timer0 {
    use super::{read, write};

    const BASE: usize = 0x4000_0000;
    const CTRL: usize = BASE;
    const VALUE: usize = BASE + 0x04;
    const RELOAD: usize = BASE + 0x08;
    const INTSTATUS: usize = BASE + 0x0C;

    const CTRL_ENABLE: u32 = 1 << 0;
    const CTRL_INT_EN: u32 = 1 << 3;

    /// Starts the timer with an interrupt every `period_counts` + 1 counts.
    pub fn start(period_counts: u32) {
        write(CTRL, 0);
        write(RELOAD, period_counts);
        write(VALUE, period_counts);
        write(CTRL, CTRL_ENABLE | CTRL_INT_EN);
    }

    /// Acknowledges the interrupt.
    pub fn clear_interrupt() {
        write(INTSTATUS, 1);
    }

    /// Stops the timer and acknowledges its interrupt.
    pub fn stop() {
        write(CTRL, 0);
        write(INTSTATUS, 1);
    }

    /// Counts since the timer last reached 0 (and raised its interrupt): the interrupt's
    /// latency when read first thing in the handler.
    pub fn counts_since_expiry() -> u32 {
        read(RELOAD).saturating_sub(read(VALUE))
    }
}

/// CMSDK APB TIMER1, free-running: the stopwatch of the measurements (40 ns resolution,
/// wraps every 172 s).
pub mod timer1 {
    use super::{read, write};

    const BASE: usize = 0x4000_1000;
    const CTRL: usize = BASE;
    const VALUE: usize = BASE + 0x04;
    const RELOAD: usize = BASE + 0x08;

    /// Starts counting (no interrupt).
    pub fn start() {
        write(CTRL, 0);
        write(RELOAD, u32::MAX);
        write(VALUE, u32::MAX);
        write(CTRL, 1);
    }

    /// Counts since [`start`], wrapping (the hardware counts down; this counts up).
    pub fn now() -> u32 {
        u32::MAX - read(VALUE)
    }
}

/// The CMSDK APB dual timer's first timer, periodic (an SP804): the current loop's interrupt.
pub mod dualtimer {
    use super::{read, write};

    const BASE: usize = 0x4000_2000;
    const LOAD: usize = BASE;
    const VALUE: usize = BASE + 0x04;
    const CONTROL: usize = BASE + 0x08;
    const INTCLR: usize = BASE + 0x0C;

    const CONTROL_32_BIT: u32 = 1 << 1;
    const CONTROL_INT_EN: u32 = 1 << 5;
    const CONTROL_PERIODIC: u32 = 1 << 6;
    const CONTROL_ENABLE: u32 = 1 << 7;

    /// Starts the timer with an interrupt every `period_counts` + 1 counts.
    pub fn start(period_counts: u32) {
        write(CONTROL, 0);
        write(LOAD, period_counts);
        write(CONTROL, CONTROL_ENABLE | CONTROL_PERIODIC | CONTROL_INT_EN | CONTROL_32_BIT);
    }

    /// Acknowledges the interrupt.
    pub fn clear_interrupt() {
        write(INTCLR, 1);
    }

    /// Stops the timer and acknowledges its interrupt.
    pub fn stop() {
        write(CONTROL, 0);
        write(INTCLR, 1);
    }

    /// Counts since the timer last reached 0: the interrupt's latency when read first thing in
    /// the handler.
    pub fn counts_since_expiry() -> u32 {
        read(LOAD).saturating_sub(read(VALUE))
    }
}

/// The SysTick as a free-running µs clock: an exception every ms counts milliseconds, the
/// counter gives the µs inside the current ms.
pub mod systick {
    use super::{read, write, SYSCLK_HZ};

    const CSR: usize = 0xE000_E010;
    const RVR: usize = 0xE000_E014;
    const CVR: usize = 0xE000_E018;
    const ICSR: usize = 0xE000_ED04;
    const ICSR_PENDSTSET: u32 = 1 << 26;
    const ICSR_PENDSTCLR: u32 = 1 << 25;

    /// Counts per millisecond.
    pub const COUNTS_PER_MS: u32 = SYSCLK_HZ / 1000;

    /// Starts the 1 ms exception from the processor clock.
    pub fn start() {
        write(RVR, COUNTS_PER_MS - 1);
        write(CVR, 0);
        // ENABLE | TICKINT | CLKSOURCE (processor clock).
        write(CSR, 0b111);
    }

    /// The counter: counts down from `COUNTS_PER_MS - 1` to 0 within each ms.
    pub fn counter() -> u32 {
        read(CVR)
    }

    /// True while the SysTick exception is pending (a ms boundary passed that its handler
    /// has not counted yet).
    pub fn pending() -> bool {
        read(ICSR) & ICSR_PENDSTSET != 0
    }

    /// Takes back a pending SysTick exception (for a loop that only sleeps until it).
    pub fn clear_pending() {
        write(ICSR, ICSR_PENDSTCLR);
    }

    /// Stops the counter and its exception.
    pub fn stop() {
        write(CSR, 0);
        clear_pending();
    }
}

/// The NVIC and SCB registers a hand-over between two images touches.
pub mod core_registers {
    use super::write;

    const NVIC_ICER0: usize = 0xE000_E180;
    const NVIC_ICPR0: usize = 0xE000_E280;
    const SCB_ICSR: usize = 0xE000_ED04;
    const SCB_VTOR: usize = 0xE000_ED08;
    const ICSR_PENDSVCLR: u32 = 1 << 27;
    const ICSR_PENDSTCLR: u32 = 1 << 25;

    /// Disables the 32 interrupt lines of the board and clears what they left pending, and
    /// the pending SysTick and PendSV exceptions.
    pub fn disable_interrupt_lines() {
        write(NVIC_ICER0, u32::MAX);
        write(NVIC_ICPR0, u32::MAX);
        write(SCB_ICSR, ICSR_PENDSVCLR | ICSR_PENDSTCLR);
    }

    /// Points the core at the vector table at `address`.
    pub fn set_vector_table(address: u32) {
        write(SCB_VTOR, address);
    }
}

/// The FPGA I/O block's user LEDs: bit 0 and bit 1 of LED0 (QEMU's `mps2_fpgaio_write` trace
/// event shows each write to the outside).
pub mod fpgaio {
    use super::write;

    const LED0: usize = 0x4002_8000;

    /// Lights the user LEDs whose bits are set (bit 0: LED 0, bit 1: LED 1).
    pub fn set_leds(bits: u32) {
        write(LED0, bits & 0b11);
    }
}

/// Semihosting: exit QEMU with a status code.
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

// The device part of the vector table (cortex-m-rt's `device` feature): the 32 interrupt lines
// of mps2-an385/an386. The firmware defines the handlers it uses as `extern "C"` functions
// with these names; `device.x` points the others at `DefaultHandler`.
extern "C" {
    fn UART0RX();
    fn TIMER0();
    fn DefaultHandler();
}

/// The interrupt vectors: IRQ 0 UART0 receive, IRQ 8 TIMER0, IRQ 10 the dual timer (the
/// current loop, in this library: [`crate::board`]), the rest `DefaultHandler`.
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
pub static __INTERRUPTS: [unsafe extern "C" fn(); 32] = [
    UART0RX,        // 0: UART0 receive
    DefaultHandler, // 1: UART0 transmit
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    TIMER0, // 8: TIMER0
    DefaultHandler,
    crate::board::current_loop_interrupt, // 10: dual timer
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
    DefaultHandler,
];

//! The B-G431B-ESC1's bootloader (CiA 302-3 program download): the core's
//! `canopen_drive::bootloader::Bootloader`, a CiA 301 node with the program download objects
//! 1F50h/1F51h/1F56h/1F57h, on FDCAN1 at the node-ID and bit rate the application uses (the
//! LSS configuration an LSS master stored, else node-ID 5 and 500 kbit/s), with the
//! application's 1000h and 1018h:1–2 (`BOOTLOADER_DEVICE`). Layout and hand-over:
//! `canopen_drive_b_g431b_esc1::boot`.
//!
//! At every reset:
//! 1. before anything is initialised (the clock is still the 16 MHz HSI16), it reads and
//!    clears the hand-over word; unless the application asked it to stay (a stop), it checks
//!    the image in the program area (header, CRC-32 of the payload, the vector table) and
//!    jumps to a valid program at once, which so starts from the reset state of every
//!    peripheral;
//! 2. else it runs the node at 170 MHz: NMT, heartbeat, SDO with block transfer streaming
//!    into the area, clear one page per step with 1F57h busy. When the master starts the
//!    verified program (1F51h:1 = 1), it waits for FDCAN1 to have sent the answer (at most
//!    100 ms) and resets, and step 1 starts the program.
//!
//! The red LED (PC6) shows the CiA 303-3 ERR indicator: bus-off, or a CAN error counter at
//! the warning limit, read from FDCAN1 every 10 ms.
//!
//! No log: the board's defmt stream over RTT is the application's. A stored node-ID of 255
//! (unconfigured, waiting for an LSS master) gives the bootloader node-ID 5: it has no LSS.
#![no_std]
#![no_main]

use canopen_drive::bootloader::Bootloader;
use canopen_drive::comm::indicators::NodeStatus;
use canopen_drive::comm::program::{read_header, ProgramRequest, ProgramState};
use canopen_drive::CanFrame;
use canopen_drive_b_g431b_esc1::boot::{self, ProgramArea, PAYLOAD_OFFSET};
use canopen_drive_b_g431b_esc1::led::{self, ErrLed};
use canopen_drive_b_g431b_esc1::{can, lss, power, BOOTLOADER_DEVICE, NODE_ID};
use canopen_drive_embassy::{now, to_embassy};
use embassy_executor::Executor;
use embassy_futures::select::{select, Either};
use embassy_stm32::can::enums::BusErrorMode;
use embassy_stm32::can::{Can, Frame};
use embassy_stm32::flash::Flash;
use embassy_time::{Duration, Instant, Timer};
use static_cell::StaticCell;

type Node = Bootloader<ProgramArea>;

static NODE: StaticCell<Node> = StaticCell::new();
static EXECUTOR: StaticCell<Executor> = StaticCell::new();

/// How long a start waits for FDCAN1 to send the answer before the reset: its three transmit
/// buffers' worth of classic frames (at most 160 bits each) at the slowest rate, 10 kbit/s,
/// is 48 ms.
const SEND_TIMEOUT: Duration = Duration::from_millis(100);
/// A CAN error counter at this value or above: the warning limit (ISO 11898-1).
const WARNING_LIMIT: u8 = 96;

#[cortex_m_rt::entry]
fn main() -> ! {
    let stay = boot::take_stay();
    // SAFETY: this is the only driver of the flash: the FLASH of embassy_stm32::init's
    // peripherals below is never used.
    let mut flash = Flash::new_blocking(unsafe { embassy_stm32::peripherals::FLASH::steal() });
    let stored = lss::load(&mut flash);
    let node_id = stored.map(|s| s.node_id).filter(|id| (1..=127).contains(id)).unwrap_or(NODE_ID);
    let bit_rate = stored.and_then(|s| s.bit_timing).and_then(can::bit_rate).unwrap_or(can::DEFAULT_BIT_RATE);
    let Ok(area) = boot::program_area(flash) else { halt() };
    let Ok(node) = Bootloader::new(BOOTLOADER_DEVICE, node_id, area, PAYLOAD_OFFSET) else { halt() };
    let node = NODE.init(node);
    if !stay {
        // The image found: verified before anything else (the node does it in steps when it
        // stays, with 1F57h busy meanwhile).
        while node.program().poll() {}
        if node.program().state() == ProgramState::Stopped {
            start_program(node);
        }
    }

    let p = embassy_stm32::init(power::clocks());
    let led = ErrLed::new(p.PC6);
    let pins = can::Pins { fdcan: p.FDCAN1, rx: p.PA11, tx: p.PB9 };
    let executor = EXECUTOR.init(Executor::new());
    executor.run(|spawner| match serve(node, pins, led, bit_rate) {
        Ok(token) => spawner.spawn(token),
        Err(_) => halt(),
    })
}

/// The node on FDCAN1: work when it is due, frames out, one received frame in per pass, the
/// LED every 10 ms. A pass erases at most one page (`poll`), so the master's requests (a read
/// of 1F57h during a clear) are answered between two pages.
#[embassy_executor::task]
async fn serve(node: &'static mut Node, mut pins: can::Pins, mut led: ErrLed, bit_rate: u32) {
    let Ok((rx, tx, _)) = pins.open(bit_rate) else { halt() };
    let mut can = Can::join(tx.into_inner(), rx.into_inner());
    let mut deadline = Some(now());
    let mut next_led = Instant::now();
    loop {
        let at = now();
        if deadline.is_some_and(|due| due <= at) {
            deadline = node.poll(at);
        }
        while let Some(frame) = node.pop_tx() {
            send(&mut can, &frame).await;
        }
        if let Some(ProgramRequest::Start | ProgramRequest::Reset) = node.take_request() {
            // The answer to the start leaves before the reset; step 1 starts the program.
            let sent = async {
                for buffer in 0..3 {
                    can.flush(buffer).await;
                }
            };
            select(sent, Timer::after(SEND_TIMEOUT)).await;
            boot::reset_into_bootloader(false);
        }
        if Instant::now() >= next_led {
            led.show(&status(node, &can), now());
            next_led = Instant::now() + Duration::from_millis(led::PERIOD_MS);
        }
        let wake = deadline.map_or(next_led, |due| to_embassy(due).min(next_led));
        if let Either::First(Ok(envelope)) = select(can.read(), Timer::at(wake)).await {
            node.on_frame(&CanFrame::from_frame(&envelope.frame), now());
            // An answer may have started work (erasing, verifying).
            deadline = Some(now());
        }
    }
}

/// Queues `frame` on FDCAN1; a lower-priority frame it displaced from a full transmit buffer
/// is queued again.
async fn send(can: &mut Can<'_>, frame: &CanFrame) {
    let Some(frame) = frame.to_frame::<Frame>() else { return };
    let mut displaced = can.write(&frame).await;
    while let Some(frame) = displaced {
        displaced = can.write(&frame).await;
    }
}

/// The node's state for the indicators, with what only the board knows: FDCAN1's error state.
fn status(node: &Node, can: &Can<'_>) -> NodeStatus {
    let properties = can.properties();
    let mode = properties.bus_error_mode();
    let counters = properties.tx_error_count().max(properties.rx_error_count());
    NodeStatus {
        bus_off: matches!(mode, BusErrorMode::BusOff),
        warning_limit: !matches!(mode, BusErrorMode::ErrorActive) || counters >= WARNING_LIMIT,
        ..node.node_status()
    }
}

/// Starts the verified program, if its vector table is one (else returns and the bootloader
/// stays).
fn start_program(node: &mut Node) {
    let area = node.program().area();
    let Ok(header) = read_header(area) else { return };
    if let Some(table) = boot::vector_table(area, header.len) {
        // SAFETY: the image's CRC is right and its vector table points into it: a program
        // built for this place (feature application-image). Nothing is initialised yet.
        unsafe { boot::start_image(table) }
    }
}

/// Stops for good (the bootloader cannot go on): interrupts masked, the core asleep. The
/// power stage's pins were never configured and stay inputs.
fn halt() -> ! {
    cortex_m::interrupt::disable();
    loop {
        cortex_m::asm::wfi();
    }
}

/// No log (see the crate docs): the core's and embassy-stm32's defmt calls end here.
#[defmt::global_logger]
struct NoLog;

// SAFETY: nothing is written anywhere.
unsafe impl defmt::Logger for NoLog {
    fn acquire() {}
    unsafe fn flush() {}
    unsafe fn release() {}
    unsafe fn write(_bytes: &[u8]) {}
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    halt()
}

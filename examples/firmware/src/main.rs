//! A `no_std` firmware skeleton around `canopen-drive` for a Cortex-M4F, without a HAL: what a
//! vendor's firmware has around the drive, with the board's parts marked `BOARD`.
//!
//! - The drive is built in place in a `static` (`static_cell::StaticCell` and
//!   `Drive::build_in`): built by value and moved, it would need several copies of itself on the
//!   stack at start-up.
//! - Its value store is sized to its tables at compile time (`OD_BYTES`).
//! - The control tick runs in the SysTick exception at a fixed rate; the communication side in
//!   thread mode. Both reach the drive through a `critical_section::Mutex` holding the
//!   `&'static mut` that `build_in` returned (the pattern of the crate's `drive` module docs).
//!   Each call into the drive is one short critical section, so the tick waits for at most one
//!   bounded call.
//! - The deadline `Drive::poll` returns is the communication side's timer: the tick compares
//!   it with the clock it keeps and wakes thread mode when it has passed (a board with a spare
//!   hardware timer programs that timer's compare register with it instead).
//!
//! Build: `cargo build --release` in this directory (for thumbv7em-none-eabihf, see
//! `.cargo/config.toml`; `scripts/test.sh` builds it in CI).
#![no_std]
#![no_main]

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicBool, Ordering};

use canopen_drive::drive::STANDARD_OD_BYTES;
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::od::{self, layout, AbortCode, Access, DataType, DefaultValue, Object, ObjectHooks, Var};
use canopen_drive::{CanFrame, Config, Drive, Instant};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{entry, exception};
use critical_section::Mutex;
use embedded_can::nb::Can;
use static_cell::StaticCell;

/// BOARD: the core clock SysTick counts.
const CORE_HZ: u32 = 170_000_000;
/// The control tick: 4 kHz.
const TICK_US: u32 = 250;
/// BOARD: the node-ID (from DIP switches, or 0xFF to wait for an LSS master).
const NODE_ID: u8 = 5;

/// The firmware's own objects.
static VENDOR: [Object; 1] = layout([Object::var(
    0x2000,
    "Pole pairs",
    Var::new("Pole pairs", DataType::Unsigned8)
        .access(Access::ReadWrite)
        .default(DefaultValue::Unsigned(4))
        .limits_unsigned(1, 32),
)]);
// A wrong table fails the build, not the firmware at start-up.
const _: () = assert!(od::check_manufacturer_table(&VENDOR).is_ok());

/// The value store: the standard objects of this build and the firmware's, nothing more.
const OD_BYTES: usize = STANDARD_OD_BYTES + od::storage_bytes(&[&VENDOR]);

/// The drive of this board: its hooks, its value store, 4 + 4 PDOs, no parameter storage.
type FirmwareDrive = Drive<Board, OD_BYTES>;

/// Where the drive is built, once.
static DRIVE_CELL: StaticCell<FirmwareDrive> = StaticCell::new();
/// The drive as both contexts reach it.
static DRIVE: Mutex<RefCell<Option<&'static mut FirmwareDrive>>> = Mutex::new(RefCell::new(None));
/// The clock (µs since start), advanced by the tick.
static NOW_US: Mutex<Cell<u64>> = Mutex::new(Cell::new(0));
/// The communication side's timer: when `poll` wants to run again (µs; `u64::MAX`: only when a
/// frame comes).
static WAKE_AT_US: Mutex<Cell<u64>> = Mutex::new(Cell::new(0));
/// Thread mode has work: the timer expired, a frame arrived, or the tick queued frames.
static WORK: AtomicBool = AtomicBool::new(true);

/// The firmware's object hooks (pole pairs go to the motor model).
#[derive(Default)]
struct Board {
    pole_pairs: u8,
}

impl ObjectHooks for Board {
    fn validate(&mut self, index: u16, _sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match (index, data) {
            // BOARD: the motor family has an even number of pole pairs.
            (0x2000, [pairs]) if pairs % 2 == 1 => Err(AbortCode::InvalidValue),
            _ => Ok(()),
        }
    }

    fn written(&mut self, index: u16, _sub: u8, data: &[u8]) {
        if let (0x2000, [pairs]) = (index, data) {
            self.pole_pairs = *pairs;
        }
    }
}

#[entry]
fn main() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else { halt() };
    let config = Config { manufacturer_objects: &VENDOR, ..Config::new(NODE_ID) };
    let drive = match FirmwareDrive::build_in(DRIVE_CELL.uninit(), config, Board::default(), ()) {
        Ok(drive) => drive,
        // BOARD: report the error (its Display names the object) before halting.
        Err(_error) => halt(),
    };
    critical_section::with(|cs| DRIVE.borrow_ref_mut(cs).replace(drive));

    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(CORE_HZ / 1_000_000 * TICK_US - 1);
    core.SYST.clear_current();
    core.SYST.enable_counter();
    core.SYST.enable_interrupt();

    let mut can = BoardCan;
    loop {
        if WORK.swap(false, Ordering::Acquire) {
            let now = critical_section::with(|cs| Instant::from_micros(NOW_US.borrow(cs).get()));
            let next = communicate(&mut can, now);
            let at = next.map_or(u64::MAX, Instant::as_micros);
            critical_section::with(|cs| WAKE_AT_US.borrow(cs).set(at));
        }
        // Until the next exception: the tick (which sets WORK when the timer expired) or the
        // CAN interrupt.
        cortex_m::asm::wfe();
    }
}

/// The communication side: frames in, timers, frames out, each drive call in its own
/// critical section. Returns the drive's next deadline.
///
/// (`can_io::service` does the same in one call; it suits a drive that no interrupt shares,
/// or one serviced from an interrupt that the tick cannot preempt anyway.)
fn communicate(can: &mut BoardCan, now: Instant) -> Option<Instant> {
    for _ in 0..canopen_drive::can_io::MAX_RX_PER_CALL {
        let Ok(frame) = can.receive() else { break };
        let frame = CanFrame::from_frame(&frame);
        with_drive(|drive| drive.on_frame(&frame, now));
    }
    let next = with_drive(|drive| drive.poll(now)).flatten();
    while let Some(frame) = with_drive(|drive| drive.peek_tx().copied()).flatten() {
        match can.transmit(&frame) {
            Ok(_) => {
                with_drive(|drive| drive.pop_tx());
            }
            // Mailboxes full: the rest waits for the next round (BOARD: the TX-empty interrupt
            // sets WORK).
            Err(_) => break,
        }
    }
    next
}

/// `f` on the drive inside one critical section (`None` before the drive exists).
fn with_drive<R>(f: impl FnOnce(&mut FirmwareDrive) -> R) -> Option<R> {
    critical_section::with(|cs| DRIVE.borrow_ref_mut(cs).as_mut().map(|drive| f(drive)))
}

/// The control tick at 4 kHz: sample, tick, apply; then the communication side's timer.
#[exception]
fn SysTick() {
    let sample = board_sample();
    let (demand, wake) = critical_section::with(|cs| {
        let clock = NOW_US.borrow(cs);
        let now = clock.get() + u64::from(TICK_US);
        clock.set(now);
        let mut drive = DRIVE.borrow_ref_mut(cs);
        let Some(drive) = drive.as_mut() else { return (Demand::OFF, false) };
        let demand = drive.tick(Instant::from_micros(now), &sample);
        // Frames the tick queued (TPDOs) go out at once; otherwise at the deadline.
        let wake = drive.peek_tx().is_some() || now >= WAKE_AT_US.borrow(cs).get();
        (demand, wake)
    });
    board_apply(&demand);
    if wake {
        WORK.store(true, Ordering::Release);
        cortex_m::asm::sev();
    }
}

/// BOARD: read the encoder, currents, DC link and inputs.
fn board_sample() -> Sample {
    Sample::default()
}

/// BOARD: hand the demand to the power stage (PWM, current loop, brake).
fn board_apply(demand: &Demand) {
    let _ = demand;
}

/// BOARD: the CAN controller (a HAL's bxCAN/FDCAN driver implements `embedded_can::nb::Can`);
/// its receive interrupt sets `WORK` and executes `sev`.
struct BoardCan;

impl Can for BoardCan {
    type Frame = CanFrame;
    type Error = embedded_can::ErrorKind;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
        let _ = frame;
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
        Err(nb::Error::WouldBlock)
    }
}

fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    // BOARD: switch the power stage off, then wait for the watchdog.
    halt()
}

//! The embassy firmware proper (bare-metal targets only).

use core::sync::atomic::{AtomicBool, Ordering};

use canopen_drive::{CanFrame, Config};
use canopen_drive_embassy::{CanRx, CanTx, SharedDrive};
use canopen_drive_qemu_mps2::board;
use canopen_drive_qemu_mps2::mps2::{self, uart0, Irq};
use canopen_drive_qemu_mps2::node::{self, BoardDrive};
use canopen_drive_qemu_mps2::objects::{exit_requested, BoardHooks, TICK_MONITOR};
use canopen_drive_slcan::{self as slcan, Command, LineDecoder};
use cortex_m::peripheral::NVIC;
use cortex_m_rt::{entry, exception, ExceptionFrame};
use defmt_semihosting as _;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_time::Timer;
use embedded_can::ErrorKind;
use static_cell::StaticCell;

#[path = "embassy_rt.rs"]
mod embassy_rt;

/// The drive, shared by the tick interrupt and the runner under the priority ceiling of the
/// tick (the current loop above it is never held off); it lives in `DRIVE_CELL`.
static DRIVE: SharedDrive<&'static mut BoardDrive, board::DriveLock> = SharedDrive::new();
static DRIVE_CELL: StaticCell<BoardDrive> = StaticCell::new();

/// Bytes from UART0, filled by its receive interrupt.
static RX_BYTES: Pipe<CriticalSectionRawMutex, 256> = Pipe::new();
/// The receive interrupt stopped taking bytes because the pipe was full.
static RX_PAUSED: AtomicBool = AtomicBool::new(false);

#[entry]
fn main() -> ! {
    uart0::init();
    DRIVE.put(make_drive());
    defmt::info!("canopen-drive on mps2: node {}, tick {} us", node::NODE_ID, node::TICK_PERIOD.as_micros());

    let Some(mut core) = cortex_m::Peripherals::take() else { mps2::exit(103) };
    // The current loop above the tick, the tick at the drive's ceiling, then UART0, SysTick.
    board::start_interrupts(&mut core.NVIC, &mut core.SCB, board::CURRENT_LOOP_PERIOD_US_REAL_TIME);
    critical_section::with(|_| uart0::set_rx_interrupt(true));
    // SAFETY: the handler below is ready; nothing else masks this line.
    unsafe { NVIC::unmask(Irq::Uart0Rx) };
    // A byte that came before the receive interrupt was enabled raised no interrupt, and
    // QEMU holds back the rest until it is read: let the handler look once.
    NVIC::pend(Irq::Uart0Rx);

    embassy_rt::run_executor(embassy_rt::Idle::Sleep, |spawner| {
        match can_task() {
            Ok(token) => spawner.spawn(token),
            Err(_) => mps2::exit(104),
        }
        match exit_task() {
            Ok(token) => spawner.spawn(token),
            Err(_) => mps2::exit(104),
        }
        match indicator_task() {
            Ok(token) => spawner.spawn(token),
            Err(_) => mps2::exit(104),
        }
        #[cfg(feature = "application-image")]
        match program::task() {
            Ok(token) => spawner.spawn(token),
            Err(_) => mps2::exit(104),
        }
    })
}

/// Builds the drive straight into its static cell (a separate function, so that main's own
/// stack frame stays small).
#[inline(never)]
fn make_drive() -> &'static mut BoardDrive {
    let hooks = BoardHooks { measurements: &board::BoardMeasurements };
    // As the bootloader's program: 1F50h–1F57h, 1F56h the CRC-32 of this image.
    let config = Config { program_download: cfg!(feature = "application-image"), ..node::config() };
    match BoardDrive::build_in(DRIVE_CELL.uninit(), config, hooks, ()) {
        Ok(drive) => {
            #[cfg(feature = "application-image")]
            drive.set_program_identification(program::identification());
            drive
        }
        Err(e) => {
            defmt::error!("dictionary: {}", e);
            mps2::exit(102);
        }
    }
}

#[embassy_executor::task]
async fn can_task() {
    canopen_drive_embassy::run(&DRIVE, SlcanRx::default(), SlcanTx).await
}

/// Time from the write of 2F00h to the exit: the SDO response goes out and the master closes
/// its end of the link first (bytes in flight when QEMU closes the socket can be lost).
const EXIT_DELAY_MS: u64 = 300;

/// Ends the firmware when a master writes 2F00h, with the written value as exit status.
#[embassy_executor::task]
async fn exit_task() {
    loop {
        Timer::after_millis(5).await;
        if let Some(code) = exit_requested() {
            // Let the SDO response go out, and the master disconnect, first.
            Timer::after_millis(EXIT_DELAY_MS).await;
            defmt::info!(
                "exit {}: {} ticks, lateness max {} ns, mean {} ns; longest lock {} ns; longest masked {} ns; current loop {} runs, gap max {} ns; stack {} bytes",
                code,
                TICK_MONITOR.ticks(),
                TICK_MONITOR.max_lateness(),
                TICK_MONITOR.mean_lateness(),
                board::longest_lock_ns(),
                board::longest_masked_ns(),
                board::current_loop().runs,
                board::current_loop().longest_gap_ns,
                board::stack_used()
            );
            mps2::exit(code);
        }
    }
}

/// The CiA 303-3 indicators on the user LEDs ([`board::show_indicators`]), every 10 ms.
#[embassy_executor::task]
async fn indicator_task() {
    let mut shown = None;
    loop {
        if let Some(status) = DRIVE.with(|drive| drive.node_status()) {
            board::show_indicators(status, canopen_drive_embassy::now(), &mut shown);
        }
        Timer::after_millis(10).await;
    }
}

/// The receiving half of the SLCAN link: lines from the pipe; control lines are answered
/// here, frames are handed to the runner.
#[derive(Default)]
struct SlcanRx {
    line: LineDecoder<CanFrame>,
    bytes: [u8; 32],
    start: usize,
    end: usize,
}

impl CanRx for SlcanRx {
    type Frame = CanFrame;
    type Error = ErrorKind;

    async fn receive(&mut self) -> Result<CanFrame, ErrorKind> {
        loop {
            while self.start < self.end {
                let byte = self.bytes.get(self.start).copied().unwrap_or(b'\r');
                self.start += 1;
                match self.line.push(byte) {
                    None => {}
                    Some(Err(_)) => uart0::write_byte(slcan::BEL),
                    Some(Ok(command)) => {
                        uart0::write_all(command.reply());
                        if let Command::Frame(frame) = command {
                            return Ok(frame);
                        }
                    }
                }
            }
            self.end = RX_BYTES.read(&mut self.bytes).await;
            self.start = 0;
            let resume = critical_section::with(|_| {
                let paused = RX_PAUSED.load(Ordering::Relaxed);
                if paused {
                    // There is room again: let the interrupt take the bytes QEMU held back.
                    RX_PAUSED.store(false, Ordering::Relaxed);
                    uart0::set_rx_interrupt(true);
                }
                paused
            });
            if resume {
                NVIC::pend(Irq::Uart0Rx);
            }
        }
    }
}

/// The transmitting half: one SLCAN line per frame.
struct SlcanTx;

impl CanTx for SlcanTx {
    type Frame = CanFrame;
    type Error = ErrorKind;

    async fn transmit(&mut self, frame: &CanFrame) -> Result<(), ErrorKind> {
        uart0::write_all(slcan::encode(frame).as_bytes());
        Ok(())
    }
}

/// UART0 receive: bytes into the pipe while it has room.
#[no_mangle]
extern "C" fn UART0RX() {
    uart0::clear_rx_interrupt();
    loop {
        if RX_BYTES.free_capacity() == 0 {
            // QEMU keeps further bytes until the receive loop made room and re-enables this.
            uart0::set_rx_interrupt(false);
            RX_PAUSED.store(true, Ordering::Release);
            return;
        }
        match uart0::read_byte() {
            Some(byte) => {
                let _ = RX_BYTES.try_write(&[byte]);
            }
            None => return,
        }
    }
}

/// TIMER0: the control tick.
#[no_mangle]
extern "C" fn TIMER0() {
    board::control_tick(|now, sample| {
        let demand = DRIVE.tick(now, sample);
        // Inside the tick's measured section: not a hold of the lock outside the tick.
        #[cfg(feature = "application-image")]
        program::take_request();
        demand
    });
}

/// The application's side of program download (feature `application-image`): a stop
/// (1F51h:1 = 0) jumps to the bootloader and asks it to stay, a reset (2) jumps to it to start
/// this program again, as a reset through the bootloader would (`canopen_drive_qemu_mps2::boot`).
///
/// The tick takes the request from the drive (`Drive::take_program_request`, at most a tick
/// after the answer has left the transmit queue) and signals this task, which waits for the
/// UART to have sent the answer, then jumps.
#[cfg(feature = "application-image")]
mod program {
    use canopen_drive::comm::program::{read_header, ProgramRequest};
    use canopen_drive_qemu_mps2::boot;
    use canopen_drive_qemu_mps2::mps2::uart0;
    use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
    use embassy_sync::signal::Signal;

    use super::DRIVE;

    /// The request the tick took.
    static REQUEST: Signal<CriticalSectionRawMutex, ProgramRequest> = Signal::new();

    /// 1F56h:1: the CRC-32 in the header the bootloader wrote before this image.
    pub fn identification() -> u32 {
        read_header(&mut boot::program_area()).map_or(0, |header| header.crc)
    }

    /// Called by the tick: takes a stop or reset from the drive once its answer is out.
    pub fn take_request() {
        if let Some(Some(request)) = DRIVE.with(|drive| drive.take_program_request()) {
            REQUEST.signal(request);
        }
    }

    /// Carries the request out: waits for the UART to have sent the answer, then jumps.
    #[embassy_executor::task]
    pub async fn task() {
        let request = REQUEST.wait().await;
        defmt::info!("program {}: to the bootloader", request);
        uart0::flush();
        boot::set_stay(request == ProgramRequest::Stop);
        // SAFETY: the bootloader's vector table is at 0x0 (this build runs only behind it);
        // this is thread mode, outside the drive's lock.
        unsafe { boot::start_image(boot::BOOTLOADER) }
    }
}

#[exception]
fn SysTick() {
    board::on_systick();
    embassy_rt::on_millisecond();
}

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    defmt::error!("hard fault");
    mps2::exit(105)
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    defmt::error!("unexpected interrupt {}", irqn);
    mps2::exit(106)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(at) => defmt::error!("panic at {}:{}", at.file(), at.line()),
        None => defmt::error!("panic"),
    }
    mps2::exit(101)
}

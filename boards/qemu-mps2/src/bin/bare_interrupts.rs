//! The drive without async: two interrupt handlers and a main loop, for vendor firmware that
//! does not use embassy. The same discipline as `canopen-drive-embassy` (see its crate docs),
//! spelled out by hand:
//!
//! | context | priority | does | holds the drive's lock for |
//! |---|---|---|---|
//! | dual timer interrupt ("current loop") | 0x00, above the lock | counts its runs (1 kHz here, 20 kHz in `tick-bound`) | never takes it |
//! | TIMER0 interrupt ("PWM/timer") | 0x40, the lock's ceiling | `Drive::tick` at 1 kHz, the motor | one `tick` |
//! | UART0 receive interrupt ("CAN RX") | 0x80 | assembles SLCAN lines; `Drive::on_frame` per received frame | one `on_frame` |
//! | main loop | thread | `Drive::poll` at its deadline or when an interrupt asked; `Drive::pop_tx` to the "CAN controller" (UART0 transmit); the user LEDs from `Drive::node_status` every 10 ms | one `poll`, one `pop_tx`, one `node_status` |
//!
//! - **Shared:** the `Drive`, in a `SharedDrive` of `canopen-drive-embassy` (which needs no
//!   executor; the value in a `StaticCell`, so the static is a pointer in `.bss`), and two
//!   flags.
//! - **Protection:** the drive's lock is a priority ceiling at the tick's priority
//!   (`PriorityCeiling`: BASEPRI on the Cortex-M4, the NVIC lines at or below the tick
//!   disabled on ARMv6-M) around each single call; no call does more than one bounded step of
//!   work, so the tick is held off by at most the longest one (boards/qemu-mps2 measures it:
//!   object 2F06h), and the current loop above the ceiling by none.
//! - **One writer per peripheral:** only the main loop writes UART0; the receive interrupt
//!   queues its replies to SLCAN commands for the main loop instead of writing them.
//!
//! On a real board the receive handler is the CAN controller's RX FIFO interrupt and the
//! transmit side feeds its mailboxes; nothing else changes.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(not(target_os = "none"))]
fn main() {}

#[cfg(target_os = "none")]
mod firmware {
    use core::cell::RefCell;
    use core::sync::atomic::{AtomicBool, Ordering};

    use canopen_drive::{CanFrame, Instant};
    use canopen_drive_embassy::SharedDrive;
    use canopen_drive_qemu_mps2::board;
    use canopen_drive_qemu_mps2::mps2::{self, uart0, Irq};
    use canopen_drive_qemu_mps2::node::{self, BoardDrive};
    use canopen_drive_qemu_mps2::objects::{exit_requested, BoardHooks};
    use canopen_drive_slcan::{self as slcan, Command, LineDecoder};
    use cortex_m::peripheral::NVIC;
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use critical_section::Mutex;
    use defmt_semihosting as _;
    use heapless::Deque;
    use static_cell::StaticCell;

    /// The drive; each access is one hold of its lock around one call.
    static DRIVE: SharedDrive<&'static mut BoardDrive, board::DriveLock> = SharedDrive::new();
    static DRIVE_CELL: StaticCell<BoardDrive> = StaticCell::new();

    /// The receive handler's line buffer and its queued replies to SLCAN control lines.
    static LINE: Mutex<RefCell<LineDecoder<CanFrame>>> = Mutex::new(RefCell::new(LineDecoder::new()));
    static REPLIES: Mutex<RefCell<Deque<&'static [u8], 16>>> = Mutex::new(RefCell::new(Deque::new()));

    /// Set by the handlers: the main loop has work (frames to send, a poll to run).
    static WORK: AtomicBool = AtomicBool::new(false);

    fn now() -> Instant {
        Instant::from_micros(board::now_micros())
    }

    #[inline(never)]
    fn make_drive() -> &'static mut BoardDrive {
        let hooks = BoardHooks { measurements: &board::BoardMeasurements };
        match BoardDrive::build_in(DRIVE_CELL.uninit(), node::config(), hooks, ()) {
            Ok(drive) => drive,
            Err(e) => {
                defmt::error!("dictionary: {}", e);
                mps2::exit(102);
            }
        }
    }

    #[entry]
    fn main() -> ! {
        uart0::init();
        let drive = make_drive();
        DRIVE.put(drive);
        defmt::info!("canopen-drive on mps2 (bare interrupts): node {}", node::NODE_ID);

        let Some(mut core) = cortex_m::Peripherals::take() else { mps2::exit(103) };
        // The current loop above the tick, the tick at the drive's ceiling, then UART0, SysTick.
        board::start_interrupts(&mut core.NVIC, &mut core.SCB, board::CURRENT_LOOP_PERIOD_US_REAL_TIME);
        critical_section::with(|_| uart0::set_rx_interrupt(true));
        // SAFETY: the handler below is ready.
        unsafe { NVIC::unmask(Irq::Uart0Rx) };
        // A byte that came before the receive interrupt was enabled raised no interrupt, and
        // QEMU holds back the rest until it is read: let the handler look once.
        NVIC::pend(Irq::Uart0Rx);

        let mut deadline: Option<Instant> = Some(now());
        let mut exit_at: Option<Instant> = None;
        // The CiA 303-3 indicators on the user LEDs, every 10 ms.
        let (mut leds_at, mut leds_shown) = (now(), None);
        loop {
            let work = WORK.load(Ordering::Acquire);
            WORK.store(false, Ordering::Release);
            let now = now();
            if work || deadline.is_some_and(|d| d <= now) {
                deadline = DRIVE.poll(now);
            }
            // Replies first: a master waits for them before its next line.
            while let Some(reply) = critical_section::with(|cs| REPLIES.borrow_ref_mut(cs).pop_front()) {
                uart0::write_all(reply);
            }
            while let Some(frame) = DRIVE.pop_tx() {
                uart0::write_all(slcan::encode(&frame).as_bytes());
            }
            if now >= leds_at {
                if let Some(status) = DRIVE.with(|drive| drive.node_status()) {
                    board::show_indicators(status, now, &mut leds_shown);
                }
                leds_at = now + canopen_drive::Duration::from_millis(10);
            }
            if let Some(code) = exit_requested() {
                // The SDO response is out; give the master 300 ms to read it and disconnect.
                let at = *exit_at.get_or_insert(now + canopen_drive::Duration::from_millis(300));
                if now >= at {
                    mps2::exit(code);
                }
            }
            // The SysTick (1 ms) wakes the loop for deadlines; the handlers set WORK.
            board::idle(|| WORK.load(Ordering::Acquire));
        }
    }

    /// UART0 receive, standing in for the CAN controller's receive interrupt.
    #[no_mangle]
    extern "C" fn UART0RX() {
        uart0::clear_rx_interrupt();
        while let Some(byte) = uart0::read_byte() {
            let line = critical_section::with(|cs| LINE.borrow_ref_mut(cs).push(byte));
            match line {
                None => continue,
                Some(Ok(Command::Frame(frame))) => {
                    DRIVE.on_frame(&frame, now());
                    queue_reply(Command::Frame(frame).reply());
                }
                Some(Ok(command)) => queue_reply(command.reply()),
                Some(Err(_)) => queue_reply(&[slcan::BEL]),
            }
            WORK.store(true, Ordering::Release);
        }
    }

    fn queue_reply(reply: &'static [u8]) {
        critical_section::with(|cs| {
            // A full queue drops the reply: python-can and adapters ignore acknowledgements.
            let _ = REPLIES.borrow_ref_mut(cs).push_back(reply);
        });
    }

    /// TIMER0: the control tick.
    #[no_mangle]
    extern "C" fn TIMER0() {
        board::control_tick(|now, sample| DRIVE.tick(now, sample));
        // The tick may have queued a TPDO or raised an EMCY that `poll` sends.
        WORK.store(true, Ordering::Release);
    }

    #[exception]
    fn SysTick() {
        board::on_systick();
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
}

//! The bootloader (CiA 302-3 program download): `canopen_drive::bootloader::Bootloader`, a
//! CiA 301 node with the program download objects, on the same SLCAN link (UART0) and node-ID
//! as the application, and with its identity for 1000h and 1018h:1–2 (`node::BOOTLOADER_DEVICE`).
//! Its program area and the application's place are in `src/boot.rs`.
//!
//! At power-on (and whenever the application jumps here):
//! 1. unless the application asked it to stay (the hand-over word, after a stop), it checks
//!    the image in the program area, header and CRC-32 of the payload, before the node starts,
//!    and starts a valid program at once;
//! 2. else it runs the node: NMT, heartbeat, SDO (block transfer streams into the area),
//!    1F50h/1F51h/1F56h/1F57h. When the master starts the verified program (1F51h:1 = 1), it
//!    waits for the UART to have sent the answer, clears the hand-over word and starts it.
//!
//! No interrupt handler runs here: the bootloader runs with interrupts masked (PRIMASK) and
//! sleeps in WFI, which UART0's receive interrupt and a 1 ms SysTick still end. The clock is
//! TIMER1, free-running. So the application starts from a core with nothing to undo but
//! those two sources (`boot::start_image`).
//!
//! No log: the defmt stream over semihosting is the application's (a log of two images in one
//! stream could not be decoded).
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(not(target_os = "none"))]
fn main() {}

#[cfg(target_os = "none")]
mod firmware {
    use canopen_drive::bootloader::Bootloader;
    use canopen_drive::comm::program::{read_header, ProgramRequest, ProgramState};
    use canopen_drive::{CanFrame, Instant};
    use canopen_drive_qemu_mps2::boot::{self, MemoryArea, PAYLOAD_OFFSET};
    use canopen_drive_qemu_mps2::mps2::{self, systick, timer1, uart0, Irq, COUNTS_PER_US};
    use canopen_drive_qemu_mps2::node;
    use canopen_drive_slcan::{self as slcan, Command, LineDecoder};
    use cortex_m::peripheral::NVIC;
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use static_cell::StaticCell;

    type Node = Bootloader<MemoryArea>;

    static NODE: StaticCell<Node> = StaticCell::new();

    #[entry]
    fn main() -> ! {
        // Interrupts stay masked: their sources only end WFI.
        cortex_m::interrupt::disable();
        let stay = boot::stay_requested();
        let area = boot::program_area();
        let node = match Bootloader::new(node::BOOTLOADER_DEVICE, node::NODE_ID, area, PAYLOAD_OFFSET) {
            Ok(node) => NODE.init(node),
            Err(_) => mps2::exit(102),
        };
        if !stay {
            // The image found: verified before anything else (the node does it in steps when it
            // stays, with 1F57h busy meanwhile).
            while node.program().poll() {}
            if node.program().state() == ProgramState::Stopped {
                start_program(node);
            }
        }

        uart0::init();
        timer1::start();
        systick::start();
        critical_section::with(|_| uart0::set_rx_interrupt(true));
        // SAFETY: PRIMASK masks the line: it only ends WFI, no handler runs.
        unsafe { NVIC::unmask(Irq::Uart0Rx) };

        let mut clock = Clock::default();
        let mut line = LineDecoder::<CanFrame>::new();
        let mut deadline = Some(clock.now());
        loop {
            // Acknowledge the wake-up sources first: what arrives from here on ends the WFI.
            uart0::clear_rx_interrupt();
            NVIC::unpend(Irq::Uart0Rx);
            systick::clear_pending();
            while let Some(byte) = uart0::read_byte() {
                match line.push(byte) {
                    None => {}
                    Some(Err(_)) => uart0::write_byte(slcan::BEL),
                    Some(Ok(command)) => {
                        uart0::write_all(command.reply());
                        if let Command::Frame(frame) = command {
                            node.on_frame(&frame, clock.now());
                            send(node);
                            // An answer may have started work (erasing, verifying).
                            deadline = Some(clock.now());
                        }
                    }
                }
            }
            let now = clock.now();
            if deadline.is_some_and(|due| due <= now) {
                deadline = node.poll(now);
                send(node);
            }
            if let Some(ProgramRequest::Start | ProgramRequest::Reset) = node.take_request() {
                // The answer to the start is on the link before the program's boot-up.
                uart0::flush();
                boot::set_stay(false);
                start_program(node);
            }
            // Sleep unless work is due: a byte or the next ms ends it.
            if deadline.is_none_or(|due| due > clock.now()) {
                cortex_m::asm::wfi();
            }
        }
    }

    /// Frames the node queued, onto the link.
    fn send(node: &mut Node) {
        while let Some(frame) = node.pop_tx() {
            uart0::write_all(slcan::encode(&frame).as_bytes());
        }
    }

    /// Starts the verified program, if its vector table is one (else returns and the
    /// bootloader stays).
    fn start_program(node: &mut Node) {
        let area = node.program().area();
        let Ok(header) = read_header(area) else { return };
        if let Some(table) = boot::vector_table(area, boot::PROGRAM_AREA, PAYLOAD_OFFSET, header.len) {
            // SAFETY: the image's CRC is right and its vector table points into it: a program
            // built for this place (memory/application.x).
            unsafe { boot::start_image(table) }
        }
    }

    /// Microseconds from TIMER1 (25 counts per µs, wrapping every 172 s), extended to 64 bits:
    /// read at least every ms by the main loop.
    #[derive(Default)]
    struct Clock {
        last: u32,
        counts: u64,
    }

    impl Clock {
        fn now(&mut self) -> Instant {
            let counts = timer1::now();
            self.counts += u64::from(counts.wrapping_sub(self.last));
            self.last = counts;
            Instant::from_micros(self.counts / u64::from(COUNTS_PER_US))
        }
    }

    /// No log (see the crate docs): the core's defmt calls end here.
    #[defmt::global_logger]
    struct NoLog;

    // SAFETY: nothing is written anywhere.
    unsafe impl defmt::Logger for NoLog {
        fn acquire() {}
        unsafe fn flush() {}
        unsafe fn release() {}
        unsafe fn write(_bytes: &[u8]) {}
    }

    #[exception]
    unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
        mps2::exit(105)
    }

    #[exception]
    unsafe fn DefaultHandler(_irqn: i16) {
        mps2::exit(106)
    }

    #[panic_handler]
    fn panic(_info: &core::panic::PanicInfo) -> ! {
        mps2::exit(101)
    }
}

//! The tick-delay bound, measured without a host in the loop: the embassy firmware's runner,
//! drive and 1 kHz TIMER0 tick, with an SDO client task inside the firmware in place of the
//! master, joined to the runner by an in-memory CAN "bus". Run it under
//! `QEMU_ICOUNT=shift=3,sleep=off` (scripts/mcu.sh does): one instruction is 8 ns of guest
//! time and idle time is skipped, so every number is an instruction count and the same on
//! every run, whatever the host does.
//!
//! The client does what stresses the runner most, phase by phase, and the firmware measures,
//! per phase, the longest critical section outside the tick (all that can hold off the
//! highest-priority tick interrupt) and the longest tick lateness:
//!
//! 1. a 16 KiB block upload of 2F10h (127-segment sub-blocks, CRC);
//! 2. a 200-byte block download of 2F11h;
//! 3. 200 expedited uploads;
//! 4. NMT reset communication.
//!
//! It prints one line per phase on the semihosting console (plain text: this firmware logs
//! nothing through defmt) and exits with status 0 when the block upload's longest critical
//! section is within [`BLOCK_UPLOAD_BOUND_INSTRUCTIONS`] and the transfer was correct, else 1.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(not(target_os = "none"))]
fn main() {}

#[cfg(target_os = "none")]
#[path = "../embassy_rt.rs"]
mod embassy_rt;

#[cfg(target_os = "none")]
mod firmware {
    use canopen_drive::wire::crc;
    use canopen_drive::CanFrame;
    use canopen_drive_embassy::{CanRx, CanTx, SharedDrive};
    use canopen_drive_qemu_mps2::board;
    use canopen_drive_qemu_mps2::mps2::{self, Irq};
    use canopen_drive_qemu_mps2::node::{self, BoardDrive, NODE_ID};
    use canopen_drive_qemu_mps2::objects::{
        pattern_byte, BoardHooks, TEST_BUFFER, TEST_PATTERN, TEST_PATTERN_LEN, TICK_MONITOR,
    };
    use cortex_m::peripheral::NVIC;
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use defmt_semihosting as _;
    use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
    use embassy_sync::channel::Channel;
    use embassy_time::{with_timeout, Duration, Timer};
    use embedded_can::{ErrorKind, Frame};
    use semihosting::println;
    use static_cell::StaticCell;

    use crate::embassy_rt;

    /// The bound checked: no critical section outside the tick may last longer during the
    /// 16 KiB block upload. The longest is the sub-block acknowledgement, which folds the 889
    /// acknowledged bytes into the CRC: 74 435 instructions measured on thumbv7em (Thumb-2),
    /// 101 590 on thumbv6m (Thumb-1 code, run on mps2-an385's Cortex-M3).
    /// (Of the two targets only thumbv7em has compare-and-swap: that tells them apart.)
    pub const BLOCK_UPLOAD_BOUND_INSTRUCTIONS: u32 =
        if cfg!(target_has_atomic = "32") { 100_000 } else { 130_000 };
    /// Guest ns per instruction under `-icount shift=3`.
    const NS_PER_INSTRUCTION: u32 = 8;

    static DRIVE: SharedDrive<&'static mut BoardDrive> = SharedDrive::new();
    static DRIVE_CELL: StaticCell<BoardDrive> = StaticCell::new();
    static TO_DRIVE: Channel<CriticalSectionRawMutex, CanFrame, 8> = Channel::new();
    static TO_CLIENT: Channel<CriticalSectionRawMutex, CanFrame, 32> = Channel::new();

    struct BusRx;
    impl CanRx for BusRx {
        type Frame = CanFrame;
        type Error = ErrorKind;
        async fn receive(&mut self) -> Result<CanFrame, ErrorKind> {
            Ok(TO_DRIVE.receive().await)
        }
    }

    struct BusTx;
    impl CanTx for BusTx {
        type Frame = CanFrame;
        type Error = ErrorKind;
        async fn transmit(&mut self, frame: &CanFrame) -> Result<(), ErrorKind> {
            TO_CLIENT.send(*frame).await;
            Ok(())
        }
    }

    #[inline(never)]
    fn make_drive() -> &'static mut BoardDrive {
        let hooks = BoardHooks { measurements: &board::BoardMeasurements };
        match BoardDrive::build_in(DRIVE_CELL.uninit(), node::config(), hooks, ()) {
            Ok(drive) => drive,
            Err(_) => mps2::exit(102),
        }
    }

    #[entry]
    fn main() -> ! {
        DRIVE.put(make_drive());
        let Some(mut core) = cortex_m::Peripherals::take() else { mps2::exit(103) };
        // SAFETY: as in the embassy firmware: the tick preempts everything.
        unsafe {
            core.NVIC.set_priority(Irq::Timer0, 0x00);
            core.SCB.set_priority(cortex_m::peripheral::scb::SystemHandler::SysTick, 0x80);
        }
        board::start_timers();
        // SAFETY: the handler below is ready.
        unsafe { NVIC::unmask(Irq::Timer0) };
        embassy_rt::run_executor(|spawner| {
            match runner() {
                Ok(token) => spawner.spawn(token),
                Err(_) => mps2::exit(104),
            }
            match client() {
                Ok(token) => spawner.spawn(token),
                Err(_) => mps2::exit(104),
            }
        })
    }

    #[embassy_executor::task]
    async fn runner() {
        canopen_drive_embassy::run(&DRIVE, BusRx, BusTx).await
    }

    fn sdo(data: [u8; 8]) -> CanFrame {
        CanFrame::new_standard(0x600 + u16::from(NODE_ID), &data).unwrap_or_else(|| mps2::exit(110))
    }

    /// The next SDO response (other frames are skipped).
    async fn response() -> [u8; 8] {
        loop {
            let Ok(frame) = with_timeout(Duration::from_secs(2), TO_CLIENT.receive()).await else {
                println!("no SDO response");
                mps2::exit(111)
            };
            if frame.standard_id() == Some(0x580 + u16::from(NODE_ID)) {
                let mut data = [0u8; 8];
                for (d, s) in data.iter_mut().zip(frame.data()) {
                    *d = *s;
                }
                return data;
            }
        }
    }

    async fn request(data: [u8; 8]) -> [u8; 8] {
        TO_DRIVE.send(sdo(data)).await;
        response().await
    }

    /// Starts a measurement phase.
    fn reset_measurements() {
        TICK_MONITOR.reset();
        board::reset_longest_section();
    }

    /// Prints the phase's measurements; returns the longest critical section (instructions).
    fn report(phase: &str) -> u32 {
        let section = board::longest_section_ns() / NS_PER_INSTRUCTION;
        println!(
            "{}: longest critical section {} instructions; longest tick {} instructions; tick lateness max {} instructions over {} ticks",
            phase,
            section,
            board::longest_tick_ns() / NS_PER_INSTRUCTION,
            TICK_MONITOR.max_lateness() / NS_PER_INSTRUCTION,
            TICK_MONITOR.ticks(),
        );
        section
    }

    /// 2F10h by block upload; true when every byte and the CRC are right.
    async fn block_upload() -> bool {
        let [lo, hi] = TEST_PATTERN.to_le_bytes();
        let initiate = request([0xA4, lo, hi, 0, 127, 0, 0, 0]).await;
        if initiate[0] & 0xE3 != 0xC2 {
            return false;
        }
        TO_DRIVE.send(sdo([0xA3, 0, 0, 0, 0, 0, 0, 0])).await;
        let mut offset = 0usize;
        let mut crc_value = 0u16;
        let mut good = true;
        loop {
            let mut seq = 0u8;
            let last = loop {
                let segment = response().await;
                seq += 1;
                good &= segment[0] & 0x7F == seq;
                for (i, b) in segment.iter().skip(1).enumerate() {
                    if offset + i < TEST_PATTERN_LEN {
                        good &= *b == pattern_byte(offset + i);
                        crc_value = crc::update(crc_value, &[*b]);
                    }
                }
                offset += 7;
                if segment[0] & 0x80 != 0 || seq == 127 {
                    break segment[0] & 0x80 != 0;
                }
            };
            if last {
                let end = request([0xA2, seq, 127, 0, 0, 0, 0, 0]).await;
                good &= end[0] & 0xE3 == 0xC1 && u16::from_le_bytes([end[1], end[2]]) == crc_value;
                TO_DRIVE.send(sdo([0xA1, 0, 0, 0, 0, 0, 0, 0])).await;
                return good && offset >= TEST_PATTERN_LEN;
            }
            TO_DRIVE.send(sdo([0xA2, seq, 127, 0, 0, 0, 0, 0])).await;
        }
    }

    /// 200 bytes to 2F11h by block download.
    async fn block_download() -> bool {
        let [lo, hi] = TEST_BUFFER.to_le_bytes();
        let data: [u8; 200] = core::array::from_fn(|i| (i * 3) as u8);
        let initiate = request([0xC6, lo, hi, 0, 200, 0, 0, 0]).await;
        if initiate[0] & 0xE3 != 0xA0 {
            return false;
        }
        let chunks = data.chunks(7).count();
        for (i, chunk) in data.chunks(7).enumerate() {
            let mut segment = [0u8; 8];
            segment[0] = (i + 1) as u8 | if i + 1 == chunks { 0x80 } else { 0 };
            for (d, s) in segment.iter_mut().skip(1).zip(chunk) {
                *d = *s;
            }
            TO_DRIVE.send(sdo(segment)).await;
        }
        let ack = response().await;
        let unused = (chunks * 7 - data.len()) as u8;
        let [c0, c1] = crc::update(0, &data).to_le_bytes();
        let end = request([0xC1 | (unused << 2), c0, c1, 0, 0, 0, 0, 0]).await;
        ack[0] == 0xA2 && end[0] == 0xA1
    }

    #[embassy_executor::task]
    async fn client() {
        println!(
            "tick-bound: {} Hz tick, runner and SDO client in the firmware",
            1_000_000 / node::TICK_PERIOD.as_micros()
        );
        // Let the drive boot and the tick settle.
        Timer::after_millis(20).await;
        while TO_CLIENT.try_receive().is_ok() {}
        let mut ok = true;

        reset_measurements();
        let uploaded = block_upload().await;
        let upload_section = report("16 KiB block upload");
        ok &= uploaded;

        reset_measurements();
        ok &= block_download().await;
        report("200-byte block download");

        reset_measurements();
        for _ in 0..200 {
            ok &= request([0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).await[0] == 0x43;
        }
        report("200 expedited uploads");

        reset_measurements();
        TO_DRIVE.send(CanFrame::new_standard(0, &[0x82, NODE_ID]).unwrap_or_else(|| mps2::exit(110))).await;
        Timer::after_millis(20).await;
        report("NMT reset communication");

        let within = upload_section <= BLOCK_UPLOAD_BOUND_INSTRUCTIONS;
        println!(
            "bound: block upload longest critical section {} <= {} instructions: {}; transfers correct: {}",
            upload_section, BLOCK_UPLOAD_BOUND_INSTRUCTIONS, within, ok
        );
        mps2::exit(if within && ok { 0 } else { 1 });
    }

    #[no_mangle]
    extern "C" fn TIMER0() {
        board::control_tick(|now, sample| DRIVE.tick(now, sample));
    }

    #[exception]
    fn SysTick() {
        board::on_systick();
        embassy_rt::on_millisecond();
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

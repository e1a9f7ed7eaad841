//! The tick-delay bound and the current loop's period, measured without a host in the loop:
//! the embassy firmware's runner, drive, 1 kHz TIMER0 tick and 20 kHz current loop (the dual
//! timer, above the drive's lock), with an SDO client task inside the firmware in place of the
//! master, joined to the runner by an in-memory CAN "bus". Run it under
//! `QEMU_ICOUNT=shift=3,sleep=off` (scripts/mcu.sh does): one instruction is 8 ns of guest
//! time and idle time is skipped, so every number is an instruction count and the same on
//! every run, whatever the host does.
//!
//! The client does what stresses the drive most, phase by phase, and the firmware measures,
//! per phase: the longest hold of the drive's lock outside the tick (what can hold off the
//! tick), the longest stretch with every interrupt masked (what can hold off the current
//! loop), the longest tick, the tick's lateness, and the current loop's runs, longest gap
//! and lateness:
//!
//! 1. a 16 KiB block upload of 2F10h (127-segment sub-blocks, CRC);
//! 2. a 200-byte block download of 2F11h;
//! 3. 200 expedited uploads;
//! 4. profile position: the drive enabled, then one set-point, whose tick plans the move;
//! 5. NMT reset communication.
//!
//! It prints one line per phase on the semihosting console (plain text: this firmware logs
//! nothing through defmt) and exits with status 0 when the block upload's longest lock hold is
//! within [`BLOCK_UPLOAD_BOUND_INSTRUCTIONS`], the current loop never missed its period in
//! any phase, and every transfer and step was right; else 1.
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
    use canopen_drive_embassy::{CanRx, CanTx, CriticalSection, Lock, PriorityCeiling, SharedDrive};
    use canopen_drive_qemu_mps2::board::{self, CURRENT_LOOP_PERIOD_US};
    use canopen_drive_qemu_mps2::mps2::{self, timer1};
    use canopen_drive_qemu_mps2::node::{self, BoardDrive, NODE_ID};
    use canopen_drive_qemu_mps2::objects::{
        pattern_byte, BoardHooks, TEST_BUFFER, TEST_PATTERN, TEST_PATTERN_LEN, TICK_MONITOR,
    };
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use defmt_semihosting as _;
    use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
    use embassy_sync::channel::Channel;
    use embassy_time::{with_timeout, Duration, Timer};
    use embedded_can::{ErrorKind, Frame};
    use semihosting::println;
    use static_cell::StaticCell;

    use crate::embassy_rt;

    /// The bound checked: no hold of the drive's lock outside the tick may last longer during
    /// the 16 KiB block upload. The longest is the sub-block acknowledgement, which folds the
    /// 889 acknowledged bytes into the CRC (see the board's README for the numbers measured on
    /// thumbv7em and on thumbv6m, Thumb-1 code run on mps2-an385's Cortex-M3).
    /// (Of the two targets only thumbv7em has compare-and-swap: that tells them apart.)
    pub const BLOCK_UPLOAD_BOUND_INSTRUCTIONS: u32 =
        if cfg!(target_has_atomic = "32") { 100_000 } else { 130_000 };
    /// Guest ns per instruction under `-icount shift=3`.
    const NS_PER_INSTRUCTION: u32 = 8;

    static DRIVE: SharedDrive<&'static mut BoardDrive, board::DriveLock> = SharedDrive::new();
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
        // As in the embassy firmware: the current loop above the tick, the tick at the drive's
        // ceiling (the UART stays masked: the bus is in memory).
        board::start_interrupts(&mut core.NVIC, &mut core.SCB, CURRENT_LOOP_PERIOD_US);
        embassy_rt::run_executor(embassy_rt::Idle::Spin, |spawner| {
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

    /// Starts a measurement phase; returns the stopwatch at its start.
    fn reset_measurements() -> u32 {
        TICK_MONITOR.reset();
        board::reset_longest_section();
        board::reset_current_loop();
        timer1::now()
    }

    /// Guest ns per count of the stopwatch (25 MHz).
    const NS_PER_COUNT: u32 = 40;

    /// What a phase measured (instructions, but for the runs).
    struct Phase {
        lock: u32,
        current_loop_kept_its_period: bool,
    }

    /// Prints the phase's measurements and checks that the current loop never missed its
    /// period: no run started a period or more after its timer expired, and it ran as often
    /// as the phase's length allows (give or take the runs at either end).
    fn report(phase: &str, started: u32) -> Phase {
        let lock = board::longest_lock_ns() / NS_PER_INSTRUCTION;
        let current_loop = board::current_loop();
        let period_ns = CURRENT_LOOP_PERIOD_US * 1000;
        let elapsed_ns = timer1::now().wrapping_sub(started).saturating_mul(NS_PER_COUNT);
        let expected_runs = elapsed_ns / period_ns;
        let kept = current_loop.most_late_ns < period_ns && current_loop.runs + 1 >= expected_runs;
        println!(
            "{}: longest lock {} instructions; longest masked {} instructions; longest tick {} instructions; tick lateness max {} instructions over {} ticks",
            phase,
            lock,
            board::longest_masked_ns() / NS_PER_INSTRUCTION,
            board::longest_tick_ns() / NS_PER_INSTRUCTION,
            TICK_MONITOR.max_lateness() / NS_PER_INSTRUCTION,
            TICK_MONITOR.ticks(),
        );
        println!(
            "{}: current loop {} runs of {} expected; period {} instructions, gap max {} instructions, lateness max {} instructions: {}",
            phase,
            current_loop.runs,
            expected_runs,
            period_ns / NS_PER_INSTRUCTION,
            current_loop.longest_gap_ns / NS_PER_INSTRUCTION,
            current_loop.most_late_ns / NS_PER_INSTRUCTION,
            if kept { "kept its period" } else { "MISSED its period" },
        );
        Phase { lock, current_loop_kept_its_period: kept }
    }

    /// Prints what one call of an empty closure under each lock costs from thread mode, in
    /// instructions (the loop's few included): the least of 20 rounds of 50 calls, so that a
    /// round an interrupt ran in does not count.
    fn lock_cost() {
        fn per_call(lock: &impl Lock) -> u32 {
            (0..20)
                .map(|_| {
                    let started = timer1::now();
                    for _ in 0..50 {
                        lock.lock(|| ());
                    }
                    timer1::now().wrapping_sub(started) * NS_PER_COUNT / NS_PER_INSTRUCTION / 50
                })
                .min()
                .unwrap_or(0)
        }
        println!(
            "one call under the lock: PriorityCeiling {} instructions, CriticalSection {} instructions",
            per_call(&PriorityCeiling::<{ board::priority::TICK }>),
            per_call(&CriticalSection),
        );
    }

    /// An expedited download of `size` (1, 2 or 4) bytes; true when confirmed.
    async fn download(index: u16, sub: u8, value: u32, size: u8) -> bool {
        let [lo, hi] = index.to_le_bytes();
        let [v0, v1, v2, v3] = value.to_le_bytes();
        let command = 0x23 | (4u8.saturating_sub(size) << 2);
        request([command, lo, hi, sub, v0, v1, v2, v3]).await[0] == 0x60
    }

    /// An expedited upload's value (up to 4 bytes).
    async fn upload(index: u16, sub: u8) -> Option<u32> {
        let [lo, hi] = index.to_le_bytes();
        let response = request([0x40, lo, hi, sub, 0, 0, 0, 0]).await;
        (response[0] & 0xE3 == 0x43)
            .then(|| u32::from_le_bytes([response[4], response[5], response[6], response[7]]))
    }

    /// Writes the controlword, then waits (up to 100 ms) for the statusword under `mask` to
    /// read `state`.
    async fn controlword(command: u16, mask: u16, state: u16) -> bool {
        if !download(0x6040, 0, u32::from(command), 2).await {
            return false;
        }
        for _ in 0..100 {
            if upload(0x6041, 0).await.is_some_and(|s| s as u16 & mask == state) {
                return true;
            }
            Timer::after_millis(1).await;
        }
        false
    }

    /// Profile position: Operation enabled, then one absolute set-point (the tick that takes it
    /// plans the whole move), then 30 ms of the move; true when every step was confirmed.
    async fn profile_position_set_point() -> bool {
        let mut ok = download(0x6060, 0, 1, 1).await; // profile position
        ok &= download(0x6081, 0, 20_000, 4).await; // profile velocity
        ok &= download(0x6083, 0, 100_000, 4).await; // acceleration
        ok &= download(0x6084, 0, 100_000, 4).await; // deceleration
        ok &= controlword(0x06, 0x6F, 0x21).await; // ready to switch on
        ok &= controlword(0x07, 0x6F, 0x23).await; // switched on
        ok &= controlword(0x0F, 0x6F, 0x27).await; // operation enabled
        ok &= download(0x607A, 0, 15_000, 4).await; // target position
                                                    // New set-point: statusword bit 12 acknowledges it.
        ok &= controlword(0x1F, 0x1000, 0x1000).await;
        ok &= download(0x6040, 0, 0x0F, 2).await;
        Timer::after_millis(30).await;
        ok
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
            "tick-bound: {} Hz tick, {} Hz current loop above the drive's lock, runner and SDO client in the firmware",
            1_000_000 / node::TICK_PERIOD.as_micros(),
            1_000_000 / CURRENT_LOOP_PERIOD_US,
        );
        lock_cost();
        // Let the drive boot and the tick settle.
        Timer::after_millis(20).await;
        while TO_CLIENT.try_receive().is_ok() {}
        let mut ok = true;
        let mut current_loop_ok = true;

        let started = reset_measurements();
        let uploaded = block_upload().await;
        let upload = report("16 KiB block upload", started);
        ok &= uploaded;
        current_loop_ok &= upload.current_loop_kept_its_period;

        let started = reset_measurements();
        ok &= block_download().await;
        current_loop_ok &= report("200-byte block download", started).current_loop_kept_its_period;

        let started = reset_measurements();
        for _ in 0..200 {
            ok &= request([0x40, 0x00, 0x10, 0, 0, 0, 0, 0]).await[0] == 0x43;
        }
        current_loop_ok &= report("200 expedited uploads", started).current_loop_kept_its_period;

        let started = reset_measurements();
        ok &= profile_position_set_point().await;
        current_loop_ok &= report("profile position set-point", started).current_loop_kept_its_period;

        let started = reset_measurements();
        TO_DRIVE.send(CanFrame::new_standard(0, &[0x82, NODE_ID]).unwrap_or_else(|| mps2::exit(110))).await;
        Timer::after_millis(20).await;
        current_loop_ok &= report("NMT reset communication", started).current_loop_kept_its_period;

        let within = upload.lock <= BLOCK_UPLOAD_BOUND_INSTRUCTIONS;
        println!(
            "bound: block upload longest lock {} <= {} instructions: {}; current loop kept its period in every phase: {}; transfers and steps correct: {}",
            upload.lock, BLOCK_UPLOAD_BOUND_INSTRUCTIONS, within, current_loop_ok, ok
        );
        mps2::exit(if within && current_loop_ok && ok { 0 } else { 1 });
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

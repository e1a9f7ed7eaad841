//! # canopen-drive on ST's B-G431B-ESC1
//!
//! The drive on a real motor-control board: STM32G431CB at 170 MHz, FDCAN1 in classic CAN
//! mode on the board's CAN connector (PA11 RX, PB9 TX, 500 kbit/s until an LSS master stores
//! another rate), parameters (1010h/1011h) in the last two pages of internal flash and the
//! LSS configuration in the page below, embassy-stm32.
//!
//! | context | priority | does |
//! |---|---|---|
//! | `InterruptExecutor` on UART4's (unused) interrupt | P1, above everything else the firmware runs | the 1 kHz control tick: sample the feedback, `SharedDrive::tick`, apply the demand to the power stage |
//! | FDCAN1 interrupts | embassy-stm32's | the HAL's receive queue and transmit wakers |
//! | thread-mode executor | lowest | the CAN runner: FDCAN ⇄ drive, `poll` at its deadline, the controller's error state to the drive, an LSS store to flash, and the bit-rate switch an LSS master activates (FDCAN1 closed and reopened); the indicator task: the red LED (PC6) as the CiA 303-3 ERR indicator every 10 ms, and the program requests of 1F51h |
//!
//! The discipline is `canopen-drive-embassy`'s (one critical section per call into the
//! drive). What is the board's to complete is marked `BOARD STUB` in `power.rs`: the FOC
//! current loop, the encoder/hall decoding and the hardware fault inputs. Flash with
//! `cargo run --release` (probe-rs over the on-board ST-LINK).
//!
//! Modes: the STM32G431CB's 128 KiB hold the drive with csp, csv, cst, pv and tq (the
//! default build, about 115 KiB; 6502h lists those); the trajectory planner of pp and hm does
//! not fit besides. The feature `stm32g474ce` builds the same firmware for the pin-compatible
//! STM32G474CE (512 KiB / 128 KiB) with every mode. README.md has the numbers.
//!
//! Program download (CiA 302-3): with the feature `application-image` the firmware is linked
//! into the program area behind the bootloader (`src/bin/bootloader.rs`, `src/boot.rs`), has
//! 1F50h-1F57h, reads its 1F56h from the image header there, and resets into the bootloader
//! for a stop or a reset (1F51h:1 = 0 or 2). What the firmware shares with the bootloader
//! (layout, identity, CAN, LSS page, LED) is the crate's library, `src/lib.rs`.
#![no_std]
#![no_main]

use canopen_drive::comm::program::ProgramRequest;
use canopen_drive::wire::lss::BitTiming;
use canopen_drive::{Config, Drive};
use canopen_drive_b_g431b_esc1::led::{self, ErrLed};
use canopen_drive_b_g431b_esc1::{boot, can, lss, power, storage, DEVICE, NODE_ID};
use canopen_drive_embassy::fdcan::FdcanStatus;
use canopen_drive_embassy::{run_until_bit_rate_change, BusState, RunnerHooks, SharedDrive, TickMonitor};
use defmt_rtt as _;
use embassy_executor::{InterruptExecutor, Spawner};
use embassy_stm32::flash::Flash;
use embassy_stm32::interrupt;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_time::{Duration, Timer};
use lss::LssConfig;
use panic_probe as _;
use static_cell::StaticCell;

/// The drive of this board: no manufacturer objects yet (a dictionary store sized to the
/// standard tables), 4 + 4 PDOs, parameters in flash.
pub type BoardDrive = Drive<(), { canopen_drive::drive::STANDARD_OD_BYTES }, 4, 4, storage::ParameterStore>;

/// Layout number of the stored parameters (part of the storage signature).
const STORAGE_LAYOUT: u16 = 1;
/// The control tick period (the core's default rate).
const TICK_PERIOD: Duration = Duration::from_micros(1000);

static DRIVE: SharedDrive<&'static mut BoardDrive> = SharedDrive::new();
static DRIVE_CELL: StaticCell<BoardDrive> = StaticCell::new();
static TICK_MONITOR: TickMonitor = TickMonitor::new();
static TICK_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

#[interrupt]
unsafe fn UART4() {
    // SAFETY: UART4 is not used as a UART on this board; its interrupt runs the tick executor.
    unsafe { TICK_EXECUTOR.on_interrupt() }
}

#[inline(never)]
fn make_drive(
    store: storage::ParameterStore,
    node_id: u8,
    identification: u32,
) -> Option<&'static mut BoardDrive> {
    let config = Config {
        device: DEVICE,
        lss_store: true,
        bit_rates: &can::BIT_RATES,
        // Behind the bootloader: 1F50h-1F57h, 1F56h the CRC-32 of this image.
        program_download: cfg!(feature = "application-image"),
        ..Config::new(node_id)
    };
    // Built in place: a drive built by value and moved would need several times its size
    // of stack, more than this part's 32 KiB of RAM.
    let drive = Drive::build_in(DRIVE_CELL.uninit(), config, (), store).ok()?;
    if cfg!(feature = "application-image") {
        drive.set_program_identification(identification);
    }
    Some(drive)
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(power::clocks());
    let mut flash = Flash::new_blocking(p.FLASH);
    let stored = lss::load(&mut flash);
    let node_id = stored.map_or(NODE_ID, |s| s.node_id);
    let bit_rate = stored.and_then(|s| s.bit_timing).and_then(can::bit_rate).unwrap_or(can::DEFAULT_BIT_RATE);
    defmt::info!(
        "canopen-drive on B-G431B-ESC1, node {}, {} bit/s (LSS store: {})",
        node_id,
        bit_rate,
        stored
    );

    // The CRC-32 of this image, from the header the bootloader wrote before it.
    let identification =
        if cfg!(feature = "application-image") { boot::identification(&mut flash) } else { 0 };

    let Some(store) = storage::open(flash, &DEVICE, STORAGE_LAYOUT) else {
        defmt::panic!("parameter flash area");
    };
    let Some(drive) = make_drive(store, node_id, identification) else {
        defmt::panic!("drive configuration");
    };
    DRIVE.put(drive);

    let (feedback, stage) = power::init(power::Pins {
        tim1: p.TIM1,
        ch1: p.PA8,
        ch1n: p.PC13,
        ch2: p.PA9,
        ch2n: p.PA12,
        ch3: p.PA10,
        ch3n: p.PB15,
        adc1: p.ADC1,
        vbus: p.PA0,
        tim4: p.TIM4,
        encoder_a: p.PB6,
        encoder_b: p.PB7,
    });

    let can = can::Pins { fdcan: p.FDCAN1, rx: p.PA11, tx: p.PB9 };

    // The tick preempts the runner (thread mode) and every lower-priority interrupt.
    interrupt::UART4.set_priority(Priority::P1);
    let tick_spawner = TICK_EXECUTOR.start(interrupt::UART4);
    match tick_task(feedback, stage) {
        Ok(token) => tick_spawner.spawn(token),
        Err(_) => defmt::panic!("tick task"),
    }
    match can_task(can, Board { status: None, stored }, bit_rate) {
        Ok(token) => spawner.spawn(token),
        Err(_) => defmt::panic!("CAN task"),
    }
    match indicator_task(ErrLed::new(p.PC6)) {
        Ok(token) => spawner.spawn(token),
        Err(_) => defmt::panic!("indicator task"),
    }
}

/// The CAN runner, and the bit-rate switches an LSS master activates (CiA 305): the runner
/// ends at the activation; the old rate is kept for a switch delay (the other nodes finish),
/// FDCAN1 is closed and reopened at the new rate and stays silent for another switch delay.
#[embassy_executor::task]
async fn can_task(mut can: can::Pins, mut board: Board, mut bit_rate: u32) {
    let mut quiet = Duration::from_ticks(0);
    loop {
        let (mut rx, mut tx, status) = match can.open(bit_rate) {
            Ok(halves) => halves,
            Err(e) => {
                defmt::panic!("no FDCAN bit timing for {} bit/s from {} Hz", e.bit_rate, e.kernel_clock)
            }
        };
        board.status = Some(status);
        Timer::after(quiet).await;
        let change = run_until_bit_rate_change(&DRIVE, &mut rx, &mut tx, &mut board).await;
        // The drive accepts only rates of can::BIT_RATES (Config::bit_rates).
        let next = can::bit_rate(change.bit_timing).unwrap_or(bit_rate);
        defmt::info!("LSS: {} bit/s in {} ms", next, change.switch_delay_ms);
        quiet = Duration::from_millis(change.switch_delay_ms.into());
        Timer::after(quiet).await;
        board.status = None;
        bit_rate = next;
        // rx and tx are dropped here: FDCAN1 is closed.
    }
}

/// The board's part of LSS and CAN error handling, for the runner.
struct Board {
    /// FDCAN1's error state, while it is open.
    status: Option<FdcanStatus>,
    /// The LSS configuration in flash.
    stored: Option<LssConfig>,
}

impl RunnerHooks for Board {
    fn bus_state(&mut self) -> Option<BusState> {
        self.status.as_ref().map(FdcanStatus::bus_state)
    }

    fn store_lss(&mut self, node_id: u8, bit_timing: Option<BitTiming>) {
        // No bit timing configured since start-up: the stored one stays.
        let bit_timing = bit_timing.or(self.stored.and_then(|s| s.bit_timing));
        let config = LssConfig { node_id, bit_timing };
        // The drive owns the flash (the parameter storage); the page is outside its area.
        // A page erase (once every 256 stores) holds the critical section for about 20 ms.
        match DRIVE.with(|d| lss::store(d.storage_mut().area_mut().flash_mut(), &config)) {
            Some(Ok(())) => {
                defmt::info!("LSS: stored {}", config);
                self.stored = Some(config);
            }
            Some(Err(e)) => defmt::error!("LSS: store failed: {}", e),
            None => defmt::error!("LSS: store failed: drive busy"),
        }
    }
}

/// How long a program request waits for FDCAN1 to send the answer before the reset: its
/// three transmit buffers' worth of classic frames (at most 160 bits each) at the slowest
/// rate, 10 kbit/s, is 48 ms.
const SEND_DELAY: Duration = Duration::from_millis(100);

/// The red LED as the CiA 303-3 ERR indicator, sampled every 10 ms; and, behind the
/// bootloader, the program requests of 1F51h:1: a stop (0) resets into the bootloader and
/// asks it to stay, a reset (2) resets into it to start this program again. The request is
/// given once its answer has left the drive's queue; the task then gives FDCAN1
/// [`SEND_DELAY`] to send it. (Without the feature `application-image` the drive has no
/// 1F51h and never asks.)
#[embassy_executor::task]
async fn indicator_task(mut led: ErrLed) {
    loop {
        let now = canopen_drive_embassy::now();
        let state = DRIVE.with(|drive| (drive.node_status(), drive.take_program_request()));
        if let Some((status, request)) = state {
            led.show(&status, now);
            if let Some(request) = request {
                defmt::info!("program {}: reset into the bootloader", request);
                Timer::after(SEND_DELAY).await;
                boot::reset_into_bootloader(request == ProgramRequest::Stop);
            }
        }
        Timer::after_millis(led::PERIOD_MS).await;
    }
}

#[embassy_executor::task]
async fn tick_task(mut feedback: power::Feedback, mut stage: power::Stage) {
    canopen_drive_embassy::run_tick(
        &DRIVE,
        TICK_PERIOD,
        &TICK_MONITOR,
        || feedback.sample(),
        |demand| stage.apply(demand),
    )
    .await
}

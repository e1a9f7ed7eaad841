//! # canopen-drive on ST's B-G431B-ESC1
//!
//! The drive on a real motor-control board: STM32G431CB at 170 MHz, FDCAN1 in classic CAN
//! mode on the board's CAN connector (PA11 RX, PB9 TX, 500 kbit/s), parameters (1010h/1011h)
//! in the last two pages of internal flash, embassy-stm32.
//!
//! | context | priority | does |
//! |---|---|---|
//! | `InterruptExecutor` on UART4's (unused) interrupt | P1, above everything else the firmware runs | the 1 kHz control tick: sample the feedback, `SharedDrive::tick`, apply the demand to the power stage |
//! | FDCAN1 interrupts | embassy-stm32's | the HAL's receive queue and transmit wakers |
//! | thread-mode executor | lowest | the CAN runner: FDCAN ⇄ drive, `poll` at its deadline |
//!
//! The discipline is `canopen-drive-embassy`'s (one critical section per call into the
//! drive). What is the board's to complete is marked `BOARD STUB` in `power.rs`: the FOC
//! current loop, the encoder/hall decoding and the hardware fault inputs. Flash with
//! `cargo run --release` (probe-rs over the on-board ST-LINK).
//!
//! Modes: the STM32G431CB's 128 KiB hold the drive with csp, csv, cst, pv and tq (the
//! default build, about 109 KiB; 6502h lists those); the trajectory planner of pp and hm does
//! not fit besides. The feature `stm32g474ce` builds the same firmware for the pin-compatible
//! STM32G474CE (512 KiB / 128 KiB) with every mode. README.md has the numbers.
#![no_std]
#![no_main]

mod can;
mod power;
mod storage;

use canopen_drive::od::DeviceInfo;
use canopen_drive::{Config, Drive};
use canopen_drive_embassy::{SharedDrive, TickMonitor};
use defmt_rtt as _;
use embassy_executor::{InterruptExecutor, Spawner};
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::{bind_interrupts, interrupt, peripherals};
use embassy_time::Duration;
use panic_probe as _;
use static_cell::StaticCell;

bind_interrupts!(struct Irqs {
    FDCAN1_IT0 => embassy_stm32::can::IT0InterruptHandler<peripherals::FDCAN1>;
    FDCAN1_IT1 => embassy_stm32::can::IT1InterruptHandler<peripherals::FDCAN1>;
});

/// The drive of this board: no manufacturer objects yet (a dictionary store sized to the
/// standard tables), 4 + 4 PDOs, parameters in flash.
pub type BoardDrive = Drive<(), { canopen_drive::drive::STANDARD_OD_BYTES }, 4, 4, storage::ParameterStore>;

/// Node-ID until LSS or a stored configuration says otherwise.
const NODE_ID: u8 = 5;
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

fn device_info() -> DeviceInfo {
    DeviceInfo {
        device_name: "canopen-drive B-G431B-ESC1",
        hardware_version: if cfg!(feature = "stm32g474ce") {
            "B-G431B-ESC1 (STM32G474CE)"
        } else {
            "B-G431B-ESC1 (STM32G431CB)"
        },
        vendor_name: "canopen-drive project",
        ..DeviceInfo::servo_drive()
    }
}

#[inline(never)]
fn make_drive(store: storage::ParameterStore) -> Option<&'static mut BoardDrive> {
    let config = Config { device: device_info(), ..Config::new(NODE_ID) };
    // Built in place: a drive built by value and moved would need several times its size
    // of stack, more than this part's 32 KiB of RAM.
    Drive::build_in(DRIVE_CELL.uninit(), config, (), store).ok()
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(power::clocks());
    defmt::info!("canopen-drive on B-G431B-ESC1, node {}", NODE_ID);

    let Some(store) = storage::open(p.FLASH, &device_info(), STORAGE_LAYOUT) else {
        defmt::panic!("parameter flash area");
    };
    let Some(drive) = make_drive(store) else {
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

    let (rx, tx) = can::start(p.FDCAN1, p.PA11, p.PB9, Irqs);

    // The tick preempts the runner (thread mode) and every lower-priority interrupt.
    interrupt::UART4.set_priority(Priority::P1);
    let tick_spawner = TICK_EXECUTOR.start(interrupt::UART4);
    match tick_task(feedback, stage) {
        Ok(token) => tick_spawner.spawn(token),
        Err(_) => defmt::panic!("tick task"),
    }
    match can_task(rx, tx) {
        Ok(token) => spawner.spawn(token),
        Err(_) => defmt::panic!("CAN task"),
    }
}

#[embassy_executor::task]
async fn can_task(rx: can::FdcanRx, tx: can::FdcanTx) {
    canopen_drive_embassy::run(&DRIVE, rx, tx).await
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

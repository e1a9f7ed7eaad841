//! # The B-G431B-ESC1 board
//!
//! What the board's two firmware images share: the application (`src/main.rs`, the drive)
//! and the bootloader (`src/bin/bootloader.rs`, CiA 302-3 program download).
//!
//! | module | what |
//! |---|---|
//! | [`layout`] | where bootloader, program area, LSS page, parameters and the hand-over word live, for both parts (build.rs writes the linker's map from it) |
//! | [`boot`] | program download: the program area, the hand-over word, the check of an image's vector table, the jump into it, the reset into the bootloader |
//! | [`can`] | FDCAN1 on the CAN connector, the bit rates |
//! | [`led`] | the red LED (PC6), the CiA 303-3 ERR indicator |
//! | [`lss`] | the LSS configuration page |
//! | [`power`] | clocks, the inverter, the feedback |
//! | [`storage`] | the parameter area |
#![no_std]

pub mod boot;
pub mod can;
pub mod led;
pub mod lss;
pub mod power;
pub mod storage;

/// The memory layout of both parts (`src/layout.rs`, shared with build.rs).
pub mod layout {
    include!("layout.rs");

    /// The layout of the part this firmware is built for.
    pub const THIS_PART: Layout = Layout::of(cfg!(feature = "stm32g474ce"));
}

use canopen_drive::od::DeviceInfo;

/// Node-ID until an LSS master stores another (`lss.rs`); the bootloader's too.
pub const NODE_ID: u8 = 5;

/// The application's identity: 1000h (a CiA 402 servo drive) and 1018h:1–2 are the
/// bootloader's too ([`BOOTLOADER_DEVICE`]), so that a master that checks them accepts both.
pub const DEVICE: DeviceInfo = DeviceInfo {
    device_name: "canopen-drive B-G431B-ESC1",
    hardware_version: if cfg!(feature = "stm32g474ce") {
        "B-G431B-ESC1 (STM32G474CE)"
    } else {
        "B-G431B-ESC1 (STM32G431CB)"
    },
    vendor_name: "canopen-drive project",
    ..DeviceInfo::servo_drive()
};

/// The bootloader's identity: the application's 1000h and 1018h:1–2, its own name (1008h),
/// software version (100Ah) and revision (1018h:3).
pub const BOOTLOADER_DEVICE: DeviceInfo = DeviceInfo {
    device_name: "canopen-drive B-G431B-ESC1 bootloader",
    software_version: "bootloader 1.0.0",
    revision_number: 0x00FF_0001,
    ..DEVICE
};

const _: () = assert!(
    BOOTLOADER_DEVICE.device_type == DEVICE.device_type
        && BOOTLOADER_DEVICE.vendor_id == DEVICE.vendor_id
        && BOOTLOADER_DEVICE.product_code == DEVICE.product_code
);

//! The drive of this firmware, and the identity it shares with the bootloader.

use canopen_drive::od::DeviceInfo;
use canopen_drive::{Config, Drive, Duration};

use crate::objects::{BoardHooks, BOARD_OBJECTS};

/// The drive type of the firmware: board hooks, default dictionary size, 4 + 4 PDOs.
pub type BoardDrive = Drive<BoardHooks>;

/// Node-ID of the firmware (and of its bootloader).
pub const NODE_ID: u8 = 5;

/// The control tick period (the core's default tick rate, 1 kHz).
pub const TICK_PERIOD: Duration = Duration::from_micros(1000);

/// 1018h:1 vendor-ID: this project has no vendor-ID of CiA's.
pub const VENDOR_ID: u32 = 0;
/// 1018h:2 product code: "MPS2" in ASCII.
pub const PRODUCT_CODE: u32 = 0x4D50_5332;

/// 100Ah of the application: the build's `QEMU_MPS2_SOFTWARE_VERSION` when it was set (two
/// builds that a program download tells apart), else the crate's version.
pub const SOFTWARE_VERSION: &str = match option_env!("QEMU_MPS2_SOFTWARE_VERSION") {
    Some(version) => version,
    None => DeviceInfo::servo_drive().software_version,
};

/// 1018h:3 of the application: the build's `QEMU_MPS2_REVISION` (decimal, or hex after "0x")
/// when it was set, else 0. A value that is no number stops the build.
pub const REVISION: u32 = match option_env!("QEMU_MPS2_REVISION") {
    None => 0,
    Some(text) => match parse_u32(text.as_bytes()) {
        Some(revision) => revision,
        #[allow(clippy::panic, reason = "evaluated when compiled: a build error, never a panic at run time")]
        None => panic!("QEMU_MPS2_REVISION is no u32 (decimal, or hex after 0x)"),
    },
};

/// The application's identity: 1000h (a CiA 402 servo drive) and 1018h:1–2 are the
/// bootloader's too ([`BOOTLOADER_DEVICE`]), so that a master that checks them accepts both.
pub const DEVICE: DeviceInfo = DeviceInfo {
    vendor_id: VENDOR_ID,
    product_code: PRODUCT_CODE,
    revision_number: REVISION,
    software_version: SOFTWARE_VERSION,
    device_name: "canopen-drive qemu-mps2",
    hardware_version: "QEMU mps2, simulated motor",
    vendor_name: "canopen-drive project",
    ..DeviceInfo::servo_drive()
};

/// The bootloader's identity (`src/bin/bootloader.rs`): the application's 1000h and
/// 1018h:1–2, its own name (1008h), software version (100Ah) and revision (1018h:3).
pub const BOOTLOADER_DEVICE: DeviceInfo = DeviceInfo {
    device_name: "canopen-drive qemu-mps2 bootloader",
    software_version: "bootloader 1.0.0",
    revision_number: 0x00FF_0001,
    ..DEVICE
};

/// The configuration: a CiA 402 servo drive with every mode, and the board's objects.
pub fn config() -> Config {
    Config { device: DEVICE, manufacturer_objects: &BOARD_OBJECTS, ..Config::new(NODE_ID) }
}

/// A number in decimal, or in hex after "0x".
const fn parse_u32(text: &[u8]) -> Option<u32> {
    let (radix, mut digits) = match text {
        [b'0', b'x' | b'X', rest @ ..] => (16, rest),
        _ => (10, text),
    };
    if digits.is_empty() {
        return None;
    }
    let mut value: u32 = 0;
    while let [first, rest @ ..] = digits {
        let digit = match (*first as char).to_digit(radix) {
            Some(d) => d,
            None => return None,
        };
        value = match value.checked_mul(radix) {
            Some(v) => match v.checked_add(digit) {
                Some(v) => v,
                None => return None,
            },
            None => return None,
        };
        digits = rest;
    }
    Some(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn revisions_parse_in_decimal_and_hex() {
        assert_eq!(parse_u32(b"0x00020001"), Some(0x0002_0001));
        assert_eq!(parse_u32(b"65536"), Some(65536));
        assert_eq!(parse_u32(b"0xFFFFFFFF"), Some(u32::MAX));
        assert_eq!(parse_u32(b"0x100000000"), None);
        assert_eq!(parse_u32(b"12a"), None);
        assert_eq!(parse_u32(b""), None);
        assert_eq!(parse_u32(b"0x"), None);
    }

    #[test]
    fn bootloader_and_application_share_1000h_and_1018h_1_2() {
        assert_eq!(BOOTLOADER_DEVICE.device_type, DEVICE.device_type);
        assert_eq!(BOOTLOADER_DEVICE.vendor_id, DEVICE.vendor_id);
        assert_eq!(BOOTLOADER_DEVICE.product_code, DEVICE.product_code);
    }
}

//! The drive of this firmware.

use canopen_drive::od::DeviceInfo;
use canopen_drive::{Config, Drive, Duration};

use crate::objects::{BoardHooks, BOARD_OBJECTS};

/// The drive type of the firmware: board hooks, default dictionary size, 4 + 4 PDOs.
pub type BoardDrive = Drive<BoardHooks>;

/// Node-ID of the firmware.
pub const NODE_ID: u8 = 5;

/// The control tick period (the core's default tick rate, 1 kHz).
pub const TICK_PERIOD: Duration = Duration::from_micros(1000);

/// The configuration: a CiA 402 servo drive with every mode, and the board's objects.
pub fn config() -> Config {
    Config {
        device: DeviceInfo {
            device_name: "canopen-drive qemu-mps2",
            hardware_version: "QEMU mps2, simulated motor",
            vendor_name: "canopen-drive project",
            ..DeviceInfo::servo_drive()
        },
        manufacturer_objects: &BOARD_OBJECTS,
        ..Config::new(NODE_ID)
    }
}

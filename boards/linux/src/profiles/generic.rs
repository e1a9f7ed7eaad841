//! The generic drive: the library's CiA 301/402 defaults, the simulation objects at
//! 2100h–2102h, and the simulated axis of the README (10 000 increments per revolution, limit
//! switches beyond ±100 000, home switch 20 000..30 000, hard stops at ±120 000).

use canopen_drive::od::eds::EdsInfo;
use canopen_drive::od::DeviceInfo;
use canopen_drive_sim::motor::{MotorParams, Zone};

use super::{BoardProfile, NoFirmware, ProfileName, TEMPLATE_NODE_ID};
use crate::board_objects::{BOARD_OBJECTS, GENERIC_SIMULATION};
use canopen_drive::Config;

/// Identity of the generic drive (1008h–100Ah, EDS `VendorName`).
pub fn device_info() -> DeviceInfo {
    DeviceInfo {
        device_name: "canopen-drive-linux",
        hardware_version: "Linux host, simulated motor",
        software_version: env!("CARGO_PKG_VERSION"),
        vendor_name: "canopen-drive project",
        ..DeviceInfo::servo_drive()
    }
}

/// The `[FileInfo]` facts of the generic drive's EDS.
pub fn eds_info() -> EdsInfo {
    EdsInfo {
        file_name: "canopen-drive-linux.eds",
        description: "canopen-drive CiA 402 drive on a Linux host with a simulated motor",
        ..EdsInfo::default()
    }
}

/// The simulated axis of the README: every homing method has a scene.
pub fn axis() -> MotorParams {
    MotorParams {
        negative_limit_switch: Some(-100_000),
        positive_limit_switch: Some(100_000),
        home_switch: Some(Zone::between(20_000, 30_000)),
        negative_hard_stop: Some(-120_000),
        positive_hard_stop: Some(120_000),
        hard_stop_stiffness: 1000.0,
        hard_stop_damping: 2.0,
        ..MotorParams::default()
    }
}

/// The generic profile.
pub fn profile() -> BoardProfile {
    BoardProfile {
        name: ProfileName::Generic,
        config: Config {
            device: device_info(),
            manufacturer_objects: &BOARD_OBJECTS,
            ..Config::new(TEMPLATE_NODE_ID)
        },
        eds: eds_info(),
        simulation: GENERIC_SIMULATION,
        rules: &[],
        axis: axis(),
        firmware: || Box::new(NoFirmware),
    }
}

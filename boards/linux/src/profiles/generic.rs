//! The generic drive: the library's CiA 301/402 defaults, manufacturer objects generated at
//! build time from their EDS (`examples/eds-import/generic-drive.eds`: example motor parameters
//! at 2000h–2006h and the simulation objects at 2100h–2102h), and the simulated axis of the README (10 000 increments per revolution, limit
//! switches beyond ±100 000, home switch 20 000..30 000, hard stops at ±120 000).

use canopen_drive::od::eds::EdsInfo;
use canopen_drive::od::DeviceInfo;
use canopen_drive_sim::motor::{MotorParams, Zone};

use super::{BoardProfile, NoFirmware, ProfileName, TEMPLATE_NODE_ID};
use crate::board_objects::GENERIC_SIMULATION;
use canopen_drive::Config;
use canopen_drive_example_eds_import::MANUFACTURER_OBJECTS;

/// Product code of the generic drive in 1018h sub 2: "CDL" (canopen-drive-linux) in ASCII.
/// Stored parameters are signed with 1018h's vendor-ID and product code, so this must differ
/// from every other profile's (the test `every_profile_signs_its_stored_parameters_differently`).
pub const PRODUCT_CODE: u32 = 0x0043_444C;

/// Identity of the generic drive (1008h–100Ah, 1018h, EDS `VendorName`). The project has no
/// vendor-ID of CiA's, so 1018h sub 1 stays 0 (unassigned); the product code, the revision (the
/// crate's major version in the high 16 bits, its minor version in the low ones, as CiA 301
/// splits the revision number) and a serial number of 1 identify the program.
pub fn device_info() -> DeviceInfo {
    DeviceInfo {
        product_code: PRODUCT_CODE,
        revision_number: revision(),
        serial_number: 1,
        device_name: "canopen-drive-linux",
        hardware_version: "Linux host, simulated motor",
        software_version: env!("CARGO_PKG_VERSION"),
        vendor_name: "canopen-drive project",
        ..DeviceInfo::servo_drive()
    }
}

/// 1018h sub 3 from the crate version: major.minor as high.low 16 bits.
fn revision() -> u32 {
    let major: u32 = env!("CARGO_PKG_VERSION_MAJOR").parse().unwrap_or(0);
    let minor: u32 = env!("CARGO_PKG_VERSION_MINOR").parse().unwrap_or(0);
    (major << 16) | (minor & 0xFFFF)
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
        axes: 1,
        name: ProfileName::Generic,
        config: Config {
            device: device_info(),
            manufacturer_objects: &MANUFACTURER_OBJECTS,
            ..Config::new(TEMPLATE_NODE_ID)
        },
        eds: eds_info(),
        simulation: GENERIC_SIMULATION,
        rules: &[],
        axis: axis(),
        firmware: || Box::new(NoFirmware),
    }
}

#[cfg(test)]
#[cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic))]
mod tests {
    use super::*;

    #[test]
    fn identity_is_not_blank() {
        let device = device_info();
        assert_eq!(device.product_code, 0x0043_444C);
        assert_eq!(device.revision_number, 1, "0.1.x is revision 0.1");
        assert_eq!(device.serial_number, 1);
    }
}

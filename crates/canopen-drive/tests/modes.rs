//! The optional modes (cargo features `pp`, `hm`, `ip`, `vl`, `touch-probe`) as a master sees
//! them: 6502h lists exactly the modes of the build, 6060h accepts exactly those, a mode's
//! objects exist exactly when it is built, a configuration that claims a missing mode is
//! refused, and a build without any of them still runs a cyclic mode to its set-point.
//!
//! The same file runs in every feature combination: `cargo test -p canopen-drive --test modes`
//! (all modes) and with `--no-default-features` (none of them), both in `scripts/test.sh`.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

use canopen_drive::cia402::objects::mode_bit;
use canopen_drive::cia402::registry::IMPLEMENTED_MODES;
use canopen_drive::drive::STANDARD_OD_BYTES;
use canopen_drive::hal::Setpoint;
use canopen_drive::od::{ConfigError, DeviceInfo};
use canopen_drive::{CanFrame, Config, Drive};

mod common;

use common::{Node, NODE};

/// (6060h value, 6502h bit, built, objects only that mode has).
fn optional_modes() -> [(i8, u32, bool, &'static [u16]); 4] {
    [
        (
            1,
            mode_bit::PROFILE_POSITION,
            cfg!(feature = "pp"),
            &[0x6081, 0x6082, 0x6086, 0x60A3, 0x60A4, 0x60F2],
        ),
        (
            2,
            canopen_drive::cia402::vl::MODE_BIT,
            cfg!(feature = "vl"),
            &[0x6042, 0x6043, 0x6044, 0x6046, 0x6048, 0x6049, 0x604A, 0x604B, 0x604C],
        ),
        (6, mode_bit::HOMING, cfg!(feature = "hm"), &[0x6098, 0x6099, 0x609A, 0x60E3]),
        (7, mode_bit::INTERPOLATED_POSITION, cfg!(feature = "ip"), &[0x60C0, 0x60C1, 0x60C4]),
    ]
}

const ALWAYS: [(i8, u32); 5] = [
    (3, mode_bit::PROFILE_VELOCITY),
    (4, mode_bit::PROFILE_TORQUE),
    (8, mode_bit::CYCLIC_POSITION),
    (9, mode_bit::CYCLIC_VELOCITY),
    (10, mode_bit::CYCLIC_TORQUE),
];

#[test]
fn supported_modes_are_the_built_ones() {
    let mut node = Node::with_sdo_set_points();
    let mut expected = ALWAYS.iter().fold(0, |bits, (_, bit)| bits | bit);
    for (_, bit, built, _) in optional_modes() {
        if built {
            expected |= bit;
        }
    }
    assert_eq!(IMPLEMENTED_MODES, expected);
    assert_eq!(node.read(0x6502, 0), Ok(expected));
    for (mode, _) in ALWAYS {
        assert_eq!(node.write(0x6060, 0, mode as u8 as u32, 1), Ok(()), "mode {mode}");
    }
    for (mode, _, built, _) in optional_modes() {
        let answer = node.write(0x6060, 0, mode as u8 as u32, 1);
        if built {
            assert_eq!(answer, Ok(()), "mode {mode}");
        } else {
            // 0609 0030h: value range exceeded (not a mode this drive has).
            assert_eq!(answer, Err(0x0609_0030), "mode {mode}");
        }
    }
}

#[test]
fn a_modes_objects_exist_when_it_is_built() {
    let mut node = Node::with_sdo_set_points();
    let probe = [0x60B8, 0x60B9, 0x60BA, 0x60BB, 0x60BC, 0x60BD, 0x60D5, 0x60D6, 0x60D7, 0x60D8];
    let groups = optional_modes().map(|(_, _, built, objects)| (built, objects));
    for (built, objects) in groups.into_iter().chain([(cfg!(feature = "touch-probe"), &probe[..])]) {
        for &index in objects {
            let answer = node.read(index, 0);
            if built {
                assert!(answer.is_ok(), "{index:04X}h: {answer:x?}");
            } else {
                assert_eq!(answer, Err(0x0602_0000), "{index:04X}h");
            }
        }
    }
    // Objects the always-built modes share with the optional ones stay.
    for index in [0x607A, 0x607C, 0x6083, 0x6084, 0x60C2, 0x60C5, 0x60C6, 0x60FF, 0x6071] {
        assert!(node.read(index, 0).is_ok(), "{index:04X}h");
    }
    // Homing method 36 homes on touch probe 1.
    if cfg!(feature = "hm") {
        let method_36 = node.write(0x6098, 0, 36, 1);
        assert_eq!(method_36.is_ok(), cfg!(feature = "touch-probe"));
    }
}

#[test]
fn a_configuration_claiming_a_missing_mode_is_refused() {
    for (_, bit, built, _) in optional_modes() {
        let config = Config {
            device: DeviceInfo { drive_modes: mode_bit::CYCLIC_POSITION | bit, ..DeviceInfo::servo_drive() },
            ..Config::new(NODE)
        };
        match Drive::new(config) {
            Ok(_) => assert!(built, "6502h bit {bit:#x} accepted without its mode"),
            Err(error) => {
                assert!(!built, "6502h bit {bit:#x}: {error:?}");
                assert!(matches!(error, ConfigError::ModesNotBuilt { modes } if modes == bit));
            }
        }
    }
    // Manufacturer bits (16–31) are the firmware's own.
    let config = Config {
        device: DeviceInfo { drive_modes: mode_bit::CYCLIC_POSITION | 1 << 16, ..DeviceInfo::servo_drive() },
        ..Config::new(NODE)
    };
    assert!(Drive::new(config).is_ok());
}

#[test]
fn csp_runs_in_every_build() {
    let mut node = Node::with_sdo_set_points();
    node.write(0x6060, 0, 8, 1).unwrap();
    // Room to reach the target within the run (60C5h/60C6h max acceleration/deceleration).
    node.write(0x60C5, 0, u32::MAX, 4).unwrap();
    node.write(0x60C6, 0, u32::MAX, 4).unwrap();
    for (command, state_mask, state) in [(0x06, 0x6F, 0x21), (0x07, 0x6F, 0x23), (0x0F, 0x6F, 0x27)] {
        node.write(0x6040, 0, command, 2).unwrap();
        node.tick();
        node.tick();
        assert_eq!(node.statusword() & state_mask, state, "after controlword {command:#x}");
    }
    assert_eq!(node.read(0x6061, 0), Ok(8));
    let mut last = 0;
    for _ in 0..50 {
        // Each cycle: the set-point, then SYNC (60C2h: 1 ms, the tick).
        node.write(0x607A, 0, 200, 4).unwrap();
        let sync = CanFrame::new_standard(0x80, &[]).unwrap();
        node.drive.on_frame(&sync, node.now);
        if let Setpoint::Position(p) = node.tick().setpoint {
            assert!((last..=200).contains(&p), "demand {p} after {last}");
            last = p;
            node.sample.position = p;
        }
    }
    assert_eq!(last, 200, "the demand reaches the target");
}

#[test]
fn a_dictionary_sized_to_the_standard_tables_holds_them() {
    type Exact = Drive<(), STANDARD_OD_BYTES>;
    let drive = Exact::build(Config::new(NODE), (), ()).unwrap();
    assert_eq!(drive.od().used_bytes(), STANDARD_OD_BYTES);
    type Short = Drive<(), { STANDARD_OD_BYTES - 1 }>;
    let refused = Short::build(Config::new(NODE), (), ()).err();
    assert_eq!(refused, Some(ConfigError::StorageTooSmall { needed: STANDARD_OD_BYTES }));
}

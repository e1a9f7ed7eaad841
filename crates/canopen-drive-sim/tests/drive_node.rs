//! A firmware's own drive of any shape, ticked against simulated motors and driven through the
//! CiA 402 procedures of the scripted master.
#![allow(clippy::unwrap_used, clippy::indexing_slicing)]

use canopen_drive::comm::pdo;
use canopen_drive::od::{layout, Object};
use canopen_drive::{Config, Duration, MultiAxisDrive};
use canopen_drive_sim::{DriveNode, Master, MotionError, VirtualBus};

static PDOS: [Object; 32] = layout(pdo::objects::<32>(8));

#[test]
fn each_axis_of_a_two_axis_node_moves_its_own_motor() {
    let config = Config { pdo_objects: &PDOS, ..Config::new(7) };
    let drive = MultiAxisDrive::<2, 8, 8, (), (), 8192>::build(config, (), ()).unwrap();
    let mut bus = VirtualBus::new();
    let node = bus.add_drive(DriveNode::new(drive, Duration::from_millis(1)));
    let mut master = Master::new(bus);

    master.axis(7, 1).enable().unwrap();
    master.axis(7, 1).pp_move(3_000, Duration::from_millis(3_000)).unwrap();
    assert!((master.axis(7, 1).read_i32(0x6064).unwrap() - 3_000).abs() <= 100, "within 6067h");
    assert_eq!(master.axis(7, 0).read_i32(0x6064).unwrap(), 0, "the first axis stays");
    let sim = master.bus().drive(node).unwrap();
    assert!((sim.axis_motor(1).unwrap().position() - 3_000.0).abs() <= 100.0);
    assert_eq!(sim.motor.position(), 0.0);
    assert!(sim.more_axes[0].1.drive_enabled, "the second axis's last demand");
    assert!(!sim.demand.drive_enabled, "the first axis has no energy");
}

#[test]
fn a_move_from_switch_on_disabled_fails_with_the_statusword() {
    let mut bus = VirtualBus::new();
    bus.add_drive(DriveNode::new(
        canopen_drive::Drive::new(Config::new(3)).unwrap(),
        Duration::from_millis(1),
    ));
    let mut master = Master::new(bus);
    let error = master.axis(3, 0).pp_move(1_000, Duration::from_millis(500)).unwrap_err();
    // Not enabled: the drive never acknowledges the set-point (statusword: Switch on disabled).
    assert!(
        matches!(error, MotionError::Timeout { waiting_for: "set-point acknowledge", statusword } if statusword & 0x4F == 0x40),
        "{error:?}"
    );
    assert!(error.to_string().starts_with("no set-point acknowledge in time (statusword "), "{error}");
}

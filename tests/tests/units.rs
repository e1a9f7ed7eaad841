//! Units of the torque and velocity objects ([`canopen_drive::cia402::Units`]): the CiA 402
//! defaults (‰ of rated torque, position units per second) unchanged, and a drive configured
//! for torques in mA (through 6075h) and velocities in motor rpm (through 608Fh) converting
//! at the object boundary — what the master writes and reads, and what reaches the power stage.

mod common;

use common::profile::*;
use common::*;

use canopen_drive::cia402::registry::PROFILE;
use canopen_drive::cia402::{TorqueUnit, Units, VelocityUnit};
use canopen_drive::hal::Setpoint;
use canopen_drive::od::eds::EdsInfo;
use canopen_drive::od::{DataType, EntryOverride};
use canopen_drive::Duration;

fn torque_bench(torque: TorqueUnit) -> Bench {
    let mut bench = Bench::with_config(|mut config| {
        config.profile.units = Units { torque, ..Units::CIA_402 };
        config
    });
    write(&mut bench, 0x6075, &2000u32.to_le_bytes()); // motor rated current, mA
    write(&mut bench, 0x6087, &1_000_000u32.to_le_bytes()); // a fast slope
    enable(&mut bench, 4);
    bench
}

fn velocity_bench(velocity: VelocityUnit) -> Bench {
    let mut bench = Bench::with_config(|mut config| {
        config.profile.units = Units { velocity, ..Units::CIA_402 };
        config
    });
    // 4000 increments per revolution; gear 3:1 and a feed of 360 per turn change positions only.
    write_sub(&mut bench, 0x608F, 1, &4000u32.to_le_bytes());
    write_sub(&mut bench, 0x6091, 1, &3u32.to_le_bytes());
    write_sub(&mut bench, 0x6092, 1, &360u32.to_le_bytes());
    bench
}

#[test]
fn cia_default_torque_is_per_mille_whatever_the_rated_current() {
    let mut bench = torque_bench(TorqueUnit::PerMilleOfRated);
    write(&mut bench, 0x6071, &500i16.to_le_bytes());
    bench.advance(Duration::from_millis(50));
    assert_eq!(od_i16(&mut bench, 0x6074), 500);
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(500));
}

#[test]
fn torque_in_milliamps_converts_through_the_rated_current() {
    let mut bench = torque_bench(TorqueUnit::MilliAmps);
    // 1000 mA at 2000 mA rated: 500 ‰ to the power stage; 6074h reads it back in mA.
    write(&mut bench, 0x6071, &1000i16.to_le_bytes());
    bench.advance(Duration::from_millis(50));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(500));
    assert_eq!(od_i16(&mut bench, 0x6074), 1000);
    // The actual torque and current (the motor's ‰) read in mA too: twice the ‰ value.
    let sample = node(&mut bench).motor.sample().torque;
    bench.advance(Duration::from_millis(1));
    let actual = i32::from(od_i16(&mut bench, 0x6077));
    assert!((actual - 2 * i32::from(sample)).abs() <= 40, "6077h {actual} mA, motor {sample} ‰");
    assert_eq!(od_i16(&mut bench, 0x6078), od_i16(&mut bench, 0x6077));
    // The limits stay in ‰: 6072h = 300 ‰ caps a 1000 mA target at 300 ‰ = 600 mA.
    write(&mut bench, 0x6072, &300u16.to_le_bytes());
    bench.advance(Duration::from_millis(20));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(300));
    assert_eq!(od_i16(&mut bench, 0x6074), 600);
    // Target reached (bit 10) compares in the same unit.
    write(&mut bench, 0x6072, &3000u16.to_le_bytes());
    write(&mut bench, 0x6071, &(-700i16).to_le_bytes());
    bench.advance(Duration::from_millis(20));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(-350));
    assert_ne!(sw(&mut bench) & 0x0400, 0);
}

/// The torque values as INTEGER32 (drives with torques in mA, e.g. the Harmonic Drive
/// actuators): an entry override widens them into the 4 bytes the table reserves.
static WIDE_TORQUES: [EntryOverride; 5] = [
    EntryOverride::of(&PROFILE, 0x6071, 0).data_type(DataType::Integer32),
    EntryOverride::of(&PROFILE, 0x6074, 0).data_type(DataType::Integer32),
    EntryOverride::of(&PROFILE, 0x6077, 0).data_type(DataType::Integer32),
    EntryOverride::of(&PROFILE, 0x6078, 0).data_type(DataType::Integer32),
    EntryOverride::of(&PROFILE, 0x60B2, 0).data_type(DataType::Integer32),
];

#[test]
fn torque_objects_widened_to_integer32_carry_values_beyond_16_bits() {
    let mut bench = Bench::with_config(|mut config| {
        config.profile.units = Units { torque: TorqueUnit::MilliAmps, ..Units::CIA_402 };
        config.entry_overrides = &WIDE_TORQUES;
        config
    });
    write(&mut bench, 0x6075, &100_000u32.to_le_bytes()); // 100 A rated
    write(&mut bench, 0x6087, &1_000_000u32.to_le_bytes());
    enable(&mut bench, 4);
    // 40 A = 400 ‰: a value INTEGER16 cannot hold, written and read as four bytes.
    write(&mut bench, 0x6071, &40_000i32.to_le_bytes());
    bench.advance(Duration::from_millis(50));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(400));
    assert_eq!(read_i32(&mut bench, 0x6071), 40_000);
    assert_eq!(read_i32(&mut bench, 0x6074), 40_000);
    let sample = node(&mut bench).motor.sample().torque;
    bench.advance(Duration::from_millis(1));
    let actual = read_i32(&mut bench, 0x6077);
    assert!((actual - 100 * i32::from(sample)).abs() <= 2000, "6077h {actual} mA, motor {sample} ‰");
    assert_eq!(read_i32(&mut bench, 0x6078), actual);
    let r = bench.sdo1(&req(0x40, 0x6077, 0, [0; 4]));
    assert_eq!(r[0], 0x43, "a four-byte upload");
    write(&mut bench, 0x6071, &(-40_000i32).to_le_bytes());
    bench.advance(Duration::from_millis(50));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(-400));
    assert_eq!(read_i32(&mut bench, 0x6074), -40_000);
    // Two bytes are now too few (0607 0013h); the limits still hold in ‰ (6072h = 300 ‰).
    let r = bench.sdo1(&req(0x2B, 0x6071, 0, [0x10, 0x27, 0, 0]));
    assert_eq!(r, abort(0x6071, 0, 0x0607_0013));
    write(&mut bench, 0x6072, &300u16.to_le_bytes());
    bench.advance(Duration::from_millis(20));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(-300));
    assert_eq!(read_i32(&mut bench, 0x6074), -30_000);
    // PDO mapping and the EDS see 32 bits.
    write_sub(&mut bench, 0x1800, 1, &0xC000_0185u32.to_le_bytes());
    write_sub(&mut bench, 0x1A00, 0, &[0]);
    let r = bench.sdo1(&req(0x23, 0x1A00, 1, 0x6077_0010u32.to_le_bytes()));
    assert_eq!(r, abort(0x1A00, 1, 0x0604_0041));
    write_sub(&mut bench, 0x1A00, 1, &0x6077_0020u32.to_le_bytes());
    let mut eds = String::new();
    node(&mut bench).drive.write_eds(&EdsInfo::default(), &mut eds).unwrap();
    let section = &eds[eds.find("\n[6071]\n").unwrap()..];
    assert!(section[..section[1..].find("\n[").unwrap()].contains("DataType=0x0004\n"), "{section}");
}

#[test]
fn torque_in_milliamps_without_a_rated_current_commands_nothing() {
    let mut bench = torque_bench(TorqueUnit::MilliAmps);
    write(&mut bench, 0x6075, &0u32.to_le_bytes());
    write(&mut bench, 0x6071, &1000i16.to_le_bytes());
    bench.advance(Duration::from_millis(50));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Torque(0));
}

#[test]
fn cia_default_velocity_is_position_units_per_second() {
    let mut bench = velocity_bench(VelocityUnit::PositionUnitsPerSecond);
    enable_pv(&mut bench);
    // 360 user units per output turn, 3 motor turns per output turn: 1 user unit/s = 100/3
    // increments/s; 60 → 2000 increments/s.
    write(&mut bench, 0x60FF, &60i32.to_le_bytes());
    bench.advance(Duration::from_millis(500));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Velocity(2000));
    assert_eq!(od_i32(&mut bench, 0x606B), 60);
}

#[test]
fn velocity_in_rpm_converts_through_the_encoder_resolution() {
    let mut bench = velocity_bench(VelocityUnit::MotorRpm);
    // Accelerations in rpm/s: 600 rpm/s = 40 000 increments/s².
    write(&mut bench, 0x6083, &600u32.to_le_bytes());
    enable_pv(&mut bench);
    // 60 rpm at 4000 increments per revolution: 4000 increments/s (the gear does not enter).
    write(&mut bench, 0x60FF, &60i32.to_le_bytes());
    bench.advance(Duration::from_millis(50));
    // After 50 ms at 600 rpm/s: 30 rpm = 2000 increments/s.
    let Setpoint::Velocity(ramping) = node(&mut bench).demand.setpoint else { panic!() };
    assert!((1900..=2100).contains(&ramping), "{ramping}");
    bench.advance(Duration::from_millis(500));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Velocity(4000));
    assert_eq!(od_i32(&mut bench, 0x606B), 60);
    bench.advance(Duration::from_millis(500));
    let actual = od_i32(&mut bench, 0x606C);
    assert!((58..=62).contains(&actual), "606Ch {actual} rpm");
    // Positions keep the factor group: 6064h is in user units (360 per output turn).
    let increments = od_i32(&mut bench, 0x6063);
    let user = od_i32(&mut bench, 0x6064);
    assert!((i64::from(user) - i64::from(increments) * 360 / 12_000).abs() <= 1);
    // The velocity limit 607Fh is in rpm too: 30 rpm caps the demand at 2000 increments/s.
    write(&mut bench, 0x607F, &30u32.to_le_bytes());
    bench.advance(Duration::from_millis(500));
    assert_eq!(node(&mut bench).demand.setpoint, Setpoint::Velocity(2000));
}

#[test]
fn profile_position_speeds_in_rpm() {
    let mut bench = velocity_bench(VelocityUnit::MotorRpm);
    write_sub(&mut bench, 0x6091, 1, &1u32.to_le_bytes());
    write_sub(&mut bench, 0x6092, 1, &4000u32.to_le_bytes()); // positions in increments
    write(&mut bench, 0x6081, &120u32.to_le_bytes()); // 120 rpm = 8000 increments/s
    write(&mut bench, 0x6083, &6000u32.to_le_bytes()); // 400 000 increments/s²
    write(&mut bench, 0x6084, &6000u32.to_le_bytes());
    enable(&mut bench, 1);
    write(&mut bench, 0x607A, &40_000i32.to_le_bytes());
    cw(&mut bench, 0x001F, 1);
    cw(&mut bench, 0x000F, 200);
    // Cruising at the profile velocity: 120 rpm in 606Bh, 8000 increments/s of feed-forward.
    assert_eq!(od_i32(&mut bench, 0x606B), 120);
    let feed_forward = node(&mut bench).demand.feed_forward.velocity;
    assert!((7990..=8000).contains(&feed_forward), "{feed_forward}");
}

#[test]
fn the_maximum_motor_speed_may_be_in_the_velocity_unit() {
    use canopen_drive::cia402::MotorSpeedUnit;
    // pv at 2000 increments/s (608Fh 1:1: a position unit is an increment, one per revolution).
    let run = |motor_speed, max_motor_speed: u32| {
        let mut bench = Bench::with_config(|mut config| {
            config.profile.units = Units { motor_speed, ..Units::CIA_402 };
            config
        });
        write(&mut bench, 0x6080, &max_motor_speed.to_le_bytes());
        write(&mut bench, 0x6083, &1_000_000u32.to_le_bytes());
        enable(&mut bench, 3);
        write(&mut bench, 0x60FF, &2000i32.to_le_bytes());
        bench.advance(Duration::from_millis(100));
        od_i32(&mut bench, 0x606B)
    };
    // CiA 402: 3000 rpm of a motor with one increment per revolution is 50 increments/s.
    assert_eq!(run(MotorSpeedUnit::Rpm, 3000), 50);
    // In the velocity unit: 3000 increments/s, no limit here; 1000 is one.
    assert_eq!(run(MotorSpeedUnit::VelocityUnit, 3000), 2000);
    assert_eq!(run(MotorSpeedUnit::VelocityUnit, 1000), 1000);
}

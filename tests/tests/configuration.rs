//! Configuration knobs for documented departures from CiA 301/402 (DESIGN invariant 6): each
//! one is off by default, and each one changes only what it says. One test per knob, observed
//! on the bus (abort codes, NMT states in heartbeats, statusword values).

mod common;

use canopen_drive::cia402::fsa::State;
use canopen_drive::cia402::registry::PROFILE;
use canopen_drive::cia402::StatusFlag;
use canopen_drive::comm::error_control::ErrorBehaviour;
use canopen_drive::comm::NmtState;
use canopen_drive::od::eds::EdsInfo;
use canopen_drive::od::standard::COMMUNICATION;
use canopen_drive::od::{
    layout, Access, ConfigError, DataType, DefaultOverride, DefaultValue, EntryOverride, Object, PdoMapping,
    Var, WriteRule,
};
use canopen_drive::{CanFrame, Config, Drive, Duration};
use common::profile::*;
use common::*;

const CANNOT_IN_THIS_STATE: u32 = 0x0800_0022;
const INVALID_VALUE: u32 = 0x0609_0030;

fn nmt(bench: &mut Bench, command: u8) {
    bench.send(frame(0x000, &[command, NODE]));
    bench.advance(Duration::from_millis(5));
}

#[test]
fn firmware_defaults_of_standard_entries_hold_at_power_on_and_after_a_reset() {
    static OVERRIDES: [DefaultOverride; 2] = [
        DefaultOverride { index: 0x6085, sub: 0, value: DefaultValue::Unsigned(51_200) },
        DefaultOverride { index: 0x6099, sub: 1, value: DefaultValue::Unsigned(0) },
    ];
    let mut bench = Bench::with_config(|c| Config { default_overrides: &OVERRIDES, ..c });
    assert_eq!(read_i32(&mut bench, 0x6085), 51_200);
    let r = bench.sdo1(&req(0x40, 0x6099, 1, [0; 4]));
    assert_eq!(r, req(0x43, 0x6099, 1, [0; 4]));
    write(&mut bench, 0x6085, &1000u32.to_le_bytes());
    nmt(&mut bench, 0x81); // reset node: the application area back to its defaults
    assert_eq!(read_i32(&mut bench, 0x6085), 51_200);

    // Without the override, the crate's default.
    let mut standard = Bench::new();
    assert_ne!(read_i32(&mut standard, 0x6085), 51_200);
}

/// The EDS section of `index`/`sub` (e.g. `[6071]` or `[60E3sub0]`) of `drive`.
fn eds_section(drive: &Drive<impl canopen_drive::od::ObjectHooks>, header: &str) -> String {
    let mut eds = String::new();
    drive.write_eds(&EdsInfo::default(), &mut eds).unwrap();
    let start = eds.find(&format!("\n[{header}]\n")).unwrap_or_else(|| panic!("no [{header}]"));
    let rest = &eds[start + 1..];
    let end = rest[1..].find("\n[").map_or(rest.len(), |e| e + 1);
    rest[..end].to_string()
}

#[test]
fn standard_entries_may_be_described_as_the_device_documents() {
    static DESCRIPTIONS: [EntryOverride; 4] = [
        EntryOverride::of(&PROFILE, 0x6071, 0).data_type(DataType::Unsigned16),
        EntryOverride::of(&PROFILE, 0x6084, 0).access(Access::ReadOnly),
        EntryOverride::of(&PROFILE, 0x6077, 0).pdo(PdoMapping::No),
        EntryOverride::of(&PROFILE, 0x6081, 0).data_type(DataType::Integer32).limits_signed(0, 1_000_000),
    ];
    let mut bench = Bench::with_config(|c| Config { entry_overrides: &DESCRIPTIONS, ..c });

    // A read-only override: writes are refused with "attempt to write a read only object".
    let before = read_i32(&mut bench, 0x6084);
    let r = bench.sdo1(&req(0x23, 0x6084, 0, 1000u32.to_le_bytes()));
    assert_eq!(r, abort(0x6084, 0, 0x0601_0002));
    assert_eq!(read_i32(&mut bench, 0x6084), before, "unchanged, still readable");

    // INTEGER16 retyped UNSIGNED16: the same two bytes, now unsigned on the bus and in the EDS;
    // the core still reads its signed target torque.
    write(&mut bench, 0x6071, &(-1i16).to_le_bytes());
    let r = bench.sdo1(&req(0x40, 0x6071, 0, [0; 4]));
    assert_eq!(r, req(0x4B, 0x6071, 0, [0xFF, 0xFF, 0, 0]));
    assert_eq!(u16::from_le_bytes([r[4], r[5]]), 65_535);
    assert_eq!(bench.drive().od().get::<i16>(0x6071, 0), Ok(-1));
    let section = eds_section(bench.drive(), "6071");
    assert!(section.contains("DataType=0x0006\n"), "{section}");

    // The overridden limits hold for SDO writes, and the EDS states them with the new type.
    let r = bench.sdo1(&req(0x23, 0x6081, 0, 1_000_001u32.to_le_bytes()));
    assert_eq!(r, abort(0x6081, 0, 0x0609_0031));
    let r = bench.sdo1(&req(0x23, 0x6081, 0, (-1i32).to_le_bytes()));
    assert_eq!(r, abort(0x6081, 0, 0x0609_0032));
    write(&mut bench, 0x6081, &5000i32.to_le_bytes());
    let section = eds_section(bench.drive(), "6081");
    assert!(section.contains("DataType=0x0004\nAccessType=rww\n"), "{section}");
    assert!(section.contains("LowLimit=0\nHighLimit=1000000\n"), "{section}");
    assert!(eds_section(bench.drive(), "6084").contains("AccessType=ro\n"));

    // PDO mapping sees the override: 6077h is no longer TPDO-mappable.
    let r = bench.sdo1(&req(0x23, 0x1800, 1, 0xC000_0185u32.to_le_bytes()));
    assert_eq!(r, req(0x60, 0x1800, 1, [0; 4]));
    let r = bench.sdo1(&req(0x2F, 0x1A00, 0, [0; 4]));
    assert_eq!(r, req(0x60, 0x1A00, 0, [0; 4]));
    let r = bench.sdo1(&req(0x23, 0x1A00, 1, 0x6077_0010u32.to_le_bytes()));
    assert_eq!(r, abort(0x1A00, 1, 0x0604_0041));

    // Without overrides: CiA 402's descriptions.
    let mut standard = Bench::new();
    write(&mut standard, 0x6084, &1000u32.to_le_bytes());
    write(&mut standard, 0x6081, &2_000_000u32.to_le_bytes());
    assert!(eds_section(standard.drive(), "6071").contains("DataType=0x0003\n"));
    assert!(eds_section(standard.drive(), "6081").contains("DataType=0x0007\nAccessType=rww\n"));
    assert!(eds_section(standard.drive(), "6084").contains("AccessType=rww\n"));
    write_sub(&mut standard, 0x1800, 1, &0xC000_0185u32.to_le_bytes());
    write_sub(&mut standard, 0x1A00, 0, &[0]);
    write_sub(&mut standard, 0x1A00, 1, &0x6077_0010u32.to_le_bytes());
}

#[test]
fn an_option_code_described_as_mappable_takes_effect_when_an_rpdo_writes_it() {
    // The tick keeps the option codes between writes: an RPDO's write must reach it as an
    // SDO's does.
    static DESCRIPTIONS: [EntryOverride; 1] = [EntryOverride::of(&PROFILE, 0x605A, 0).pdo(PdoMapping::Rpdo)];
    let mut bench = Bench::with_config(|c| Config { entry_overrides: &DESCRIPTIONS, ..c });
    write_sub(&mut bench, 0x1400, 1, &0x8000_0205u32.to_le_bytes());
    write_sub(&mut bench, 0x1600, 0, &[0]);
    write_sub(&mut bench, 0x1600, 1, &0x605A_0010u32.to_le_bytes());
    write_sub(&mut bench, 0x1600, 0, &[1]);
    write_sub(&mut bench, 0x1400, 1, &0x0000_0205u32.to_le_bytes());
    nmt(&mut bench, 0x01);
    enable_pv(&mut bench);
    bench.send(frame(0x205, &6i16.to_le_bytes()));
    bench.advance(Duration::from_millis(2));
    assert_eq!(bench.drive().od().get::<i16>(0x605A, 0), Ok(6));
    cw(&mut bench, 0x000B, 5);
    assert!(is(&mut bench, QSA), "605Ah = 6 by RPDO: the quick stop stays in Quick stop active");

    // The same quick stop with 605Ah = 2, the default, ends in Switch on disabled.
    let mut standard = Bench::with_config(|c| Config { entry_overrides: &DESCRIPTIONS, ..c });
    enable_pv(&mut standard);
    cw(&mut standard, 0x000B, 5);
    assert!(is(&mut standard, SOD));
}

#[test]
fn a_limit_an_rpdo_writes_beside_a_set_point_takes_effect_at_the_next_tick() {
    // The tick keeps the limits it converted while no configuration was written: an RPDO that
    // maps only set-points leaves them, one that maps a limit must reach the tick as an SDO
    // download does.
    let mut bench = Bench::new();
    let map = |bench: &mut Bench, pdo: u16, cob: u32, entries: &[u32]| {
        write_sub(bench, 0x1400 + pdo, 1, &(0x8000_0000 | cob).to_le_bytes());
        write_sub(bench, 0x1600 + pdo, 0, &[0]);
        for (sub, entry) in (1..).zip(entries) {
            write_sub(bench, 0x1600 + pdo, sub, &entry.to_le_bytes());
        }
        write_sub(bench, 0x1600 + pdo, 0, &[entries.len() as u8]);
        write_sub(bench, 0x1400 + pdo, 1, &cob.to_le_bytes());
    };
    let target_only = 0x200 + u16::from(NODE);
    let with_limit = 0x300 + u16::from(NODE);
    map(&mut bench, 0, u32::from(target_only), &[0x60FF_0020]);
    map(&mut bench, 1, u32::from(with_limit), &[0x60FF_0020, 0x607F_0020]);
    for ramp in [0x6083, 0x6084, 0x60C5, 0x60C6] {
        write(&mut bench, ramp, &10_000_000u32.to_le_bytes());
    }
    nmt(&mut bench, 0x01);
    enable_pv(&mut bench);
    let demand_after = |bench: &mut Bench, id: u16, data: &[u8]| {
        bench.send(frame(id, data));
        bench.advance(Duration::from_millis(20));
        od_i32(bench, 0x606B)
    };
    assert_eq!(demand_after(&mut bench, target_only, &50_000i32.to_le_bytes()), 50_000);
    let mut both = [0u8; 8];
    both[..4].copy_from_slice(&50_000i32.to_le_bytes());
    both[4..].copy_from_slice(&20_000u32.to_le_bytes());
    assert_eq!(demand_after(&mut bench, with_limit, &both), 20_000, "607Fh = 20 000 by RPDO limits pv");
    assert_eq!(demand_after(&mut bench, target_only, &60_000i32.to_le_bytes()), 20_000);
    both[4..].copy_from_slice(&u32::MAX.to_le_bytes());
    assert_eq!(demand_after(&mut bench, with_limit, &both), 50_000, "607Fh raised by RPDO");
}

#[test]
fn a_description_override_must_keep_the_entrys_size() {
    // 6072h reserves no wider storage; 6071h does (4 bytes), but not for another signedness
    // or beyond its reserve.
    static WIDER: [EntryOverride; 1] =
        [EntryOverride::of(&PROFILE, 0x6072, 0).data_type(DataType::Unsigned32)];
    static UNSIGNED_WIDER: [EntryOverride; 1] =
        [EntryOverride::of(&PROFILE, 0x6071, 0).data_type(DataType::Unsigned32)];
    static BEYOND_RESERVE: [EntryOverride; 1] =
        [EntryOverride::of(&PROFILE, 0x6071, 0).data_type(DataType::Integer64)];
    static CONSTANT: [EntryOverride; 1] = [EntryOverride::of(&PROFILE, 0x6084, 0).access(Access::Const)];
    static NARROWER: [EntryOverride; 1] =
        [EntryOverride::new(0x6081, 0, Var::new("Profile velocity", DataType::Unsigned16))];
    let refused = [
        (&WIDER, 0x6072),
        (&UNSIGNED_WIDER, 0x6071),
        (&BEYOND_RESERVE, 0x6071),
        (&CONSTANT, 0x6084),
        (&NARROWER, 0x6081),
    ];
    for (overrides, index) in refused {
        let config = Config { entry_overrides: overrides, ..Config::new(NODE) };
        assert_eq!(Drive::new(config).err(), Some(ConfigError::EntrySize { index, sub: 0 }));
    }
    static MISSING: [EntryOverride; 1] = [EntryOverride::of(&PROFILE, 0x6071, 1)];
    let config = Config { entry_overrides: &MISSING, ..Config::new(NODE) };
    assert_eq!(Drive::new(config).err(), Some(ConfigError::NoSuchEntry { index: 0x6071, sub: 1 }));
    assert!(Config::new(NODE).entry_overrides.is_empty());
    assert!(Config::new(NODE).extra_profile_objects.is_empty());
}

#[test]
fn a_smaller_count_of_a_standard_record_or_array_hides_the_entries_above_it() {
    static DESCRIPTIONS: [EntryOverride; 2] = [
        EntryOverride::of(&COMMUNICATION, 0x1016, 0).default(DefaultValue::Unsigned(1)),
        EntryOverride::of(&COMMUNICATION, 0x1018, 0).default(DefaultValue::Unsigned(3)),
    ];
    let mut bench = Bench::with_config(|c| Config { entry_overrides: &DESCRIPTIONS, ..c });
    assert_eq!(bench.sdo1(&req(0x40, 0x1018, 0, [0; 4])), req(0x4F, 0x1018, 0, [3, 0, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x40, 0x1018, 4, [0; 4])), abort(0x1018, 4, 0x0609_0011));
    assert_eq!(bench.sdo1(&req(0x40, 0x1016, 0, [0; 4])), req(0x4F, 0x1016, 0, [1, 0, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x23, 0x1016, 2, [0; 4])), abort(0x1016, 2, 0x0609_0011));
    write_sub(&mut bench, 0x1016, 1, &0x0010_0064u32.to_le_bytes());
    let identity = eds_section_of(bench.drive(), "1018", "1018sub4");
    assert!(identity.contains("SubNumber=0x4\n"), "{identity}");
    assert!(!eds_contains(bench.drive(), "[1018sub4]") && !eds_contains(bench.drive(), "[1016sub2]"));
    assert!(eds_section(bench.drive(), "1016").contains("SubNumber=0x2\n"));

    // CiA 301's defaults: four consumer entries, the serial number.
    let mut standard = Bench::new();
    assert_eq!(standard.sdo1(&req(0x40, 0x1018, 4, [0; 4])), req(0x43, 0x1018, 4, [0; 4]));
    write_sub(&mut standard, 0x1016, 4, &0u32.to_le_bytes());
    assert!(eds_contains(standard.drive(), "[1018sub4]"));
}

fn eds_contains(drive: &Drive<impl canopen_drive::od::ObjectHooks>, text: &str) -> bool {
    let mut eds = String::new();
    drive.write_eds(&EdsInfo::default(), &mut eds).unwrap();
    eds.contains(text)
}

/// The EDS from section `[from]` up to section `[to]`.
fn eds_section_of(drive: &Drive<impl canopen_drive::od::ObjectHooks>, from: &str, to: &str) -> String {
    let mut eds = String::new();
    drive.write_eds(&EdsInfo::default(), &mut eds).unwrap();
    let start = eds.find(&format!("[{from}]")).unwrap();
    let end = eds[start..].find(&format!("[{to}]")).map_or(eds.len(), |e| start + e);
    eds[start..end].to_string()
}

#[test]
fn the_profile_area_may_hold_objects_after_the_crates() {
    static VERSION: [Object; 1] = layout([Object::var(
        0x67FE,
        "Version number",
        Var::new("Version number", DataType::Unsigned32)
            .access(Access::Const)
            .default(DefaultValue::Unsigned(3)),
    )]);
    let mut bench = Bench::with_config(|c| Config { extra_profile_objects: &VERSION, ..c });
    assert_eq!(bench.sdo1(&req(0x40, 0x67FE, 0, [0; 4])), req(0x43, 0x67FE, 0, [3, 0, 0, 0]));
    assert_eq!(bench.sdo1(&req(0x23, 0x67FE, 0, [4, 0, 0, 0])), abort(0x67FE, 0, 0x0601_0002));
    assert!(eds_section(bench.drive(), "67FE").contains("AccessType=const\n"));
    // Not in the standard configuration (CiA 402-2 v3.0 has no 67FEh).
    let mut standard = Bench::new();
    assert_eq!(standard.sdo1(&req(0x40, 0x67FE, 0, [0; 4])), abort(0x67FE, 0, 0x0602_0000));
    // Below the crate's profile objects: refused (the tables cover ascending index ranges).
    static INSIDE: [Object; 1] =
        layout([Object::var(0x6500, "Inside", Var::new("Inside", DataType::Unsigned8))]);
    let config = Config { extra_profile_objects: &INSIDE, ..Config::new(NODE) };
    assert_eq!(Drive::new(config).err(), Some(ConfigError::NotSorted { index: 0x6500 }));
}

#[test]
fn nmt_stopped_faults_an_enabled_axis_only_when_configured() {
    // CiA 402: 6007h = 0 (no action) leaves the axis enabled in Stopped.
    let mut standard = Bench::new();
    write(&mut standard, 0x6007, &0i16.to_le_bytes());
    enable_pv(&mut standard);
    nmt(&mut standard, 0x02);
    assert!(matches!(standard.drive().state(), State::OperationEnabled { .. }));

    let mut bench = Bench::with_config(|mut c| {
        c.profile.nmt_stopped_fault = true;
        c
    });
    write(&mut bench, 0x6007, &0i16.to_le_bytes());
    enable_pv(&mut bench);
    nmt(&mut bench, 0x02);
    assert_eq!(bench.drive().nmt_state(), NmtState::Stopped);
    bench.advance(Duration::from_millis(20));
    assert_eq!(bench.drive().state(), State::Fault);
    nmt(&mut bench, 0x80);
    assert_eq!(od_u16(&mut bench, 0x603F), 0x8100);

    // An axis that is not enabled is not faulted.
    let mut idle = Bench::with_config(|mut c| {
        c.profile.nmt_stopped_fault = true;
        c
    });
    cw(&mut idle, 0x0006, 2);
    nmt(&mut idle, 0x02);
    bench.advance(Duration::from_millis(20));
    assert_eq!(idle.drive().state(), State::ReadyToSwitchOn);
}

#[test]
fn statusword_bits_14_and_15_show_what_the_configuration_says() {
    fn run(bench: &mut Bench) -> (u16, u16) {
        enable_pv(bench);
        write(bench, 0x6083, &1_000_000u32.to_le_bytes());
        write(bench, 0x6084, &1_000_000u32.to_le_bytes());
        write(bench, 0x60FF, &(-20_000i32).to_le_bytes());
        bench.advance(Duration::from_millis(300));
        let moving = sw(bench);
        write(bench, 0x60FF, &0i32.to_le_bytes());
        bench.advance(Duration::from_millis(500));
        (moving, sw(bench))
    }
    let (moving, resting) = run(&mut Bench::new());
    assert_eq!(moving & 0xC000, 0, "{moving:04X}: manufacturer bits are 0 by default");
    assert_eq!(resting & 0xC000, 0);

    let mut bench = Bench::with_config(|mut c| {
        c.profile.statusword_bit_14 = StatusFlag::Moving;
        c.profile.statusword_bit_15 = StatusFlag::Negative;
        c
    });
    let (moving, resting) = run(&mut bench);
    assert_eq!(moving & 0xC000, 0xC000, "{moving:04X}");
    assert_eq!(resting & 0xC000, 0, "{resting:04X}");

    // A quick stop ramping down is a transition.
    let mut bench = Bench::with_config(|mut c| {
        c.profile.statusword_bit_14 = StatusFlag::Transition;
        c
    });
    enable_pv(&mut bench);
    write(&mut bench, 0x6083, &1_000_000u32.to_le_bytes());
    write(&mut bench, 0x6085, &20_000u32.to_le_bytes());
    write(&mut bench, 0x60FF, &20_000i32.to_le_bytes());
    bench.advance(Duration::from_millis(300));
    assert_eq!(sw(&mut bench) & 0x4000, 0);
    write(&mut bench, 0x605A, &6i16.to_le_bytes());
    cw(&mut bench, 0x000B, 50);
    assert_eq!(sw(&mut bench) & 0x4000, 0x4000, "ramping");
    bench.advance(Duration::from_millis(2000));
    assert!(is(&mut bench, QSA));
    assert_eq!(sw(&mut bench) & 0x4000, 0, "at rest");
}

#[test]
fn a_parameter_may_be_writable_only_in_switch_on_disabled() {
    static OBJECTS: [Object; 1] = layout([Object::var(
        0x2100,
        "Guarded",
        Var::new("Guarded", DataType::Unsigned32).access(Access::ReadWrite).rule(WriteRule::SwitchOnDisabled),
    )]);
    let mut bench = Bench::with_config(|c| Config { manufacturer_objects: &OBJECTS, ..c });
    write(&mut bench, 0x2100, &3u32.to_le_bytes());
    cw(&mut bench, 0x0006, 2);
    let r = bench.sdo1(&req(0x23, 0x2100, 0, [1, 0, 0, 0]));
    assert_eq!(r, abort(0x2100, 0, CANNOT_IN_THIS_STATE), "Ready to switch on");
    cw(&mut bench, 0x000F, 2);
    let r = bench.sdo1(&req(0x23, 0x2100, 0, [1, 0, 0, 0]));
    assert_eq!(r, abort(0x2100, 0, CANNOT_IN_THIS_STATE), "Operation enabled");
    let r = bench.sdo1(&req(0x40, 0x2100, 0, [0; 4]));
    assert_eq!(r, req(0x43, 0x2100, 0, [3, 0, 0, 0]), "always readable");
    cw(&mut bench, 0x0000, 2);
    write(&mut bench, 0x2100, &1u32.to_le_bytes());
}

#[test]
fn a_mode_change_may_be_refused_in_operation_enabled() {
    let mut standard = Bench::new();
    enable_pv(&mut standard);
    write(&mut standard, 0x6060, &[1]);

    let mut bench = Bench::with_config(|mut c| {
        c.profile.mode_change_in_operation = false;
        c
    });
    enable_pv(&mut bench);
    let r = bench.sdo1(&req(0x2F, 0x6060, 0, [1, 0, 0, 0]));
    assert_eq!(r, abort(0x6060, 0, CANNOT_IN_THIS_STATE));
    write(&mut bench, 0x6060, &[3]); // the same mode again is no change
    cw(&mut bench, 0x0007, 5);
    write(&mut bench, 0x6060, &[1]);
    bench.advance(Duration::from_millis(5));
    assert_eq!(bench.drive().od().get::<i8>(0x6061, 0), Ok(1));
}

#[test]
fn error_behaviour_values_may_mean_what_the_device_documents() {
    // The device's table: 0 = Stopped, 1 = no change (2 does not exist).
    static VALUES: [(u8, ErrorBehaviour); 2] = [(0, ErrorBehaviour::Stopped), (1, ErrorBehaviour::NoChange)];
    for (values, after) in
        [(&ErrorBehaviour::CIA_301[..], NmtState::PreOperational), (&VALUES[..], NmtState::Stopped)]
    {
        let mut bench = Bench::with_config(|c| Config { error_behaviour_values: values, ..c });
        // Supervise node 0x10's heartbeat at 100 ms; 1029h sub 1 stays 0.
        write_sub(&mut bench, 0x1016, 1, &0x0010_0064u32.to_le_bytes());
        nmt(&mut bench, 0x01);
        bench.send(frame(0x710, &[0x05]));
        bench.advance(Duration::from_millis(200));
        assert_eq!(bench.drive().nmt_state(), after);
    }
    let mut bench = Bench::with_config(|c| Config { error_behaviour_values: &VALUES, ..c });
    let r = bench.sdo1(&req(0x2F, 0x1029, 1, [2, 0, 0, 0]));
    assert_eq!(r, abort(0x1029, 1, INVALID_VALUE));
    write_sub(&mut bench, 0x1029, 1, &[1]);
}

#[test]
fn a_zero_following_error_window_may_switch_the_check_off() {
    fn run(zero_off: bool) -> u16 {
        let mut bench = Bench::with_config(|mut c| {
            c.profile.zero_following_error_window_off = zero_off;
            c
        });
        write(&mut bench, 0x6065, &0u32.to_le_bytes());
        write(&mut bench, 0x6066, &0u16.to_le_bytes());
        enable(&mut bench, 1);
        write(&mut bench, 0x607A, &20_000i32.to_le_bytes());
        cw(&mut bench, 0x001F, 2);
        cw(&mut bench, 0x000F, 100);
        sw(&mut bench)
    }
    assert_eq!(run(false) & 0x2000, 0x2000, "CiA 402: a window of 0 is exceeded by any lag");
    assert_eq!(run(true) & 0x2000, 0);
}

// --- Hard-stop homing with the home at the backed-off position -------------------------------

mod hard_stop {
    use super::*;
    use canopen_drive::cia402::hm::{HardStopEntries, HomingConfig, VendorMethod};
    use canopen_drive_sim::motor::{MotorParams, SimMotor};

    /// A device's own layout: threshold, back-off positive, back-off negative in one record.
    const SUBS: [(u8, Var); 4] = [
        (
            0,
            Var::new("Highest sub-index supported", DataType::Unsigned8)
                .access(Access::Const)
                .default(DefaultValue::Unsigned(3)),
        ),
        (
            1,
            Var::new("Threshold", DataType::Unsigned16)
                .access(Access::ReadWrite)
                .default(DefaultValue::Unsigned(300)),
        ),
        (
            2,
            Var::new("Back-off positive", DataType::Unsigned32)
                .access(Access::ReadWrite)
                .default(DefaultValue::Unsigned(300)),
        ),
        (
            3,
            Var::new("Back-off negative", DataType::Unsigned32)
                .access(Access::ReadWrite)
                .default(DefaultValue::Unsigned(500)),
        ),
    ];
    static OBJECTS: [Object; 1] = layout([Object::record(0x2025, "Hard stop", &SUBS)]);
    static METHODS: [(i8, VendorMethod); 4] = [
        (-1, VendorMethod::HardStopLimit { positive: true }),
        (-2, VendorMethod::HardStopLimit { positive: false }),
        (-3, VendorMethod::HardStopRange { positive_first: true }),
        (-4, VendorMethod::HardStopRange { positive_first: false }),
    ];

    fn scene() -> Bench {
        let mut bench = Bench::with_config(|mut c| {
            c.manufacturer_objects = &OBJECTS;
            c.profile.homing = HomingConfig {
                vendor_methods: &METHODS,
                hard_stop_entries: Some(HardStopEntries {
                    threshold: (0x2025, 1),
                    time: None,
                    back_off_positive: (0x2025, 2),
                    back_off_negative: (0x2025, 3),
                }),
                ..HomingConfig::new()
            };
            c
        });
        node(&mut bench).motor = SimMotor::with_params(MotorParams {
            increments_per_revolution: 1000,
            negative_hard_stop: Some(-12_000),
            positive_hard_stop: Some(12_000),
            ..MotorParams::default()
        });
        write_sub(&mut bench, 0x6099, 2, &4000u32.to_le_bytes());
        write(&mut bench, 0x609A, &50_000u32.to_le_bytes());
        enable(&mut bench, 6);
        bench
    }

    /// Runs `method`; returns the encoder count at rest, 6064h there, and 607Dh.
    fn run(bench: &mut Bench, method: i8) -> (i32, i32, (i32, i32)) {
        write(bench, 0x6098, &[method as u8]);
        cw(bench, 0x001F, 0);
        for _ in 0..3000 {
            bench.advance(Duration::from_millis(10));
            if sw(bench) & 0x3400 == 0x1400 {
                break;
            }
        }
        assert_eq!(sw(bench) & 0x3400, 0x1400, "homing completed");
        bench.advance(Duration::from_millis(300));
        let limits = (od_i32_sub(bench, 0x607D, 1), od_i32_sub(bench, 0x607D, 2));
        (od_i32(bench, 0x6063), od_i32(bench, 0x6064), limits)
    }

    fn od_i32_sub(bench: &mut Bench, index: u16, sub: u8) -> i32 {
        bench.drive().od().get::<i32>(index, sub).unwrap()
    }

    #[test]
    fn single_stop_homes_backed_off_and_sets_that_sides_limit() {
        let mut bench = scene();
        let (raw, position, limits) = run(&mut bench, -1);
        assert!((raw - 11_700).abs() <= 10, "backed off 300 from the stop: {raw}");
        assert!(position.abs() <= 10, "home there: {position}");
        assert_eq!(limits, (i32::MIN, 0));

        let mut bench = scene();
        let (raw, position, limits) = run(&mut bench, -2);
        assert!((raw + 11_500).abs() <= 10, "backed off 500 from the stop: {raw}");
        assert!(position.abs() <= 10);
        assert_eq!(limits, (0, i32::MAX));
    }

    #[test]
    fn both_stops_set_the_range_and_home_at_the_second() {
        let mut bench = scene();
        let (raw, position, limits) = run(&mut bench, -3);
        assert!((raw + 11_500).abs() <= 10, "home backed off from the negative stop: {raw}");
        assert!(position.abs() <= 10);
        assert_eq!(limits.0, 0);
        assert!((limits.1 - 23_200).abs() <= 10, "{limits:?}");

        let mut bench = scene();
        let (raw, _, limits) = run(&mut bench, -4);
        assert!((raw - 11_700).abs() <= 10, "{raw}");
        assert_eq!(limits.1, 0);
        assert!((limits.0 + 23_200).abs() <= 10, "{limits:?}");
    }
}

// --- A store on command is told to the firmware -----------------------------------------------

#[test]
fn the_firmware_hears_of_a_store_on_command() {
    use canopen_drive::od::{DeviceInfo, ObjectHooks};
    use canopen_drive::storage::{device_signature, Storage};
    use canopen_drive::{Drive, Instant};
    use canopen_drive_sim::flash::SimFlash;

    #[derive(Default)]
    struct Hooks(Vec<u8>);
    impl ObjectHooks for Hooks {
        fn stored(&mut self, sub: u8) {
            self.0.push(sub);
        }
    }
    let storage =
        Storage::new(SimFlash::new(8192, 512, 4), device_signature(&DeviceInfo::servo_drive(), 1)).unwrap();
    let mut drive = Drive::with_storage(Config::new(NODE), Hooks::default(), storage).unwrap();
    drive.poll(Instant::ZERO);
    for (sub, signature) in [(2u8, *b"save"), (1, *b"save"), (1, *b"nope")] {
        drive.on_frame(&frame(SDO_RX, &req(0x23, 0x1010, sub, signature)), Instant::from_millis(1));
    }
    assert_eq!(drive.hooks_mut().0, [2, 1], "only the stores that happened");
}

// --- Midpoint methods searched positive first, and the middle of the home switch ---------------

#[test]
fn midpoints_searched_positive_first_and_of_the_home_switch() {
    use canopen_drive::cia402::hm::{hard_stop_object, HomingConfig, VendorMethod};
    use canopen_drive_sim::motor::{MotorParams, SimMotor, Zone};

    static OBJECTS: [Object; 1] = layout([hard_stop_object(0x2500)]);
    static METHODS: [(i8, VendorMethod); 6] = [
        (-5, VendorMethod::MidpointOfHardStopsPositiveFirst),
        (-7, VendorMethod::MidpointOfLimitSwitchesPositiveFirst),
        (-9, VendorMethod::MidpointOfHomeSwitch { positive: true }),
        (-10, VendorMethod::MidpointOfHomeSwitch { positive: false }),
        (-11, VendorMethod::MidpointOfHomeSwitchHardStop { positive: true }),
        (-12, VendorMethod::MidpointOfHomeSwitchHardStop { positive: false }),
    ];
    // (method, start, expected home); −11/−12 start beyond the switch: they turn at the stop.
    for (method, start, expected) in [
        (-5, 0, 0),
        (-7, 3000, 0),
        (-9, 0, 5000),
        (-9, 5500, 5000),
        (-10, 0, 5000),
        (-11, 7000, 5000),
        (-12, 3000, 5000),
    ] {
        let mut bench = Bench::with_config(|mut c| {
            c.manufacturer_objects = &OBJECTS;
            c.profile.homing = HomingConfig {
                vendor_methods: &METHODS,
                hard_stop_object: Some(0x2500),
                ..HomingConfig::new()
            };
            c
        });
        node(&mut bench).motor = SimMotor::with_params(MotorParams {
            increments_per_revolution: 1000,
            // The hard-stop methods on an axis without limit switches.
            negative_limit_switch: (![-5, -11, -12].contains(&method)).then_some(-10_000),
            positive_limit_switch: (![-5, -11, -12].contains(&method)).then_some(10_000),
            home_switch: Some(Zone::between(4000, 6000)),
            negative_hard_stop: Some(-12_000),
            positive_hard_stop: Some(12_000),
            ..MotorParams::default()
        });
        node(&mut bench).motor.set_position(start);
        write_sub(&mut bench, 0x2500, 1, &300u16.to_le_bytes());
        write_sub(&mut bench, 0x6099, 1, &8000u32.to_le_bytes());
        write_sub(&mut bench, 0x6099, 2, &2000u32.to_le_bytes());
        write(&mut bench, 0x609A, &50_000u32.to_le_bytes());
        enable(&mut bench, 6);
        write(&mut bench, 0x6098, &[method as u8]);
        cw(&mut bench, 0x001F, 20);
        let first_move = od_i32(&mut bench, 0x6063) - start;
        for _ in 0..6000 {
            bench.advance(Duration::from_millis(10));
            if sw(&mut bench) & 0x3400 == 0x1400 {
                break;
            }
        }
        assert_eq!(sw(&mut bench) & 0x3400, 0x1400, "method {method} from {start}");
        bench.advance(Duration::from_millis(300));
        let home = od_i32(&mut bench, 0x6063) - od_i32(&mut bench, 0x6064);
        assert!((home - expected).abs() <= 10, "method {method} from {start}: home {home}");
        if method != -9 || start == 0 {
            assert_eq!(
                first_move > 0,
                !matches!(method, -10 | -12),
                "method {method}: first move {first_move}"
            );
        }
    }
}

// --- Cyclic set-points written by SDO ----------------------------------------------------------

#[test]
fn cyclic_set_points_by_sdo_feed_the_stream_only_when_configured() {
    fn run(sdo_set_points: bool) -> (u16, Vec<canopen_drive::CanFrame>) {
        let mut bench = Bench::with_config(|mut c| {
            c.profile.cyclic.sdo_set_points = sdo_set_points;
            c
        });
        write_sub(&mut bench, 0x60C2, 1, &[10]); // 10 ms
        nmt(&mut bench, 0x01);
        let start = od_i32(&mut bench, 0x6064);
        enable(&mut bench, 8);
        let mut frames = Vec::new();
        for k in 1..=50 {
            write(&mut bench, 0x607A, &(start + 100 * k).to_le_bytes());
            frames.extend(bench.send(frame(0x080, &[])));
            frames.extend(bench.advance(Duration::from_millis(10)));
        }
        (sw(&mut bench), frames)
    }
    let emcy = |frames: &[canopen_drive::CanFrame]| {
        frames
            .iter()
            .any(|f| f.standard_id() == Some(0x85) && embedded_can::Frame::data(f)[..2] == [0x00, 0x87])
    };
    let (status, frames) = run(false);
    assert!(emcy(&frames), "CiA 402: SDO writes are no stream");
    assert_eq!(status & 0x1000, 0);
    let (status, frames) = run(true);
    assert!(!emcy(&frames));
    assert_eq!(status & 0x106F, 0x1027, "Operation enabled, the target used: {status:04X}");
}

#[test]
fn cyclic_cycles_may_start_at_each_set_point_without_sync() {
    use canopen_drive::cia402::cyclic::CycleStart;
    // Set-points by SDO, 10 ms apart, no SYNC at all; 60C2h = 10 ms.
    fn run(cycle_start: CycleStart) -> (i32, i32, Vec<i32>) {
        let mut bench = Bench::with_config(|mut c| {
            c.profile.cyclic.sdo_set_points = true;
            c.profile.cyclic.cycle_start = cycle_start;
            c
        });
        write_sub(&mut bench, 0x60C2, 1, &[10]);
        write(&mut bench, 0x60C5, &u32::MAX.to_le_bytes());
        write(&mut bench, 0x60C6, &u32::MAX.to_le_bytes());
        nmt(&mut bench, 0x01);
        let start = od_i32(&mut bench, 0x6064);
        enable(&mut bench, 8);
        let mut demands = Vec::new();
        for k in 1..=20 {
            write(&mut bench, 0x607A, &(start + 100 * k).to_le_bytes());
            for _ in 0..10 {
                bench.advance(Duration::from_millis(1));
                demands.push(od_i32(&mut bench, 0x6062) - start);
            }
        }
        // The master stops writing: the last set-point holds, no lost stream.
        bench.advance(Duration::from_millis(200));
        (od_i32(&mut bench, 0x6062) - start, i32::from(sw(&mut bench) & 0x6F), demands)
    }
    let (end, state, _) = run(CycleStart::Sync);
    assert_eq!(end, 0, "CiA 402: without SYNC the stream does not advance");
    assert_eq!(state, 0x27);
    let (end, state, demands) = run(CycleStart::SetPoint);
    assert_eq!(state, 0x27, "Operation enabled: no lost stream");
    assert_eq!(end, 2000, "the last set-point, held");
    // Each set-point is reached over 60C2h from its arrival: 10 increments per ms.
    assert_eq!(demands[9], 100);
    assert_eq!(demands[104], 1050, "half-way through the eleventh set-point");
    assert!(demands.windows(2).all(|w| w[1] - w[0] <= 11), "no jumps: {demands:?}");
}

#[test]
fn a_hard_stop_search_may_pass_the_limit_switch() {
    use canopen_drive::cia402::hm::{hard_stop_object, HomingConfig, VendorMethod};
    use canopen_drive_sim::motor::{MotorParams, SimMotor};

    static OBJECTS: [Object; 1] = layout([hard_stop_object(0x2500)]);
    static METHODS: [(i8, VendorMethod); 1] = [(-1, VendorMethod::HardStop { positive: true, index: false })];
    for passes in [false, true] {
        let mut bench = Bench::with_config(|mut c| {
            c.manufacturer_objects = &OBJECTS;
            c.profile.homing = HomingConfig {
                vendor_methods: &METHODS,
                hard_stop_object: Some(0x2500),
                hard_stop_passes_limit_switches: passes,
                ..HomingConfig::new()
            };
            c
        });
        node(&mut bench).motor = SimMotor::with_params(MotorParams {
            increments_per_revolution: 1000,
            positive_limit_switch: Some(10_000),
            positive_hard_stop: Some(12_000),
            ..MotorParams::default()
        });
        write_sub(&mut bench, 0x2500, 1, &300u16.to_le_bytes());
        write_sub(&mut bench, 0x6099, 2, &4000u32.to_le_bytes());
        write(&mut bench, 0x609A, &50_000u32.to_le_bytes());
        enable(&mut bench, 6);
        write(&mut bench, 0x6098, &[0xFF]);
        cw(&mut bench, 0x001F, 0);
        for _ in 0..1000 {
            bench.advance(Duration::from_millis(10));
            if sw(&mut bench) & 0x0400 != 0 {
                break;
            }
        }
        let expected = if passes { 0x1400 } else { 0x2400 };
        assert_eq!(sw(&mut bench) & 0x3400, expected, "passes the limit switch: {passes}");
    }
}

/// Block transfers are optional in CiA 301: a drive documented without them answers both
/// initiations with abort 0x0504_0001; by default they are offered.
#[test]
fn sdo_block_transfer_can_be_left_out() {
    const INVALID_COMMAND: u32 = 0x0504_0001;
    // Block upload initiate of 1008h (cc = 1, 16 segments per block, pst 0); block download
    // initiate of 6081h with the size indicated (4 bytes).
    let upload = req(0xA4, 0x1008, 0, [16, 0, 0, 0]);
    let download = req(0xC6, 0x6081, 0, [4, 0, 0, 0]);

    let mut standard = Bench::new();
    assert_eq!(standard.sdo1(&upload)[0] & 0xE3, 0xC2, "block upload initiated");
    // The master aborts it again (an abort is never answered).
    assert!(standard.send(frame(SDO_RX, &abort(0x1008, 0, 0x0800_0000))).is_empty());
    assert_eq!(standard.sdo1(&download)[0] & 0xE3, 0xA0, "block download initiated");

    let mut without = Bench::with_config(|c| Config { sdo_block_transfer: false, ..c });
    assert_eq!(without.sdo1(&upload), abort(0x1008, 0, INVALID_COMMAND));
    assert_eq!(without.sdo1(&download), abort(0x6081, 0, INVALID_COMMAND));
    // Expedited and segmented transfers are unchanged.
    assert_eq!(without.sdo1(&req(0x40, 0x6081, 0, [0; 4]))[0], 0x43);
}

/// A manual's own error codes: the crate's code is reported as the drive's in the EMCY, 1003h
/// and 603Fh, and cleared as such; without the map the CiA 402 code is reported.
#[test]
fn error_codes_can_be_the_drives_own() {
    use canopen_drive::cia402::ProfileConfig;
    use canopen_drive::hal::HardwareFaults;
    static CODES: [(u16, u16); 1] = [(0x3220, 0xFF00)];
    for (codes, expected) in [(&[][..], 0x3220u16), (&CODES[..], 0xFF00)] {
        let mut bench = Bench::with_config(|c| Config {
            profile: ProfileConfig { error_codes: codes, ..c.profile },
            ..c
        });
        enable_pv(&mut bench);
        node(&mut bench).motor.inject_fault(HardwareFaults::UNDER_VOLTAGE);
        let frames = bench.advance(Duration::from_millis(5));
        let emcy: Vec<_> =
            frames.iter().filter(|f| f.standard_id() == Some(0x80 + u16::from(NODE))).collect();
        assert_eq!(emcy.len(), 1, "{frames:?}");
        assert_eq!(embedded_can::Frame::data(emcy[0])[..2], expected.to_le_bytes());
        assert_eq!(bench.drive().od().get::<u16>(0x603F, 0), Ok(expected));
        assert_eq!(bench.drive().od().get::<u32>(0x1003, 1).map(|e| e as u16), Ok(expected));
        assert_eq!(bench.drive().error_register().bits() & 0x04, 0x04, "voltage bit set");
        // Cause gone, fault reset: the error (under its reported code) is cleared.
        node(&mut bench).motor.clear_faults();
        bench.advance(Duration::from_millis(5));
        cw(&mut bench, 0x0080, 5);
        assert_eq!(bench.drive().error_register().bits() & 0x04, 0, "voltage bit cleared");
    }
}

/// Every frame a drive sends for `requests` (one per millisecond, polled in between).
fn session(drive: &mut Drive, requests: &[CanFrame]) -> Vec<CanFrame> {
    let mut out = Vec::new();
    let mut now = canopen_drive::Instant::from_micros(0);
    drive.poll(now);
    for request in requests {
        drive.on_frame(request, now);
        now = now + Duration::from_millis(1);
        drive.poll(now);
        while let Some(f) = drive.pop_tx() {
            out.push(f);
        }
    }
    out
}

#[test]
fn a_drive_built_in_place_answers_as_one_built_by_value() {
    static OVERRIDES: [DefaultOverride; 1] =
        [DefaultOverride { index: 0x6085, sub: 0, value: DefaultValue::Unsigned(51_200) }];
    let config = || Config { default_overrides: &OVERRIDES, ..Config::new(NODE) };
    let requests = [
        frame(0x000, &[0x01, NODE]),                                   // start
        frame(0x600 + u16::from(NODE), &req(0x40, 0x1000, 0, [0; 4])), // device type
        frame(0x600 + u16::from(NODE), &req(0x40, 0x1018, 1, [0; 4])), // vendor-ID
        frame(0x600 + u16::from(NODE), &req(0x40, 0x6085, 0, [0; 4])), // the override
        frame(0x600 + u16::from(NODE), &req(0x40, 0x1A00, 1, [0; 4])), // a PDO default
        frame(0x600 + u16::from(NODE), &req(0x40, 0x6041, 0, [0; 4])), // statusword
        frame(0x080, &[]),                                             // SYNC
    ];
    let mut by_value = Drive::new(config()).unwrap();
    let mut slot = core::mem::MaybeUninit::<Drive>::uninit();
    let in_place = Drive::build_in(&mut slot, config(), (), ()).unwrap();
    let expected = session(&mut by_value, &requests);
    assert_eq!(session(in_place, &requests), expected);
    // Boot-up, five SDO answers, the two SYNC TPDOs: the session is not empty.
    assert!(expected.len() >= 8, "{expected:?}");
    assert_eq!(sdo_data(&expected)[2][4..], 51_200u32.to_le_bytes());

    // The same refusals.
    let mut slot = core::mem::MaybeUninit::<Drive>::uninit();
    let bad_node = Drive::build_in(&mut slot, Config::new(0), (), ());
    assert!(matches!(bad_node, Err(ConfigError::InvalidNodeId)));
    static BAD: [DefaultOverride; 1] =
        [DefaultOverride { index: 0x6085, sub: 7, value: DefaultValue::Unsigned(1) }];
    let mut slot = core::mem::MaybeUninit::<Drive>::uninit();
    let bad_override =
        Drive::build_in(&mut slot, Config { default_overrides: &BAD, ..Config::new(NODE) }, (), ());
    assert!(matches!(bad_override, Err(ConfigError::NoSuchEntry { index: 0x6085, sub: 7 })));
}

fn emcys(frames: &[CanFrame]) -> Vec<Vec<u8>> {
    frames
        .iter()
        .filter(|f| f.standard_id() == Some(0x80 + u16::from(NODE)))
        .map(|f| embedded_can::Frame::data(f).to_vec())
        .collect()
}

#[test]
fn travel_limits_can_raise_the_drives_emcy() {
    use canopen_drive::hal::DigitalInputs;
    // Standard: the limit switch is an input (60FDh), no EMCY.
    let mut standard = Bench::new();
    node(&mut standard).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    assert_eq!(emcys(&standard.advance(Duration::from_millis(5))), Vec::<Vec<u8>>::new());
    assert_eq!(od_u32(&mut standard, 0x60FD) & 0b11, 0b10);

    let mut bench = Bench::with_config(|c| Config {
        profile: canopen_drive::cia402::ProfileConfig { travel_limit_emcy: Some(0xFF01), ..c.profile },
        ..c
    });
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    let frames = bench.advance(Duration::from_millis(5));
    assert_eq!(emcys(&frames), vec![vec![0x01, 0xFF, 0x81, 3, 0, 0, 0, 0]], "positive switch");
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, false);
    node(&mut bench).motor.set_input(DigitalInputs::NEGATIVE_LIMIT, true);
    let frames = bench.advance(Duration::from_millis(5));
    assert_eq!(
        emcys(&frames),
        vec![vec![0, 0, 0, 0, 0, 0, 0, 0], vec![0x01, 0xFF, 0x81, 4, 0, 0, 0, 0]],
        "reset, then the negative switch"
    );
    node(&mut bench).motor.set_input(DigitalInputs::NEGATIVE_LIMIT, false);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(5))), vec![vec![0; 8]], "left the switch");

    // Software limits: the axis stands at 0; limits above it put it below the negative one.
    write_sub(&mut bench, 0x607D, 2, &2000i32.to_le_bytes());
    write_sub(&mut bench, 0x607D, 1, &1000i32.to_le_bytes());
    let frames = bench.advance(Duration::from_millis(5));
    assert_eq!(emcys(&frames), vec![vec![0x01, 0xFF, 0x81, 2, 0, 0, 0, 0]], "negative software limit");
    write_sub(&mut bench, 0x607D, 1, &(-1000i32).to_le_bytes());
    assert_eq!(emcys(&bench.advance(Duration::from_millis(5))), vec![vec![0; 8]], "inside again");
    write_sub(&mut bench, 0x607D, 2, &(-10i32).to_le_bytes());
    let frames = bench.advance(Duration::from_millis(5));
    assert_eq!(emcys(&frames), vec![vec![0x01, 0xFF, 0x81, 1, 0, 0, 0, 0]], "positive software limit");
    // In homing mode the switches are the method's signals, not limits.
    write_sub(&mut bench, 0x607D, 2, &2000i32.to_le_bytes());
    bench.advance(Duration::from_millis(5));
    write(&mut bench, 0x6060, &[6]);
    bench.advance(Duration::from_millis(5));
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(5))), Vec::<Vec<u8>>::new(), "homing");
}

/// A bench whose drive reports travel limits as `emcy` (FF01h: the Trinamic profile's), with
/// motion into an active limit switch stopped or not.
fn travel_limit_bench(emcy: Option<u16>, stop: bool) -> Bench {
    pp_bench(|mut c| {
        c.profile.travel_limit_emcy = emcy;
        c.profile.limit_switches_stop = stop;
        c
    })
}

/// FF01h with the travel limit in byte 1 (error register: generic + manufacturer-specific).
fn ff01(limit: u8) -> Vec<u8> {
    vec![0x01, 0xFF, 0x81, limit, 0, 0, 0, 0]
}

#[test]
fn a_pp_move_into_an_active_limit_switch_raises_the_travel_limit_emcy_again() {
    use canopen_drive::hal::DigitalInputs;
    // Writes 607Ah and raises bit 4: the EMCYs of the ticks that take the set-point.
    let set_point = |bench: &mut Bench, target: i32| {
        write(bench, 0x607A, &target.to_le_bytes());
        write(bench, 0x6040, &0x001Fu16.to_le_bytes());
        let frames = bench.advance(Duration::from_millis(2));
        cw(bench, 0x000F, 2);
        emcys(&frames)
    };
    // Standard: no EMCY at all.
    let mut standard = travel_limit_bench(None, true);
    node(&mut standard).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    enable(&mut standard, 1);
    let start = read_i32(&mut standard, 0x6064);
    assert_eq!(set_point(&mut standard, start + 5000), Vec::<Vec<u8>>::new());

    let mut bench = travel_limit_bench(Some(0xFF01), true);
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(5))), vec![ff01(3)], "the switch became active");
    enable(&mut bench, 1);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(20))), Vec::<Vec<u8>>::new(), "at a standstill");
    let start = read_i32(&mut bench, 0x6064);
    assert_eq!(set_point(&mut bench, start + 5000), vec![ff01(3)], "a move into the switch");
    assert_eq!(
        emcys(&bench.advance(Duration::from_millis(200))),
        Vec::<Vec<u8>>::new(),
        "once, not per tick"
    );
    assert!((read_i32(&mut bench, 0x6064) - start).abs() <= 50, "it did not move");
    assert_eq!(set_point(&mut bench, start + 8000), vec![ff01(3)], "another move into it");
    assert_eq!(set_point(&mut bench, start - 3000), Vec::<Vec<u8>>::new(), "away from it");
    let frames = bench.advance(Duration::from_millis(1000));
    assert_eq!(emcys(&frames), Vec::<Vec<u8>>::new());
    let away = read_i32(&mut bench, 0x6064);
    assert!((away - (start - 3000)).abs() <= 100, "away from it ({away})");
    assert_eq!(set_point(&mut bench, away + 1), vec![ff01(3)], "back towards it: a new touch");

    // The negative switch: byte 1 = 4 (the positive one released first: error reset).
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, false);
    node(&mut bench).motor.set_input(DigitalInputs::NEGATIVE_LIMIT, true);
    let frames = bench.advance(Duration::from_millis(5));
    assert_eq!(emcys(&frames), vec![vec![0; 8], ff01(4)]);
    let here = read_i32(&mut bench, 0x6064);
    assert_eq!(set_point(&mut bench, here + 2000), Vec::<Vec<u8>>::new(), "away from the negative one");
    bench.advance(Duration::from_millis(1000));
    let here = read_i32(&mut bench, 0x6064);
    assert_eq!(set_point(&mut bench, here - 2000), vec![ff01(4)], "into the negative one");
    // Released: the error reset, and no touch.
    node(&mut bench).motor.set_input(DigitalInputs::NEGATIVE_LIMIT, false);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(5))), vec![vec![0; 8]]);
    let here = read_i32(&mut bench, 0x6064);
    assert_eq!(set_point(&mut bench, here - 2000), Vec::<Vec<u8>>::new(), "no switch active");
}

#[test]
fn a_pv_target_into_an_active_limit_switch_raises_the_travel_limit_emcy_again() {
    use canopen_drive::hal::DigitalInputs;
    // Writes 60FFh: the EMCYs of the next ticks.
    let target = |bench: &mut Bench, velocity: i32| {
        write(bench, 0x60FF, &velocity.to_le_bytes());
        emcys(&bench.advance(Duration::from_millis(20)))
    };
    let none = Vec::<Vec<u8>>::new();
    // Standard: no EMCY at all.
    let mut standard = travel_limit_bench(None, true);
    node(&mut standard).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    enable(&mut standard, 3);
    assert_eq!(target(&mut standard, 1000), none);

    let mut bench = travel_limit_bench(Some(0xFF01), true);
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(5))), vec![ff01(3)], "the switch became active");
    enable(&mut bench, 3);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(20))), none, "at a standstill");
    assert_eq!(target(&mut bench, 1000), vec![ff01(3)], "a velocity into the switch");
    assert_eq!(od_i32(&mut bench, 0x606B), 0, "held at 0");
    assert_eq!(target(&mut bench, 2000), none, "still the same touch");
    assert_eq!(emcys(&bench.advance(Duration::from_millis(200))), none, "once, not per tick");
    assert_eq!(target(&mut bench, -1000), none, "away from it");
    assert_eq!(target(&mut bench, 0), none);
    assert_eq!(target(&mut bench, 1000), vec![ff01(3)], "towards it again: a new touch");
    assert_eq!(target(&mut bench, 0), none);

    // Running into the switch: its EMCY once (not a second one for the touch).
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, false);
    assert_eq!(target(&mut bench, 1000), vec![vec![0; 8]], "released: error reset");
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(20))), vec![ff01(3)], "ran into it");
    // Released and touched again with the target held.
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, false);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(20))), vec![vec![0; 8]]);
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(20))), vec![ff01(3)]);

    // The negative switch: byte 1 = 4.
    assert_eq!(target(&mut bench, 0), none);
    node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, false);
    node(&mut bench).motor.set_input(DigitalInputs::NEGATIVE_LIMIT, true);
    assert_eq!(emcys(&bench.advance(Duration::from_millis(5))), vec![vec![0; 8], ff01(4)]);
    assert_eq!(target(&mut bench, 500), none, "away from the negative one");
    assert_eq!(target(&mut bench, -500), vec![ff01(4)], "into the negative one");

    // Without the stop the axis moves on into the switch: a touch all the same.
    let mut moving = travel_limit_bench(Some(0xFF01), false);
    node(&mut moving).motor.set_input(DigitalInputs::NEGATIVE_LIMIT, true);
    moving.advance(Duration::from_millis(5));
    enable(&mut moving, 3);
    assert_eq!(target(&mut moving, -1000), vec![ff01(4)]);
    assert!(od_i32(&mut moving, 0x606B) < 0, "it moves");
    assert_eq!(emcys(&moving.advance(Duration::from_millis(200))), none, "once");
}

#[test]
fn error_behaviour_may_show_a_class_for_the_drives_fault() {
    // CiA 301 as configured by default: 1029h has one class, communication errors.
    let mut standard = Bench::new();
    assert_eq!(standard.sdo1(&req(0x40, 0x1029, 0, [0; 4])), req(0x4F, 0x1029, 0, [1, 0, 0, 0]));
    assert_eq!(standard.sdo1(&req(0x40, 0x1029, 2, [0; 4])), abort(0x1029, 2, 0x0609_0011));
    assert!(!eds_section(standard.drive(), "1029").contains("SubNumber=0x3"));

    static CLASSES: [DefaultOverride; 1] =
        [DefaultOverride { index: 0x1029, sub: 0, value: DefaultValue::Unsigned(2) }];
    let run = |behaviour: u8| {
        let mut bench = Bench::with_config(|c| Config { default_overrides: &CLASSES, ..c });
        assert_eq!(bench.sdo1(&req(0x40, 0x1029, 0, [0; 4])), req(0x4F, 0x1029, 0, [2, 0, 0, 0]));
        write_sub(&mut bench, 0x1029, 2, &[behaviour]);
        write(&mut bench, 0x1017, &10u16.to_le_bytes());
        nmt(&mut bench, 0x01);
        enable(&mut bench, 3);
        node(&mut bench).motor.inject_fault(canopen_drive::hal::HardwareFaults::OVER_CURRENT);
        let frames = bench.advance(Duration::from_millis(30));
        assert_eq!(sw(&mut bench) & 0x4F, 0x08, "Fault");
        let heartbeats: Vec<u8> = frames
            .iter()
            .filter(|f| f.standard_id() == Some(ERROR_CONTROL))
            .map(|f| embedded_can::Frame::data(f)[0])
            .collect();
        (eds_section(bench.drive(), "1029"), heartbeats.last().copied())
    };
    let (eds, last) = run(0);
    assert!(eds.contains("SubNumber=0x3"), "{eds}");
    assert_eq!(last, Some(0x7F), "0: Pre-operational on the drive's Fault");
    assert_eq!(run(1).1, Some(0x05), "1: no change");
    assert_eq!(run(2).1, Some(0x04), "2: Stopped");
}

#[test]
fn manufacturer_modes_may_run_as_direct_set_point_modes() {
    use canopen_drive::cia402::DirectMode;
    // CiA 402 only: a negative mode is refused, 6061h stays.
    let mut standard = Bench::new();
    assert_eq!(standard.sdo1(&req(0x2F, 0x6060, 0, [0xFC, 0, 0, 0])), abort(0x6060, 0, INVALID_VALUE));

    static MODES: [(i8, DirectMode); 2] = [(-4, DirectMode::Position), (-3, DirectMode::Velocity)];
    let mut bench = Bench::with_config(|c| Config {
        profile: canopen_drive::cia402::ProfileConfig { manufacturer_modes: &MODES, ..c.profile },
        ..c
    });
    write(&mut bench, 0x60C5, &u32::MAX.to_le_bytes());
    write(&mut bench, 0x60C6, &u32::MAX.to_le_bytes());
    let start = od_i32(&mut bench, 0x6064);
    write(&mut bench, 0x607A, &start.to_le_bytes());
    enable(&mut bench, 0xFC); // −4: direct position
    assert_eq!(bench.drive().od().get::<i8>(0x6061, 0).unwrap(), -4);
    // No SYNC, no interpolation period: the target is the demand at the next tick.
    write(&mut bench, 0x607A, &(start + 300).to_le_bytes());
    bench.advance(Duration::from_millis(2));
    assert_eq!(od_i32(&mut bench, 0x6062), start + 300);
    bench.advance(Duration::from_millis(300));
    assert!((od_i32(&mut bench, 0x6064) - (start + 300)).abs() < 20, "the axis follows");
    assert_eq!(sw(&mut bench) & 0x106F, 0x1027, "Operation enabled, target used (csp's bit 12)");
    // −3: direct velocity; the switch happens at rest, as any mode change.
    write(&mut bench, 0x60FF, &2000i32.to_le_bytes());
    write(&mut bench, 0x6060, &[0xFD]);
    bench.advance(Duration::from_millis(50));
    assert_eq!(bench.drive().od().get::<i8>(0x6061, 0).unwrap(), -3);
    assert_eq!(od_i32(&mut bench, 0x606B), 2000);
}

#[test]
fn digital_outputs_without_the_bit_mask_follow_sub_1() {
    // A drive described with 60FEh sub 1 only (a shorter constant sub 0).
    static DESCRIPTIONS: [EntryOverride; 1] =
        [EntryOverride::of(&PROFILE, 0x60FE, 0).default(DefaultValue::Unsigned(1))];
    let mut bench = Bench::with_config(|c| Config { entry_overrides: &DESCRIPTIONS, ..c });
    assert_eq!(bench.sdo1(&req(0x40, 0x60FE, 2, [0; 4])), abort(0x60FE, 2, 0x0609_0011));
    enable(&mut bench, 3);
    assert!(node(&mut bench).demand.brake_released);
    // Without a mask the brake bit is the master's at once (CiA 402's mask would be 0).
    bench.sdo1(&req(0x23, 0x60FE, 1, [1, 0, 0, 0]));
    bench.advance(Duration::from_millis(2));
    assert!(!node(&mut bench).demand.brake_released, "brake engaged by the master");
}

#[test]
fn statusword_bit_7_may_be_reserved() {
    use canopen_drive::hal::HardwareFaults;
    let run = |warning_bit: bool| {
        let mut bench = Bench::with_config(|c| Config {
            profile: canopen_drive::cia402::ProfileConfig { warning_bit, ..c.profile },
            ..c
        });
        node(&mut bench).motor.set_warnings(HardwareFaults::OVER_TEMPERATURE);
        bench.advance(Duration::from_millis(2));
        sw(&mut bench) & 0x0080
    };
    assert_eq!(run(true), 0x0080, "CiA 402: the board's warning");
    assert_eq!(run(false), 0, "reserved");
}

#[test]
fn option_code_minus_1_may_brake_dynamically() {
    use canopen_drive::cia402::OptionCodes;
    // CiA 402: −1 is no value of 605Ah.
    let mut standard = Bench::new();
    assert_eq!(standard.sdo1(&req(0x2B, 0x605A, 0, [0xFF, 0xFF, 0, 0])), abort(0x605A, 0, INVALID_VALUE));

    // A quick stop with 605Ah = `code` from 3000 increments/s: ms until the shaft is at rest,
    // and whether the windings were shorted meanwhile.
    let stop = |code: i16| {
        let mut bench = Bench::with_config(|c| Config {
            profile: canopen_drive::cia402::ProfileConfig {
                option_codes: OptionCodes {
                    quick_stop: OptionCodes::ALL.quick_stop | OptionCodes::DYNAMIC_BRAKE,
                    ..OptionCodes::ALL
                },
                ..c.profile
            },
            ..c
        });
        // A motor without a holding brake (one would stop the shaft at once).
        node(&mut bench).motor =
            canopen_drive_sim::motor::SimMotor::with_params(canopen_drive_sim::motor::MotorParams {
                brake_holding_torque: 0.0,
                ..Default::default()
            });
        write(&mut bench, 0x605A, &code.to_le_bytes());
        write(&mut bench, 0x6083, &100_000u32.to_le_bytes());
        enable(&mut bench, 3);
        write(&mut bench, 0x60FF, &3000i32.to_le_bytes());
        bench.advance(Duration::from_millis(200));
        cw(&mut bench, 0x000B, 0); // quick stop
        let (mut ms, mut shorted) = (0, false);
        while node(&mut bench).motor.sample().velocity != 0 && ms < 20_000 {
            bench.advance(Duration::from_millis(1));
            let demand = node(&mut bench).demand;
            assert!(!demand.drive_enabled);
            shorted |= demand.dynamic_brake;
            ms += 1;
        }
        bench.advance(Duration::from_millis(2));
        assert!(!node(&mut bench).demand.dynamic_brake, "released at rest");
        assert_eq!(sw(&mut bench) & 0x6F, 0x40, "Switch on disabled");
        (ms, shorted)
    };
    let (coasting, shorted) = stop(0);
    assert!(!shorted);
    let (braked, shorted) = stop(-1);
    assert!(shorted);
    assert!(braked * 2 < coasting, "dynamic braking {braked} ms, coasting {coasting} ms");
}

#[test]
fn the_firmware_may_preset_the_position() {
    let mut bench = Bench::new();
    node(&mut bench).motor.set_position(1234);
    bench.advance(Duration::from_millis(2));
    assert_eq!(od_i32(&mut bench, 0x6064), 1234);
    bench.drive().preset_position(-100);
    bench.advance(Duration::from_millis(2));
    assert_eq!(od_i32(&mut bench, 0x6064), -100, "the present position reads the preset");
    assert_eq!(od_i32(&mut bench, 0x6063), 1234, "the internal count is the encoder's");
    // A pp move in the new coordinates.
    enable(&mut bench, 1);
    write(&mut bench, 0x607A, &400i32.to_le_bytes());
    cw(&mut bench, 0x001F, 2);
    cw(&mut bench, 0x000F, 1500);
    assert!((od_i32(&mut bench, 0x6064) - 400).abs() <= 5, "{}", od_i32(&mut bench, 0x6064));
    assert!((od_i32(&mut bench, 0x6063) - 1734).abs() <= 5);
}

// --- Issue 18: departures the vendor profiles switch on ------------------------------------------

#[test]
fn a_set_point_written_before_operation_enabled_is_the_target_once_enabled() {
    use canopen_drive::cia402::cyclic::CycleStart;
    // An SDO-driven cycle (no SYNC): mode, controlword 6 and 7, the set-point, ticks pass, then
    // controlword 15. The set-point written in Switched on must be reached, not dropped.
    for mode in [8u8, 9] {
        let mut bench = Bench::with_config(|mut c| {
            c.profile.cyclic.sdo_set_points = true;
            c.profile.cyclic.cycle_start = CycleStart::SetPoint;
            c
        });
        write_sub(&mut bench, 0x60C2, 1, &[10]);
        write(&mut bench, 0x60C5, &u32::MAX.to_le_bytes());
        write(&mut bench, 0x60C6, &u32::MAX.to_le_bytes());
        write(&mut bench, 0x6060, &[mode]);
        cw(&mut bench, 0x0006, 2);
        cw(&mut bench, 0x0007, 2);
        let start = od_i32(&mut bench, 0x6064);
        if mode == 8 {
            write(&mut bench, 0x607A, &(start + 512).to_le_bytes());
        } else {
            write(&mut bench, 0x60FF, &2000i32.to_le_bytes());
        }
        bench.advance(Duration::from_millis(20)); // ticks between the steps
        cw(&mut bench, 0x000F, 100);
        if mode == 8 {
            assert_eq!(od_i32(&mut bench, 0x6062) - start, 512, "csp demand");
        } else {
            assert_eq!(od_i32(&mut bench, 0x606B), 2000, "csv demand");
        }
    }
}

#[test]
fn the_home_offset_may_be_the_value_of_the_home_position() {
    use canopen_drive::cia402::hm::{HomeOffset, HomingConfig};
    for (convention, expected) in [(HomeOffset::ZeroBeforeHome, -5), (HomeOffset::HomeValue, 5)] {
        let mut bench = Bench::with_config(|mut c| {
            c.profile.homing = HomingConfig { home_offset: convention, ..HomingConfig::new() };
            c
        });
        write(&mut bench, 0x607C, &5i32.to_le_bytes());
        write(&mut bench, 0x6098, &[35]);
        enable(&mut bench, 6);
        cw(&mut bench, 0x001F, 5);
        assert_eq!(sw(&mut bench) & 0x3400, 0x1400);
        assert_eq!(read_i32(&mut bench, 0x6064), expected, "{convention:?}");
    }
}

#[test]
fn method_35_may_zero_the_internal_position_too() {
    use canopen_drive::cia402::hm::HomingConfig;
    for rebase in [false, true] {
        let mut bench = Bench::with_config(|mut c| {
            c.profile.homing = HomingConfig { rebase_internal_position: rebase, ..HomingConfig::new() };
            c
        });
        node(&mut bench).motor.set_position(4321);
        bench.advance(Duration::from_millis(2));
        write(&mut bench, 0x6098, &[35]);
        enable(&mut bench, 6);
        cw(&mut bench, 0x001F, 5);
        assert_eq!(read_i32(&mut bench, 0x6064), 0);
        assert_eq!(read_i32(&mut bench, 0x6063), if rebase { 0 } else { 4321 }, "rebase {rebase}");
    }
}

/// pp to `target` from where the axis is; returns 6064h after a second.
fn pp_move(bench: &mut Bench, target: i32) -> i32 {
    write(bench, 0x607A, &target.to_le_bytes());
    cw(bench, 0x001F, 2);
    cw(bench, 0x000F, 1000);
    read_i32(bench, 0x6064)
}

fn pp_bench(adjust: impl FnOnce(Config) -> Config) -> Bench {
    let mut bench = Bench::with_config(adjust);
    write(&mut bench, 0x6081, &20_000u32.to_le_bytes());
    write(&mut bench, 0x6083, &200_000u32.to_le_bytes());
    write(&mut bench, 0x6084, &200_000u32.to_le_bytes());
    bench
}

#[test]
fn software_limits_may_wait_for_homing() {
    for after_homing in [false, true] {
        let mut bench = pp_bench(|mut c| {
            c.profile.software_limits_after_homing = after_homing;
            c
        });
        write_sub(&mut bench, 0x607D, 2, &5000i32.to_le_bytes());
        enable(&mut bench, 1);
        let reached = pp_move(&mut bench, 10_000);
        if after_homing {
            assert!((reached - 10_000).abs() <= 100, "not homed: no limit ({reached})");
        } else {
            assert!((reached - 5000).abs() <= 100, "CiA 402: the limit holds at once ({reached})");
        }
        // Homed (method 35 here), the limit holds.
        cw(&mut bench, 0x000F, 2);
        write(&mut bench, 0x6060, &[6]);
        write(&mut bench, 0x6098, &[35]);
        bench.advance(Duration::from_millis(5));
        cw(&mut bench, 0x001F, 5);
        assert_eq!(sw(&mut bench) & 0x3400, 0x1400, "homed");
        cw(&mut bench, 0x000F, 2);
        write(&mut bench, 0x6060, &[1]);
        bench.advance(Duration::from_millis(5));
        let reached = pp_move(&mut bench, 8000);
        assert!((reached - 5000).abs() <= 100, "homed: clamped ({reached})");
        assert_ne!(sw(&mut bench) & 0x0800, 0, "bit 11: the target was clamped");
    }
}

#[test]
fn an_active_limit_switch_may_stop_motion_towards_it() {
    use canopen_drive::hal::DigitalInputs;
    for stop in [false, true] {
        let mut bench = pp_bench(|mut c| {
            c.profile.limit_switches_stop = stop;
            c
        });
        node(&mut bench).motor.set_input(DigitalInputs::POSITIVE_LIMIT, true);
        enable(&mut bench, 1);
        let start = read_i32(&mut bench, 0x6064);
        let reached = pp_move(&mut bench, start + 5000);
        if stop {
            assert!((reached - start).abs() <= 50, "no move into the switch ({reached})");
            assert_ne!(sw(&mut bench) & 0x0800, 0, "bit 11");
            let back = pp_move(&mut bench, start - 3000);
            assert!((back - (start - 3000)).abs() <= 100, "away from it ({back})");
        } else {
            assert!((reached - start - 5000).abs() <= 100, "CiA 402 leaves it to the manufacturer");
        }
    }
}

#[test]
fn halt_may_wait_for_the_shaft_to_rest() {
    // With the option, bit 10 under halt comes only once 606Ch is 0, not with the demand.
    for standstill in [false, true] {
        let mut bench = pp_bench(|mut c| {
            c.profile.halt_reached_at_standstill = standstill;
            c
        });
        // A soft position loop: the shaft lags the demand.
        node(&mut bench).motor =
            canopen_drive_sim::motor::SimMotor::with_params(canopen_drive_sim::motor::MotorParams {
                position_gain: 5.0,
                velocity_proportional_gain: 200.0,
                ..Default::default()
            });
        enable(&mut bench, 1);
        write(&mut bench, 0x607A, &40_000i32.to_le_bytes());
        cw(&mut bench, 0x001F, 2);
        cw(&mut bench, 0x000F, 300);
        cw(&mut bench, 0x010F, 0);
        let mut moving_when_reached = false;
        for _ in 0..500 {
            bench.advance(Duration::from_millis(1));
            if sw(&mut bench) & 0x0400 != 0 {
                moving_when_reached = od_i32(&mut bench, 0x606C) != 0;
                break;
            }
        }
        assert_eq!(moving_when_reached, !standstill, "halt_reached_at_standstill {standstill}");
    }
}

#[test]
fn standard_objects_a_drive_lacks_do_not_exist_for_the_bus() {
    static ABSENT: [u16; 3] = [0x1003, 0x603F, 0x6072];
    let mut bench = Bench::with_config(|c| Config { absent_objects: &ABSENT, ..c });
    for index in ABSENT {
        assert_eq!(bench.sdo1(&req(0x40, index, 0, [0; 4])), abort(index, 0, 0x0602_0000));
    }
    // Not mappable either.
    let r = bench.sdo1(&req(0x2F, 0x1A00, 0, [0; 4]));
    assert_eq!(r, abort(0x1A00, 0, 0x0601_0000), "TPDO1 is valid");
    assert_eq!(bench.sdo1(&req(0x23, 0x1800, 1, [0x81, 0x01, 0, 0x80])), req(0x60, 0x1800, 1, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x2F, 0x1A00, 0, [0, 0, 0, 0])), req(0x60, 0x1A00, 0, [0; 4]));
    let r = bench.sdo1(&req(0x23, 0x1A00, 1, 0x603F_0010u32.to_le_bytes()));
    assert_eq!(r, abort(0x1A00, 1, 0x0602_0000));
    // Nor in the EDS; their behaviour stays: the fault code is still kept inside, a torque
    // limit at its default still limits.
    let mut eds = String::new();
    bench.drive().write_eds(&EdsInfo::default(), &mut eds).unwrap();
    for index in ABSENT {
        assert!(!eds.contains(&format!("\n[{index:04X}]\n")), "{index:04X} in the EDS");
        assert!(!eds.contains(&format!("=0x{index:04X}\n")), "{index:04X} listed");
    }
    assert_eq!(bench.drive().od().get::<u16>(0x6072, 0), Ok(3000));
}

#[test]
fn emcy_bytes_may_be_the_drives_own() {
    static BYTES: [(u16, [u8; 5]); 1] = [(0x8210, [0, 0xFF, 0, 0, 0])];
    for table in [&[][..], &BYTES[..]] {
        let mut bench = Bench::with_config(|c| Config { emcy_additional_bytes: table, ..c });
        nmt(&mut bench, 0x01);
        let frames = bench.send(frame(0x200 + u16::from(NODE), &[0x06]));
        let expected = if table.is_empty() { [0u8; 5] } else { [0, 0xFF, 0, 0, 0] };
        let mut data = vec![0x10, 0x82, 0x11];
        data.extend_from_slice(&expected);
        assert_eq!(emcys(&frames), vec![data]);
    }
}

#[test]
fn a_firmware_may_let_mappings_change_while_the_pdo_is_valid() {
    let mut bench = Bench::new();
    let refused = bench.sdo1(&req(0x2F, 0x1A00, 0, [0; 4]));
    assert_eq!(refused, abort(0x1A00, 0, 0x0601_0000), "CiA 301: only while invalid");
    bench.drive().set_remap_while_valid(true);
    for (sub, value) in [(0u8, 0u32), (1, 0x6041_0010), (2, 0x6061_0008), (0, 2)] {
        let command = if sub == 0 { 0x2F } else { 0x23 };
        assert_eq!(
            bench.sdo1(&req(command, 0x1A00, sub, value.to_le_bytes())),
            req(0x60, 0x1A00, sub, [0; 4])
        );
    }
    // The new mapping is in use at once: statusword and 6061h in TPDO1.
    write(&mut bench, 0x6060, &[3]);
    bench.advance(Duration::from_millis(2));
    let mut frames = bench.send(frame(0x000, &[0x01, NODE]));
    frames.extend(bench.advance(Duration::from_millis(5)));
    let tpdo: Vec<_> = frames
        .iter()
        .filter(|f| f.standard_id() == Some(0x180 + u16::from(NODE)))
        .map(|f| embedded_can::Frame::data(f).to_vec())
        .collect();
    assert!(tpdo.iter().any(|d| d.len() == 3 && d[2] == 3), "{tpdo:02X?}");
    bench.drive().set_remap_while_valid(false);
    assert_eq!(bench.sdo1(&req(0x2F, 0x1A00, 0, [0; 4])), abort(0x1A00, 0, 0x0601_0000));
}

/// The rules of a standard object belong to the service that implements it, not to the table
/// that describes it: a firmware that brings its own PDO records (other defaults, other names)
/// and its own profile object still gets every CiA 301 / CiA 402 refusal.
#[test]
fn a_firmwares_own_descriptions_of_standard_objects_keep_their_rules() {
    const RW32: Var = Var::new("COB-ID", DataType::Unsigned32).access(Access::ReadWrite);
    const TYPE: Var = Var::new("Transmission type", DataType::Unsigned8).access(Access::ReadWrite);
    const RPDO_SUBS: [(u8, Var); 3] = [
        (
            0,
            Var::new("Highest sub-index supported", DataType::Unsigned8)
                .access(Access::Const)
                .default(DefaultValue::Unsigned(2)),
        ),
        (1, RW32.default(DefaultValue::NodeIdPlus(0x8000_0200))),
        (2, TYPE.default(DefaultValue::Unsigned(255))),
    ];
    const TPDO_SUBS: [(u8, Var); 3] = [
        (
            0,
            Var::new("Highest sub-index supported", DataType::Unsigned8)
                .access(Access::Const)
                .default(DefaultValue::Unsigned(2)),
        ),
        (1, RW32.default(DefaultValue::NodeIdPlus(0xC000_0180))),
        (2, TYPE.default(DefaultValue::Unsigned(255))),
    ];
    const MAPPING: Var = Var::new("Mapping entry", DataType::Unsigned32).access(Access::ReadWrite);
    const MAPPING_SUBS: [(u8, Var); 3] = [
        (0, Var::new("Number of mapped objects", DataType::Unsigned8).access(Access::ReadWrite)),
        (1, MAPPING),
        (2, MAPPING),
    ];
    static PDOS: [Object; 16] = layout([
        Object::record(0x1400, "RPDO communication parameter", &RPDO_SUBS),
        Object::record(0x1401, "RPDO communication parameter", &RPDO_SUBS),
        Object::record(0x1402, "RPDO communication parameter", &RPDO_SUBS),
        Object::record(0x1403, "RPDO communication parameter", &RPDO_SUBS),
        Object::record(0x1600, "RPDO mapping parameter", &MAPPING_SUBS),
        Object::record(0x1601, "RPDO mapping parameter", &MAPPING_SUBS),
        Object::record(0x1602, "RPDO mapping parameter", &MAPPING_SUBS),
        Object::record(0x1603, "RPDO mapping parameter", &MAPPING_SUBS),
        Object::record(0x1800, "TPDO communication parameter", &TPDO_SUBS),
        Object::record(0x1801, "TPDO communication parameter", &TPDO_SUBS),
        Object::record(0x1802, "TPDO communication parameter", &TPDO_SUBS),
        Object::record(0x1803, "TPDO communication parameter", &TPDO_SUBS),
        Object::record(0x1A00, "TPDO mapping parameter", &MAPPING_SUBS),
        Object::record(0x1A01, "TPDO mapping parameter", &MAPPING_SUBS),
        Object::record(0x1A02, "TPDO mapping parameter", &MAPPING_SUBS),
        Object::record(0x1A03, "TPDO mapping parameter", &MAPPING_SUBS),
    ]);
    let mut bench = Bench::with_config(|c| Config { pdo_objects: &PDOS, ..c });
    // PDO: a reserved transmission type, a restricted COB-ID, an entry that cannot be mapped.
    assert_eq!(bench.sdo1(&req(0x2F, 0x1400, 2, [241, 0, 0, 0])), abort(0x1400, 2, INVALID_VALUE));
    assert_eq!(
        bench.sdo1(&req(0x23, 0x1800, 1, 0x0000_0701u32.to_le_bytes())),
        abort(0x1800, 1, INVALID_VALUE)
    );
    assert_eq!(
        bench.sdo1(&req(0x23, 0x1600, 1, 0x6041_0010u32.to_le_bytes())),
        abort(0x1600, 1, 0x0604_0041),
        "6041h is not receive-mappable"
    );
    // SYNC and the profile keep theirs too.
    assert_eq!(bench.sdo1(&req(0x2F, 0x1019, 0, [1, 0, 0, 0])), abort(0x1019, 0, INVALID_VALUE));
    assert_eq!(bench.sdo1(&req(0x2F, 0x6060, 0, [77, 0, 0, 0])), abort(0x6060, 0, INVALID_VALUE));
    // And a valid mapping is taken.
    assert_eq!(bench.sdo1(&req(0x23, 0x1600, 1, 0x6040_0010u32.to_le_bytes()))[0], 0x60);
}

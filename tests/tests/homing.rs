//! Homing mode on the virtual bus with the simulated motor: section L of
//! `docs/testing.md` and every method from several start positions.
//!
//! `cargo test -p canopen-drive-tests --test homing -- --nocapture` prints the table of
//! methods × start positions × result (also kept in `docs/homing-methods.md`).

mod common;

use common::profile::*;
use common::*;

use canopen_drive::cia402::hm::{hard_stop_object, HomingConfig, VendorMethod};
use canopen_drive::hal::HardwareFaults;
use canopen_drive::od::{layout, Object};
use canopen_drive::Duration;
use canopen_drive_sim::motor::{MotorParams, SimMotor, Zone};
use embedded_can::Frame;

const HM: u8 = 6;
const FAST: u32 = 5000;
const SLOW: u32 = 400;

/// Homing status (bit 13, bit 12, bit 10).
fn homing_status(statusword: u16) -> (u8, u8, u8) {
    (((statusword >> 13) & 1) as u8, ((statusword >> 12) & 1) as u8, ((statusword >> 10) & 1) as u8)
}

/// The axis of the item-120 scene, extended: 1000 increments per revolution, index pulses at
/// 150 + k·1000, limit switches active beyond ±10 000, hard stops at ±12 000.
fn axis() -> MotorParams {
    MotorParams {
        increments_per_revolution: 1000,
        index_position: 150,
        negative_limit_switch: Some(-10_000),
        positive_limit_switch: Some(10_000),
        negative_hard_stop: Some(-12_000),
        positive_hard_stop: Some(12_000),
        ..MotorParams::default()
    }
}

fn bench_with(params: MotorParams, start: i32) -> Bench {
    bench_config(params, start, |config| config)
}

fn bench_config(
    params: MotorParams,
    start: i32,
    adjust: impl FnOnce(canopen_drive::Config) -> canopen_drive::Config,
) -> Bench {
    let mut bench = Bench::with_config(adjust);
    node(&mut bench).motor = SimMotor::with_params(params);
    node(&mut bench).motor.set_position(start);
    write_sub(&mut bench, 0x6099, 1, &FAST.to_le_bytes());
    write_sub(&mut bench, 0x6099, 2, &SLOW.to_le_bytes());
    write(&mut bench, 0x609A, &50_000u32.to_le_bytes());
    bench.advance(Duration::from_millis(2));
    bench
}

/// The result of one homing run.
#[derive(Debug)]
struct Run {
    /// Statuses seen, in order, without repeats.
    statuses: Vec<(u8, u8, u8)>,
    /// The encoder count at user zero (6063h − 6064h at the end, 607Ch = 0).
    home: i32,
    /// Lowest and highest encoder count seen.
    span: (i32, i32),
}

/// Starts `method` (bit 4 edge) and runs until the status is final or `seconds` pass.
fn home(bench: &mut Bench, method: i8, seconds: u64) -> Run {
    write(bench, 0x6098, &[method as u8]);
    cw(bench, 0x000F, 1);
    cw(bench, 0x001F, 0);
    let mut statuses = Vec::new();
    let start = od_i32(bench, 0x6063);
    let mut span = (start, start);
    for _ in 0..seconds * 100 {
        bench.advance(Duration::from_millis(10));
        let raw = od_i32(bench, 0x6063);
        span = (span.0.min(raw), span.1.max(raw));
        let status = homing_status(sw(bench));
        if statuses.last() != Some(&status) {
            statuses.push(status);
        }
        if matches!(status, (0, 1, 1) | (1, 0, 1)) {
            break;
        }
    }
    // Let the position loop settle on the final demand.
    bench.advance(Duration::from_millis(300));
    let home = od_i32(bench, 0x6063) - od_i32(bench, 0x6064);
    Run { statuses, home, span }
}

fn enabled_hm(params: MotorParams, start: i32) -> Bench {
    let mut bench = bench_with(params, start);
    enable(&mut bench, HM);
    bench
}

/// Positive home switch at 3000 (active above) for methods 3, 4, 19, 20; negative (active
/// below) for 5, 6, 21, 22; a zone 2000..=4000 for 7–14 and 23–30.
fn scene(method: i8) -> MotorParams {
    let home_switch = match method {
        3 | 4 | 19 | 20 => Some(Zone::above(3000)),
        5 | 6 | 21 | 22 => Some(Zone::below(3000)),
        7..=14 | 23..=30 => Some(Zone::between(2000, 4000)),
        _ => None,
    };
    MotorParams { home_switch, ..axis() }
}

/// The expected home (encoder count) of each method in its scene.
fn expected(method: i8, start: i32) -> i32 {
    match method {
        1 => -9850,
        2 => 9150,
        17 => -10_000,
        18 => 10_000,
        3 | 6 => 2150,
        4 | 5 => 3150,
        19..=22 => 3000,
        7 | 14 => 1150,
        8 | 13 => 2150,
        9 | 12 => 3150,
        10 | 11 => 4150,
        23 | 24 | 29 | 30 => 2000,
        25..=28 => 4000,
        // The first index pulse in the direction of travel.
        33 => 150 + ((start - 150 - 1).div_euclid(1000)) * 1000,
        34 => 150 + ((start - 150).div_euclid(1000) + 1) * 1000,
        _ => start,
    }
}

#[test]
fn every_method_from_several_starts_finds_its_home() {
    let methods: Vec<i8> = (1..=14).chain(17..=30).chain(33..=35).collect();
    let mut table = String::from("| method | start | home (encoder count) | expected | statuses (b13 b12 b10) |\n|---|---|---|---|---|\n");
    let mut failures = Vec::new();
    for &method in &methods {
        let starts: &[i32] = match method {
            1 | 17 => &[-11_000, -5000, 5000],
            2 | 18 => &[11_000, 5000, -5000],
            3..=6 | 19..=22 => &[-5000, 3000, 8000],
            _ => &[-5000, 3000, 8000],
        };
        for &start in starts {
            let mut bench = enabled_hm(scene(method), start);
            let run = home(&mut bench, method, 30);
            let want = expected(method, start);
            let ok = run.statuses.last() == Some(&(0, 1, 1))
                && (run.home - want).abs() <= 2
                && run.span.0 > -12_000
                && run.span.1 < 12_000;
            table.push_str(&format!(
                "| {method} | {start} | {} | {want} | {} |\n",
                run.home,
                run.statuses.iter().map(|(a, b, c)| format!("{a}{b}{c}")).collect::<Vec<_>>().join(" → ")
            ));
            if !ok {
                failures.push(format!("method {method} from {start}: {run:?}, expected {want}"));
            }
            // Never an error or an interruption on the way.
            assert!(
                run.statuses.iter().all(|s| matches!(s, (0, 0, 0) | (0, 1, 0) | (0, 1, 1))),
                "method {method} from {start}: {run:?}"
            );
        }
    }
    println!("{table}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn l_116_idle_homing_status_before_any_run() {
    let mut bench = enabled_hm(axis(), 0);
    assert_eq!(homing_status(statusword(&mut bench)), (0, 0, 1));
}

#[test]
fn l_117_l_135_method_35_uses_the_current_position_and_the_home_offset() {
    let mut bench = enabled_hm(axis(), 4321);
    write(&mut bench, 0x607C, &2000i32.to_le_bytes());
    write(&mut bench, 0x6098, &[35]);
    cw(&mut bench, 0x001F, 5);
    assert_eq!(homing_status(statusword(&mut bench)), (0, 1, 1));
    assert_eq!(read_i32(&mut bench, 0x6064), -2000, "6064h = −607Ch at home");
    assert_eq!(read_i32(&mut bench, 0x6063), 4321, "no motion");
    // l_135: pp to 0 moves +2000 from home.
    write(&mut bench, 0x6060, &[1]);
    write(&mut bench, 0x6081, &20_000u32.to_le_bytes());
    write(&mut bench, 0x6083, &100_000u32.to_le_bytes());
    write(&mut bench, 0x6084, &100_000u32.to_le_bytes());
    write(&mut bench, 0x607A, &0i32.to_le_bytes());
    cw(&mut bench, 0x000F, 2);
    cw(&mut bench, 0x001F, 1);
    cw(&mut bench, 0x000F, 1000);
    assert_eq!(bench.drive().od().get::<i32>(0x60FC, 0), Ok(0), "60FCh counts from the user zero");
    let raw = read_i32(&mut bench, 0x6063);
    assert!((raw - 6321).abs() <= 10, "{raw}");
}

#[test]
fn l_118_method_35_without_operation_enabled() {
    let mut bench = bench_with(axis(), 777);
    write(&mut bench, 0x6060, &[HM]);
    write(&mut bench, 0x6098, &[35]);
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x0007, 2);
    cw(&mut bench, 0x0017, 2);
    assert!(is(&mut bench, SO));
    assert!(!node(&mut bench).demand.drive_enabled);
    assert_eq!(homing_status(statusword(&mut bench)), (0, 1, 1));
    assert_eq!(read_i32(&mut bench, 0x6064), 0);
}

#[test]
fn a_mode_change_and_bit_4_between_two_ticks_start_homing() {
    // A master that selects hm and raises bit 4 before the drive's next tick (python-canopen
    // on a fast link does): the tick that changes the mode takes the edge as well. Before, it
    // was lost and homing never started.
    let mut bench = bench_with(axis(), 777);
    write(&mut bench, 0x6060, &[1]);
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x0007, 2);
    assert!(is(&mut bench, SO));
    write(&mut bench, 0x6060, &[HM]);
    write(&mut bench, 0x6098, &[35]);
    cw(&mut bench, 0x0017, 2);
    assert_eq!(homing_status(statusword(&mut bench)), (0, 1, 1));
    assert_eq!(read_i32(&mut bench, 0x6064), 0);
}

#[test]
fn l_119_l_120_method_1_reverses_on_the_limit_and_homes_on_the_index() {
    // The digest's scene: NLS at 0, index every 1000 counts from 150, start at 5000.
    let params = MotorParams { negative_limit_switch: Some(0), positive_limit_switch: None, ..axis() };
    let mut bench = enabled_hm(params, 5000);
    let run = home(&mut bench, 1, 30);
    assert_eq!(run.statuses.first(), Some(&(0, 0, 0)), "l_119: in progress while moving");
    assert_eq!(run.statuses.last(), Some(&(0, 1, 1)));
    assert!(run.span.0 < 0, "went onto the NLS");
    assert!((run.home - 150).abs() <= 2, "{run:?}");
}

#[test]
fn l_128_search_speeds_and_acceleration() {
    let mut bench = enabled_hm(scene(8), -5000);
    write(&mut bench, 0x6098, &[8]);
    cw(&mut bench, 0x001F, 0);
    bench.advance(Duration::from_millis(500));
    assert_eq!(read_i32(&mut bench, 0x606B), FAST as i32, "switch search at 6099h.1");
    // 50 000 increments/s² → 500 per 10 ms.
    let mut bench = enabled_hm(scene(8), -5000);
    write(&mut bench, 0x6098, &[8]);
    cw(&mut bench, 0x001F, 50);
    let v = read_i32(&mut bench, 0x606B);
    assert!((2400..=2600).contains(&v), "609Ah: {v}");
    let mut bench = enabled_hm(scene(33), 5500);
    write(&mut bench, 0x6098, &[33]);
    cw(&mut bench, 0x001F, 100);
    assert_eq!(read_i32(&mut bench, 0x606B), -(SLOW as i32), "zero search at 6099h.2");
}

#[test]
fn l_129_l_130_halt_and_bit_4_interrupt() {
    for command in [0x011F, 0x000F] {
        let mut bench = enabled_hm(scene(7), -5000);
        write(&mut bench, 0x6098, &[7]);
        cw(&mut bench, 0x001F, 300);
        cw(&mut bench, command, 1);
        assert_eq!(homing_status(sw(&mut bench)), (0, 0, 0), "decelerating");
        // 605Dh = 1: the slow-down ramp 6084h (10 000/s²) from 5000 increments/s.
        bench.advance(Duration::from_millis(600));
        assert_eq!(read_i32(&mut bench, 0x606B), 0);
        assert_eq!(homing_status(statusword(&mut bench)), (0, 0, 1), "interrupted at rest");
        assert!(is(&mut bench, OE));
    }
}

#[test]
fn l_131_both_limits_active_is_a_homing_error() {
    let mut bench = enabled_hm(scene(7), -5000);
    write(&mut bench, 0x6098, &[7]);
    cw(&mut bench, 0x001F, 200);
    node(&mut bench).motor.set_input(canopen_drive::hal::DigitalInputs::NEGATIVE_LIMIT, true);
    node(&mut bench).motor.set_input(canopen_drive::hal::DigitalInputs::POSITIVE_LIMIT, true);
    let frames = bench.advance(Duration::from_millis(1));
    let emcy = frames.iter().find(|f| f.standard_id() == Some(0x80 + u16::from(NODE))).expect("EMCY");
    assert_eq!(emcy.data()[..2], [0x13, 0x86]);
    assert_eq!(homing_status(sw(&mut bench)), (1, 0, 0), "error while decelerating");
    bench.advance(Duration::from_millis(300));
    assert_eq!(homing_status(statusword(&mut bench)), (1, 0, 1), "error at rest");
}

#[test]
fn l_132_homed_status_survives_a_mode_round_trip() {
    let mut bench = enabled_hm(scene(34), 0);
    let run = home(&mut bench, 34, 10);
    assert_eq!(run.statuses.last(), Some(&(0, 1, 1)));
    write(&mut bench, 0x6060, &[1]);
    bench.advance(Duration::from_millis(5));
    write(&mut bench, 0x6060, &[HM]);
    bench.advance(Duration::from_millis(5));
    assert_eq!(homing_status(statusword(&mut bench)), (0, 1, 1), "b12 = 1 without a new run");
    assert_eq!(read_i32(&mut bench, 0x606B), 0);
}

#[test]
fn l_133_l_134_method_values_and_sizes() {
    let mut bench = Bench::new();
    for method in [15i8, 16, 31, 32, 37, 100, 127, -1] {
        assert_eq!(
            bench.sdo1(&req(0x2F, 0x6098, 0, [method as u8, 0, 0, 0])),
            abort(0x6098, 0, 0x0609_0030),
            "{method}"
        );
    }
    assert_eq!(bench.sdo1(&req(0x40, 0x6098, 0, [0; 4])), req(0x4F, 0x6098, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x6099, 0, [0; 4])), req(0x4F, 0x6099, 0, [2, 0, 0, 0]));
    // hm is listed in 6502h.
    let modes = bench.sdo1(&req(0x40, 0x6502, 0, [0; 4]));
    assert_eq!(modes[4] & 0x20, 0x20);
}

#[test]
fn i_81_polarity_has_no_effect_on_homing_directions() {
    let mut bench = enabled_hm(scene(34), 0);
    write(&mut bench, 0x607E, &[0x80]);
    let run = home(&mut bench, 34, 10);
    assert_eq!(run.statuses.last(), Some(&(0, 1, 1)));
    assert_eq!(run.home, 150, "first index moving positive in encoder counts");
    assert!(run.span.0 >= 0, "never moved negative: {run:?}");
}

#[test]
fn method_37_is_accepted_when_configured() {
    let mut bench = bench_config(axis(), 1234, |mut config| {
        config.profile.homing = HomingConfig { method_37: true, ..HomingConfig::new() };
        config
    });
    enable(&mut bench, HM);
    write(&mut bench, 0x6098, &[37]);
    cw(&mut bench, 0x001F, 3);
    assert_eq!(homing_status(statusword(&mut bench)), (0, 1, 1));
    assert_eq!(read_i32(&mut bench, 0x6064), 0);
}

#[test]
fn a_limit_switch_in_the_wrong_phase_is_a_homing_error() {
    // Method 3 needs a positive home switch; with none the search runs into the PLS.
    let mut bench = enabled_hm(axis(), 0);
    let run = home(&mut bench, 3, 30);
    assert_eq!(run.statuses.last(), Some(&(1, 0, 1)), "{run:?}");
    assert!(run.span.1 < 12_000);
}

#[test]
fn a_switch_that_never_comes_is_a_homing_error() {
    // Method 34 with no index pulse within reach: a timeout ends it.
    let mut bench = bench_config(
        MotorParams {
            increments_per_revolution: 1_000_000,
            index_position: 900_000,
            ..MotorParams::default()
        },
        0,
        |mut config| {
            config.profile.homing =
                HomingConfig { timeout: Duration::from_millis(2000), ..HomingConfig::new() };
            config
        },
    );
    enable(&mut bench, HM);
    let run = home(&mut bench, 34, 10);
    assert_eq!(run.statuses.last(), Some(&(1, 0, 1)), "{run:?}");
}

#[test]
fn a_following_error_during_homing_is_a_homing_error() {
    let mut bench = enabled_hm(scene(34), 0);
    write(&mut bench, 0x6065, &50u32.to_le_bytes());
    write(&mut bench, 0x6066, &10u16.to_le_bytes());
    node(&mut bench).motor.set_load_torque(-5000.0);
    let run = home(&mut bench, 34, 5);
    assert_eq!(run.statuses.last(), Some(&(1, 0, 1)), "{run:?}");
}

#[test]
fn quick_stop_during_homing_interrupts_it() {
    let mut bench = enabled_hm(scene(7), -5000);
    write(&mut bench, 0x605A, &6i16.to_le_bytes());
    write(&mut bench, 0x6098, &[7]);
    cw(&mut bench, 0x001F, 300);
    cw(&mut bench, 0x001B, 300);
    assert!(is(&mut bench, QSA));
    assert_eq!(read_i32(&mut bench, 0x606B), 0);
    cw(&mut bench, 0x000F, 5);
    assert!(is(&mut bench, OE));
    assert_eq!(homing_status(statusword(&mut bench)), (0, 0, 1));
}

#[test]
fn an_encoder_fault_forgets_the_home() {
    let mut bench = enabled_hm(scene(34), 0);
    home(&mut bench, 34, 10);
    node(&mut bench).motor.inject_fault(HardwareFaults::ENCODER);
    bench.advance(Duration::from_millis(10));
    node(&mut bench).motor.clear_faults();
    cw(&mut bench, 0x0080, 2);
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x000F, 2);
    assert_eq!(homing_status(statusword(&mut bench)), (0, 0, 1));
}

// --- Hard-stop homing (vendor methods) ---------------------------------------------------------

static HARD_STOP: [Object; 1] = layout([hard_stop_object(0x2500)]);
static VENDOR_METHODS: [(i8, VendorMethod); 4] = [
    (-1, VendorMethod::HardStop { positive: true, index: false }),
    (-2, VendorMethod::HardStop { positive: false, index: true }),
    (-3, VendorMethod::MidpointOfHardStops),
    (-4, VendorMethod::MidpointOfLimitSwitches),
];

fn hard_stop_bench(params: MotorParams, start: i32) -> Bench {
    let mut bench = bench_config(params, start, |mut config| {
        config.manufacturer_objects = &HARD_STOP;
        config.profile.homing = HomingConfig {
            vendor_methods: &VENDOR_METHODS,
            hard_stop_object: Some(0x2500),
            ..HomingConfig::new()
        };
        config
    });
    write_sub(&mut bench, 0x2500, 1, &300u16.to_le_bytes());
    write_sub(&mut bench, 0x2500, 2, &20u16.to_le_bytes());
    write_sub(&mut bench, 0x2500, 3, &200u32.to_le_bytes());
    enable(&mut bench, HM);
    bench
}

fn stops_only() -> MotorParams {
    MotorParams { negative_limit_switch: None, positive_limit_switch: None, ..axis() }
}

#[test]
fn hard_stop_homing_finds_the_stop_and_backs_off() {
    for start in [-8000, 0, 8000] {
        let mut bench = hard_stop_bench(stops_only(), start);
        let run = home(&mut bench, -1, 60);
        assert_eq!(run.statuses.last(), Some(&(0, 1, 1)), "{run:?}");
        assert!((run.home - 12_000).abs() <= 5, "home at the stop: {run:?}");
        assert!(run.span.1 <= 12_000, "never past the stop");
        let raw = read_i32(&mut bench, 0x6063);
        assert!((raw - 11_800).abs() <= 10, "rests backed off: {raw}");
        assert!((read_i32(&mut bench, 0x6064) + 200).abs() <= 10);
    }
}

#[test]
fn hard_stop_then_index_and_the_midpoints() {
    let mut bench = hard_stop_bench(stops_only(), 0);
    let run = home(&mut bench, -2, 60);
    assert_eq!(run.statuses.last(), Some(&(0, 1, 1)), "{run:?}");
    // Backed off from −12 000 to −11 800, then the next index moving positive: −10 850.
    assert!((run.home + 10_850).abs() <= 2, "{run:?}");

    let mut bench = hard_stop_bench(stops_only(), 3000);
    write_sub(&mut bench, 0x6099, 2, &2000u32.to_le_bytes());
    let run = home(&mut bench, -3, 120);
    assert_eq!(run.statuses.last(), Some(&(0, 1, 1)), "{run:?}");
    assert!(run.home.abs() <= 5, "midway between ±12 000: {run:?}");

    let mut bench = hard_stop_bench(axis(), 3000);
    write_sub(&mut bench, 0x6099, 2, &2000u32.to_le_bytes());
    let run = home(&mut bench, -4, 120);
    assert_eq!(run.statuses.last(), Some(&(0, 1, 1)), "{run:?}");
    assert!(run.home.abs() <= 3, "midway between the limit switches: {run:?}");
}

#[test]
fn vendor_methods_are_accepted_only_when_configured() {
    let mut bench = hard_stop_bench(stops_only(), 0);
    for method in [-1i8, -2, -3, -4] {
        write(&mut bench, 0x6098, &[method as u8]);
    }
    assert_eq!(bench.sdo1(&req(0x2F, 0x6098, 0, [0xFB, 0, 0, 0])), abort(0x6098, 0, 0x0609_0030));
}

#[test]
fn hard_stop_homing_against_elastic_stops_stays_at_the_stop() {
    let params = MotorParams {
        negative_limit_switch: None,
        positive_limit_switch: None,
        ..MotorParams::homing_axis()
    };
    // −1: home at the stop; −2: backed off from −2000 to −1800, then the next index (−850).
    for (method, stop) in [(-1i8, 22_000), (-2, -850)] {
        let mut bench = hard_stop_bench(params, 10_000);
        let run = home(&mut bench, method, 60);
        assert_eq!(run.statuses.last(), Some(&(0, 1, 1)), "{run:?}");
        assert!((run.home - stop).abs() <= 10, "home: {run:?}");
        let penetration = node(&mut bench).motor.max_hard_stop_penetration();
        assert!(penetration < 10.0, "pressed {penetration} increments into the stop");
    }
}

// --- 60E3h supported homing methods -------------------------------------------------------------

fn upload(bench: &mut Bench, index: u16, sub: u8) -> [u8; 8] {
    bench.sdo1(&req(0x40, index, sub, [0; 4]))
}

/// 60E3h as an SDO master reads it: sub 0, then each listed method; the sub-index after the
/// last does not exist.
fn supported_methods(bench: &mut Bench) -> Vec<i8> {
    let r = upload(bench, 0x60E3, 0);
    assert_eq!(r[0], 0x4F, "{r:02X?}");
    let count = r[4];
    let methods = (1..=count)
        .map(|sub| {
            let r = upload(bench, 0x60E3, sub);
            assert_eq!(r[0], 0x4F, "sub {sub}: {r:02X?}");
            r[4] as i8
        })
        .collect();
    let r = upload(bench, 0x60E3, count + 1);
    assert_eq!((r[0], u32::from_le_bytes([r[4], r[5], r[6], r[7]])), (0x80, 0x0609_0011));
    methods
}

#[test]
fn supported_homing_methods_60e3_follow_the_configuration() {
    // CiA 402 default: every standard method this crate runs (37 only with method_37).
    let mut bench = Bench::new();
    let standard: Vec<i8> = (1..=14).chain(17..=30).chain(33..=36).collect();
    assert_eq!(supported_methods(&mut bench), standard);
    let r = bench.sdo1(&req(0x2F, 0x60E3, 1, [5, 0, 0, 0]));
    assert_eq!(u32::from_le_bytes([r[4], r[5], r[6], r[7]]), 0x0601_0002, "constant");

    // A vendor's choice: fewer standard methods, 37, and its own negative methods first.
    let mut bench = Bench::with_config(|mut config| {
        config.manufacturer_objects = &HARD_STOP;
        config.profile.homing = HomingConfig {
            method_37: true,
            standard_methods: (1 << 1) | (1 << 17) | (1 << 35) | (1 << 37),
            vendor_methods: &VENDOR_METHODS,
            hard_stop_object: Some(0x2500),
            ..HomingConfig::new()
        };
        config
    });
    assert_eq!(supported_methods(&mut bench), [-4, -3, -2, -1, 1, 17, 35, 37]);
    // Every listed method is accepted by 6098h.
    for method in supported_methods(&mut bench) {
        write(&mut bench, 0x6098, &[method as u8]);
    }
}

#[test]
fn the_homing_speeds_are_held_within_the_maximum_profile_velocity() {
    let mut bench = enabled_hm(scene(17), 0);
    write(&mut bench, 0x607F, &1000u32.to_le_bytes()); // below the search speed 6099h sub 1
    write(&mut bench, 0x6098, &[17]);
    cw(&mut bench, 0x001F, 0);
    let mut fastest = 0;
    for _ in 0..100 {
        bench.advance(Duration::from_millis(10));
        fastest = fastest.max(od_i32(&mut bench, 0x606B).unsigned_abs());
    }
    assert!(fastest <= 1000, "velocity demand {fastest} above 607Fh");
    assert!(fastest >= 990, "searching at the capped speed, not slower ({fastest})");
    assert!(od_i32(&mut bench, 0x6064) < -900, "moving toward the negative limit switch");
}

#[test]
fn complete_only_at_rest_on_home() {
    // Issue 18 (1), digest §10.4: 0/1/1 means the axis rests on home. The first tick that
    // reports it must see the shaft within the position window 6067h of home and still
    // (606Ch within 606Fh); the demand arriving is "attained" (0/1/0) at most.
    let mut bench = enabled_hm(axis(), 2000);
    write(&mut bench, 0x6098, &[17]);
    cw(&mut bench, 0x001F, 0);
    let window = od_u32(&mut bench, 0x6067) as i32;
    let mut attained_moving = false;
    for _ in 0..20_000 {
        bench.advance(Duration::from_millis(1));
        let status = homing_status(sw(&mut bench));
        let (position, velocity) = (od_i32(&mut bench, 0x6064), od_i32(&mut bench, 0x606C));
        if status == (0, 1, 0) && velocity != 0 {
            attained_moving = true;
        }
        if status == (0, 1, 1) {
            // Home is the negative limit switch's release (−10 000): 6064h reads 0 there.
            assert_eq!(velocity, 0, "606Ch when complete");
            assert!(position.abs() <= window, "6064h = {position} when complete");
            assert!(attained_moving, "the shaft's last motion was reported as attained, not complete");
            return;
        }
    }
    panic!("homing never completed");
}

//! Profile position mode, the position control function and the factor group on the virtual
//! bus with the simulated motor: sections I, J and K of `docs/testing.md` (and
//! the pp items of B and H). Tests are named after the items they check.

mod common;

use common::profile::*;
use common::*;

use canopen_drive::hal::Setpoint;
use canopen_drive::Duration;
use embedded_can::Frame;

const PP: u8 = 1;
const PV: u8 = 3;

/// One millisecond (one tick).
fn tick(bench: &mut Bench) {
    bench.advance(Duration::from_millis(1));
}

/// One sample per tick: (position demand 6062h, velocity demand 606Bh, statusword).
#[derive(Clone, Copy, Debug)]
struct Tick {
    demand: i32,
    velocity: i32,
    statusword: u16,
}

fn run(bench: &mut Bench, ms: usize) -> Vec<Tick> {
    (0..ms)
        .map(|_| {
            tick(bench);
            Tick { demand: od_i32(bench, 0x6062), velocity: od_i32(bench, 0x606B), statusword: sw(bench) }
        })
        .collect()
}

/// Runs until the statusword shows target reached (bit 10) with no set-point pending, at most
/// `ms` ticks; returns the samples.
fn run_to_target(bench: &mut Bench, ms: usize) -> Vec<Tick> {
    let mut ticks = Vec::new();
    for _ in 0..ms {
        tick(bench);
        let t =
            Tick { demand: od_i32(bench, 0x6062), velocity: od_i32(bench, 0x606B), statusword: sw(bench) };
        ticks.push(t);
        if t.statusword & 0x0400 != 0 {
            return ticks;
        }
    }
    panic!("target not reached in {ms} ms; last {:?}", ticks.last());
}

/// pp enabled at rest with fast but bounded ramps (user units = increments).
fn pp_bench() -> Bench {
    let mut bench = Bench::new();
    setup_ramps(&mut bench, 20_000, 200_000);
    enable(&mut bench, PP);
    bench
}

fn setup_ramps(bench: &mut Bench, velocity: u32, acceleration: u32) {
    write(bench, 0x6081, &velocity.to_le_bytes());
    write(bench, 0x6083, &acceleration.to_le_bytes());
    write(bench, 0x6084, &acceleration.to_le_bytes());
    write(bench, 0x60C5, &u32::MAX.to_le_bytes());
    write(bench, 0x60C6, &u32::MAX.to_le_bytes());
}

/// Writes 607Ah and raises bit 4 with the given extra bits (5 immediate, 6 relative, 9 change
/// on set-point), runs one tick, then clears bit 4 again (one tick).
fn setpoint(bench: &mut Bench, target: i32, bits: u16) {
    write(bench, 0x607A, &target.to_le_bytes());
    cw(bench, 0x000F | bits, 0);
    cw(bench, 0x001F | bits, 1);
    cw(bench, 0x000F | bits, 1);
}

// --- B, H: set-points and edges around enabling ---------------------------------------------

#[test]
fn b_23_transition_4_clears_buffered_setpoints() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 50_000, 0);
    setpoint(&mut bench, -50_000, 0);
    assert_eq!(sw(&mut bench) & 0x1000, 0x1000, "buffer full");
    cw(&mut bench, 0x0007, 400); // disable operation: ramps down, Switched on
    assert!(is(&mut bench, SO));
    cw(&mut bench, 0x000F, 2);
    assert!(is(&mut bench, OE));
    assert_eq!(sw(&mut bench) & 0x1000, 0, "no set-point after re-entering OE");
    let still = od_i32(&mut bench, 0x6062);
    let after = run(&mut bench, 300);
    assert!(after.iter().all(|t| t.demand == still), "nothing executed after transition 4");
}

#[test]
fn h_74_entering_operation_with_bit_4_set_starts_nothing() {
    let mut bench = Bench::new();
    write(&mut bench, 0x6060, &[PP]);
    write(&mut bench, 0x607A, &5000i32.to_le_bytes());
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x001F, 2);
    assert!(is(&mut bench, OE));
    let ticks = run(&mut bench, 100);
    assert!(ticks.iter().all(|t| t.demand == 0 && t.statusword & 0x1000 == 0));
}

#[test]
fn h_73_switching_into_pp_with_bit_4_held_starts_nothing() {
    let mut bench = Bench::new();
    enable(&mut bench, PV);
    write(&mut bench, 0x607A, &5000i32.to_le_bytes());
    cw(&mut bench, 0x001F, 2);
    write(&mut bench, 0x6060, &[PP]);
    let ticks = run(&mut bench, 100);
    assert!(ticks.iter().all(|t| t.demand == 0));
    // A new edge does start it.
    cw(&mut bench, 0x000F, 1);
    cw(&mut bench, 0x001F, 1);
    assert_eq!(sw(&mut bench) & 0x1000, 0x1000);
}

// --- I: factor group and polarity ------------------------------------------------------------

/// 4096 increments/rev, gear 10:1, 360 000 user units per output revolution (items 75, 76).
fn digest_factors(bench: &mut Bench) {
    write_sub(bench, 0x608F, 1, &4096u32.to_le_bytes());
    write_sub(bench, 0x6091, 1, &10u32.to_le_bytes());
    write_sub(bench, 0x6092, 1, &360_000u32.to_le_bytes());
}

#[test]
fn i_75_i_76_i_113_factor_group_converts_both_ways() {
    let mut bench = Bench::new();
    digest_factors(&mut bench);
    node(&mut bench).motor.set_position(40_960);
    bench.advance(Duration::from_millis(2));
    assert_eq!(read_i32(&mut bench, 0x6063), 40_960);
    assert_eq!(read_i32(&mut bench, 0x6064), 360_000);
    // User-unit ramps: 1 output revolution per second = 360 000 user units/s.
    setup_ramps(&mut bench, 360_000, 3_600_000);
    enable(&mut bench, PP);
    setpoint(&mut bench, 180_000, 0);
    let ticks = run_to_target(&mut bench, 3000);
    assert_eq!(ticks.last().unwrap().demand, 180_000);
    assert_eq!(read_i32(&mut bench, 0x60FC), 20_480, "i_76: 607Ah 180000 is 20480 increments");
    // k_113: 60FCh is 6062h in increments on every tick of the move.
    let mut bench = Bench::new();
    digest_factors(&mut bench);
    setup_ramps(&mut bench, 360_000, 3_600_000);
    enable(&mut bench, PP);
    setpoint(&mut bench, 100_000, 0);
    for _ in 0..200 {
        tick(&mut bench);
        let user = i64::from(od_i32(&mut bench, 0x6062));
        let internal = i64::from(od_i32(&mut bench, 0x60FC));
        // user = internal × 360000/40960: within half a user increment of rounding.
        assert!((internal * 360_000 - user * 40_960).abs() <= 40_960 / 2 + 360_000, "{internal} {user}");
    }
}

#[test]
fn i_77_i_78_factor_group_refuses_zero_and_sub_0_is_constant() {
    let mut bench = Bench::new();
    for index in [0x608F, 0x6090, 0x6091, 0x6092] {
        for sub in [1, 2] {
            assert_eq!(bench.sdo1(&req(0x23, index, sub, [0; 4])), abort(index, sub, 0x0609_0032));
            assert_eq!(bench.sdo1(&req(0x40, index, sub, [0; 4])), req(0x43, index, sub, [1, 0, 0, 0]));
        }
    }
    for index in [0x607B, 0x607D, 0x608F, 0x6090, 0x6091, 0x6092] {
        assert_eq!(bench.sdo1(&req(0x40, index, 0, [0; 4])), req(0x4F, index, 0, [2, 0, 0, 0]));
        assert_eq!(bench.sdo1(&req(0x2F, index, 0, [2, 0, 0, 0])), abort(index, 0, 0x0601_0002));
    }
}

#[test]
fn i_79_conversion_of_the_largest_position_saturates() {
    let mut bench = Bench::new();
    digest_factors(&mut bench);
    node(&mut bench).motor.set_position(i32::MAX);
    bench.advance(Duration::from_millis(2));
    assert_eq!(read_i32(&mut bench, 0x6063), i32::MAX);
    // 2³¹−1 increments are 1.9·10¹⁰ user units: 6064h shows the largest INTEGER32.
    assert_eq!(read_i32(&mut bench, 0x6064), i32::MAX);
}

#[test]
fn i_80_i_83_position_polarity_mirrors_pp_and_velocity_polarity_does_not() {
    let mut bench = Bench::new();
    write(&mut bench, 0x607E, &[0x80]);
    setup_ramps(&mut bench, 20_000, 200_000);
    enable(&mut bench, PP);
    setpoint(&mut bench, 1000, 0);
    let ticks = run_to_target(&mut bench, 1000);
    assert!(ticks.iter().all(|t| t.demand >= 0), "6062h in the master's frame");
    assert_eq!(read_i32(&mut bench, 0x60FC), -1000, "i_80: internal demand negative");
    bench.advance(Duration::from_millis(300));
    let actual = read_i32(&mut bench, 0x6064);
    assert!((actual - 1000).abs() <= 100, "6064h ends at +1000 as the master sees it: {actual}");

    // i_83: velocity polarity has no effect on positioning.
    let mut bench = Bench::new();
    write(&mut bench, 0x607E, &[0x40]);
    setup_ramps(&mut bench, 20_000, 200_000);
    enable(&mut bench, PP);
    setpoint(&mut bench, 1000, 0);
    run_to_target(&mut bench, 1000);
    assert_eq!(read_i32(&mut bench, 0x60FC), 1000);
}

#[test]
fn i_82_velocity_polarity_negates_pv() {
    let mut bench = Bench::new();
    write(&mut bench, 0x607E, &[0x40]);
    enable(&mut bench, PV);
    write(&mut bench, 0x60FF, &100i32.to_le_bytes());
    bench.advance(Duration::from_millis(50));
    assert!(matches!(node(&mut bench).demand.setpoint, Setpoint::Velocity(v) if v == -100));
    assert_eq!(read_i32(&mut bench, 0x606B), 100, "606Bh in the master's frame");
}

#[test]
fn i_84_polarity_defaults_to_0_and_reserved_bits_are_refused() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x607E, 0, [0; 4])), req(0x4F, 0x607E, 0, [0; 4]));
    for value in [0x01u8, 0x20, 0xC1] {
        assert_eq!(bench.sdo1(&req(0x2F, 0x607E, 0, [value, 0, 0, 0])), abort(0x607E, 0, 0x0609_0030));
    }
}

// --- J: profile position ---------------------------------------------------------------------

#[test]
fn j_85_a_target_without_an_edge_does_not_move() {
    let mut bench = pp_bench();
    write(&mut bench, 0x607A, &10_000i32.to_le_bytes());
    let ticks = run(&mut bench, 100);
    assert!(ticks.iter().all(|t| t.demand == 0 && t.velocity == 0));
    assert!(matches!(node(&mut bench).demand.setpoint, Setpoint::Position(0)));
}

#[test]
fn j_86_j_87_j_88_setpoint_handshake() {
    let mut bench = pp_bench();
    write(&mut bench, 0x607A, &10_000i32.to_le_bytes());
    cw(&mut bench, 0x002F, 1);
    cw(&mut bench, 0x003F, 1);
    let status = sw(&mut bench);
    assert_eq!(status & 0x1400, 0x1000, "j_86: acknowledged, target not reached");
    tick(&mut bench);
    assert!(od_i32(&mut bench, 0x606B) > 0, "moving");
    cw(&mut bench, 0x002F, 1);
    assert_eq!(sw(&mut bench) & 0x1000, 0, "j_87: acknowledge cleared with bit 4");
    // j_88: bit 4 held after arrival starts nothing new.
    cw(&mut bench, 0x003F, 1);
    run_to_target(&mut bench, 2000);
    write(&mut bench, 0x607A, &0i32.to_le_bytes());
    let ticks = run(&mut bench, 100);
    assert!(ticks.iter().all(|t| t.demand == 10_000));
}

/// Moves to `target` and returns the tick at which the trajectory arrived plus the samples.
fn arrive(bench: &mut Bench, target: i32) -> usize {
    setpoint(bench, target, 0);
    for n in 0..5000 {
        tick(bench);
        if od_i32(bench, 0x6062) == target && od_i32(bench, 0x606B) == 0 {
            return n;
        }
    }
    panic!("no arrival");
}

#[test]
fn j_89_j_90_target_reached_needs_the_window_time() {
    let mut bench = pp_bench();
    write(&mut bench, 0x6067, &10u32.to_le_bytes());
    write(&mut bench, 0x6068, &20u16.to_le_bytes());
    // A 5-increment move: the actual position is inside the window all the time.
    arrive(&mut bench, 5);
    let ticks = run(&mut bench, 20);
    let reached: Vec<bool> = ticks.iter().map(|t| t.statusword & 0x0400 != 0).collect();
    assert!(reached[..18].iter().all(|r| !r), "not before 20 ms: {reached:?}");
    assert!(reached[19], "set at 20 ms of presence: {reached:?}");
    // j_90: leaving the window restarts the timer.
    node(&mut bench).motor.set_position(500);
    tick(&mut bench);
    assert_eq!(sw(&mut bench) & 0x0400, 0);
    node(&mut bench).motor.set_position(5);
    let ticks = run(&mut bench, 25);
    let first = ticks.iter().position(|t| t.statusword & 0x0400 != 0).unwrap();
    assert!(first >= 19, "the 20 ms start again: {first}");
}

#[test]
fn j_91_window_off_reports_on_arrival_of_the_demand() {
    let mut bench = pp_bench();
    write(&mut bench, 0x6067, &u32::MAX.to_le_bytes());
    write(&mut bench, 0x6068, &50u16.to_le_bytes());
    arrive(&mut bench, 10_000);
    let status = sw(&mut bench);
    let actual = read_i32(&mut bench, 0x6064);
    assert_eq!(status & 0x0400, 0x0400, "bit 10 with the demand at the target");
    assert_ne!(actual, 10_000, "while the motor still lags");
}

#[test]
fn j_92_single_setpoint_replans_at_once() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 100_000, 0);
    let ticks = run(&mut bench, 300);
    assert!(ticks.last().unwrap().velocity > 0);
    let v0 = od_i32(&mut bench, 0x606B);
    setpoint(&mut bench, -5000, 0x0020);
    // One tick for the edge, one to release bit 4: already slowing down.
    assert!(od_i32(&mut bench, 0x606B) < v0, "slowing towards the new target behind");
    let ticks = run_to_target(&mut bench, 5000);
    assert!(ticks.iter().rev().skip(1).all(|t| t.statusword & 0x0400 == 0));
    assert_eq!(ticks.last().unwrap().demand, -5000);
    assert!(ticks.iter().any(|t| t.velocity < 0), "reversed");
}

#[test]
fn j_93_set_of_setpoints_stops_at_each_target() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 5000, 0);
    setpoint(&mut bench, 10_000, 0);
    assert_eq!(sw(&mut bench) & 0x1000, 0x1000, "buffer occupied");
    let ticks = run_to_target(&mut bench, 5000);
    let stop = ticks.iter().position(|t| t.demand == 5000 && t.velocity == 0);
    assert!(stop.is_some(), "stopped at the first target");
    assert!(ticks[..ticks.len() - 1].iter().all(|t| t.statusword & 0x0400 == 0), "bit 10 only at the end");
    assert_eq!(ticks.last().unwrap().demand, 10_000);
}

#[test]
fn j_94_change_on_setpoint_passes_the_first_target_at_speed() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 5000, 0x0200);
    setpoint(&mut bench, 10_000, 0x0200);
    let ticks = run_to_target(&mut bench, 5000);
    let passing = ticks.iter().find(|t| t.demand >= 5000).unwrap();
    assert!(passing.velocity >= 19_000, "passes 5000 at the profile velocity: {passing:?}");
    assert!(ticks.iter().all(|t| t.velocity >= 0));
    let last = ticks.last().unwrap();
    assert_eq!((last.demand, last.velocity), (10_000, 0));
}

#[test]
fn j_95_immediate_setpoint_discards_the_buffer() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 5000, 0);
    setpoint(&mut bench, 20_000, 0);
    assert_eq!(sw(&mut bench) & 0x1000, 0x1000);
    setpoint(&mut bench, 1000, 0x0020);
    let ticks = run_to_target(&mut bench, 5000);
    assert_eq!(ticks.last().unwrap().demand, 1000);
    let ticks = run(&mut bench, 500);
    assert!(ticks.iter().all(|t| t.demand == 1000), "20000 never runs");
}

#[test]
fn j_96_full_buffer_refuses_a_queued_setpoint() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 5000, 0);
    setpoint(&mut bench, 8000, 0);
    setpoint(&mut bench, 30_000, 0);
    assert_eq!(sw(&mut bench) & 0x1000, 0x1000, "still occupied by 8000");
    let ticks = run_to_target(&mut bench, 5000);
    assert_eq!(ticks.last().unwrap().demand, 8000);
    let ticks = run(&mut bench, 300);
    assert!(ticks.iter().all(|t| t.demand == 8000), "30000 was not taken");
}

#[test]
fn j_97_relative_to_the_preceding_target() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 1000, 0x0040);
    setpoint(&mut bench, 1000, 0x0060);
    let ticks = run_to_target(&mut bench, 5000);
    assert_eq!(ticks.last().unwrap().demand, 2000);
}

#[test]
fn j_98_relative_to_the_actual_position() {
    let mut bench = Bench::new();
    setup_ramps(&mut bench, 20_000, 200_000);
    write(&mut bench, 0x60F2, &2u16.to_le_bytes());
    node(&mut bench).motor.set_position(350);
    enable(&mut bench, PP);
    setpoint(&mut bench, 1000, 0x0040);
    let ticks = run_to_target(&mut bench, 5000);
    assert_eq!(ticks.last().unwrap().demand, 1350);
}

#[test]
fn j_99_relative_to_the_position_demand() {
    let mut bench = pp_bench();
    write(&mut bench, 0x60F2, &1u16.to_le_bytes());
    setpoint(&mut bench, 100_000, 0);
    bench.advance(Duration::from_millis(100));
    write(&mut bench, 0x607A, &1000i32.to_le_bytes());
    cw(&mut bench, 0x006F, 0);
    let demand = read_i32(&mut bench, 0x6062);
    cw(&mut bench, 0x007F, 1);
    cw(&mut bench, 0x006F, 1);
    let ticks = run_to_target(&mut bench, 5000);
    assert_eq!(ticks.last().unwrap().demand, demand + 1000);
}

#[test]
fn j_100_unimplemented_positioning_options_are_refused() {
    let mut bench = Bench::new();
    for value in [0x0003u16, 0x0004, 0x0008, 0x0010, 0x0020, 0x0100, 0x8000] {
        let [lo, hi] = value.to_le_bytes();
        assert_eq!(bench.sdo1(&req(0x2B, 0x60F2, 0, [lo, hi, 0, 0])), abort(0x60F2, 0, 0x0609_0030));
    }
    write(&mut bench, 0x60F2, &2u16.to_le_bytes());
}

#[test]
fn j_101_j_102_halt_and_resume() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 40_000, 0);
    bench.advance(Duration::from_millis(300));
    cw(&mut bench, 0x010F, 0);
    let ticks = run(&mut bench, 200);
    let stopped = ticks.iter().position(|t| t.velocity == 0).expect("stops");
    assert!(ticks[..stopped].iter().all(|t| t.statusword & 0x0400 == 0), "decelerating: bit 10 = 0");
    assert!(ticks[stopped..].iter().all(|t| t.statusword & 0x0400 != 0), "at rest: bit 10 = 1");
    assert!(is(&mut bench, OE));
    let held = od_i32(&mut bench, 0x6062);
    assert!(held < 40_000);
    cw(&mut bench, 0x000F, 0);
    let ticks = run_to_target(&mut bench, 5000);
    assert!(ticks[..ticks.len() - 1].iter().all(|t| t.statusword & 0x0400 == 0));
    assert_eq!(ticks.last().unwrap().demand, 40_000);
}

#[test]
fn j_103_velocity_never_exceeds_the_smallest_limit() {
    let mut bench = Bench::new();
    // 10 000 increments per revolution and user units = increments.
    write_sub(&mut bench, 0x608F, 1, &10_000u32.to_le_bytes());
    write_sub(&mut bench, 0x6092, 1, &10_000u32.to_le_bytes());
    setup_ramps(&mut bench, 50_000, 200_000);
    write(&mut bench, 0x607F, &30_000u32.to_le_bytes());
    write(&mut bench, 0x6080, &90u32.to_le_bytes()); // 90 rpm = 15 000 increments/s
    enable(&mut bench, PP);
    setpoint(&mut bench, 60_000, 0);
    let ticks = run_to_target(&mut bench, 10_000);
    let top = ticks.iter().map(|t| t.velocity).max().unwrap();
    // The planner cruises a hair under the limit (it fits the peak so the target is exact).
    assert!((14_950..=15_000).contains(&top), "cruise at min(6081h, 607Fh, 6080h): {top}");
}

#[test]
fn j_104_ramps_never_exceed_60c5_60c6() {
    let mut bench = Bench::new();
    setup_ramps(&mut bench, 20_000, 100_000);
    write(&mut bench, 0x60C5, &20_000u32.to_le_bytes());
    write(&mut bench, 0x60C6, &40_000u32.to_le_bytes());
    enable(&mut bench, PP);
    setpoint(&mut bench, 30_000, 0);
    let ticks = run_to_target(&mut bench, 10_000);
    for pair in ticks.windows(2) {
        let dv = pair[1].velocity - pair[0].velocity;
        assert!((-41..=21).contains(&dv), "{dv} per ms");
    }
}

#[test]
fn j_105_j_106_software_limits_corrected_by_the_home_offset() {
    let mut bench = pp_bench();
    write_sub(&mut bench, 0x607D, 1, &(-5000i32).to_le_bytes());
    write_sub(&mut bench, 0x607D, 2, &10_000i32.to_le_bytes());
    write(&mut bench, 0x607C, &2000i32.to_le_bytes());
    setpoint(&mut bench, 9000, 0);
    let ticks = run_to_target(&mut bench, 5000);
    assert_eq!(ticks.last().unwrap().demand, 8000);
    assert_eq!(sw(&mut bench) & 0x0800, 0x0800, "j_106: internal limit active");
    setpoint(&mut bench, -8000, 0);
    let ticks = run_to_target(&mut bench, 5000);
    assert_eq!(ticks.last().unwrap().demand, -7000);
    setpoint(&mut bench, 0, 0);
    run_to_target(&mut bench, 5000);
    assert_eq!(sw(&mut bench) & 0x0800, 0, "a target inside the limits clears bit 11");
}

#[test]
fn j_107_position_range_limit_wraps_the_target() {
    let mut bench = pp_bench();
    write_sub(&mut bench, 0x607B, 1, &0i32.to_le_bytes());
    write_sub(&mut bench, 0x607B, 2, &3599i32.to_le_bytes());
    setpoint(&mut bench, 1000, 0);
    run_to_target(&mut bench, 5000);
    setpoint(&mut bench, 3600, 0);
    assert_eq!(run_to_target(&mut bench, 5000).last().unwrap().demand, 0);
    setpoint(&mut bench, -1, 0);
    assert_eq!(run_to_target(&mut bench, 5000).last().unwrap().demand, 3599);
}

#[test]
fn j_109_defaults_after_reset() {
    let mut bench = Bench::new();
    assert_eq!(bench.sdo1(&req(0x40, 0x6082, 0, [0; 4])), req(0x43, 0x6082, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x6086, 0, [0; 4])), req(0x4B, 0x6086, 0, [0; 4]));
    assert_eq!(bench.sdo1(&req(0x40, 0x60F2, 0, [0; 4])), req(0x4B, 0x60F2, 0, [0; 4]));
    // 6086h: trapezoidal (0) and jerk-limited (3) only.
    for value in [1u8, 2, 4, 0xFF] {
        assert_eq!(bench.sdo1(&req(0x2B, 0x6086, 0, [value, 0, 0, 0])), abort(0x6086, 0, 0x0609_0030));
    }
}

#[test]
fn j_jerk_limited_move_arrives_exactly() {
    let mut bench = pp_bench();
    write(&mut bench, 0x6086, &3i16.to_le_bytes());
    write_sub(&mut bench, 0x60A4, 1, &2_000_000u32.to_le_bytes());
    setpoint(&mut bench, 25_000, 0);
    let ticks = run_to_target(&mut bench, 5000);
    assert_eq!(ticks.last().unwrap().demand, 25_000);
    // The acceleration changes by at most jerk·dt² per tick: 2·10⁶/s³ → 2 increments/s per ms².
    for w in ticks.windows(3) {
        let jerk = (w[2].velocity - w[1].velocity) - (w[1].velocity - w[0].velocity);
        assert!(jerk.abs() <= 3, "{jerk}");
    }
}

// --- K: position control function ------------------------------------------------------------

#[test]
fn k_110_k_112_following_error_window_and_time() {
    let mut bench = pp_bench();
    write(&mut bench, 0x6065, &100u32.to_le_bytes());
    write(&mut bench, 0x6066, &10u16.to_le_bytes());
    // Block the motor: a load above the power stage's torque limit.
    node(&mut bench).motor.set_load_torque(-5000.0);
    setpoint(&mut bench, 10_000, 0);
    let mut outside = None;
    for n in 0..200 {
        tick(&mut bench);
        let error = od_i32(&mut bench, 0x60F4);
        let expected = od_i32(&mut bench, 0x6062) - od_i32(&mut bench, 0x6064);
        assert_eq!(error, expected, "k_112: 60F4h = 6062h − 6064h");
        let bit13 = sw(&mut bench) & 0x2000 != 0;
        match outside {
            None if error.abs() > 100 => {
                outside = Some(n);
                assert!(!bit13);
            }
            None => assert!(!bit13, "within the window"),
            Some(first) if n - first <= 10 => assert!(!bit13, "not before 10 ms ({})", n - first),
            Some(_) => assert!(bit13, "after 10 ms"),
        }
    }
    assert!(outside.is_some());
}

#[test]
fn k_111_following_error_monitoring_off() {
    let mut bench = pp_bench();
    write(&mut bench, 0x6065, &u32::MAX.to_le_bytes());
    node(&mut bench).motor.set_load_torque(-5000.0);
    setpoint(&mut bench, 10_000, 0);
    let ticks = run(&mut bench, 300);
    assert!(od_i32(&mut bench, 0x60F4) > 1000);
    assert!(ticks.iter().all(|t| t.statusword & 0x2000 == 0));
}

#[test]
fn k_114_following_error_is_sent_in_the_same_tpdo_cycle() {
    let mut bench = pp_bench();
    write(&mut bench, 0x6065, &100u32.to_le_bytes());
    write(&mut bench, 0x6066, &0u16.to_le_bytes());
    bench.send(frame(0x000, &[0x01, NODE]));
    node(&mut bench).motor.set_load_torque(-5000.0);
    setpoint(&mut bench, 10_000, 0);
    let mut seen = None;
    for _ in 0..100 {
        let frames = bench.advance_timed(Duration::from_millis(1));
        if sw(&mut bench) & 0x2000 != 0 {
            let now = bench.now();
            let tpdo = frames.iter().find(|(_, f)| f.standard_id() == Some(0x180 + u16::from(NODE)));
            let (time, f) = tpdo.expect("TPDO 1 in the tick bit 13 rose");
            assert_eq!(*time, now);
            assert_eq!(u16::from_le_bytes([f.data()[0], f.data()[1]]) & 0x2000, 0x2000);
            seen = Some(now);
            break;
        }
    }
    assert!(seen.is_some());
}

#[test]
fn k_115_following_error_fault_when_configured() {
    let mut bench = Bench::with_config(|mut config| {
        config.profile.following_error_fault = true;
        config
    });
    setup_ramps(&mut bench, 20_000, 200_000);
    enable(&mut bench, PP);
    write(&mut bench, 0x6065, &100u32.to_le_bytes());
    write(&mut bench, 0x6066, &5u16.to_le_bytes());
    node(&mut bench).motor.set_load_torque(-5000.0);
    setpoint(&mut bench, 10_000, 0);
    let frames = bench.advance(Duration::from_millis(100));
    let emcy = frames.iter().find(|f| f.standard_id() == Some(0x80 + u16::from(NODE))).expect("EMCY");
    assert_eq!(emcy.data()[..2], [0x11, 0x86]);
    assert_eq!(bench.drive().od().get::<u16>(0x603F, 0), Ok(0x8611));
    assert!(is(&mut bench, FAULT) || is(&mut bench, FRA));
}

// --- The core's cascaded loops (ProfileConfig::cascade) ----------------------------------------

static CASCADE_OBJECTS: [canopen_drive::od::Object; 1] =
    canopen_drive::od::layout([canopen_drive::control::object(0x2400)]);

fn cascade_bench() -> Bench {
    let mut bench = Bench::with_config(|mut config| {
        config.manufacturer_objects = &CASCADE_OBJECTS;
        config.profile.cascade = Some(0x2400);
        config
    });
    // Velocity loop 100/s on the simulated axis (1000 increments/s² per ‰): 0.1 ‰ per
    // increment/s in Q8.24; integral time 20 ms; position loop 20/s.
    write_sub(&mut bench, 0x2400, 2, &1_677_722u32.to_le_bytes());
    write_sub(&mut bench, 0x2400, 1, &(20u32 << 16).to_le_bytes());
    bench
}

#[test]
fn cascade_turns_pp_into_torque_demands_and_reaches_the_target() {
    let mut bench = cascade_bench();
    setup_ramps(&mut bench, 20_000, 200_000);
    enable(&mut bench, PP);
    setpoint(&mut bench, 30_000, 0);
    tick(&mut bench);
    assert!(matches!(node(&mut bench).demand.setpoint, Setpoint::Torque(t) if t > 0));
    assert!(od_i32(&mut bench, 0x60FA) > 0, "60FAh: the velocity command");
    run_to_target(&mut bench, 5000);
    bench.advance(Duration::from_millis(300));
    let actual = read_i32(&mut bench, 0x6064);
    assert!((actual - 30_000).abs() <= 20, "settles on the target: {actual}");
    // Torque limit 6072h holds for the loop's output too.
    write(&mut bench, 0x6072, &50u16.to_le_bytes());
    setpoint(&mut bench, -30_000, 0);
    for _ in 0..300 {
        tick(&mut bench);
        assert!(matches!(node(&mut bench).demand.setpoint, Setpoint::Torque(t) if t.abs() <= 50));
    }
}

#[test]
fn cascade_runs_the_velocity_loop_in_pv_and_refuses_bad_gains() {
    let mut bench = cascade_bench();
    enable(&mut bench, PV);
    write(&mut bench, 0x60FF, &5000i32.to_le_bytes());
    bench.advance(Duration::from_millis(1500));
    let velocity = read_i32(&mut bench, 0x606C);
    assert!((velocity - 5000).abs() <= 50, "{velocity}");
    assert!(matches!(node(&mut bench).demand.setpoint, Setpoint::Torque(_)));
    // A zero gain is refused with the object's own limit.
    assert_eq!(bench.sdo1(&req(0x23, 0x2400, 2, [0; 4])), abort(0x2400, 2, 0x0609_0032));
}

// --- DESIGN invariant 2 under random set-points -----------------------------------------------

#[test]
fn random_setpoints_halts_and_replans_never_exceed_the_limits() {
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move |range: u64| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed % range
    };
    for profile in [0i16, 3] {
        let mut bench = Bench::new();
        setup_ramps(&mut bench, 60_000, 400_000);
        write(&mut bench, 0x607F, &25_000u32.to_le_bytes());
        write(&mut bench, 0x60C5, &150_000u32.to_le_bytes());
        write(&mut bench, 0x60C6, &200_000u32.to_le_bytes());
        write(&mut bench, 0x6086, &profile.to_le_bytes());
        write_sub(&mut bench, 0x60A4, 1, &20_000_000u32.to_le_bytes());
        enable(&mut bench, PP);
        let mut last = 0i32;
        for step in 0..300 {
            let target = next(200_000) as i32 - 100_000;
            let bits = [0x0020u16, 0x0000, 0x0200, 0x0060][next(4) as usize];
            if next(5) == 0 {
                cw(&mut bench, 0x010F, 0); // halt
            } else {
                write(&mut bench, 0x6081, &(5_000 + next(60_000) as u32).to_le_bytes());
                write(&mut bench, 0x607A, &target.to_le_bytes());
                cw(&mut bench, 0x001F | bits, 0);
            }
            for n in 0..next(150) + 2 {
                if n == 1 {
                    cw(&mut bench, 0x000F | bits, 0);
                }
                tick(&mut bench);
                let v = od_i32(&mut bench, 0x606B);
                assert!(v.abs() <= 25_000, "step {step}, profile {profile}: velocity {v} beyond 607Fh");
                let dv = v - last;
                // Speeding up: 60C5h = 150 per ms; slowing down: 60C6h = 200 per ms (+1 rounding).
                let rate = if v.abs() > last.abs() { 151 } else { 201 };
                assert!(dv.abs() <= rate, "step {step}, profile {profile}: {last} → {v} per ms");
                last = v;
            }
        }
    }
}

/// A velocity limit (607Fh) lowered below a running move holds at once: the velocity demand
/// comes down to it at the deceleration and stays there, never rising on the way; a lower
/// profile velocity 6081h alone waits for the next set-point. (Found by the drive_frames
/// fuzzer: the old plan ran on at its speed.)
#[test]
fn a_velocity_limit_lowered_mid_move_holds_at_once() {
    let mut bench = pp_bench();
    setpoint(&mut bench, 1_000_000, 0);
    let ticks = run(&mut bench, 200);
    let cruise = ticks.last().unwrap().velocity;
    assert!(cruise > 19_000, "cruising: {cruise}");
    write(&mut bench, 0x6081, &5_000u32.to_le_bytes());
    let ticks = run(&mut bench, 20);
    assert!(ticks.iter().all(|t| t.velocity == cruise), "6081h waits for the next set-point");
    write(&mut bench, 0x607F, &2_000u32.to_le_bytes());
    let ticks = run(&mut bench, 200);
    assert!(ticks.windows(2).all(|w| w[1].velocity <= w[0].velocity.max(2_000)), "never rising");
    assert!(ticks[150..].iter().all(|t| (0..=2_000).contains(&t.velocity)), "{:?}", &ticks[150..155]);
}

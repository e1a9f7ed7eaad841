//! Velocity mode (vl) on the virtual bus with the simulated motor: the ramp function driven by
//! controlword bits 4–6, the rpm → increments/s conversion through 608Fh, and the stops
//! (section Q of `docs/testing.md`; the ramp arithmetic itself is unit-tested in
//! `cia402::vl`).

mod common;

use common::profile::*;
use common::*;

use canopen_drive::hal::Setpoint;
use canopen_drive::Duration;

fn vl_bench() -> Bench {
    let mut bench = Bench::new();
    // 10 000 increments per revolution: 1 rpm = 10 000 / 60 increments/s.
    write_sub(&mut bench, 0x608F, 1, &10_000u32.to_le_bytes());
    // 6048h: 600 rpm per 1 s.
    write_sub(&mut bench, 0x6048, 1, &600u32.to_le_bytes());
    write_sub(&mut bench, 0x6048, 2, &1u16.to_le_bytes());
    write(&mut bench, 0x6060, &[2]);
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x000F, 2);
    assert!(is(&mut bench, OE));
    bench
}

fn demand(bench: &mut Bench) -> i16 {
    bench.drive().od().get::<i16>(0x6043, 0).unwrap()
}

#[test]
fn q_165_the_ramp_reaches_the_target_and_the_motor_turns() {
    let mut bench = vl_bench();
    write(&mut bench, 0x6042, &300i16.to_le_bytes());
    cw(&mut bench, 0x007F, 250);
    let d = demand(&mut bench);
    assert!((148..=152).contains(&d), "600 rpm/s for 250 ms: {d}");
    bench.advance(Duration::from_millis(500));
    assert_eq!(demand(&mut bench), 300);
    // 300 rpm = 50 000 increments/s to the power stage.
    assert!(matches!(node(&mut bench).demand.setpoint, Setpoint::Velocity(50_000)));
    assert_eq!(statusword(&mut bench) & 0x0400, 0x0400, "ramp output = input");
    bench.advance(Duration::from_millis(300));
    let actual = bench.drive().od().get::<i16>(0x6044, 0).unwrap();
    assert!((295..=305).contains(&actual), "6044h: {actual}");
}

#[test]
fn q_166_q_167_q_168_ramp_bits() {
    let mut bench = vl_bench();
    write(&mut bench, 0x6042, &300i16.to_le_bytes());
    cw(&mut bench, 0x007F, 200);
    let running = demand(&mut bench);
    cw(&mut bench, 0x005F, 200);
    assert_eq!(demand(&mut bench), running, "q_167: bit 5 = 0 freezes the ramp output");
    cw(&mut bench, 0x003F, 100);
    assert!(demand(&mut bench) < running, "q_166: bit 6 = 0 ramps towards 0");
    cw(&mut bench, 0x006F, 2);
    assert_eq!(demand(&mut bench), 0, "q_168: bit 4 = 0, the demand no longer follows the ramp");
}

#[test]
fn q_170_zero_factors_are_refused() {
    let mut bench = vl_bench();
    for (index, sub) in [(0x604Bu16, 1u8), (0x604B, 2), (0x604C, 1), (0x604C, 2)] {
        let data = if index == 0x604B { [0, 0, 0, 0] } else { [0; 4] };
        let command = if index == 0x604B { 0x2B } else { 0x23 };
        assert_eq!(bench.sdo1(&req(command, index, sub, data)), abort(index, sub, 0x0609_0030));
    }
}

#[test]
fn quick_stop_in_vl_uses_604a() {
    let mut bench = vl_bench();
    write_sub(&mut bench, 0x604A, 1, &3000u32.to_le_bytes());
    write_sub(&mut bench, 0x604A, 2, &1u16.to_le_bytes());
    write(&mut bench, 0x6042, &300i16.to_le_bytes());
    cw(&mut bench, 0x007F, 800);
    assert_eq!(demand(&mut bench), 300);
    cw(&mut bench, 0x007B, 50);
    let d = demand(&mut bench);
    assert!((145..=155).contains(&d), "3000 rpm/s for 50 ms: {d}");
    bench.advance(Duration::from_millis(100));
    assert!(is(&mut bench, SOD));
}

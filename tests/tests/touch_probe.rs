//! Touch probe 60B8h–60BDh on the virtual bus with the simulated motor: section M of
//! `docs/testing.md`, and touch-probe homing (method 36).

mod common;

use common::profile::*;
use common::*;

use canopen_drive::hal::DigitalInputs;
use canopen_drive::Duration;
use canopen_drive_sim::motor::{MotorParams, SimMotor};

fn status(bench: &mut Bench) -> u16 {
    let r = bench.sdo1(&req(0x40, 0x60B9, 0, [0; 4]));
    u16::from_le_bytes([r[4], r[5]])
}

fn function(bench: &mut Bench, value: u16) {
    write(bench, 0x60B8, &value.to_le_bytes());
    bench.advance(Duration::from_millis(1));
}

/// Moves the (idle) shaft to `position` and sets `input` to `active`, one tick each.
fn edge(bench: &mut Bench, input: DigitalInputs, position: i32, active: bool) {
    node(bench).motor.set_position(position);
    bench.advance(Duration::from_millis(1));
    node(bench).motor.set_input(input, active);
    bench.advance(Duration::from_millis(1));
}

#[test]
fn m_136_disabled_probe_reports_nothing() {
    let mut bench = Bench::new();
    function(&mut bench, 0x0030);
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 100, true);
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 200, false);
    assert_eq!(status(&mut bench) & 0x0007, 0);
}

#[test]
fn m_137_m_138_first_event_latches_once() {
    let mut bench = Bench::new();
    function(&mut bench, 0x0011);
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 1234, true);
    assert_eq!(read_i32(&mut bench, 0x60BA), 1234);
    assert_eq!(status(&mut bench), 0x0003);
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 2000, false);
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 5678, true);
    assert_eq!(read_i32(&mut bench, 0x60BA), 1234, "m_138: the first event stays");
}

#[test]
fn m_139_continuous_updates_on_every_edge() {
    let mut bench = Bench::new();
    function(&mut bench, 0x0013);
    for position in [100, -300, 777] {
        edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, position, true);
        assert_eq!(read_i32(&mut bench, 0x60BA), position);
        edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, position + 1, false);
    }
}

#[test]
fn m_140_m_141_negative_edge_and_switching_off() {
    let mut bench = Bench::new();
    function(&mut bench, 0x0021);
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 10, true);
    assert_eq!(status(&mut bench), 0x0001, "no rising-edge sampling");
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 420, false);
    assert_eq!(read_i32(&mut bench, 0x60BB), 420);
    assert_eq!(status(&mut bench), 0x0005);
    function(&mut bench, 0x0020);
    assert_eq!(status(&mut bench), 0x0000, "m_141: cleared in the same tick");
}

fn counter(bench: &mut Bench, index: u16) -> u16 {
    let r = bench.sdo1(&req(0x40, index, 0, [0; 4]));
    assert_eq!(r[0], 0x4B, "upload {index:04X}: {r:02X?}");
    u16::from_le_bytes([r[4], r[5]])
}

#[test]
fn edge_counters_60d5_to_60d8_count_latched_edges() {
    let mut bench = Bench::new();
    // Probe 1 continuous on both edges, probe 2 first event on its positive edge.
    function(&mut bench, 0x1133);
    for n in 1..=3u16 {
        edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 100 * i32::from(n), true);
        assert_eq!(counter(&mut bench, 0x60D5), n);
        edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 100 * i32::from(n) + 50, false);
        assert_eq!(counter(&mut bench, 0x60D6), n);
    }
    for _ in 0..2 {
        edge(&mut bench, DigitalInputs::TOUCH_PROBE_2, 7, true);
        edge(&mut bench, DigitalInputs::TOUCH_PROBE_2, 8, false);
    }
    // First event: the second rising edge is not latched, so not counted; no negative sampling.
    assert_eq!((counter(&mut bench, 0x60D7), counter(&mut bench, 0x60D8)), (1, 0));
    // Re-arming probe 2's positive edge restarts its counter; probe 1 counts on.
    function(&mut bench, 0x0133);
    function(&mut bench, 0x1133);
    assert_eq!((counter(&mut bench, 0x60D5), counter(&mut bench, 0x60D7)), (3, 0));
    // Switching probe 1 off keeps its counters; switching it on again restarts them.
    function(&mut bench, 0x1132);
    assert_eq!(counter(&mut bench, 0x60D5), 3);
    function(&mut bench, 0x1133);
    assert_eq!((counter(&mut bench, 0x60D5), counter(&mut bench, 0x60D6)), (0, 0));
    // Read-only, and TPDO-mappable (the master may read them each cycle).
    let r = bench.sdo1(&req(0x2B, 0x60D5, 0, [1, 0, 0, 0]));
    assert_eq!(u32::from_le_bytes([r[4], r[5], r[6], r[7]]), 0x0601_0002);
}

#[test]
fn m_142_probe_2_uses_its_own_bits_and_objects() {
    let mut bench = Bench::new();
    function(&mut bench, 0x3100);
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_2, 900, true);
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_2, 950, false);
    assert_eq!(read_i32(&mut bench, 0x60BC), 900);
    assert_eq!(read_i32(&mut bench, 0x60BD), 950);
    assert_eq!(status(&mut bench), 0x0700);
    // Probe 1's input does nothing for probe 2.
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 1, true);
    assert_eq!(read_i32(&mut bench, 0x60BC), 900);
}

#[test]
fn m_143_index_pulse_as_trigger() {
    let mut bench = Bench::new();
    node(&mut bench).motor = SimMotor::with_params(MotorParams {
        increments_per_revolution: 1000,
        index_position: 150,
        ..MotorParams::default()
    });
    function(&mut bench, 0x0015);
    // The probe input does not trigger it.
    edge(&mut bench, DigitalInputs::TOUCH_PROBE_1, 0, true);
    assert_eq!(status(&mut bench), 0x0001);
    // Turning the shaft over the index at 150 does.
    write(&mut bench, 0x6060, &[3]);
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x000F, 2);
    write(&mut bench, 0x60FF, &200i32.to_le_bytes());
    bench.advance(Duration::from_millis(1500));
    assert_eq!(status(&mut bench), 0x0003);
    let latched = read_i32(&mut bench, 0x60BA);
    assert!((150..=151).contains(&latched), "{latched}");
}

#[test]
fn reserved_function_bits_are_refused() {
    let mut bench = Bench::new();
    for value in [0x0008u16, 0x0800] {
        let [lo, hi] = value.to_le_bytes();
        assert_eq!(bench.sdo1(&req(0x2B, 0x60B8, 0, [lo, hi, 0, 0])), abort(0x60B8, 0, 0x0609_0030));
    }
}

#[test]
fn method_36_homes_on_the_probe() {
    let mut bench = Bench::new();
    write_sub(&mut bench, 0x6099, 2, &500u32.to_le_bytes());
    function(&mut bench, 0x0011);
    write(&mut bench, 0x6060, &[6]);
    write(&mut bench, 0x6098, &[36]);
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x000F, 2);
    cw(&mut bench, 0x001F, 400);
    // The probe switch closes while the axis moves positive.
    node(&mut bench).motor.set_input(DigitalInputs::TOUCH_PROBE_1, true);
    let probe_at = read_i32(&mut bench, 0x6063);
    bench.advance(Duration::from_millis(2000));
    let sw = statusword(&mut bench);
    assert_eq!(sw & 0x3400, 0x1400, "homing completed: {sw:04X}");
    let home = read_i32(&mut bench, 0x6063) - read_i32(&mut bench, 0x6064);
    assert!((home - probe_at).abs() <= 2, "home {home} at the probe {probe_at}");
}

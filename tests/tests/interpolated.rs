//! Interpolated position mode (ip) on the virtual bus with the simulated motor: items 144–148 of
//! `docs/testing.md` (149–153, the buffer itself, are unit tests of
//! `cia402::ip`), plus a ring buffer driven over the bus.

mod common;

use common::profile::*;
use common::*;

use canopen_drive::motion::TickRate;
use canopen_drive::Duration;

const IP: u8 = 7;

fn bench_4k() -> Bench {
    let mut bench = Bench::with_config_and_tick(
        |mut config| {
            config.profile.tick_rate = TickRate::new(4000).unwrap();
            config
        },
        Duration::from_micros(250),
    );
    write(&mut bench, 0x60C5, &u32::MAX.to_le_bytes());
    write(&mut bench, 0x60C6, &u32::MAX.to_le_bytes());
    write(&mut bench, 0x6060, &[IP]);
    cw(&mut bench, 0x0006, 2);
    cw(&mut bench, 0x000F, 2);
    assert!(is(&mut bench, OE));
    bench
}

fn record(bench: &mut Bench, position: i32) {
    write_sub(bench, 0x60C1, 1, &position.to_le_bytes());
}

fn demand(bench: &mut Bench) -> i32 {
    bench.drive().od().get::<i32>(0x6062, 0).unwrap()
}

/// A SYNC and 1 ms.
fn sync(bench: &mut Bench) {
    bench.send(frame(0x080, &[]));
    bench.advance(Duration::from_millis(1));
}

#[test]
fn n_144_records_are_buffered_while_inactive() {
    let mut bench = bench_4k();
    for p in [100, 200, 300] {
        record(&mut bench, p);
    }
    for _ in 0..5 {
        sync(&mut bench);
    }
    assert_eq!(demand(&mut bench), 0, "no motion");
    assert_eq!(sw(&mut bench) & 0x1000, 0, "interpolation inactive");
}

#[test]
fn n_145_n_146_each_sync_actuates_the_next_record_linearly() {
    let mut bench = bench_4k();
    for p in [400, 800, 1200] {
        record(&mut bench, p);
    }
    cw(&mut bench, 0x001F, 0);
    bench.send(frame(0x080, &[]));
    let mut demands = Vec::new();
    for _ in 0..4 {
        bench.advance(Duration::from_micros(250));
        demands.push(demand(&mut bench));
    }
    assert_eq!(demands, [100, 200, 300, 400], "linear within the 1 ms period");
    assert_eq!(sw(&mut bench) & 0x1000, 0x1000, "interpolation active");
    sync(&mut bench);
    assert_eq!(demand(&mut bench), 800);
    // n_146: bit 4 = 0: inactive, holds.
    cw(&mut bench, 0x000F, 0);
    sync(&mut bench);
    sync(&mut bench);
    assert_eq!(demand(&mut bench), 800);
    assert_eq!(sw(&mut bench) & 0x1000, 0);
}

#[test]
fn n_147_halt_stops_and_clears_bit_12() {
    let mut bench = bench_4k();
    // Halt with the slow-down ramp (605Dh = 1): 6084h = 10⁷ increments/s² stops in 2 ms.
    write(&mut bench, 0x6084, &10_000_000u32.to_le_bytes());
    // 16 records (the buffer's capacity), 20 increments apart: 20 000 increments/s.
    for k in 1..=16 {
        record(&mut bench, 20 * k);
    }
    cw(&mut bench, 0x001F, 0);
    for _ in 0..8 {
        sync(&mut bench);
    }
    cw(&mut bench, 0x011F, 0);
    sync(&mut bench);
    assert_eq!(sw(&mut bench) & 0x1000, 0, "bit 12 = 0 under halt");
    for _ in 0..50 {
        sync(&mut bench);
    }
    let held = demand(&mut bench);
    sync(&mut bench);
    assert_eq!(demand(&mut bench), held, "at rest");
    assert!(held < 320, "stopped before the last record: {held}");
    assert!(is(&mut bench, OE));
}

#[test]
fn n_148_an_empty_fifo_stops_at_the_last_point_and_reports_target_reached() {
    let mut bench = bench_4k();
    for p in [100, 300, 600] {
        record(&mut bench, p);
    }
    cw(&mut bench, 0x001F, 0);
    let mut reached = Vec::new();
    for _ in 0..6 {
        sync(&mut bench);
        reached.push((demand(&mut bench), sw(&mut bench) & 0x0400 != 0));
    }
    assert_eq!(reached[..3].iter().map(|r| r.0).collect::<Vec<_>>(), [100, 300, 600]);
    assert!(reached[..2].iter().all(|r| !r.1), "bit 10 = 0 while records remain: {reached:?}");
    assert!(reached[3..].iter().all(|r| r.0 == 600 && r.1), "stopped at the last point: {reached:?}");
}

#[test]
fn ring_buffer_replays_its_records() {
    let mut bench = bench_4k();
    write_sub(&mut bench, 0x60C4, 2, &4u32.to_le_bytes());
    write_sub(&mut bench, 0x60C4, 3, &[1]);
    for (slot, p) in [(0u16, 0), (1, 100), (2, 200), (3, 100)] {
        write_sub(&mut bench, 0x60C4, 4, &slot.to_le_bytes());
        record(&mut bench, p);
    }
    cw(&mut bench, 0x001F, 0);
    let mut seen = Vec::new();
    for _ in 0..8 {
        sync(&mut bench);
        seen.push(demand(&mut bench));
    }
    assert_eq!(seen, [0, 100, 200, 100, 0, 100, 200, 100]);
}

#[test]
fn overflow_of_a_full_fifo_is_refused_by_sdo() {
    let mut bench = bench_4k();
    write_sub(&mut bench, 0x60C4, 2, &2u32.to_le_bytes());
    record(&mut bench, 1);
    record(&mut bench, 2);
    let r = bench.sdo1(&req(0x23, 0x60C1, 1, [3, 0, 0, 0]));
    assert_eq!(r, abort(0x60C1, 1, 0x0800_0020));
}

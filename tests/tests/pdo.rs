//! PDOs and SYNC on the virtual bus (CiA 301 §7.2.2, §7.2.5, digest §6–7): the CiA 402 default
//! mapping, every transmission type, timers, the remap procedure with its abort codes, length
//! errors, RPDO timeout, SYNC supervision and production.

mod common;

use common::*;

use canopen_drive::comm::NmtState;
use canopen_drive::{CanFrame, Duration, Instant};
use embedded_can::Frame;

const EMCY: u16 = 0x080 + NODE as u16;
const SYNC: u16 = 0x080;
const RPDO1: u16 = 0x205;
const TPDO1: u16 = 0x185;
const TPDO3: u16 = 0x385;

fn emcy(data: [u8; 8]) -> CanFrame {
    frame(EMCY, &data)
}

fn ok(index: u16, sub: u8) -> [u8; 8] {
    req(0x60, index, sub, [0; 4])
}

fn write_u32(bench: &mut Bench, index: u16, sub: u8, value: u32) -> [u8; 8] {
    bench.sdo1(&req(0x23, index, sub, value.to_le_bytes()))
}

fn write_u16(bench: &mut Bench, index: u16, sub: u8, value: u16) -> [u8; 8] {
    let [a, b] = value.to_le_bytes();
    bench.sdo1(&req(0x2B, index, sub, [a, b, 0, 0]))
}

fn write_u8(bench: &mut Bench, index: u16, sub: u8, value: u8) -> [u8; 8] {
    bench.sdo1(&req(0x2F, index, sub, [value, 0, 0, 0]))
}

fn upload_u32(bench: &mut Bench, index: u16, sub: u8) -> u32 {
    let r = bench.sdo1(&req(0x40, index, sub, [0; 4]));
    assert_eq!(r[0] & 0xE0, 0x40, "upload of {index:04X}:{sub} answered {r:02X?}");
    u32::from_le_bytes([r[4], r[5], r[6], r[7]])
}

/// Operational, with the frames the transition produced discarded.
fn operational(bench: &mut Bench) {
    bench.send(frame(0x000, &[0x01, NODE]));
    bench.advance(Duration::from_millis(1));
    assert_eq!(bench.drive().nmt_state(), NmtState::Operational);
}

fn sync(bench: &mut Bench) -> Vec<CanFrame> {
    let mut frames = bench.send(frame(SYNC, &[]));
    frames.extend(bench.advance(Duration::from_millis(1)));
    frames
}

/// The statusword of Switch on disabled with remote set, as a TPDO carries it.
const SW_SWITCH_ON_DISABLED: [u8; 2] = [0x40, 0x02];

/// Writes the controlword through SDO; returns the TPDO1 frames sent at this instant.
fn controlword(bench: &mut Bench, value: u16) -> Vec<CanFrame> {
    let [a, b] = value.to_le_bytes();
    let frames = bench.send(frame(SDO_RX, &req(0x2B, 0x6040, 0, [a, b, 0, 0])));
    only(&frames, TPDO1)
}

fn only(frames: &[CanFrame], id: u16) -> Vec<CanFrame> {
    frames.iter().filter(|f| f.standard_id() == Some(id)).copied().collect()
}

#[test]
fn default_mapping_is_the_cia_402_set() {
    let mut bench = Bench::new();
    for (index, entries) in [
        (0x1600, vec![0x6040_0010]),
        (0x1601, vec![0x6040_0010, 0x6060_0008]),
        (0x1602, vec![0x6040_0010, 0x607A_0020]),
        (0x1603, vec![0x6040_0010, 0x60FF_0020]),
        (0x1A00, vec![0x6041_0010]),
        (0x1A01, vec![0x6041_0010, 0x6061_0008]),
        (0x1A02, vec![0x6041_0010, 0x6064_0020]),
        (0x1A03, vec![0x6041_0010, 0x606C_0020]),
    ] {
        assert_eq!(upload_u32(&mut bench, index, 0) as usize, entries.len(), "{index:04X}");
        for (sub, entry) in entries.iter().enumerate() {
            assert_eq!(upload_u32(&mut bench, index, sub as u8 + 1), *entry, "{index:04X}:{}", sub + 1);
        }
    }
    assert_eq!(upload_u32(&mut bench, 0x1400, 1), 0x205);
    assert_eq!(upload_u32(&mut bench, 0x1403, 1), 0x505);
    assert_eq!(upload_u32(&mut bench, 0x1800, 1), 0x4000_0185, "valid, no RTR");
    assert_eq!(upload_u32(&mut bench, 0x1802, 2), 1, "TPDO3 every SYNC");
    assert_eq!(bench.sdo1(&req(0x40, 0x1404, 1, [0; 4])), abort(0x1404, 1, 0x0602_0000), "capacity 4");
}

#[test]
fn pdos_move_only_in_operational() {
    let mut bench = Bench::new();
    assert!(bench.send(frame(RPDO1, &[0x0F, 0x00])).is_empty());
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(0));
    assert!(only(&sync(&mut bench), TPDO3).is_empty());
    operational(&mut bench);
    bench.send(frame(RPDO1, &[0x0F, 0x00]));
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(0x000F), "asynchronous: applied at once");
    assert_eq!(only(&sync(&mut bench), TPDO3), vec![frame(TPDO3, &[0x40, 0x02, 0, 0, 0, 0])]);
    bench.send(frame(0x000, &[0x80, NODE]));
    bench.send(frame(RPDO1, &[0x07, 0x00]));
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(0x000F));
}

#[test]
fn rpdo_length_errors() {
    let mut bench = Bench::new();
    operational(&mut bench);
    // Too short: EMCY 0x8210, not applied.
    assert_eq!(bench.send(frame(RPDO1, &[0x06])), vec![emcy([0x10, 0x82, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(0));
    // Correct again: the error resets.
    assert_eq!(bench.send(frame(RPDO1, &[0x06, 0x00])), vec![emcy([0; 8])]);
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(6));
    // Too long: applied, EMCY 0x8220.
    assert_eq!(bench.send(frame(RPDO1, &[0x07, 0x00, 0xFF])), vec![emcy([0x20, 0x82, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(7));
}

#[test]
fn synchronous_rpdo_takes_effect_at_the_next_sync() {
    let mut bench = Bench::new();
    assert_eq!(write_u8(&mut bench, 0x1400, 2, 0), ok(0x1400, 2));
    operational(&mut bench);
    bench.send(frame(RPDO1, &[0x0F, 0x00]));
    bench.advance(Duration::from_millis(5));
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(0), "latched");
    bench.send(frame(SYNC, &[]));
    bench.advance(Duration::from_millis(1));
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(0x000F), "applied at the tick after SYNC");
}

#[test]
fn cyclic_tpdo_every_nth_sync() {
    let mut bench = Bench::new();
    operational(&mut bench);
    for _ in 0..3 {
        assert_eq!(only(&sync(&mut bench), TPDO3), vec![frame(TPDO3, &[0x40, 0x02, 0, 0, 0, 0])]);
    }
    // Every 3rd SYNC.
    assert_eq!(write_u8(&mut bench, 0x1802, 2, 3), ok(0x1802, 2));
    let counts: Vec<usize> = (0..9).map(|_| only(&sync(&mut bench), TPDO3).len()).collect();
    assert_eq!(counts, [0, 0, 1, 0, 0, 1, 0, 0, 1]);
}

#[test]
fn acyclic_synchronous_tpdo_sends_at_sync_only_after_a_change() {
    let mut bench = Bench::new();
    assert_eq!(write_u8(&mut bench, 0x1800, 2, 0), ok(0x1800, 2));
    operational(&mut bench);
    assert_eq!(only(&sync(&mut bench), TPDO1).len(), 1, "first SYNC after start");
    assert!(only(&sync(&mut bench), TPDO1).is_empty(), "no change");
    // Shutdown: the statusword becomes Ready to switch on at the next tick.
    assert!(controlword(&mut bench, 0x0006).is_empty());
    assert!(only(&bench.advance(Duration::from_millis(3)), TPDO1).is_empty(), "waits for SYNC");
    assert_eq!(only(&sync(&mut bench), TPDO1), vec![frame(TPDO1, &[0x21, 0x02])]);
    assert!(only(&sync(&mut bench), TPDO1).is_empty());
}

/// The times TPDO1 (statusword) goes out while the drive is enabled one command per ms, with
/// inhibit time 5 in the drive's unit.
fn statusword_tpdo_times(bench: &mut Bench) -> Vec<Duration> {
    write_u32(bench, 0x1800, 1, 0xC000_0185);
    assert_eq!(write_u16(bench, 0x1800, 3, 5), ok(0x1800, 3));
    write_u32(bench, 0x1800, 1, 0x4000_0185);
    operational(bench);
    bench.advance(Duration::from_millis(20));
    let start = bench.now();
    let mut times = Vec::new();
    for cw in [0x0006u16, 0x0007, 0x000F] {
        let now = bench.now();
        times.extend(only(&controlword(bench, cw), TPDO1).iter().map(|_| now - start));
        times.extend(
            bench
                .advance_timed(Duration::from_millis(1))
                .into_iter()
                .filter(|(_, f)| f.standard_id() == Some(TPDO1))
                .map(|(t, _)| t - start),
        );
    }
    times.extend(
        bench
            .advance_timed(Duration::from_millis(20))
            .into_iter()
            .filter(|(_, f)| f.standard_id() == Some(TPDO1))
            .map(|(t, _)| t - start),
    );
    times
}

#[test]
fn the_tpdo_inhibit_time_unit_can_be_the_drives_own() {
    // CiA 301: 5 × 100 µs; every change of the three goes out (one per ms).
    let times = statusword_tpdo_times(&mut Bench::new());
    assert_eq!(times.len(), 3, "{times:?}");
    // A drive documented in ms: 5 ms between frames, the last change waits.
    let mut bench =
        Bench::with_config(|c| canopen_drive::Config { tpdo_inhibit_unit: Duration::from_millis(1), ..c });
    let times = statusword_tpdo_times(&mut bench);
    assert_eq!(times.len(), 2, "{times:?}");
    assert_eq!(times[1].as_micros() - times[0].as_micros(), 5_000);
}

#[test]
fn event_tpdo_on_change_with_inhibit_time_and_event_timer() {
    let mut bench = Bench::new();
    // TPDO1: inhibit 50 × 100 µs = 5 ms, written while invalid.
    assert_eq!(write_u16(&mut bench, 0x1800, 3, 50), abort(0x1800, 3, 0x0609_0030), "only while invalid");
    write_u32(&mut bench, 0x1800, 1, 0xC000_0185);
    assert_eq!(write_u16(&mut bench, 0x1800, 3, 50), ok(0x1800, 3));
    write_u32(&mut bench, 0x1800, 1, 0x4000_0185);
    operational(&mut bench);
    // Entering Operational sent TPDO1 once; let its inhibit time pass.
    bench.advance(Duration::from_millis(10));
    let start = bench.now();
    let mut sent = Vec::new();
    // Shutdown, Switch on, Enable operation, one per ms: three statusword changes.
    for cw in [0x0006u16, 0x0007, 0x000F] {
        let now = bench.now();
        sent.extend(controlword(&mut bench, cw).into_iter().map(|f| (now, f)));
        sent.extend(
            bench
                .advance_timed(Duration::from_millis(1))
                .into_iter()
                .filter(|(_, f)| f.standard_id() == Some(TPDO1)),
        );
    }
    sent.extend(
        bench
            .advance_timed(Duration::from_millis(10))
            .into_iter()
            .filter(|(_, f)| f.standard_id() == Some(TPDO1)),
    );
    // Ready to switch on goes at the next tick; Switched on and Operation enabled come within the
    // inhibit time: only the latest goes, 5 ms after the previous frame.
    let frames: Vec<(Instant, CanFrame)> = sent;
    assert_eq!(frames.len(), 2, "{frames:?}");
    assert_eq!(frames[0].1, frame(TPDO1, &[0x21, 0x02]));
    assert!(frames[0].0 - start <= Duration::from_millis(1));
    assert_eq!(frames[1].1, frame(TPDO1, &[0x37, 0x02]), "Operation enabled, voltage enabled");
    assert_eq!(frames[1].0 - frames[0].0, Duration::from_millis(5));

    // Event timer 20 ms: sent periodically without change.
    assert_eq!(write_u16(&mut bench, 0x1800, 5, 20), ok(0x1800, 5));
    bench.advance(Duration::from_millis(1));
    let times: Vec<Instant> = bench
        .advance_timed(Duration::from_millis(100))
        .into_iter()
        .filter(|(_, f)| f.standard_id() == Some(TPDO1))
        .map(|(t, _)| t)
        .collect();
    assert!(times.len() >= 4, "{times:?}");
    for pair in times.windows(2) {
        assert_eq!(pair[1] - pair[0], Duration::from_millis(20));
    }
}

#[test]
fn sync_start_value_delays_the_first_cyclic_transmission() {
    let mut bench = Bench::new();
    assert_eq!(write_u8(&mut bench, 0x1019, 0, 10), ok(0x1019, 0));
    write_u32(&mut bench, 0x1802, 1, 0xC000_0385);
    assert_eq!(write_u8(&mut bench, 0x1802, 6, 241), abort(0x1802, 6, 0x0609_0030));
    assert_eq!(write_u8(&mut bench, 0x1802, 6, 4), ok(0x1802, 6));
    write_u8(&mut bench, 0x1802, 2, 2);
    write_u32(&mut bench, 0x1802, 1, 0x4000_0385);
    operational(&mut bench);
    let mut sent_at = Vec::new();
    for counter in 1..=10u8 {
        let frames = bench.send(frame(SYNC, &[counter]));
        bench.advance(Duration::from_millis(1));
        if !only(&frames, TPDO3).is_empty() {
            sent_at.push(counter);
        }
    }
    assert_eq!(sent_at, [4, 6, 8, 10]);
}

#[test]
fn remap_procedure_and_its_abort_codes() {
    let mut bench = Bench::new();
    // Valid PDO: mapping refused.
    assert_eq!(write_u32(&mut bench, 0x1A00, 1, 0x6064_0020), abort(0x1A00, 1, 0x0601_0000));
    assert_eq!(write_u8(&mut bench, 0x1A00, 0, 0), abort(0x1A00, 0, 0x0601_0000));
    // 1. invalidate.
    assert_eq!(write_u32(&mut bench, 0x1800, 1, 0xC000_0185), ok(0x1800, 1));
    // Entries only while sub0 = 0.
    assert_eq!(write_u32(&mut bench, 0x1A00, 1, 0x6064_0020), abort(0x1A00, 1, 0x0601_0000));
    // 2. disable the mapping.
    assert_eq!(write_u8(&mut bench, 0x1A00, 0, 0), ok(0x1A00, 0));
    // Validating an empty PDO is refused.
    assert_eq!(write_u32(&mut bench, 0x1800, 1, 0x4000_0185), abort(0x1800, 1, 0x0609_0030));
    // 3. entries: each check.
    for (entry, code) in [
        (0x3000_0020, 0x0602_0000),    // no such object
        (0x6041_0110, 0x0609_0011),    // no such sub-index
        (0x1000_0020, 0x0604_0041),    // not mappable
        (0x6040_0010, 0x0604_0041),    // RPDO-only object in a TPDO
        (0x6041_0008, 0x0604_0041),    // wrong length
        (0x0005_0010, 0x0604_0041u32), // dummy of the wrong length
    ] {
        assert_eq!(write_u32(&mut bench, 0x1A00, 1, entry), abort(0x1A00, 1, code), "{entry:08X}");
    }
    assert_eq!(write_u32(&mut bench, 0x1A00, 1, 0x6041_0010), ok(0x1A00, 1));
    assert_eq!(write_u32(&mut bench, 0x1A00, 2, 0x6064_0020), ok(0x1A00, 2));
    assert_eq!(write_u32(&mut bench, 0x1A00, 3, 0x606C_0020), ok(0x1A00, 3));
    // 4. 80 bits do not fit, nor do 9 entries.
    assert_eq!(write_u8(&mut bench, 0x1A00, 0, 3), abort(0x1A00, 0, 0x0604_0042));
    assert_eq!(write_u8(&mut bench, 0x1A00, 0, 9), abort(0x1A00, 0, 0x0604_0042));
    assert_eq!(write_u8(&mut bench, 0x1A00, 0, 2), ok(0x1A00, 0));
    // Transmission type rules; restricted and changed CAN-IDs.
    assert_eq!(write_u8(&mut bench, 0x1800, 2, 245), abort(0x1800, 2, 0x0609_0030));
    assert_eq!(write_u8(&mut bench, 0x1400, 2, 252), abort(0x1400, 2, 0x0609_0030));
    assert_eq!(write_u32(&mut bench, 0x1800, 1, 0x4000_0705), abort(0x1800, 1, 0x0609_0030));
    assert_eq!(write_u32(&mut bench, 0x1800, 1, 0x6000_0185), abort(0x1800, 1, 0x0609_0030), "29-bit");
    assert_eq!(write_u8(&mut bench, 0x1800, 0, 6), abort(0x1800, 0, 0x0601_0002));
    // 5. validate (at a new CAN-ID) and see the new content.
    assert_eq!(write_u32(&mut bench, 0x1800, 1, 0x4000_0190), ok(0x1800, 1));
    assert_eq!(write_u32(&mut bench, 0x1800, 1, 0x4000_0191), abort(0x1800, 1, 0x0609_0030), "valid: fixed");
    let frames = bench.send(frame(0x000, &[0x01, NODE]));
    assert_eq!(only(&frames, 0x190), vec![frame(0x190, &[0x40, 0x02, 0, 0, 0, 0])]);
    assert!(only(&frames, TPDO1).is_empty());
}

#[test]
fn rpdo_with_dummy_and_bit_entries() {
    let mut bench = Bench::new();
    write_u32(&mut bench, 0x1401, 1, 0x8000_0305);
    write_u8(&mut bench, 0x1601, 0, 0);
    // Skip one byte, then one bit of a BOOLEAN, then a UNSIGNED8 at bit 9.
    assert_eq!(write_u32(&mut bench, 0x1601, 1, 0x0005_0008), ok(0x1601, 1));
    assert_eq!(write_u32(&mut bench, 0x1601, 2, (u32::from(FLAG) << 16) | 1), ok(0x1601, 2));
    assert_eq!(write_u32(&mut bench, 0x1601, 3, (u32::from(PERCENT) << 16) | 8), ok(0x1601, 3));
    assert_eq!(write_u8(&mut bench, 0x1601, 0, 3), ok(0x1601, 0));
    assert_eq!(write_u32(&mut bench, 0x1401, 1, 0x0000_0305), ok(0x1401, 1));
    operational(&mut bench);
    // Byte 0 ignored; bit 8 = 1; bits 9..16 = 42.
    bench.send(frame(0x305, &[0xAA, 0x01 | (42 << 1), 0x00]));
    assert_eq!(bench.drive().od().get::<u8>(FLAG, 0), Ok(1));
    assert_eq!(bench.drive().od().get::<u8>(PERCENT, 0), Ok(42));
    // A value beyond the entry's limits: the whole PDO is refused.
    bench.send(frame(0x305, &[0x00, 101 << 1, 0x00]));
    assert_eq!(bench.drive().od().get::<u8>(FLAG, 0), Ok(1));
    assert_eq!(bench.drive().od().get::<u8>(PERCENT, 0), Ok(42));
}

#[test]
fn rpdo_timeout_raises_8250() {
    let mut bench = Bench::new();
    assert_eq!(write_u16(&mut bench, 0x1400, 5, 100), ok(0x1400, 5));
    operational(&mut bench);
    // Monitoring starts with the first frame.
    assert!(only(&bench.advance(Duration::from_millis(500)), EMCY).is_empty());
    bench.send(frame(RPDO1, &[0, 0]));
    assert!(only(&bench.advance(Duration::from_millis(99)), EMCY).is_empty());
    assert_eq!(
        only(&bench.advance(Duration::from_millis(1)), EMCY),
        vec![emcy([0x50, 0x82, 0x11, 1, 0, 0, 0, 0])]
    );
    assert_eq!(bench.drive().nmt_state(), NmtState::PreOperational, "1029h = 0");
    operational(&mut bench);
    assert_eq!(only(&bench.send(frame(RPDO1, &[0, 0])), EMCY), vec![emcy([0; 8])]);
}

#[test]
fn tpdo_answers_remote_frames_when_allowed() {
    let mut bench = Bench::new();
    operational(&mut bench);
    let rtr = CanFrame::new_remote_standard(TPDO1, 2).unwrap();
    assert!(bench.send(rtr).is_empty(), "bit 30 set: no RTR");
    write_u32(&mut bench, 0x1800, 1, 0xC000_0185);
    write_u8(&mut bench, 0x1800, 2, 253);
    write_u32(&mut bench, 0x1800, 1, 0x0000_0185);
    assert_eq!(bench.send(rtr), vec![frame(TPDO1, &SW_SWITCH_ON_DISABLED)]);
    // 252: the value sampled at the last SYNC.
    write_u32(&mut bench, 0x1800, 1, 0x8000_0185);
    write_u8(&mut bench, 0x1800, 2, 252);
    write_u32(&mut bench, 0x1800, 1, 0x0000_0185);
    sync(&mut bench);
    controlword(&mut bench, 0x0006);
    bench.advance(Duration::from_millis(2));
    assert_eq!(bench.drive().od().get::<u16>(0x6041, 0), Ok(0x0221), "the statusword changed");
    assert_eq!(bench.send(rtr), vec![frame(TPDO1, &SW_SWITCH_ON_DISABLED)], "sampled at the SYNC");
}

#[test]
fn sync_length_loss_and_counter_rules() {
    let mut bench = Bench::new();
    // Wrong length for a SYNC without counter.
    assert_eq!(bench.send(frame(SYNC, &[1])), vec![emcy([0x40, 0x82, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(bench.send(frame(SYNC, &[])), vec![emcy([0; 8])]);
    // 1006h = 10 ms: after 15 ms of silence, SYNC is lost.
    assert_eq!(write_u32(&mut bench, 0x1006, 0, 10_000), ok(0x1006, 0));
    bench.send(frame(SYNC, &[]));
    assert!(bench.advance(Duration::from_micros(14_999)).is_empty());
    assert_eq!(bench.advance(Duration::from_micros(1)), vec![emcy([0x00, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    assert_eq!(bench.send(frame(SYNC, &[])), vec![emcy([0; 8])]);
    // 1019h only while 1006h = 0; 1 and > 240 are not counter values.
    assert_eq!(write_u8(&mut bench, 0x1019, 0, 5), abort(0x1019, 0, 0x0800_0022));
    write_u32(&mut bench, 0x1006, 0, 0);
    assert_eq!(write_u8(&mut bench, 0x1019, 0, 1), abort(0x1019, 0, 0x0609_0030));
    assert_eq!(write_u8(&mut bench, 0x1019, 0, 241), abort(0x1019, 0, 0x0609_0030));
    assert_eq!(write_u8(&mut bench, 0x1019, 0, 240), ok(0x1019, 0));
}

#[test]
fn sync_producer_with_counter() {
    let mut bench = Bench::new();
    write_u8(&mut bench, 0x1019, 0, 3);
    assert_eq!(write_u32(&mut bench, 0x1005, 0, 0x4000_0080), ok(0x1005, 0));
    assert_eq!(write_u32(&mut bench, 0x1005, 0, 0x4000_0081), abort(0x1005, 0, 0x0609_0030), "producing");
    assert_eq!(write_u32(&mut bench, 0x1006, 0, 2000), ok(0x1006, 0));
    operational(&mut bench);
    let frames = bench.advance_timed(Duration::from_millis(10));
    let syncs: Vec<(Instant, Vec<u8>)> = frames
        .iter()
        .filter(|(_, f)| f.standard_id() == Some(SYNC))
        .map(|(t, f)| (*t, f.data().to_vec()))
        .collect();
    assert_eq!(syncs.len(), 5, "{syncs:?}");
    assert!(syncs.windows(2).all(|w| w[1].0 - w[0].0 == Duration::from_millis(2)));
    let counters: Vec<u8> = syncs.iter().map(|(_, d)| d[0]).collect();
    assert!(counters.windows(2).all(|w| w[1] == w[0] % 3 + 1), "{counters:?}");
    // The node's own SYNC drives its cyclic TPDOs.
    assert_eq!(only(&frames.iter().map(|(_, f)| *f).collect::<Vec<_>>(), TPDO3).len(), 5);
}

#[test]
fn synchronous_rpdo_outside_the_window_is_discarded() {
    let mut bench = Bench::new();
    write_u8(&mut bench, 0x1400, 2, 1);
    assert_eq!(write_u32(&mut bench, 0x1007, 0, 500), ok(0x1007, 0));
    operational(&mut bench);
    bench.send(frame(SYNC, &[]));
    bench.advance(Duration::from_millis(1));
    bench.send(frame(RPDO1, &[0x0F, 0x00]));
    sync(&mut bench);
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(0), "late: discarded");
    // Right after a SYNC: inside the window, applied at the next SYNC.
    bench.send(frame(SYNC, &[]));
    bench.send(frame(RPDO1, &[0x0F, 0x00]));
    sync(&mut bench);
    assert_eq!(bench.drive().od().get::<u16>(0x6040, 0), Ok(0x000F), "inside the window");
}

#[test]
fn long_rpdo_policy_is_configurable() {
    use canopen_drive::comm::pdo::LongRpdo;
    use canopen_drive::{Config, Drive};
    use canopen_drive_sim::{DriveNode, VirtualBus};
    let config = Config { long_rpdo: LongRpdo::DiscardAndReport, ..Config::new(NODE) };
    let mut bus = VirtualBus::new();
    let node = bus.add_node(DriveNode::new(Drive::new(config).unwrap(), Duration::from_millis(1)));
    bus.send(frame(0x000, &[0x01, NODE]));
    bus.advance(Duration::from_millis(1)).unwrap();
    bus.drain_received_frames();
    bus.send(frame(RPDO1, &[0x07, 0x00, 0xFF]));
    bus.settle().unwrap();
    assert_eq!(only(&bus.drain_received_frames(), EMCY), vec![emcy([0x20, 0x82, 0x11, 0, 0, 0, 0, 0])]);
    let drive = &bus.node::<DriveNode>(node).unwrap().drive;
    assert_eq!(drive.od().get::<u16>(0x6040, 0), Ok(0), "not applied");
}

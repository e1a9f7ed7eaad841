//! CiA 402 helpers: statusword masks (digest §3.5), SDO shorthands, the node under test.

use super::*;
use canopen_drive_sim::DriveNode;

pub const SOD: (u16, u16) = (0x004F, 0x0040);
pub const RTSO: (u16, u16) = (0x006F, 0x0021);
pub const SO: (u16, u16) = (0x006F, 0x0023);
pub const OE: (u16, u16) = (0x006F, 0x0027);
pub const QSA: (u16, u16) = (0x006F, 0x0007);
pub const FRA: (u16, u16) = (0x004F, 0x000F);
pub const FAULT: (u16, u16) = (0x004F, 0x0008);

pub fn statusword(bench: &mut Bench) -> u16 {
    let r = bench.sdo1(&req(0x40, 0x6041, 0, [0; 4]));
    assert_eq!(r[0], 0x4B);
    u16::from_le_bytes([r[4], r[5]])
}

pub fn is(bench: &mut Bench, (mask, value): (u16, u16)) -> bool {
    statusword(bench) & mask == value
}

/// Writes `bytes` (1, 2 or 4) to `index` sub `sub` and expects success.
pub fn write_sub(bench: &mut Bench, index: u16, sub: u8, bytes: &[u8]) {
    let command = match bytes.len() {
        1 => 0x2F,
        2 => 0x2B,
        _ => 0x23,
    };
    let mut data = [0u8; 4];
    data[..bytes.len()].copy_from_slice(bytes);
    let r = bench.sdo1(&req(command, index, sub, data));
    assert_eq!(r, req(0x60, index, sub, [0; 4]), "write {index:04X}sub{sub}");
}

pub fn write(bench: &mut Bench, index: u16, bytes: &[u8]) {
    write_sub(bench, index, 0, bytes);
}

/// Uploads a 4-byte object through SDO.
pub fn read_i32(bench: &mut Bench, index: u16) -> i32 {
    let r = bench.sdo1(&req(0x40, index, 0, [0; 4]));
    assert_eq!(r[0], 0x43, "upload {index:04X}: {r:02X?}");
    i32::from_le_bytes([r[4], r[5], r[6], r[7]])
}

/// Writes the controlword and lets `ms` ticks run.
pub fn cw(bench: &mut Bench, value: u16, ms: u64) {
    write(bench, 0x6040, &value.to_le_bytes());
    bench.advance(Duration::from_millis(ms));
}

pub fn node(bench: &mut Bench) -> &mut DriveNode<TestHooks> {
    let handle = canopen_drive_sim::bus::NodeHandle::from_index(0);
    bench.bus.node_mut::<DriveNode<TestHooks>>(handle).unwrap()
}

/// Selects `mode` and enables the drive (Operation enabled).
pub fn enable(bench: &mut Bench, mode: u8) {
    write(bench, 0x6060, &[mode]);
    cw(bench, 0x0006, 2);
    cw(bench, 0x000F, 2);
    assert!(is(bench, OE));
}

pub fn enable_pv(bench: &mut Bench) {
    enable(bench, 3);
}

/// The dictionary's value now (what the master would read), without an SDO round trip: for
/// per-tick observations.
pub fn od_i32(bench: &mut Bench, index: u16) -> i32 {
    bench.drive().od().get::<i32>(index, 0).unwrap()
}

/// See [`od_i32`].
pub fn od_i16(bench: &mut Bench, index: u16) -> i16 {
    bench.drive().od().get::<i16>(index, 0).unwrap()
}

/// See [`od_i32`].
pub fn od_u16(bench: &mut Bench, index: u16) -> u16 {
    bench.drive().od().get::<u16>(index, 0).unwrap()
}

/// The statusword as the dictionary holds it after the last tick.
pub fn sw(bench: &mut Bench) -> u16 {
    od_u16(bench, 0x6041)
}

pub fn od_u32(bench: &mut Bench, index: u16) -> u32 {
    bench.drive().od().get::<u32>(index, 0).unwrap()
}

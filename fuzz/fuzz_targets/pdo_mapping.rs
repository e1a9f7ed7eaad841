//! (c) PDO mapping writes followed by PDO traffic: writes to the communication and mapping
//! records (values drawn from the dictionary's own mappable entries, dummy entries and raw
//! values), NMT, RPDOs on whatever COB-IDs are configured, SYNCs and remote frames, in a
//! drive with the CiA defaults or a narrowed vendor configuration (first byte, bit 0), booted
//! or Operational and moving in pp (bit 1).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| canopen_drive_fuzz::targets::pdo_mapping(data));

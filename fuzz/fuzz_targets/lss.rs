//! (d) LSS: requests of every command specifier (and unknown ones) with arbitrary parameters,
//! NMT resets that activate a configured node-ID, time and stray frames, on a node that starts
//! unconfigured (node-ID 255) or configured (first byte, bit 0), waiting or in the LSS
//! configuration state (bit 1). Beyond the rig's invariants: at most one LSS response per
//! request and none without one, an unconfigured node sends nothing but LSS responses, and the
//! node-ID is always 1..=127 or 255.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| canopen_drive_fuzz::targets::lss(data));

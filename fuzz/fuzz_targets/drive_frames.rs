//! (a) Arbitrary frame sequences with arbitrary time steps into a whole drive with the
//! simulated motor (tick + on_frame + poll), every op of the language, in one of four drive
//! configurations (first byte % 4), booted or prepared in a mode (first byte / 4 % 5, see
//! `canopen_drive_fuzz::rig::Start`). Invariants after every step: see `canopen_drive_fuzz::rig`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| canopen_drive_fuzz::targets::drive_frames(data));

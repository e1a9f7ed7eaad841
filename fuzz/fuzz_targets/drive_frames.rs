//! (a) Arbitrary frame sequences with arbitrary time steps into a whole drive with the
//! simulated motor (tick + on_frame + poll), every op of the language, in one of four drive
//! configurations (first byte). Invariants after every step: see `canopen_drive_fuzz::rig`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| canopen_drive_fuzz::targets::drive_frames(data));

//! The full drive: `Drive` with the default configuration (every CiA 402 mode, 4 + 4 PDOs,
//! the dictionary store sized to the standard tables), no manufacturer objects, no parameter
//! storage. Built without the optional modes it is the image drive-cyclic.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use canopen_drive::drive::STANDARD_OD_BYTES;
use canopen_drive::{Config, Drive};
use canopen_drive_footprint::{run, target, NODE_ID};

#[cortex_m_rt::entry]
fn main() -> ! {
    // The node lives in a static, as on a board (cortex-m-rt makes this `static mut` a
    // `&'static mut`), and is built in place there.
    // The dictionary sized to the standard tables, as a firmware without objects of its own
    // sizes it (the default leaves 2 KiB for those).
    static mut NODE: MaybeUninit<Drive<(), STANDARD_OD_BYTES>> = MaybeUninit::uninit();
    let Ok(node) = Drive::build_in(NODE, Config::new(NODE_ID), (), ()) else {
        semihosting::process::exit(102)
    };
    let init = target::used_since_reset();
    let depth = run(node, &mut target::probe);
    target::report_and_exit(init, depth)
}

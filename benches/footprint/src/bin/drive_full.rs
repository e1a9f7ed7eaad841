//! The full drive: `Drive` with the default configuration (every CiA 402 mode, 4 + 4 PDOs,
//! the default 3 KiB dictionary store), no manufacturer objects, no parameter storage.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use canopen_drive::{Config, Drive};
use canopen_drive_footprint::{run, target, NODE_ID};

#[cortex_m_rt::entry]
fn main() -> ! {
    // The node lives in a static, as on a board (cortex-m-rt makes this `static mut` a
    // `&'static mut`), and is built in place there.
    static mut NODE: MaybeUninit<Drive> = MaybeUninit::uninit();
    let Ok(node) = Drive::build_in(NODE, Config::new(NODE_ID), (), ()) else {
        semihosting::process::exit(102)
    };
    let init = target::used_since_reset();
    let depth = run(node, &mut target::probe);
    target::report_and_exit(init, depth)
}

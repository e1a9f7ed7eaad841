//! The CiA 301-only node (see `node301` in the library).
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use canopen_drive_footprint::node301::Node301;
use canopen_drive_footprint::{run, target, NODE_ID};

#[cortex_m_rt::entry]
fn main() -> ! {
    // The node lives in a static, as on a board (cortex-m-rt makes this `static mut` a
    // `&'static mut`), and is built in place there.
    static mut NODE: MaybeUninit<Node301> = MaybeUninit::uninit();
    let Ok(node) = Node301::build_in(NODE, NODE_ID) else { semihosting::process::exit(102) };
    let init = target::used_since_reset();
    let depth = run(node, &mut target::probe);
    target::report_and_exit(init, depth)
}

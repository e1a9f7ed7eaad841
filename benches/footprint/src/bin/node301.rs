//! The CiA 301-only node (see `node301` in the library).
#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use canopen_drive_footprint::node301::Node301;
use canopen_drive_footprint::{run, target, NODE_ID};

#[cortex_m_rt::entry]
fn main() -> ! {
    // The node lives in a static, as on a board (cortex-m-rt makes this `static mut` a
    // `&'static mut`); it is built on the stack and moved there.
    static mut NODE: MaybeUninit<Node301> = MaybeUninit::uninit();
    let Ok(built) = Node301::new(NODE_ID) else { semihosting::process::exit(102) };
    let node = NODE.write(built);
    let init = target::used_since_reset();
    let depth = run(node, &mut target::probe);
    target::report_and_exit(init, depth)
}

//! The bootloader node (`canopen_drive::bootloader`): CiA 301 for program download.
#![no_std]
#![no_main]

use canopen_drive_footprint::boot::{node, BootNode};
use canopen_drive_footprint::{run, target};

#[cortex_m_rt::entry]
fn main() -> ! {
    // The node lives in a static, as on a board.
    static mut NODE: Option<BootNode> = None;
    let Ok(node) = node(NODE) else { semihosting::process::exit(102) };
    let init = target::used_since_reset();
    let depth = run(node, &mut target::probe);
    target::report_and_exit(init, depth)
}

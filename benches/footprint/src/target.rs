//! The bare-metal side of the harness: vector table, stack probe, console, exit.

use core::sync::atomic::{compiler_fence, Ordering};

use crate::StackUse;

extern "C" {
    fn DefaultHandler();
}

/// The device part of the vector table: one line, unused (nothing here takes interrupts).
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
pub static __INTERRUPTS: [unsafe extern "C" fn(); 1] = [DefaultHandler];

const PAINT: u32 = 0xCCCC_CCCC;
/// How far below the caller the probe paints (more than any call here needs).
const WINDOW: usize = 24 * 1024;

fn stack_bottom() -> usize {
    extern "C" {
        static _stack_end: u32;
    }
    core::ptr::addr_of!(_stack_end) as usize
}

fn stack_top() -> usize {
    extern "C" {
        static _stack_start: u32;
    }
    core::ptr::addr_of!(_stack_start) as usize
}

/// Bytes of stack used below the top since reset (cortex-m-rt painted it at start-up).
pub fn used_since_reset() -> u32 {
    let top = stack_top();
    let mut p = stack_bottom();
    // SAFETY: every word from `_stack_end` to `_stack_start` is stack RAM.
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    (top - p) as u32
}

/// Runs `f` and returns how deep (bytes below this function's frame) it used the stack.
#[inline(never)]
pub fn probe(f: &mut dyn FnMut()) -> u32 {
    let here = cortex_m::register::msp::read() as usize;
    let low = here.saturating_sub(WINDOW).max(stack_bottom());
    // Leave 64 bytes under the probe's own frame alone (the call to `f` pushes there first).
    let high = here.saturating_sub(64);
    let mut p = low;
    while p < high {
        // SAFETY: [low, high) is unused stack below the current frame.
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
    compiler_fence(Ordering::SeqCst);
    f();
    compiler_fence(Ordering::SeqCst);
    let mut q = low;
    // SAFETY: as above.
    while q < high && unsafe { core::ptr::read_volatile(q as *const u32) } == PAINT {
        q += 4;
    }
    (here - q) as u32
}

/// Writes `text` on the semihosting console.
pub fn print_text(text: &str) {
    for b in text.bytes() {
        semihosting::sys::arm_compat::sys_writec(b);
    }
}

/// Writes `text` and `value` in decimal on the semihosting console (no `core::fmt`).
pub fn print(text: &str, value: u32) {
    print_text(text);
    let mut digits = [0u8; 10];
    let mut n = value;
    let mut i = digits.len();
    loop {
        i -= 1;
        if let Some(d) = digits.get_mut(i) {
            *d = b'0' + (n % 10) as u8;
        }
        n /= 10;
        if n == 0 || i == 0 {
            break;
        }
    }
    for &d in digits.get(i..).unwrap_or(&[]) {
        semihosting::sys::arm_compat::sys_writec(d);
    }
}

/// Prints the measurements and ends the run (QEMU exits with status 0).
pub fn report_and_exit(init: u32, depth: StackUse) -> ! {
    print("init=", init);
    print(" comm=", depth.comm);
    print(" tick=", depth.tick);
    print_text("\n");
    semihosting::process::exit(0)
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    semihosting::process::exit(101)
}

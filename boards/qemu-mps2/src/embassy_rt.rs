//! What the embassy firmwares of this board share (included with `#[path]`, so that the
//! non-async firmware links none of it): embassy-time on SysTick, and a thread-mode executor
//! that sleeps with WFI.
//!
//! - Time: `now` is the board's µs clock (a 1 ms SysTick exception plus the counter inside
//!   the ms); expired timers are woken at the next ms. Resolution 1 ms, which is what the
//!   runner needs (its deadlines are heartbeats, SDO timeouts, inhibit times).
//! - Executor: embassy's stock thread executor idles with WFE, which spins QEMU at 100 % of a
//!   host core; this one sleeps with WFI unless a task was woken while it polled, or, for the
//!   measuring firmware, never sleeps ([`Idle::Spin`]).

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, Ordering};
use core::task::Waker;

use canopen_drive_qemu_mps2::board;
use critical_section::Mutex;
use embassy_executor::raw::Executor;
use embassy_executor::Spawner;
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;
use static_cell::StaticCell;

struct SysTickDriver {
    queue: Mutex<RefCell<Queue>>,
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    queue: Mutex::new(RefCell::new(Queue::new()))
});

impl Driver for SysTickDriver {
    fn now(&self) -> u64 {
        board::now_micros()
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            let mut queue = self.queue.borrow_ref_mut(cs);
            if queue.schedule_wake(at, waker) {
                // Wakes it at once if `at` has passed.
                queue.next_expiration(board::now_micros());
            }
        });
    }
}

/// Call from the SysTick exception (after the clock counted the ms): wakes expired timers.
pub fn on_millisecond() {
    critical_section::with(|cs| {
        DRIVER.queue.borrow_ref_mut(cs).next_expiration(board::now_micros());
    });
}

/// A task was woken since the executor last polled (set by the pender).
static WOKEN: AtomicBool = AtomicBool::new(false);

/// The executor's pender: notes the wake-up (an interrupt that woke a task woke the core too).
#[unsafe(export_name = "__pender")]
fn pender(_context: *mut ()) {
    WOKEN.store(true, Ordering::Release);
}

/// What the executor does when no task is ready.
#[allow(dead_code)] // each firmware uses one
pub enum Idle {
    /// Sleep in WFI until an interrupt.
    Sleep,
    /// Poll again at once. Under `-icount` with `sleep=off`, QEMU skips the time the core
    /// sleeps, and in doing so it can pass over an expiry of a fast timer (a run of the 20 kHz
    /// current loop is then lost while the core slept, which real hardware never does): a
    /// firmware that measures the current loop's period keeps the core running instead.
    Spin,
}

/// Runs the thread-mode executor for ever: `init` spawns the first tasks.
pub fn run_executor(idle: Idle, init: impl FnOnce(Spawner)) -> ! {
    static EXECUTOR: StaticCell<Executor> = StaticCell::new();
    let executor: &'static Executor = EXECUTOR.init(Executor::new(core::ptr::null_mut()));
    init(executor.spawner());
    loop {
        WOKEN.store(false, Ordering::Relaxed);
        // SAFETY: polled only here, in thread mode, on the executor's own thread.
        unsafe { executor.poll() };
        // Sleep unless a task was woken while polling.
        if let Idle::Sleep = idle {
            board::idle(|| WOKEN.load(Ordering::Acquire));
        }
    }
}

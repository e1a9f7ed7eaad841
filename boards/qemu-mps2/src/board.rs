//! What both firmwares share on the target: the µs clock on SysTick, the body of the control
//! tick, the stack measurement.

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use canopen_drive::hal::{Demand, Sample};
use canopen_drive::Instant;
use critical_section::Mutex;

use crate::motor::{Motor, MotorParams};
use crate::mps2::{systick, timer0, timer1, COUNTS_PER_US, SYSCLK_HZ};
use crate::node::TICK_PERIOD;
use crate::objects::{load_torque, TICK_MONITOR};

/// Milliseconds counted by the SysTick exception.
static MILLIS: Mutex<Cell<u64>> = Mutex::new(Cell::new(0));

/// The simulated axis, touched only by the tick.
static MOTOR: Mutex<RefCell<Motor>> = Mutex::new(RefCell::new(Motor::new(MotorParams::DEFAULT)));

/// Nanoseconds per count of the board's timers.
const NS_PER_COUNT: u32 = 1_000_000_000 / SYSCLK_HZ;

/// Starts SysTick (the clock), TIMER1 (the stopwatch) and TIMER0 (the tick); the caller
/// unmasks their interrupts.
pub fn start_timers() {
    timer1::start();
    systick::start();
    timer0::start(tick_period_counts().saturating_sub(1));
}

/// Call from the SysTick exception: counts one millisecond.
pub fn on_systick() {
    critical_section::with(|cs| {
        let millis = MILLIS.borrow(cs);
        millis.set(millis.get().wrapping_add(1));
    });
}

/// Microseconds since the timers started.
pub fn now_micros() -> u64 {
    critical_section::with(|cs| loop {
        // With interrupts masked the SysTick handler cannot run: a wrap shows as "pending".
        let before = systick::pending();
        let counter = systick::counter();
        let after = systick::pending();
        if before == after {
            let millis = MILLIS.borrow(cs).get() + u64::from(before);
            let elapsed = (systick::COUNTS_PER_MS - 1).saturating_sub(counter) / COUNTS_PER_US;
            return millis * 1000 + u64::from(elapsed);
        }
    })
}

/// The body of the TIMER0 interrupt: records how late it started, samples the motor, runs
/// `drive_tick` (the drive's tick, behind whatever lock the firmware uses), and moves the motor
/// for one tick period under the demand.
///
/// Lateness is recorded only for ticks that fell due while the core was running: one that
/// fell due while it slept in WFI also waits for QEMU to wake up, which under `-icount`
/// follows the host's clock and scheduler, not the firmware.
pub fn control_tick(drive_tick: impl FnOnce(Instant, &Sample) -> Demand) {
    let now_counts = timer1::now();
    let since_expiry = timer0::counts_since_expiry();
    timer0::clear_interrupt();
    IN_TICK.store(true, Ordering::Relaxed);
    // When this tick fell due: the time the previous tick expected, so that a tick held off
    // for longer than a period (the timer then expired more than once) shows its whole delay.
    // The next one is expected on the timer's own grid.
    let period = tick_period_counts();
    let this_expiry = now_counts.wrapping_sub(since_expiry);
    // (Plain loads and stores: thumbv6m has no atomic swap; only this handler writes these.)
    let due =
        if TICKS_STARTED.load(Ordering::Relaxed) { NEXT_DUE.load(Ordering::Relaxed) } else { this_expiry };
    TICKS_STARTED.store(true, Ordering::Relaxed);
    NEXT_DUE.store(this_expiry.wrapping_add(period), Ordering::Relaxed);
    // `due` after the last wake-up (in wrapping time): the core was running when it fell due.
    let woke = SLEEP_ENDED_AT.load(Ordering::Relaxed);
    if due.wrapping_sub(woke) < u32::MAX / 2 && due != woke {
        TICK_MONITOR.record(now_counts.wrapping_sub(due).saturating_mul(NS_PER_COUNT));
    }
    let now = Instant::from_micros(now_micros());
    let sample = critical_section::with(|cs| {
        let mut motor = MOTOR.borrow_ref_mut(cs);
        motor.set_load(load_torque());
        motor.sample()
    });
    let started = timer1::now();
    let demand = drive_tick(now, &sample);
    let took = timer1::now().wrapping_sub(started);
    if took > LONGEST_TICK.load(Ordering::Relaxed) {
        LONGEST_TICK.store(took, Ordering::Relaxed);
    }
    let dt = TICK_PERIOD.as_micros() as f32 * 1.0e-6;
    critical_section::with(|cs| MOTOR.borrow_ref_mut(cs).step(&demand, dt));
    IN_TICK.store(false, Ordering::Relaxed);
}

/// TIMER1 count at which the next tick falls due.
static NEXT_DUE: AtomicU32 = AtomicU32::new(0);
/// The first tick has set `NEXT_DUE`.
static TICKS_STARTED: AtomicBool = AtomicBool::new(false);

fn tick_period_counts() -> u32 {
    (TICK_PERIOD.as_micros() as u32).saturating_mul(COUNTS_PER_US)
}

/// TIMER1 count at the end of the last WFI.
static SLEEP_ENDED_AT: AtomicU32 = AtomicU32::new(0);

/// The idle step of a main loop: sleeps in WFI unless `work_waiting` (checked with interrupts
/// masked, so a wake-up between the check and the WFI is not lost: WFI wakes on a pending
/// interrupt even while PRIMASK masks it). Interrupts that came in run when this returns.
pub fn idle(work_waiting: impl FnOnce() -> bool) {
    cortex_m::interrupt::disable();
    if !work_waiting() {
        cortex_m::asm::wfi();
        SLEEP_ENDED_AT.store(timer1::now(), Ordering::Relaxed);
    }
    // SAFETY: the main loops call this with interrupts enabled, never inside a critical
    // section.
    unsafe { cortex_m::interrupt::enable() };
}

/// True while the tick handler runs (its own critical sections do not delay it).
static IN_TICK: AtomicBool = AtomicBool::new(false);
/// TIMER1 count when the outermost critical section began.
static SECTION_START: AtomicU32 = AtomicU32::new(0);
/// The longest critical section outside the tick (TIMER1 counts).
static LONGEST_SECTION: AtomicU32 = AtomicU32::new(0);

/// The longest `Drive::tick` (TIMER1 counts).
static LONGEST_TICK: AtomicU32 = AtomicU32::new(0);

/// The longest `Drive::tick` call (ns) since the last [`reset_longest_section`].
pub fn longest_tick_ns() -> u32 {
    LONGEST_TICK.load(Ordering::Relaxed).saturating_mul(NS_PER_COUNT)
}

/// The longest time (ns) interrupts were masked by a critical section outside the tick
/// handler since the last [`reset_longest_section`]: the most any of them can have delayed
/// the tick.
pub fn longest_section_ns() -> u32 {
    LONGEST_SECTION.load(Ordering::Relaxed).saturating_mul(NS_PER_COUNT)
}

/// Starts a new measurement of [`longest_section_ns`] and [`longest_tick_ns`].
pub fn reset_longest_section() {
    LONGEST_SECTION.store(0, Ordering::Relaxed);
    LONGEST_TICK.store(0, Ordering::Relaxed);
}

/// The `critical-section` implementation of this board: single core, interrupts masked with
/// PRIMASK (as cortex-m's `critical-section-single-core`), plus a stopwatch on every outermost
/// section, which is how the firmware measures what can hold off its tick.
struct MeasuredCriticalSection;
critical_section::set_impl!(MeasuredCriticalSection);

// SAFETY: on a single core, masking interrupts excludes every other context; the restore
// state says whether this call masked them and must unmask them again.
unsafe impl critical_section::Impl for MeasuredCriticalSection {
    unsafe fn acquire() -> bool {
        let was_enabled = cortex_m::register::primask::read().is_active();
        cortex_m::interrupt::disable();
        if was_enabled {
            SECTION_START.store(timer1::now(), Ordering::Relaxed);
        }
        was_enabled
    }

    unsafe fn release(was_enabled: bool) {
        if was_enabled {
            if !IN_TICK.load(Ordering::Relaxed) {
                let held = timer1::now().wrapping_sub(SECTION_START.load(Ordering::Relaxed));
                if held > LONGEST_SECTION.load(Ordering::Relaxed) {
                    LONGEST_SECTION.store(held, Ordering::Relaxed);
                }
            }
            // SAFETY: interrupts were enabled when the outermost section began.
            unsafe { cortex_m::interrupt::enable() };
        }
    }
}

/// The deepest stack use since reset (bytes): the stack is painted at reset (cortex-m-rt
/// `paint-stack`), so the lowest word that lost its paint marks the deepest use.
pub fn stack_used() -> u32 {
    extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    const PAINT: u32 = 0xCCCC_CCCC;
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let mut p = core::ptr::addr_of!(_stack_end) as usize;
    // SAFETY: every word from `_stack_end` up to `_stack_start` is RAM of the stack region.
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    (top - p) as u32
}

/// The measurements of this board, for the objects 2F04h and 2F06h.
pub struct BoardMeasurements;

impl crate::objects::Measurements for BoardMeasurements {
    fn stack_used(&self) -> u32 {
        stack_used()
    }

    fn longest_section_ns(&self) -> u32 {
        longest_section_ns()
    }

    fn longest_tick_ns(&self) -> u32 {
        longest_tick_ns()
    }

    fn reset_longest_section(&self) {
        reset_longest_section();
    }
}

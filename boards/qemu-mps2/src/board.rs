//! What the firmwares share on the target: the interrupt priorities and the drive's lock, the
//! µs clock on SysTick, the body of the control tick, the stand-in current loop, the
//! measurements (lock holds, masked stretches, stack).
//!
//! | context | priority | touches the drive |
//! |---|---|---|
//! | dual timer: the current loop (20 kHz, 1 kHz in real time) | [`priority::CURRENT_LOOP`], above the drive's lock | never |
//! | TIMER0: the control tick (1 kHz) | [`priority::TICK`], the drive's ceiling | `SharedDrive::tick` |
//! | UART0 receive ("CAN RX") | [`priority::UART_RX`] | `on_frame` (bare-interrupt firmware) |
//! | SysTick (1 ms clock, embassy timers) | [`priority::SYSTICK`] | never |
//! | thread mode: the runner, `poll`, transmit | – | `on_frame`, `poll`, `pop_tx` |

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use canopen_drive::comm::indicators::NodeStatus;
use canopen_drive::hal::{Demand, Sample};
use canopen_drive::Instant;
use canopen_drive_embassy::{Lock, PriorityCeiling};
use cortex_m::peripheral::{scb::SystemHandler, NVIC, SCB};
use critical_section::Mutex;

use crate::motor::{Motor, MotorParams};
use crate::mps2::{dualtimer, systick, timer0, timer1, Irq, COUNTS_PER_US, SYSCLK_HZ};
use crate::node::TICK_PERIOD;
use crate::objects::{load_torque, CurrentLoop, TICK_MONITOR};

/// The interrupt priorities (as the NVIC holds them: lower is more urgent). Only the top two
/// bits are used, so they mean the same on every Cortex-M (ARMv6-M implements two bits).
pub mod priority {
    /// The current loop: above the drive's lock, never held off by it.
    pub const CURRENT_LOOP: u8 = 0x00;
    /// The control tick, and the ceiling of the drive's lock.
    pub const TICK: u8 = 0x40;
    /// UART0 receive.
    pub const UART_RX: u8 = 0x80;
    /// SysTick.
    pub const SYSTICK: u8 = 0xC0;
}

/// The lock of the drive (and of the board state the tick shares): a priority ceiling at the
/// tick's priority, measured ([`longest_lock_ns`]).
pub type DriveLock = MeasuredLock;

/// Milliseconds counted by the SysTick exception.
static MILLIS: Mutex<Cell<u64>> = Mutex::new(Cell::new(0));

/// State the tick shares with the rest of the firmware, under the drive's ceiling (not a
/// critical section, which would hold off the current loop too).
struct TickShared<T>(RefCell<T>);

// SAFETY: the value is touched only inside `PriorityCeiling::lock`, one context at a time.
unsafe impl<T: Send> Sync for TickShared<T> {}

impl<T> TickShared<T> {
    fn with<R>(&self, f: impl FnOnce(&mut T) -> R) -> Option<R> {
        PriorityCeiling::<{ priority::TICK }>
            .lock(|| self.0.try_borrow_mut().ok().map(|mut v| f(&mut v)))
            .flatten()
    }
}

/// The simulated axis, touched only by the tick.
static MOTOR: TickShared<Motor> = TickShared(RefCell::new(Motor::new(MotorParams::DEFAULT)));

/// Nanoseconds per count of the board's timers.
const NS_PER_COUNT: u32 = 1_000_000_000 / SYSCLK_HZ;

/// Sets the priorities of every interrupt the firmwares use ([`priority`]), starts SysTick (the
/// clock), TIMER1 (the stopwatch), TIMER0 (the tick) and the dual timer (the current loop,
/// every `current_loop_period_us`), and unmasks the tick and the current loop; the firmware
/// unmasks UART0 itself.
pub fn start_interrupts(nvic: &mut NVIC, scb: &mut SCB, current_loop_period_us: u32) {
    // SAFETY: priorities are set before the interrupts are unmasked.
    unsafe {
        nvic.set_priority(Irq::DualTimer, priority::CURRENT_LOOP);
        nvic.set_priority(Irq::Timer0, priority::TICK);
        nvic.set_priority(Irq::Uart0Rx, priority::UART_RX);
        scb.set_priority(SystemHandler::SysTick, priority::SYSTICK);
    }
    timer1::start();
    systick::start();
    timer0::start(tick_period_counts().saturating_sub(1));
    let loop_period = current_loop_period_us.saturating_mul(COUNTS_PER_US).max(1);
    LOOP_PERIOD.store(loop_period, Ordering::Relaxed);
    dualtimer::start(loop_period - 1);
    // SAFETY: their handlers (the firmware's TIMER0, `current_loop_interrupt`) are ready.
    unsafe {
        NVIC::unmask(Irq::Timer0);
        NVIC::unmask(Irq::DualTimer);
    }
}

/// The current loop's period in the firmware that measures it (`tick-bound`, run under
/// `-icount`, where its 20 kHz cost the host nothing): 50 µs.
pub const CURRENT_LOOP_PERIOD_US: u32 = 50;
/// Its period in the firmwares a master talks to in real time: 1 ms (at 20 kHz QEMU would
/// keep most of a host core busy).
pub const CURRENT_LOOP_PERIOD_US_REAL_TIME: u32 = 1000;
/// The current loop's period (TIMER1 counts).
static LOOP_PERIOD: AtomicU32 = AtomicU32::new(1);

/// Current-loop runs since the last [`reset_current_loop`].
static LOOP_RUNS: AtomicU32 = AtomicU32::new(0);
/// TIMER1 count of the last run.
static LOOP_LAST_RUN: AtomicU32 = AtomicU32::new(0);
/// TIMER1 count at which the next run falls due.
static LOOP_NEXT_DUE: AtomicU32 = AtomicU32::new(0);
/// The longest time between two runs (TIMER1 counts).
static LOOP_LONGEST_GAP: AtomicU32 = AtomicU32::new(0);
/// The latest start of a run after it fell due (counts).
static LOOP_MOST_LATE: AtomicU32 = AtomicU32::new(0);
/// Asks the handler to start the statistics afresh at its next run.
static LOOP_RESET: AtomicBool = AtomicBool::new(true);

/// The dual timer's interrupt: the stand-in for a motor's current loop, at the most urgent
/// priority, above the drive's lock. It only counts its runs, the longest gap between two and
/// its lateness; a real one would read the phase currents and set the PWM duties.
/// (Plain loads and stores: thumbv6m has no atomic read-modify-write; only this handler
/// writes these.)
pub extern "C" fn current_loop_interrupt() {
    let now = timer1::now();
    let this_expiry = now.wrapping_sub(dualtimer::counts_since_expiry());
    dualtimer::clear_interrupt();
    // When this run fell due: one period after the previous run's expiry, so that a run held
    // off past the next expiry (the timer then expired twice, and one run is lost) shows its
    // whole delay, not the delay modulo the period.
    let late = if LOOP_RESET.load(Ordering::Relaxed) {
        LOOP_RESET.store(false, Ordering::Relaxed);
        LOOP_RUNS.store(0, Ordering::Relaxed);
        LOOP_LONGEST_GAP.store(0, Ordering::Relaxed);
        LOOP_MOST_LATE.store(0, Ordering::Relaxed);
        now.wrapping_sub(this_expiry)
    } else {
        let gap = now.wrapping_sub(LOOP_LAST_RUN.load(Ordering::Relaxed));
        if gap > LOOP_LONGEST_GAP.load(Ordering::Relaxed) {
            LOOP_LONGEST_GAP.store(gap, Ordering::Relaxed);
        }
        // The two timers are read a few instructions apart: a run on time can seem to start a
        // count before it fell due.
        let late = now.wrapping_sub(LOOP_NEXT_DUE.load(Ordering::Relaxed));
        if late > u32::MAX / 2 {
            0
        } else {
            late
        }
    };
    LOOP_NEXT_DUE.store(this_expiry.wrapping_add(LOOP_PERIOD.load(Ordering::Relaxed)), Ordering::Relaxed);
    LOOP_LAST_RUN.store(now, Ordering::Relaxed);
    LOOP_RUNS.store(LOOP_RUNS.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
    if late > LOOP_MOST_LATE.load(Ordering::Relaxed) {
        LOOP_MOST_LATE.store(late, Ordering::Relaxed);
    }
}

/// The current loop's statistics since the last [`reset_current_loop`].
pub fn current_loop() -> CurrentLoop {
    CurrentLoop {
        runs: LOOP_RUNS.load(Ordering::Relaxed),
        longest_gap_ns: LOOP_LONGEST_GAP.load(Ordering::Relaxed).saturating_mul(NS_PER_COUNT),
        most_late_ns: LOOP_MOST_LATE.load(Ordering::Relaxed).saturating_mul(NS_PER_COUNT),
    }
}

/// Starts the current loop's statistics afresh at its next run.
pub fn reset_current_loop() {
    LOOP_RESET.store(true, Ordering::Relaxed);
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
    let sample = MOTOR
        .with(|motor| {
            motor.set_load(load_torque());
            motor.sample()
        })
        .unwrap_or_default();
    let started = timer1::now();
    let demand = drive_tick(now, &sample);
    let took = timer1::now().wrapping_sub(started);
    if took > LONGEST_TICK.load(Ordering::Relaxed) {
        LONGEST_TICK.store(took, Ordering::Relaxed);
    }
    let dt = TICK_PERIOD.as_micros() as f32 * 1.0e-6;
    MOTOR.with(|motor| motor.step(&demand, dt));
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

/// True while the tick handler runs (its own holds of the lock do not delay it).
static IN_TICK: AtomicBool = AtomicBool::new(false);
/// The drive's lock is held (plain loads and stores: touched only under the lock).
static LOCK_HELD: AtomicBool = AtomicBool::new(false);
/// The longest hold of the drive's lock outside the tick (TIMER1 counts).
static LONGEST_LOCK: AtomicU32 = AtomicU32::new(0);
/// TIMER1 count when the outermost critical section began.
static SECTION_START: AtomicU32 = AtomicU32::new(0);
/// The longest critical section, anywhere (TIMER1 counts).
static LONGEST_MASKED: AtomicU32 = AtomicU32::new(0);

/// The longest `Drive::tick` (TIMER1 counts).
static LONGEST_TICK: AtomicU32 = AtomicU32::new(0);

/// The longest `Drive::tick` call (ns) since the last [`reset_longest_section`].
pub fn longest_tick_ns() -> u32 {
    LONGEST_TICK.load(Ordering::Relaxed).saturating_mul(NS_PER_COUNT)
}

/// The longest hold (ns) of the drive's lock outside the tick handler since the last
/// [`reset_longest_section`]: the most any call of the communication side can have delayed
/// the tick.
pub fn longest_lock_ns() -> u32 {
    LONGEST_LOCK.load(Ordering::Relaxed).saturating_mul(NS_PER_COUNT)
}

/// The longest time (ns) every interrupt was masked by a critical section, in any context,
/// since the last [`reset_longest_section`]: the most the current loop can have been delayed.
pub fn longest_masked_ns() -> u32 {
    LONGEST_MASKED.load(Ordering::Relaxed).saturating_mul(NS_PER_COUNT)
}

/// Starts a new measurement of [`longest_lock_ns`], [`longest_masked_ns`] and
/// [`longest_tick_ns`].
pub fn reset_longest_section() {
    LONGEST_LOCK.store(0, Ordering::Relaxed);
    LONGEST_MASKED.store(0, Ordering::Relaxed);
    LONGEST_TICK.store(0, Ordering::Relaxed);
}

/// The drive's lock: [`PriorityCeiling`] at the tick's priority, with a stopwatch on every
/// outermost hold outside the tick ([`longest_lock_ns`]), which is how the firmware measures
/// what can hold off its tick.
#[derive(Debug)]
pub struct MeasuredLock(PriorityCeiling<{ priority::TICK }>);

// SAFETY: every `f` runs inside `PriorityCeiling::lock`, which keeps the contexts apart.
unsafe impl Lock for MeasuredLock {
    const NEW: Self = MeasuredLock(PriorityCeiling);

    fn lock<R>(&self, f: impl FnOnce() -> R) -> Option<R> {
        self.0.lock(|| {
            if LOCK_HELD.load(Ordering::Relaxed) {
                return f();
            }
            LOCK_HELD.store(true, Ordering::Relaxed);
            let started = timer1::now();
            let result = f();
            let held = timer1::now().wrapping_sub(started);
            LOCK_HELD.store(false, Ordering::Relaxed);
            if !IN_TICK.load(Ordering::Relaxed) && held > LONGEST_LOCK.load(Ordering::Relaxed) {
                LONGEST_LOCK.store(held, Ordering::Relaxed);
            }
            result
        })
    }
}

/// The `critical-section` implementation of this board: single core, interrupts masked with
/// PRIMASK (as cortex-m's `critical-section-single-core`), plus a stopwatch on every outermost
/// section ([`longest_masked_ns`]): what can hold off even the current loop.
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
            let held = timer1::now().wrapping_sub(SECTION_START.load(Ordering::Relaxed));
            if held > LONGEST_MASKED.load(Ordering::Relaxed) {
                LONGEST_MASKED.store(held, Ordering::Relaxed);
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

    fn longest_lock_ns(&self) -> u32 {
        longest_lock_ns()
    }

    fn longest_masked_ns(&self) -> u32 {
        longest_masked_ns()
    }

    fn current_loop(&self) -> CurrentLoop {
        current_loop()
    }

    fn longest_tick_ns(&self) -> u32 {
        longest_tick_ns()
    }

    fn reset_longest_section(&self) {
        reset_longest_section();
        reset_current_loop();
    }
}

/// The CiA 303-3 indicators on the user LEDs: LED 0 the green RUN LED, LED 1 the red ERR LED,
/// as `status` shows them at `now`. Writes the LED register only when they change (`shown`:
/// what it holds, `None` before the first write). A firmware calls it every 10 ms or so (each
/// flash of 200 ms then within 5 %, a flicker of 50 ms within 20 %).
pub fn show_indicators(status: NodeStatus, now: Instant, shown: &mut Option<u32>) {
    let leds = status.leds(now);
    let bits = u32::from(leds.run) | u32::from(leds.err) << 1;
    if *shown != Some(bits) {
        crate::mps2::fpgaio::set_leds(bits);
        *shown = Some(bits);
    }
}

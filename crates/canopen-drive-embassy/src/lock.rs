//! The locks a [`SharedDrive`](crate::SharedDrive) is built on: a critical section (every
//! interrupt masked; any target) and, on Cortex-M, a priority ceiling that masks only the
//! interrupts at or below the drive's tick, so that a current loop above it always runs.

/// Keeps apart the contexts that share a value: the tick and the communication side of a
/// [`SharedDrive`](crate::SharedDrive), or any state of the firmware that they share.
///
/// Implemented by [`CriticalSection`] and (Cortex-M) [`PriorityCeiling`]; a firmware may wrap
/// one of them, e.g. to measure how long it is held.
///
/// # Safety
///
/// While the `f` of one [`Lock::lock`] call runs, no other context may run the `f` of another
/// `lock` call on any value of the same type. A context from which an implementation cannot
/// promise that gets `None`, and `f` does not run.
#[allow(unsafe_code)] // an unsafe trait: implementations promise exclusion
pub unsafe trait Lock {
    /// The lock, for the initializer of a `static`.
    const NEW: Self;

    /// Runs `f` with every other context that uses this lock held off; `None`, without
    /// running `f`, when the calling context cannot take it (see the implementation). Calls
    /// may nest.
    fn lock<R>(&self, f: impl FnOnce() -> R) -> Option<R>;
}

/// Every interrupt masked for each call (the `critical-section` crate: PRIMASK on a
/// single-core Cortex-M, a spin lock across cores on a multi-core part, a mutex on a host).
/// The default lock of [`SharedDrive`](crate::SharedDrive): it works on every target and never
/// refuses, but while the drive works every interrupt waits, a current loop above the tick too.
#[derive(Clone, Copy, Debug, Default)]
pub struct CriticalSection;

// SAFETY: `critical_section::with` excludes every other critical section of the program.
#[allow(unsafe_code)]
unsafe impl Lock for CriticalSection {
    const NEW: Self = CriticalSection;

    #[inline]
    fn lock<R>(&self, f: impl FnOnce() -> R) -> Option<R> {
        Some(critical_section::with(|_| f()))
    }
}

/// The drive's lock at a priority ceiling (single-core Cortex-M): while a call holds it, only
/// the interrupts whose priority is `PRIORITY` or lower are held off; every interrupt more
/// urgent than `PRIORITY` (a smaller number) keeps running, whatever the drive does.
///
/// `PRIORITY` is the ceiling: the priority of the most urgent context that touches the drive,
/// which is the tick's interrupt. Give the tick exactly this priority, as the NVIC holds it
/// (the implemented upper bits only: `0x40` is level 1 on a part with 2 priority bits, level 4
/// on one with 4). Run everything else that calls into the drive (the runner in thread mode,
/// CAN interrupts) at this priority or lower. A call from a more urgent context cannot be kept
/// apart from the tick, so it is refused ([`SharedDrive::with`](crate::SharedDrive::with)
/// returns `None`, [`SharedDrive::tick`](crate::SharedDrive::tick) `Demand::OFF`): a
/// misconfigured firmware does nothing, it never corrupts the drive. `PRIORITY` 0 would mask
/// nothing and does not compile.
///
/// - **ARMv7-M, ARMv7E-M, ARMv8-M Mainline** (Cortex-M3/M4/M7/M33): each call raises BASEPRI
///   to `PRIORITY` and restores it after, as RTIC's resource locks do: a handful of
///   instructions (8 a call from thread mode on a Cortex-M4, measured in `boards/qemu-mps2`).
///   With PRIGROUP splitting priorities into group and sub-priority, BASEPRI works on the
///   group: interrupts of the ceiling's group priority are held off too. Not for Cortex-M7 r0p1 (erratum 837070:
///   a raise of BASEPRI can take effect one instruction late), and in the current security
///   state only (ARMv8-M with TrustZone).
/// - **ARMv6-M** (Cortex-M0/M0+/M1; no BASEPRI): each call reads the priorities of the
///   enabled NVIC lines and disables, for the call, those at `PRIORITY` or lower (ICER/ISER),
///   then enables them again: about 100 instructions a call in `boards/qemu-mps2` (three lines
///   enabled, all among the first twelve), some 40 more for each further group of four lines
///   with one enabled. The system exceptions SysTick, PendSV and SVCall have no NVIC line to
///   disable, so calls from them are refused: on ARMv6-M the tick and the communication side
///   run in NVIC interrupts or in thread mode. Nothing else may enable or disable those NVIC lines while the drive is in
///   use (a line enabled during a call would run at once).
/// - **ARMv8-M Baseline and other targets** (hosts among them): the type exists, but it is
///   no [`Lock`] there; use [`CriticalSection`].
///
/// The tick itself runs at the ceiling, where nothing that takes the lock can preempt it: its
/// calls only read which exception runs and its priority, and mask nothing (on ARMv6-M that
/// saves the tick the NVIC round trip).
///
/// What stays free: every priority more urgent than `PRIORITY`, and the fault exceptions.
/// The other critical sections of a firmware (embassy's timer queue and channels, a board's
/// clock, a `defmt` logger) still mask everything, briefly: in `boards/qemu-mps2` at most 215
/// instructions, about 900 while the drive logs a `defmt` line.
#[derive(Clone, Copy, Debug, Default)]
pub struct PriorityCeiling<const PRIORITY: u8>;

// SAFETY: on a single core, a context can only run while no more urgent one is active. Every
// context that gets past `caller` runs at `PRIORITY` or lower. One below the ceiling masks the
// others while it holds the lock (BASEPRI at `PRIORITY`, or their NVIC lines disabled; thread
// mode is below every exception); one at the ceiling cannot be preempted by any of them (none
// is more urgent), so it needs no masking. No other holder can start until it lets go.
// Contexts above the ceiling are refused.
#[cfg(any(ceiling_basepri, ceiling_nvic))]
#[allow(unsafe_code)]
unsafe impl<const PRIORITY: u8> Lock for PriorityCeiling<PRIORITY> {
    const NEW: Self = PriorityCeiling;

    #[inline]
    fn lock<R>(&self, f: impl FnOnce() -> R) -> Option<R> {
        const {
            assert!(
                PRIORITY != 0,
                "a priority ceiling of 0 would mask nothing: give the tick a lower priority"
            );
        }
        match cortex_m::caller(PRIORITY) {
            cortex_m::Caller::Above => None,
            // The tick: nothing that takes the lock can preempt it.
            cortex_m::Caller::At => Some(f()),
            cortex_m::Caller::Below => {
                let held = cortex_m::raise(PRIORITY);
                let result = f();
                cortex_m::restore(held);
                Some(result)
            }
        }
    }
}

/// The Cortex-M registers behind [`PriorityCeiling`]: the special registers IPSR and BASEPRI,
/// the NVIC's enable and priority registers, the system handlers' priorities. Word accesses
/// only (ARMv6-M has no byte access to the priority registers).
#[cfg(any(ceiling_basepri, ceiling_nvic))]
#[allow(unsafe_code)] // raw register access, each with its SAFETY note
mod cortex_m {
    use core::arch::asm;
    use core::ptr::read_volatile;

    /// NVIC interrupt priority registers (IPR0…), four lines a word.
    const NVIC_IPR: usize = 0xE000_E400;
    /// System handler priority registers (SHPR1…), four exceptions a word from exception 4.
    #[cfg(ceiling_basepri)]
    const SCB_SHPR: usize = 0xE000_ED18;

    fn read(address: usize) -> u32 {
        // SAFETY: only called with the addresses of the system control space above, which
        // every Cortex-M maps and which reading does not change.
        unsafe { read_volatile(address as *const u32) }
    }

    /// The priority byte of entry `n` of the priority registers at `base`.
    fn priority(base: usize, n: u32) -> u8 {
        let word = read(base + 4 * (n / 4) as usize);
        (word >> (8 * (n % 4))) as u8
    }

    /// Where the running context stands against the ceiling.
    pub(super) enum Caller {
        /// More urgent than the ceiling (or an exception the lock cannot mask, on ARMv6-M):
        /// refused.
        Above,
        /// An exception at the ceiling's priority: no context that takes the lock can preempt
        /// it.
        At,
        /// Thread mode, or an exception less urgent than the ceiling: the lock masks the
        /// others.
        Below,
    }

    /// Where the running context stands against `ceiling`, from its exception number (IPSR)
    /// and that exception's priority.
    #[inline]
    pub(super) fn caller(ceiling: u8) -> Caller {
        let ipsr: u32;
        // SAFETY: reading IPSR has no effect.
        unsafe { asm!("mrs {}, IPSR", out(reg) ipsr, options(nomem, nostack, preserves_flags)) };
        let priority = match ipsr & 0x1FF {
            0 => return Caller::Below,
            exception @ 16.. => priority(NVIC_IPR, exception - 16),
            // MemManage, BusFault, UsageFault, SecureFault, SVCall, DebugMonitor, PendSV, SysTick.
            #[cfg(ceiling_basepri)]
            exception @ 4..=15 => priority(SCB_SHPR, exception - 4),
            // NMI and HardFault (fixed priorities above every ceiling); on ARMv6-M also SVCall,
            // PendSV and SysTick, which no NVIC line masks.
            _ => return Caller::Above,
        };
        match priority.cmp(&ceiling) {
            core::cmp::Ordering::Less => Caller::Above,
            core::cmp::Ordering::Equal => Caller::At,
            core::cmp::Ordering::Greater => Caller::Below,
        }
    }

    /// What `raise` changed, for `restore`: the previous BASEPRI.
    #[cfg(ceiling_basepri)]
    pub(super) type Held = u32;

    /// Raises BASEPRI to `ceiling` (never lowers it) and returns its previous value.
    #[cfg(ceiling_basepri)]
    #[inline]
    pub(super) fn raise(ceiling: u8) -> Held {
        let before: u32;
        // SAFETY: BASEPRI_MAX only raises the execution priority: it masks interrupts, which
        // breaks no invariant. The asm is a compiler barrier (no `nomem`): the caller's
        // accesses to the shared value stay after it.
        unsafe {
            asm!("mrs {}, BASEPRI", out(reg) before, options(nomem, nostack, preserves_flags));
            asm!("msr BASEPRI_MAX, {}", in(reg) u32::from(ceiling), options(nostack, preserves_flags));
        }
        before
    }

    /// Puts BASEPRI back to what `raise` found.
    #[cfg(ceiling_basepri)]
    #[inline]
    pub(super) fn restore(before: Held) {
        // SAFETY: restores the value this context had before `raise`; a compiler barrier, so
        // the caller's accesses to the shared value stay before it.
        unsafe { asm!("msr BASEPRI, {}", in(reg) before, options(nostack, preserves_flags)) };
    }

    /// NVIC interrupt set-enable and clear-enable registers (lines 0–31, all ARMv6-M has).
    #[cfg(ceiling_nvic)]
    const NVIC_ISER: usize = 0xE000_E100;
    #[cfg(ceiling_nvic)]
    const NVIC_ICER: usize = 0xE000_E180;

    /// What `raise` changed, for `restore`: the NVIC lines it disabled.
    #[cfg(ceiling_nvic)]
    pub(super) type Held = u32;

    #[cfg(ceiling_nvic)]
    fn write(address: usize, value: u32) {
        // SAFETY: only called with the NVIC's ISER and ICER, where a write sets or clears the
        // enable bits it has ones for and changes nothing else.
        unsafe { core::ptr::write_volatile(address as *mut u32, value) }
    }

    /// Disables the enabled NVIC lines whose priority is `ceiling` or lower; returns them.
    #[cfg(ceiling_nvic)]
    #[inline]
    pub(super) fn raise(ceiling: u8) -> Held {
        let mut lines = 0u32;
        // Four lines a priority word; the loop ends after the highest enabled line.
        let mut rest = read(NVIC_ISER);
        let mut first = 0u32;
        while rest != 0 {
            if rest & 0xF != 0 {
                let priorities = read(NVIC_IPR + first as usize);
                for line in 0..4u32 {
                    if rest & (1 << line) != 0 && (priorities >> (8 * line)) as u8 >= ceiling {
                        lines |= 1 << (first + line);
                    }
                }
            }
            rest >>= 4;
            first += 4;
        }
        write(NVIC_ICER, lines);
        // SAFETY: barriers only. The disable takes effect before the next instruction (an
        // interrupt of these lines already on its way is taken before it, and ends before
        // the caller goes on); the asm is a compiler barrier for the caller's accesses too.
        unsafe { asm!("dsb", "isb", options(nostack, preserves_flags)) };
        lines
    }

    /// Enables again the lines `raise` disabled.
    #[cfg(ceiling_nvic)]
    #[inline]
    pub(super) fn restore(lines: Held) {
        // Keeps the caller's accesses to the shared value before the enable.
        core::sync::atomic::compiler_fence(core::sync::atomic::Ordering::SeqCst);
        write(NVIC_ISER, lines);
    }
}

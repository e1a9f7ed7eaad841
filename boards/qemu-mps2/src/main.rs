//! The embassy firmware: see the library docs for the board, and `canopen-drive-embassy` for
//! the concurrency discipline.
//!
//! | context | priority | does |
//! |---|---|---|
//! | dual timer interrupt | 0x00, above the drive's lock | the stand-in current loop (1 kHz here, 20 kHz in `tick-bound`): counts its runs, never touches the drive |
//! | TIMER0 interrupt | 0x40, the drive's ceiling | the 1 kHz control tick (`SharedDrive::tick`), the simulated motor |
//! | UART0 receive interrupt | 0x80 | moves received bytes into a pipe, wakes the receive loop |
//! | SysTick exception | 0xC0 | counts ms, wakes expired embassy timers |
//! | thread mode | – | the executor: the runner (SLCAN ⇄ drive, `poll`), the exit task; WFI when idle |
//!
//! The drive is a `SharedDrive` with a `PriorityCeiling` at the tick's priority: the runner's
//! calls mask the tick and everything below it, never the current loop.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(not(target_os = "none"))]
fn main() {}

#[cfg(target_os = "none")]
mod firmware;

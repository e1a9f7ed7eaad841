//! The embassy firmware: see the library docs for the board, and `canopen-drive-embassy` for
//! the concurrency discipline.
//!
//! | context | priority | does |
//! |---|---|---|
//! | TIMER0 interrupt | highest | the 1 kHz control tick (`SharedDrive::tick`), the simulated motor |
//! | UART0 receive interrupt | middle | moves received bytes into a pipe, wakes the receive loop |
//! | SysTick exception | lowest interrupt | counts ms, wakes expired embassy timers |
//! | thread mode | – | the executor: the runner (SLCAN ⇄ drive, `poll`), the exit task; WFI when idle |
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(not(target_os = "none"))]
fn main() {}

#[cfg(target_os = "none")]
mod firmware;

//! Writes the memory map (`memory.x`) of the selected part into the build directory and adds
//! the linker scripts (cortex-m-rt's `link.x`, defmt's `defmt.x`; the interrupt vectors come
//! from embassy-stm32's PAC). There is deliberately no `memory.x` in the crate directory: the
//! linker resolves cortex-m-rt's `INCLUDE memory.x` from its working directory first, so one
//! there would win over this one.
//!
//! | feature | flash | RAM | kept from the linker (end of flash): LSS page, parameter pages |
//! |---|---|---|---|
//! | `stm32g431cb` (the board's part) | 128 KiB | 32 KiB | 2 KiB, 2 × 2 KiB |
//! | `stm32g474ce` (pin-compatible) | 512 KiB | 128 KiB | 2 KiB, 4 × 2 KiB (dual-bank mode) |

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let g474 = env::var_os("CARGO_FEATURE_STM32G474CE").is_some();
    // (flash KiB, RAM KiB, parameter area KiB); the RAM of both parts is contiguous from
    // 0x2000_0000 (SRAM1, SRAM2, CCM SRAM).
    let (flash, ram, parameters) = if g474 { (512, 128, 8) } else { (128, 32, 4) };
    // The LSS configuration page, right below the parameters (src/lss.rs).
    let lss = 2;
    let memory = format!(
        "/* Written by build.rs. The last {parameters} KiB of flash hold the stored parameters\n   \
         (src/storage.rs), the {lss} KiB below them the LSS configuration (src/lss.rs); neither\n   \
         is given to the linker. */\n\
         MEMORY\n{{\n  FLASH : ORIGIN = 0x08000000, LENGTH = {}K\n  RAM   : ORIGIN = 0x20000000, LENGTH = {ram}K\n}}\n",
        flash - parameters - lss
    );
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    if let Err(e) = fs::write(out.join("memory.x"), memory) {
        println!("cargo:warning=cannot write memory.x: {e}");
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}

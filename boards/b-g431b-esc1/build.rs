//! Writes the memory map (`memory.x`) of the selected part and build into the build directory
//! and adds the linker scripts (cortex-m-rt's `link.x`, defmt's `defmt.x`; the interrupt
//! vectors come from embassy-stm32's PAC). The numbers are `src/layout.rs`'s, which the
//! firmware uses too. There is deliberately no `memory.x` in the crate directory: the linker
//! resolves cortex-m-rt's `INCLUDE memory.x` from its working directory first, so one there
//! would win over this one.
//!
//! | build | FLASH region | RAM region |
//! |---|---|---|
//! | default (the standalone firmware; the `bootloader` bin too) | from 0x0800_0000 up to the LSS page | from 0x2000_0010 to the end of RAM |
//! | feature `application-image` | the program area after the header's page | the same |
//!
//! Neither region includes the LSS page and the parameter pages at the end of flash, nor
//! the hand-over word at the start of RAM. The `bootloader` bin is also linked with
//! `bootloader.x`, which checks that it starts at 0x0800_0000 and ends below the program
//! area: building it with the feature `application-image` fails there, on purpose.

use std::env;
use std::fs;
use std::path::PathBuf;

#[allow(dead_code, reason = "the firmware's module: build.rs uses part of it")]
mod layout {
    include!("src/layout.rs");
}

use layout::{Layout, BOOTLOADER_LEN, FLASH_BASE, HANDOFF_LEN, PAYLOAD_OFFSET, RAM_BASE};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/layout.rs");
    let g474 = env::var_os("CARGO_FEATURE_STM32G474CE").is_some();
    let application = env::var_os("CARGO_FEATURE_APPLICATION_IMAGE").is_some();
    let part = Layout::of(g474);
    let (origin, length, what) = if application {
        (
            FLASH_BASE + part.program_area() + PAYLOAD_OFFSET,
            part.application_len(),
            "the application behind the bootloader (feature application-image),\n   \
             the program area's payload after the image header's page",
        )
    } else {
        (FLASH_BASE, part.code_len(), "a standalone firmware,\n   or the bootloader (bootloader.x bounds it)")
    };
    let memory = format!(
        "/* Written by build.rs from src/layout.rs: {what}.\n   \
         The last {parameters} bytes of flash hold the stored parameters, the page below them the\n   \
         LSS configuration; the first {HANDOFF_LEN} bytes of RAM the hand-over word between\n   \
         bootloader and application. */\n\
         MEMORY\n{{\n  FLASH : ORIGIN = {origin:#010X}, LENGTH = {length:#X}\n  \
         RAM   : ORIGIN = {ram_origin:#010X}, LENGTH = {ram_length:#X}\n}}\n",
        parameters = part.parameters,
        ram_origin = RAM_BASE + HANDOFF_LEN,
        ram_length = part.ram - HANDOFF_LEN,
    );
    let bootloader = format!(
        "/* Written by build.rs, linked into the bootloader only: it runs from the start of flash\n   \
         and must end below the program area. */\n\
         ASSERT(ORIGIN(FLASH) == {FLASH_BASE:#010X}, \"the bootloader runs from the start of flash: build it without the feature application-image\");\n\
         ASSERT(__sidata + SIZEOF(.data) <= {end:#010X}, \"the bootloader reaches into the program area\");\n",
        end = FLASH_BASE + BOOTLOADER_LEN,
    );
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    for (name, text) in [("memory.x", memory), ("bootloader.x", bootloader)] {
        if let Err(e) = fs::write(out.join(name), text) {
            println!("cargo:warning=cannot write {name}: {e}");
        }
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    println!("cargo:rustc-link-arg-bin=bootloader=-Tbootloader.x");
}

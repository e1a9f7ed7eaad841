//! Puts this board's memory layout where the linker finds it as `memory.x` and adds the linker
//! scripts, for the bare-metal targets only (the library part also builds and tests on the
//! host).
//!
//! - `memory/standalone.x`: every firmware at the start of code memory, the bootloader too;
//!   `memory/bootloader.x` adds to the bootloader the check that it ends below the program area.
//! - With the feature `application-image`, `memory/application.x`: the firmware is linked to
//!   run from the program area, as the bootloader's program (`src/boot.rs`).
//!
//! No file of the package is called `memory.x`: the linker looks in the working directory
//! (the package's) before the search path, and would take that one whatever the feature.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    for script in
        ["memory/standalone.x", "memory/application.x", "memory/bootloader.x", "device.x", "build.rs"]
    {
        println!("cargo:rerun-if-changed={script}");
    }
    let target = env::var("TARGET").unwrap_or_default();
    if !target.starts_with("thumbv") {
        return;
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    let memory = if env::var_os("CARGO_FEATURE_APPLICATION_IMAGE").is_some() {
        "memory/application.x"
    } else {
        "memory/standalone.x"
    };
    for (from, to) in
        [(memory, "memory.x"), ("device.x", "device.x"), ("memory/bootloader.x", "bootloader.x")]
    {
        if let Err(e) = fs::copy(from, out.join(to)) {
            println!("cargo:warning=cannot copy {from}: {e}");
        }
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    println!("cargo:rustc-link-arg-bin=bootloader=-Tbootloader.x");
}

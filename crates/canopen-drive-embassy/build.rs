//! Tells the crate which Cortex-M architecture it is built for, from the target's name (stable
//! Rust does not expose the Arm target features to `cfg`): `PriorityCeiling` raises BASEPRI on
//! ARMv7-M, ARMv7E-M and ARMv8-M Mainline, and masks NVIC lines on ARMv6-M, which has no
//! BASEPRI. Other targets (hosts, RISC-V, ARMv8-M Baseline) get the critical-section lock only.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(ceiling_basepri)");
    println!("cargo::rustc-check-cfg=cfg(ceiling_nvic)");
    println!("cargo::rerun-if-changed=build.rs");
    let target = std::env::var("TARGET").unwrap_or_default();
    let bare_metal = target.ends_with("-none-eabi") || target.ends_with("-none-eabihf");
    match target.split('-').next() {
        Some("thumbv7m" | "thumbv7em" | "thumbv8m.main") if bare_metal => {
            println!("cargo::rustc-cfg=ceiling_basepri");
        }
        Some("thumbv6m") if bare_metal => println!("cargo::rustc-cfg=ceiling_nvic"),
        _ => {}
    }
}

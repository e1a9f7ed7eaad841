//! The vendor's EDS objects as a Rust table, as its firmware's build.rs would make them.

fn main() {
    println!("cargo:rerun-if-changed=vendor.eds");
    let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").unwrap());
    if let Err(error) =
        canopen_drive_build::Table::new("GENERATED").build("vendor.eds", out.join("generated.rs"))
    {
        panic!("vendor.eds: {error}");
    }
}

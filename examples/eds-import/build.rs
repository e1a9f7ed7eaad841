//! Generates the table of the manufacturer objects of `generic-drive.eds` (see src/lib.rs).

fn main() {
    let Some(out) = std::env::var_os("OUT_DIR") else {
        println!("cargo:warning=OUT_DIR is not set");
        std::process::exit(1);
    };
    let out = std::path::Path::new(&out).join("manufacturer_objects.rs");
    if let Err(error) =
        canopen_drive_build::Table::new("MANUFACTURER_OBJECTS").build("generic-drive.eds", out)
    {
        // The reason names the object and what the core cannot hold.
        println!("cargo:warning=generic-drive.eds: {error}");
        std::process::exit(1);
    }
}

//! Runs a fuzz target's body on corpus files or directories, without libFuzzer (stable
//! toolchain, no sanitizer): `cargo run --manifest-path fuzz/Cargo.toml --release --features
//! tools --bin replay -- <target> <file or dir>...`. A violated invariant panics with its
//! description; the file being run is printed first.

use std::path::PathBuf;

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(target) = args.next() else {
        eprintln!("usage: replay <drive_frames|sdo_server|pdo_mapping|lss> <file or dir>...");
        std::process::exit(2);
    };
    let run: fn(&[u8]) = match target.as_str() {
        "drive_frames" => canopen_drive_fuzz::targets::drive_frames,
        "sdo_server" => canopen_drive_fuzz::targets::sdo_server,
        "pdo_mapping" => canopen_drive_fuzz::targets::pdo_mapping,
        "lss" => canopen_drive_fuzz::targets::lss,
        other => {
            eprintln!("unknown target {other}");
            std::process::exit(2);
        }
    };
    let mut files: Vec<PathBuf> = Vec::new();
    for arg in args {
        let path = PathBuf::from(arg);
        match std::fs::read_dir(&path) {
            Ok(entries) => files.extend(entries.filter_map(|e| e.ok().map(|e| e.path()))),
            Err(_) => files.push(path),
        }
    }
    files.sort();
    let started = std::time::Instant::now();
    for file in &files {
        let Ok(data) = std::fs::read(file) else { continue };
        eprintln!("{}", file.display());
        run(&data);
    }
    println!("{target}: {} inputs ran clean in {:.2?}", files.len(), started.elapsed());
}

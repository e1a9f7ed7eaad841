/work/main/benches/drive-bench/target/debug/deps/drive_bench-309fb68e80c229f7.d: src/lib.rs src/axis.rs src/objects.rs src/rig.rs src/scenarios.rs

/work/main/benches/drive-bench/target/debug/deps/libdrive_bench-309fb68e80c229f7.rlib: src/lib.rs src/axis.rs src/objects.rs src/rig.rs src/scenarios.rs

/work/main/benches/drive-bench/target/debug/deps/libdrive_bench-309fb68e80c229f7.rmeta: src/lib.rs src/axis.rs src/objects.rs src/rig.rs src/scenarios.rs

src/lib.rs:
src/axis.rs:
src/objects.rs:
src/rig.rs:
src/scenarios.rs:

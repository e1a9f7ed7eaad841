/work/main/benches/drive-bench/target/debug/deps/drive_bench-f3e0893b8b9100c8.d: src/main.rs

/work/main/benches/drive-bench/target/debug/deps/drive_bench-f3e0893b8b9100c8: src/main.rs

src/main.rs:

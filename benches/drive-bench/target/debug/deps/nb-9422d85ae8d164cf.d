/work/main/benches/drive-bench/target/debug/deps/nb-9422d85ae8d164cf.d: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/nb-1.1.0/src/lib.rs

/work/main/benches/drive-bench/target/debug/deps/libnb-9422d85ae8d164cf.rlib: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/nb-1.1.0/src/lib.rs

/work/main/benches/drive-bench/target/debug/deps/libnb-9422d85ae8d164cf.rmeta: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/nb-1.1.0/src/lib.rs

/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/nb-1.1.0/src/lib.rs:

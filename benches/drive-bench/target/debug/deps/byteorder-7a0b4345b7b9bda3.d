/work/main/benches/drive-bench/target/debug/deps/byteorder-7a0b4345b7b9bda3.d: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/byteorder-1.5.0/src/lib.rs

/work/main/benches/drive-bench/target/debug/deps/libbyteorder-7a0b4345b7b9bda3.rlib: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/byteorder-1.5.0/src/lib.rs

/work/main/benches/drive-bench/target/debug/deps/libbyteorder-7a0b4345b7b9bda3.rmeta: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/byteorder-1.5.0/src/lib.rs

/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/byteorder-1.5.0/src/lib.rs:

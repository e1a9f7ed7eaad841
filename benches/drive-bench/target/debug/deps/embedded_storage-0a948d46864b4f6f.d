/work/main/benches/drive-bench/target/debug/deps/embedded_storage-0a948d46864b4f6f.d: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/lib.rs /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/iter.rs /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/nor_flash.rs

/work/main/benches/drive-bench/target/debug/deps/libembedded_storage-0a948d46864b4f6f.rlib: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/lib.rs /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/iter.rs /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/nor_flash.rs

/work/main/benches/drive-bench/target/debug/deps/libembedded_storage-0a948d46864b4f6f.rmeta: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/lib.rs /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/iter.rs /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/nor_flash.rs

/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/lib.rs:
/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/iter.rs:
/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embedded-storage-0.3.2/src/nor_flash.rs:

/work/main/benches/drive-bench/target/debug/deps/stable_deref_trait-a2ac9e062780911b.d: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/stable_deref_trait-1.2.1/src/lib.rs

/work/main/benches/drive-bench/target/debug/deps/libstable_deref_trait-a2ac9e062780911b.rlib: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/stable_deref_trait-1.2.1/src/lib.rs

/work/main/benches/drive-bench/target/debug/deps/libstable_deref_trait-a2ac9e062780911b.rmeta: /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/stable_deref_trait-1.2.1/src/lib.rs

/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/stable_deref_trait-1.2.1/src/lib.rs:

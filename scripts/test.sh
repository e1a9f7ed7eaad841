#!/usr/bin/env bash
# Installs everything the test suite needs on a fresh machine, then runs all of it:
# formatting, lints, unit + integration tests, the robustness scenarios (24 h simulated soak),
# no_std builds of the core for the MCU targets, the python-canopen interoperability tests
# against the Linux drive program (generic and vendor profiles), fuzzing (scripts/fuzz.sh),
# the MCU part (scripts/mcu.sh: firmware in QEMU, tick bound, footprint budgets) and the
# instruction-count benchmarks against their budgets (scripts/bench.sh --check).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

step() { printf '\n=== %s\n' "$*"; }

step "toolchain: components and no_std targets (rust-toolchain.toml pins the version)"
rustup component add clippy rustfmt
rustup target add thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imac-unknown-none-elf

step "python venv for the interoperability tests"
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/python/requirements.txt

step "cargo fmt --check"
cargo fmt --all --check

step "cargo clippy (host members, all targets)"
cargo clippy --workspace --all-targets -- -D warnings

step "cargo test"
cargo test --workspace

step "the optional modes (features pp, hm, ip, vl, touch-probe): the core without them, and with each alone"
cargo clippy -p canopen-drive --no-default-features --all-targets -- -D warnings
cargo test -p canopen-drive --no-default-features --test modes
for feature in pp hm ip vl touch-probe; do
    cargo test -p canopen-drive --no-default-features --features "$feature" --test modes
done

step "robustness: fault injection, 24 h simulated soak, hostile configuration (docs/robustness.md)"
SOAK_HOURS=24 CARGO_PROFILE_DEV_OPT_LEVEL=2 \
    cargo test -p canopen-drive-tests --test robustness -- --nocapture

step "cargo doc (library docs build without warnings)"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps -p canopen-drive -p canopen-drive-sim

step "no_std builds of the core"
for target in thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imac-unknown-none-elf; do
    cargo build -p canopen-drive --target "$target"
    cargo build -p canopen-drive --target "$target" --features eds-object
    cargo build -p canopen-drive --target "$target" --no-default-features
    cargo clippy -p canopen-drive --target "$target" -- -D warnings
done

step "python-canopen against canopen-drive-linux"
# Optimised (the timing tests stream at 100 Hz and must not depend on a debug build keeping up
# on a loaded machine), with debug assertions and overflow checks kept on.
CARGO_PROFILE_RELEASE_DEBUG_ASSERTIONS=true CARGO_PROFILE_RELEASE_OVERFLOW_CHECKS=true \
    cargo build --release -p canopen-drive-linux
CANOPEN_DRIVE_LINUX="$root/target/release/canopen-drive-linux" \
    .venv/bin/python -m pytest tests/python -q -p no:cacheprovider

step "fuzzing: every cargo-fuzz target for 45 s (scripts/fuzz.sh)"
./scripts/fuzz.sh 45

step "MCU: firmware in QEMU with python-canopen, tick bound, footprint budgets (scripts/mcu.sh)"
./scripts/mcu.sh

step "benchmarks: instruction counts against their budgets, BENCHMARKS.md up to date (scripts/bench.sh --check)"
./scripts/bench.sh --check

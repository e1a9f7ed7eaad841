#!/usr/bin/env bash
# Installs everything the test suite needs on a fresh machine, then runs all of it:
# formatting, lints, unit + integration tests, no_std builds of the core for the MCU targets,
# and the python-canopen interoperability tests against the Linux drive program.
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

step "cargo doc (library docs build without warnings)"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps -p canopen-drive -p canopen-drive-sim

step "no_std builds of the core"
for target in thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imac-unknown-none-elf; do
    cargo build -p canopen-drive --target "$target"
    cargo build -p canopen-drive --target "$target" --features eds-object
    cargo clippy -p canopen-drive --target "$target" -- -D warnings
done

step "python-canopen against canopen-drive-linux"
cargo build -p canopen-drive-linux
CANOPEN_DRIVE_LINUX="$root/target/debug/canopen-drive-linux" \
    .venv/bin/python -m pytest tests/python -q -p no:cacheprovider

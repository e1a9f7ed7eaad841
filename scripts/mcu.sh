#!/usr/bin/env bash
# The MCU part of the suite (issue 7): installs qemu-system-arm if it is missing, builds the
# QEMU firmware for thumbv7em and thumbv6m (and the real-board firmware for thumbv7em, when it
# is in the tree: drive, bootloader, and the STM32G474CE's application image), the QEMU
# bootloader's two application images (program download, issue 35),
# runs the python-canopen tests against the firmware in QEMU, the
# deterministic tick-bound run (how long the drive holds off the tick; that the current loop
# above the drive's lock keeps its period), and the footprint check against its budgets.
#
# Firmware crates are their own workspaces and are built one per cargo call (RIG.md); their
# build output goes to target/firmware/<crate>. Needs the python venv of scripts/test.sh
# (created here when missing).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
firmware_target="$root/target/firmware"

step() { printf '\n=== %s\n' "$*"; }

step "tools: qemu-system-arm, the thumb targets, llvm-tools (llvm-size)"
if ! command -v qemu-system-arm >/dev/null; then
    if [ "$(id -u)" = 0 ]; then
        apt-get update -qq && apt-get install -y -qq qemu-system-arm >/dev/null
    else
        sudo apt-get update -qq && sudo apt-get install -y -qq qemu-system-arm >/dev/null
    fi
fi
qemu-system-arm --version | head -1
rustup target add thumbv6m-none-eabi thumbv7em-none-eabihf
rustup component add llvm-tools clippy rustfmt

step "python venv (python-canopen)"
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
.venv/bin/pip install --quiet --disable-pip-version-check -r tests/python/requirements.txt

step "canopen-drive-embassy: docs (its tests and lints run in scripts/test.sh's workspace steps), and its feature stm32-fdcan for one FDCAN chip, as docs.rs builds it"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps -p canopen-drive-embassy
# embassy-stm32 builds only with a chip feature, which the crate leaves to the firmware.
fdcan_features=stm32-fdcan,embassy-stm32/stm32g431cb
cargo clippy -p canopen-drive-embassy --features "$fdcan_features" --target thumbv7em-none-eabihf -- -D warnings
RUSTC_BOOTSTRAP=1 RUSTDOCFLAGS="--cfg docsrs -D warnings" \
    cargo doc --no-deps -p canopen-drive-embassy --features "$fdcan_features" --target thumbv7em-none-eabihf

step "rustfmt of the firmware crates"
for crate in boards/qemu-mps2 benches/footprint boards/b-g431b-esc1; do
    [ -f "$crate/Cargo.toml" ] || continue
    (cd "$crate" && cargo fmt --check)
done

step "boards/qemu-mps2: host unit tests (motor model, board objects, identity, program area)"
(cd boards/qemu-mps2 && CARGO_TARGET_DIR="$firmware_target/qemu-mps2-host" \
    cargo test --lib --target x86_64-unknown-linux-gnu -q)

step "boards/qemu-mps2: firmware for thumbv7em (mps2-an386) and thumbv6m (mps2-an385)"
for target in thumbv7em-none-eabihf thumbv6m-none-eabi; do
    (cd boards/qemu-mps2 && CARGO_TARGET_DIR="$firmware_target/qemu-mps2" \
        cargo clippy --release --target "$target" --bins --lib -- -D warnings)
    (cd boards/qemu-mps2 && CARGO_TARGET_DIR="$firmware_target/qemu-mps2" \
        cargo build --release --target "$target" --bins)
done

step "boards/qemu-mps2: the application as the bootloader's program (feature application-image), two builds that differ in 100Ah and 1018h:3, as images (make_image.py)"
# The bootloader itself was built above (bin bootloader, thumbv7em; it builds for thumbv6m
# too, but only the thumbv7em pair runs in the tests). The builds' values are the ones
# tests/qemu/test_program_download.py expects (BUILDS).
image_dir="$firmware_target/qemu-mps2-image"
(cd boards/qemu-mps2 && CARGO_TARGET_DIR="$image_dir" \
    cargo clippy --release --target thumbv7em-none-eabihf --features application-image --bins --lib -- -D warnings)
for build in "1 1.0.0 0x00010000" "2 2.0.0 0x00020000"; do
    read -r n version revision <<<"$build"
    (cd boards/qemu-mps2 && CARGO_TARGET_DIR="$image_dir" \
        QEMU_MPS2_SOFTWARE_VERSION="$version" QEMU_MPS2_REVISION="$revision" \
        cargo build --release --target thumbv7em-none-eabihf --features application-image --bin qemu-mps2)
    cp "$image_dir/thumbv7em-none-eabihf/release/qemu-mps2" "$image_dir/app-$n.elf"
    python3 boards/qemu-mps2/make_image.py "$image_dir/app-$n.elf" "$image_dir/app-$n.img"
done

if [ -f boards/b-g431b-esc1/Cargo.toml ]; then
    step "boards/b-g431b-esc1: firmware for thumbv7em (embassy-stm32): the drive and the bootloader for the STM32G431CB (csp, csv, cst, pv, tq) and the STM32G474CE variant (every mode)"
    # The board's own STM32G431CB (128 KiB) holds the drive without pp, hm, ip, vl and the touch
    # probe (boards/b-g431b-esc1/README.md); the pin-compatible STM32G474CE runs every mode.
    # Each build links both bins: the standalone drive and the bootloader (CiA 302-3, whose
    # link checks that it ends below the program area).
    for features in "" "--no-default-features --features stm32g474ce"; do
        # shellcheck disable=SC2086 # two words of cargo arguments
        (cd boards/b-g431b-esc1 && CARGO_TARGET_DIR="$firmware_target/b-g431b-esc1" \
            cargo clippy --release $features -- -D warnings)
        # shellcheck disable=SC2086
        (cd boards/b-g431b-esc1 && CARGO_TARGET_DIR="$firmware_target/b-g431b-esc1" \
            cargo build --release $features)
    done

    step "boards/b-g431b-esc1: the drive as the bootloader's program (feature application-image): linted for both parts, linked and made an image for the STM32G474CE"
    # On the STM32G431CB the drive does not fit behind the bootloader yet (the README has the
    # numbers): its application-image build is linted, never linked.
    # The same target directory as above (the dependencies are built already); the image and
    # its ELF are kept apart, since the next build of the drive overwrites its output.
    for features in "--features application-image" "--no-default-features --features stm32g474ce,application-image"; do
        # shellcheck disable=SC2086
        (cd boards/b-g431b-esc1 && CARGO_TARGET_DIR="$firmware_target/b-g431b-esc1" \
            cargo clippy --release $features -- -D warnings)
    done
    (cd boards/b-g431b-esc1 && CARGO_TARGET_DIR="$firmware_target/b-g431b-esc1" \
        cargo build --release --no-default-features --features stm32g474ce,application-image --bin b-g431b-esc1)
    board_image_dir="$firmware_target/b-g431b-esc1-image"
    mkdir -p "$board_image_dir"
    cp "$firmware_target/b-g431b-esc1/thumbv7em-none-eabihf/release/b-g431b-esc1" "$board_image_dir/app-g474ce.elf"
    python3 boards/qemu-mps2/make_image.py "$board_image_dir/app-g474ce.elf" "$board_image_dir/app-g474ce.img" \
        --area "$board_image_dir/app-g474ce.area" --payload-offset 0x800
fi

step "python-canopen against the firmware in QEMU (embassy on mps2-an386 and program download through its bootloader, then the bare-interrupt firmware and the thumbv6m build)"
elf_dir="$firmware_target/qemu-mps2"
QEMU_MPS2_ELF="$elf_dir/thumbv7em-none-eabihf/release/qemu-mps2" \
QEMU_BOOTLOADER_ELF="$elf_dir/thumbv7em-none-eabihf/release/bootloader" \
QEMU_APP_IMAGE_1="$image_dir/app-1.img" QEMU_APP_IMAGE_2="$image_dir/app-2.img" \
QEMU_TICK_BOUND_ELF="$elf_dir/thumbv7em-none-eabihf/release/tick-bound" \
QEMU_TICK_BOUND_ELF_V6M="$elf_dir/thumbv6m-none-eabi/release/tick-bound" \
    .venv/bin/python -m pytest tests/qemu -q -p no:cacheprovider -rs
QEMU_MPS2_ELF="$elf_dir/thumbv7em-none-eabihf/release/bare-interrupts" \
    .venv/bin/python -m pytest tests/qemu/test_qemu.py -q -p no:cacheprovider -rs
QEMU_MPS2_ELF="$elf_dir/thumbv6m-none-eabi/release/qemu-mps2" \
    .venv/bin/python -m pytest tests/qemu/test_qemu.py -q -p no:cacheprovider -rs

step "footprint: flash, static RAM and stack against the budgets (writes docs/footprint.md)"
(cd benches/footprint && for target in thumbv7em-none-eabihf thumbv6m-none-eabi; do
    CARGO_TARGET_DIR="$firmware_target/footprint" cargo clippy --release --target "$target" --bins --lib -- -D warnings
done)
FOOTPRINT_TARGET_DIR="$firmware_target/footprint" python3 scripts/footprint.py

#!/usr/bin/env bash
# Boots a firmware ELF of this crate in qemu-system-arm; also the cargo runner of this crate
# (`cargo run --release` / `cargo run --release --target thumbv6m-none-eabi`).
#
#   run.sh ELF
#
# - Machine: mps2-an386 (Cortex-M4F) for thumbv7em builds, mps2-an385 (Cortex-M3) for
#   thumbv6m builds (picked from the ELF's path, or QEMU_MACHINE=an385|an386).
# - CAN: SLCAN on UART0, served by QEMU on 127.0.0.1:$SLCAN_PORT (default 29537), e.g.
#   python-can: interface="slcan", channel="socket://127.0.0.1:29537", sleep_after_open=0.
#   QEMU does not wait for a client: frames sent before one connects are lost (the boot-up).
# - Time: the host's clock by default. QEMU_ICOUNT=shift=3,sleep=off gives `-icount`: one
#   instruction is 8 ns of guest time and idle time is skipped, so the firmware's stopwatch
#   counts instructions, the same on every run — what the self-contained tick-bound firmware
#   uses. Not for a firmware a master talks to: with sleep=off guest time races ahead of the
#   master while the guest idles (1 s SDO timeouts pass in a few ms of host time).
# - Logs: defmt frames over semihosting, decoded on stdout by defmt-print when installed
#   (`cargo install defmt-print`); with DEFMT_RAW=FILE QEMU's stdout (the raw frames and
#   QEMU's own notes) goes to FILE instead.
# - Exit: the firmware's own status, through semihosting (a master writes it to 2F00h).
set -euo pipefail

elf=${1:?usage: run.sh ELF}
port=${SLCAN_PORT:-29537}
shift_arg=${QEMU_ICOUNT:-off}

machine=${QEMU_MACHINE:-}
if [ -z "$machine" ]; then
    case "$elf" in
        *thumbv6m*) machine=an385 ;;
        *) machine=an386 ;;
    esac
fi
case "$machine" in
    an385) args=(-machine mps2-an385 -cpu cortex-m3) ;;
    an386) args=(-machine mps2-an386 -cpu cortex-m4) ;;
    *) echo "run.sh: unknown machine $machine" >&2; exit 2 ;;
esac

args+=(-display none -monitor none -nodefaults
       -serial "tcp:127.0.0.1:${port},server=on,wait=off,nodelay=on"
       -semihosting-config enable=on,target=native)
if [ "$shift_arg" != off ]; then
    args+=(-icount "${shift_arg}")
fi
args+=(-kernel "$elf")
# Anything else for QEMU, e.g. QEMU_EXTRA="-s -S" to wait for gdb.
if [ -n "${QEMU_EXTRA:-}" ]; then
    read -r -a extra <<<"$QEMU_EXTRA"
    args+=("${extra[@]}")
fi

# QEMU writes its own notes to stdout too (align=on's "The guest is now late by …"): they are
# taken out of the frame stream before decoding.
strip_qemu_notes() {
    perl -pe 's/Warning: The guest is now late by [0-9.]+ to [0-9.]+ seconds\.?\n//g'
}

if [ -n "${DEFMT_RAW:-}" ]; then
    exec qemu-system-arm "${args[@]}" >"$DEFMT_RAW"
fi
if command -v defmt-print >/dev/null; then
    set +e
    qemu-system-arm "${args[@]}" | strip_qemu_notes | defmt-print -e "$elf"
    exit "${PIPESTATUS[0]}"
fi
echo "run.sh: defmt-print is not installed (cargo install defmt-print): raw defmt frames on stdout" >&2
exec qemu-system-arm "${args[@]}"

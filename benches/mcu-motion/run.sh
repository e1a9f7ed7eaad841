#!/usr/bin/env bash
# Instruction counts of the motion planner on Cortex-M, in QEMU.
#
# Builds the firmware of this directory for a Cortex-M4F (thumbv7em-none-eabihf, run on
# mps2-an386) and for a core without FPU (thumbv6m-none-eabi, run on mps2-an385, a Cortex-M3
# that runs v6-M code), runs every measurement with the instruction-counting plugin, and prints
# a Markdown table of instructions per call.
#
# Needs qemu-system-arm 7.2 (`apt-get install -y qemu-system-arm`), gcc, and the two Rust
# targets. Environment:
#   CARGO_TARGET_DIR  where to build (default: <repo>/target/mcu-motion)
#   INSNCOUNT_SRC     the plugin source (default: <repo>/tools/qemu-plugins/insncount.c)
#   PLANS, STEPS      repetitions of a plan / a step per run (default: 10 / 1000)
#
# Method: each run prepares the same planners, then repeats "copy a planner, make the call" n
# times; the `base` run only copies. One call = (total − total of base) / n, which counts
# everything the call executes, callees (soft-float, 128-bit division) included.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target/mcu-motion}
insncount_src=${INSNCOUNT_SRC:-$root/tools/qemu-plugins/insncount.c}
plans=${PLANS:-10}
steps=${STEPS:-1000}

command -v qemu-system-arm >/dev/null || { echo "qemu-system-arm missing: apt-get install -y qemu-system-arm" >&2; exit 1; }
mkdir -p "$CARGO_TARGET_DIR"
plugin=$CARGO_TARGET_DIR/libinsncount.so
if [[ ! -f $plugin || $insncount_src -nt $plugin ]]; then
    gcc -O2 -shared -fPIC -fvisibility=hidden -o "$plugin" "$insncount_src"
fi

targets=(thumbv7em-none-eabihf thumbv6m-none-eabi)
declare -A machine=([thumbv7em-none-eabihf]="mps2-an386 cortex-m4" [thumbv6m-none-eabi]="mps2-an385 cortex-m3")
for target in "${targets[@]}"; do
    # One cargo call per target, from this directory (its .cargo/config.toml adds the link
    # script).
    (cd "$here" && cargo build --quiet --release --target "$target")
done

# total <target> <measurement> <repetitions>: guest instructions of one whole run.
total() {
    local target=$1 which=$2 n=$3 board cpu output
    read -r board cpu <<<"${machine[$target]}"
    output=$(timeout 600 qemu-system-arm -machine "$board" -cpu "$cpu" -nographic \
        -semihosting-config "enable=on,target=native,arg=mcu-motion,arg=$which,arg=$n" \
        -kernel "$CARGO_TARGET_DIR/$target/release/mcu-motion" \
        -plugin "$plugin" -d plugin 2>&1) || { echo "$target $which failed: $output" >&2; exit 1; }
    sed -n 's/^insncount: total \([0-9]*\) .*/\1/p' <<<"$output"
}

measurements=(
    "plan-trapezoid-rest|plan, trapezoid, from standstill|$plans"
    "plan-s-curve-rest|plan, jerk-limited, from standstill|$plans"
    "plan-trapezoid-short|plan, trapezoid, from standstill, short (no cruise)|$plans"
    "plan-s-curve-short|plan, jerk-limited, from standstill, short (no cruise)|$plans"
    "replan-trapezoid|plan, trapezoid, re-plan while accelerating|$plans"
    "replan-s-curve|plan, jerk-limited, re-plan while accelerating|$plans"
    "fallback-trapezoid|plan, trapezoid, re-plan that takes the fallback|$plans"
    "fallback-s-curve|plan, jerk-limited, re-plan that takes the fallback|$plans"
    "step-trapezoid|step, trapezoid (ramp tick)|$steps"
    "step-s-curve|step, jerk-limited (jerk tick)|$steps"
)

declare -A base
for target in "${targets[@]}"; do
    for n in "$plans" "$steps"; do
        base[$target/$n]=$(total "$target" base "$n")
    done
done

echo "| call | Cortex-M4F (thumbv7em-none-eabihf, mps2-an386) | no FPU (thumbv6m-none-eabi, Cortex-M3 on mps2-an385) |"
echo "|---|---:|---:|"
for entry in "${measurements[@]}"; do
    IFS='|' read -r which label n <<<"$entry"
    row="| $label |"
    for target in "${targets[@]}"; do
        t=$(total "$target" "$which" "$n")
        row+=" $(( (t - ${base[$target/$n]} + n / 2) / n )) |"
    done
    echo "$row"
done
echo
echo "Instructions per call (QEMU TCG plugin count, $plans plans / $steps steps per run, minus a run that only copies the planner)."

#!/usr/bin/env bash
# Instruction counts of canopen-drive's entry points (issue 8): the control tick in every mode,
# on_frame (+ pop_tx) for the SDO, PDO, NMT, heartbeat and SYNC paths, and object dictionary
# look-ups, and the bootloader's frame and poll paths (issue 35), on a Cortex-M4 (thumbv7em-none-eabihf in QEMU mps2-an386, counted by the project's
# plugin tools/qemu-plugins/insncount.c), on a core without FPU and without the v7-M
# instructions (thumbv6m-none-eabi, the Cortex-M0 instruction set, run by the Cortex-M3 of QEMU
# mps2-an385) and on x86-64 (callgrind). The scenarios are in
# benches/drive-bench (see its README.md); both back-ends run the same scenario code.
#
#   scripts/bench.sh                   measure, print the table, write BENCHMARKS.md
#   scripts/bench.sh --check           also fail when the committed BENCHMARKS.md differs from the
#                                      fresh table (the Cortex-M4 counts are deterministic; the
#                                      x86-64 column is not compared); leaves it as is
#   scripts/bench.sh --update [--force]
#                                      set the budgets in benches/drive-bench/budgets.txt to the
#                                      Cortex-M4 count + 5 % (lowering only, unless --force)
#
# Exits non-zero when a Cortex-M4 count exceeds its budget (benches/drive-bench/budgets.txt).
#
# Method: every repetition starts from the same state. Each measurement prepares a drive
# through the public API, then repeats "copy the prepared drive into a scratch slot, make the
# measured call on the copy" n times; the base mode makes only the copies. Both modes run with n
# and with 2n repetitions, and one call is
#     ((measured(2n) − measured(n)) − (base(2n) − base(n))) / n
# instructions, callees included; start-up, set-up, the harness and the loop's entry and exit
# cancel out, and a difference that does not divide by n (repetitions not identical) is an error. Look-ups change nothing and
# are repeated without copies. On the host only the function that repeats is counted
# (callgrind --toggle-collect, one dump per call); in QEMU the whole run (four runs each).
#
# Whole runs (issue 32: the worst tick of a whole pp move and of a whole homing run): the
# firmware drives the rig through the move once, each tick between two marker functions
# (drive_bench_tick_begin/_end, found with nm); the plugin counts every interval between them
# and reports the largest, and the first, which the firmware makes with nothing between the
# markers: worst tick = largest − first. One QEMU run per target; on the host, callgrind dumps
# every call of drive_bench::counted_tick (the tick between the markers) and the largest, less
# a call of drive_bench::calibrate (the markers alone), is the row's x86-64 count.
#
# The peer (issue 17): when ../shared/peers/canopennode/ is beside the clone (CI), its run.sh
# measures CANopenNode's Cortex-M4 counts and footprint in the same run (it needs
# gcc-arm-none-eabi and libnewlib-arm-none-eabi, installed here), and the table gets its count
# and the ratio for every scenario with a counterpart, plus the 301-only footprint next to
# CANopenNode's. Without it those columns are left out with a note. The peer's code stays in
# ../shared: nothing of it is copied into this repository. It is the only part of this script
# that looks outside the repository, and it is skipped with a note when absent.
#
# Needs qemu-system-arm and valgrind (installed here when missing, as root), gcc, python3 and
# the thumbv7em target. Environment: CARGO_TARGET_DIR (default target/drive-bench; the callgrind
# dumps stay in $CARGO_TARGET_DIR/results/callgrind for callgrind_annotate), REPETITIONS
# (default 10), INSNCOUNT_SRC (the plugin source).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
bench=$root/benches/drive-bench
started=$SECONDS

check=false
update=()
for arg in "$@"; do
    case $arg in
        --check) check=true ;;
        --update) update+=(--update) ;;
        --force) update+=(--force) ;;
        *) echo "usage: scripts/bench.sh [--check | --update [--force]]" >&2; exit 2 ;;
    esac
done
if $check && [ ${#update[@]} -gt 0 ]; then
    echo "--check and --update exclude each other" >&2
    exit 2
fi
if [[ " ${update[*]} " == *" --force "* && " ${update[*]} " != *" --update "* ]]; then
    echo "--force goes with --update" >&2
    exit 2
fi

export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$root/target/drive-bench}
out=$CARGO_TARGET_DIR/results
n=${REPETITIONS:-10}
insncount_src=${INSNCOUNT_SRC:-$root/tools/qemu-plugins/insncount.c}
[ -f "$insncount_src" ] || { echo "QEMU plugin source $insncount_src not found" >&2; exit 1; }

install() {
    if [ "$(id -u)" = 0 ]; then
        apt-get update -qq && apt-get install -y -qq "$@" >/dev/null
    else
        sudo apt-get update -qq && sudo apt-get install -y -qq "$@" >/dev/null
    fi
}
peer_run=${CANOPENNODE_PEER:-$root/../shared/peers/canopennode/run.sh}
missing=()
command -v qemu-system-arm >/dev/null || missing+=(qemu-system-arm)
command -v valgrind >/dev/null || missing+=(valgrind)
if [ -x "$peer_run" ]; then
    command -v arm-none-eabi-gcc >/dev/null || missing+=(gcc-arm-none-eabi libnewlib-arm-none-eabi)
fi
if [ ${#missing[@]} -gt 0 ]; then
    install "${missing[@]}"
fi
rustup target add thumbv7em-none-eabihf thumbv6m-none-eabi >/dev/null 2>&1 || true

mkdir -p "$out"
plugin=$CARGO_TARGET_DIR/libinsncount.so
if [[ ! -f $plugin || $insncount_src -nt $plugin ]]; then
    gcc -O2 -shared -fPIC -fvisibility=hidden -o "$plugin" "$insncount_src"
fi

# Three builds of each: the single-axis measurements, (cargo feature `two-axes`, its own
# target directory) the two-axis ones, and (feature `bootloader`, its own directory) the
# bootloader's, so that no image holds two node types (the compiler would inline the shared
# code differently and the single-axis counts would not be a single-axis firmware's).
echo "building benches/drive-bench (host, thumbv7em-none-eabihf, thumbv6m-none-eabi; one and two axes, bootloader)" >&2
axes_dir=$CARGO_TARGET_DIR/two-axes
boot_dir=$CARGO_TARGET_DIR/bootloader
for features in "" two-axes bootloader; do
    case $features in
        two-axes) dir=$axes_dir ;;
        bootloader) dir=$boot_dir ;;
        *) dir=$CARGO_TARGET_DIR ;;
    esac
    for target in "" thumbv7em-none-eabihf thumbv6m-none-eabi; do
        (cd "$bench" && CARGO_TARGET_DIR=$dir cargo build --quiet --release ${target:+--target $target} \
            ${features:+--features $features})
    done
done
host=$CARGO_TARGET_DIR/release/drive-bench
host_axes=$axes_dir/release/drive-bench
host_boot=$boot_dir/release/drive-bench

# The two-axis rows follow the single-axis ticks; the bootloader's come last.
"$host" list >"$out/labels-one.tsv"
"$host_axes" list >"$out/labels-two.tsv"
"$host_boot" list >"$out/labels-boot.tsv"
awk -v two="$out/labels-two.tsv" '{ print } /^tick-cst\t/ { while ((getline line < two) > 0) print line }' \
    "$out/labels-one.tsv" >"$out/labels.tsv"
cat "$out/labels-boot.tsv" >>"$out/labels.tsv"
mapfile -t names < <(cut -f1 "$out/labels.tsv")
# The whole runs (one QEMU run each, per-tick counts) and the measurements repeated n and 2n
# times (four runs each).
mapfile -t wholes < <("$host" runs)
is_whole() {
    local w
    for w in "${wholes[@]}"; do [ "$w" = "$1" ] && return 0; done
    return 1
}

# --- x86-64: one callgrind run, four dumps per measurement, in the background -----------------
rm -rf "$out/callgrind" "$out/m4" "$out/m0"
mkdir -p "$out/callgrind" "$out/m4" "$out/m0"
callgrind() {
    valgrind --tool=callgrind --collect-atstart=no --compress-strings=no --compress-pos=no \
        --toggle-collect=drive_bench::run_repetitions --dump-after=drive_bench::run_repetitions \
        --callgrind-out-file="$out/callgrind/$2.out" \
        "$1" run "$n" >"$out/callgrind/$2.order" 2>>"$out/callgrind/valgrind.log"
}
# A whole run: one dump per call of drive_bench::counted_tick (the tick between the markers),
# all in one file (--combine-dumps: a file per tick would take twice as long), and one run
# for the markers alone (drive_bench::calibrate). wholes.txt: `name largest markers`.
callgrind_whole() {
    local name=$1 function largest markers
    for function in calibrate counted_tick; do
        valgrind --tool=callgrind --collect-atstart=no --dump-line=no --combine-dumps=yes \
            --toggle-collect=drive_bench::$function --dump-after=drive_bench::$function \
            --callgrind-out-file="$out/callgrind/$name.$function.out" \
            "$host" whole "$name" >/dev/null 2>>"$out/callgrind/valgrind.log"
    done
    largest=$(sed -n 's/^summary: //p' "$out/callgrind/$name.counted_tick.out" | sort -n | tail -1)
    markers=$(sed -n 's/^summary: //p' "$out/callgrind/$name.calibrate.out" | head -1)
    echo "$name $largest $markers" >>"$out/callgrind/wholes.txt"
    rm -f "$out/callgrind/$name.counted_tick.out" "$out/callgrind/$name.calibrate.out"
}
: >"$out/callgrind/wholes.txt"
(
    callgrind "$host" one && callgrind "$host_axes" two && callgrind "$host_boot" boot &&
        for name in "${wholes[@]}"; do callgrind_whole "$name" || exit 1; done
) &
callgrind_pid=$!

# --- Cortex-M4 and v6-M: four QEMU runs per measurement each, two at a time ------------------
elf_of() {
    local dir=$CARGO_TARGET_DIR
    [[ $2 == tick-2-axes-* ]] && dir=$axes_dir
    [[ $2 == boot-* ]] && dir=$boot_dir
    case $1 in
        m4) echo "$dir/thumbv7em-none-eabihf/release/drive-bench" ;;
        *) echo "$dir/thumbv6m-none-eabi/release/drive-bench" ;;
    esac
}
# The markers of the whole runs, per target: plugin arguments begin=ADDR,end=ADDR.
marks_of() {
    nm "$(elf_of "$1" one)" | awk '$3 == "drive_bench_tick_begin" { b = $1 } $3 == "drive_bench_tick_end" { e = $1 }
        END { if (b != "" && e != "") printf "begin=0x%s,end=0x%s", b, e; else exit 1 }'
}
MARKS_M4=$(marks_of m4) && MARKS_M0=$(marks_of m0) || { echo "no tick markers in the firmware" >&2; exit 1; }
qemu_run() {
    local arch=$1 name=$2 mode=$3 reps=$4 log machine plugin=$PLUGIN
    case $arch in
        m4) machine=(-machine mps2-an386 -cpu cortex-m4) ;;
        *) machine=(-machine mps2-an385 -cpu cortex-m3) ;;
    esac
    if [ "$mode" = whole ]; then
        if [ "$arch" = m4 ]; then plugin+=,$MARKS_M4; else plugin+=,$MARKS_M0; fi
    fi
    log=$(timeout 300 qemu-system-arm "${machine[@]}" -kernel "$(elf_of "$arch" "$name")" -nographic \
        -semihosting-config "enable=on,target=native,arg=drive-bench,arg=$name,arg=$reps,arg=$mode" \
        -plugin "$plugin" -d plugin 2>&1) || {
        echo "QEMU $arch $name $mode $reps failed: $log" >&2
        return 1
    }
    if [ "$mode" = whole ]; then
        # intervals, first, largest, its number, unmatched markers; the firmware's tick count.
        sed -n 's/^insncount: intervals \([0-9]*\); first \([0-9]*\); largest \([0-9]*\) (interval \([0-9]*\)); unmatched \([0-9]*\)$/\1 \2 \3 \4 \5/p' \
            <<<"$log" | tr '\n' ' ' >"$OUT/$arch/$name.whole"
        sed -n 's/^ticks=\([0-9]*\)\r\{0,1\}$/\1/p' <<<"$log" >>"$OUT/$arch/$name.whole"
        return 0
    fi
    sed -n 's/^insncount: total \([0-9]*\) .*/\1/p' <<<"$log" >"$OUT/$arch/$name.$mode.$reps"
}
export -f qemu_run elf_of
export CARGO_TARGET_DIR axes_dir boot_dir PLUGIN=$plugin OUT=$out MARKS_M4 MARKS_M0
for arch in m4 m0; do
    for name in "${names[@]}"; do
        if is_whole "$name"; then
            printf '%s %s whole 1\n' "$arch" "$name"
            continue
        fi
        for mode in base measured; do
            printf '%s %s %s %s\n%s %s %s %s\n' "$arch" "$name" "$mode" "$n" "$arch" "$name" "$mode" "$((2 * n))"
        done
    done
done | xargs -P 2 -L 1 bash -c 'qemu_run "$@"' _ || { kill "$callgrind_pid" 2>/dev/null; exit 1; }

wait "$callgrind_pid" || { cat "$out/callgrind/valgrind.log" >&2; exit 1; }

# --- Raw counts -> report ---------------------------------------------------------------------
runs=("base.$n" "base.$((2 * n))" "measured.$n" "measured.$((2 * n))")
# A whole run's row: `name worst-tick` (largest interval − the markers' first), or `name ?`
# when the plugin and the firmware disagree; its tick and the worst tick's number go to
# wholes.txt (`arch name ticks number`).
: >"$out/wholes.txt"
for arch in m4 m0; do
    : >"$out/$arch.txt"
    for name in "${names[@]}"; do
        if is_whole "$name"; then
            intervals='' first='' largest='' at='' unmatched='' ticks=''
            read -r intervals first largest at unmatched ticks <"$out/$arch/$name.whole" || true
            if [[ $ticks =~ ^[0-9]+$ && $intervals == "$((ticks + 1))" && $unmatched == 0 && $at -ge 1 ]]; then
                echo "$name $((largest - first))" >>"$out/$arch.txt"
                echo "$arch $name $ticks $at" >>"$out/wholes.txt"
            else
                echo "$name: $arch: the plugin's intervals do not match the firmware's ticks: $(cat "$out/$arch/$name.whole")" >&2
                echo "$name ?" >>"$out/$arch.txt"
            fi
            continue
        fi
        row=$name
        for run in "${runs[@]}"; do
            value=$(cat "$out/$arch/$name.$run" 2>/dev/null || true)
            row+=" ${value:-0}"
        done
        echo "$row" >>"$out/$arch.txt"
    done
done

# Dump k (from 1) of a run is call (k-1) mod 4 of its measurement (k-1) / 4; kept as
# <name>.<run>.out.
: >"$out/x86.txt"
for build in one two boot; do
    mapfile -t order <"$out/callgrind/$build.order"
    k=1
    for name in "${order[@]}"; do
        row=$name
        for run in "${runs[@]}"; do
            dump=$out/callgrind/$build.out.$k
            value=$(sed -n 's/^summary: \([0-9]*\)$/\1/p' "$dump" 2>/dev/null || true)
            row+=" ${value:-0}"
            [ -f "$dump" ] && mv "$dump" "$out/callgrind/$name.$run.out"
            k=$((k + 1))
        done
        echo "$row" >>"$out/x86.txt"
    done
done
while read -r name largest markers; do
    echo "$name $((largest - markers))" >>"$out/x86.txt"
done <"$out/callgrind/wholes.txt"

# --- The peer: CANopenNode's Cortex-M4 counts and footprint, same QEMU and plugin -------------
peer_args=()
if [ -x "$peer_run" ]; then
    echo "measuring the peer: $peer_run" >&2
    INSNCOUNT_SRC=$insncount_src "$peer_run" --m4-only --build-dir "$CARGO_TARGET_DIR/canopennode-peer" \
        >"$out/peer.log" 2>&1 || { cat "$out/peer.log" >&2; exit 1; }
    peer_args=(--peer-m4 "$CARGO_TARGET_DIR/canopennode-peer/results/m4.tsv"
        --peer-results "$CARGO_TARGET_DIR/canopennode-peer/results/results.md")
else
    echo "bench: peer comparison skipped ($peer_run not found: ../shared is not beside this clone)" >&2
fi

# The 301-only node's footprint: the one this run's mcu step measured (scripts/test.sh sets
# GENERATED_DOCS), else the committed table.
footprint=$root/docs/footprint.md
if [ -n "${GENERATED_DOCS:-}" ] && [ -f "$GENERATED_DOCS/footprint.md" ]; then
    footprint=$GENERATED_DOCS/footprint.md
fi

status=0
python3 "$bench/report.py" --labels "$out/labels.tsv" --m4 "$out/m4.txt" --m0 "$out/m0.txt" --x86 "$out/x86.txt" \
    --wholes "$out/wholes.txt" --repetitions "$n" --budgets "$bench/budgets.txt" --out "$out/BENCHMARKS.md" \
    --footprint "$footprint" "${peer_args[@]}" "${update[@]}" || status=1

# The x86-64 column is not compared: the host binary's libc picks its memcpy by CPU features,
# so that column may differ between machines; the Cortex-M4 and v6-M counts (QEMU) may not. Nor
# is the peer (columns 6 and 7 and the section "The peer"): a clone without ../shared has none.
without_x86() {
    awk -F'|' 'BEGIN { OFS = "|" } /^## The peer/ { peer = 1 } peer { next }
        /^\|/ && NF >= 10 { $5 = ""; $6 = ""; $7 = "" } { print }' "$1"
}
if $check; then
    if ! diff -u <(without_x86 "$root/BENCHMARKS.md") <(without_x86 "$out/BENCHMARKS.md") >&2; then
        echo "BENCHMARKS.md differs from this run: run scripts/bench.sh and commit it" >&2
        status=1
    fi
else
    cp "$out/BENCHMARKS.md" "$root/BENCHMARKS.md"
fi
if [ $status -ne 0 ]; then
    echo "bench: FAILED (see above)" >&2
fi
echo "bench: $((SECONDS - started)) s" >&2
exit $status

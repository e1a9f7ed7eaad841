#!/usr/bin/env bash
# Runs every cargo-fuzz target (fuzz/fuzz_targets/) for SECONDS each (default 60) and fails on
# the first crash: a panic of the core or a violated invariant (see fuzz/src/rig.rs).
#
#   scripts/fuzz.sh [SECONDS]        FUZZ_TARGETS="lss sdo_server" scripts/fuzz.sh 30
#
# - Installs cargo-fuzz if it is missing (cargo install cargo-fuzz --locked).
# - Uses the pinned stable toolchain: cargo-fuzz's -Z flags are allowed with RUSTC_BOOTSTRAP=1.
#   No sanitizer (-s none: the core has no unsafe code, so ASan adds cost, not findings); debug
#   assertions on (-a: an integer overflow is a crash).
# - The whole-drive targets (drive_frames, pdo_mapping, lss) copy a prepared drive per
#   execution (fuzz/src/rig.rs, `Start`) and run short programs from it (-max_len=64), so that
#   an execution takes a fraction of a millisecond (docs/robustness.md has the rates). They are built without comparison tracing
#   (--no-trace-compares; their own target directory): the dictionary's binary searches compare
#   on every access, and tracing them halves the speed. sdo_server keeps the defaults.
# - Seeds fuzz/corpus/<target>/ with the built-in scenarios of fuzz/src/bin/seeds.rs and the
#   frame traces of the integration tests (collected here by running them with
#   CANOPEN_DRIVE_TRACE_DIR, unless FUZZ_TRACES=0 or the directory already has traces).
# - Prints, per target: executions, executions/s, coverage (cov = edges, ft = features) and
#   corpus size; writes them to target/fuzz-report.txt.
# - A crash leaves its input in fuzz/artifacts/<target>/; reproduce it on stable without
#   libFuzzer: cargo run --manifest-path fuzz/Cargo.toml --release --features tools --bin replay -- <target> <file>
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
seconds=${1:-60}
targets=${FUZZ_TARGETS:-"drive_frames sdo_server pdo_mapping lss"}
target_dir=${CARGO_TARGET_DIR:-$root/target}
traces=${CANOPEN_DRIVE_TRACE_DIR:-$target_dir/test-traces}
report=$target_dir/fuzz-report.txt

step() { printf '\n=== %s\n' "$*"; }

if ! cargo fuzz --version >/dev/null 2>&1; then
    step "installing cargo-fuzz"
    cargo install cargo-fuzz --locked
fi
export RUSTC_BOOTSTRAP=1

if [ "${FUZZ_TRACES:-1}" != 0 ] && ! compgen -G "$traces/*.trace" >/dev/null; then
    step "frame traces of the integration tests -> $traces"
    mkdir -p "$traces"
    # A failing integration test is the test suite's business, not the fuzzer's.
    # (The robustness scenarios leave no traces and take a while: skipped.)
    CANOPEN_DRIVE_TRACE_DIR="$traces" cargo test -q -p canopen-drive-tests --tests --no-fail-fast -- \
        --skip fault_injection --skip soak_and_time_wraps --skip hostile_configuration --skip regression_ \
        >/dev/null 2>&1 || true
fi

step "seed corpora"
mkdir -p "$traces"  # empty with FUZZ_TRACES=0
cargo run -q --manifest-path fuzz/Cargo.toml --target-dir "$target_dir/fuzz-tools" --release --features tools --bin seeds \
    -- "$traces"

: > "$report"
for t in $targets; do
    step "fuzzing $t for ${seconds}s"
    log=$target_dir/fuzz-$t.log
    mkdir -p "fuzz/corpus/$t"
    status=0
    case $t in
        drive_frames | pdo_mapping | lss)
            build=(--no-trace-compares --target-dir "$target_dir/cargo-fuzz-drive")
            run=(-max_len=64)
            ;;
        *) build=(--target-dir "$target_dir/cargo-fuzz"); run=() ;;
    esac
    cargo fuzz run -s none -a "${build[@]}" "$t" "fuzz/corpus/$t" -- \
        -max_total_time="$seconds" -timeout=30 -rss_limit_mb=2048 -print_final_stats=1 "${run[@]}" \
        >"$log" 2>&1 || status=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
    cov=$(grep -oE 'cov: [0-9]+ ft: [0-9]+ corp: [0-9]+' "$log" | tail -1)
    line="$t: ${execs:-?} executions, ${rate:-?} exec/s, ${cov:-no coverage line}"
    echo "$line" | tee -a "$report"
    if [ "$status" != 0 ]; then
        grep -E -A2 "panicked at|invariant violated|ERROR: libFuzzer|SUMMARY" "$log" | head -20 || true
        echo "FAILED: $t (exit $status); log: $log; input: fuzz/artifacts/$t/" >&2
        exit 1
    fi
done
step "summary (also in $report)"
cat "$report"

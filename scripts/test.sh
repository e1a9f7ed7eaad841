#!/usr/bin/env bash
# The whole test suite, with everything it needs installed first (on a fresh machine too).
#
#   ./scripts/test.sh            every step (about 15 min warm, 30 cold, on 2 cores)
#   ./scripts/test.sh --quick    format, clippy, unit + integration tests and one python-canopen
#                                smoke test (about 1 min warm)
#   ./scripts/test.sh --bless    every step, and write the generated documents (docs/footprint.md,
#                                docs/robustness.md, BENCHMARKS.md) over the committed ones
#   ./scripts/test.sh --verbose  (with either) stream every step's output instead of a summary
#   ./scripts/test.sh --from KEY (with either) start at the step KEY (e.g. mcu, after a failure
#                                there), keeping the documents earlier steps generated; the
#                                summary says which steps were not run
#
# Each step prints its number, name and duration; its output goes to target/test-logs/NN-name.log
# (shown when the step fails; a step that runs longer than 30 s prints a progress line every 30 s
# with the last line of its output). The run stops at the first failing step and ends with one
# line per step and PASS or FAIL. Goals the measurements do not reach yet (benchmarks, footprint)
# are listed in the summary as such: they are not failures. Budgets are (scripts/bench.sh,
# scripts/footprint.py).
#
# Generated documents are written to target/generated-docs/ and compared with their committed
# copies: a difference fails the run (regenerate with --bless and commit). No tracked file is
# modified by a run; the last step checks that.
#
# What the steps install: rustup components and targets; a Python venv (.venv) with
# tests/python/requirements.txt; with apt-get as root (sudo otherwise), only what is missing:
# can-utils and gcc (trace replay test), qemu-system-arm (scripts/mcu.sh), valgrind
# (scripts/bench.sh); cargo-fuzz (cargo install) for scripts/fuzz.sh, which builds the fuzz
# targets on the pinned stable toolchain with RUSTC_BOOTSTRAP=1 (cargo-fuzz passes -Z flags).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

mode=full
bless=false
verbose=false
from=""
usage="usage: scripts/test.sh [--quick | --bless] [--verbose] [--from STEP]"
while [ $# -gt 0 ]; do
    case $1 in
        --quick) mode=quick ;;
        --bless) bless=true ;;
        --verbose) verbose=true ;;
        --from) [ $# -ge 2 ] || { echo "$usage" >&2; exit 2; }; from=$2; shift ;;
        -h | --help) sed -n '2,28p' "$0"; exit 0 ;;
        *) echo "$usage" >&2; exit 2 ;;
    esac
    shift
done
if $bless && [ $mode = quick ]; then
    echo "--bless needs the full run (the documents come from its slow steps)" >&2
    exit 2
fi

logs=$root/target/test-logs
generated=$root/target/generated-docs
export GENERATED_DOCS=$generated
rm -rf "$logs"
[ -n "$from" ] || rm -rf "$generated"
mkdir -p "$logs" "$generated"

# Tracked files modified before the run (a developer's edits): not the run's doing.
tracked_before=$(git status --porcelain --untracked-files=no 2>/dev/null || true)

apt_install() {
    if [ "$(id -u)" = 0 ]; then
        apt-get update -qq && apt-get install -y -qq "$@" >/dev/null
    else
        sudo apt-get update -qq && sudo apt-get install -y -qq "$@" >/dev/null
    fi
}

# --- The steps ---------------------------------------------------------------------------------

step_toolchain() {
    rustup component add clippy rustfmt
    rustup target add thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imac-unknown-none-elf
}

step_venv() {
    [ -x .venv/bin/python ] || python3 -m venv .venv
    .venv/bin/pip install --quiet --disable-pip-version-check -r tests/python/requirements.txt
    .venv/bin/python -c "import canopen, can, serial; print('canopen', canopen.__version__, 'python-can', can.__version__)"
}

# Where cargo puts what it builds: target/ by default, CARGO_TARGET_DIR (or a cargo config's
# build.target-dir) when set.
cargo_target_dir() {
    cargo metadata --format-version 1 --no-deps |
        python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])'
}

# A firmware vendor's crate outside the workspace (tests/vendor: its own workspace and lock
# file, the library crates by path), as a user of the published crates would build it.
vendor=(--manifest-path tests/vendor/Cargo.toml)

# The no_std firmware example (examples/firmware: its own workspace, built for thumbv7em by its
# .cargo/config.toml, run from its directory so that its memory.x is the one linked).
firmware_example() {
    local dir
    dir="$(cargo_target_dir)/firmware-example"
    (cd examples/firmware && CARGO_TARGET_DIR="$dir" cargo "$@")
}

step_fmt() {
    cargo fmt --all --check
    cargo fmt "${vendor[@]}" --check
    cargo fmt --manifest-path examples/firmware/Cargo.toml --check
}

step_clippy() {
    cargo clippy --workspace --all-targets -- -D warnings
    # The core with its log feature (the Linux program turns it on) and without default features.
    cargo clippy -p canopen-drive --features log --all-targets -- -D warnings
    cargo clippy "${vendor[@]}" --all-targets -- -D warnings
}

step_test() {
    cargo test --workspace
    cargo test "${vendor[@]}"
}

step_python_smoke() {
    cargo build -p canopen-drive-linux
    CANOPEN_DRIVE_LINUX="$(cargo_target_dir)/debug/canopen-drive-linux" .venv/bin/python -m pytest -q -p no:cacheprovider \
        "tests/python/test_drive.py::test_expedited_uploads_of_device_type_and_identity"
}

step_modes() {
    cargo clippy -p canopen-drive --no-default-features --all-targets -- -D warnings
    cargo test -p canopen-drive --no-default-features --test modes
    for feature in pp hm ip vl touch-probe; do
        cargo test -p canopen-drive --no-default-features --features "$feature" --test modes
    done
}

step_robustness() {
    SOAK_HOURS=24 CARGO_PROFILE_DEV_OPT_LEVEL=2 \
        cargo test -p canopen-drive-tests --test robustness -- --nocapture
    [ -f "$generated/robustness.md" ] || { echo "the robustness report was not written"; return 1; }
}

step_doc() {
    RUSTDOCFLAGS="-D warnings" cargo doc --no-deps -p canopen-drive -p canopen-drive-sim -p canopen-drive-slcan
    # As docs.rs builds the core (its [package.metadata.docs.rs]): every feature, and the
    # feature badges of doc_cfg, which needs a nightly compiler (RUSTC_BOOTSTRAP stands in).
    RUSTC_BOOTSTRAP=1 RUSTDOCFLAGS="--cfg docsrs -D warnings" cargo doc --no-deps -p canopen-drive --all-features
    # The public API as a listing in the repository (docs/public-api/): a change to it is a
    # reviewed diff; --bless writes it.
    local api_target
    api_target="$(cargo_target_dir)/public-api"
    if $bless; then
        PUBLIC_API_TARGET_DIR="$api_target" python3 scripts/public_api.py
    else
        PUBLIC_API_TARGET_DIR="$api_target" python3 scripts/public_api.py --check
    fi
}

step_no_std() {
    for target in thumbv6m-none-eabi thumbv7em-none-eabihf riscv32imac-unknown-none-elf; do
        echo "--- $target"
        cargo build -p canopen-drive --target "$target"
        cargo build -p canopen-drive --target "$target" --features eds-object
        cargo build -p canopen-drive --target "$target" --no-default-features
        cargo build -p canopen-drive --target "$target" --features defmt
        cargo clippy -p canopen-drive --target "$target" -- -D warnings
        cargo clippy -p canopen-drive --target "$target" --features defmt -- -D warnings
        cargo clippy -p canopen-drive-slcan --target "$target" -- -D warnings
    done
    # A firmware's table generated from its EDS at build time (canopen-drive-build).
    cargo clippy -p canopen-drive-example-eds-import --target thumbv7em-none-eabihf -- -D warnings
    echo "--- examples/firmware (thumbv7em-none-eabihf)"
    firmware_example clippy --release -- -D warnings
    firmware_example build --release
}

# The library crates with the oldest Rust they declare (`rust-version` of the workspace):
# installed with rustup when missing, then checked for the host and for thumbv7em.
step_msrv() {
    local msrv
    msrv=$(sed -n 's/^rust-version = "\([0-9.]*\)"$/\1/p' Cargo.toml | head -1)
    [ -n "$msrv" ] || { echo "no rust-version in Cargo.toml"; return 1; }
    echo "rust-version $msrv"
    rustup run "$msrv" rustc --version >/dev/null 2>&1 || rustup toolchain install "$msrv" --profile minimal
    rustup target add --toolchain "$msrv" thumbv7em-none-eabihf
    cargo "+$msrv" check -p canopen-drive -p canopen-drive-sim -p canopen-drive-slcan -p canopen-drive-build
    cargo "+$msrv" check -p canopen-drive -p canopen-drive-embassy -p canopen-drive-slcan \
        --target thumbv7em-none-eabihf
    cargo "+$msrv" check -p canopen-drive --target thumbv7em-none-eabihf --no-default-features
    cargo "+$msrv" check -p canopen-drive --target thumbv7em-none-eabihf --all-features
}

# Every library crate as crates.io would take it: packaged (metadata, README, licences, every
# internal dependency with a version) and built from the package against the others' packages.
# --workspace leaves out the members with publish = false; the list says which must be in.
step_publish() {
    # Cargo takes the packages of its temporary registry as it takes any registry's: never
    # changing once unpacked and built. So a second run on the same machine would build the
    # dependent packages against the first run's sources: drop cargo's unpacked copies and
    # verify in a target directory of its own, new each run (a fresh machine has neither).
    rm -rf "${CARGO_HOME:-$HOME/.cargo}"/registry/src/*/canopen-drive*-[0-9]*
    local target
    target="$(cargo_target_dir)/publish"
    rm -rf "$target"
    CARGO_TARGET_DIR="$target" cargo publish --dry-run --workspace --allow-dirty 2>&1 |
        tee "$logs/publish-dry-run.txt"
    local crate status=0
    for crate in canopen-drive canopen-drive-sim canopen-drive-embassy canopen-drive-slcan canopen-drive-build; do
        grep -q "Uploading $crate v" "$logs/publish-dry-run.txt" ||
            { echo "$crate was not packaged"; status=1; }
    done
    return $status
}

step_python() {
    command -v canplayer >/dev/null && command -v gcc >/dev/null || apt_install can-utils gcc
    # Optimised (the timing tests stream at 100 Hz and must not depend on a debug build keeping
    # up on a loaded machine), with debug assertions and overflow checks kept on.
    CARGO_PROFILE_RELEASE_DEBUG_ASSERTIONS=true CARGO_PROFILE_RELEASE_OVERFLOW_CHECKS=true \
        cargo build --release -p canopen-drive-linux
    CANPLAYER_REQUIRED=1 CANOPEN_DRIVE_LINUX="$(cargo_target_dir)/release/canopen-drive-linux" \
        .venv/bin/python -m pytest tests/python -q -p no:cacheprovider -rs
}

step_fuzz() { ./scripts/fuzz.sh 45; }

step_mcu() { ./scripts/mcu.sh; }

step_bench() {
    if $bless; then ./scripts/bench.sh; else ./scripts/bench.sh --check; fi
}

# Compares the documents this run generated with their committed copies (or, with --bless,
# copies them over).
step_generated_docs() {
    local status=0 name compare
    for name in footprint.md robustness.md; do
        compare=()
        # The footprint's sizes move by a few hundred bytes with the directory the firmware is
        # built in (scripts/compare_doc.py says why); everything else must be equal.
        [ $name = footprint.md ] && compare=(--numbers-within 1 --informative "| bytes | kind | symbol |" --informative "| where | bytes |")
        if [ ! -f "$generated/$name" ]; then
            echo "$name: not generated by this run"
            status=1
        elif $bless; then
            cp "$generated/$name" "docs/$name"
            echo "docs/$name: updated from this run"
        elif ! python3 scripts/compare_doc.py "docs/$name" "$generated/$name" "${compare[@]}"; then
            echo "docs/$name differs from this run's target/generated-docs/$name:"
            echo "  regenerate with ./scripts/test.sh --bless (or copy it) and commit"
            status=1
        else
            echo "docs/$name: as generated"
        fi
    done
    return $status
}

step_untouched() {
    local now
    now=$(git status --porcelain --untracked-files=no 2>/dev/null || true)
    if $bless; then
        echo "--bless: the generated documents were updated on purpose:"
        echo "$now"
        return 0
    fi
    if [ "$now" != "$tracked_before" ]; then
        echo "tracked files changed by this run:"
        diff <(echo "$tracked_before") <(echo "$now") || true
        return 1
    fi
    echo "no tracked file modified"
}

# The steps both runs start with.
steps=(
    "toolchain|rustup components and no_std targets|step_toolchain"
    "venv|python venv with python-canopen|step_venv"
    "fmt|cargo fmt --check|step_fmt"
    "clippy|cargo clippy (workspace, all targets; the core with log)|step_clippy"
    "test|cargo test --workspace (unit and integration tests)|step_test"
)
if [ $mode = quick ]; then
    steps+=(
        "python-smoke|python-canopen smoke test against canopen-drive-linux|step_python_smoke"
    )
else
    steps+=(
        "modes|the core without its optional modes, and with each alone|step_modes"
        "robustness|fault injection, 24 h simulated soak, hostile configuration|step_robustness"
        "doc|cargo doc without warnings; the public API listing|step_doc"
        "no-std|the core (with and without defmt) and the SLCAN codec for thumbv6m, thumbv7em, riscv32imac; the firmware example|step_no_std"
        "msrv|the library crates with the declared minimum Rust (rust-version)|step_msrv"
        "publish|cargo publish --dry-run of the library crates|step_publish"
        "python|python-canopen against canopen-drive-linux (all profiles, trace replay)|step_python"
        "fuzz|every cargo-fuzz target for 45 s|step_fuzz"
        "mcu|firmware in QEMU, tick bound, footprint budgets|step_mcu"
        "bench|instruction counts against their budgets|step_bench"
        "docs|generated documents equal their committed copies|step_generated_docs"
    )
fi
steps+=("untouched|no tracked file modified by the run|step_untouched")

# --- Running them --------------------------------------------------------------------------------

clock() {
    local s=$1
    if [ "$s" -ge 60 ]; then printf '%dm%02ds' $((s / 60)) $((s % 60)); else printf '%ds' "$s"; fi
}

# A line on what the step's log says about tests and goals, for the summary.
details() {
    local log=$1 text="" n
    n=$(grep -aoE 'test result: ok\. [0-9]+ passed' "$log" | awk '{s += $4} END {print s + 0}' || true)
    [ "$n" -gt 0 ] && text="$n Rust tests passed"
    n=$(grep -aE '^[0-9]+ passed' "$log" | awk '{s += $1} END {print s + 0}' || true)
    if [ "$n" -gt 0 ]; then
        text="${text:+$text, }$n python tests passed"
        local skipped
        skipped=$(grep -aE '^[0-9]+ passed.*skipped' "$log" | grep -oE '[0-9]+ skipped' | awk '{s += $1} END {print s + 0}' || true)
        [ "$skipped" -gt 0 ] && text="$text ($skipped skipped)"
    fi
    n=$(grep -acE 'goal missed' "$log" || true)
    [ "$n" -gt 0 ] && text="${text:+$text, }$n benchmark goals missed (not a failure; see BENCHMARKS.md)"
    n=$(grep -aE '^\| thumbv7em-none-eabihf \| [a-z0-9-]+ \| [0-9.]+ KiB' "$log" | grep -c ' no ' || true)
    [ "$n" -gt 0 ] && text="${text:+$text, }$n footprint goals missed (not a failure; see docs/footprint.md)"
    echo "$text"
}

total=${#steps[@]}
if [ -n "$from" ] && ! printf '%s\n' "${steps[@]}" | grep -q "^$from|"; then
    echo "no step '$from'; the steps: $(printf '%s\n' "${steps[@]}" | cut -d'|' -f1 | tr '\n' ' ')" >&2
    exit 2
fi
skipping=${from:+true}
results=()
failed=""
run_started=$SECONDS
printf 'scripts/test.sh: %s run, %d steps; logs in %s\n' "$mode" "$total" "${logs#"$root"/}"
for i in "${!steps[@]}"; do
    IFS='|' read -r key title function <<<"${steps[$i]}"
    number=$((i + 1))
    log=$(printf '%s/%02d-%s.log' "$logs" "$number" "$key")
    label=$(printf '[%d/%d] %s' "$number" "$total" "$title")
    [ "$key" = "$from" ] && skipping=""
    if [ -n "$skipping" ]; then
        results+=("$(printf '%-80s %8s  SKIP (--from %s)' "$label" "-" "$from")")
        continue
    fi
    if [ -n "$failed" ]; then
        results+=("$(printf '%-80s %8s  SKIP (not run)' "$label" "-")")
        continue
    fi
    printf '\n%s\n' "$label"
    started=$SECONDS
    if $verbose; then
        set +e
        ("$function") 2>&1 | tee "$log"
        status=${PIPESTATUS[0]}
        set -e
    else
        ("$function") >"$log" 2>&1 &
        pid=$!
        next_report=$((SECONDS + 30))
        while kill -0 "$pid" 2>/dev/null; do
            sleep 1
            if [ $SECONDS -ge $next_report ]; then
                last=$(tail -c 2000 "$log" | tr '\r' '\n' | grep -av '^\s*$' | tail -1 | cut -c1-100 || true)
                printf '    ... %s: %s\n' "$(clock $((SECONDS - started)))" "$last"
                next_report=$((SECONDS + 30))
            fi
        done
        set +e
        wait "$pid"
        status=$?
        set -e
    fi
    took=$(clock $((SECONDS - started)))
    note=$(details "$log")
    if [ "$status" -eq 0 ]; then
        printf '    PASS in %s%s\n' "$took" "${note:+ ($note)}"
        results+=("$(printf '%-80s %8s  PASS%s' "$label" "$took" "${note:+  $note}")")
    else
        printf '    FAIL in %s (exit %d); the end of %s:\n' "$took" "$status" "${log#"$root"/}"
        $verbose || tail -n 60 "$log" | sed 's/^/    | /'
        results+=("$(printf '%-80s %8s  FAIL (see %s)' "$label" "$took" "${log#"$root"/}")")
        failed=$key
    fi
done

printf '\n=== summary (%s run, %s)\n' "$mode" "$(clock $((SECONDS - run_started)))"
printf '%s\n' "${results[@]}"
passed=0
for line in "${results[@]}"; do
    [[ $line == *"  PASS"* ]] && passed=$((passed + 1))
done
if [ -n "$failed" ]; then
    echo "FAIL: step '$failed' failed"
    echo "steps: $passed passed, 1 failed"
    exit 1
fi
if [ -n "$from" ]; then
    echo "PASS (from step '$from' on; the steps before it were not run)"
else
    echo "PASS"
fi
echo "steps: $passed passed, 0 failed"

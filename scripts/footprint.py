#!/usr/bin/env python3
"""Footprint of canopen-drive on Cortex-M: builds benches/footprint (a CiA 301-only node, the
full drive, and the bare harness) for thumbv7em-none-eabihf and thumbv6m-none-eabi with
opt-level "s" and LTO, reads flash and static RAM from the ELF sections, measures the stack
in QEMU (stack painting), prints the table, writes the page docs/footprint.md is a committed
copy of (into target/generated-docs/footprint.md, or --doc PATH) and checks the budgets in
benches/footprint/budgets.txt.

    scripts/footprint.py            build, measure, write the doc, check (exit 1 over budget)
    scripts/footprint.py --update   same, then set the budgets to the measured values + margin
    scripts/footprint.py --doc docs/footprint.md   write the committed copy directly

scripts/test.sh compares the fresh page with docs/footprint.md and fails when they differ
(`scripts/test.sh --bless` copies it over).

flash = .vector_table + .text + .rodata + .data (its initial values live in flash);
static RAM = .data + .bss + .uninit (the node lives in a static, as on a board).
"""

import argparse
import math
import os
import pathlib
import re
import shutil
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
CRATE = ROOT / "benches" / "footprint"
BUDGETS = CRATE / "budgets.txt"
DOC = pathlib.Path(os.environ.get("GENERATED_DOCS", ROOT / "target" / "generated-docs")) / "footprint.md"
TARGET_DIR = pathlib.Path(os.environ.get("FOOTPRINT_TARGET_DIR", ROOT / "target" / "firmware" / "footprint"))
TARGETS = {
    "thumbv7em-none-eabihf": ["-machine", "mps2-an386", "-cpu", "cortex-m4"],
    "thumbv6m-none-eabi": ["-machine", "mps2-an385", "-cpu", "cortex-m3"],
}
IMAGES = ["baseline", "node301", "bootloader", "drive-full", "drive-cyclic", "drive-two-axes"]
# Images built from another image's binary with other cargo arguments, in their own target
# directory: image -> (binary, cargo arguments).
VARIANTS = {"drive-cyclic": ("drive-full", ["--no-default-features"])}
# The goals (thumbv7em), in bytes.
GOALS = {
    ("thumbv7em-none-eabihf", "drive-full"): (48 * 1024, 8 * 1024),
    ("thumbv7em-none-eabihf", "node301"): (13 * 1024, 2 * 1024),
    # Issue 35: a bootloader node (CiA 301 and program download) in at most 24 KiB.
    ("thumbv7em-none-eabihf", "bootloader"): (24 * 1024, 2 * 1024),
}
# Issue 32 (a bounded tick): the full drive's deepest tick stack and the bytes of its trajectory
# code (`motion/`, the area of AREAS named TRAJECTORY) on thumbv7em.
TICK_STACK_GOAL = ("thumbv7em-none-eabihf", "drive-full", 2048)
TRAJECTORY_GOAL = 8 * 1024
MARGIN = 1.03  # budgets = measured + 3 %, rounded up to 256 bytes
EXCEPTION_FRAME = 32  # basic Cortex-M exception frame (no FPU context)


def size_tool():
    sysroot = subprocess.run(["rustc", "--print", "sysroot"], capture_output=True, text=True).stdout.strip()
    for candidate in pathlib.Path(sysroot).glob("lib/rustlib/*/bin/llvm-size"):
        return str(candidate)
    for name in ("llvm-size", "rust-size"):
        if shutil.which(name):
            return name
    sys.exit("footprint: no llvm-size (rustup component add llvm-tools)")


def build(target):
    env = dict(os.environ, CARGO_TARGET_DIR=str(TARGET_DIR))
    subprocess.run(["cargo", "build", "--release", "--target", target, "--bins"], cwd=CRATE, env=env, check=True)
    for image, (binary, arguments) in VARIANTS.items():
        env = dict(os.environ, CARGO_TARGET_DIR=str(TARGET_DIR / image))
        subprocess.run(["cargo", "build", "--release", "--target", target, "--bin", binary, *arguments],
                       cwd=CRATE, env=env, check=True)


def elf(target, image):
    if image in VARIANTS:
        return TARGET_DIR / image / target / "release" / VARIANTS[image][0]
    return TARGET_DIR / target / "release" / image


def sections_of(path, tool):
    out = subprocess.run([tool, "-A", str(path)], capture_output=True, text=True, check=True).stdout
    sizes = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sizes[parts[0]] = int(parts[1])
    return sizes


def sections(path, tool):
    sizes = sections_of(path, tool)
    flash = sum(sizes.get(s, 0) for s in (".vector_table", ".text", ".rodata", ".data"))
    ram = sum(sizes.get(s, 0) for s in (".data", ".bss", ".uninit"))
    return flash, ram


def stack(target, image):
    if shutil.which("qemu-system-arm") is None:
        return None
    cmd = ["qemu-system-arm", *TARGETS[target], "-display", "none", "-monitor", "none", "-nodefaults",
           "-semihosting-config", "enable=on,target=native", "-kernel", str(elf(target, image))]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    # The semihosting console is stderr or stdout depending on the QEMU build: look in both.
    match = re.search(r"init=(\d+) comm=(\d+) tick=(\d+)", result.stdout + result.stderr)
    if result.returncode != 0 or not match:
        sys.exit(f"footprint: the stack run of {image} ({target}) failed: {result.returncode}\n{result.stdout}{result.stderr}")
    return tuple(int(g) for g in match.groups())


def top_symbols(path, count=12):
    nm = pathlib.Path(size_tool()).with_name("llvm-nm")
    tool = str(nm) if nm.exists() else "llvm-nm"
    out = subprocess.run([tool, "--size-sort", "-S", "-C", str(path)], capture_output=True, text=True).stdout
    rows = []
    for line in out.splitlines():
        parts = line.split(None, 3)
        if len(parts) == 4 and parts[2] in "tTrR":
            name = re.sub(r"::h[0-9a-f]{16}$", "", parts[3])
            for code, text in (("$LT$", "<"), ("$GT$", ">"), ("$u7b$", "{"), ("$u7d$", "}"), ("$C$", ","),
                               ("$u20$", " "), ("$RF$", "&"), ("$BP$", "*"), (".." , "::")):
                name = name.replace(code, text)
            rows.append((int(parts[1], 16), parts[2].lower(), name))
    return rows[-count:][::-1]


# Where the code of an image comes from: the source file of each instruction (the innermost
# inlined location, from the line table), grouped. First match wins; `core::…` code inlined
# into the crate's functions counts as the library's (its share is the cost of 64/128-bit
# arithmetic, comparisons and Option/Result plumbing that the crate's code expands to).
AREAS = [
    ("the run-time of one axis (`cia402/profile.rs`: `Profile::tick` and its helpers)", ["canopen-drive/src/cia402/profile.rs"]),
    ("the CiA 402 modes and functions (`cia402/`: pp, hm, vl, ip, cyclic, touch probe, FSA, factor group, object rules)", ["canopen-drive/src/cia402/"]),
    ("the trajectory code (`motion/`: the position planner of pp and hm, the velocity ramps, unit conversion, limit clamps)", ["canopen-drive/src/motion/"]),
    ("128-bit division and multiplication, compiled once (`wide.rs`: for `motion/`, the factor group, vl, the cyclic limiter)", ["canopen-drive/src/wide.rs"]),
    ("the object dictionary (`od/`: look-up, values, rules, storage format)", ["canopen-drive/src/od/"]),
    ("the CiA 301 services and the composer (`comm/`, `wire/`, `drive.rs`, …)", ["canopen-drive/src/"]),
    ("`core` integer arithmetic inlined (64/128-bit multiplication, division, saturation)", ["/library/core/src/num/", "/library/core/src/intrinsics/", "/int/specialized_div_rem/"]),
    ("`core` comparisons, `Option`/`Result`, slices, iterators and copies inlined", ["/library/core/src/"]),
]


# The index in AREAS of the trajectory code (issue 32's goal).
TRAJECTORY = next(n for n, (_, prefixes) in enumerate(AREAS) if prefixes == ["canopen-drive/src/motion/"])


def code_areas(path):
    """Bytes of code per entry of AREAS (and the rest), from the line table of `path`."""
    objdump = pathlib.Path(size_tool()).with_name("llvm-objdump")
    tool = str(objdump) if objdump.exists() else "llvm-objdump"
    out = subprocess.run([tool, "-d", "-l", "--no-show-raw-insn", str(path)], capture_output=True, text=True).stdout
    sizes = [0] * (len(AREAS) + 1)
    current, previous = None, None
    for line in out.splitlines():
        located = re.match(r"^; (/\S+):\d+", line)
        if located:
            current = located.group(1)
            continue
        insn = re.match(r"^\s+([0-9a-f]+):\s", line)
        if not insn:
            previous = None if not line.strip() else previous
            continue
        address = int(insn.group(1), 16)
        if previous is not None and 0 < address - previous[0] < 8:
            sizes[previous[1]] += address - previous[0]
        area = len(AREAS)
        for n, (_, prefixes) in enumerate(AREAS):
            if current and any(p in current for p in prefixes):
                area = n
                break
        previous = (address, area)
    return sizes


def read_budgets():
    budgets = {}
    if BUDGETS.exists():
        for line in BUDGETS.read_text().splitlines():
            fields = line.split("#")[0].split()
            if len(fields) == 4:
                budgets[(fields[0], fields[1])] = (int(fields[2]), int(fields[3]))
    return budgets


def write_budgets(results):
    lines = [
        "# Footprint budgets checked by scripts/footprint.py (bytes): target image flash static-ram.",
        "# Set from the measured values + 3 % (scripts/footprint.py --update); the issue's goals",
        "# (thumbv7em: full drive 48 KiB / 8 KiB, 301-only node 13 KiB / 2 KiB) are met for the full",
        "# drive's RAM only: see docs/footprint.md.",
    ]
    for (target, image), r in sorted(results.items()):
        if image == "baseline":
            continue
        flash = math.ceil(r["flash"] * MARGIN / 256) * 256
        ram = math.ceil(r["ram"] * MARGIN / 256) * 256
        lines.append(f"{target} {image} {flash} {ram}")
    BUDGETS.write_text("\n".join(lines) + "\n")


def kib(n):
    return f"{n / 1024:.1f} KiB"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--update", action="store_true", help="set the budgets from this measurement")
    parser.add_argument("--doc", type=pathlib.Path, default=DOC, help="where to write the page")
    args = parser.parse_args()
    tool = size_tool()
    results = {}
    for target in TARGETS:
        build(target)
        for image in IMAGES:
            flash, ram = sections(elf(target, image), tool)
            results[(target, image)] = {"flash": flash, "ram": ram, "stack": stack(target, image)}
    if args.update:
        write_budgets(results)
    budgets = read_budgets()

    header = "| target | image | flash | static RAM | library flash (image − baseline) | stack: build / comm / tick / worst | budget (flash / RAM) | |"
    rows = [header, "|---|---|---|---|---|---|---|---|"]
    failures = []
    for (target, image), r in results.items():
        base = results[(target, "baseline")]
        s = r["stack"]
        if s is None:
            stack_text = "(no QEMU)"
        else:
            init, comm, tick = s
            worst = comm + tick + EXCEPTION_FRAME
            stack_text = f"{init} / {comm} / {tick} / {worst}"
        budget = budgets.get((target, image))
        if image == "baseline":
            verdict, budget_text = "", "–"
        elif budget is None:
            verdict, budget_text = "no budget", "–"
            failures.append(f"{target} {image}: no budget in {BUDGETS.relative_to(ROOT)}")
        else:
            ok = r["flash"] <= budget[0] and r["ram"] <= budget[1]
            verdict = "ok" if ok else "OVER"
            budget_text = f"{budget[0]} / {budget[1]}"
            if not ok:
                failures.append(f"{target} {image}: flash {r['flash']} / RAM {r['ram']} over budget {budget[0]} / {budget[1]}")
        library = r["flash"] - base["flash"] if image != "baseline" else 0
        rows.append(
            f"| {target} | {image} | {r['flash']} ({kib(r['flash'])}) | {r['ram']} ({kib(r['ram'])}) | "
            f"{library if image != 'baseline' else '–'} | {stack_text} | {budget_text} | {verdict} |"
        )
    table = "\n".join(rows)
    print(table)

    goal_rows = ["| target | image | goal flash / RAM | measured flash / RAM | reached: flash / RAM |",
                 "|---|---|---|---|---|"]
    for (target, image), (gf, gr) in GOALS.items():
        r = results[(target, image)]
        reached = f"{'yes' if r['flash'] <= gf else 'no'} / {'yes' if r['ram'] <= gr else 'no'}"
        goal_rows.append(f"| {target} | {image} | {kib(gf)} / {kib(gr)} | {kib(r['flash'])} / {kib(r['ram'])} | {reached} |")
    goals = "\n".join(goal_rows)
    print()
    print(goals)

    target, image, goal = TICK_STACK_GOAL
    s = results[(target, image)]["stack"]
    tick_rows = ["| target | image | goal: deepest `tick` stack | measured | reached |", "|---|---|---|---|---|"]
    if s is None:
        tick_rows.append(f"| {target} | {image} | {kib(goal)} ({goal} B) | (no QEMU) | – |")
    else:
        tick = s[2]
        tick_rows.append(f"| {target} | {image} | {kib(goal)} ({goal} B) | {kib(tick)} ({tick} B) | {'yes' if tick <= goal else 'no'} |")
    tick_stack = "\n".join(tick_rows)
    print()
    print(tick_stack)

    symbols = top_symbols(elf("thumbv7em-none-eabihf", "drive-full"))
    symbol_rows = ["| bytes | kind | symbol |", "|---|---|---|"] + [
        f"| {size} | {'code' if kind == 't' else 'data'} | `{name.replace('|', '/')}` |" for size, kind, name in symbols
    ]
    full = elf("thumbv7em-none-eabihf", "drive-full")
    sizes = code_areas(full)
    rodata = sections_of(full, tool).get(".rodata", 0)
    area_rows = ["| where | bytes | goal (issue 32) |", "|---|---|---|"]
    for n, ((label, _), size) in enumerate(zip(AREAS, sizes)):
        goal = "–"
        if n == TRAJECTORY:
            goal = f"{kib(TRAJECTORY_GOAL)}: {'reached' if size <= TRAJECTORY_GOAL else 'not reached'}"
        area_rows.append(f"| {label} | {size} ({kib(size)}) | {goal} |")
    area_rows.append(f"| the rest of the code (the harness, `cortex-m-rt`, compiler built-ins) | {sizes[-1]} ({kib(sizes[-1])}) | – |")
    area_rows.append(f"| `.rodata`: the dictionary's tables, names, constants | {rodata} ({kib(rodata)}) | – |")
    areas = "\n".join(area_rows)
    print()
    print(areas)
    axis_rows = ["| target | flash: one axis / two axes / the second axis | static RAM: one axis / two axes / the second axis |",
                 "|---|---|---|"]
    for target in TARGETS:
        one, two = results[(target, "drive-full")], results[(target, "drive-two-axes")]
        axis_rows.append(
            f"| {target} | {one['flash']} / {two['flash']} / {two['flash'] - one['flash']} | "
            f"{one['ram']} / {two['ram']} / {two['ram'] - one['ram']} |"
        )
    axes = "\n".join(axis_rows)
    print()
    print(axes)
    args.doc.parent.mkdir(parents=True, exist_ok=True)
    args.doc.write_text(
        DOC_TEMPLATE.format(table=table, goals=goals, tick_stack=tick_stack, areas=areas, axes=axes,
                            symbols="\n".join(symbol_rows))
    )
    print(f"\nwrote {args.doc}")
    if failures:
        print("\nover budget:\n  " + "\n  ".join(failures), file=sys.stderr)
        sys.exit(1)
    print("footprint: every image within its budget")


DOC_TEMPLATE = """# Footprint on Cortex-M

Written by `scripts/footprint.py` (do not edit by hand: `scripts/mcu.sh` writes it to
`target/generated-docs/` and `scripts/test.sh` fails when this copy differs in its text or by
more than 1 % in a number: `scripts/compare_doc.py`; `--bless` updates it).
Images from `benches/footprint`, built with opt-level "s", fat LTO, one codegen unit,
panic = abort, and without the crate's default `names` feature (no parameter names in the
tables: a firmware that does not write its EDS leaves them out, some 4 KiB):

- `baseline`: the measuring harness alone (cortex-m-rt start-up, a scripted master fed
  through volatile reads, the stack probe, semihosting output);
- `node301`: a CiA 301-only node composed from the crate's services (NMT, SDO server with
  expedited / segmented / block transfer, heartbeat, EMCY, SYNC consumer, 4 + 4 PDOs, the
  standard 1xxxh objects; see `benches/footprint/src/node301.rs`);
- `bootloader`: the crate's bootloader node (`canopen_drive::bootloader`: NMT, heartbeat, SDO
  server with expedited / segmented / block transfer streaming to the program area, CiA 302-3
  program download 1F50h–1F57h, the identity objects) over a stand-in program area that reads
  erased and takes every write (`benches/footprint/src/boot.rs`);
- `drive-full`: `Drive::build_in` with `Config::new(5)`, every CiA 402 mode, 4 + 4 PDOs, the
  dictionary store sized to the standard tables (`drive::STANDARD_OD_BYTES`, about 1 KiB; the
  default `DEFAULT_OD_BYTES` of 3 KiB leaves room for a firmware's own objects);
- `drive-cyclic`: the same drive built without the crate's optional modes (cargo features
  `pp`, `hm`, `ip`, `vl`, `touch-probe` off): csp, csv, cst, pv and tq, as a drive under a
  motion controller runs them. The session's profile position move is refused there.
- `drive-two-axes`: the full drive with two CiA 402 axes (`Drive<…, AXES = 2>`, 4 + 4 PDOs per
  axis, the store sized to its tables); the session drives the first axis, both tick every
  millisecond (`benches/footprint/src/bin/drive_two_axes.rs`).

Flash = `.vector_table + .text + .rodata + .data`; static RAM = `.data + .bss + .uninit`,
with the node in a static. Bytes.

{table}

Stack (bytes, measured in QEMU by painting): *build* is the deepest use from reset through
constructing the node (before any interrupt runs); *comm* the deepest `on_frame`/`poll` call of
the scripted session (every SDO transfer type, NMT, the CiA 402 state machine, two profile
position moves); *tick* the deepest `tick` of the session (those that plan take a trapezoid's
set-point and its quick stop, then a jerk-limited set-point, a change-immediately set-point
while it moves, a halt and its release; the session has no homing run); *worst* = comm + tick + a 32-byte
exception frame, for a board whose tick interrupt preempts the deepest communication call. The
probe reads with a granularity of a few dozen bytes.

## Two axes

What a second axis adds (`drive-two-axes` − `drive-full`): the second profile (its state and
its objects' values) and the PDO records of PDOs 5–8 in RAM; in flash the code that ticks
and routes by axis and the larger PDO table, not a second copy of the profile's description
or code (the dictionary attaches one description per axis, 6000h + n × 800h).

{axes}

## Goals of the issue

{goals}

Issue 32 (a bounded tick): the full drive's deepest tick stack (the *tick* column above) at most
2 KiB, and its trajectory code at most 8 KiB on thumbv7em (the `motion/` row of the table of
bytes by source area below; the `core` arithmetic inlined into that code counts in the `core`
rows, and the 128-bit helpers of `wide.rs` it shares have a row of their own).

{tick_stack}

The flash goals are not reached. The full drive's static RAM is within its goal since the
dictionary store is sized to the tables (`drive::STANDARD_OD_BYTES` instead of the 3 KiB
default, −2 KiB) and every mode keeps its state in one variant of the active mode (pp's,
vl's, ip's and the cyclic modes' share the same bytes) but for pp's and homing's trajectory,
one planner of some 1.3 KiB per axis that the two share (session 17); the 301-only
node's since issue 17 (an optional instant in 8 bytes, not 16, through a niche of `Instant`;
PDO and SDO timers in 4 bytes; one TPDO data buffer: 2 296 → 2 048 B). Since issue 21 the
profile keeps the motion limits it converted, with the values they came from (about 260 B), so
that a tick divides again only when a master changes one, and the inputs and demand of its
last idle tick (some 80 B with the dictionary's revision and the TPDOs' wake time), so that an
idle tick repeats them while nothing changed (the revision and the sample). Without the
optional modes (`drive-cyclic`: cargo features `pp`, `hm`, `ip`, `vl`, `touch-probe` off) the
drive takes a little over half the full image's flash — the trajectory generator of pp and
hm and the code of those modes are the difference — and some 1.6 KiB less static RAM: the
planner of pp and hm exists only in the builds that run them. The budgets in `benches/footprint/budgets.txt` are therefore
set at the measured values plus 3 % (`scripts/footprint.py --update`) so that CI catches
growth; they are not the goals.

Where the bytes of `drive-full` (thumbv7em) go, by the source file of each instruction (the
innermost inlined location of the line table: `core` code that the crate's 64- and 128-bit
arithmetic, comparisons and `Option`/`Result` handling expand to is counted as `core`'s):

{areas}

Read with the symbols below: `Profile::tick` is inlined into `Drive::full_tick` (some 12 KiB
with the drive's part), each mode's step is a function of its own since session 17 (`run_pp`,
`run_homing`, `run_vl`, `run_cyclic`, …: some 15 KiB together; one mode runs at a time, but
every mode of the build is in the image), the bounded trajectory generator (`motion::ramps`,
`pulse`, `planner`, `fixed`) about 19 KiB, much of it 128-bit arithmetic inlined (checked sums
and products; the divisions go through `fixed` and `crate::wide`), and the dictionary's
descriptions (40 bytes per entry without names, 56 per object) most of `.rodata`. The goal of
48 KiB is beyond what the open items can give: the motion code alone is some 19 KiB and the
profile's tick and modes some 27 KiB, and descriptors of 16 bytes
(issue 17 item 2) would save some 6 KiB of `.rodata`. The rest is spread over parts of a size
each: the CiA 301 services, the dictionary, the modes, the profile's run-time and the `core`
code they inline (Option/Result handling, comparisons, copies).

The largest symbols of `drive-full` on thumbv7em:

{symbols}

## Stack

Boards build the drive in place (`Drive::build_in` into a `static`, e.g. `StaticCell::uninit()`):
the *build* column is then about one drive's worth of stack (the drive is assembled once and
written into its place). Built by value with `Drive::new` and moved into a static, the same
image needed about 43 KiB (several copies in the constructor's frame) — more than a 32 KiB
part has.

The tick's depth (thumbv7em, frames read from the disassembly's stack adjustments and calls,
session 18). Two chains, one after the other, never one on the other:
- the tick's work: `Drive::full_tick` with `Profile::tick` inlined, about 0.8 KiB; the active
  mode's step under it (`Profile::run_pp` about 0.45 KiB, `run_homing` 0.37, each mode's step
  a function of its own); under that a set-point's request (checked and converted, some
  0.3 KiB to `Ramps::ask_jerk`) or the planner's step (`PositionPlanner::follow`: a tick of
  the plan, no planning);
- then, once the demands are out, the share of a plan in progress for the next tick
  (`Drive::tick_axes` calls `Profile::plan_ahead` for each axis): a stage of a trapezoid
  (`Ramps::work_trapezoid`, some 0.5 KiB with its callees) or of a jerk-limited plan
  (`Ramps::work_jerk`, up to some 1.2 KiB).

Measured, the deepest tick is 1 928 B (2 956 B with the share under the mode's step, session
17). The disassembly's longest chain, which follows every call whether a tick takes it or
not, is about 2.2 KiB: the first chain down to a 128-bit division that a request reaches only
for a decay of more than 2²⁰ ticks (`fixed::exact_ticks` → `div_ceil` → `wide::udivrem_wide`,
some 0.4 KiB). The share of the tick that asks for a plan only begins it, so a plan starts one
tick later than with the share before the step; the provisional acceleration of a trapezoid
being planned is chosen in the share, so the share that completes a plan computes none. pp
and homing share one position planner per axis, built when the drive is configured and reset
in place when either mode starts, so a change of the mode of operation builds no planner on
the tick's stack (it was the deepest tick, 4.1 KiB). An NMT reset resets each profile in place
(`Profile::reset`, field by field): no profile is built on its stack.
"""

if __name__ == "__main__":
    main()

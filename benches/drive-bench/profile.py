#!/usr/bin/env python3
"""Where the instructions of one measurement go, per function (self cost, inlined code counted
in the function it was inlined into), per call.

    benches/drive-bench/profile.py <measurement> [--top K] [--m4 [--lines]]

x86-64 (default): reads the callgrind dumps scripts/bench.sh leaves in
$CARGO_TARGET_DIR/results/callgrind (default target/drive-bench). --m4: runs the firmware that
scripts/bench.sh built in QEMU with tools/qemu-blockcount.c (built here) and maps the blocks to
the firmware's symbols with llvm-nm (`rustup component add llvm-tools`). Either way it prints
(measured(2n) − base(2n)) / 2n per function: the copies of the drive cancel out.
"""

import argparse
import bisect
import collections
import glob
import os
import pathlib
import re
import shutil
import subprocess
import sys

REPETITIONS = 10


def self_costs(path):
    """Self cost per function name of one callgrind dump (uncompressed names)."""
    costs = collections.Counter()
    function, skip_next = None, False
    with open(path) as f:
        for line in f:
            if line.startswith("fn="):
                function = line[3:].strip()
            elif line.startswith("calls="):
                skip_next = True  # the next cost line is the inclusive cost of the call
            elif line[:1].isdigit() or line[:1] in "+-*":
                if skip_next:
                    skip_next = False
                    continue
                fields = line.split()
                if function is not None and len(fields) >= 2:
                    costs[function] += int(fields[1])
    return costs


def readable(symbol):
    """A Rust legacy symbol as llvm-nm -C leaves it, without hash and escapes."""
    symbol = re.sub(r"::h[0-9a-f]{16}$", "", symbol)
    if symbol.startswith("_$"):
        symbol = symbol[1:]
    for escape, text in (("$LT$", "<"), ("$GT$", ">"), ("$C$", ","), ("$u20$", " "), ("$RF$", "&"), ("..", "::")):
        symbol = symbol.replace(escape, text)
    return symbol


# Line tables already read, by firmware.
LINES = {}


def line_table(firmware, tool):
    """Address -> (the innermost source line of the crate's code, address of the next
    instruction), from the firmware's line table: code of `core` inlined into the crate counts
    for the crate's line that called it."""
    listing = subprocess.run([tool, "-d", "--no-show-raw-insn", firmware],
                             check=True, capture_output=True, text=True).stdout
    addresses = [int(m.group(1), 16) for m in re.finditer(r"(?m)^\s+([0-9a-f]+):\s", listing)]
    symbolizer = shutil.which("llvm-symbolizer")
    if symbolizer is None:
        sys.exit("--lines needs llvm-symbolizer (Debian: apt install llvm)")
    frames = subprocess.run([symbolizer, "--inlining", "--no-demangle", "--functions=none", "-e", firmware],
                            input="\n".join(hex(a) for a in addresses), check=True, capture_output=True,
                            text=True).stdout.split("\n\n")
    table = {}
    for n, (address, chain) in enumerate(zip(addresses, frames)):
        lines = [re.sub(r":\d+$", "", line) for line in chain.strip().splitlines()]
        own = [line for line in lines if "/library/" not in line and "/rustc/" not in line]
        location = re.sub(r"^.*?/src/", "src/", (own or lines or ["?"])[0])
        table[address] = (location, addresses[n + 1] if n + 1 < len(addresses) else None)
    return table


def block_costs(firmware, plugin, name, mode, reps, out, lines=False):
    """Instructions per function of one QEMU run (self cost: a block counts for the function it
    starts in), or with `lines` per source line of the crate (`line_table`)."""
    subprocess.run(
        ["qemu-system-arm", "-machine", "mps2-an386", "-cpu", "cortex-m4", "-nographic",
         "-semihosting-config", f"enable=on,target=native,arg=drive-bench,arg={name},arg={reps},arg={mode}",
         "-kernel", firmware, "-plugin", f"{plugin},out={out}", "-d", "plugin"],
        check=True, capture_output=True, timeout=300,
    )
    nm = sorted(glob.glob(os.path.expanduser("~/.rustup/toolchains/*/lib/rustlib/*/bin/llvm-nm")))
    if not nm:
        sys.exit("llvm-nm not found: rustup component add llvm-tools")
    symbols = []
    listing = subprocess.run([nm[-1], "-n", "-C", "--defined-only", firmware],
                             check=True, capture_output=True, text=True).stdout
    for line in listing.splitlines():
        fields = line.split(" ", 2)
        if len(fields) == 3 and fields[1] in "tT":
            symbols.append((int(fields[0], 16) & ~1, readable(fields[2])))
    starts = [address for address, _ in symbols]
    costs = collections.Counter()
    table = LINES.setdefault(firmware, line_table(firmware, str(pathlib.Path(nm[-1]).with_name("llvm-objdump")))) \
        if lines else None
    with open(out) as f:
        for line in f:
            pc, insns, executions = line.split()
            if table is not None:
                address = int(pc, 16)
                for _ in range(int(insns)):
                    location, address = table.get(address, ("?", None))
                    costs[location] += int(executions)
                    if address is None:
                        break
                continue
            index = bisect.bisect_right(starts, int(pc, 16)) - 1
            function = symbols[index][1] if index >= 0 else "?"
            costs[function] += int(insns) * int(executions)
    return costs


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("measurement")
    parser.add_argument("--top", type=int, default=10)
    parser.add_argument("--m4", action="store_true")
    parser.add_argument("--lines", action="store_true",
                        help="with --m4: per source line of the crate (core code inlined counts for its caller)")
    args = parser.parse_args()
    name, n = args.measurement, REPETITIONS
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(os.path.dirname(here))
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(root, "target", "drive-bench"))
    if args.m4:
        plugin = os.path.join(target, "libblockcount.so")
        source = os.path.join(here, "tools", "qemu-blockcount.c")
        if not os.path.exists(plugin) or os.path.getmtime(source) > os.path.getmtime(plugin):
            subprocess.run(["gcc", "-O2", "-shared", "-fPIC", "-fvisibility=hidden", "-o", plugin, source],
                           check=True)
        # The two-axis and the bootloader's measurements are in builds of their own
        # (scripts/bench.sh).
        build = target
        if name.startswith("tick-2-axes-"):
            build = os.path.join(target, "two-axes")
        elif name.startswith("boot-"):
            build = os.path.join(target, "bootloader")
        firmware = os.path.join(build, "thumbv7em-none-eabihf", "release", "drive-bench")
        out = os.path.join(target, "results", f"{name}.blocks")
        measured = block_costs(firmware, plugin, name, "measured", 2 * n, out, args.lines)
        base = block_costs(firmware, plugin, name, "base", 2 * n, out, args.lines)
        unit = "Cortex-M4"
    else:
        dumps = os.path.join(target, "results", "callgrind")
        measured = self_costs(os.path.join(dumps, f"{name}.measured.{2 * n}.out"))
        base = self_costs(os.path.join(dumps, f"{name}.base.{2 * n}.out"))
        unit = "x86-64"
    difference = {f: measured[f] - base.get(f, 0) for f in measured}
    total = sum(difference.values())
    print(f"{name}: {total / (2 * n):.0f} {unit} instructions per call")
    for function, cost in sorted(difference.items(), key=lambda item: -item[1])[: args.top]:
        if cost <= 0:
            break
        print(f"{cost / (2 * n):9.1f}  {100 * cost / total:5.1f} %  {function}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""The table of scripts/bench.sh: instructions per call from the raw counts, budgets, goals.

    report.py --labels L --m4 M --x86 X --repetitions N --budgets B --out FILE [--update [--force]]
              [--wholes W] [--footprint F] [--peer-m4 P --peer-results R]

L: `name<TAB>label` per measurement (the host binary's `list`). M, X: `name base(n) base(2n)
measured(n) measured(2n)` per measurement (total instructions of the four runs), or, for a
whole run (the worst tick of a scripted move), `name count` (that tick's instructions, `?`
when not measured). W: `arch name ticks number` per whole run and target (m4, m0): the run's
ticks and which one was the worst, added to its label. Writes the Markdown page to FILE and
prints the table. With --update, rewrites the budgets of B to measured + 5 % (rounded up),
lowering them only, unless --force. Exit status 1 when a Cortex-M4 count exceeds its budget, a
measurement has no budget, or repetitions were not identical.

F: docs/footprint.md (the 301-only node's library flash and static RAM). P, R: the results of
the CANopenNode peer harness (../shared/peers/canopennode/run.sh): its `m4.tsv` (scenario,
count, remainder, check) and `results.md` (the footprint table). With them, each measurement
with a counterpart in PEER_SCENARIOS gets the peer's Cortex-M4 count and the ratio (project ÷
CANopenNode), and the page compares the 301-only node with CANopenNode's 301-only node with
block transfer.
"""

import argparse
import math
import re
import sys

MARGIN_PERCENT = 5

# The CANopenNode scenario that does the same work as a measurement (README of the peer
# harness): an expedited upload of a 2-byte entry, an expedited 4-byte download, RPDOs with 1, 4
# and 8 mapped entries, a SYNC with 4 synchronous TPDOs of 4 entries (each: frame in, dispatch,
# processing, frames out).
PEER_SCENARIOS = {
    "sdo-upload": "sdo-upload-1017",
    "sdo-download": "sdo-download-2001",
    "rpdo-1": "rpdo-1",
    "rpdo-4": "rpdo-4",
    "rpdo-8": "rpdo-8",
    "sync-4-tpdos": "sync-4-tpdos",
}


def read_peer_counts(path):
    """{scenario: count} of the peer's m4.tsv (only scenarios whose remainder is 0)."""
    counts = {}
    with open(path) as f:
        for line in f:
            fields = line.rstrip("\n").split("\t")
            if len(fields) >= 3 and fields[1].isdigit() and fields[2] == "0":
                counts[fields[0]] = int(fields[1])
    return counts


def read_peer_footprint(path):
    """(flash − baseline, static RAM − baseline) of CANopenNode's 301-only node with block
    transfer (cn301-blk) from the peer's results.md, or None."""
    with open(path) as f:
        for line in f:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if cells and cells[0].startswith("cn301-blk") and len(cells) >= 5:
                try:
                    return int(cells[3]), int(cells[4])
                except ValueError:
                    return None
    return None


def read_node301(path):
    """(library flash, static RAM) of the 301-only node on thumbv7em from docs/footprint.md."""
    with open(path) as f:
        for line in f:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) >= 5 and cells[0] == "thumbv7em-none-eabihf" and cells[1] == "node301":
                try:
                    return int(cells[4]), int(cells[3].split()[0])
                except ValueError:
                    return None
    return None


def per_call(raw, n):
    """One call from the four counts; None when the repetitions were not identical."""
    base_n, base_2n, measured_n, measured_2n = raw
    difference = (measured_2n - measured_n) - (base_2n - base_n)
    if difference % n:
        return None
    return difference // n


def read_counts(path, n):
    counts = {}
    with open(path) as f:
        for line in f:
            fields = line.split()
            if len(fields) == 2:
                counts[fields[0]] = int(fields[1]) if fields[1].isdigit() else None
            elif fields:
                counts[fields[0]] = per_call([int(v) for v in fields[1:5]], n)
    return counts


def read_wholes(path):
    """{name: {arch: (ticks, number of the worst tick)}} of the whole runs."""
    wholes = {}
    with open(path) as f:
        for line in f:
            fields = line.split()
            if len(fields) == 4:
                wholes.setdefault(fields[1], {})[fields[0]] = (int(fields[2]), int(fields[3]))
    return wholes


def whole_label(label, runs):
    """The label of a whole run with the number of its worst tick on each target."""
    worst = [f"tick {runs[arch][1]} on {target}" for arch, target in (("m4", "Cortex-M4"), ("m0", "v6-M"))
             if arch in runs]
    if not worst:
        return label
    if label.endswith(")"):
        return f"{label[:-1]}; the worst: {', '.join(worst)})"
    return f"{label} (the worst: {', '.join(worst)})"


def read_budgets(path):
    """{name: (budget or None, goal text)} and the comment lines at the top."""
    budgets, header = {}, []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                if not budgets:
                    header.append(line.rstrip("\n"))
                continue
            name, budget, goal = line.split()[:3]
            budgets[name] = (None if budget == "-" else int(budget), goal)
    return budgets, header


def with_margin(count):
    return math.ceil(count * (100 + MARGIN_PERCENT) / 100)


def dictionary_objects(label):
    match = re.search(r"\((\d+) objects", label)
    return int(match.group(1)) if match else None


def goal_of(name, goal, m4, labels):
    """The goal as a number (or None). "log": at most the small dictionary's count of the same
    look-up times log2(objects) / log2(objects of the small dictionary)."""
    if goal == "-":
        return None
    if goal != "log":
        return int(goal)
    reference = re.sub(r"^od-(small|medium|large)-", "od-small-", name)
    if reference == name or m4.get(reference) is None:
        return None
    objects, small = dictionary_objects(labels[name]), dictionary_objects(labels[reference])
    if not objects or not small:
        return None
    return math.ceil(m4[reference] * math.log2(objects) / math.log2(small))


def main():
    parser = argparse.ArgumentParser()
    for option in ("--labels", "--m4", "--m0", "--x86", "--budgets", "--out"):
        parser.add_argument(option, required=True)
    parser.add_argument("--repetitions", type=int, required=True)
    parser.add_argument("--footprint")
    parser.add_argument("--wholes")
    parser.add_argument("--peer-m4")
    parser.add_argument("--peer-results")
    parser.add_argument("--update", action="store_true")
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args()

    labels = {}
    with open(args.labels) as f:
        for line in f:
            name, label = line.rstrip("\n").split("\t", 1)
            labels[name] = label
    wholes = read_wholes(args.wholes) if args.wholes else {}
    for name, runs in wholes.items():
        if name in labels:
            labels[name] = whole_label(labels[name], runs)
    m4 = read_counts(args.m4, args.repetitions)
    m0 = read_counts(args.m0, args.repetitions)
    x86 = read_counts(args.x86, args.repetitions)
    budgets, header = read_budgets(args.budgets)
    peer = read_peer_counts(args.peer_m4) if args.peer_m4 else {}
    failed = False

    for name in labels:
        for target, counts in (("Cortex-M4", m4), ("v6-M", m0), ("x86-64", x86)):
            if counts.get(name) is None:
                print(f"{name}: {target} repetitions were not identical (or not measured)", file=sys.stderr)
                failed = True

    if args.update:
        updated = {}
        for name in labels:
            old, goal = budgets.get(name, (None, "-"))
            fresh = with_margin(m4[name]) if m4.get(name) is not None else old
            if old is not None and fresh is not None and not args.force:
                fresh = min(old, fresh)
            updated[name] = (fresh, goal)
        budgets = updated
        with open(args.budgets, "w") as f:
            for line in header:
                f.write(line + "\n")
            width = max(len(name) for name in budgets)
            for name, (budget, goal) in budgets.items():
                f.write(f"{name:<{width}}  {'-' if budget is None else budget:>8}  {goal}\n")

    rows, goals, goals_met = [], 0, 0
    for name, label in labels.items():
        count = m4.get(name)
        budget, goal_text = budgets.get(name, (None, "-"))
        goal = goal_of(name, goal_text, m4, labels)
        status = []
        if budget is None:
            status.append("**no budget**")
            failed = True
        elif count is None or count > budget:
            status.append("**over budget**")
            failed = True
        if goal is not None and count is not None:
            goals += 1
            if count <= goal:
                goals_met += 1
                status.append("goal met")
            else:
                status.append(f"goal missed (×{count / goal:.1f})")
        if not status:
            status.append("within budget")
        goal_cell = "-" if goal is None else (f"{goal} (log)" if goal_text == "log" else str(goal))
        peer_count = peer.get(PEER_SCENARIOS.get(name, ""))
        cells = [
            label,
            "?" if count is None else str(count),
            "?" if m0.get(name) is None else str(m0[name]),
            "?" if x86.get(name) is None else str(x86[name]),
            "-" if peer_count is None else str(peer_count),
            "-" if peer_count is None or count is None else f"{count / peer_count:.2f}",
            "-" if budget is None else str(budget),
            goal_cell,
            ", ".join(status),
        ]
        rows.append("| " + " | ".join(cells) + " |")

    table = [
        "| measurement | Cortex-M4 instructions | v6-M instructions | x86-64 instructions | peer (M4) "
        "| ratio (M4) | budget (M4) | goal (M4) | status |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|",
        *rows,
    ]
    page = [
        "# Benchmarks",
        "",
        "Instructions per call of canopen-drive's entry points, written by `scripts/bench.sh` (do not",
        "edit by hand; `scripts/bench.sh --check`, run in CI, fails when a Cortex-M4 count or a budget",
        "here differs from a fresh run).",
        "Method and scenarios: [benches/drive-bench/README.md](benches/drive-bench/README.md).",
        "",
        *table,
        "",
        f"Goals met: {goals_met} of {goals}.",
        "",
        "- Cortex-M4: thumbv7em-none-eabihf, opt-level \"s\", LTO, counted by the QEMU plugin",
        "  (`qemu-system-arm -machine mps2-an386`): deterministic on any host. v6-M: the same firmware",
        "  built for thumbv6m-none-eabi (the Cortex-M0/M0+ instruction set: no FPU, no hardware",
        "  divide, no 32×32→64 multiply), run by the Cortex-M3 of `mps2-an385`; deterministic too,",
        "  reported without budget or goal. Instructions, not cycles. x86-64: the same",
        "  profile, callgrind's `Ir`; libc's memcpy is chosen by the host CPU's features, so this",
        "  column can differ slightly between machines and is not compared by `--check`.",
        "- Budgets ([benches/drive-bench/budgets.txt](benches/drive-bench/budgets.txt)): the Cortex-M4",
        f"  count + {MARGIN_PERCENT} % when last set; a count above its budget fails the script.",
        "- Goals: issue 8; issue 17 (CANopenNode's cost or less) for the SDO, RPDO, SYNC and other-node rows. \"(log)\": a look-up may grow at most logarithmically with the dictionary:",
        "  at 2000 objects it costs at most the small dictionary's count × log₂(2000) / log₂(objects of",
        "  the small one). Issue 32 for the ticks that take a set-point, stop, change a homing phase,",
        "  and the worst ticks of whole runs: every single-axis tick at most 5 000 Cortex-M4",
        "  instructions, and at most 15 000 on v6-M (a bound this table has no column for).",
        "- Worst tick of a whole run: the run (a scripted move, every tick through the public API) is",
        "  made once, each tick between two marker functions; the QEMU plugin counts every tick on",
        "  its own and keeps the largest, less the markers' own share (see the method). \"The worst:",
        "  tick k\" numbers the run's ticks from 1. x86-64: callgrind's count of the largest tick of the",
        "  same run.",
    ]
    page += ["", "## The peer", ""]
    if peer:
        page += [
            "- peer (M4): CANopenNode (../shared/peers/canopennode, its default configuration), the",
            "  same operation counted in the same run with the same QEMU machine and plugin",
            "  (arm-none-eabi-gcc -Os); ratio = canopen-drive ÷ CANopenNode, below 1 is fewer",
            "  instructions. Counterparts: " + ", ".join(f"{k} ↔ {v}" for k, v in PEER_SCENARIOS.items()) + ".",
        ]
    else:
        page.append("- CANopenNode columns left out: ../shared/peers/canopennode is not beside this clone.")
    node301 = read_node301(args.footprint) if args.footprint else None
    peer_fp = read_peer_footprint(args.peer_results) if args.peer_results else None
    if node301 and peer_fp:
        page += [
            "",
            "| 301-only node (thumbv7em, block transfer in both) | library flash | static RAM |",
            "|---|---:|---:|",
            f"| canopen-drive node301 (docs/footprint.md) | {node301[0]} | {node301[1]} |",
            f"| CANopenNode cn301-blk (image − baseline) | {peer_fp[0]} | {peer_fp[1]} |",
            f"| ratio (CANopenNode = 1) | {node301[0] / peer_fp[0]:.2f} | {node301[1] / peer_fp[1]:.2f} |",
        ]
    with open(args.out, "w") as f:
        f.write("\n".join(page) + "\n")
    print("\n".join(table))
    print(f"\nGoals met: {goals_met} of {goals}.")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

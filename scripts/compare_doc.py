#!/usr/bin/env python3
"""Compares a committed generated document with the one a test run just wrote.

    scripts/compare_doc.py COMMITTED FRESH                      the same text, exactly
    scripts/compare_doc.py COMMITTED FRESH --numbers-within 1 --informative "| bytes | kind | symbol |"

Exits 0 when they agree, 1 (with a diff of what differs) when not.

`--numbers-within PERCENT`: every line must read the same once its numbers are taken out, and
each number may differ from the committed one by at most PERCENT % (of the larger). This is
for docs/footprint.md: the firmware images depend, by a few hundred bytes, on the directory
the repository is built in (the benches are cargo workspaces of their own, and cargo hashes
the absolute path of the core crate, which lies outside them, into its symbol names; LLVM's
inlining then takes slightly different turns). A real change of the code moves the numbers by
more, or changes the text.

`--informative HEADER` (repeatable): the rows of the Markdown table under HEADER are not
compared (the largest symbols of an image, the bytes per source area: their sizes and order
follow those inlining turns).
"""

import argparse
import difflib
import re
import sys

NUMBER = re.compile(r"\d+(?:\.\d+)?")


def lines_to_compare(text, informative):
    lines, skipping = [], False
    for line in text.splitlines():
        if any(line.startswith(header) for header in informative):
            lines.append(line)
            skipping = True
            continue
        if skipping and line.startswith("|"):
            continue
        skipping = False
        lines.append(line)
    return lines


def numbers_agree(committed, fresh, percent):
    if NUMBER.sub("#", committed) != NUMBER.sub("#", fresh):
        return False
    for a, b in zip(NUMBER.findall(committed), NUMBER.findall(fresh)):
        x, y = float(a), float(b)
        if abs(x - y) > percent / 100 * max(abs(x), abs(y)):
            return False
    return True


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("committed")
    parser.add_argument("fresh")
    parser.add_argument("--numbers-within", type=float, default=None, metavar="PERCENT")
    parser.add_argument("--informative", action="append", default=[], metavar="HEADER")
    args = parser.parse_args()
    with open(args.committed) as f:
        committed = lines_to_compare(f.read(), args.informative)
    with open(args.fresh) as f:
        fresh = lines_to_compare(f.read(), args.informative)
    if args.numbers_within is None:
        same = committed == fresh
    else:
        same = len(committed) == len(fresh) and all(
            numbers_agree(a, b, args.numbers_within) for a, b in zip(committed, fresh)
        )
    if same:
        return 0
    sys.stdout.writelines(
        line + "\n" for line in difflib.unified_diff(committed, fresh, args.committed, args.fresh, lineterm="")
    )
    if args.numbers_within is not None:
        print(f"(numbers may differ by {args.numbers_within} %; the lines above differ by more, or in text)")
    return 1


if __name__ == "__main__":
    sys.exit(main())

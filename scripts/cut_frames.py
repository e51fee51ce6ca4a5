#!/usr/bin/env python3
"""Frame times of cutting frames against the others, from `voxcut run --csv` files.

A frame cuts when its `cut_links` column (the links it cut) is above zero. For each file, and for
all files together, prints how many frames of each kind there were, their mean and p95 frame
time (ms), and the ratio of the p95s: the figure of docs/performance.md, "Cut frames".

    voxcut run scenes/liver-probe-cut.json --threads 2 --csv run1.csv
    /usr/bin/python3 scripts/cut_frames.py run1.csv run2.csv run3.csv

Uses the standard library only.
"""

import argparse
import csv
import math
import sys


def p95(values):
    """The 95th percentile, nearest rank (as `voxcut run --json` reports it)."""
    ordered = sorted(values)
    return ordered[max(0, math.ceil(0.95 * len(ordered)) - 1)]


def split_frames(path):
    """(cutting frame times, other frame times) of one CSV file."""
    cutting, other = [], []
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = {"frame_ms", "cut_links"} - set(reader.fieldnames or [])
        if missing:
            raise ValueError(f"{path}: not a `voxcut run --csv` file (no column "
                             f"{', '.join(sorted(missing))})")
        for line, row in enumerate(reader, start=2):
            try:
                links = int(row["cut_links"])
                ms = float(row["frame_ms"])
            except (TypeError, ValueError):
                raise ValueError(f"{path}:{line}: frame_ms and cut_links must be numbers")
            (cutting if links > 0 else other).append(ms)
    return cutting, other


def summary(name, cutting, other):
    def part(values):
        if not values:
            return "    0 frames"
        return f"{len(values):5d} frames, mean {sum(values) / len(values):7.2f}, p95 {p95(values):7.2f}"
    ratio = f"{p95(cutting) / p95(other):.2f}" if cutting and other else "-"
    return f"{name}\n  cutting {part(cutting)}\n  other   {part(other)}\n  p95 ratio {ratio}"


def main():
    parser = argparse.ArgumentParser(
        description="Cutting frames' times against the others', from voxcut run --csv files.")
    parser.add_argument("csv", nargs="+", help="files written by voxcut run --csv")
    args = parser.parse_args()
    all_cutting, all_other = [], []
    try:
        for path in args.csv:
            cutting, other = split_frames(path)
            print(summary(path, cutting, other))
            all_cutting += cutting
            all_other += other
    except (OSError, ValueError) as e:
        print(f"cut_frames: error: {e}", file=sys.stderr)
        return 2
    if len(args.csv) > 1:
        print(summary("all files", all_cutting, all_other))
    return 0


if __name__ == "__main__":
    sys.exit(main())

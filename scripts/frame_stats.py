#!/usr/bin/env python3
"""Summarises the per-frame CSV of `voxcut run --csv FILE`: the figures of docs/performance.md,
"Frame times at 2 threads, and bunny-ear at resolution 303".

Usage: python3 scripts/frame_stats.py FILE.csv [FILE.csv ...] [--moving FIRST LAST]

For each file it prints one line:
  - the mean frame and the 95th percentile of every frame (the same nearest-rank percentile as
    `voxcut run --json`'s `frame_ms.p95`);
  - over the moving frames (FIRST..LAST, both included; default every frame), those that cut
    nothing (`cut_links` 0): the intersection test's mean and maximum;
  - the collision total (voxel position update + intersection test + octree subdivision),
    averaged over the moving frames and over those that cut.

Needs nothing beyond the Python standard library. A file without the expected columns, or
with no frame in the range, is reported on stderr and makes the exit status 1.
"""

import argparse
import csv
import math
import sys

COLUMNS = ("frame", "frame_ms", "cut_links", "voxel_position_update_ms",
           "intersection_test_ms", "octree_subdivision_ms")


def mean(values):
    return sum(values) / len(values) if values else float("nan")


def percentile(values, q):
    ordered = sorted(values)
    k = max(0, min(len(ordered) - 1, math.ceil(q * len(ordered)) - 1))
    return ordered[k]


def summarise(path, first, last):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"missing column(s) {', '.join(missing)}")
        rows = list(reader)
    if not rows:
        raise ValueError("no frames")
    frame_ms = [float(r["frame_ms"]) for r in rows]
    moving = [r for r in rows
              if (first is None or int(r["frame"]) >= first)
              and (last is None or int(r["frame"]) <= last)]
    if not moving:
        raise ValueError("no frame in the --moving range")
    idle = [r for r in moving if int(r["cut_links"]) == 0]
    cutting = [r for r in moving if int(r["cut_links"]) > 0]

    def collision(r):
        return (float(r["voxel_position_update_ms"]) + float(r["intersection_test_ms"])
                + float(r["octree_subdivision_ms"]))

    idle_test = [float(r["intersection_test_ms"]) for r in idle]
    return (f"{path}: mean {mean(frame_ms):.2f} ms, p95 {percentile(frame_ms, 0.95):.2f} ms; "
            f"intersection test in {len(idle)} moving frames that cut nothing: mean "
            f"{mean(idle_test):.3f}, max {max(idle_test) if idle_test else float('nan'):.3f} ms; "
            f"collision total: moving frames {mean([collision(r) for r in moving]):.3f} ms, "
            f"{len(cutting)} cutting frames {mean([collision(r) for r in cutting]):.3f} ms")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="+", metavar="FILE.csv")
    parser.add_argument("--moving", nargs=2, type=int, metavar=("FIRST", "LAST"),
                        help="the frames in which the tool moves (default: every frame)")
    args = parser.parse_args()
    first, last = args.moving if args.moving else (None, None)
    status = 0
    for path in args.files:
        try:
            print(summarise(path, first, last))
        except (OSError, ValueError, KeyError) as e:
            print(f"{path}: {e}", file=sys.stderr)
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())

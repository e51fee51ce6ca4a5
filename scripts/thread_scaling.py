#!/usr/bin/python3
"""Makes the tables of scripts/thread_scaling.sh from the raw outputs it leaves in one folder.

Reads, for thread count T and repeat R:
  single-frame.T.R.csv  the CSV of `voxcut bench single-frame` (total_ms: the collision total,
                        itself a median over its --repeat cuts);
  scene.NAME.T.R.json   `voxcut run scenes/NAME.json --json` (frame_ms.mean, frame_ms.p95,
                        cut_set_hash);
  fem.R.json            `bench_fem --benchmark_format=json` with BunnyThreads/RES/T entries
                        (real_time in ms; counters nodes and iterations).
Prints the header and two Markdown tables (median with min-max, speed-up over 1 thread) and
writes the same to --out. Needs nothing beyond the Python standard library.
"""

import argparse
import csv
import json
import math
import re
import statistics
import sys
import textwrap
from pathlib import Path

MODELS = ("bunny", "liver", "starfish")


def fmt(ms):
    """Three significant digits, no exponent."""
    if ms <= 0 or not math.isfinite(ms):
        return f"{ms:.3f}"
    decimals = max(0, min(3, 2 - math.floor(math.log10(ms))))
    return f"{ms:.{decimals}f}"


def single_frame(raw, threads, repeats):
    """Rows, {(row, T): [ms per repeat]} and {model: set of cut link counts}."""
    times, cuts = {}, {}
    for t in threads:
        for r in range(1, repeats + 1):
            with open(raw / f"single-frame.{t}.{r}.csv", newline="") as f:
                for row in csv.DictReader(f):
                    octree = "octree" if row["octree"] == "1" else "baseline"
                    key = (f"single-frame collision, {row['model']}, {octree}", t)
                    times.setdefault(key, []).append(float(row["total_ms"]))
                    cuts.setdefault(row["model"], set()).add(row["cut_links"])
    rows = [f"single-frame collision, {m}, {o}" for m in MODELS for o in ("octree", "baseline")
            if (f"single-frame collision, {m}, {o}", threads[0]) in times]
    return rows, times, cuts


def deformation(raw, threads, repeats):
    """Rows, {(row, T): [ms]} and {row: {T: [iterations per step]}} from BunnyThreads."""
    times, iterations, nodes = {}, {}, {}
    name = re.compile(r"^BunnyThreads/(\d+)/(\d+)/")
    for r in range(1, repeats + 1):
        # The benchmark's own "iterations" (its loop count) comes before the counter of the
        # same name, the solver's iterations per step; json keeps the last of repeated keys.
        path = raw / f"fem.{r}.json"
        if not path.exists():
            continue
        with open(path) as f:
            data = json.load(f)
        for b in data.get("benchmarks", []):
            m = name.match(b.get("name", ""))
            if not m or b.get("error_occurred"):
                continue
            resolution, t = int(m.group(1)), int(m.group(2))
            scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}[b.get("time_unit", "ns")]
            nodes[resolution] = int(b.get("nodes", 0))
            times.setdefault((resolution, t), []).append(b["real_time"] * scale)
            iterations.setdefault(resolution, {}).setdefault(t, []).append(b.get("iterations"))
    rows, out_times, out_iterations = [], {}, {}
    for resolution in sorted(nodes, reverse=True):
        row = f"deformation step, {nodes[resolution]:,} nodes (resolution {resolution})"
        rows.append(row)
        for t in threads:
            if (resolution, t) in times:
                out_times[(row, t)] = times[(resolution, t)]
        out_iterations[row] = iterations[resolution]
    return rows, out_times, out_iterations


def scenes(raw, names, threads, repeats):
    """Rows, {(row, T): [ms]} and {scene: {cut set hash: {T, ...}}}."""
    rows, times, hashes = [], {}, {}
    for name in names:
        rows += [f"{name}: frame mean", f"{name}: frame p95"]
        for t in threads:
            for r in range(1, repeats + 1):
                with open(raw / f"scene.{name}.{t}.{r}.json") as f:
                    data = json.load(f)
                times.setdefault((f"{name}: frame mean", t), []).append(data["frame_ms"]["mean"])
                times.setdefault((f"{name}: frame p95", t), []).append(data["frame_ms"]["p95"])
                hashes.setdefault(name, {}).setdefault(data.get("cut_set_hash"), set()).add(t)
    return rows, times, hashes


def table(header, rows):
    """A Markdown table with its columns padded to line up."""
    cells = [header] + rows
    widths = [max(len(r[c]) for r in cells) for c in range(len(header))]

    def line(r):
        return "| " + " | ".join(r[c].ljust(widths[c]) for c in range(len(r))) + " |"

    return "\n".join([line(header), "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
                     + [line(r) for r in rows])


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--raw", type=Path, required=True)
    p.add_argument("--threads", required=True)
    p.add_argument("--repeats", type=int, required=True)
    p.add_argument("--cores", type=int, required=True)
    p.add_argument("--machine", required=True)
    p.add_argument("--commit", required=True)
    p.add_argument("--started", required=True)
    p.add_argument("--command", required=True)
    p.add_argument("--single-frame-repeat", type=int, required=True)
    p.add_argument("--scenes", required=True)
    p.add_argument("--frames", type=int, help="scenes cut to this many frames")
    p.add_argument("--out", type=Path)
    a = p.parse_args()
    threads = [int(t) for t in a.threads.split()]
    base = 1 if 1 in threads else min(threads)

    sf_rows, sf_times, sf_cuts = single_frame(a.raw, threads, a.repeats)
    fem_rows, fem_times, fem_iterations = deformation(a.raw, threads, a.repeats)
    sc_rows, sc_times, sc_hashes = scenes(a.raw, a.scenes.split(), threads, a.repeats)
    rows = sf_rows + fem_rows + sc_rows
    times = {**sf_times, **fem_times, **sc_times}

    def column(t):
        label = f"{t} thread" + ("" if t == 1 else "s")
        return label + (f" (oversubscribed: {a.cores} cores)" if t > a.cores else "")

    header = ["measurement, ms"] + [column(t) for t in threads]
    medians = {k: statistics.median(v) for k, v in times.items()}
    time_rows, speed_rows = [], []
    for row in rows:
        cells, speeds = [row], [row]
        for t in threads:
            v = times.get((row, t))
            if not v:
                cells.append("-")
                speeds.append("-")
                continue
            cell = fmt(medians[(row, t)])
            if len(v) > 1:
                cell += f" ({fmt(min(v))}-{fmt(max(v))})"
            cells.append(cell)
            b = medians.get((row, base))
            speeds.append(f"{b / medians[(row, t)]:.2f}x" if b else "-")
        time_rows.append(cells)
        speed_rows.append(speeds)

    over = "one run" if a.repeats == 1 else f"median of {a.repeats} repeats (min-max)"
    frames = f", scenes cut to {a.frames} frames" if a.frames else ""
    lines = [
        f"- commit: {a.commit}",
        f"- machine: {a.machine}",
        f"- started: {a.started}",
        f"- command: `{a.command}`",
        "",
        f"Time per thread count, ms, {over}; single-frame: each run the median of "
        f"{a.single_frame_repeat} cuts{frames}:",
        "",
        table(header, time_rows),
        "",
        f"Speed-up over {base} thread{'' if base == 1 else 's'} (median / median):",
        "",
        table(["measurement"] + header[1:], speed_rows),
        "",
    ]
    differing = {m: sorted(c) for m, c in sf_cuts.items() if len(c) > 1}
    lines.append("- single-frame cut links: " + (
        "the same at every thread count" if not differing else
        "DIFFER between runs: " + "; ".join(f"{m} {', '.join(c)}" for m, c in differing.items())))
    for name, by_hash in sc_hashes.items():
        if len(by_hash) > 1:
            lines.append(f"- {name}: cut sets DIFFER between runs: " + "; ".join(
                f"{h} at {', '.join(map(str, sorted(ts)))} threads" for h, ts in by_hash.items()))
    if all(len(h) == 1 for h in sc_hashes.values()):
        lines.append("- scenes' cut sets: the same at every thread count")
    # The steps are the same at any thread count, but a faster run times more of them, so
    # the mean over the timed steps may differ a little.
    for row, by_threads in fem_iterations.items():
        per_threads = "; ".join(f"{t} thread{'' if t == 1 else 's'} "
                                + ", ".join(f"{i:.1f}" for i in v)
                                for t, v in sorted(by_threads.items()))
        lines.append(f"- {row}: solver iterations per step, mean over the timed steps: "
                     + per_threads)
    # Prose at the width of docs/, so that the output pastes there as it is; tables stay whole.
    text = "\n".join(
        line if line.startswith("|") else
        textwrap.fill(line, 96, subsequent_indent="  " if line.startswith("- ") else "",
                      break_long_words=False, break_on_hyphens=False)
        for line in lines)
    print(text)
    if a.out:
        a.out.write_text(text + "\n")
        print(f"wrote {a.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Draws the figures of `voxcut bench complex` (the paper's figures 6 to 8) from its CSVs.

Usage: python3 scripts/plot_complex.py OUT_DIR [--dpi N] [--window SECONDS]

OUT_DIR is the bench's output folder: runs.csv lists the runs (scene, run name, CSV path
relative to OUT_DIR, threads, octree, max_internal_level, time_step ...), and each run's CSV
holds one row per frame (frame_ms, fps, every stage's *_ms, cut_links, cutting ...). For each
scene it writes, into OUT_DIR, as PNG and SVG:

  SCENE-fps-threads      FPS over simulated time at each thread count, octree and baseline (fig. 6)
  SCENE-fps-levels       FPS at each maximum internal level, 2 threads, and the baseline (fig. 7)
  SCENE-collision-steps  the cutting tool collision's steps over time at each thread count (fig. 8)

Per-frame times are noisy, so every curve is a centred moving average over a short window
(default 0.06 s, 15 frames at 4 ms); FPS is the window's frames over its wall-clock time. The
titles say so. Cutting periods (the CSV's `cutting` column) are shaded. Needs matplotlib
(Debian: python3-matplotlib); draws with the Agg backend, no display needed.
"""

import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend is chosen first)

THREAD_COLOURS = {1: "tab:blue", 2: "tab:orange", 3: "tab:green"}
LEVEL_COLOURS = {1: "tab:purple", 2: "tab:olive", 3: "tab:cyan", 4: "tab:orange"}


def read_runs(out_dir):
    path = os.path.join(out_dir, "runs.csv")
    with open(path, newline="", encoding="utf-8") as f:
        runs = list(csv.DictReader(f))
    if not runs:
        sys.exit("plot_complex: %s lists no runs" % path)
    for run in runs:
        with open(os.path.join(out_dir, run["csv"]), newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        run["columns"] = {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}
        run["threads"] = int(run["threads"])
        run["octree"] = run["octree"] == "1"
        run["max_internal_level"] = int(run["max_internal_level"])
        run["time_step"] = float(run["time_step"])
    return runs


def smooth(values, window):
    """Centred moving average over `window` values (fewer at the ends)."""
    half = window // 2
    prefix = [0.0]
    for v in values:
        prefix.append(prefix[-1] + v)
    out = []
    for i in range(len(values)):
        lo, hi = max(0, i - half), min(len(values), i + half + 1)
        out.append((prefix[hi] - prefix[lo]) / (hi - lo))
    return out


def smoothed_fps(run, window):
    return [1000.0 / ms if ms > 0 else 0.0 for ms in smooth(run["columns"]["frame_ms"], window)]


def shade_cutting(ax, run):
    """Grey spans over the cutting periods."""
    t, cutting = run["columns"]["time_s"], run["columns"]["cutting"]
    dt = run["time_step"]
    start = None
    for i, c in enumerate(cutting + [0.0]):
        if c and start is None:
            start = t[i] - dt
        elif not c and start is not None:
            ax.axvspan(start, t[i - 1], color="0.88", zorder=0, lw=0)
            start = None


def save(fig, out_dir, name, dpi):
    for ext in ("png", "svg"):
        path = os.path.join(out_dir, "%s.%s" % (name, ext))
        fig.savefig(path, dpi=dpi)
        print("wrote", path)
    plt.close(fig)


def label(run):
    if not run["octree"]:
        return "baseline, %d T" % run["threads"]
    return "octree, %d T" % run["threads"]


def fig_threads(scene, runs, window, out_dir, dpi):
    fig, ax = plt.subplots(figsize=(8, 4.2))
    shade_cutting(ax, runs[0])
    for run in sorted(runs, key=lambda r: (not r["octree"], r["threads"])):
        if run["octree"] and run["run"] != "octree-t%d" % run["threads"]:
            continue  # the level runs go to the next figure
        ax.plot(run["columns"]["time_s"], smoothed_fps(run, window), lw=1.1,
                color=THREAD_COLOURS.get(run["threads"], "k"),
                ls="-" if run["octree"] else "--", label=label(run))
    finish(ax, "%s: FPS per thread count, octree (solid) vs baseline (dashed)" % scene,
           window, runs[0], "FPS")
    save(fig, out_dir, scene + "-fps-threads", dpi)


def fig_levels(scene, runs, window, out_dir, dpi):
    fig, ax = plt.subplots(figsize=(8, 4.2))
    shade_cutting(ax, runs[0])
    level_runs = [r for r in runs if r["octree"] and r["threads"] == 2]
    for run in sorted(level_runs, key=lambda r: r["max_internal_level"]):
        level = run["max_internal_level"]
        ax.plot(run["columns"]["time_s"], smoothed_fps(run, window), lw=1.1,
                color=LEVEL_COLOURS.get(level, "k"),
                label="octree, L%d" % level if level >= 0 else "octree, scene's levels")
    for run in runs:
        if not run["octree"] and run["threads"] == 2:
            ax.plot(run["columns"]["time_s"], smoothed_fps(run, window), lw=1.1, color="k",
                    ls="--", label="baseline")
    finish(ax, "%s: FPS per maximum internal level (L#), 2 threads" % scene, window, runs[0],
           "FPS")
    save(fig, out_dir, scene + "-fps-levels", dpi)


def stage(run, *names):
    cols = run["columns"]
    return [sum(v) for v in zip(*(cols[n + "_ms"] for n in names))]


def fig_collision(scene, runs, window, out_dir, dpi):
    panels = [
        ("cutting tool collision total",
         ("voxel_position_update", "intersection_test", "octree_subdivision"), True),
        ("position update + intersection test",
         ("voxel_position_update", "intersection_test"), True),
        ("octree subdivision", ("octree_subdivision",), False),
        ("deferred updates", ("deferred_updates",), False),
    ]
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.4), sharex=True)
    thread_runs = [r for r in runs if r["run"] in ("octree-t%d" % r["threads"],
                                                   "baseline-t%d" % r["threads"])]
    for ax, (title, names, with_baseline) in zip(axes.flat, panels):
        shade_cutting(ax, runs[0])
        for run in sorted(thread_runs, key=lambda r: (not r["octree"], r["threads"])):
            if not run["octree"] and not with_baseline:
                continue
            ax.plot(run["columns"]["time_s"], smooth(stage(run, *names), window), lw=1.0,
                    color=THREAD_COLOURS.get(run["threads"], "k"),
                    ls="-" if run["octree"] else "--", label=label(run))
        ax.set_title(title, fontsize=10)
        ax.set_ylabel("ms")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("simulated time (s)")
    axes[0][0].legend(fontsize=7, ncol=2)
    dt = runs[0]["time_step"]
    fig.suptitle("%s: cutting tool collision steps per thread count, octree (solid) vs baseline "
                 "(dashed)\nmoving average over %d frames (%.0f ms); grey: cutting periods"
                 % (scene, window, window * dt * 1000), fontsize=10)
    fig.tight_layout()
    save(fig, out_dir, scene + "-collision-steps", dpi)


def finish(ax, title, window, run, ylabel):
    dt = run["time_step"]
    ax.set_title("%s\nmoving average over %d frames (%.0f ms); grey: cutting periods"
                 % (title, window, window * dt * 1000), fontsize=10)
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel(ylabel)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    ax.figure.tight_layout()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out_dir", help="the output folder of voxcut bench complex")
    parser.add_argument("--dpi", type=int, default=90, help="PNG resolution (default 90)")
    parser.add_argument("--window", type=float, default=0.06,
                        help="moving average window in seconds of simulated time (default 0.06)")
    args = parser.parse_args()
    runs = read_runs(args.out_dir)
    scenes = []
    for run in runs:
        if run["run"] and run["scene"] not in scenes:
            scenes.append(run["scene"])
    for scene in scenes:
        mine = [r for r in runs if r["scene"] == scene and r["columns"]]
        if not mine:
            continue
        frames = max(1, int(round(args.window / mine[0]["time_step"])))
        window = frames if frames % 2 == 1 else frames + 1  # centred: an odd count
        fig_threads(scene, mine, window, args.out_dir, args.dpi)
        fig_levels(scene, mine, window, args.out_dir, args.dpi)
        fig_collision(scene, mine, window, args.out_dir, args.dpi)


if __name__ == "__main__":
    main()

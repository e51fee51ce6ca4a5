#!/usr/bin/python3
"""The soak benchmark over a grid of runs: `voxcut bench soak` for every model and element
level, with several seeds each; prints the runs' summaries as one markdown table and draws
each run's frame time over its frames (docs/performance.md, "Soak benchmark").

    /usr/bin/python3 scripts/soak.py                     # 3 models x levels 2-5 x 3 seeds = 36 runs
    /usr/bin/python3 scripts/soak.py --models bunny --levels 3 --seeds 2 --frames 300   # 2 runs

Every run is a call of the binary of its own, into OUT/MODEL-lLEVEL-sSEED/ (its per-frame
CSV and summary.csv): a process per run, so that each run's memory figures start from a fresh
heap (runs of one call share the process, and a later seed starts with what the earlier left). The figure has one panel per model, one line per run (its
colour the element level), frame time on a log axis. Needs Debian's python3 with matplotlib
(python3-matplotlib) for the figure; --no-plot skips it. Exit status: 0 when every call of the
binary finished (whether or not the runs meet the bar), 1 otherwise.
"""

import argparse
import csv
import os
import signal
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MODELS = ["bunny", "liver", "starfish"]
LEVELS = [2, 3, 4, 5]


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--binary", default=os.path.join(ROOT, "build/release/apps/voxcut/voxcut"),
                   help="the voxcut binary (default: build/release/apps/voxcut/voxcut)")
    p.add_argument("--models", nargs="+", default=MODELS, help="default: bunny liver starfish")
    p.add_argument("--levels", nargs="+", type=int, default=LEVELS,
                   help="element levels (default: 2 3 4 5)")
    p.add_argument("--seeds", type=int, default=3, help="runs per model and level (default 3)")
    p.add_argument("--seed", type=int, default=1, help="first seed (default 1)")
    p.add_argument("--frames", type=int, default=600, help="frames per run (default 600)")
    p.add_argument("--resolution", type=int, default=64, help="default 64")
    p.add_argument("--finest-level", type=int, default=None,
                   help="default: the library's (element level - 2, at least 0)")
    p.add_argument("--threads", type=int, default=0, help="default: all cores")
    p.add_argument("--self-collision", choices=["on", "off"], default="on")
    p.add_argument("--timeout", type=float, default=0,
                   help="seconds per run; then it is sent SIGTERM and stops at the next frame "
                        "boundary with its summary (default: none)")
    p.add_argument("--out", default=os.path.join(ROOT, "out/soak-grid"),
                   help="output folder (default out/soak-grid)")
    p.add_argument("--png", default=os.path.join(ROOT, "docs/figures/soak.png"),
                   help="the figure (default docs/figures/soak.png)")
    p.add_argument("--no-plot", action="store_true", help="print the table only")
    a = p.parse_args()
    if a.seeds < 1 or a.frames < 1:
        p.error("--seeds and --frames must be at least 1")
    for level in a.levels:
        if not 0 <= level <= 6:
            p.error(f"--levels: {level} is not an element level 0..6")
    return a


def run_one(a, model, level, seed):
    """Runs the binary for one run; returns (folder, finished)."""
    folder = os.path.join(a.out, f"{model}-l{level}-s{seed}")
    cmd = [a.binary, "bench", "soak", "--model", model, "--resolution", str(a.resolution),
           "--element-level", str(level),
           "--frames", str(a.frames), "--seed", str(seed), "--self-collision", a.self_collision,
           "--out", folder]
    if a.finest_level is not None:
        cmd += ["--finest-level", str(min(a.finest_level, level))]
    if a.threads > 0:
        cmd += ["--threads", str(a.threads)]
    start = time.time()
    print(f"{model} level {level} seed {seed}: {a.frames} frames ...", file=sys.stderr,
          flush=True)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    try:
        out, _ = proc.communicate(timeout=a.timeout if a.timeout > 0 else None)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate()
    elapsed = time.time() - start
    # 130: stopped by the timeout, with its summary; anything else but 0 is a failure.
    finished = proc.returncode in (0, 130)
    print(f"  {elapsed:.0f} s, status {proc.returncode}", file=sys.stderr, flush=True)
    if not finished:
        sys.stderr.write(out)
    return folder, finished


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def print_table(rows):
    print("| model | level | seed | blades | frames | first ms | last ms | ratio | nodes start | "
          "nodes end | ratio | unconverged | memory ratio | max penetration (voxels) | "
          "energy gain untouched (J; frames) | cut links | pieces | most grown stage (ms) | bar |")
    print("|" + "---|" * 19)
    for r in rows:
        frames = r["frames"] + ("" if r["status"] == "complete" else f" ({r['status']})")
        bar = "met" if r["meets_bar"] == "1" else "missed: " + r["misses"]
        print(f"| {r['model']} | {r['element_level']} | {r['seed']} | {r['blades']} | {frames} | "
              f"{r['first_ms']} | {r['last_ms']} | {r['time_ratio']} | {r['nodes_start']} | "
              f"{r['nodes_end']} | {r['nodes_ratio']} | {r['unconverged_frames']} | "
              f"{r['memory_ratio']} | {r['max_penetration_voxels']} | "
              f"{r['untouched_energy_gain_j']}; {r['untouched_gain_frames']} | {r['cut_links']} | "
              f"{r['pieces']} | {r['grown_stage']} {r['grown_stage_ms']} | {bar} |")
    met = sum(1 for r in rows if r["meets_bar"] == "1")
    print(f"\n{met} of {len(rows)} runs meet the bar (last 100 frames' mean <= 3x the first "
          "100's and <= 30 ms; nodes at the end <= 3x; no unconverged frame; peak memory <= 2x)")


def plot(a, runs):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("soak.py: no matplotlib (sudo apt-get install python3-matplotlib; run with "
              "/usr/bin/python3); figure not drawn", file=sys.stderr)
        return
    models = [m for m in a.models if any(r[0]["model"] == m for r in runs)]
    fig, axes = plt.subplots(1, max(1, len(models)), figsize=(5 * max(1, len(models)), 4),
                             sharey=True, squeeze=False)
    colours = plt.get_cmap("tab10")
    levels = sorted({int(r[0]["element_level"]) for r in runs})
    for ax, model in zip(axes[0], models):
        for summary, frames in runs:
            if summary["model"] != model:
                continue
            level = int(summary["element_level"])
            colour = colours(levels.index(level) % 10)
            ax.plot([int(f["frame"]) for f in frames], [float(f["frame_ms"]) for f in frames],
                    color=colour, linewidth=0.7, alpha=0.8,
                    label=f"level {level}" if summary["seed"] == str(a.seed) else None)
        ax.set_yscale("log")
        ax.axhline(30, color="grey", linestyle="--", linewidth=0.8)
        ax.set_title(f"{model}, resolution {a.resolution}")
        ax.set_xlabel("frame")
        ax.legend(fontsize=8)
    axes[0][0].set_ylabel("frame time (ms)")
    fig.suptitle(f"voxcut bench soak: {a.seeds} seed(s) per level, dashed: 30 ms")
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(a.png)), exist_ok=True)
    fig.savefig(a.png, dpi=120)
    print(f"figure: {a.png}", file=sys.stderr)


def main():
    a = parse_args()
    if not os.access(a.binary, os.X_OK):
        sys.exit(f"soak.py: no voxcut binary at {a.binary} (build it, or give --binary)")
    start = time.time()
    rows, runs, failed = [], [], 0
    grid = [(m, l, s) for m in a.models for l in a.levels for s in range(a.seed, a.seed + a.seeds)]
    for model, level, seed in grid:
        folder, finished = run_one(a, model, level, seed)
        failed += 0 if finished else 1
        summary = os.path.join(folder, "summary.csv")
        if not os.path.exists(summary):
            continue
        for r in read_csv(summary):
            rows.append(r)
            frames = os.path.join(folder, r["run"] + ".csv")
            if os.path.exists(frames):
                runs.append((r, read_csv(frames)))
    print_table(rows)
    print(f"\n{len(rows)} runs in {(time.time() - start) / 60:.1f} min; CSVs in {a.out}",
          flush=True)
    if not a.no_plot and runs:
        plot(a, runs)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

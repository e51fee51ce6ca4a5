"""A parameter sweep on Dask: Young's modulus x blade speed on scenes/bunny-ear.json.

Each point of the grid is one run of the scene (voxcut.sweep.run_scene) with the bunny's
material stiffness set before the first frame and the blade's stroke played faster or slower
(it starts at 0.3 s as in the scene; at speed 1 it takes 0.4 s); every run goes on 0.3 s after
the stroke ends, as the scene does. The runs go to a Dask LocalCluster on this machine (or to
the scheduler given), and the table they make is plotted against the blade's speed, one line
per stiffness:

- the cut: the links cut in all (the blade cuts what its edge sweeps through the material as
  it is then, so the ear's motion during the stroke changes the cut);
- the blade's load: the most links it cut in one frame. A blade feels no force in voxcut (it
  cuts without resistance; FrameReport.tool_forces is zero for blades), so the cutting rate is
  what grows with its speed;
- the frame time: the median over all frames and over the frames that cut (medians, since
  the runs share the machine with whatever else runs on it).

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/sweep_bunny_ear.py
    ... --quick                      a 2 x 1 grid of short runs (the tests' setting)
    ... --repeat 5                   each point 5 times, keeping the smallest timings (the
                                     figure in docs/figures)
    ... --scheduler tcp://host:8786  on a running Dask cluster (the repository at the same
                                     path on every worker)
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any, List, Optional

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402 -- after choosing the backend
from matplotlib.lines import Line2D  # noqa: E402

from voxcut.sweep import (  # noqa: E402
    is_timing, rows_of, scene_runner, sweep, without_timings, write_csv)

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
SCENE = os.path.join(ROOT, "scenes", "bunny-ear.json")
DEFAULT_OUT = os.path.join(ROOT, "docs", "figures", "sweep-bunny-ear.png")

TIME_STEP = 0.004        # s, the scene's
STROKE = (0.3, 0.4)      # s, when the scene's stroke starts and how long it takes
AFTER = 0.3              # s, how long the scene runs on after the stroke

# The full grid: stiffness around the scene's 1 MPa, the stroke from half to four times its
# speed.
MODULI = [3e5, 1e6, 3e6]
SPEEDS = [0.5, 1.0, 2.0, 4.0]
# --quick: two stiffnesses, the fastest stroke (0.3 s to 0.4 s), 130 frames (to 0.52 s).
QUICK_MODULI = [1e6, 3e6]
QUICK_SPEEDS = [4.0]
QUICK_FRAMES = 130


def frames_for(speed: float) -> int:
    """Frames to the end of the stroke at `speed`, and AFTER more."""
    return round((STROKE[0] + STROKE[1] / speed + AFTER) / TIME_STEP)


def grid(quick: bool = False) -> List[dict]:
    """The sweep's points: a list of parameter dicts, each with its own frame count."""
    if quick:
        return [{"young_modulus": e, "blade_speed": s, "frames": QUICK_FRAMES}
                for e in QUICK_MODULI for s in QUICK_SPEEDS]
    return [{"young_modulus": e, "blade_speed": s, "frames": frames_for(s)}
            for e in MODULI for s in SPEEDS]


def run(quick: bool = False, scheduler: Any = None, n_workers: Optional[int] = 2,
        repeat: int = 1, verbose: bool = True) -> List[dict]:
    """Runs the sweep and returns its rows (a list of dicts, in the grid's order). With
    `repeat` > 1 every point runs that many times, as tasks of their own; the runs of a point
    must agree on every number but the timings (a run is deterministic), and its row keeps
    each timing's smallest value, the one least disturbed by whatever else the machine ran."""
    points = grid(quick)
    table = sweep(scene_runner(SCENE), points * repeat, scheduler=scheduler,
                  n_workers=n_workers if scheduler is None else None, verbose=verbose,
                  as_frame=False)
    rows = rows_of(table)
    out = []
    for i in range(len(points)):
        runs = rows[i::len(points)]
        same = without_timings(runs)
        if any(r != same[0] for r in same[1:]):
            raise RuntimeError(f"the runs of {points[i]} differ: {same}")
        row = dict(runs[0])
        for key in row:
            times = [r[key] for r in runs if isinstance(r[key], float)]
            if is_timing(key) and times:
                row[key] = min(times)
        out.append(row)
    return out


def plot(rows: List[dict], out: str, title: str) -> None:
    """Three panels against blade speed, one line per Young's modulus."""
    moduli = sorted({r["young_modulus"] for r in rows})
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), constrained_layout=True)
    for i, e in enumerate(moduli):
        mine = sorted((r for r in rows if r["young_modulus"] == e and r["error"] is None),
                      key=lambda r: r["blade_speed"])
        if not mine:
            continue
        colour = f"C{i}"
        label = f"E = {e / 1e6:g} MPa"
        speed = [r["blade_speed"] for r in mine]
        axes[0].plot(speed, [r["cut_links"] for r in mine], "o-", color=colour, label=label)
        for r in mine:
            if r["pieces"] < 2:  # the ear stayed on
                axes[0].plot([r["blade_speed"]], [r["cut_links"]], "kx", markersize=10)
        axes[1].plot(speed, [r["peak_cut_links"] for r in mine], "o-", color=colour,
                     label=label)
        axes[2].plot(speed, [r["median_frame_ms"] for r in mine], "o-", color=colour)
        axes[2].plot(speed, [r["median_cut_frame_ms"] for r in mine], "s--", color=colour)
    axes[0].set_title("the cut: links cut in all (x: the ear stayed on)")
    axes[0].set_ylabel("links")
    axes[1].set_title("the blade's load: most links cut in one frame")
    axes[1].set_ylabel("links")
    axes[2].set_title("frame time, median (one thread a run)")
    axes[2].set_ylabel("ms")
    axes[2].set_ylim(bottom=0)
    axes[2].legend(handles=[Line2D([], [], color="grey", marker="o", label="all frames"),
                            Line2D([], [], color="grey", marker="s", linestyle="--",
                                   label="frames that cut")], fontsize=8)
    for ax in axes:
        ax.set_xlabel("blade speed (x the scene's stroke)")
        ax.set_xscale("log", base=2)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[1].legend(fontsize=8)
    fig.suptitle(title)
    os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=DEFAULT_OUT, help="the PNG to write")
    parser.add_argument("--csv", help="also write the table as CSV here")
    parser.add_argument("--quick", action="store_true", help="a tiny grid of short runs")
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    parser.add_argument("--scheduler", help="a Dask scheduler address instead of a "
                                            "LocalCluster, or 'serial'")
    parser.add_argument("--repeat", type=int, default=1,
                        help="run each point this many times and keep the smallest timings")
    args = parser.parse_args(argv)
    rows = run(args.quick, scheduler=args.scheduler, n_workers=args.workers,
               repeat=args.repeat)
    failed = [r for r in rows if r["error"] is not None]
    for r in failed:
        print(f"E={r['young_modulus']:g} speed={r['blade_speed']:g}: {r['error']}",
              file=sys.stderr)
    print(f"{'E (Pa)':>8} {'speed':>5} {'frames':>6} {'cut':>5} {'peak':>5} {'pieces':>6} "
          f"{'drop mm':>8} {'mean ms':>8} {'med ms':>7} {'cut ms':>7} {'max ms':>7}  cut set")
    for r in rows:
        if r["error"] is None:
            print(f"{r['young_modulus']:8.0e} {r['blade_speed']:5g} {r['frames']:6d} "
                  f"{r['cut_links']:5d} {r['peak_cut_links']:5d} {r['pieces']:6d} "
                  f"{1e3 * r['fragment_drop']:8.1f} {r['mean_frame_ms']:8.2f} "
                  f"{r['median_frame_ms']:7.2f} {r['median_cut_frame_ms'] or 0:7.2f} "
                  f"{r['max_frame_ms']:7.2f}  "
                  f"{r['cut_set_hash']}")
    if args.csv:
        write_csv(rows, args.csv)
    runs = "130 frames each" if args.quick else f"each to {AFTER} s after the stroke"
    times = f", timings the least of {args.repeat}" if args.repeat > 1 else ""
    plot(rows, args.out, f"scenes/bunny-ear.json: Young's modulus x blade speed "
                         f"({len(rows) * args.repeat} runs on Dask, {runs}{times})")
    print(f"wrote {args.out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

"""A control loop on a voxcut world: a probe pressed to a target force, one episode at a time.

The world is a soft box 10 x 6 x 8 cm held at its base, with a sphere probe 1 cm in radius
above the middle of its top. It is built once and settled under gravity; then a snapshot is
taken (World.snapshot), and every episode starts from it (World.restore), as a learning or
tuning loop starts each episode from the same state. In an episode a policy moves the probe
frame by frame: it reads the force the body pushes the probe with (Tool.force, the last
frame's) and steps the probe down or up in proportion to the force error, a proportional
controller on the probe's speed (an integral controller on its position) with the step
clipped to a maximum speed:

    y(k+1) = y(k) - clip(gain * (target - F_y(k)), -max_step, max_step)

Each episode presses to its own target force; an episode run twice gives the same numbers,
since a run is deterministic and restore puts back everything (the probe's force model too).

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/control_loop.py
"""

from __future__ import annotations

import argparse
import sys
from typing import Any, Dict, List, Sequence

import numpy as np

import voxcut

TOP = 0.06             # m, the box's top face (its base at y = 0)
PROBE_RADIUS = 0.01    # m
START = (0.0, TOP + PROBE_RADIUS + 0.003, 0.0)  # the probe's centre, 3 mm above the top
SETTLE_FRAMES = 25     # 0.1 s under gravity before the snapshot
# m/N: the probe's step per newton of force error. The force answers a move within the frame,
# with a stiffness of about 1e4 N/m at 4 N here, so each step multiplies the error by about
# 1 - GAIN * 1e4: this gain makes that nearly 0 (dead-beat), twice it makes it -1 and the
# loop rings with a period of two frames.
GAIN = 1.0e-4
MAX_STEP = 2.0e-4      # m: at most 5 cm/s at 4 ms frames
TOLERANCE = 0.02       # an episode reaches its target when within 2 % of it


def build_world() -> tuple:
    """The box, its floor-side base held, and the probe above it: (world, body, probe)."""
    world = voxcut.World()
    body = world.add_body(
        "box:0.1,0.06,0.08", resolution=24, element_level=2, offset=(0.0, 0.03, 0.0),
        materials={"default": voxcut.Material(young_modulus=1e5, poisson_ratio=0.3)},
        fixed=[((-1.0, -1.0, -1.0), (1.0, 0.002, 1.0))])
    probe = world.add_probe(PROBE_RADIUS, START)
    return world, body, probe


def episode(world: voxcut.World, probe: voxcut.Tool, target: float, steps: int,
            gain: float = GAIN, max_step: float = MAX_STEP) -> Dict[str, Any]:
    """Runs one episode of `steps` frames from the world as it is; returns the probe's force
    (N, upwards) and the depth of its lowest point below the top face at rest (m), per frame,
    with the step from which the force stays within TOLERANCE of `target` (-1: never)."""
    y = float(probe.pose[0][1])
    forces = np.empty(steps)
    depths = np.empty(steps)
    for k in range(steps):
        force = float(probe.force[1])  # the bodies push the probe up: > 0 when pressing
        y -= float(np.clip(gain * (target - force), -max_step, max_step))
        probe.pose = (START[0], y, START[2])
        world.step()
        forces[k] = float(probe.force[1])
        depths[k] = TOP - (y - PROBE_RADIUS)
    within = np.abs(forces - target) <= TOLERANCE * target
    outside = np.flatnonzero(~within)
    settled = 0 if len(outside) == 0 else int(outside[-1]) + 1
    return {
        "target": target,
        "final_force": forces[-1],
        "final_depth": depths[-1],
        "settled_step": settled if settled < steps else -1,
        "forces": forces,
        "depths": depths,
        "cut_set_hash": f"{world.cut_set_hash():016x}",
        "frame": world.frame,
    }


def run(episodes: int = 4, steps: int = 100,
        targets: Sequence[float] = (2.0, 4.0, 6.0)) -> List[Dict[str, Any]]:
    """Runs `episodes` episodes of `steps` frames, episode e pressing to targets[e % len]
    (N), each from the same snapshot; returns each episode's results (episode())."""
    world, _, probe = build_world()
    world.step(SETTLE_FRAMES)
    start = world.snapshot()
    results = []
    for e in range(episodes):
        world.restore(start)  # the same state each episode: bodies, tools, clock
        r = episode(world, probe, float(targets[e % len(targets)]), steps)
        r["episode"] = e
        results.append(r)
    return results


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--targets", type=float, nargs="+", default=[2.0, 4.0, 6.0],
                        help="target forces (N), taken in turn")
    args = parser.parse_args(argv)
    results = run(args.episodes, args.steps, args.targets)
    print(f"{'episode':>7} {'target N':>8} {'force N':>8} {'depth mm':>8} {'settled':>7}")
    for r in results:
        settled = r["settled_step"] if r["settled_step"] >= 0 else "never"
        print(f"{r['episode']:7d} {r['target']:8.2f} {r['final_force']:8.3f} "
              f"{1e3 * r['final_depth']:8.2f} {settled!s:>7}")
    missed = [r for r in results if r["settled_step"] < 0]
    for r in missed:
        print(f"control_loop: episode {r['episode']} did not reach {r['target']} N",
              file=sys.stderr)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())

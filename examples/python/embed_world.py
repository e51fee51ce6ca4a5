"""Embedding voxcut from Python: the story of examples/embed_world/main.cpp.

A soft box held at its base 5 mm above a floor; a blade that cuts a slab off its side, which
falls onto the floor; a probe that presses on its top. The tools are moved frame by frame the
way an interactive application moves them, and the surface is read each frame the way a
renderer reads it: a zero-copy view, with only the triangle slots that changed copied.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/embed_world.py

prints a summary and exits 0, or prints what went wrong and exits 1. run() is the same story
as a function returning its numbers (the tests call it); with `record_to` it also saves the
run as a scene that `voxcut run` replays.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any, Dict, Optional

import numpy as np

import voxcut

PROBE_RADIUS = 0.01  # m: a sphere of 1 cm radius


def blade_pose(frame: int):
    """The blade's edge spans the box along z. Frames 0-39 it goes down through the side of the
    box at x = -0.035 from above to 1 cm over the floor, frames 40-64 it comes out sideways at
    that height: the slab x < -0.035 is cut off and falls onto the floor. (The C++ example's
    arithmetic, so that both compute the same poses.)"""
    down = min(max(frame / 40.0, 0.0), 1.0)
    out = min(max((frame - 40) / 25.0, 0.0), 1.0)
    x = -0.035 - 0.035 * out
    y = 0.07 - 0.06 * down
    return ((x, y, -0.06), (x, y, 0.06))


def probe_pose(frame: int):
    """The probe starts 5 mm above the top (y = 0.06) and presses 5 mm into it over the first
    50 frames, then holds. One point: a sphere (two ends would make a capsule)."""
    return (0.025, 0.075 - 0.01 * min(frame / 50.0, 1.0), 0.0)


class RenderedSurface:
    """What a renderer keeps of a body's surface: its own copy of the triangle slots (an index
    buffer on the GPU, say), brought up to date from the slots that changed since the revision
    it last read. Positions and normals change every frame and would be uploaded whole."""

    def __init__(self) -> None:
        self.triangles = np.empty((0, 3), dtype=np.int32)
        self.revision = 0
        self.empty = True         # nothing read yet
        self.copied_triangles = 0  # triangle slots copied over all reads
        self.reads = 0

    def update(self, body: voxcut.Body) -> None:
        # The view shows the world's own arrays; while it (or an array of it) is alive the
        # world refuses step(), so it lives only inside this call.
        view = body.surface_view()
        changes = body.surface_changes(self.revision)
        slots = view.triangles
        if len(self.triangles) != len(slots):
            grown = np.full((len(slots), 3), -1, dtype=np.int32)
            n = min(len(slots), len(self.triangles))
            grown[:n] = self.triangles[:n]
            self.triangles = grown
        if self.empty or changes.full:
            # The first read, or the reader fell too far behind: copy everything.
            self.triangles[:] = slots
            self.copied_triangles += len(slots)
        else:
            # Dead slots read (-1, -1, -1); a slot both removed and added holds its new one.
            changed = np.asarray(changes.removed_triangles + changes.added_triangles,
                                 dtype=np.int64)
            self.triangles[changed] = slots[changed]
            self.copied_triangles += len(changed)
        self.revision = view.revision
        self.empty = False
        self.reads += 1


def run(frames: int = 100, record_to: Optional[str] = None) -> Dict[str, Any]:
    """Runs the story for `frames` frames (4 ms each) and returns its numbers: cut_links,
    pieces, cut_set_hash (16 hex digits, as `voxcut run --json`), probe_force and floor_force
    ((3,) N), floor_contacts, mean_frame_ms, unconverged (frames), copied_triangles,
    rendered_matches (the renderer's triangles equal the world's), nan_pose_refused, and
    surface (the final voxcut.Surface). With `record_to`, the run is recorded from its first
    frame and saved there as a scene file (World.save_scene)."""
    world = voxcut.World()  # 4 ms frames, gravity 9.81 m/s^2 along -y

    # The body: a 10 x 6 x 8 cm box at 24 voxels along its longest side (about 4.5 mm each),
    # its base at y = 0; coarse elements (level 2: 4 voxels a side) for speed; a soft material;
    # its base held in place (as if glued onto a stand).
    body = world.add_body(
        "box:0.1,0.06,0.08", resolution=24, element_level=2, offset=(0.0, 0.03, 0.0),
        materials={"default": voxcut.Material(young_modulus=1e5, poisson_ratio=0.3)},
        fixed=[((-1.0, -1.0, -1.0), (1.0, 0.002, 1.0))])

    # The floor: the half-space below y = -5 mm, which the bodies' surfaces cannot enter.
    world.add_plane(point=(0.0, -0.005, 0.0), normal=(0.0, 1.0, 0.0))

    blade = world.add_blade(blade_pose(0))
    probe = world.add_probe(PROBE_RADIUS, probe_pose(0))

    if record_to is not None:
        world.start_recording()  # before the first frame: a scene replays from frame 0
    rendered = RenderedSurface()
    rendered.update(body)
    frame_ms = 0.0
    unconverged = 0
    report = None
    for f in range(frames):
        # Where each tool should be at the end of this frame (from the user's hand, a haptic
        # device...); during the frame it moves there in a straight line.
        blade.pose = blade_pose(f + 1)
        probe.pose = probe_pose(f + 1)
        report = world.step()
        frame_ms += report.total_ms
        unconverged += report.status != "ok"  # a status, not an error: the frame still ran
        rendered.update(body)

    # A bad argument, such as a NaN pose from a device, is an InputError that changes nothing.
    try:
        probe.pose = (math.nan, 0.0, 0.0)
        nan_pose_refused = False
    except voxcut.InputError:
        nan_pose_refused = True

    view = body.surface_view()
    rendered_matches = bool(np.array_equal(np.asarray(view.triangles), rendered.triangles))
    del view

    contacts = world.contacts()
    floor_contacts = int(np.count_nonzero(contacts.kind == voxcut.CONTACT_KINDS.index("obstacle")))
    if record_to is not None:
        world.save_scene(record_to, frames=frames)
    return {
        "frames": world.frame,
        "time": world.time,
        "mean_frame_ms": frame_ms / frames,
        "unconverged": unconverged,
        "cut_links": body.info.cut_links,
        "pieces": body.pieces(),
        "cut_set_hash": f"{world.cut_set_hash():016x}",
        "surface_triangles": body.info.surface_triangles,
        "copied_triangles": rendered.copied_triangles,
        "surface_reads": rendered.reads,
        "rendered_matches": rendered_matches,
        "probe_force": np.array(probe.force),
        # Per obstacle in the order of world.obstacles(): the floor is the only one.
        "floor_force": np.array(report.obstacle_forces[0]),
        "floor_contacts": floor_contacts,
        "nan_pose_refused": nan_pose_refused,
        "surface": body.surface(),
    }


def problems(result: Dict[str, Any]) -> list:
    """What went wrong, as the C++ example checks it (empty when the story came out right)."""
    out = []
    if result["cut_links"] == 0:
        out.append("the blade cut no link")
    if result["pieces"] < 2:
        out.append("the blade did not cut the slab off")
    if not result["probe_force"][1] > 0.0:
        out.append("the body does not push the probe up")
    if not result["floor_force"][1] < 0.0 or result["floor_contacts"] == 0:
        out.append("the slab does not rest on the floor")
    if not result["nan_pose_refused"]:
        out.append("a NaN pose was accepted")
    if not result["rendered_matches"]:
        out.append("the rendered triangles differ from the world's")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--record", metavar="SCENE",
                        help="save the run as a scene file that `voxcut run` replays")
    args = parser.parse_args(argv)
    try:
        r = run(args.frames, record_to=args.record)
    except (voxcut.InputError, voxcut.StepError) as e:
        print(f"embed_world: error: {e}", file=sys.stderr)
        return 1
    p, fl = r["probe_force"], r["floor_force"]
    print(f"frames          {r['frames']} ({r['time']:.3f} s simulated, "
          f"{r['mean_frame_ms']:.2f} ms a frame)")
    print(f"cut links       {r['cut_links']} (cut set {r['cut_set_hash']})")
    print(f"pieces          {r['pieces']}")
    print(f"surface         {r['surface_triangles']} triangles; {r['copied_triangles']} triangle "
          f"slots copied over {r['surface_reads']} reads")
    print(f"probe force     ({p[0]:.4f}, {p[1]:.4f}, {p[2]:.4f}) N")
    print(f"floor force     ({fl[0]:.4f}, {fl[1]:.4f}, {fl[2]:.4f}) N (the slab's weight), "
          f"{r['floor_contacts']} contacts")
    print(f"unconverged     {r['unconverged']} frames")
    if args.record:
        print(f"recorded        {args.record} (voxcut run {args.record} --json replays it)")
    for problem in problems(r):
        print(f"embed_world: {problem}", file=sys.stderr)
    return 1 if problems(r) else 0


if __name__ == "__main__":
    sys.exit(main())

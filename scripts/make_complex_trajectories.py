#!/usr/bin/env python3
"""Writes the tool recordings of the complex scenes (scenes/recordings/complex-*.json).

The paper's complex scenario (section 4.2) plays back a poking tool and a cutting tool that a
user drove once. These recordings stand in for such a user: each tool follows waypoints, with
minimum-jerk motion between them (the velocity profile of a reaching hand) and holds where two
waypoints are equal, plus a small tremor (a few sinusoids near 9 Hz and a slow drift, a tenth
of a millimetre or two). The tremor's phases come from a fixed seed, so the output is the same
on every run and machine. Keys are written every two frames (8 ms), as a recorder sampling at
125 Hz would; the scene plays them back interpolated linearly.

Usage: python3 scripts/make_complex_trajectories.py [OUTPUT_FOLDER]
(default: scenes/recordings next to this script's folder). The scenes themselves
(scenes/complex-*.json) hold the bodies and name these files in their tools' "trajectory".
"""

import json
import math
import os
import random
import sys

TIME_STEP = 0.004  # the scenes' time step (s)
KEY_EVERY = 2  # frames between keys


def min_jerk(s):
    """Minimum-jerk progress 10 s^3 - 15 s^4 + 6 s^5 of a move, for s in [0, 1]."""
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def lerp(p, q, s):
    return [pi + (qi - pi) * s for pi, qi in zip(p, q)]


class Track:
    """A tool's path: waypoints (t, pose), a pose being a list of points (one for a spherical
    probe, two for a blade's ends). Between waypoints the tool moves by minimum jerk; before
    the first and after the last it holds."""

    def __init__(self, waypoints):
        self.waypoints = waypoints
        for (t0, _), (t1, _) in zip(waypoints, waypoints[1:]):
            assert t1 > t0, "waypoint times must increase"

    def pose(self, t):
        w = self.waypoints
        if t <= w[0][0]:
            return w[0][1]
        for (t0, p0), (t1, p1) in zip(w, w[1:]):
            if t <= t1:
                s = min_jerk((t - t0) / (t1 - t0))
                return [lerp(a, b, s) for a, b in zip(p0, p1)]
        return w[-1][1]


class Tremor:
    """A smooth hand tremor: per axis, three sinusoids between 8 and 11 Hz and one slow drift
    between 0.4 and 1.2 Hz, amplitudes in metres."""

    def __init__(self, rng, tremor=1.2e-4, drift=2.5e-4):
        self.terms = []
        for axis in range(3):
            for _ in range(3):
                self.terms.append((axis, tremor / 3.0, rng.uniform(8.0, 11.0),
                                   rng.uniform(0.0, 2.0 * math.pi)))
            self.terms.append((axis, drift, rng.uniform(0.4, 1.2), rng.uniform(0.0, 2.0 * math.pi)))

    def offset(self, t):
        d = [0.0, 0.0, 0.0]
        for axis, amplitude, frequency, phase in self.terms:
            d[axis] += amplitude * math.sin(2.0 * math.pi * frequency * t + phase)
        return d


def keys(track, tremor, duration):
    """Keys every KEY_EVERY frames from 0 to duration (inclusive), rounded to a micrometre."""
    out = []
    n = int(round(duration / TIME_STEP))
    for frame in range(0, n + 1, KEY_EVERY):
        t = round(frame * TIME_STEP, 6)
        d = tremor.offset(t)
        pose = [[round(c + dc, 6) for c, dc in zip(p, d)] for p in track.pose(t)]
        if len(pose) == 1:
            out.append({"t": t, "p": pose[0]})
        else:
            assert pose[0] != pose[1], "a blade's ends must differ"
            out.append({"t": t, "a": pose[0], "b": pose[1]})
    return out


def blade(a, b):
    return [list(a), list(b)]


def point(p):
    return [list(p)]


# ---- the bunny (y up, base at y = 0, head and ears towards -x, back towards +x) ----------


def bunny():
    # The blade: parked in front of the head, then the ear stroke of scenes/bunny-ear.json
    # (y = 0.129, x from -0.044 to 0.012, front to back), then, held upright like a scalpel
    # and put in along its own line, an incision about 2.2 cm deep and 5 cm long along the back
    # at z = 0.02.
    park = blade((-0.044, 0.15, 0.075), (0.012, 0.15, 0.075))
    ear_start = blade((-0.044, 0.129, 0.032), (0.012, 0.129, 0.032))
    ear_end = blade((-0.044, 0.129, -0.032), (0.012, 0.129, -0.032))
    ear_up = blade((-0.044, 0.165, -0.032), (0.012, 0.165, -0.032))
    high = blade((0.0, 0.17, 0.05), (0.056, 0.17, 0.05))
    upright_high = blade((-0.004, 0.135, 0.02), (-0.004, 0.19, 0.02))
    upright_in = blade((-0.004, 0.073, 0.02), (-0.004, 0.128, 0.02))
    upright_along = blade((0.046, 0.073, 0.02), (0.046, 0.128, 0.02))
    upright_out = blade((0.046, 0.135, 0.02), (0.046, 0.19, 0.02))
    blade_track = Track([
        (0.0, park), (1.15, park),
        (1.45, ear_start),  # approach, along the head's top
        (1.95, ear_end),  # cut 1: the right ear's base (0.128 m/s)
        (2.15, ear_up), (2.45, park), (3.0, park),
        (3.3, high), (3.55, upright_high),  # turned upright in the air
        (3.7, upright_in),  # the tip goes in along the blade
        (4.1, upright_along),  # cut 2: the incision along the back (0.125 m/s)
        (4.2, upright_out), (4.5, high), (4.8, high),
    ])
    # The probe (a sphere 1 cm in radius) presses the back behind the ears twice, after the ear
    # cut the back again, after the incision the back beside it (6 to 9 mm below the surface
    # at rest each time).
    above1, down1 = point((0.04, 0.122, 0.0)), point((0.04, 0.0966, 0.0))
    above2, down2 = point((0.025, 0.115, -0.015)), point((0.025, 0.089, -0.015))
    above3, down3 = point((0.02, 0.126, 0.002)), point((0.02, 0.1, 0.002))
    rest = point((0.07, 0.14, 0.04))
    probe_track = Track([
        (0.0, rest), (0.2, rest), (0.35, above1),
        (0.6, down1), (0.85, down1), (1.05, above1),  # poke 1
        (1.15, down1), (1.3, above1),  # a short second press
        (1.5, rest), (2.4, rest), (2.6, above2),
        (2.85, down2), (3.05, down2), (3.25, above2), (3.45, rest),  # poke 2, after the ear cut
        (4.25, rest), (4.4, above3),
        (4.6, down3), (4.72, down3), (4.8, above3),  # poke 3, beside the incision
    ])
    return 4.8, blade_track, probe_track, 0.01


# ---- the liver (z up, +y posterior, right lobe towards -x, tumor in the right lobe) -------


def liver():
    # A vertical blade (its tip at z = 0.0, the handle above the liver) cuts from the front
    # back through the tumor (x -0.064 to -0.034, y -0.010 to 0.025, z 0.009 to 0.046) along
    # x = -0.049: the cut crosses the liver-tumor boundary, as in the paper. Then, after a
    # pause, a second, full-depth cut across the front of the right lobe at y = -0.04.
    park = blade((-0.049, -0.11, 0.06), (-0.049, -0.11, 0.16))
    front = blade((-0.049, -0.075, 0.0), (-0.049, -0.075, 0.12))
    through = blade((-0.049, 0.012, 0.0), (-0.049, 0.012, 0.12))
    lifted = blade((-0.049, 0.012, 0.1), (-0.049, 0.012, 0.22))
    high2 = blade((-0.105, -0.04, 0.1), (-0.105, -0.04, 0.32))
    park2 = blade((-0.105, -0.04, -0.11), (-0.105, -0.04, 0.11))
    across = blade((-0.03, -0.04, -0.11), (-0.03, -0.04, 0.11))
    lifted2 = blade((-0.03, -0.04, 0.12), (-0.03, -0.04, 0.34))
    blade_track = Track([
        (0.0, park), (1.0, park), (1.25, front),
        (1.9, through),  # cut 1: 8.7 cm through the tumor (0.134 m/s)
        (2.05, lifted), (2.3, high2), (2.6, park2), (3.1, park2),
        (3.6, across),  # cut 2: 7.5 cm across the right lobe's front, full depth
        (3.7, across), (3.95, lifted2),  # lifted out along itself
    ])
    # The probe (a sphere 1 cm in radius) presses the right lobe's top from above (8 mm below
    # its surface at rest), then beside the first cut, then the left lobe.
    above1, down1 = point((-0.065, -0.025, 0.09)), point((-0.065, -0.025, 0.0684))
    above2, down2 = point((-0.035, -0.025, 0.105)), point((-0.035, -0.025, 0.085))
    above3, down3 = point((0.03, -0.02, 0.095)), point((0.03, -0.02, 0.0782))
    rest = point((0.0, -0.09, 0.12))
    probe_track = Track([
        (0.0, rest), (0.2, rest), (0.35, above1),
        (0.6, down1), (0.8, down1), (0.95, above1),  # poke 1
        (1.1, rest), (2.2, rest), (2.4, above2),
        (2.65, down2), (2.9, down2), (3.05, above2), (3.2, rest),  # poke 2, opens cut 1
        (4.0, rest), (4.15, above3),
        (4.35, down3), (4.5, down3), (4.65, above3),  # poke 3, the left lobe
    ])
    return 4.7, blade_track, probe_track, 0.01


# ---- the starfish (lying flat in the xy plane, z up, one arm along +y) --------------------


def starfish():
    # A vertical blade cuts off the +y arm at y = 0.032 (the stroke of
    # scenes/starfish-arm.json, slower), then, after a pause, the tip of the arm pointing
    # down to the right (306 degrees) about 6.5 cm from the centre.
    park = blade((-0.05, 0.045, -0.05), (-0.05, 0.045, 0.06))
    arm_start = blade((-0.03, 0.032, -0.05), (-0.03, 0.032, 0.06))
    arm_end = blade((0.03, 0.032, -0.05), (0.03, 0.032, 0.06))
    arm_lift = blade((0.03, 0.032, 0.03), (0.03, 0.032, 0.14))
    angle = math.radians(306.0)
    axis = (math.cos(angle), math.sin(angle))
    across = (-axis[1], axis[0])  # perpendicular to the arm, in the plane
    centre = (0.065 * axis[0], 0.065 * axis[1])

    def tip_cut(s, z0=-0.05, z1=0.06):
        x, y = centre[0] + s * across[0], centre[1] + s * across[1]
        return blade((x, y, z0), (x, y, z1))

    park2 = tip_cut(0.035, 0.03, 0.14)
    blade_track = Track([
        (0.0, park), (0.9, park), (1.1, arm_start),
        (1.5, arm_end),  # cut 1: the +y arm (0.15 m/s)
        (1.65, arm_lift), (2.0, park2), (2.8, park2),
        (3.0, tip_cut(0.025)),  # set down beside the arm
        (3.3, tip_cut(-0.025)),  # cut 2: the arm's tip (0.17 m/s)
        (3.45, tip_cut(-0.025, 0.03, 0.14)),
    ])
    # The probe (a sphere 8 mm in radius) presses the arm pointing right (18 degrees), then the
    # arm pointing left (162 degrees), then the right arm again after both cuts (5 mm below
    # the arm's top at rest).
    a18, a162 = math.radians(18.0), math.radians(162.0)
    right = (0.062 * math.cos(a18), 0.062 * math.sin(a18))
    left = (0.062 * math.cos(a162), 0.062 * math.sin(a162))
    above_r, down_r = point((right[0], right[1], 0.03)), point((right[0], right[1], 0.013))
    above_l, down_l = point((left[0], left[1], 0.03)), point((left[0], left[1], 0.013))
    rest = point((0.0, -0.03, 0.06))
    probe_track = Track([
        (0.0, rest), (0.15, rest), (0.3, above_r),
        (0.5, down_r), (0.7, down_r), (0.85, above_r),  # poke 1
        (1.0, rest), (1.8, rest), (2.0, above_l),
        (2.2, down_l), (2.45, down_l), (2.6, above_l), (2.75, rest),  # poke 2
        (3.5, rest), (3.65, above_r),
        (3.85, down_r), (4.0, down_r), (4.15, above_r),  # poke 3
    ])
    return 4.2, blade_track, probe_track, 0.008


SCENES = {"complex-bunny": (bunny, 11), "complex-liver": (liver, 12),
          "complex-starfish": (starfish, 13)}


def recording(name):
    make, seed = SCENES[name]
    duration, blade_track, probe_track, radius = make()
    rng = random.Random(seed)
    blade_keys = keys(blade_track, Tremor(rng), duration)
    probe_keys = keys(probe_track, Tremor(rng), duration)
    return {
        "description": "voxcut tool recording: " + name + " (scripts/make_complex_trajectories.py)",
        "time_step": TIME_STEP,
        "tools": [{"type": "blade", "keys": blade_keys},
                  {"type": "probe", "radius": radius, "keys": probe_keys}],
    }


def write(record, path):
    """JSON with one key per line, so that a diff of two versions reads."""
    lines = ["{", '  "description": %s,' % json.dumps(record["description"]),
             '  "time_step": %s,' % json.dumps(record["time_step"]), '  "tools": [']
    for i, tool in enumerate(record["tools"]):
        head = {k: v for k, v in tool.items() if k != "keys"}
        lines.append("    " + json.dumps(head)[:-1] + ', "keys": [')
        for j, key in enumerate(tool["keys"]):
            lines.append("      " + json.dumps(key) + ("," if j + 1 < len(tool["keys"]) else ""))
        lines.append("    ]}" + ("," if i + 1 < len(record["tools"]) else ""))
    lines += ["  ]", "}"]
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "scenes", "recordings")
    os.makedirs(out, exist_ok=True)
    for name in SCENES:
        path = os.path.join(out, name + ".json")
        write(recording(name), path)
        print("wrote", os.path.normpath(path))


if __name__ == "__main__":
    main()

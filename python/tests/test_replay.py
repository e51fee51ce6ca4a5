"""Python runs against the command line: a scene stepped from Python gives what `voxcut run`
gives, and a run recorded in Python, saved as a scene, replays under `voxcut run` to the same
cuts and surfaces."""

import json
import pathlib
import subprocess

import numpy as np
import pytest

import voxcut
from conftest import SOURCE_DIR


def run_cli(cli, scene, frames, *extra):
    out = subprocess.run([str(cli), "run", str(scene), "--frames", str(frames), "--json",
                          *map(str, extra)], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def read_obj(path):
    vertices, faces = [], []
    for line in pathlib.Path(path).read_text().splitlines():
        if line.startswith("v "):
            vertices.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            faces.append([int(x.split("/")[0]) - 1 for x in line.split()[1:4]])
    return np.array(vertices), np.array(faces)


def test_a_scene_in_python_cuts_what_voxcut_run_cuts(cli):
    scene = SOURCE_DIR / "scenes" / "bunny-ear.json"
    frames = 140  # the blade is half-way through the ear
    world = voxcut.World.from_scene(scene)
    world.step(frames)
    summary = run_cli(cli, scene, frames)
    assert summary["cut_links"] > 0
    assert f"{world.cut_set_hash():016x}" == summary["cut_set_hash"]
    assert world.bodies()[0].info.cut_links == summary["cut_links"]


def embed_story(world, frames):
    """examples/embed_world's story: a held box, a floor, a blade cutting a slab off its side
    and a probe pressing on its top, moved frame by frame."""
    body = world.add_body("box:0.1,0.06,0.08", resolution=24, element_level=2,
                          offset=(0.0, 0.03, 0.0),
                          materials={"default": voxcut.Material(young_modulus=1e5,
                                                                poisson_ratio=0.3)},
                          fixed=[((-1, -1, -1), (1, 0.002, 1))])
    world.add_plane(point=(0.0, -0.005, 0.0), normal=(0.0, 1.0, 0.0))

    def blade_pose(f):
        down, out = np.clip(f / 40.0, 0, 1), np.clip((f - 40) / 25.0, 0, 1)
        x, y = -0.035 - 0.035 * out, 0.07 - 0.06 * down
        return ((x, y, -0.06), (x, y, 0.06))

    def probe_pose(f):
        return (0.025, 0.075 - 0.01 * min(f / 50.0, 1.0), 0.0)

    blade = world.add_blade(blade_pose(0))
    probe = world.add_probe(0.01, probe_pose(0))
    world.start_recording()
    for f in range(frames):
        blade.pose = blade_pose(f + 1)
        probe.pose = probe_pose(f + 1)
        world.step()
    return body, blade, probe


def test_recorded_run_replays_under_voxcut_run(cli, tmp_path):
    frames = 80
    world = voxcut.World()
    body, blade, probe = embed_story(world, frames)
    assert body.pieces() >= 2  # the slab is off
    scene = tmp_path / "story.json"
    world.save_scene(scene, frames=frames)
    text = json.loads(scene.read_text())
    assert len(text["tools"]) == 2 and len(text["tools"][0]["keys"]) == frames + 1
    export = tmp_path / "export"
    summary = run_cli(cli, scene, frames, "--export", export, "--every", frames)
    assert summary["cut_set_hash"] == f"{world.cut_set_hash():016x}"
    assert summary["pieces"] == body.pieces()
    # The surfaces agree: the command's last export against Python's copy (the OBJ writer
    # prints enough digits to read back the same doubles).
    vertices, faces = read_obj(export / f"frame_{frames:05d}.obj")
    surface = body.surface()
    np.testing.assert_array_equal(faces, surface.triangles)
    np.testing.assert_array_equal(vertices, surface.vertices)
    # The probe's force: the command's final force is the Python run's.
    np.testing.assert_allclose(summary["tool_forces"][1]["final"], probe.force, rtol=1e-9,
                               atol=1e-12)


def test_label_array_bodies_are_saved_with_the_scene(cli, tmp_path):
    n = 20
    c = (n - 1) / 2.0
    i, j, k = np.mgrid[0:n, 0:n, 0:n]
    labels = (np.sqrt((i - c) ** 2 + (j - c) ** 2 + (k - c) ** 2) < 0.45 * n).astype(np.uint8)
    labels[: n // 2] *= 2  # two tissues: 2 on the low-x half, 1 on the other
    world = voxcut.World()
    body = world.add_body_from_labels(labels, 0.003, origin=(-0.03, 0.0, -0.03),
                                      names={1: "soft", 2: "firm"}, resolution=24,
                                      element_level=2,
                                      materials={"firm": voxcut.Material(young_modulus=2e5)},
                                      fixed=[((-1, -1, -1), (1, 0.01, 1))])
    blade = world.add_blade(((-0.04, 0.07, 0.0), (0.04, 0.07, 0.0)))
    world.start_recording()
    frames = 40
    for f in range(frames):
        y = 0.07 - 0.05 * (f + 1) / frames
        blade.pose = ((-0.04, y, 0.0), (0.04, y, 0.0))
        world.step()
    assert body.info.cut_links > 0
    scene = tmp_path / "labels.json"
    world.save_scene(scene)
    assert (tmp_path / "labels.body0.nrrd").is_file()
    summary = run_cli(cli, scene, frames)
    assert summary["cut_set_hash"] == f"{world.cut_set_hash():016x}"


def test_save_scene_refuses_what_cannot_be_replayed(tmp_path):
    world = voxcut.World()
    with pytest.raises(voxcut.InputError, match="nothing recorded"):
        world.save_scene(tmp_path / "a.json")
    world.add_body("box:0.05,0.05,0.05", resolution=12)
    world.step()
    world.start_recording()
    with pytest.raises(voxcut.InputError, match="not at the start"):
        world.save_scene(tmp_path / "b.json")
    world2 = voxcut.World()
    world2.start_recording()
    world2.add_body("box:0.05,0.05,0.05", resolution=12)
    with pytest.raises(voxcut.InputError, match="cannot be replayed"):
        world2.save_scene(tmp_path / "c.json")
    assert not list(tmp_path.iterdir())

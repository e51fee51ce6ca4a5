"""The Python examples (examples/python/) run and come out right: embed_world cuts the slab off
and its recorded run replays through `voxcut run` to the same cut; control_loop reaches each
target force and repeats an episode exactly; sweep_bunny_ear --quick writes its figure."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import voxcut

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
EXAMPLES = os.path.join(ROOT, "examples", "python")
# The command line: where CTest says (conftest.py's VOXCUT_CLI), else the release build's.
CLI = os.environ.get("VOXCUT_CLI",
                     os.path.join(ROOT, "build", "release", "apps", "voxcut", "voxcut"))


def example(name):
    """The example module examples/python/NAME.py, imported under its own name."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, os.path.join(EXAMPLES, name + ".py"))
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def run_script(name, *args, timeout=300):
    """Runs examples/python/NAME.py as a program, with this interpreter and package."""
    env = dict(os.environ)
    package = os.path.dirname(os.path.dirname(voxcut.__file__))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package, env.get("PYTHONPATH")) if p)
    return subprocess.run([sys.executable, os.path.join(EXAMPLES, name + ".py"), *args],
                          capture_output=True, text=True, timeout=timeout, env=env, cwd=ROOT)


# ---- embed_world ----

@pytest.fixture(scope="module")
def embedded(tmp_path_factory):
    scene = tmp_path_factory.mktemp("embed") / "embed-world.json"
    return example("embed_world").run(frames=100, record_to=str(scene)), scene


def test_embed_world_cuts_the_slab_off(embedded):
    r, _ = embedded
    assert r["frames"] == 100 and r["time"] == pytest.approx(0.4)
    assert r["cut_links"] > 0
    assert r["pieces"] >= 2
    assert r["probe_force"][1] > 0.0                               # the top pushes the probe up
    assert r["floor_force"][1] < 0.0 and r["floor_contacts"] > 0  # the slab lies on the floor
    assert r["nan_pose_refused"]
    assert r["unconverged"] == 0
    # The renderer's incremental copy equals the world's triangles, and it copied less than
    # a full read every frame would have.
    assert r["rendered_matches"]
    assert r["copied_triangles"] < 101 * r["surface_triangles"]
    surface = r["surface"]
    assert isinstance(surface, voxcut.Surface)
    assert len(surface.triangles) == r["surface_triangles"] > 0
    assert surface.vertices.shape == surface.normals.shape == (surface.vertices.shape[0], 3)
    # The slab is off the box's side: surface below y = 0 lies on the floor, left of the cut.
    low = surface.vertices[:, 1] < -0.001
    assert low.any() and (surface.vertices[low, 0] < -0.03).all()


def test_embed_world_surface_marks_the_cut_faces(embedded):
    r, _ = embedded
    surface = r["surface"]
    assert surface.cut.any() and not surface.cut.all()  # the cut faces are closed over
    assert set(np.unique(surface.materials)) == {1}     # "default", the box's one material


def test_embed_world_saves_a_scene_that_voxcut_run_replays(embedded):
    r, scene = embedded
    spec = json.loads(scene.read_text())
    assert spec["frames"] == 100 and len(spec["tools"]) == 2 and len(spec["obstacles"]) == 1
    assert os.access(CLI, os.X_OK), f"the voxcut command line is not built: {CLI}"
    out = subprocess.run([CLI, "run", str(scene), "--json", "--threads", "1"],
                         capture_output=True, text=True, check=True, timeout=120)
    replay = json.loads(out.stdout)
    assert replay["cut_set_hash"] == r["cut_set_hash"]
    assert replay["cut_links"] == r["cut_links"]
    assert replay["pieces"] == r["pieces"]
    assert replay["tool_forces"][1]["final"] == pytest.approx(list(r["probe_force"]), rel=1e-9)


def test_embed_world_as_a_program():
    done = run_script("embed_world", "--frames", "100")
    assert done.returncode == 0, done.stderr
    assert "pieces          2" in done.stdout
    assert done.stderr == ""


# ---- control_loop ----

@pytest.fixture(scope="module")
def episodes():
    return example("control_loop").run(episodes=4, steps=100, targets=(2.0, 4.0, 6.0))


def test_control_loop_reaches_each_target(episodes):
    tolerance = example("control_loop").TOLERANCE
    assert [e["target"] for e in episodes] == [2.0, 4.0, 6.0, 2.0]
    for e in episodes:
        assert abs(e["final_force"] - e["target"]) <= tolerance * e["target"]
        assert 0 < e["settled_step"] < 100
        # It holds the force steadily there (a gain too high rings around the target).
        assert np.ptp(e["forces"][-10:]) < 0.005 * e["target"]
        assert e["final_depth"] > 0.0
    # Harder presses go deeper; nothing is cut by a probe.
    depths = [e["final_depth"] for e in episodes[:3]]
    assert depths[0] < depths[1] < depths[2]
    assert {e["cut_set_hash"] for e in episodes} == {f"{voxcut.World().cut_set_hash():016x}"}


def test_control_loop_repeats_an_episode_exactly(episodes):
    first, again = episodes[0], episodes[3]
    assert np.array_equal(first["forces"], again["forces"])
    assert np.array_equal(first["depths"], again["depths"])
    assert first["frame"] == again["frame"]
    assert not np.array_equal(first["forces"], episodes[1]["forces"])


def test_control_loop_restore_is_a_fresh_start(episodes):
    # An episode from the snapshot equals the same episode on a world built and settled anew.
    loop = example("control_loop")
    world, _, probe = loop.build_world()
    world.step(loop.SETTLE_FRAMES)
    fresh = loop.episode(world, probe, 2.0, 100)
    assert np.array_equal(fresh["forces"], episodes[0]["forces"])


# ---- sweep_bunny_ear ----

def test_sweep_bunny_ear_quick_writes_its_figure(tmp_path):
    png = tmp_path / "sweep.png"
    table = tmp_path / "sweep.csv"
    done = run_script("sweep_bunny_ear", "--quick", "--out", str(png), "--csv", str(table))
    assert done.returncode == 0, done.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["young_modulus"]) for r in rows] == [1e6, 3e6]
    for r in rows:
        assert r["error"] == ""
        assert int(r["pieces"]) == 2 and int(r["cut_links"]) > 0  # the ear came off
        assert int(r["peak_cut_links"]) > 0 and r["peak_probe_force"] == ""
    # One progress line a run, on stderr.
    assert sum(line.startswith("[") for line in done.stderr.splitlines()) == 2

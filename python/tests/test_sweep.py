"""voxcut.sweep: the grid, the checks made before anything runs, the same numbers on a Dask
LocalCluster as in a plain loop, rows in the grid's order, failing tasks as error rows, no
worker process left behind, and run_scene against `voxcut run` on the same changes.

Most runs are of a small scene written here (a box at resolution 20, a blade and a probe,
80 frames: about 0.3 s a run); two are of scenes/bunny-ear.json.
"""

from __future__ import annotations

import csv
import json
import math
import multiprocessing
import os
import subprocess
import time
import warnings

import psutil
import pytest

import voxcut
import voxcut.sweep as vs  # not `from voxcut import sweep`: see the report on __getattr__

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir))
BUNNY_EAR = os.path.join(ROOT, "scenes", "bunny-ear.json")
# The command line: where CTest says (conftest.py's VOXCUT_CLI), else the release build's.
CLI = os.environ.get("VOXCUT_CLI",
                     os.path.join(ROOT, "build", "release", "apps", "voxcut", "voxcut"))

# A soft box held at its base; a blade goes down through its side (0 to 0.16 s) and out
# sideways (to 0.26 s), cutting a slab off; a sphere probe presses 5 mm into its top (0 to
# 0.2 s); a floor below.
SMALL_SCENE = {
    "description": "test_sweep: a box, a blade cutting a slab off its side, a probe on its top",
    "time_step": 0.004,
    "frames": 80,
    "bodies": [{"model": "box:0.1,0.06,0.08", "resolution": 20, "element_level": 2,
                "offset": [0, 0.03, 0],
                "materials": {"default": {"young_modulus": 1e5, "poisson_ratio": 0.3}},
                "fixed": [{"box": [[-1, -1, -1], [1, 0.002, 1]]}]}],
    "tools": [
        {"type": "blade", "keys": [
            {"t": 0.0, "a": [-0.035, 0.07, -0.06], "b": [-0.035, 0.07, 0.06]},
            {"t": 0.16, "a": [-0.035, 0.01, -0.06], "b": [-0.035, 0.01, 0.06]},
            {"t": 0.26, "a": [-0.07, 0.01, -0.06], "b": [-0.07, 0.01, 0.06]}]},
        {"type": "probe", "radius": 0.01, "keys": [
            {"t": 0.0, "p": [0.025, 0.075, 0.0]}, {"t": 0.2, "p": [0.025, 0.065, 0.0]}]}],
    "obstacles": [{"type": "plane", "point": [0, -0.005, 0], "normal": [0, 1, 0]}],
}

# Eight runs: every parameter the grid names changes the numbers.
GRID8 = {"young_modulus": [5e4, 1e5], "blade_speed": [1.0, 2.0], "probe_speed": [1.0, 2.0]}


@pytest.fixture(scope="module")
def small_scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("scenes") / "small.json"
    path.write_text(json.dumps(SMALL_SCENE))
    return str(path)


@pytest.fixture(scope="module")
def cluster():
    """A 2-worker LocalCluster shared by the tests that do not test sweep's own."""
    import logging

    import distributed

    with warnings.catch_warnings():
        # Debian's tornado 6.2 under distributed 2022.12 warns of its own deprecated call.
        warnings.filterwarnings("ignore", "make_current is deprecated", DeprecationWarning)
        c = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                     host="127.0.0.1", dashboard_address=None,
                                     scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                                     worker_dashboard_address="127.0.0.1:0",
                                     silence_logs=logging.ERROR)
    with c:
        yield c


@pytest.fixture(scope="module")
def client(cluster):
    import distributed

    with distributed.Client(cluster) as c:
        yield c


def dask_workers():
    """This process's live children that are Dask worker processes (spawned by
    multiprocessing; its resource tracker is not one)."""
    out = []
    for p in psutil.Process().children(recursive=True):
        try:
            if p.is_running() and p.status() != psutil.STATUS_ZOMBIE and \
                    any("spawn_main" in a for a in p.cmdline()):
                out.append(p.pid)
        except psutil.NoSuchProcess:
            pass
    return set(out)


def wait_gone(pids, seconds=10.0):
    """The pids among `pids` still alive after waiting up to `seconds` for them to end."""
    deadline = time.monotonic() + seconds
    alive = set(pids)
    while alive and time.monotonic() < deadline:
        alive &= dask_workers()
        if alive:
            time.sleep(0.2)
    return alive


def same(a, b):
    """Rows equal value for value, NaN equal to NaN."""
    if len(a) != len(b):
        return False
    for ra, rb in zip(a, b):
        if ra.keys() != rb.keys():
            return False
        for k in ra:
            x, y = ra[k], rb[k]
            if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
                continue
            if x != y:
                return False
    return True


# ---- functions tasks run (module level, so that workers can import them) ----

def square(x, delay=0.0):
    time.sleep(delay)
    return {"square": x * x}


def fail_on_two(x):
    if x == 2:
        raise ValueError("boom at two")
    return {"twice": 2 * x}


def not_a_dict(x):
    return x


# ---- the grid and the checks before anything runs ----

def test_grid_points_take_the_product_in_order():
    points = vs.grid_points({"a": [1, 2], "b": ["x", "y", "z"]})
    assert points == [{"a": 1, "b": "x"}, {"a": 1, "b": "y"}, {"a": 1, "b": "z"},
                      {"a": 2, "b": "x"}, {"a": 2, "b": "y"}, {"a": 2, "b": "z"}]
    listed = [{"a": 3}, {"a": 1, "b": 2}]
    assert vs.grid_points(listed) == listed


@pytest.mark.parametrize("grid, error, text", [
    ({"a": 1}, TypeError, "expected a list of values"),
    ({"a": "abc"}, TypeError, "expected a list of values"),
    ({"a": []}, ValueError, "no values"),
    ({"not a name": [1]}, TypeError, "identifiers"),
    ([], ValueError, "no parameter sets"),
    ([{"a": 1}, 5], TypeError, r"grid\[1\]"),
    ("a", TypeError, "expected a dict"),
])
def test_a_bad_grid_is_refused(grid, error, text):
    with pytest.raises(error, match=text):
        vs.grid_points(grid)


def test_an_unknown_parameter_is_a_clear_error_before_anything_runs(small_scene):
    before = dask_workers()
    start = time.monotonic()
    run = vs.scene_runner(small_scene, frames=5)
    with pytest.raises(ValueError, match=r"takes no parameter 'youngs_modulus' \(it takes: "
                                         r".*young_modulus"):
        vs.sweep(run, {"youngs_modulus": [1e5, 2e5]})
    with pytest.raises(ValueError, match="takes no parameter 'y'"):
        vs.sweep(square, {"x": [1], "y": [2]})
    with pytest.raises(ValueError, match="required parameter 'x'"):
        vs.sweep(square, [{"delay": 0.0}])
    with pytest.raises(ValueError, match="run_scene takes no parameter 'speed'"):
        vs.scene_runner(small_scene, speed=2)
    with pytest.raises(FileNotFoundError):
        vs.scene_runner(os.path.join(os.path.dirname(small_scene), "missing.json"))
    with pytest.raises(ValueError, match="n_workers applies only"):
        vs.sweep(square, {"x": [1]}, scheduler="serial", n_workers=2)
    # Refused at once: no cluster was started for any of them.
    assert time.monotonic() - start < 2.0
    assert dask_workers() == before


def test_a_sweep_in_a_starting_worker_process_is_refused(monkeypatch):
    # What a spawned worker sees when the main script calls sweep outside its __main__ guard.
    monkeypatch.setattr(multiprocessing.current_process(), "_inheriting", True, raising=False)
    with pytest.raises(RuntimeError, match='if __name__ == "__main__":'):
        vs.sweep(square, {"x": [1]})


# ---- the same numbers on a LocalCluster as in a loop ----

def test_eight_runs_on_a_local_cluster_match_a_plain_loop(small_scene):
    before = dask_workers()
    run = vs.scene_runner(small_scene)
    done = []
    on_cluster = vs.sweep(run, GRID8, n_workers=2, as_frame=False,
                          progress=lambda d, n, i, row: done.append((d, n, i)))
    assert not wait_gone(dask_workers() - before), "the sweep left worker processes behind"
    in_loop = vs.sweep_serial(run, GRID8, as_frame=False)

    assert len(on_cluster) == 8
    assert all(r["error"] is None for r in on_cluster), [r["error"] for r in on_cluster]
    # Rows in the grid's order, with their parameters.
    points = vs.grid_points(GRID8)
    assert [{k: r[k] for k in GRID8} for r in on_cluster] == points
    # The same numbers, timings aside, whichever worker ran which task.
    assert same(vs.without_timings(on_cluster), vs.without_timings(in_loop))
    # Both worker processes took tasks, and none ran in this process.
    workers = {r["worker"] for r in on_cluster}
    assert len(workers) == 2 and all(not w.endswith(f":{os.getpid()}") for w in workers)
    assert {r["worker"] for r in in_loop} == {f"{os.uname().nodename}:{os.getpid()}"}
    # Progress: once a task, counting up to 8, each index once.
    assert [d for d, _, _ in done] == list(range(1, 9))
    assert {n for _, n, _ in done} == {8} and sorted(i for _, _, i in done) == list(range(8))
    # The parameters took effect: each changes what the run did (the stiffness the probe's
    # force, the speeds the cut and the push), and the slab came off in every run.
    assert len({r["cut_set_hash"] for r in on_cluster}) == 8
    assert len({r["peak_probe_force"] for r in on_cluster}) == 8
    soft = [r["peak_probe_force"] for r in on_cluster if r["young_modulus"] == 5e4]
    stiff = [r["peak_probe_force"] for r in on_cluster if r["young_modulus"] == 1e5]
    assert all(s < t for s, t in zip(soft, stiff))
    assert all(r["pieces"] == 2 and r["cut_links"] > 0 and r["fragment_drop"] > 0.005
               for r in on_cluster)


def test_a_local_cluster_listens_on_the_loopback_only():
    listening = set()

    def look(done, total, index, row):
        # While the cluster is up: every socket this process and its children listen on.
        ours = {p.pid for p in psutil.Process().children(recursive=True)} | {os.getpid()}
        try:
            connections = psutil.net_connections(kind="inet")
        except psutil.AccessDenied:
            pytest.skip("listing sockets needs more rights here")
        listening.update((c.laddr.ip, c.pid) for c in connections
                         if c.status == psutil.CONN_LISTEN and c.pid in ours)

    before = dask_workers()
    rows = vs.sweep(square, {"x": [1, 2]}, n_workers=2, progress=look, as_frame=False)
    assert [r["square"] for r in rows] == [1, 4]
    workers = {int(r["worker"].rsplit(":", 1)[1]) for r in rows}
    assert workers & {pid for _, pid in listening}, "no worker's socket was seen"
    assert {ip for ip, _ in listening} == {"127.0.0.1"}
    assert not wait_gone(dask_workers() - before)


def test_a_table_is_a_data_frame_when_pandas_is_there(small_scene, client):
    try:
        import pandas
    except ImportError:
        pandas = None
    table = vs.sweep(vs.scene_runner(small_scene, frames=10),
                     {"young_modulus": [5e4, 1e5]}, scheduler=client)
    rows = vs.rows_of(table)
    assert rows[0]["frames"] == 10 and rows[0]["error"] is None
    assert [r["young_modulus"] for r in rows] == [5e4, 1e5]
    if pandas is None:
        assert isinstance(table, list)
        with pytest.raises(ImportError):
            vs.sweep(square, {"x": [1]}, scheduler="serial", as_frame=True)
        return
    assert isinstance(table, pandas.DataFrame)
    assert list(table.columns[:2]) == ["young_modulus", "frames"]
    assert list(table.columns[-3:]) == ["error", "seconds", "worker"]
    assert isinstance(vs.sweep(square, {"x": [1]}, scheduler="serial", as_frame=False), list)


def test_rows_come_in_grid_order_whatever_order_tasks_finish(client):
    # The first tasks take longest: the last started finish first.
    finished = []
    grid = [{"x": x, "delay": 0.25 * (5 - x)} for x in range(6)]
    rows = vs.sweep(square, grid, scheduler=client, as_frame=False,
                    progress=lambda d, n, i, row: finished.append(i))
    assert [r["x"] for r in rows] == list(range(6))
    assert [r["square"] for r in rows] == [x * x for x in range(6)]
    assert sorted(finished) == list(range(6))
    assert finished != list(range(6)), "the tasks finished in grid order: nothing was tested"


def test_a_scheduler_address_runs_there(cluster):
    rows = vs.sweep(square, {"x": [3, 4]}, scheduler=cluster.scheduler_address,
                    as_frame=False)
    assert [r["square"] for r in rows] == [9, 16]
    assert all(int(r["worker"].rsplit(":", 1)[1]) in dask_workers() for r in rows)


# ---- failures ----

@pytest.mark.parametrize("where", ["serial", "cluster"])
def test_a_failing_task_gives_an_error_row(where, client):
    scheduler = "serial" if where == "serial" else client
    rows = vs.sweep(fail_on_two, {"x": [1, 2, 3]}, scheduler=scheduler, as_frame=False)
    assert [r["x"] for r in rows] == [1, 2, 3]
    assert rows[1]["error"] == "ValueError: boom at two" and "twice" not in rows[1]
    assert [rows[0]["twice"], rows[2]["twice"]] == [2, 6]
    assert rows[0]["error"] is None and rows[2]["error"] is None
    with pytest.raises(ValueError, match="boom at two"):
        vs.sweep(fail_on_two, {"x": [1, 2, 3]}, scheduler=scheduler, raise_errors=True)
    bad = vs.sweep(not_a_dict, {"x": [1]}, scheduler=scheduler, as_frame=False)
    assert bad[0]["error"] == "TypeError: not_a_dict returned int, expected a dict of results"


def test_a_bad_scene_parameter_gives_an_error_row(small_scene, client):
    run = vs.scene_runner(small_scene, frames=5)
    grid = [{"materials": {"default": {"young_modulus": 2e5}}},
            {"materials": {"tumour": {"young_modulus": 2e5}}},
            {"materials": {"default": {"youngs_modulus": 2e5}}},
            {"blade_speed": -1.0},
            {"tool_keys": {5: [(0.0, (0, 0, 0))]}},
            {"materials": {"default": {"max_internal_level": 2}}},
            {"young_modulus": -5.0}]
    rows = vs.sweep(run, grid, scheduler=client, as_frame=False)
    errors = [r["error"] for r in rows]
    assert errors[0] is None and rows[0]["frames"] == 5
    assert "no body of the scene has material 'tumour'" in errors[1]
    assert "unknown key 'youngs_modulus'" in errors[2]
    assert "blade_speed must be a finite number > 0" in errors[3]
    assert "no tool 5" in errors[4]
    assert "max_internal_level: set when the body is built" in errors[5]
    # The library's own check, through Body.set_material.
    assert errors[6].startswith("InputError: ") and "must be in (0, 1e12] Pa, got -5" in errors[6]


def test_sweep_closes_its_cluster_when_a_task_raises():
    before = dask_workers()
    with pytest.raises(ValueError, match="boom at two"):
        vs.sweep(fail_on_two, {"x": [1, 2, 3, 4]}, n_workers=2, raise_errors=True)
    assert not wait_gone(dask_workers() - before), "the sweep left worker processes behind"


# ---- output ----

def test_verbose_prints_a_line_a_task_and_write_csv_writes_the_table(tmp_path, capsys):
    rows = vs.sweep(fail_on_two, {"x": [1, 2]}, scheduler="serial", verbose=True,
                    as_frame=False)
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2
    assert err[0].startswith("[1/2] #0 x=1: ok (")
    assert err[1].startswith("[2/2] #1 x=2: ValueError: boom at two (")
    path = tmp_path / "table.csv"
    vs.write_csv(rows, path)
    with open(path, newline="") as f:
        read = list(csv.DictReader(f))
    assert list(read[0]) == ["x", "twice", "error", "seconds", "worker"]
    assert [(r["x"], r["twice"], r["error"]) for r in read] == [
        ("1", "2", ""), ("2", "", "ValueError: boom at two")]


# ---- run_scene against the command line ----

def cli_summary(scene, frames):
    assert os.access(CLI, os.X_OK), f"the voxcut command line is not built: {CLI}"
    out = subprocess.run([CLI, "run", str(scene), "--frames", str(frames), "--json",
                          "--threads", "1"], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def test_run_scene_is_the_scene_that_voxcut_run_runs(tmp_path):
    """A changed material (set_material before the first frame) and a faster blade
    (Tool.trajectory) give exactly the cut of a scene file holding the same changes."""
    changed = vs.run_scene(BUNNY_EAR, 130, young_modulus=2e6, blade_speed=4.0)
    spec = json.loads(open(BUNNY_EAR).read())
    spec["bodies"][0]["materials"]["default"]["young_modulus"] = 2e6
    keys = spec["tools"][0]["keys"]
    t0 = keys[0]["t"]
    for k in keys:
        k["t"] = t0 + (k["t"] - t0) / 4.0
    scene = tmp_path / "bunny-ear-changed.json"
    scene.write_text(json.dumps(spec))
    cli = cli_summary(scene, 130)
    assert changed["cut_set_hash"] == cli["cut_set_hash"]
    assert changed["cut_links"] == cli["cut_links"] > 0
    assert changed["pieces"] == cli["pieces"] == 2
    assert changed["max_displacement"] == pytest.approx(cli["max_displacement"], rel=1e-12)
    # The same frames unchanged cut less (the blade has not finished): the changes mattered.
    plain = vs.run_scene(BUNNY_EAR, 130)
    assert plain["cut_set_hash"] != changed["cut_set_hash"]
    assert plain["peak_probe_force"] is None  # a blade only: no probe force to report


def test_run_scene_lengthens_the_run_for_a_slower_tool(small_scene):
    # The scene's tools end at 0.26 s and it runs 80 frames (0.32 s); at half speed the
    # blade ends at 0.52 s, 65 frames later.
    slow = vs.run_scene(small_scene, blade_speed=0.5, probe_speed=2.0)
    assert slow["frames"] == 80 + 65
    assert vs.run_scene(small_scene, frames=3)["frames"] == 3
    # A new path for the probe: pressing twice as deep over the same time.
    deeper = vs.run_scene(small_scene, tool_keys={1: voxcut.Keys(
        t=[0.0, 0.2], a=[[0.025, 0.075, 0.0], [0.025, 0.055, 0.0]],
        b=[[0.025, 0.075, 0.0], [0.025, 0.055, 0.0]])})
    base = vs.run_scene(small_scene)
    assert deeper["frames"] == 80
    assert deeper["peak_probe_force"] > 1.5 * base["peak_probe_force"]

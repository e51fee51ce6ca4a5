"""The world API from Python: building, stepping, copies and views, errors, threads, pickling.

Each test can fail: it checks a value, an exception type or the state after a refused call
against a world that never saw it."""

import gc
import pickle
import threading
import time

import numpy as np
import pytest

import voxcut


def small_world(probe=True, **settings):
    """A soft box resting on a floor, held at its base, with a probe above it."""
    world = voxcut.World(**settings)
    body = world.add_body("box:0.06,0.04,0.05", resolution=16, element_level=2,
                          offset=(0.0, 0.02, 0.0),
                          materials={"default": voxcut.Material(young_modulus=2e4)},
                          fixed=[((-1, -1, -1), (1, 0.002, 1))])
    world.add_plane(point=(0, -0.002, 0), normal=(0, 1, 0))
    tool = world.add_probe(0.01, (0.0, 0.05, 0.0)) if probe else None
    return world, body, tool


def press(world, tool, frames, depth=0.012):
    """Moves the probe down into the box's top over `frames` frames."""
    for f in range(frames):
        y = 0.05 - depth * min(1.0, (f + 1) / frames)
        tool.pose = (0.0, y, 0.0)
        world.step()


def test_world_builds_and_steps():
    world, body, tool = small_world()
    assert world.frame == 0
    report = world.step()
    assert isinstance(report, voxcut.FrameReport)
    assert report.frame == 0 and world.frame == 1
    assert set(report.stage_ms) == set(voxcut.frame_stage_names())
    assert report.status in ("ok", "not_converged")
    assert report.solver_solves >= 1  # one body: at least one solve a frame
    info = body.info
    assert info.nodes > 0 and info.surface_triangles > 0 and info.material_names == ["default"]
    nodes = body.nodes()
    assert nodes.positions.shape == (info.nodes, 3) and nodes.masses.shape == (info.nodes,)
    # The box's mass: 6 x 4 x 5 cm of density 1000 kg/m^3, to within the voxelization.
    assert nodes.masses.sum() == pytest.approx(0.06 * 0.04 * 0.05 * 1000.0, rel=0.15)


def test_probe_pushes_and_reports_force():
    world, body, tool = small_world()
    press(world, tool, 30)
    # The box pushes the probe up: the reaction on it points along +y.
    assert tool.force[1] > 0.01
    contacts = world.contacts()
    assert len(contacts) > 0
    assert set(contacts.kind_names()) == {"probe"}  # the held base does not reach the floor
    assert contacts.point.shape == (len(contacts), 3)
    # The forces of the probe's contacts on the body sum to minus the reaction on the probe.
    on_probe = contacts.kind == 1
    np.testing.assert_allclose(-contacts.force[on_probe].sum(axis=0), tool.force,
                               rtol=1e-6, atol=1e-9)


def test_copies_do_not_change_when_the_world_steps():
    world, body, tool = small_world()
    press(world, tool, 5)
    surface = body.surface()
    nodes = body.nodes()
    before = (surface.vertices.copy(), nodes.positions.copy())
    press(world, tool, 10)
    np.testing.assert_array_equal(surface.vertices, before[0])
    np.testing.assert_array_equal(nodes.positions, before[1])
    # ... while the world's surface has moved.
    assert not np.array_equal(body.surface().vertices, before[0])
    assert surface.triangles.dtype == np.int32 and surface.vertices.dtype == np.float64
    assert surface.materials.shape == (len(surface.triangles),)
    assert surface.cut.dtype == bool and not surface.cut.any()


def address(a):
    return a.__array_interface__["data"][0]


def test_views_are_zero_copy_read_only_and_hold_the_world():
    world, body, tool = small_world()
    world.step()
    view = body.surface_view()
    first = view.vertices
    again = view.vertices
    assert address(first) == address(again)  # the world's own memory, not a copy
    assert address(body.surface().vertices) != address(first)
    with pytest.raises(ValueError):
        first[0, 0] = 1.0
    with pytest.raises(ValueError):
        view.triangles[0, 0] = 0
    live = view.triangles[:, 0] >= 0
    np.testing.assert_array_equal(np.sort(view.vertices[np.unique(view.triangles[live])], axis=0),
                                  np.sort(body.surface().vertices, axis=0))
    # step() and restore() refuse while a view (or any of its arrays) is alive.
    snap = world.snapshot()
    with pytest.raises(voxcut.BusyError):
        world.step()
    with pytest.raises(voxcut.BusyError):
        world.restore(snap)
    assert world.frame == 1
    del view, again
    gc.collect()
    with pytest.raises(voxcut.BusyError):  # `first` still holds the view
        world.step()
    del first
    gc.collect()
    world.step()
    assert world.frame == 2


def test_a_view_keeps_its_world_alive():
    world, body, tool = small_world()
    world.step()
    vertices = body.surface_view().vertices
    expected = np.array(vertices)
    del world, body, tool
    gc.collect()
    # The world is gone from Python but its memory lives as long as the array.
    np.testing.assert_array_equal(vertices, expected)
    assert vertices.base is not None


def same_state(a, b):
    """Two worlds' bodies are at the same positions and velocities, bit for bit."""
    for ba, bb in zip(a.bodies(), b.bodies()):
        na, nb = ba.nodes(), bb.nodes()
        np.testing.assert_array_equal(na.positions, nb.positions)
        np.testing.assert_array_equal(na.velocities, nb.velocities)
    assert a.cut_set_hash() == b.cut_set_hash()


def test_nan_pose_raises_and_changes_nothing():
    plain, _, plain_tool = small_world()
    hit, _, hit_tool = small_world()
    press(plain, plain_tool, 5)
    press(hit, hit_tool, 5)
    with pytest.raises(voxcut.InputError) as e:
        hit_tool.pose = (0.0, float("nan"), 0.0)
    assert isinstance(e.value, ValueError)
    with pytest.raises(voxcut.InputError):
        hit_tool.pose = ((0, 0, 0), (0, float("inf"), 0))
    with pytest.raises(voxcut.InputError):
        hit.add_probe(-0.01, (0, 0.1, 0))
    press(plain, plain_tool, 3)
    press(hit, hit_tool, 3)
    same_state(plain, hit)


def test_stale_handles_raise_key_error_and_change_nothing():
    plain, _, plain_tool = small_world()
    hit, hit_body, hit_tool = small_world()
    extra = hit.add_blade(((-1, 1, 0), (1, 1, 0)))
    box = hit.add_box((1, 1, 1), (2, 2, 2))
    hit.remove(extra)
    hit.remove(box)
    assert not extra.alive and not box.alive
    with pytest.raises(voxcut.StaleHandleError) as e:
        extra.pose = (0, 0, 0)
    assert isinstance(e.value, KeyError)
    with pytest.raises(KeyError):
        _ = extra.force
    with pytest.raises(KeyError):
        hit.remove(extra)
    with pytest.raises(KeyError):
        _ = box.kind
    # A handle of another world is refused, though its slot names a body here.
    with pytest.raises(KeyError):
        plain.remove(hit_body)
    assert len(plain.bodies()) == 1
    press(plain, plain_tool, 4)
    press(hit, hit_tool, 4)
    same_state(plain, hit)


def test_removed_body_is_refused():
    world, body, tool = small_world()
    world.remove(body)
    assert world.bodies() == []
    with pytest.raises(voxcut.StaleHandleError):
        body.nodes()
    with pytest.raises(voxcut.StaleHandleError):
        body.surface_view()
    world.step()  # a world with only a tool and a plane still steps


def test_wrong_arrays_raise_the_right_exceptions():
    plain, _, plain_tool = small_world()
    world, body, tool = small_world()
    sphere = sphere_labels(8)
    with pytest.raises(TypeError):
        world.add_body_from_labels(sphere.astype(np.float32), 0.002)
    with pytest.raises(TypeError):
        world.add_body_from_labels(sphere.astype(np.int32), 0.002)
    with pytest.raises(TypeError):
        world.add_body_from_labels(sphere.tolist(), 0.002)
    with pytest.raises(voxcut.InputError):
        world.add_body_from_labels(sphere[:, :, 0], 0.002)
    with pytest.raises(voxcut.InputError):
        world.add_body_from_labels(sphere, -0.002)
    with pytest.raises(voxcut.InputError):
        world.add_body_from_labels(sphere, 0.002, origin=(0, 0))
    with pytest.raises(voxcut.InputError):
        tool.pose = np.zeros((3, 3))
    with pytest.raises(voxcut.InputError):
        tool.pose = "up"
    with pytest.raises(voxcut.InputError):
        world.add_body("box:0.1,0.1,0.1", resolution=12, materials={"default": {"young": 1}})
    with pytest.raises(voxcut.InputError):
        voxcut.World(time_step=-1.0)
    with pytest.raises(voxcut.InputError):
        voxcut.World(unknown_setting=1)
    with pytest.raises(voxcut.InputError, match="comes from the scene file"):
        voxcut.World.from_scene(voxcut_scene("bunny-ear.json"), time_step=0.001)
    assert len(world.bodies()) == 1
    press(plain, plain_tool, 4)
    press(world, tool, 4)
    same_state(plain, world)


def sphere_labels(n, label=1, inner=0):
    """An n^3 uint8 array holding a ball of `label` (and a smaller core of `inner`)."""
    c = (n - 1) / 2.0
    i, j, k = np.mgrid[0:n, 0:n, 0:n]
    r = np.sqrt((i - c) ** 2 + (j - c) ** 2 + (k - c) ** 2)
    a = np.where(r < 0.4 * n, label, 0).astype(np.uint8)
    if inner:
        a[r < 0.2 * n] = inner
    return a


def test_body_from_a_label_array():
    world = voxcut.World(gravity=(0, 0, 0))
    n, h = 24, 0.002
    labels = sphere_labels(n, label=3, inner=7)
    body = world.add_body_from_labels(labels, h, origin=(0.1, 0.0, 0.0),
                                      names={3: "shell", 7: "core"}, resolution=30)
    info = body.info
    assert info.material_names == ["shell", "core"]
    voxels = body.voxels()
    # The ball's volume: (4/3) pi (0.4 n h)^3, to within a few per cent at this resolution.
    volume = len(voxels.rest_positions) * info.voxel_size ** 3
    assert volume == pytest.approx(4.0 / 3.0 * np.pi * (0.4 * n * h) ** 3, rel=0.08)
    centre = voxels.rest_positions.mean(axis=0)
    np.testing.assert_allclose(centre, [0.1 + (n - 1) / 2 * h, (n - 1) / 2 * h, (n - 1) / 2 * h],
                               atol=h / 2)
    # The same array as uint16, C or Fortran order, gives the same body.
    other = voxcut.World(gravity=(0, 0, 0))
    same = other.add_body_from_labels(np.ascontiguousarray(labels.astype(np.uint16)), h,
                                      origin=(0.1, 0.0, 0.0), names={3: "shell", 7: "core"},
                                      resolution=30)
    np.testing.assert_array_equal(same.voxels().rest_positions, voxels.rest_positions)


def test_step_releases_the_gil():
    world = voxcut.World.from_scene(voxcut_scene("bunny-poke.json"), threaded=False)
    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.0005)

    world.step()  # the first frame factorises; the timed ones below are ordinary
    thread = threading.Thread(target=ticker)
    thread.start()
    time.sleep(0.01)
    start = time.perf_counter()
    world.step(15)
    end = time.perf_counter()
    stop.set()
    thread.join()
    during = [t for t in ticks if start < t < end]
    # With the GIL held through the step, the ticker could not run at all while it ran.
    assert end - start > 0.05
    assert len(during) >= 10, f"{len(during)} ticks in a {end - start:.3f} s step"


def test_a_second_thread_cannot_step_or_edit_the_same_world():
    world = voxcut.World.from_scene(voxcut_scene("bunny-poke.json"))
    errors = []
    started = threading.Event()

    def other():
        started.wait()
        time.sleep(0.02)
        for call in (lambda: world.step(), lambda: world.bodies(), lambda: world.snapshot()):
            try:
                call()
                errors.append(None)
            except voxcut.BusyError as e:
                errors.append(e)

    thread = threading.Thread(target=other)
    thread.start()
    started.set()
    world.step(20)
    thread.join()
    assert len(errors) == 3 and all(isinstance(e, voxcut.BusyError) for e in errors), errors
    assert world.frame == 20


def test_haptic_from_another_thread_while_stepping():
    # bunny-poke's probe presses into the bunny; its frames are long enough (milliseconds)
    # for a haptic loop to run many times within each.
    world = voxcut.World.from_scene(voxcut_scene("bunny-poke.json"))
    tool = world.tools()[0]
    world.step(90)
    pose = tool.pose
    answers = []
    stop = threading.Event()

    def haptic_loop():
        while not stop.is_set():
            answers.append((time.perf_counter(), tool.haptic(pose)))
            time.sleep(0.0002)

    thread = threading.Thread(target=haptic_loop)
    thread.start()
    time.sleep(0.005)
    start = time.perf_counter()
    world.step(10)
    end = time.perf_counter()
    stop.set()
    thread.join()
    during = [a for t, a in answers if start < t < end]
    assert len(during) > 5, f"{len(during)} haptic answers during {end - start:.3f} s of frames"
    assert all(a.status == "ok" for a in during)
    assert all(np.isfinite(a.force).all() for a in during)
    assert max(np.linalg.norm(a.force) for a in during) > 0.0  # it presses into the bunny
    # A NaN position answers zero and says why; a blade's handle is not a probe.
    nan = tool.haptic((0.0, float("nan"), 0.0))
    assert nan.status == "non_finite_pose" and not nan.force.any()
    assert tool.haptic("nonsense").status == "non_finite_pose"
    blade = world.add_blade(((-1, 1, 0), (1, 1, 0)))
    assert blade.haptic((0, 0, 0)).status == "not_a_probe"


def test_a_world_cannot_be_pickled():
    world, body, tool = small_world()
    with pytest.raises(TypeError, match="cannot be pickled"):
        pickle.dumps(world)


def test_snapshot_restore_reproduces_the_run():
    world, body, tool = small_world()
    press(world, tool, 5)
    snap = world.snapshot()
    assert snap.frame == 5
    press(world, tool, 8)
    first = (body.nodes().positions, tool.force, world.cut_set_hash())
    world.restore(snap)
    assert world.frame == 5
    press(world, tool, 8)
    np.testing.assert_array_equal(body.nodes().positions, first[0])
    np.testing.assert_array_equal(tool.force, first[1])
    assert world.cut_set_hash() == first[2]


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


def test_one_thousand_episodes_do_not_grow_memory():
    world, body, tool = small_world()
    world.step()
    snap = world.snapshot()
    rss = {}
    for episode in range(1, 1001):
        world.restore(snap)
        for f in range(2):
            tool.pose = (0.0, 0.045 - 0.004 * f, 0.0)
            world.step()
        if episode in (100, 1000):
            gc.collect()
            rss[episode] = rss_bytes()
    assert rss[1000] <= rss[100] * 1.05, rss


def test_two_hundred_worlds_do_not_grow_memory():
    rss = {}
    for i in range(1, 201):
        world, body, tool = small_world()
        world.step()
        del world, body, tool
        if i in (20, 200):
            gc.collect()
            rss[i] = rss_bytes()
    assert rss[200] <= rss[20] * 1.05, rss


def voxcut_scene(name):
    from conftest import SOURCE_DIR
    return str(SOURCE_DIR / "scenes" / name)

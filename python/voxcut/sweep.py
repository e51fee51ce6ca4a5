"""Parameter sweeps: many independent voxcut runs on Dask distributed, gathered into a table.

    from voxcut.sweep import sweep, scene_runner
    run = scene_runner("scenes/bunny-ear.json")
    table = sweep(run, {"young_modulus": [5e5, 1e6, 2e6], "blade_speed": [1, 2]})

sweep() calls ``run(**params)`` once per point of the grid, each call a task that builds its
own world, on a Dask LocalCluster it starts on this machine (and always closes), on the Dask
scheduler at an address (``scheduler="tcp://host:8786"``), or in a plain loop in this process
(``scheduler="serial"``). A voxcut run is deterministic, so the table holds the same numbers
wherever and in whatever order its tasks ran; only the timing columns differ (their names end
in ``_ms`` or ``seconds``, and ``worker``: without_timings drops them). Rows come in the
grid's order. run_scene is the ready-made run of a scene file with its materials, tool speeds
and tool paths changed; scene_runner binds its fixed arguments. docs/python-sweeps.md is the
guide.

Dask is imported only when a sweep runs on it, pandas only when a table is made a DataFrame.
"""

from __future__ import annotations

import csv
import functools
import inspect
import itertools
import json
import logging
import math
import multiprocessing
import os
import socket
import sys
import time
import uuid
import warnings
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

__all__ = [
    "sweep", "sweep_serial", "grid_points", "run_scene", "scene_runner", "rows_of",
    "is_timing", "without_timings", "write_csv",
]

Row = Dict[str, Any]
Grid = Union[Mapping[str, Sequence[Any]], Sequence[Mapping[str, Any]]]
# progress(done, total, index, row): after each task, in the order they finish; `index` is
# the task's place in the grid.
Progress = Callable[[int, int, int, Row], None]


# ---- the grid ----

def grid_points(grid: Grid) -> List[Dict[str, Any]]:
    """The parameter sets of `grid`, in order. A dict of name -> list of values gives their
    Cartesian product, the first name varying slowest (itertools.product's order); a list of
    dicts is taken as it is. Raises TypeError for another shape, ValueError for an empty list
    of values or no point at all."""
    if isinstance(grid, Mapping):
        names = list(grid)
        values = []
        for name in names:
            _check_name(name)
            v = grid[name]
            if isinstance(v, (str, bytes, Mapping)) or not hasattr(v, "__iter__"):
                raise TypeError(f"grid[{name!r}]: expected a list of values, got "
                                f"{type(v).__name__} (give [value] for one value)")
            v = list(v)
            if not v:
                raise ValueError(f"grid[{name!r}]: no values (the product would be empty)")
            values.append(v)
        points = [dict(zip(names, p)) for p in itertools.product(*values)]
    elif isinstance(grid, Sequence) and not isinstance(grid, (str, bytes)):
        points = []
        for i, p in enumerate(grid):
            if not isinstance(p, Mapping):
                raise TypeError(f"grid[{i}]: expected a dict of parameters, got "
                                f"{type(p).__name__}")
            for name in p:
                _check_name(name)
            points.append(dict(p))
    else:
        raise TypeError("grid: expected a dict of name -> list of values, or a list of dicts, "
                        f"got {type(grid).__name__}")
    if not points:
        raise ValueError("grid: no parameter sets")
    return points


def _check_name(name: Any) -> None:
    if not isinstance(name, str) or not name.isidentifier():
        raise TypeError(f"grid: parameter names must be identifiers (keywords of run), got "
                        f"{name!r}")


def _callable_name(run: Callable[..., Any]) -> str:
    if isinstance(run, functools.partial):
        return _callable_name(run.func)
    return getattr(run, "__qualname__", None) or type(run).__name__


def _check_parameters(run: Callable[..., Any], points: List[Dict[str, Any]]) -> None:
    """Refuses, before any task starts, a grid whose names `run` does not take or that leaves
    out one of its required parameters: a misspelt name would otherwise fail every task."""
    try:
        signature = inspect.signature(run)
    except (TypeError, ValueError):
        return  # no signature to check against (a builtin): the tasks will tell
    params = signature.parameters.values()
    if any(p.kind == inspect.Parameter.VAR_KEYWORD for p in params):
        return
    known = [p.name for p in params
             if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                           inspect.Parameter.KEYWORD_ONLY)]
    required = [p.name for p in params
                if p.default is inspect.Parameter.empty
                and p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                               inspect.Parameter.KEYWORD_ONLY)]
    given = {name for p in points for name in p}
    unknown = sorted(given - set(known))
    if unknown:
        raise ValueError(
            f"sweep: {_callable_name(run)} takes no parameter "
            f"{', '.join(repr(n) for n in unknown)} (it takes: {', '.join(known) or 'none'})")
    for i, p in enumerate(points):
        missing = [n for n in required if n not in p]
        if missing:
            raise ValueError(
                f"sweep: grid point {i} gives no value for {_callable_name(run)}'s required "
                f"parameter {', '.join(repr(n) for n in missing)}")


# ---- one task ----

def _run_task(run: Callable[..., Mapping[str, Any]], params: Dict[str, Any],
              raise_errors: bool) -> Dict[str, Any]:
    """Runs one point where the task landed: the run's numbers, or its error as a message
    (re-raised instead with raise_errors), with the wall time and where it ran."""
    start = time.perf_counter()
    error = None
    result: Dict[str, Any] = {}
    try:
        out = run(**params)
        if not isinstance(out, Mapping):
            raise TypeError(f"{_callable_name(run)} returned {type(out).__name__}, expected a "
                            "dict of results")
        result = dict(out)
    except Exception as e:  # noqa: BLE001 -- a task's failure becomes its row's error
        if raise_errors:
            raise
        error = _error_text(e)
    return {"result": result, "error": error, "seconds": time.perf_counter() - start,
            "worker": f"{socket.gethostname()}:{os.getpid()}"}


def _error_text(e: BaseException) -> str:
    return f"{type(e).__name__}: {e}"


def _row(params: Dict[str, Any], done: Dict[str, Any]) -> Row:
    row = dict(params)
    row.update(done["result"])
    row["error"] = done["error"]
    row["seconds"] = done["seconds"]
    row["worker"] = done["worker"]
    return row


def _failed_row(params: Dict[str, Any], e: BaseException) -> Row:
    # A task that failed outside the run: its worker died (KilledWorker), or it could not be
    # unpickled there (a run function the workers cannot import).
    return _row(params, {"result": {}, "error": _error_text(e), "seconds": math.nan,
                         "worker": None})


# ---- the sweep ----

def sweep(run: Callable[..., Mapping[str, Any]], grid: Grid, *,
          scheduler: Any = None, n_workers: Optional[int] = None,
          raise_errors: bool = False, progress: Optional[Progress] = None,
          verbose: bool = False, as_frame: Optional[bool] = None,
          retries: int = 0, cluster_options: Optional[Mapping[str, Any]] = None) -> Any:
    """Runs ``run(**params)`` for every parameter set of `grid` as independent tasks and
    returns their results as a table, one row per set in the grid's order.

    run: a function of keyword parameters returning a dict of numbers, picklable (a
        module-level function, a functools.partial of one, or scene_runner(...)); each call
        builds its own world. A run should use one thread (World(threaded=False), as run_scene
        does): the tasks are the parallelism.
    grid: a dict of name -> list of values (their Cartesian product, the first name varying
        slowest) or a list of dicts (grid_points). Every name must be a parameter of `run`
        and every required parameter of `run` must be given (ValueError before anything runs).
    scheduler: None starts a LocalCluster on this machine (`n_workers` worker processes, one
        thread each, on 127.0.0.1, no dashboard) and closes it when done, also on an error or
        an interrupt; "serial" runs the tasks one after another in this process, without
        Dask; an address such as "tcp://host:8786" connects to that Dask scheduler; a
        distributed.Client or a cluster object is used as it is and left open.
    n_workers: LocalCluster workers (default: os.cpu_count(), at most one per task); only
        with scheduler=None.
    raise_errors: False: a task that raises gives a row with its `error` ("Type: message")
        and the sweep goes on; True: the first error cancels the other tasks and is raised.
    progress: called as progress(done, total, index, row) in this process after each task,
        in the order they finish; `index` is the task's place in the grid.
    verbose: prints one line a task to stderr as it finishes.
    as_frame: True: a pandas DataFrame; False: a list of dicts; None: a DataFrame when pandas
        can be imported, else a list of dicts (write_csv writes either).
    retries: times Dask may rerun a task whose worker died (runs are deterministic, so a
        rerun gives the same row).
    cluster_options: more keywords for the LocalCluster (memory_limit, ...).

    Each row holds the task's parameters, the run's results, `error` (None when it ran),
    `seconds` (the task's wall time) and `worker` (host:pid of the process that ran it).

    A script calls sweep under ``if __name__ == "__main__":``: the LocalCluster's workers are
    spawned processes, which import the main script (a sweep there raises RuntimeError).
    """
    if not callable(run):
        raise TypeError(f"sweep: run must be callable, got {type(run).__name__}")
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        # A Dask worker process starts by importing the main script: a sweep at its top level
        # would start a cluster in every worker, which never ends.
        raise RuntimeError("sweep: called while a worker process imports the main script; put "
                           "the sweep under `if __name__ == \"__main__\":`")
    points = grid_points(grid)
    _check_parameters(run, points)
    if n_workers is not None:
        if scheduler is not None:
            raise ValueError("sweep: n_workers applies only to the LocalCluster sweep starts "
                             "(scheduler=None)")
        if not isinstance(n_workers, int) or n_workers < 1:
            raise ValueError(f"sweep: n_workers must be a positive integer, got {n_workers!r}")
    report = _Reporter(len(points), progress, verbose)
    if isinstance(scheduler, str) and scheduler == "serial":
        rows = _sweep_serial(run, points, raise_errors, report)
    else:
        rows = _sweep_dask(run, points, scheduler, n_workers, raise_errors, report, retries,
                           dict(cluster_options or {}))
    return _table(rows, as_frame)


def sweep_serial(run: Callable[..., Mapping[str, Any]], grid: Grid, **options: Any) -> Any:
    """sweep(run, grid, scheduler="serial", ...): the same tasks in a plain loop, no Dask."""
    return sweep(run, grid, scheduler="serial", **options)


class _Reporter:
    """Counts finished tasks and tells the progress callback and, when verbose, stderr."""

    def __init__(self, total: int, progress: Optional[Progress], verbose: bool) -> None:
        self.total = total
        self.done = 0
        self.progress = progress
        self.verbose = verbose

    def __call__(self, index: int, params: Dict[str, Any], row: Row) -> None:
        self.done += 1
        if self.verbose:
            what = "ok" if row["error"] is None else row["error"]
            where = f", {row['worker']}" if row.get("worker") else ""
            settings = " ".join(f"{k}={_short(v)}" for k, v in params.items())
            print(f"[{self.done}/{self.total}] #{index} {settings}: {what} "
                  f"({row['seconds']:.2f} s{where})", file=sys.stderr, flush=True)
        if self.progress is not None:
            self.progress(self.done, self.total, index, row)


def _short(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def _sweep_serial(run, points, raise_errors, report) -> List[Row]:
    rows = []
    for i, params in enumerate(points):
        row = _row(params, _run_task(run, params, raise_errors))
        rows.append(row)
        report(i, params, row)
    return rows


def _sweep_dask(run, points, scheduler, n_workers, raise_errors, report, retries,
                cluster_options) -> List[Row]:
    try:
        import distributed
    except ImportError as e:  # pragma: no cover -- Debian's python3-distributed is a dependency
        raise ImportError("voxcut.sweep needs Dask distributed (python3-distributed, or pip "
                          "install distributed); scheduler='serial' runs without it") from e
    if scheduler is None:
        options = {
            "n_workers": n_workers or max(1, min(os.cpu_count() or 1, len(points))),
            "threads_per_worker": 1,
            "processes": True,
            "host": "127.0.0.1",         # nothing listens beyond this machine
            "dashboard_address": None,  # no dashboard
            # The scheduler and each worker serve a few plain HTTP routes (health, metrics)
            # even without a dashboard: the scheduler's on port 8787 and the workers' on every
            # interface unless told, so both are told a free port on the loopback. (Given an
            # address, a worker also serves its dashboard there when bokeh is installed.)
            "scheduler_kwargs": {"dashboard_address": "127.0.0.1:0"},
            "worker_dashboard_address": "127.0.0.1:0",
            "silence_logs": logging.ERROR,
        }
        options["scheduler_kwargs"].update(cluster_options.pop("scheduler_kwargs", None) or {})
        options.update(cluster_options)
        with warnings.catch_warnings():
            # Debian's tornado 6.2 under distributed 2022.12 warns of its own deprecated call.
            warnings.filterwarnings("ignore", "make_current is deprecated", DeprecationWarning)
            cluster = distributed.LocalCluster(**options)
        # The context managers close the client, then the cluster and its worker processes,
        # however the sweep ends (an error, raise_errors, Ctrl-C).
        with cluster, distributed.Client(cluster) as client:
            return _gather(client, run, points, raise_errors, report, retries)
    if cluster_options:
        raise ValueError("sweep: cluster_options applies only to the LocalCluster sweep starts "
                         "(scheduler=None)")
    if isinstance(scheduler, distributed.Client):
        return _gather(scheduler, run, points, raise_errors, report, retries)
    if isinstance(scheduler, str) or hasattr(scheduler, "scheduler_address"):
        with distributed.Client(scheduler) as client:
            return _gather(client, run, points, raise_errors, report, retries)
    raise TypeError("sweep: scheduler must be None, 'serial', a scheduler address, a "
                    f"distributed.Client or a cluster, got {type(scheduler).__name__}")


def _gather(client, run, points, raise_errors, report, retries) -> List[Row]:
    import distributed

    tag = uuid.uuid4().hex[:12]
    futures = [client.submit(_run_task, run, params, raise_errors, key=f"voxcut-sweep-{tag}-{i}",
                             pure=False, retries=retries)
               for i, params in enumerate(points)]
    index = {f.key: i for i, f in enumerate(futures)}
    rows: List[Optional[Row]] = [None] * len(points)
    try:
        for future in distributed.as_completed(futures):
            i = index[future.key]
            try:
                row = _row(points[i], future.result())
            except Exception as e:  # noqa: BLE001 -- the task failed outside the run
                if raise_errors:
                    raise
                row = _failed_row(points[i], e)
            rows[i] = row
            report(i, points[i], row)
    finally:
        # On an error or an interrupt, the tasks still queued or running on a shared
        # scheduler are dropped rather than left to run for nobody.
        pending = [f for f in futures if not f.done()]
        if pending:
            client.cancel(pending)
    return rows  # type: ignore[return-value]


# ---- tables ----

def _columns(rows: Sequence[Row]) -> List[str]:
    seen: Dict[str, None] = {}
    for row in rows:
        for k in row:
            seen.setdefault(k, None)
    tail = [k for k in ("error", "seconds", "worker") if k in seen]
    return [k for k in seen if k not in tail] + tail


def _table(rows: List[Row], as_frame: Optional[bool]) -> Any:
    if as_frame is False:
        return rows
    try:
        import pandas
    except ImportError:
        if as_frame:
            raise
        return rows
    return pandas.DataFrame(rows, columns=_columns(rows))


def rows_of(table: Any) -> List[Row]:
    """The table as a list of dicts (a DataFrame's records, or the list itself)."""
    if hasattr(table, "to_dict"):
        return table.to_dict("records")
    return list(table)


def is_timing(column: str) -> bool:
    """Whether a column says how long or where a task ran rather than what it computed."""
    return column in ("seconds", "worker") or column.endswith(("_ms", "_seconds"))


def without_timings(table: Any) -> List[Row]:
    """The rows without the columns that vary from run to run (is_timing): what must be equal
    between two sweeps of the same grid, wherever they ran."""
    return [{k: v for k, v in row.items() if not is_timing(k)} for row in rows_of(table)]


def write_csv(table: Any, path: Union[str, "os.PathLike[str]"]) -> None:
    """Writes the table (a DataFrame or a list of dicts) as CSV with a header row."""
    rows = rows_of(table)
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=_columns(rows), restval="")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: ("" if v is None else v) for k, v in row.items()})


# ---- the ready-made run of a scene ----

# Material keys of a scene file (docs/scenes.md) as voxcut.Material fields.
_SCENE_MATERIAL_KEYS = ("young_modulus", "poisson_ratio", "density", "max_internal_level",
                        "max_boundary_level")
# Set when a body is built (its voxel octree), so an edit afterwards would not take effect.
_BUILD_TIME_KEYS = ("max_internal_level", "max_boundary_level")


def scene_runner(scene: Union[str, "os.PathLike[str]"], **fixed: Any) -> Callable[..., Row]:
    """run_scene with the scene (made an absolute path) and the keywords in `fixed` bound: the
    `run` of a sweep over the remaining keywords. A picklable functools.partial; the scene file
    must be here (FileNotFoundError) and at the same path on every worker. An unknown keyword
    is a ValueError."""
    path = os.path.abspath(os.fspath(scene))
    if not os.path.isfile(path):
        raise FileNotFoundError(f"scene_runner: no scene file {path}")
    unknown = sorted(set(fixed) - set(_RUN_SCENE_PARAMETERS))
    if unknown:
        raise ValueError(f"scene_runner: run_scene takes no parameter "
                         f"{', '.join(repr(n) for n in unknown)} (it takes: "
                         f"{', '.join(_RUN_SCENE_PARAMETERS)})")
    return functools.partial(run_scene, path, **fixed)


def run_scene(scene: Union[str, "os.PathLike[str]"], frames: Optional[int] = None, *,
              young_modulus: Optional[float] = None, poisson_ratio: Optional[float] = None,
              density: Optional[float] = None,
              materials: Optional[Mapping[str, Any]] = None,
              blade_speed: float = 1.0, probe_speed: float = 1.0,
              tool_keys: Optional[Mapping[int, Any]] = None,
              settings: Optional[Mapping[str, Any]] = None,
              threads: int = 1) -> Row:
    """Runs the scene file `scene` with some of its parameters changed and returns what the run
    did, as numbers.

    frames: frames to run; default the scene's "frames" (else 100), lengthened by as many
        frames as the changes below moved the tools' last key later, so that the run goes on
        as long after the tools stop as the scene's did.
    young_modulus, poisson_ratio, density: set on every material of every body.
    materials: material name -> a dict of voxcut.Material fields, merged over the scene's
        values of that material in every body that has it (a voxcut.Material replaces them);
        young_modulus, poisson_ratio and density apply on top. max_internal_level and
        max_boundary_level are fixed when a body is built: a different value is an error
        (change the scene instead).
    blade_speed, probe_speed: each blade's (probe's) path is played this many times faster:
        a key at time t moves to t0 + (t - t0) / speed, t0 the tool's first key.
    tool_keys: tool index (scene order) -> the tool's new path: a voxcut.Keys or a list of
        (t, pose) or (t, pose, jump) (Tool.trajectory's forms); the speeds apply to it too.
    settings: World settings keywords the scene does not hold (use_octree,
        min_fragment_voxels, ...).
    threads: 1 runs the world in this thread (World(threaded=False)), as tasks of a sweep
        should; n > 1 limits the process's voxcut threads to n (voxcut.set_threads), 0 uses
        every core.

    The materials are set (Body.set_material) and the paths (Tool.trajectory) before the first
    frame. Returns: frames; cut_links, cut_set_hash (16 hex digits, as `voxcut run --json`),
    pieces (summed over bodies), peak_cut_links (most links one frame cut) and cut_frames
    (frames that cut); peak_probe_force and final_probe_force (the largest magnitude over the
    frames and the last frame's, over the probes, N; None without a probe: blades feel no
    force); max_displacement (m); fragment_voxels and fragment_drop (the voxels outside each
    body's largest piece, and how far they moved along gravity on average, m; 0 when nothing
    came off); converged (every frame's solve), unconverged_frames, solver_iterations_mean,
    max_penetration (m); and timings: build_seconds, mean_frame_ms, median_frame_ms,
    median_cut_frame_ms (over the frames that cut; None when none did), p95_frame_ms,
    max_frame_ms.
    """
    from . import World, set_threads  # the package imports this module lazily

    path = os.fspath(scene)
    with open(path, encoding="utf-8") as f:
        spec = json.load(f)
    for name, speed in (("blade_speed", blade_speed), ("probe_speed", probe_speed)):
        if not isinstance(speed, (int, float, np.number)) or not (math.isfinite(speed)
                                                                   and speed > 0):
            raise ValueError(f"run_scene: {name} must be a finite number > 0, got {speed!r}")
    if not isinstance(threads, (int, np.integer)) or threads < 0:
        raise ValueError(f"run_scene: threads must be an integer >= 0, got {threads!r}")

    time_step = float(spec.get("time_step", 0.004))
    scene_tools = spec.get("tools", [])
    paths = [_scene_tool_keys(path, t) for t in scene_tools]
    new_paths = _changed_paths(scene_tools, paths, blade_speed, probe_speed, tool_keys)
    if frames is None:
        frames = int(spec.get("frames", 100))
        old_end = max((k[-1][0] for k in paths), default=0.0)
        new_end = max((k[-1][0] for k in (new_paths[i] if i in new_paths else p
                                           for i, p in enumerate(paths))), default=0.0)
        if new_end > old_end:
            frames += math.ceil((new_end - old_end) / time_step - 1e-9)
    if not isinstance(frames, (int, np.integer)) or frames < 1:
        raise ValueError(f"run_scene: frames must be an integer >= 1, got {frames!r}")

    world_settings = dict(settings or {})
    if threads == 1:
        world_settings.setdefault("threaded", False)
    else:
        set_threads(int(threads) if threads > 1 else 0)
    start = time.perf_counter()
    world = World.from_scene(path, **world_settings)
    _set_materials(world, spec, materials,
                   {k: v for k, v in (("young_modulus", young_modulus),
                                      ("poisson_ratio", poisson_ratio),
                                      ("density", density)) if v is not None})
    tools = world.tools()
    for i, keys in new_paths.items():
        tools[i].trajectory = keys
    build_seconds = time.perf_counter() - start

    probes = [i for i, t in enumerate(tools) if t.kind == "probe"]
    frame_ms = np.empty(frames)
    cut_per_frame = np.empty(frames, dtype=np.int64)
    probe_force = np.zeros(frames)
    unconverged = 0
    iterations = 0
    penetration = 0.0
    for f in range(frames):
        r = world.step()
        frame_ms[f] = r.total_ms
        cut_per_frame[f] = r.cut_links
        if probes:
            probe_force[f] = np.linalg.norm(r.tool_forces[probes], axis=1).max()
        unconverged += not r.converged
        iterations += r.solver_iterations
        penetration = max(penetration, r.max_penetration)

    cutting = cut_per_frame > 0
    bodies = world.bodies()
    fragment_voxels, fragment_drop = _fragments(world, bodies)
    return {
        "frames": frames,
        "cut_links": int(sum(b.info.cut_links for b in bodies)),
        "cut_set_hash": f"{world.cut_set_hash():016x}",
        "pieces": int(sum(b.pieces() for b in bodies)),
        "peak_cut_links": int(cut_per_frame.max()),
        "cut_frames": int(np.count_nonzero(cut_per_frame)),
        "peak_probe_force": float(probe_force.max()) if probes else None,
        "final_probe_force": float(probe_force[-1]) if probes else None,
        "max_displacement": float(world.max_displacement()),
        "fragment_voxels": fragment_voxels,
        "fragment_drop": fragment_drop,
        "converged": unconverged == 0,
        "unconverged_frames": unconverged,
        "solver_iterations_mean": iterations / frames,
        "max_penetration": penetration,
        "build_seconds": build_seconds,
        "mean_frame_ms": float(frame_ms.mean()),
        "median_frame_ms": float(np.median(frame_ms)),
        "median_cut_frame_ms": float(np.median(frame_ms[cutting])) if cutting.any() else None,
        "p95_frame_ms": float(np.percentile(frame_ms, 95)),
        "max_frame_ms": float(frame_ms.max()),
    }


_RUN_SCENE_PARAMETERS = tuple(inspect.signature(run_scene).parameters)[1:]


def _scene_tool_keys(scene_path: str, tool: Mapping[str, Any]) -> List[tuple]:
    """A scene tool's keys as Tool.trajectory takes them: (t, pose, jump), pose a point for a
    sphere probe and two ends otherwise; a tool that plays a recording has its keys."""
    if "keys" in tool:
        keys = tool["keys"]
    else:
        folder = os.path.dirname(os.path.abspath(scene_path))
        with open(os.path.join(folder, tool["trajectory"]), encoding="utf-8") as f:
            keys = json.load(f)["tools"][int(tool.get("trajectory_tool", 0))]["keys"]
    return [(float(k["t"]), k["p"] if "p" in k else (k["a"], k["b"]), bool(k.get("jump", False)))
            for k in keys]


def _changed_paths(scene_tools, paths, blade_speed, probe_speed, tool_keys) -> Dict[int, list]:
    """The tools whose paths the parameters change, each with its new keys."""
    out: Dict[int, list] = {}
    for i, keys in (tool_keys or {}).items():
        if not isinstance(i, (int, np.integer)) or not 0 <= i < len(paths):
            raise ValueError(f"run_scene: tool_keys: no tool {i!r} in the scene (it has "
                             f"{len(paths)})")
        if hasattr(keys, "t") and hasattr(keys, "a"):  # a voxcut.Keys
            jump = keys.jump if len(keys.jump) == len(keys.t) else np.zeros(len(keys.t), bool)
            keys = [(float(t), (a, b), bool(j)) for t, a, b, j in zip(keys.t, keys.a, keys.b,
                                                                       jump)]
        keys = [tuple(k) if len(k) == 3 else (k[0], k[1], False) for k in keys]
        if not keys:
            raise ValueError(f"run_scene: tool_keys[{i}]: no keys")
        out[int(i)] = keys
    for i, tool in enumerate(scene_tools):
        speed = blade_speed if tool.get("type") == "blade" else probe_speed
        if speed == 1:
            continue  # untouched: t0 + (t - t0) / 1 may round away from t
        keys = out.get(i, paths[i])
        t0 = keys[0][0]
        out[i] = [(t0 + (t - t0) / speed, pose, jump) for t, pose, jump in keys]
    return out


def _scene_material(values: Mapping[str, Any]) -> Dict[str, Any]:
    """A scene file's material object as voxcut.Material fields, defaults filled in."""
    from . import Material

    m = Material().as_dict()
    for key in _SCENE_MATERIAL_KEYS:
        if key in values:
            m[key] = values[key]
    if "damping" in values:
        m["mass_damping"], m["stiffness_damping"] = values["damping"]
    return m


def _set_materials(world, spec, materials, common: Dict[str, Any]) -> None:
    from . import Material

    materials = dict(materials or {})
    if not materials and not common:
        return
    seen = set()
    for body, body_spec in zip(world.bodies(), spec["bodies"]):
        scene_values = body_spec.get("materials", {})
        for name in body.info.material_names:
            if name not in materials and not common:
                continue
            seen.add(name)
            base = _scene_material(scene_values.get(name, {}))
            given = materials.get(name, {})
            if isinstance(given, Material):
                values = given.as_dict()
            elif isinstance(given, Mapping):
                values = dict(base)
                unknown = sorted(set(given) - set(values))
                if unknown:
                    raise ValueError(f"run_scene: materials[{name!r}]: unknown key "
                                     f"{', '.join(repr(k) for k in unknown)} (known: "
                                     f"{', '.join(values)})")
                values.update(given)
            else:
                raise TypeError(f"run_scene: materials[{name!r}]: expected a dict or a "
                                f"voxcut.Material, got {type(given).__name__}")
            values.update(common)
            for key in _BUILD_TIME_KEYS:
                if values[key] != base[key]:
                    raise ValueError(
                        f"run_scene: materials[{name!r}].{key}: set when the body is built "
                        f"({base[key]} in the scene); change it in the scene file")
            if values != base:
                body.set_material(name, Material(**values))
    unknown = sorted(set(materials) - seen)
    if unknown:
        raise ValueError(f"run_scene: materials: no body of the scene has material "
                         f"{', '.join(repr(n) for n in unknown)}")


def _fragments(world, bodies) -> tuple:
    """Voxels outside each body's largest piece, and their mean displacement along gravity."""
    gravity = np.asarray(world.settings["gravity"], dtype=float)
    g = np.linalg.norm(gravity)
    count = 0
    drop = 0.0
    for body in bodies:
        v = body.voxels()
        if len(v.piece_voxels) < 2:
            continue
        outside = v.pieces != int(np.argmax(v.piece_voxels))
        count += int(np.count_nonzero(outside))
        if g > 0:
            drop += float(((v.positions[outside] - v.rest_positions[outside]) @ gravity).sum()
                          / g)
    return count, (drop / count if count else 0.0)

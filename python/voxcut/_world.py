"""The World and its handles: the compiled classes with their Python-facing methods.

The compiled module (voxcut._voxcut) returns plain dicts of numpy arrays from its private
methods (_step, _nodes, ...); the public methods here turn them into the dataclasses of
voxcut._types and check array arguments before they reach C++.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _voxcut
from ._types import (
    BodyInfo,
    Contacts,
    Energy,
    FrameReport,
    HapticAnswer,
    Keys,
    Material,
    Nodes,
    Surface,
    SurfaceChanges,
    Voxels,
)

Body = _voxcut.Body
Tool = _voxcut.Tool
Obstacle = _voxcut.Obstacle
Snapshot = _voxcut.Snapshot
SurfaceView = _voxcut.SurfaceView

PathLike = Union[str, "os.PathLike[str]"]


def _materials(materials: Optional[Mapping[str, Union[Material, Mapping[str, Any]]]]):
    if materials is None:
        return None
    if not isinstance(materials, Mapping):
        raise TypeError("materials: expected a dict of material name to Material")
    out = {}
    for name, m in materials.items():
        out[name] = m.as_dict() if isinstance(m, Material) else dict(m)
    return out


class World(_voxcut.World):
    """A world of deformable bodies, tools (blades and probes) and static obstacles.

    ``World(**settings)`` makes an empty world; ``World.from_scene(path)`` the world of a
    scene file, as ``voxcut run`` builds it. Settings (keywords): time_step (s), gravity
    (m/s^2), tolerance, max_iterations, preconditioner ("auto", ...; solver_choices()),
    projection_history, contact_stiffness (N/m, 0: automatic), friction, self_collision,
    keep_self_candidates, use_octree, threaded, blade_segments, min_fragment_voxels.

    One call at a time per world: step() runs without the GIL, and a call on the same world
    from another thread meanwhile raises BusyError, except Tool.haptic, which any thread may
    call at any time. A World cannot be pickled: reproduce a run from its scene and
    recording (save_scene), which are deterministic.
    """

    def __init__(self, scene: Optional[PathLike] = None, **settings: Any) -> None:
        super().__init__(None if scene is None else os.fspath(scene), **settings)

    @classmethod
    def from_scene(cls, path: PathLike, **settings: Any) -> "World":
        """The world of the scene file at `path` (docs/scenes.md), its tools driven by their
        key frames. Settings the scene does not hold (use_octree, threaded, blade_segments,
        min_fragment_voxels) come from the keywords."""
        return cls(scene=path, **settings)

    def __reduce_ex__(self, protocol: Any) -> Any:
        raise TypeError(
            "a voxcut.World cannot be pickled: it holds native state and threads; rebuild it "
            "from its scene (World.from_scene) and replay its recording (save_scene) instead, "
            "which is deterministic")

    # ---- bodies ----

    def add_body(self, model: PathLike, *, resolution: Optional[int] = None,
                 element_level: int = 3, finest_level: Optional[int] = None,
                 front_level: Optional[int] = None, surface_level: Optional[int] = None,
                 materials: Optional[Mapping[str, Union[Material, Mapping[str, Any]]]] = None,
                 fixed: Optional[Iterable[Any]] = None, offset: Any = (0.0, 0.0, 0.0),
                 labels: Optional[Mapping[int, str]] = None,
                 label_names: Optional[PathLike] = None, min_island: int = 8) -> Body:
        """Adds a body made from `model`: a built-in model ("bunny", "liver", "starfish",
        "box:LX,LY,LZ", "sphere:R"), a mesh file or a label volume file, voxelized at
        `resolution` (voxels along the longest side; default: the model's own) and moved by
        `offset`; the keywords are the scene body keys of docs/scenes.md."""
        return self._add_body(
            os.fspath(model), resolution=resolution, element_level=element_level,
            finest_level=finest_level, front_level=front_level, surface_level=surface_level,
            materials=_materials(materials), fixed=None if fixed is None else list(fixed),
            offset=offset, labels=None if labels is None else dict(labels),
            label_names=None if label_names is None else os.fspath(label_names),
            min_island=min_island)

    def add_body_from_labels(self, labels: np.ndarray, voxel_size: Any,
                             origin: Any = (0.0, 0.0, 0.0), *,
                             names: Optional[Mapping[int, str]] = None,
                             **body: Any) -> Body:
        """Adds a body made from the application's own segmentation: `labels` a 3-D numpy
        array of dtype uint8 or uint16 (0 background, one value per tissue), element [i, j, k]
        the voxel centred at origin + voxel_size * (i, j, k) (m; voxel_size one number or
        three). It is resampled as a label volume file is (docs/algorithms.md, "Label
        volumes"); `names` names labels' materials (else label_VALUE); the other keywords are
        add_body's. Raises TypeError for another type or dtype, InputError for another
        shape."""
        if not isinstance(labels, np.ndarray):
            raise TypeError("labels: expected a numpy array, got " + type(labels).__name__)
        if labels.dtype not in (np.dtype(np.uint8), np.dtype(np.uint16)):
            raise TypeError("labels: expected dtype uint8 or uint16, got " + str(labels.dtype))
        if labels.ndim != 3:
            raise InputError(f"labels: expected a 3-D array, got shape {labels.shape}")
        size = np.broadcast_to(np.asarray(voxel_size, dtype=float), (3,)).copy()
        if "labels" in body:
            raise TypeError("add_body_from_labels: give the chosen labels as `names`")
        return self._add_label_array(np.asfortranarray(labels), size, origin,
                                     dict(names or {}), **_body_options(body))

    # ---- tools and obstacles ----

    def add_plane(self, point: Any, normal: Any, friction: Optional[float] = None) -> Obstacle:
        """A static half-space: the points x with normal . (x - point) <= 0 are inside."""
        return self.add_obstacle("plane", point=point, normal=normal, friction=friction)

    def add_box(self, lo: Any, hi: Any, friction: Optional[float] = None) -> Obstacle:
        """A static axis-aligned box lo <= x <= hi."""
        return self.add_obstacle("box", lo=lo, hi=hi, friction=friction)

    def add_mesh_obstacle(self, path: PathLike, friction: Optional[float] = None) -> Obstacle:
        """A static obstacle inside the closed triangle mesh of the file at `path`."""
        return self.add_obstacle("mesh", path=os.fspath(path), friction=friction)

    # ---- time ----

    def step(self, n: int = 1) -> FrameReport:
        """Runs `n` frames (without the GIL) and returns the last one's report. Raises
        StepError when a frame cannot finish (the world is then as before that frame),
        BusyError while another thread steps this world or a SurfaceView is alive."""
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool):
            raise TypeError("step: n must be an integer")
        return FrameReport(**self._step(int(n)))

    def save_scene(self, path: PathLike, frames: Optional[int] = None) -> None:
        """Writes the run recorded since start_recording() (called before the first step) as
        a scene file that `voxcut run` and `voxcut-view` replay to the same cuts: settings,
        bodies (an array body as a NRRD file beside it, PATH_STEM.bodyN.nrrd), obstacles and
        every tool's recorded poses. Raises InputError when the run cannot be replayed (no
        recording from frame 0; bodies, tools, obstacles or materials changed after it
        started; a restore)."""
        super().save_scene(os.fspath(path), frames)

    def contacts(self) -> Contacts:
        """Every contact at the end of the last frame."""
        return Contacts(**self._contacts())


def _body_options(body: Dict[str, Any]) -> Dict[str, Any]:
    out = dict(body)
    if "materials" in out:
        out["materials"] = _materials(out["materials"])
    if "fixed" in out and out["fixed"] is not None:
        out["fixed"] = list(out["fixed"])
    if "label_names" in out and out["label_names"] is not None:
        out["label_names"] = os.fspath(out["label_names"])
    return out


InputError = _voxcut.InputError


# ---- Body, Tool: the public reads over the compiled private ones ----

def _body_info(self: Body) -> BodyInfo:
    """The body's size and cut state."""
    return BodyInfo(**self._info())


def _body_nodes(self: Body) -> Nodes:
    """The body's deformation nodes at the end of the last frame (copies)."""
    return Nodes(**self._nodes())


def _body_voxels(self: Body) -> Voxels:
    """The body's occupied voxels at rest and now, with their pieces (copies)."""
    return Voxels(**self._voxels())


def _body_energy(self: Body) -> Energy:
    """Kinetic, gravitational and elastic energy at the end of the last frame (J)."""
    return Energy(**self._energy())


def _body_surface(self: Body) -> Surface:
    """A compact, owning copy of the deformed surface; it does not change as the world
    steps."""
    return Surface(**self._surface())


def _body_surface_changes(self: Body, since: int) -> SurfaceChanges:
    """Which slots of surface_view() changed since revision `since`."""
    d = self._surface_changes(int(since))
    return SurfaceChanges(from_revision=d["from"], to_revision=d["to"], full=d["full"],
                          added_vertices=d["added_vertices"],
                          removed_vertices=d["removed_vertices"],
                          added_triangles=d["added_triangles"],
                          removed_triangles=d["removed_triangles"])


def _body_material(self: Body, name: str) -> Material:
    """The body's material `name` as it is set now (the defaults where never set)."""
    return Material(**self._material(name))


def _body_set_material(self: Body, name: str,
                       material: Union[Material, Mapping[str, Any], None] = None,
                       **values: Any) -> None:
    """Sets the body's material `name` (one of info.material_names): to `material` (a
    Material or a dict of its fields), and/or the fields given as keywords over what it is
    now, e.g. body.set_material("default", young_modulus=2e5). The element matrices are
    recomputed; the voxel octree's levels are fixed when the body is added (a change is an
    InputError)."""
    merged = self._material(name)
    if material is not None:
        merged.update(material.as_dict() if isinstance(material, Material) else dict(material))
    merged.update(values)
    self._set_material(name, merged)


def _body_set_fixed(self: Body, boxes: Iterable[Any]) -> None:
    self._set_fixed(list(boxes))


def _tool_haptic(self: Tool, pose: Any) -> HapticAnswer:
    """The force and torque a probe at `pose` (a point or two ends) would feel now, for a
    haptic loop faster than the frames. Any thread, any time, also while step() runs;
    never raises: a bad pose or a handle that names no probe answers zero with a status."""
    force, torque, status = self._haptic(pose)
    return HapticAnswer(force=force, torque=torque, status=status)


def _tool_recording(self: Tool) -> Keys:
    """The tool's recorded poses (World.start_recording): one key when recording started,
    then one per frame."""
    return Keys(**self._recording())


def _tool_set_trajectory(self: Tool, keys: Union[Keys, Sequence[Any]]) -> None:
    if isinstance(keys, Keys):
        jump = keys.jump if len(keys.jump) == len(keys.t) else np.zeros(len(keys.t), bool)
        keys = [(float(t), (a, b), bool(j)) for t, a, b, j in zip(keys.t, keys.a, keys.b, jump)]
    self._set_trajectory(list(keys))


Body.info = property(_body_info)
Body.nodes = _body_nodes
Body.voxels = _body_voxels
Body.energy = _body_energy
Body.surface = _body_surface
Body.surface_changes = _body_surface_changes
Body.material = _body_material
Body.set_material = _body_set_material
Body.fixed = property(None, _body_set_fixed, doc="Sets the body's fixed boxes ((lo, hi), ...).")
Body.__repr__ = lambda self: f"<voxcut.Body slot {self.slot}{'' if self.alive else ' (removed)'}>"
Tool.haptic = _tool_haptic
Tool.recording = property(_tool_recording)
Tool.trajectory = property(
    None, _tool_set_trajectory,
    doc="Drives the tool by key frames: a Keys, or a list of (t, pose) or (t, pose, jump).")
Tool.__repr__ = lambda self: f"<voxcut.Tool slot {self.slot}{'' if self.alive else ' (removed)'}>"
Obstacle.__repr__ = (
    lambda self: f"<voxcut.Obstacle slot {self.slot}{'' if self.alive else ' (removed)'}>")

"""voxcut: interactive cutting of deformable objects modelled as linked voxels.

A World holds deformable bodies (from built-in models, mesh files, label volumes or numpy
label arrays), tools (blades that cut, probes that push) and static obstacles; step() runs a
frame. Surfaces, nodes, contacts and forces come back as numpy arrays. docs/python.md in the
repository is the guide; every class and function has its docstring.

    import voxcut
    world = voxcut.World.from_scene("scenes/bunny-ear.json")
    report = world.step(10)
    surface = world.bodies()[0].surface()

Errors: InputError (a ValueError) for a bad argument, which changes nothing;
StaleHandleError (a KeyError) for a handle of a removed body, tool or obstacle; BusyError
(a RuntimeError) for a call on a world another thread is stepping; StepError (a
RuntimeError) for a frame that cannot finish, which leaves the world as it was.
"""

from . import _voxcut
from ._types import (
    CONTACT_KINDS,
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
from ._world import Body, Obstacle, Snapshot, SurfaceView, Tool, World

InputError = _voxcut.InputError
StaleHandleError = _voxcut.StaleHandleError
BusyError = _voxcut.BusyError
StepError = _voxcut.StepError
Interrupted = _voxcut.Interrupted
set_threads = _voxcut.set_threads
solver_choices = _voxcut.solver_choices
frame_stage_names = _voxcut.frame_stage_names
builtin_models = _voxcut.builtin_models
__version__ = _voxcut.__version__

__all__ = [
    "World", "Body", "Tool", "Obstacle", "Snapshot", "SurfaceView",
    "Material", "FrameReport", "BodyInfo", "Nodes", "Voxels", "Energy", "Surface",
    "SurfaceChanges", "Contacts", "CONTACT_KINDS", "HapticAnswer", "Keys",
    "InputError", "StaleHandleError", "BusyError", "StepError", "Interrupted",
    "set_threads", "solver_choices", "frame_stage_names", "builtin_models",
    "sweep",
]


def __getattr__(name):
    # voxcut.sweep imports dask only when used.
    if name == "sweep":
        import importlib
        return importlib.import_module(__name__ + ".sweep")
    raise AttributeError(f"module 'voxcut' has no attribute {name!r}")

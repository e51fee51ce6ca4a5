"""Value types of the voxcut Python API: plain dataclasses over numpy arrays.

Units are SI (m, kg, s, Pa, N) in the world frame, as in the C++ library
(src/voxcut/sim/WorldTypes.h documents every field).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np


@dataclass
class Material:
    """A material's physical and voxel-octree parameters (defaults: a soft tissue)."""

    young_modulus: float = 5.0e4
    """E, Pa, > 0."""
    poisson_ratio: float = 0.4
    """nu, in [0, 0.5)."""
    density: float = 1000.0
    """rho, kg/m^3, > 0."""
    mass_damping: float = 1.0
    """Rayleigh alpha, 1/s, >= 0."""
    stiffness_damping: float = 0.01
    """Rayleigh beta, s, >= 0."""
    max_internal_level: int = 4
    """Voxel octree: largest cube of this material alone, 0..7."""
    max_boundary_level: int = 0
    """Voxel octree: largest cube mixing it with other materials, 0..7."""

    def as_dict(self) -> Dict[str, float]:
        return dataclasses.asdict(self)


@dataclass
class FrameReport:
    """What one frame did (summed over bodies). `status` is "ok", or "not_converged" when
    some body's solve stopped at its iteration cap (the frame still ran; a frame that cannot
    finish raises StepError instead and leaves the world as it was)."""

    frame: int
    time: float
    stage_ms: Dict[str, float]
    total_ms: float
    cut_links: int
    positioned_voxels: int
    tested_links: int
    solver_iterations: int
    solver_solves: int
    """Implicit steps solved, summed over bodies: one a body, more where a step was solved
    again because its contact set changed."""
    solver_factorisations: int
    converged: bool
    contacts: int
    max_penetration: float
    obstacle_forces: np.ndarray
    """(obstacles, 3): per obstacle of World.obstacles(), the bodies' force on it (N)."""
    tool_forces: np.ndarray
    """(tools, 3): per tool of World.tools(), the bodies' force on it (N)."""
    tool_torques: np.ndarray
    """(tools, 3): the torques about each tool's segment midpoint (N m)."""

    @property
    def status(self) -> str:
        return "ok" if self.converged else "not_converged"


@dataclass
class BodyInfo:
    elements: int
    nodes: int
    cut_links: int
    surface_vertices: int
    surface_triangles: int
    voxel_size: float
    material_names: List[str]
    material_colours: List[Optional[Tuple[float, float, float]]]
    solver: str
    self_candidate_queries: int


@dataclass
class Nodes:
    """A body's deformation nodes at the end of the last frame (owning copies)."""

    positions: np.ndarray
    rest_positions: np.ndarray
    velocities: np.ndarray
    masses: np.ndarray


@dataclass
class Voxels:
    """A body's occupied voxels' centres at rest and now, and the piece each belongs to."""

    rest_positions: np.ndarray
    positions: np.ndarray
    pieces: np.ndarray
    piece_voxels: List[int]


@dataclass
class Energy:
    kinetic: float
    gravitational: float
    elastic: float

    @property
    def total(self) -> float:
        return self.kinetic + self.gravitational + self.elastic


@dataclass
class Surface:
    """A compact, owning copy of a body's deformed surface."""

    vertices: np.ndarray
    """(V, 3) float64, m."""
    normals: np.ndarray
    """(V, 3) float64, unit."""
    triangles: np.ndarray
    """(F, 3) int32, counter-clockwise seen from outside."""
    materials: np.ndarray
    """(F,) uint8: the material on each triangle's side (index into material_names, from 1)."""
    cut: np.ndarray
    """(F,) bool: whether each triangle lies on a cut."""


@dataclass
class SurfaceChanges:
    """Slots of a surface view that changed between two revisions."""

    from_revision: int
    to_revision: int
    full: bool
    added_vertices: List[int]
    removed_vertices: List[int]
    added_triangles: List[int]
    removed_triangles: List[int]


CONTACT_KINDS = ("obstacle", "probe", "body", "self")


@dataclass
class Contacts:
    """Every contact at the end of the last frame, as arrays of one row per contact.

    kind: codes into CONTACT_KINDS; body: the touching body's position in World.bodies();
    target: the touched obstacle's position in World.obstacles(), probe's in World.tools(),
    or body's in World.bodies(); point, normal, force: (n, 3); depth: (n,)."""

    kind: np.ndarray
    body: np.ndarray
    target: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    force: np.ndarray

    def __len__(self) -> int:
        return len(self.kind)

    def kind_names(self) -> List[str]:
        return [CONTACT_KINDS[k] for k in self.kind]


@dataclass
class HapticAnswer:
    """The haptic call's answer: force and torque (N, N m) and "ok", "non_finite_pose",
    "not_a_probe" or "busy" (tools were being added, removed or restored: zero force)."""

    force: np.ndarray
    torque: np.ndarray
    status: str


@dataclass
class Keys:
    """A tool's key frames (a recording or a trajectory): times (n,), ends a and b (n, 3),
    and which keys are jumps."""

    t: np.ndarray
    a: np.ndarray
    b: np.ndarray
    jump: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def __len__(self) -> int:
        return len(self.t)

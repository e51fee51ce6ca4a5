#pragma once
/// @file WorldTypes.h
/// The value types of the world API (sim/World.h; docs/architecture.md, "The world API"):
/// handles, settings, materials, tool keys, reports and views. Plain data: nothing here refers
/// to a module's internals, so an embedder that includes World.h sees only this, core's value
/// types, the standard library and Eigen.
///
/// Units: SI (m, kg, s, Pa, N), world frame.

#include <array>
#include <compare>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "voxcut/core/BladePose.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/SurfaceMesh.h"
#include "voxcut/core/Types.h"

namespace voxcut {

// ---- handles ----

/// A typed handle to a world's body, tool or obstacle: the slot it lives in and the slot's
/// generation when it was made. Removing the object bumps its slot's generation, so an old
/// handle is refused (InputError) instead of reaching whatever takes the slot next. Handles
/// of different kinds are different types: passing a tool where a body is asked is a compile
/// error. A default-made handle is invalid and names nothing.
template <class Tag>
class Handle {
 public:
  constexpr Handle() = default;
  constexpr Handle(std::uint32_t slot, std::uint32_t generation)
      : slot_(slot), generation_(generation) {}
  /// Whether it was made by a world (it may still be stale).
  [[nodiscard]] constexpr bool valid() const { return slot_ != kNone; }
  [[nodiscard]] constexpr std::uint32_t slot() const { return slot_; }
  [[nodiscard]] constexpr std::uint32_t generation() const { return generation_; }
  friend constexpr auto operator<=>(Handle, Handle) = default;

 private:
  static constexpr std::uint32_t kNone = 0xffffffffu;
  std::uint32_t slot_ = kNone;
  std::uint32_t generation_ = 0;
};

struct BodyTag;
struct ToolTag;
struct ObstacleTag;
using BodyId = Handle<BodyTag>;          ///< a deformable body
using ToolId = Handle<ToolTag>;          ///< a blade or a probe
using ObstacleId = Handle<ObstacleTag>;  ///< a static obstacle

// ---- settings ----

/// How each body's implicit step solves its linear system: the preconditioner of its conjugate
/// gradients (docs/algorithms.md, "Preconditioners"). Automatic (the default) leaves the choice
/// to each body's step: the sparse Cholesky factor of an earlier step, the multigrid or the
/// two-level V-cycle, whichever the body's size and its last steps (cuts, contacts, how long a
/// factor lasts) say is cheapest (fem/AutomaticChoice.h; docs/algorithms.md, "The automatic solver choice");
/// BodyInfo::solver says which its last step chose. The others force one kind everywhere (for
/// comparisons and benchmarks).
enum class SolverChoice {
  Automatic,
  Cholesky,              ///< sparse Cholesky factor of an earlier step's matrix
  Multigrid,             ///< geometric multigrid V-cycle on the node grid
  Jacobi,                ///< inverse of the diagonal entries
  BlockJacobi,           ///< inverse of each node's 3x3 diagonal block
  SymmetricGaussSeidel,  ///< one forward and one backward block Gauss-Seidel sweep
  IncompleteCholesky,    ///< block IC(0), refactorised every step
  TwoLevel,              ///< Gauss-Seidel and aggregates' rigid motions
};

/// Every solver choice, in declaration order.
inline constexpr SolverChoice kSolverChoices[] = {
    SolverChoice::Automatic,          SolverChoice::Cholesky,
    SolverChoice::Multigrid,          SolverChoice::Jacobi,
    SolverChoice::BlockJacobi,        SolverChoice::SymmetricGaussSeidel,
    SolverChoice::IncompleteCholesky, SolverChoice::TwoLevel};

/// The choice's name in scene files and reports: "auto", "cholesky", "multigrid", "jacobi",
/// "block_jacobi", "symmetric_gauss_seidel", "incomplete_cholesky", "two_level".
[[nodiscard]] const char* solverChoiceName(SolverChoice c);

/// Settings of the implicit solver's linear solve (preconditioned conjugate gradients).
struct SolverSettings {
  double tolerance = 1e-3;  ///< relative residual at which the solve stops, > 0
  int maxIterations = 100;  ///< iteration cap, >= 1
  SolverChoice preconditioner = SolverChoice::Automatic;
  /// Earlier solutions a solve's start is projected onto (docs/algorithms.md, "Projection
  /// onto earlier solutions"), 0..64; 0 for none.
  int projectionHistory = 8;
};

/// A material's physical and voxel-octree parameters. The defaults are a soft tissue (about
/// liver parenchyma, stiffened for the coarse deformation octree) and are what a body gets
/// for a material it does not set.
struct SceneMaterial {
  std::string name;             ///< the model's material name ("default", "liver", "tumor"...)
  double youngModulus = 5.0e4;  ///< E, Pa, > 0
  double poissonRatio = 0.4;    ///< nu, in [0, 0.5)
  double density = 1000.0;      ///< rho, kg/m^3, > 0
  /// Rayleigh damping C = massDamping * M + stiffnessDamping * K: alpha (1/s) and beta (s),
  /// both >= 0.
  double massDamping = 1.0;
  double stiffnessDamping = 0.01;
  int maxInternalLevel = 4;  ///< voxel octree: largest cube of this material alone, 0..7
  int maxBoundaryLevel = 0;  ///< voxel octree: largest cube mixing it with others, 0..7
};

/// An axis-aligned box of the world frame (metres), lo <= hi on every axis, bounds included.
/// Deformation nodes whose rest position lies inside do not move.
struct FixedBox {
  Vec3d lo = Vec3d::Zero();
  Vec3d hi = Vec3d::Zero();
};

/// What a tool is.
enum class ToolKind {
  Blade,  ///< cuts the links its edge (the segment a-b) sweeps; pushes nothing
  Probe,  ///< a sphere (a == b) or a capsule around the segment a-b; pushes, cuts nothing
};

/// One key frame of a tool: at time t (s) its segment runs from a to b (world frame, metres).
/// A jump key places the tool there at time t without moving it from the key before: the tool
/// holds the previous key's pose until t, and sweeps or pushes nothing on the way (a hand
/// lifting the tool away and setting it down elsewhere; World::placeTool).
struct ToolKey {
  double t = 0.0;
  BladePose pose;
  bool jump = false;
};

/// Contact between bodies and obstacles (docs/algorithms.md, "Contact").
struct ContactSettings {
  /// Penalty stiffness per surface vertex (N/m), >= 0; 0: 10 times each body's largest
  /// Young's modulus times its voxel size (ten times the stiffness of one voxel of it;
  /// docs/algorithms.md, "Contact", says why not more). A self contact pair gets it divided
  /// by the edge, in voxels, of the coarser of its two elements (docs/algorithms.md, "Self
  /// contact in one solve").
  double stiffness = 0.0;
  /// Whether a body's surface vertices are kept out of its own material away from their
  /// neighbourhood (folds, the two sides of a cut); bodies never pass through each other.
  bool selfCollision = false;
  /// Coulomb friction coefficient of contacts, >= 0, where an obstacle or tool does not set
  /// its own (and always between bodies).
  double friction = 0.3;
  /// Self collision keeps its broad phase's candidates between frames (a Verlet list:
  /// queried afresh only when a node has moved out of their skin or a cut changed the
  /// elements); false queries afresh every frame, the same contacts at a higher cost (for
  /// comparisons). BodyInfo::selfCandidateQueries counts the queries.
  bool keepSelfCandidates = true;
};

/// Settings of a world that do not belong to one body or tool.
struct WorldSettings {
  double timeStep = 0.004;         ///< s, > 0
  Vec3d gravity{0.0, -9.81, 0.0};  ///< m/s^2
  SolverSettings solver;
  ContactSettings contact;
  bool useOctree = true;  ///< false: the baseline, every link active, no voxel octree
  bool threaded = true;
  /// Least number of segments of a blade's edge carried with the material between frames;
  /// more where the blade is longer than this many voxels (one per voxel). 0 sweeps from the
  /// blade's previous pose in the world instead (parts moving across the blade's plane during
  /// a cut can then stay attached by bridges along the frames' seams).
  int bladeSegments = 16;
  /// Cuts that would leave a fragment of fewer voxels than this are undone; 0 or 1 keeps
  /// every cut.
  std::size_t minFragmentVoxels = 8;
};

/// How a body is discretised and what it is made of.
struct BodySettings {
  int elementLevel = 3;  ///< starting level of the deformation octree, 0..6
  /// Finest level refinement reaches where a blade's front rests in an element whose cut
  /// sides stay glued there (docs/algorithms.md, "Cut topology"), <= elementLevel; -1:
  /// elementLevel - 2 (at least 0).
  int finestLevel = -1;
  /// Level a cut's front coarsens back to once the cuts have left it (docs/algorithms.md,
  /// "Coarsening after cuts"), in [finestLevel, elementLevel]; -1: elementLevel (the front
  /// then opens to within one start-level element of its end).
  int frontLevel = -1;
  /// Level down to which elements less than half full are split at the start,
  /// <= elementLevel; -1: the library's default (two below elementLevel, at least 0).
  int surfaceLevel = -1;
  /// Materials by the grid's material names; the grid's others take SceneMaterial's defaults.
  std::vector<SceneMaterial> materials;
  std::vector<FixedBox> fixed;  ///< world frame
};

// ---- reads ----

/// A body's size and cut state.
struct BodyInfo {
  std::size_t elements = 0;  ///< deformation octree elements (copies after cuts)
  std::size_t nodes = 0;
  std::size_t cutLinks = 0;  ///< links cut so far
  std::size_t surfaceVertices = 0;
  std::size_t surfaceTriangles = 0;
  double voxelSize = 0.0;                  ///< m
  std::vector<std::string> materialNames;  ///< of materials 1..N (element 0 is material 1)
  /// Display colours (RGB in [0, 1]) of materials 1..N that the model gave (a label volume's
  /// segment colours); shorter than materialNames, or without a value, where it gave none.
  std::vector<std::optional<std::array<float, 3>>> materialColours;
  /// The solver its last step chose: under Automatic, Cholesky, Multigrid or TwoLevel as the
  /// choice goes (fem/AutomaticChoice.h); before the first step, the setting.
  SolverChoice solver = SolverChoice::Cholesky;
  /// Times self collision's broad phase was queried afresh for the body
  /// (ContactSettings::keepSelfCandidates).
  std::size_t selfCandidateQueries = 0;
};

/// A body's deformed surface, read in place: arrays indexed by slot, where a removed vertex
/// or triangle leaves a dead slot that a later one may reuse. Valid until the next step() or
/// edit of the world.
struct SurfaceView {
  std::span<const Vec3d> positions;  ///< per vertex slot, current (m); dead slots: stale
  /// Per vertex slot, unit, area-weighted (+z on no triangle of non-zero area); dead: zero.
  std::span<const Vec3d> normals;
  /// Per triangle slot, vertex slots, counter-clockwise seen from outside; dead: {-1, -1, -1}.
  std::span<const std::array<int, 3>> triangles;
  /// Per triangle slot, the material on its side (an index into BodyInfo::materialNames,
  /// from 1) and whether it lies on a cut; dead slots: stale.
  std::span<const TriangleTag> triangleTags;
  std::uint64_t revision = 0;  ///< of the topology (slots); positions change every frame
};

/// The topology changes of a body's surface between two revisions: the vertex and triangle
/// slots that were added (or reused) and those that died, each ascending and unique. A slot
/// can be in both lists (died, then reused): its current content is in the view.
struct SurfaceChanges {
  std::uint64_t from = 0, to = 0;
  bool full = false;  ///< the changes since `from` are no longer kept: read everything again
  std::vector<std::int32_t> addedVertices, removedVertices;
  std::vector<std::int32_t> addedTriangles, removedTriangles;
};

/// The pseudo voxel octree of a body made visible, at the deformed positions of its voxels:
/// the links that take part in the cutting tool's collision (active and connected; all
/// connected links without the octree), and the octree's cubes by their corners.
struct ActivityView {
  std::size_t activeLinks = 0;  ///< all of the body's active links that are still connected
  /// Segments between the voxels of active links: all of them, or every k-th in voxel order
  /// when there are more than asked for.
  std::vector<std::array<Vec3d, 2>> links;
  /// Per cube its 8 corner voxels' positions, corner c at offset ((c & 1), (c >> 1 & 1),
  /// (c >> 2)) times the cube's side; with its level (side 2^level voxels).
  std::vector<std::array<Vec3d, 8>> cubes;
  std::vector<std::uint8_t> cubeLevels;
};

/// A body's nodes (the deformation octree's corners) at the end of the last frame. Free
/// nodes move; fixed ones (in a fixed box) and hanging ones (on a coarser neighbour's edge or
/// face, at the mean of their masters) follow.
struct NodeState {
  std::vector<Vec3d> positions;   ///< m
  std::vector<Vec3d> restPositions;  ///< m, where each node is at rest (its node-grid point)
  std::vector<Vec3d> velocities;  ///< m/s; zero before the first frame
  std::vector<double> masses;     ///< kg, lumped from the material each node's elements hold
};

/// A body's material points, its occupied voxels' centres in ascending voxel order, and the
/// pieces they make (World::pieces): what a cut-off part is measured by (where it rests, how
/// far it fell).
struct BodyVoxels {
  std::vector<Vec3d> restPositions;  ///< m, each voxel's centre at rest
  std::vector<Vec3d> positions;      ///< m, where it is at the end of the last frame
  /// Per voxel, its piece (connected through connected links): 0 .. pieceVoxels.size() - 1,
  /// numbered in order of their first voxel.
  std::vector<int> pieces;
  std::vector<std::size_t> pieceVoxels;  ///< per piece, its number of voxels
};

/// The force and torque the bodies exert on a tool at the end of the last frame (N, N m; the
/// torque about the midpoint of the tool's segment). A blade's are zero.
struct ToolReaction {
  Vec3d force = Vec3d::Zero();
  Vec3d torque = Vec3d::Zero();
};

/// What the haptic call answers: the probe's force and torque, and whether it could answer.
struct HapticAnswer {
  enum class Status {
    Ok,
    NonFinitePose,  ///< the pose asked about was not finite or out of range: zero force
    NotAProbe,      ///< the handle names no live probe: zero force
  };
  ToolReaction reaction;
  Status status = Status::Ok;
};

/// One contact at the end of the last frame: a body's surface point pressed against an
/// obstacle, a probe, another body or another part of itself.
struct Contact {
  enum class With { Obstacle, Probe, Body, Self };
  BodyId body;            ///< the body whose surface vertex touches
  With with = With::Obstacle;
  ObstacleId obstacle;    ///< with an obstacle
  ToolId tool;            ///< with a probe
  BodyId other;           ///< with another body (the body itself for Self)
  Vec3d point = Vec3d::Zero();   ///< the touching point at the frame's end (m)
  Vec3d normal = Vec3d::Zero();  ///< unit, out of what it touches: the way `body` is pushed
  /// How far the point lies inside what it touches, along the normal (m; negative: a gap the
  /// step was closing): with obstacles and probes at the frame's end, against the surface
  /// point found for it; with bodies and itself as found at the frame's start.
  double depth = 0.0;
  /// The force on `body` at the point (N): the normal push and the friction.
  Vec3d force = Vec3d::Zero();
};

/// The stages of a frame, in order; FrameReport::stageMs follows this order.
[[nodiscard]] const std::vector<std::string>& frameStageNames();

/// What one frame did (summed over bodies).
struct FrameReport {
  int frame = 0;                ///< index of the frame just run (0 first)
  double time = 0.0;            ///< simulated time at its end (s)
  std::vector<double> stageMs;  ///< per frameStageNames() entry, wall-clock ms
  double totalMs = 0.0;         ///< wall-clock ms of the whole frame
  std::size_t cutLinks = 0;     ///< links cut in this frame
  /// The cutting tool collision's work this frame: voxels it positioned to cull the links
  /// near the blades, and links it tested against them (intersection test and octree
  /// subdivision).
  std::size_t positionedVoxels = 0;
  std::size_t testedLinks = 0;
  int solverIterations = 0;      ///< summed over bodies
  /// Implicit steps solved, summed over bodies: one a body, more where the contact set a
  /// step ended with differed from the one it was given and the step was solved again.
  int solverSolves = 0;
  int solverFactorisations = 0;  ///< bodies whose step computed a new Cholesky factor
  bool converged = true;         ///< every body's solve converged
  /// Contacts at the frame's end: with obstacles and probes, between bodies and within one
  /// (World::contacts lists them).
  std::size_t contacts = 0;
  /// The deepest any surface vertex lies inside an obstacle, probe or body at the frame's
  /// end (m).
  double maxPenetration = 0.0;
  /// Per obstacle, in the order of World::obstacles(), the force the bodies press on it with
  /// at the frame's end (N).
  std::vector<Vec3d> obstacleForces;
  /// Per tool, in the order of World::tools(), the bodies' reaction on it at the frame's end
  /// (World::toolReaction).
  std::vector<ToolReaction> toolReactions;
};

/// A step that could not finish (World::step): a body's solve diverged or its state became
/// non-finite, or the frame ran out of memory. The world is left exactly as it was before the
/// step (docs/architecture.md, "Errors"): it can be stepped again (after a change of what made
/// the step fail: a tool's pose, a material) or restored from a snapshot.
class StepError : public std::runtime_error {
 public:
  StepError(const std::string& what, BodyId body, int frame)
      : std::runtime_error(what), body_(body), frame_(frame) {}
  /// The body whose step failed (invalid when the frame failed outside a body's step).
  [[nodiscard]] BodyId body() const { return body_; }
  /// The frame that failed (World::frame() before and after the call).
  [[nodiscard]] int frame() const { return frame_; }

 private:
  BodyId body_;
  int frame_ = 0;
};

/// A body's mechanical energy (J): what a soak or a test watches for energy the contacts
/// create. The contact springs' own energy is not counted.
struct BodyEnergy {
  double kinetic = 0.0;  ///< 1/2 sum_n m_n |v_n|^2, lumped node masses
  /// -sum_n m_n g . x_n: zero at the world's origin, growing against gravity
  double gravitational = 0.0;
  double elastic = 0.0;  ///< corotated strain energy, sum_e 1/2 y_e^T K_e y_e
  [[nodiscard]] double total() const { return kinetic + gravitational + elastic; }
};

}  // namespace voxcut

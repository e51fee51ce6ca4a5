#pragma once
/// @file Scene.h
/// A simulation scene as plain data: time step, gravity, solver settings, bodies (model,
/// resolution, deformation octree levels, materials, fixed boxes, offset), tools (key-framed
/// blades), static obstacles and contact settings. io/SceneReader.h reads and validates it from
/// JSON (format: docs/scenes.md); this header does no I/O. Units: SI (m, kg, s, Pa), world frame.
///
/// Thread-safety: plain values; the free functions are pure and may be called concurrently.

#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/Types.h"
#include "voxcut/sim/WorldTypes.h"
#include "voxcut/voxel/LabelResample.h"
#include "voxcut/voxel/LabelVolume.h"

namespace voxcut {

/// One deformable body.
struct SceneBody {
  /// A built-in model spec as io/ModelSource.h understands it (bunny, liver, starfish,
  /// box:LX,LY,LZ, sphere:R), or the absolute, lexically normalised path of a mesh file or a
  /// label volume.
  std::string model;
  std::optional<int> resolution;  ///< voxels along the longest side; empty: the model's own
  int elementLevel = 3;           ///< starting level of the deformation octree, 0..6
  /// Finest level refinement after cuts reaches, <= elementLevel; -1: elementLevel - 2, at
  /// least 0 (BodySettings::finestLevel).
  int finestLevel = -1;
  /// Level a cut's front coarsens back to once the cuts have left it, in [finestLevel,
  /// elementLevel]; -1: elementLevel (BodySettings::frontLevel).
  int frontLevel = -1;
  /// Level down to which elements less than half full are split at the start, <= elementLevel;
  /// -1: defaultSurfaceLevel (topology/DeformationOctree.h).
  int surfaceLevel = -1;
  /// The materials the scene sets, in the order the file lists them (unique names); the
  /// model's other materials take SceneMaterial's defaults (see sceneMaterial).
  std::vector<SceneMaterial> materials;
  std::vector<FixedBox> fixed;   ///< world frame, metres
  Vec3d offset = Vec3d::Zero();  ///< translation of the model into the world, metres
  /// A label volume's labels made materials ("labels": {"255": "liver"}), in the order
  /// written; empty: every label ("labels": "all", the default).
  std::vector<LabelChoice> labels;
  int minIsland = 8;  ///< a label volume's island threshold ("min_island"), voxels
  /// A label volume's names file ("label_names"; lines `value name`): the absolute, lexically
  /// normalised path; empty: none.
  std::string labelNames;
  /// A label volume given in memory (an application's own segmentation) instead of a file:
  /// when set, loadBodyModel uses it (with labels, min_island and offset as for a file) and
  /// `model` only names it in messages. Shared and immutable, so copies of a scene do not copy
  /// its voxels. A scene holding one cannot be written as a file (io/SceneWriter.h).
  std::shared_ptr<const LabelVolume> volume;
};

/// A key-framed tool. Keys' times increase strictly, except that a jump key may share the
/// time of the key before it (the pose before the jump and the pose after it); there is at
/// least one key.
struct SceneTool {
  ToolKind kind = ToolKind::Blade;
  double radius = 0.0;     ///< a probe's radius (m), > 0; 0 for a blade
  double friction = -1.0;  ///< a probe's Coulomb coefficient, >= 0; negative: the default
  std::vector<ToolKey> keys;
};

/// A whole scene.
struct Scene {
  std::string source;              ///< the file it was read from, as given (prefix of messages)
  double timeStep = 0.004;         ///< s, > 0
  Vec3d gravity{0.0, -9.81, 0.0};  ///< m/s^2
  SolverSettings solver;
  std::optional<int> frames;      ///< default frame count of `voxcut run`; empty: not given
  /// The direction pictures of the scene look from, yaw and pitch in degrees as the viewer's
  /// --view takes them ("view"); empty: the viewer's default.
  std::optional<std::array<double, 2>> view;
  std::vector<SceneBody> bodies;  ///< at least one
  std::vector<SceneTool> tools;
  std::vector<Obstacle> obstacles;  ///< static, world frame
  ContactSettings contact;
};

/// The pose of `tool` at time `t` (s): the linear interpolation of the two keys around t,
/// i.e. for t_k <= t <= t_{k+1}, a = a_k + s (a_{k+1} - a_k) with s = (t - t_k) /
/// (t_{k+1} - t_k), b likewise; the first key's pose before the first key and the last key's
/// after the last key. A key's time gives its pose exactly. Towards a jump key the pose holds
/// the key before it; at the jump's time it is the jump's pose (of keys sharing a time, the
/// last). Asserts that there are keys and that the keys the pose comes from have finite times
/// and ends within the coordinate range (core/CoordinateRange.h). O(log keys).
[[nodiscard]] BladePose bladePoseAt(const std::vector<ToolKey>& keys, double t);
/// The pose the tool reaches as time rises to `t`: bladePoseAt, except at the time of a jump
/// key, where it is the pose before the jump.
[[nodiscard]] BladePose bladePoseBefore(const std::vector<ToolKey>& keys, double t);
/// The last jump key with a time in [t0, t1), or nullptr.
[[nodiscard]] const ToolKey* jumpIn(const std::vector<ToolKey>& keys, double t0, double t1);
/// Whether `keys` are in order: at least one, times increasing strictly except that a jump
/// key may share the time of the key before it.
[[nodiscard]] bool keysInOrder(const std::vector<ToolKey>& keys);
[[nodiscard]] inline BladePose bladePoseAt(const SceneTool& tool, double t) {
  return bladePoseAt(tool.keys, t);
}

/// The body settings of a scene body (levels, materials, fixed boxes): what World::fromScene
/// gives each body, and any client that adds a scene body to a world.
[[nodiscard]] BodySettings bodySettings(const SceneBody& body);

/// The material `name` of `materials` (a body's list), or SceneMaterial's defaults named
/// `name` when the list does not hold it.
[[nodiscard]] SceneMaterial sceneMaterial(const std::vector<SceneMaterial>& materials,
                                          const std::string& name);
/// The material `name` of `body`: the one the scene sets, or SceneMaterial's defaults.
[[nodiscard]] inline SceneMaterial sceneMaterial(const SceneBody& body, const std::string& name) {
  return sceneMaterial(body.materials, name);
}

/// Checks that every material `body` (bodies[bodyIndex] of `scene`) sets is one of
/// `modelMaterials` (the loaded model's material names, in order). Throws InputError naming
/// the key path otherwise, e.g. "scene.json: bodies[0].materials.tumour: model 'liver' has no
/// material 'tumour' (it has: liver, tumor)". Asserts that bodyIndex is in range.
void checkMaterialNames(const Scene& scene, std::size_t bodyIndex,
                        const std::vector<std::string>& modelMaterials);

}  // namespace voxcut

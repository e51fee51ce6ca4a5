#include "voxcut/sim/Scene.h"

#include <algorithm>
#include <cmath>

#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Error.h"

namespace voxcut {

BladePose bladePoseAt(const std::vector<ToolKey>& keys, double t) {
  VOXCUT_ASSERT(!keys.empty(), "a tool needs at least one key");
  // Only the keys a pose comes from are checked, so that a call stays O(log keys); the
  // geometric predicates need coordinates within the range (core/CoordinateRange.h).
  const auto checked = [](const ToolKey& key) -> const ToolKey& {
    VOXCUT_ASSERT(std::isfinite(key.t) && isCoordinate(key.pose.a) && isCoordinate(key.pose.b),
                  "a tool key with a non-finite time or an end outside the coordinate range");
    return key;
  };
  if (!(t > keys.front().t)) return checked(keys.front()).pose;  // also NaN: the first pose
  if (t >= keys.back().t) return checked(keys.back()).pose;
  // First key strictly after t; keys.front().t < t < keys.back().t, so 1 <= k < size.
  const auto next = std::upper_bound(keys.begin(), keys.end(), t,
                                     [](double time, const ToolKey& key) { return time < key.t; });
  const ToolKey& k1 = checked(*next);
  const ToolKey& k0 = checked(*(next - 1));
  if (t == k0.t) return k0.pose;
  const double s = (t - k0.t) / (k1.t - k0.t);
  return {k0.pose.a + s * (k1.pose.a - k0.pose.a), k0.pose.b + s * (k1.pose.b - k0.pose.b)};
}

SceneMaterial sceneMaterial(const std::vector<SceneMaterial>& materials, const std::string& name) {
  for (const SceneMaterial& m : materials)
    if (m.name == name) return m;
  SceneMaterial m;
  m.name = name;
  return m;
}

void checkMaterialNames(const Scene& scene, std::size_t bodyIndex,
                        const std::vector<std::string>& modelMaterials) {
  VOXCUT_ASSERT(bodyIndex < scene.bodies.size(), "body index out of range");
  const SceneBody& body = scene.bodies[bodyIndex];
  for (const SceneMaterial& m : body.materials) {
    if (std::find(modelMaterials.begin(), modelMaterials.end(), m.name) != modelMaterials.end())
      continue;
    std::string known;
    for (const std::string& name : modelMaterials) known += (known.empty() ? "" : ", ") + name;
    throw InputError(scene.source + ": bodies[" + std::to_string(bodyIndex) + "].materials." +
                     m.name + ": model '" + body.model + "' has no material '" + m.name +
                     "' (it has: " + known + ")");
  }
}

}  // namespace voxcut

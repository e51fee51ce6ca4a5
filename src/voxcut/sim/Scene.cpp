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
  if (!(t >= keys.front().t)) return checked(keys.front()).pose;  // also NaN: the first pose
  if (t >= keys.back().t) return checked(keys.back()).pose;
  // First key strictly after t; keys.front().t <= t < keys.back().t, so 1 <= k < size (of
  // keys sharing a time, the one before `next` is the last: a jump's pose from its time on).
  const auto next = std::upper_bound(keys.begin(), keys.end(), t,
                                     [](double time, const ToolKey& key) { return time < key.t; });
  const ToolKey& k1 = checked(*next);
  const ToolKey& k0 = checked(*(next - 1));
  if (t == k0.t || k1.jump) return k0.pose;
  const double s = (t - k0.t) / (k1.t - k0.t);
  return {k0.pose.a + s * (k1.pose.a - k0.pose.a), k0.pose.b + s * (k1.pose.b - k0.pose.b)};
}

BladePose bladePoseBefore(const std::vector<ToolKey>& keys, double t) {
  VOXCUT_ASSERT(!keys.empty(), "a tool needs at least one key");
  // The first key at t or after: a jump at exactly t is not reached yet.
  const auto at = std::lower_bound(keys.begin(), keys.end(), t,
                                   [](const ToolKey& key, double time) { return key.t < time; });
  // Keys sharing a time are a key and the jumps after it: before them, the key's pose (or,
  // where a jump comes first, the pose it jumps from).
  if (at != keys.end() && at->t == t)
    return at->jump && at != keys.begin() ? (at - 1)->pose : at->pose;
  return bladePoseAt(keys, t);
}

const ToolKey* jumpIn(const std::vector<ToolKey>& keys, double t0, double t1) {
  const auto end = std::lower_bound(keys.begin(), keys.end(), t1,
                                    [](const ToolKey& key, double time) { return key.t < time; });
  for (auto k = end; k != keys.begin();) {
    --k;
    if (k->t < t0) break;
    if (k->jump) return &*k;
  }
  return nullptr;
}

bool keysInOrder(const std::vector<ToolKey>& keys) {
  if (keys.empty()) return false;
  for (std::size_t k = 1; k < keys.size(); ++k)
    if (!(keys[k - 1].t < keys[k].t || (keys[k].jump && keys[k - 1].t == keys[k].t))) return false;
  return true;
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

BodySettings bodySettings(const SceneBody& body) {
  BodySettings bs;
  bs.elementLevel = body.elementLevel;
  bs.finestLevel = body.finestLevel;
  bs.frontLevel = body.frontLevel;
  bs.surfaceLevel = body.surfaceLevel;
  bs.materials = body.materials;
  bs.fixed = body.fixed;
  return bs;
}

}  // namespace voxcut

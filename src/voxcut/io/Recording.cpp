#include "voxcut/io/Recording.h"

#include <nlohmann/json.hpp>

namespace voxcut {
namespace {

nlohmann::ordered_json vec(const Vec3d& v) {
  return {v.x(), v.y(), v.z()};
}

}  // namespace

std::string recordingText(const World& world) {
  nlohmann::ordered_json top;
  top["description"] = "voxcut tool recording";
  top["time_step"] = world.settings().timeStep;
  nlohmann::ordered_json tools = nlohmann::ordered_json::array();
  for (const ToolId t : world.tools()) {
    const bool probe = world.toolKind(t) == ToolKind::Probe;
    nlohmann::ordered_json tool;
    tool["type"] = probe ? "probe" : "blade";
    if (probe) tool["radius"] = world.toolRadius(t);
    std::vector<ToolKey> keys = world.recording(t);
    if (keys.empty()) keys.push_back({world.time(), world.toolPose(t)});
    // A probe is a sphere throughout, or a capsule throughout (docs/scenes.md).
    bool sphere = probe;
    for (const ToolKey& k : keys) sphere = sphere && k.pose.a == k.pose.b;
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const ToolKey& k : keys) {
      nlohmann::ordered_json key;
      key["t"] = k.t;
      if (k.jump) key["jump"] = true;
      if (sphere) {
        key["p"] = vec(k.pose.a);
      } else {
        key["a"] = vec(k.pose.a);
        key["b"] = vec(k.pose.b);
      }
      list.push_back(std::move(key));
    }
    tool["keys"] = std::move(list);
    tools.push_back(std::move(tool));
  }
  top["tools"] = std::move(tools);
  return top.dump(1) + "\n";
}

}  // namespace voxcut

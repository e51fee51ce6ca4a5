/// @file fuzz_scene.cpp
/// libFuzzer harness of the scene reader: the input is a scene file's text, parsed and
/// validated with parseScene. Relative mesh paths resolve against a folder that does not
/// exist, so every mesh model is a checked "no such file". InputError is the expected answer
/// to bad input; any other exception, a crash, a sanitizer report, a leak or a timeout is a
/// finding.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

#include "voxcut/core/Error.h"
#include "voxcut/io/SceneReader.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const voxcut::Scene scene =
        voxcut::parseScene(text, "fuzz.json", std::filesystem::path("/nonexistent/voxcut-fuzz"));
    for (const voxcut::SceneBody& body : scene.bodies) (void)voxcut::isBuiltinModelSpec(body.model);
  } catch (const voxcut::InputError&) {
    // Bad input, reported as the library promises.
  }
  return 0;
}

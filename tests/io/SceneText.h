#pragma once
/// @file SceneText.h
/// Scene JSON snippets and parse helpers shared by the scene reader's tests.

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "voxcut/core/Error.h"
#include "voxcut/io/SceneReader.h"

namespace voxcut::test {

/// Parses `text` as "scene.json" in the current directory.
inline Scene parse(const std::string& text) {
  return parseScene(text, "scene.json", std::filesystem::current_path());
}

/// The message of the InputError that parsing `text` throws; fails the test if none is.
inline std::string parseError(const std::string& text) {
  try {
    (void)parse(text);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError for " << text.substr(0, 200);
  return {};
}

/// Expects parsing `text` to fail with a one-line message that starts with
/// "scene.json: " + `start`.
inline void expectError(const std::string& text, const std::string& start) {
  const std::string msg = parseError(text);
  EXPECT_EQ(msg.rfind("scene.json: " + start, 0), 0u) << "message: " << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
}

/// A scene of one bunny whose body has the extra members `body` (JSON text after a comma).
inline std::string withBody(const std::string& body) {
  return R"({"bodies": [{"model": "bunny", )" + body + "}]}";
}

/// A scene with one bunny and the extra top-level members `top`.
inline std::string withTop(const std::string& top) {
  return R"({"bodies": [{"model": "bunny"}], )" + top + "}";
}

}  // namespace voxcut::test

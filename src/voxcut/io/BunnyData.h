#pragma once
/// @file BunnyData.h
/// The built-in bunny's OBJ text, compiled into the library from data/models/bunny.obj at
/// configure time (see src/voxcut/CMakeLists.txt and BunnyData.cpp.in).

#include <string_view>

namespace voxcut::detail {

/// Wavefront OBJ text in metres: 1839 vertices, 3674 triangles, closed, genus 0, y up.
/// Load it with readMeshFromMemory(kBunnyObj, "obj") or loadModel("bunny").
extern const std::string_view kBunnyObj;

}  // namespace voxcut::detail

#pragma once
/// @file SceneReader.h
/// Reads a JSON scene (format: docs/scenes.md) into a validated sim/Scene.h Scene, and loads a
/// body's model the way a scene means it.
///
/// Every error is an InputError of one line that starts with the scene's name as given and,
/// for a bad value, the key path of the value, e.g.
///   "scene.json: bodies[0].materials.tumor.poisson_ratio: must be in [0, 0.5), got 0.7".
/// Thread-safety: all functions are reentrant and share no state.

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "voxcut/io/ModelSource.h"
#include "voxcut/sim/Scene.h"

namespace voxcut {

/// The largest scene file readScene reads, bytes (64 MiB; the shipped scenes are about 2 KiB).
inline constexpr std::size_t kMaxSceneFileBytes = std::size_t{64} << 20;

/// The deepest nesting of lists and objects a scene may have (the format itself needs 7:
/// a fixed box's corner).
inline constexpr std::size_t kMaxSceneDepth = 64;

/// Reads and validates the scene file at `path`: readSceneText, then parseScene. Relative
/// mesh paths in `model` and in mesh obstacles' `path` are resolved against the file's
/// folder. Scene::source is set to `path` as given. A mesh obstacle's file is read here
/// (io/MeshReader.h) and its signed distance built (collision/MeshDistance.h); body models
/// are loaded later (loadBodyModel).
/// Throws InputError for a missing, unreadable, irregular or oversized file, nesting deeper
/// than kMaxSceneDepth, a JSON syntax error (with line and column), an unknown key anywhere,
/// a missing required key, a value of the wrong type or out of range (coordinates within
/// core/CoordinateRange.h's range), a mesh file that does not exist, and an obstacle mesh
/// that cannot be read or has no non-degenerate triangle (see docs/scenes.md for every rule).
/// Time and memory are linear in the size of the file, plus building the obstacle meshes'
/// signed distances.
[[nodiscard]] Scene readScene(const std::string& path);

/// The bytes of the scene file at `path`. Throws InputError for a path that does not exist,
/// is a directory or is not a regular file (a device such as /dev/zero, a FIFO, a socket:
/// they are never opened, so none can block or stream without end), and for a file larger
/// than kMaxSceneFileBytes, checked on its size before reading and again while reading (at
/// most kMaxSceneFileBytes + 1 bytes are read).
[[nodiscard]] std::string readSceneText(const std::string& path);

/// Parses and validates the scene JSON `text`. `source` names it in messages (and becomes
/// Scene::source); relative mesh paths are resolved against `baseDir` (made absolute against
/// the current directory if relative). Throws InputError as readScene does.
[[nodiscard]] Scene parseScene(std::string_view text, const std::string& source,
                               const std::filesystem::path& baseDir);

/// Whether `model` names a built-in model or primitive of loadModel (bunny, liver, starfish,
/// box..., sphere...) rather than a mesh file.
[[nodiscard]] bool isBuiltinModelSpec(std::string_view model);

/// Loads the model of scene.bodies[bodyIndex] for simulation: loadModel(body.model), or the
/// label volume body.volume holds in memory when it is set (checked as a file's would be); a mesh
/// file's single material is renamed "default" (the name scenes use for it); every material
/// mesh is translated by body.offset (metres) and must then lie within the coordinate range
/// (core/CoordinateRange.h); then checkMaterialNames. Errors of loadModel come back prefixed
/// with the key path, e.g. "scene.json: bodies[0].model: ...".
/// Asserts that bodyIndex is in range. Thread-safe.
[[nodiscard]] Model loadBodyModel(const Scene& scene, std::size_t bodyIndex);

}  // namespace voxcut

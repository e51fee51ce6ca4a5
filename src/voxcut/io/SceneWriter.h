#pragma once
/// @file SceneWriter.h
/// Writes a sim/Scene.h Scene as the JSON text of a scene file (format: docs/scenes.md,
/// "Writing scenes"): what an application saves so that `voxcut run` replays it.
///
/// Thread-safety: reentrant, no shared state.

#include <filesystem>
#include <string>

#include "voxcut/sim/Scene.h"

namespace voxcut {

/// The scene file text of `scene`, such that parseScene(sceneText(scene, dir), name, dir)
/// (io/SceneReader.h) gives back a Scene equal to `scene` in every field but `source` (which
/// becomes `name`): numbers are written in the shortest form that reads back to the same
/// double, keys in the order the reader keeps (materials and labels in their order), every
/// setting written except optional ones that are unset or at their "unset" value (a body's
/// resolution, levels of -1, empty lists, a probe's or obstacle's negative friction, a zero
/// offset). A tool played from a recording is written with its keys; a probe whose every key
/// has a == b gets "p" keys, any other probe or blade "a" and "b".
///
/// Paths (a body's model that is a file, its label_names, a mesh obstacle's path) that lie
/// under `baseDir` (made absolute and normalised; none when empty) are written relative to it,
/// others absolute (a relative path in `scene` is taken against the current directory). The
/// reader resolves them against the folder it is given, so the text is meant to be saved in
/// `baseDir`. A relative path that would read as a built-in model (a file named "bunny") is
/// written absolute.
///
/// Throws InputError naming the key path (e.g. "obstacles[2].path: ...") for what the format
/// cannot hold: a non-finite number, a mesh obstacle without a file path (Obstacle::path), a
/// body holding an in-memory volume (SceneBody::volume; write it with io/VolumeWriter.h and
/// name the file), labels, min_island or label_names on a body whose model is no label
/// volume path, an empty or repeated material name, a label value chosen twice, a blade with
/// a radius or friction, contact.keepSelfCandidates off (no key), and a string that is not
/// valid UTF-8. Values the reader would refuse for their range are not checked here. Linear
/// in the size of the scene.
[[nodiscard]] std::string sceneText(const Scene& scene, const std::filesystem::path& baseDir = {});

}  // namespace voxcut

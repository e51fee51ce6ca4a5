/// @file fuzz_mesh.cpp
/// libFuzzer harness of one mesh reader: the input is a file of the format
/// VOXCUT_FUZZ_MESH_FORMAT ("obj", "stl", "ply" or "off"), read with readMeshFromMemory. A mesh
/// that reads is then repaired and voxelized at a tiny resolution, serially, as `voxcut info`
/// would voxelize it. InputError is the expected answer to bad input; any other exception, a
/// crash, a sanitizer report, a leak or a timeout is a finding.

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "voxcut/core/Error.h"
#include "voxcut/io/MeshReader.h"
#include "voxcut/voxel/Voxelizer.h"

#ifndef VOXCUT_FUZZ_MESH_FORMAT
#error "compile with -DVOXCUT_FUZZ_MESH_FORMAT=\"obj\" (or stl, ply, off)"
#endif

namespace {

// Voxels along the longest side: big enough for interior voxels and links of every kind,
// small enough that voxelizing costs little next to reading.
constexpr int kResolution = 10;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    voxcut::TriangleMesh mesh = voxcut::readMeshFromMemory(bytes, VOXCUT_FUZZ_MESH_FORMAT);
    voxcut::VoxelizeParams params;
    params.resolution.resolution = kResolution;
    params.threaded = false;
    const voxcut::VoxelGrid grid = voxcut::voxelize({{"default", std::move(mesh)}}, params);
    (void)grid;
  } catch (const voxcut::InputError&) {
    // Bad input, reported as the library promises.
  }
  return 0;
}

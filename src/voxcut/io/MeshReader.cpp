#include "voxcut/io/MeshReader.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <array>
#include <assimp/Importer.hpp>
#include <bit>
#include <climits>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string_view>
#include <unordered_map>

#include "voxcut/core/Error.h"

namespace voxcut {
namespace {

// Triangulate polygons, bake node transforms into one coordinate frame, split meshes by
// primitive type, and validate the imported data first (without validation an out-of-range
// index in a PLY file is read out of bounds by later steps).
//
// aiProcess_JoinIdenticalVertices is deliberately not used: it runs before we could look at
// the coordinates and merges a NaN vertex into a finite one (NaN compares as "close"), hiding
// bad input; and it only joins vertices that also share normals within one mesh, so an STL
// soup stays a soup. weldedMesh() below welds exact positions across all meshes instead.
// No step that fixes normals, winding or degenerate faces is enabled.
constexpr unsigned kImportFlags = aiProcess_Triangulate | aiProcess_PreTransformVertices |
                                  aiProcess_SortByPType | aiProcess_ValidateDataStructure;

/// Assimp's error text on one line: control characters become spaces, runs collapse.
std::string oneLine(std::string_view text) {
  std::string out;
  for (const char c : text) {
    const bool space = c == '\n' || c == '\r' || c == '\t' || c == ' ';
    if (space) {
      if (!out.empty() && out.back() != ' ') out.push_back(' ');
    } else {
      out.push_back(c);
    }
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out.empty() ? std::string("unknown error") : out;
}

/// Exact position as a hash key; -0 is folded into +0 so that equal values weld.
struct PositionKey {
  std::array<std::uint64_t, 3> bits;
  friend bool operator==(const PositionKey&, const PositionKey&) = default;
};

struct PositionKeyHash {
  std::size_t operator()(const PositionKey& k) const {
    std::uint64_t h = 0x9e3779b97f4a7c15ULL;
    for (const std::uint64_t b : k.bits) {
      h ^= b + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
      h *= 0xff51afd7ed558ccdULL;
      h ^= h >> 33;
    }
    return static_cast<std::size_t>(h);
  }
};

PositionKey keyOf(const Vec3d& p) {
  return {{std::bit_cast<std::uint64_t>(p.x() + 0.0), std::bit_cast<std::uint64_t>(p.y() + 0.0),
           std::bit_cast<std::uint64_t>(p.z() + 0.0)}};
}

/// Merges the triangles of every mesh of `scene` into one mesh, welding equal positions.
/// `what` names the source in error messages ("mesh file 'x.obj'").
TriangleMesh weldedMesh(const aiScene& scene, const std::string& what) {
  std::size_t triangles = 0;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[m];
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D& p = mesh.mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        throw InputError(what + " has a non-finite vertex coordinate (NaN or infinity)");
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f)
      if (mesh.mFaces[f].mNumIndices == 3) ++triangles;
  }
  if (triangles == 0) throw InputError(what + " has no triangles");
  if (triangles > static_cast<std::size_t>(INT_MAX) / 3)
    throw InputError(what + " has too many triangles (" + std::to_string(triangles) + ")");

  TriangleMesh out;
  out.faces.reserve(triangles);
  std::unordered_map<PositionKey, int, PositionKeyHash> ids;
  ids.reserve(triangles);
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[m];
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines
      std::array<int, 3> tri{};
      for (int k = 0; k < 3; ++k) {
        const unsigned index = face.mIndices[k];
        if (index >= mesh.mNumVertices) throw InputError(what + " has a vertex index out of range");
        const aiVector3D& p = mesh.mVertices[index];
        const Vec3d position(static_cast<double>(p.x), static_cast<double>(p.y),
                             static_cast<double>(p.z));
        const auto [it, inserted] =
            ids.try_emplace(keyOf(position), static_cast<int>(out.vertices.size()));
        if (inserted) out.vertices.push_back(position);
        tri[k] = it->second;
      }
      out.faces.push_back(tri);
    }
  }
  return out;
}

/// Turns the importer's result into a mesh, or its failure into an InputError.
TriangleMesh meshFromImport(const aiScene* scene, const Assimp::Importer& importer,
                            const std::string& what) {
  if (scene == nullptr) {
    const std::string reason = oneLine(importer.GetErrorString());
    // Assimp reports a file without faces in several ways, depending on the importer and on
    // the step that notices; say what it means, keeping assimp's words.
    for (const char* noFaces :
         {"No output meshes", "contains no faces", "contains no vertices", "no valid faces"})
      if (reason.find(noFaces) != std::string::npos)
        throw InputError(what + " has no triangles (" + reason + ")");
    throw InputError("cannot read " + what + ": " + reason);
  }
  return weldedMesh(*scene, what);
}

}  // namespace

TriangleMesh readMesh(const std::string& path) {
  namespace fs = std::filesystem;
  const std::string what = "mesh file '" + path + "'";
  // Checked here because assimp's own messages for these cases are vague.
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (status.type() == fs::file_type::none)  // an error other than "not found"
    throw InputError(what + " cannot be accessed (" + ec.message() + ")");
  if (!fs::exists(status)) throw InputError(what + " does not exist");
  if (fs::is_directory(status)) throw InputError(what + " is a directory");
  if (!fs::is_regular_file(status)) throw InputError(what + " is not a regular file");
  if (!std::ifstream(path, std::ios::binary)) throw InputError(what + " cannot be opened");
  if (fs::file_size(path, ec) == 0 && !ec) throw InputError(what + " is empty");

  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, kImportFlags);
  return meshFromImport(scene, importer, what);
}

TriangleMesh readMeshFromMemory(std::string_view data, const char* formatHint) {
  const std::string hint = formatHint != nullptr ? formatHint : "";
  const std::string what = "in-memory mesh (" + (hint.empty() ? std::string("?") : hint) + ")";
  if (data.empty()) throw InputError(what + " is empty");
  Assimp::Importer importer;
  const aiScene* scene =
      importer.ReadFileFromMemory(data.data(), data.size(), kImportFlags, hint.c_str());
  return meshFromImport(scene, importer, what);
}

}  // namespace voxcut

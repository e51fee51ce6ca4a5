#include "voxcut/io/MeshReader.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string_view>
#include <vector>

#include "voxcut/core/Error.h"
#include "voxcut/io/MeshFormats.h"

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

/// Merges the triangles of every mesh of `scene` into one mesh, welding equal positions.
/// `what` names the source in error messages ("mesh file 'x.obj'").
TriangleMesh weldedMesh(const aiScene& scene, const std::string& what) {
  meshio::RawMesh raw;
  std::vector<int> corners(3);
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[m];
    const std::size_t base = raw.vertexCount();
    if (mesh.mNumVertices > meshio::kMaxVertices - base)
      throw InputError(what + " has too many vertices");
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D& p = mesh.mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        throw InputError(what + " has a non-finite vertex coordinate (NaN or infinity)");
      raw.addVertex(
          Vec3d(static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z)));
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines
      for (int k = 0; k < 3; ++k) {
        const unsigned index = face.mIndices[k];
        if (index >= mesh.mNumVertices) throw InputError(what + " has a vertex index out of range");
        corners[static_cast<std::size_t>(k)] = static_cast<int>(base + index);
      }
      raw.addPolygon(corners);
    }
  }
  return raw.finish({{}, what});
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

/// The reader of our own for `format` (an extension without the dot, any case), or null when
/// assimp has to read it.
using FormatReader = TriangleMesh (*)(const meshio::MeshInput&);
FormatReader ownReader(std::string_view format) {
  std::string lower(format);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower == "obj") return &meshio::readObj;
  if (lower == "stl") return &meshio::readStl;
  if (lower == "ply") return &meshio::readPly;
  if (lower == "off") return &meshio::readOff;
  return nullptr;
}

/// The whole regular file at `path` (checked by the caller), or InputError naming `what`.
std::string fileBytes(const std::string& path, const std::string& what) {
  std::ifstream file(path, std::ios::binary);
  std::string bytes;
  char buffer[1 << 16];
  while (file.read(buffer, sizeof buffer) || file.gcount() > 0)
    bytes.append(buffer, static_cast<std::size_t>(file.gcount()));
  if (file.bad()) throw InputError(what + " could not be read");
  return bytes;
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

  std::string extension = fs::path(path).extension().string();
  if (!extension.empty()) extension.erase(0, 1);
  if (const FormatReader reader = ownReader(extension)) {
    const std::string bytes = fileBytes(path, what);
    if (bytes.empty()) throw InputError(what + " is empty");
    return reader({bytes, what});
  }
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, kImportFlags);
  return meshFromImport(scene, importer, what);
}

TriangleMesh readMeshFromMemory(std::string_view data, const char* formatHint) {
  const std::string hint = formatHint != nullptr ? formatHint : "";
  const std::string what = "in-memory mesh (" + (hint.empty() ? std::string("?") : hint) + ")";
  if (data.empty()) throw InputError(what + " is empty");
  if (const FormatReader reader = ownReader(hint)) return reader({data, what});
  Assimp::Importer importer;
  const aiScene* scene =
      importer.ReadFileFromMemory(data.data(), data.size(), kImportFlags, hint.c_str());
  return meshFromImport(scene, importer, what);
}

}  // namespace voxcut

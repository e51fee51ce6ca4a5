#include "voxcut/io/SurfaceWriter.h"

// Written directly rather than through Assimp::Exporter (which MeshReader's assimp would
// offer): assimp's OBJ exporter is slow, renumbers the vertices (breaking the match with
// SurfaceMesh::vertexVoxel and between frames) and prints floats with artifacts
// (0.00100000005); its binary PLY needs an aiScene, materials and nodes built around one
// heap-allocated index array per triangle just to pass the data through. Both formats are a
// few lines each; the writers below keep vertex order, print OBJ doubles exactly (shortest
// round-trip decimals from std::to_chars) and are faster than assimp's (docs/performance.md,
// "Surface").

#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <system_error>

#include "voxcut/core/Error.h"

namespace voxcut {
namespace {

/// Bytes gathered before each write to the stream.
constexpr std::size_t kChunk = std::size_t{1} << 20;

void flushIfFull(std::string& buffer, std::ostream& out) {
  if (buffer.size() < kChunk) return;
  out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  buffer.clear();
}

void flushAll(std::string& buffer, std::ostream& out) {
  out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  buffer.clear();
}

/// Appends the shortest decimal that reads back as exactly `value`.
void appendNumber(std::string& buffer, double value) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  buffer.append(text, result.ptr);
}

void appendNumber(std::string& buffer, int value) {
  char text[16];
  const auto result = std::to_chars(text, text + sizeof text, value);
  buffer.append(text, result.ptr);
}

void appendVector(std::string& buffer, const char* tag, const Vec3d& v) {
  buffer += tag;
  for (int k = 0; k < 3; ++k) {
    buffer += ' ';
    appendNumber(buffer, v[k]);
  }
  buffer += '\n';
}

// Whether triangles are written grouped by material: names given and one tag per triangle.
bool grouped(const SurfaceMesh& mesh, const std::vector<std::string>& names) {
  return !names.empty() && mesh.triangleTags.size() == mesh.triangles.size();
}

// The material name of tag value m (names[m - 1]), or "material_m" beyond the names.
std::string materialName(const std::vector<std::string>& names, int m) {
  return m >= 1 && static_cast<std::size_t>(m) <= names.size()
             ? names[static_cast<std::size_t>(m - 1)]
             : "material_" + std::to_string(m);
}

void writeObj(const SurfaceMesh& mesh, const std::vector<std::string>& names, std::ostream& out) {
  const bool normals = !mesh.normals.empty();
  std::string buffer;
  buffer.reserve(kChunk + 256);
  buffer += "# voxcut surface: " + std::to_string(mesh.positions.size()) + " vertices, " +
            std::to_string(mesh.triangles.size()) + " triangles\n";
  for (const Vec3d& p : mesh.positions) {
    appendVector(buffer, "v", p);
    flushIfFull(buffer, out);
  }
  for (const Vec3d& n : mesh.normals) {
    appendVector(buffer, "vn", n);
    flushIfFull(buffer, out);
  }
  const auto face = [&](const std::array<int, 3>& t) {
    buffer += 'f';
    for (const int v : t) {
      buffer += ' ';
      appendNumber(buffer, v + 1);
      if (normals) {
        buffer += "//";
        appendNumber(buffer, v + 1);
      }
    }
    buffer += '\n';
    flushIfFull(buffer, out);
  };
  if (!grouped(mesh, names)) {
    for (const auto& t : mesh.triangles) face(t);
  } else {
    // One group per material, each with its triangles in the mesh's order.
    for (int m = 0; m < 256; ++m) {
      bool any = false;
      for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        if (mesh.triangleTags[t].material != m) continue;
        if (!any) buffer += "g " + materialName(names, m) + "\n";
        any = true;
        face(mesh.triangles[t]);
      }
    }
  }
  flushAll(buffer, out);
}

/// Appends `value`'s bytes in little-endian order.
template <class T>
void appendLittleEndian(std::string& buffer, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  buffer.append(bytes, sizeof(T));
}

void writePly(const SurfaceMesh& mesh, const std::vector<std::string>& names, std::ostream& out) {
  const bool normals = !mesh.normals.empty();
  const bool materials = grouped(mesh, names);
  std::string buffer;
  buffer.reserve(kChunk + 256);
  buffer += "ply\nformat binary_little_endian 1.0\ncomment voxcut surface\n";
  if (materials)
    for (std::size_t m = 0; m < names.size(); ++m)
      buffer += "comment material " + std::to_string(m + 1) + " " + names[m] + "\n";
  buffer += "element vertex " + std::to_string(mesh.positions.size()) + "\n";
  buffer += "property float x\nproperty float y\nproperty float z\n";
  if (normals) buffer += "property float nx\nproperty float ny\nproperty float nz\n";
  buffer += "element face " + std::to_string(mesh.triangles.size()) + "\n";
  buffer += "property list uchar int vertex_indices\n";
  if (materials) buffer += "property uchar material\n";
  buffer += "end_header\n";
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    for (int k = 0; k < 3; ++k)
      appendLittleEndian(buffer, static_cast<float>(mesh.positions[i][k]));
    if (normals)
      for (int k = 0; k < 3; ++k)
        appendLittleEndian(buffer, static_cast<float>(mesh.normals[i][k]));
    flushIfFull(buffer, out);
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    appendLittleEndian(buffer, std::uint8_t{3});
    for (const int v : mesh.triangles[i]) appendLittleEndian(buffer, static_cast<std::int32_t>(v));
    if (materials) appendLittleEndian(buffer, mesh.triangleTags[i].material);
    flushIfFull(buffer, out);
  }
  flushAll(buffer, out);
}

using FormatWriter = void (*)(const SurfaceMesh&, const std::vector<std::string>&,
                              std::ostream&);

/// The writer for `path`'s extension, or nullptr.
FormatWriter writerFor(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".obj") return writeObj;
  if (extension == ".ply") return writePly;
  return nullptr;
}

}  // namespace

void checkSurfacePath(const std::string& path) {
  namespace fs = std::filesystem;
  const std::string what = "cannot write surface '" + path + "': ";
  if (writerFor(path) == nullptr)
    throw InputError(what + "unknown extension '" + fs::path(path).extension().string() +
                     "' (use .obj or .ply)");
  std::error_code ec;
  const fs::path parent =
      fs::path(path).parent_path().empty() ? fs::path(".") : fs::path(path).parent_path();
  if (!fs::is_directory(parent, ec))
    throw InputError(what + "directory '" + parent.string() + "' does not exist");
  if (fs::is_directory(path, ec)) throw InputError(what + "it is a directory");
  // The temporary is created beside the file.
  if (::access(parent.c_str(), W_OK | X_OK) != 0)
    throw InputError(what + "cannot create files in directory '" + parent.string() + "' (" +
                     std::generic_category().message(errno) + ")");
}

SurfaceMesh materialPart(const SurfaceMesh& mesh, std::uint8_t material) {
  VOXCUT_ASSERT(mesh.triangleTags.size() == mesh.triangles.size(),
                "materialPart needs one tag per triangle");
  SurfaceMesh part;
  std::vector<int> index(mesh.positions.size(), -1);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (mesh.triangleTags[t].material != material) continue;
    std::array<int, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      const auto v = static_cast<std::size_t>(mesh.triangles[t][static_cast<std::size_t>(k)]);
      if (index[v] < 0) {
        index[v] = static_cast<int>(part.positions.size());
        part.positions.push_back(mesh.positions[v]);
        if (!mesh.normals.empty()) part.normals.push_back(mesh.normals[v]);
        if (!mesh.vertexVoxel.empty()) part.vertexVoxel.push_back(mesh.vertexVoxel[v]);
      }
      tri[static_cast<std::size_t>(k)] = index[v];
    }
    part.triangles.push_back(tri);
    part.triangleTags.push_back(mesh.triangleTags[t]);
  }
  return part;
}

void writeSurface(const SurfaceMesh& mesh, const std::string& path,
                  const std::vector<std::string>& materialNames) {
  namespace fs = std::filesystem;
  VOXCUT_ASSERT(mesh.normals.empty() || mesh.normals.size() == mesh.positions.size(),
                "a surface needs one normal per position, or none");
  const int vertexCount = static_cast<int>(mesh.positions.size());
  VOXCUT_ASSERT(std::all_of(mesh.triangles.begin(), mesh.triangles.end(),
                            [&](const std::array<int, 3>& t) {
                              return std::all_of(t.begin(), t.end(),
                                                 [&](int v) { return v >= 0 && v < vertexCount; });
                            }),
                "surface triangle index out of range");

  const std::string what = "cannot write surface '" + path + "': ";
  checkSurfacePath(path);
  const FormatWriter write = writerFor(path);
  std::error_code ec;
  const std::string temporary = path + ".tmp";
  std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
  if (!out)
    throw InputError(what + "cannot create '" + temporary + "' (" +
                     std::generic_category().message(errno) + ")");
  try {
    write(mesh, materialNames, out);
    out.close();
    if (!out) throw InputError(what + "writing '" + temporary + "' failed (disk full?)");
    fs::rename(temporary, path, ec);
    if (ec) throw InputError(what + "cannot rename '" + temporary + "' (" + ec.message() + ")");
  } catch (...) {
    out.close();
    fs::remove(temporary, ec);
    throw;
  }
}

}  // namespace voxcut

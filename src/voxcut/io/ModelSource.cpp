#include "voxcut/io/ModelSource.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string_view>

#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/BunnyData.h"
#include "voxcut/io/MeshReader.h"
#include "voxcut/io/StrictJson.h"
#include "voxcut/io/VolumeReader.h"
#include "voxcut/voxel/BuiltinModels.h"

namespace voxcut {
namespace {

constexpr std::string_view kBoxPrefix = "box:";
constexpr std::string_view kSpherePrefix = "sphere:";
constexpr int kSphereSubdivisions = 5;
// Voxels along the longest side: the paper's grids for the liver (100x62x88) and the starfish
// (180x166x30); 101 for every other model.
constexpr int kDefaultResolution = 101;
constexpr int kLiverResolution = 100;
constexpr int kStarfishResolution = 180;

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

/// Parses the comma-separated sizes after a primitive's prefix: exactly `count` numbers, each
/// positive and finite (metres). `form` is the primitive's syntax for messages.
std::vector<double> parseSizes(const std::string& spec, std::string_view list, std::size_t count,
                               std::string_view form) {
  const std::string bad = "bad model '" + spec + "': ";
  std::vector<double> sizes;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = list.find(',', start);
    const std::string_view field =
        trimmed(list.substr(start, comma == std::string_view::npos ? comma : comma - start));
    double value = 0.0;
    const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
    const bool whole = !field.empty() && end == field.data() + field.size();
    if (!whole || (ec != std::errc() && ec != std::errc::result_out_of_range))
      throw InputError(bad + "'" + std::string(field) + "' is not a number (expected " +
                       std::string(form) + " in metres)");
    if (ec == std::errc::result_out_of_range || !isLength(value))
      throw InputError(bad + "sizes must be in " + kLengthRangeText + ", got '" +
                       std::string(field) + "'");
    sizes.push_back(value);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (sizes.size() != count)
    throw InputError(bad + std::string(form) + " takes " + std::to_string(count) +
                     (count == 1 ? " number" : " numbers") + ", got " +
                     std::to_string(sizes.size()));
  return sizes;
}

/// A model of the given meshes (none yet: filled by the caller).
Model meshModel(std::string name, std::vector<MaterialMesh> materials, int resolution) {
  Model model;
  model.name = std::move(name);
  model.materials = std::move(materials);
  model.defaultResolution = resolution;
  return model;
}

/// A model of one material named "default".
Model singleMaterial(std::string name, TriangleMesh mesh, int resolution) {
  Model model = meshModel(std::move(name), {}, resolution);
  model.materials.push_back({"default", std::move(mesh)});
  return model;
}

/// The file name without its volume extensions (.nii.gz, .seg.nrrd, ...).
std::string volumeStem(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  for (const char* ext : {".gz", ".nii", ".nrrd", ".nhdr", ".seg", ".mha", ".mhd"}) {
    const std::string e = ext;
    if (name.size() > e.size()) {
      std::string tail = name.substr(name.size() - e.size());
      std::transform(tail.begin(), tail.end(), tail.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (tail == e) name.resize(name.size() - e.size());
    }
  }
  return name.empty() ? "volume" : name;
}

}  // namespace

std::vector<LabelChoice> parseLabelList(const std::string& text, const std::string& what) {
  if (trimmed(text) == "all") return {};
  std::vector<LabelChoice> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    const std::string_view item = trimmed(std::string_view(text).substr(
        start, comma == std::string::npos ? std::string::npos : comma - start));
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos)
      throw InputError(what + ": '" + detail::oneLine(item) +
                       "' is not VALUE=NAME (e.g. 255=liver,85=tumor, or all)");
    const std::string_view number = trimmed(item.substr(0, eq));
    const std::string_view name = trimmed(item.substr(eq + 1));
    std::int64_t value = 0;
    const auto [end, ec] = std::from_chars(number.data(), number.data() + number.size(), value);
    if (number.empty() || ec != std::errc() || end != number.data() + number.size())
      throw InputError(what + ": label value '" + detail::oneLine(number) +
                       "' is not an integer");
    if (name.empty())
      throw InputError(what + ": label " + std::to_string(value) + " has an empty name");
    out.push_back({value, std::string(name)});
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

void applyLabelNames(LabelVolume& volume, const std::string& path) {
  const std::string what = detail::oneLine(path);
  std::ifstream in(path);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec) || !in)
    throw InputError(what + ": label names file cannot be read");
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();  // CRLF files (aal.nii.txt)
    const std::string_view t = trimmed(line);
    if (t.empty() || t.front() == '#') continue;
    std::istringstream fields{std::string(t)};
    std::int64_t value = 0;
    std::string name;
    if (!(fields >> value >> name))
      throw InputError(what + ", line " + std::to_string(number) +
                       ": expected 'VALUE NAME', got '" + detail::oneLine(t.substr(0, 60)) + "'");
    for (LabelInfo& l : volume.labels)
      if (l.value == value) l.name = name;
  }
}

std::vector<std::string> builtinModelNames() {
  return {"bunny", "liver", "starfish"};
}

Model loadModel(const std::string& spec, const ModelLoadParams& params) {
  if (spec == "bunny")
    return singleMaterial("bunny", readMeshFromMemory(detail::kBunnyObj, "obj"),
                          kDefaultResolution);
  if (spec == "liver") return meshModel("liver", makeLiver(), kLiverResolution);
  if (spec == "starfish") return meshModel("starfish", makeStarfish(), kStarfishResolution);

  const std::string_view view = spec;
  if (view.starts_with(kBoxPrefix)) {
    const auto s = parseSizes(spec, view.substr(kBoxPrefix.size()), 3, "box:LX,LY,LZ");
    return singleMaterial("box", makeBox(Vec3d(s[0], s[1], s[2])), kDefaultResolution);
  }
  if (view.starts_with(kSpherePrefix)) {
    const auto s = parseSizes(spec, view.substr(kSpherePrefix.size()), 1, "sphere:R");
    return singleMaterial("sphere", makeSphere(s[0], kSphereSubdivisions), kDefaultResolution);
  }

  std::error_code ec;
  if (!spec.empty() && isVolumePath(spec) && std::filesystem::exists(spec, ec)) {
    VolumeReadParams rp;
    rp.maxMemory = params.maxMemory;
    LabelVolume volume = readLabelVolume(spec, rp);
    if (!params.labelNames.empty()) applyLabelNames(volume, params.labelNames);
    Model model = meshModel(volumeStem(spec), {}, kDefaultResolution);
    model.volume = std::make_shared<const LabelVolume>(std::move(volume));
    return model;
  }
  if (!spec.empty() && std::filesystem::exists(spec, ec)) {
    std::string stem = std::filesystem::path(spec).stem().string();
    if (stem.empty()) stem = "default";
    TriangleMesh mesh = readMesh(spec);
    Model model = meshModel(stem, {}, kDefaultResolution);
    model.materials.push_back({std::move(stem), std::move(mesh)});
    return model;
  }
  if (spec == "box" || spec == "sphere")
    throw InputError("model '" + spec + "' needs its size in metres: " +
                     (spec == "box" ? "box:LX,LY,LZ" : "sphere:R"));
  throw InputError("unknown model '" + spec +
                   "': not a built-in (bunny, liver, starfish, box:LX,LY,LZ, sphere:R) and no "
                   "such file");
}

Model loadMaterials(const std::vector<std::pair<std::string, std::string>>& nameAndMesh) {
  if (nameAndMesh.empty()) throw InputError("no materials given");
  Model model = meshModel("", {}, 0);
  for (const auto& [name, spec] : nameAndMesh) {
    if (name.empty()) throw InputError("material for model '" + spec + "' has an empty name");
    // An init-capture, since clang before 16 cannot capture a structured binding.
    const bool repeated = std::any_of(model.materials.begin(), model.materials.end(),
                                      [&n = name](const MaterialMesh& m) { return m.name == n; });
    if (repeated) throw InputError("material '" + name + "' is given twice");
    Model part = loadModel(spec);
    if (part.materials.size() != 1)
      throw InputError("material '" + name + "': model '" + spec + "' has " +
                       std::to_string(part.materials.size()) + " materials, not one");
    model.materials.push_back({name, std::move(part.materials.front().mesh)});
    model.name += (model.name.empty() ? "" : "+") + name;
    model.defaultResolution = std::max(model.defaultResolution, part.defaultResolution);
  }
  return model;
}

void requireVoxels(const VoxelGrid& grid, const std::string& subject) {
  for (std::size_t v = 0; v < grid.voxelCount(); ++v)
    if (grid.occupied(v)) return;
  const Index3& d = grid.dims();
  const int resolution = std::max({d.x, d.y, d.z});
  char size[32];
  std::snprintf(size, sizeof size, "%.3g", grid.voxelSize());
  throw InputError(subject + ": voxelizes to no voxels at resolution " +
                   std::to_string(resolution) + " (voxel size " + size +
                   " m): its surface encloses no voxel centre (an open or flat surface, or a "
                   "model thinner than a voxel; try a finer resolution)");
}

}  // namespace voxcut

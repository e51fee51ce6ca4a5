#include "voxcut/io/SegmentationMetadata.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <map>
#include <set>
#include <string_view>
#include <unordered_map>

#include "voxcut/core/Error.h"
#include "voxcut/io/MeshParse.h"
#include "voxcut/io/VolumeData.h"

namespace voxcut::volumeio {
namespace {

constexpr int kMaxSegmentNumber = 1000000;
constexpr std::size_t kMaxNameChars = 256;
constexpr std::size_t kMaxNamesListed = 5;

// A name from the file as a label name: UTF-8 kept, control bytes replaced, length bounded.
std::string nameText(std::string_view value) {
  std::string out;
  for (const char ch : trimmed(value).substr(0, kMaxNameChars)) {
    const auto c = static_cast<unsigned char>(ch);
    out += (c < 0x20 || c == 0x7f) ? '?' : ch;
  }
  return out;
}

// "Segment12_Name" -> (12, "Name"); nullopt for any other key.
std::optional<std::pair<int, std::string_view>> segmentKey(std::string_view key) {
  constexpr std::string_view kPrefix = "Segment";
  if (key.substr(0, kPrefix.size()) != kPrefix) return std::nullopt;
  std::size_t p = kPrefix.size();
  int number = 0;
  const std::size_t firstDigit = p;
  while (p < key.size() && key[p] >= '0' && key[p] <= '9') {
    number = number * 10 + (key[p] - '0');
    if (number > kMaxSegmentNumber) return std::nullopt;
    ++p;
  }
  if (p == firstDigit || p >= key.size() || key[p] != '_') return std::nullopt;
  return std::pair<int, std::string_view>{number, key.substr(p + 1)};
}

// How a warning names a segment: its name, else its key prefix.
std::string describe(const Segment& s) {
  if (!s.name.empty()) return "'" + escaped(s.name, 40) + "'";
  return "Segment" + std::to_string(s.number);
}

// One warning line naming the segments left without voxels.
std::string droppedWarning(const std::vector<const Segment*>& dropped) {
  std::string line = "segments with no voxel, not kept as labels: ";
  for (std::size_t k = 0; k < dropped.size() && k < kMaxNamesListed; ++k)
    line += (k ? ", " : "") + describe(*dropped[k]);
  if (dropped.size() > kMaxNamesListed)
    line += " and " + std::to_string(dropped.size() - kMaxNamesListed) + " more";
  return line;
}

std::optional<std::array<float, 3>> parseColour(std::string_view value) {
  std::vector<std::string_view> tokens;
  meshio::splitTokens(value, tokens);
  if (tokens.size() != 3) return std::nullopt;
  std::array<float, 3> rgb{};
  for (int c = 0; c < 3; ++c) {
    const std::optional<double> v = meshio::parseNumber(tokens[static_cast<std::size_t>(c)]);
    if (!v || !(*v >= 0.0 && *v <= 1.0)) return std::nullopt;
    rgb[static_cast<std::size_t>(c)] = static_cast<float>(*v);
  }
  return rgb;
}

}  // namespace

std::vector<Segment> parseSegments(const KeyValues& keyValues, int layers, const std::string& what,
                                   std::vector<std::string>& warnings) {
  std::map<int, Segment> byNumber;
  std::map<int, int> explicitLayer;
  for (const auto& [key, rawValue] : keyValues) {
    const auto parsed = segmentKey(key);
    if (!parsed) continue;
    const auto [number, property] = *parsed;
    const std::string_view value = trimmed(rawValue);
    Segment& s = byNumber[number];
    s.number = number;
    const std::string keyName = "Segment" + std::to_string(number) + "_" + std::string(property);
    if (property == "ID") {
      s.id = nameText(value);
    } else if (property == "Name") {
      s.name = nameText(value);
    } else if (property == "Color") {
      s.colour = parseColour(value);
      if (!s.colour)
        warnings.push_back("key " + keyName + " '" + escaped(value) +
                           "' is not three numbers in [0, 1]; colour ignored");
    } else if (property == "LabelValue") {
      const std::optional<std::int64_t> v = meshio::parseInteger(value);
      if (!v)
        throw InputError(what + ": key " + keyName + ": '" + escaped(value) +
                         "' is not an integer label value");
      s.labelValue = *v;
    } else if (property == "Layer") {
      const std::optional<std::int64_t> v = meshio::parseInteger(value);
      if (!v || *v < 0 || *v > INT_MAX)
        throw InputError(what + ": key " + keyName + ": '" + escaped(value) +
                         "' is not a layer number (a non-negative integer)");
      explicitLayer[number] = static_cast<int>(*v);
    }
  }
  std::vector<Segment> segments;
  for (auto& [number, s] : byNumber) {
    const auto layer = explicitLayer.find(number);
    // Without Segment{N}_Layer, older Slicer files store segment N alone in layer N.
    s.layer = layer != explicitLayer.end() ? layer->second : (layers > 1 ? number : 0);
    if (s.layer >= layers) {
      warnings.push_back("segment " + describe(s) + " is in layer " + std::to_string(s.layer) +
                         ", but the data have " + std::to_string(layers) +
                         (layers == 1 ? " layer" : " layers") + "; segment ignored");
      continue;
    }
    if (s.labelValue == 0) {
      warnings.push_back("segment " + describe(s) +
                         " has label value 0 (the background); segment ignored");
      continue;
    }
    segments.push_back(std::move(s));
  }
  return segments;
}

void nameLabels(LabelVolume& volume, const std::vector<Segment>& segments) {
  if (segments.empty()) return;
  std::unordered_map<std::int64_t, std::size_t> labelOf;
  for (std::size_t l = 0; l < volume.labels.size(); ++l) labelOf[volume.labels[l].value] = l;
  std::vector<const Segment*> owner(volume.labels.size(), nullptr);
  std::vector<const Segment*> dropped;
  for (const Segment& s : segments) {
    const auto it = labelOf.find(s.labelValue);
    if (s.layer != 0 || it == labelOf.end()) {
      dropped.push_back(&s);
      continue;
    }
    if (owner[it->second] != nullptr) {
      volume.warnings.push_back("segment " + describe(s) + " has the label value " +
                                std::to_string(s.labelValue) + " of segment " +
                                describe(*owner[it->second]) + "; segment ignored");
      continue;
    }
    owner[it->second] = &s;
    volume.labels[it->second].name = s.name;
    volume.labels[it->second].colour = s.colour;
  }
  if (!dropped.empty()) volume.warnings.push_back(droppedWarning(dropped));
  const auto unnamed = static_cast<std::size_t>(std::count(owner.begin(), owner.end(), nullptr));
  if (unnamed > 0)
    volume.warnings.push_back(std::to_string(unnamed) +
                              " label value(s) have no segment in the metadata; kept unnamed");
}

void setLabelsFromLayers(LabelVolume& volume, const void* data, int layers, SampleType type,
                         bool bigEndian, const std::vector<Segment>& segments,
                         const std::string& what) {
  VOXCUT_ASSERT(layers >= 2, "one-layer data go through setLabelsFromSamples");
  const std::size_t voxels = volume.voxelCount();
  const auto nLayers = static_cast<std::size_t>(layers);
  // Every sample as a compact value, read as a volume of dims (layers, nx*ny, nz); with two or
  // more layers, nx*ny is at most 2^30 (the reader caps samples at 2^31).
  LabelVolume samples;
  samples.dims = {layers, volume.dims.x * volume.dims.y, volume.dims.z};
  setLabelsFromSamples(samples, data, voxels * nLayers, type, bigEndian,
                       what + " (4-D samples numbered as (layer, i + nx*j, k))");

  // The (layer, value) pairs that occur, keyed layer * 2^16 + compact value. Runs of one value
  // in a layer are looked up once, through a small cache indexed by layer (fixed size, so that
  // a file with millions of layers costs no more memory than its samples).
  const auto keyOf = [](std::size_t layer, std::uint16_t slot) {
    return (static_cast<std::uint64_t>(layer) << 16) | slot;
  };
  constexpr std::size_t kCache = 64;
  std::unordered_map<std::uint64_t, std::uint32_t> rankOf;
  std::vector<std::uint64_t> pairs;
  {
    std::array<std::uint64_t, kCache> seen;
    seen.fill(UINT64_MAX);
    for (std::size_t s = 0; s < samples.index.size(); ++s) {
      const std::uint16_t slot = samples.index[s];
      if (slot == 0) continue;
      const std::uint64_t key = keyOf(s % nLayers, slot);
      std::uint64_t& cached = seen[(s % nLayers) % kCache];
      if (cached == key) continue;
      cached = key;
      if (rankOf.emplace(key, 0).second) pairs.push_back(key);
    }
  }
  if (pairs.size() > 65535)
    throw InputError(what + ": more than 65535 distinct (layer, value) pairs");

  // Rank: pairs no segment declares first, by (layer, value); then segments by number.
  std::map<std::pair<int, std::int64_t>, const Segment*> segmentOf;
  std::set<const Segment*> ignored;
  for (const Segment& s : segments) {
    if (segmentOf.emplace(std::pair{s.layer, s.labelValue}, &s).second) continue;
    ignored.insert(&s);
    volume.warnings.push_back(
        "segment " + describe(s) + " has the layer and label value of segment " +
        describe(*segmentOf.at({s.layer, s.labelValue})) + "; segment ignored");
  }
  struct Pair {
    int layer;
    std::int64_t value;
    const Segment* segment;
  };
  std::vector<Pair> ranked;
  for (const std::uint64_t key : pairs) {
    const auto layer = static_cast<int>(key >> 16);
    const std::int64_t value = samples.labels[(key & 0xffff) - 1].value;
    const auto it = segmentOf.find({layer, value});
    ranked.push_back({layer, value, it == segmentOf.end() ? nullptr : it->second});
  }
  std::vector<std::size_t> order(pairs.size());
  for (std::size_t r = 0; r < order.size(); ++r) order[r] = r;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const Pair& pa = ranked[a];
    const Pair& pb = ranked[b];
    if ((pa.segment != nullptr) != (pb.segment != nullptr)) return pb.segment != nullptr;
    if (pa.segment != nullptr) return pa.segment->number < pb.segment->number;
    return std::pair{pa.layer, pa.value} < std::pair{pb.layer, pb.value};
  });
  std::vector<Pair> byRank;
  for (std::size_t r = 0; r < order.size(); ++r) {
    rankOf[pairs[order[r]]] = static_cast<std::uint32_t>(r);
    byRank.push_back(ranked[order[r]]);
  }

  // Each voxel takes its highest-ranked non-zero layer (stored as rank + 1 for now).
  volume.index.assign(voxels, 0);
  std::vector<std::size_t> counts(byRank.size(), 0);
  std::size_t overlapping = 0;
  std::array<std::uint64_t, kCache> cachedKey;
  std::array<std::uint32_t, kCache> cachedRank{};
  cachedKey.fill(UINT64_MAX);
  for (std::size_t v = 0; v < voxels; ++v) {
    std::uint32_t best = 0;
    int nonZero = 0;
    for (std::size_t layer = 0; layer < nLayers; ++layer) {
      const std::uint16_t slot = samples.index[v * nLayers + layer];
      if (slot == 0) continue;
      ++nonZero;
      const std::uint64_t key = keyOf(layer, slot);
      const std::size_t c = layer % kCache;
      if (cachedKey[c] != key) {
        cachedKey[c] = key;
        cachedRank[c] = rankOf.at(key);
      }
      best = std::max(best, cachedRank[c] + 1);
    }
    if (nonZero > 1) ++overlapping;
    if (best == 0) continue;
    volume.index[v] = static_cast<std::uint16_t>(best);
    ++counts[best - 1];
  }
  std::vector<std::uint16_t>().swap(samples.index);

  // Labels for the pairs that hold voxels; values kept where unique, else renumbered above all.
  std::int64_t next = 1;
  for (std::size_t r = 0; r < byRank.size(); ++r)
    if (counts[r] > 0) next = std::max(next, byRank[r].value);
  if (next == INT64_MAX) throw InputError(what + ": label values too large to renumber layers");
  ++next;
  std::set<std::int64_t> used;
  std::vector<std::uint16_t> idOf(byRank.size() + 1, 0);
  std::set<const Segment*> kept;
  volume.labels.clear();
  std::size_t undeclared = 0;
  for (std::size_t r = 0; r < byRank.size(); ++r) {
    if (counts[r] == 0) continue;
    const Pair& p = byRank[r];
    LabelInfo info;
    info.value = used.insert(p.value).second ? p.value : next++;
    used.insert(info.value);
    if (p.segment != nullptr) {
      info.name = p.segment->name;
      info.colour = p.segment->colour;
      kept.insert(p.segment);
    } else {
      ++undeclared;
    }
    if (info.value != p.value)
      volume.warnings.push_back(
          (p.segment ? "segment " + describe(*p.segment) : std::string("unnamed data")) +
          " (layer " + std::to_string(p.layer) + ", value " + std::to_string(p.value) +
          ") shares its value with another layer's label; it is label value " +
          std::to_string(info.value));
    volume.labels.push_back(std::move(info));
    idOf[r + 1] = static_cast<std::uint16_t>(volume.labels.size());
  }
  for (std::uint16_t& i : volume.index) i = idOf[i];

  std::vector<const Segment*> dropped;
  for (const Segment& s : segments)
    if (kept.count(&s) == 0 && ignored.count(&s) == 0) dropped.push_back(&s);
  if (!dropped.empty()) volume.warnings.push_back(droppedWarning(dropped));
  if (undeclared > 0 && !segments.empty())
    volume.warnings.push_back(std::to_string(undeclared) +
                              " (layer, value) pair(s) have no segment in the metadata; kept "
                              "unnamed");
  if (overlapping > 0)
    volume.warnings.push_back(std::to_string(overlapping) +
                              " voxels are non-zero in several layers; each is given the "
                              "segment numbered last among them");
}

}  // namespace voxcut::volumeio

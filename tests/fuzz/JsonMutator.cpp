#include "JsonMutator.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <string_view>
#include <vector>

namespace voxcut::fuzz {
namespace {

using Json = nlohmann::ordered_json;

// Every value of the tree, parents before children.
void collect(Json& j, std::vector<Json*>& out) {
  out.push_back(&j);
  if (j.is_structured())
    for (Json& child : j) collect(child, out);
}

template <typename T, std::size_t N>
const T& pick(const std::array<T, N>& table, std::mt19937& rng) {
  return table[rng() % N];
}

constexpr std::array<double, 16> kNumbers = {0.0,     -0.0,   1.0,   -1.0,  0.5,    1e-300,
                                             -1e-300, 1e6,    1e155, 1e308, -1e308, 1e-12,
                                             0.49999, 4096.0, 1e9,   0.004};
constexpr std::array<double, 8> kScales = {-1.0, 2.0, 0.5, 10.0, 0.1, 1e6, 1e-6, 0.0};
constexpr std::array<long long, 12> kIntegers = {0, 1, 2,  3,    -1,         6,
                                                 7, 8, 10, 4097, 2147483647, -2147483648LL};
constexpr std::array<std::string_view, 19> kStrings = {"box:0.1,0.1,0.1",
                                                       "sphere:0.05",
                                                       "box:1e-9,1,1",
                                                       "box:0.1,0.1",
                                                       "sphere:1e300",
                                                       "tet.obj",
                                                       "bunny",
                                                       "liver",
                                                       "starfish",
                                                       "default",
                                                       "tumor",
                                                       "blade",
                                                       "cholesky",
                                                       "two_level",
                                                       "multigrid",
                                                       "jacobi",
                                                       "block_jacobi",
                                                       "",
                                                       "incomplete_cholesky"};

void mutateOne(std::vector<Json*>& nodes, std::mt19937& rng) {
  Json& node = *nodes[rng() % nodes.size()];
  switch (rng() % 8) {
    case 0:
      node = pick(kNumbers, rng);
      break;
    case 1:
      if (node.is_number())
        node = node.get<double>() * pick(kScales, rng);
      else
        node = pick(kIntegers, rng);
      break;
    case 2:
      node = pick(kIntegers, rng);
      break;
    case 3:
      node = std::string(pick(kStrings, rng));
      break;
    case 4:  // duplicate a list element
      if (node.is_array() && !node.empty()) {
        const Json copy = node[rng() % node.size()];
        node.push_back(copy);
      }
      break;
    case 5:  // remove a list element or a key
      if (node.is_array() && !node.empty())
        node.erase(rng() % node.size());
      else if (node.is_object() && !node.empty())
        node.erase(std::next(node.begin(), static_cast<std::ptrdiff_t>(rng() % node.size())));
      break;
    case 6: {  // replace by a copy of another value (may be its own ancestor or descendant)
      Json copy = *nodes[rng() % nodes.size()];
      node = std::move(copy);
      break;
    }
    default:
      switch (rng() % 4) {
        case 0:
          node = nullptr;
          break;
        case 1:
          node = (rng() % 2) == 0;
          break;
        case 2:
          node = Json::array();
          break;
        default:
          node = Json::object();
          break;
      }
  }
}

}  // namespace

std::size_t mutateJsonValues(std::uint8_t* data, std::size_t size, std::size_t maxSize,
                             unsigned int seed) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  Json j = Json::parse(text, nullptr, false);
  if (j.is_discarded()) return 0;
  std::mt19937 rng(seed);
  const int edits = 1 + static_cast<int>(rng() % 3);
  for (int e = 0; e < edits; ++e) {
    std::vector<Json*> nodes;  // re-collected: an edit may free nodes
    collect(j, nodes);
    mutateOne(nodes, rng);
  }
  const std::string out = j.dump();
  if (out.size() > maxSize) return 0;
  std::memcpy(data, out.data(), out.size());
  return out.size();
}

}  // namespace voxcut::fuzz

#pragma once
/// @file UnionFind.h
/// The one disjoint-set forest of voxcut: elements 0..n-1, path halving, and the root of each
/// set is its lowest element. Because the root is the minimum, it does not depend on the order
/// of the unions, so results built from roots are deterministic.
///
/// Thread safety: none (find compresses paths); one instance per thread.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace voxcut {

/// Disjoint sets over 0..size()-1. find and unite cost amortised O(log n) with path halving.
class UnionFind {
 public:
  UnionFind() = default;
  /// n singletons.
  explicit UnionFind(std::size_t n) { reset(n); }

  /// Makes n singletons, reusing the storage (for a forest rebuilt many times).
  void reset(std::size_t n) {
    parent_.resize(n);
    for (std::size_t i = 0; i < n; ++i) parent_[i] = static_cast<std::uint32_t>(i);
  }
  [[nodiscard]] std::size_t size() const { return parent_.size(); }

  /// The root of a's set: its lowest element.
  [[nodiscard]] std::uint32_t find(std::uint32_t a) {
    while (parent_[a] != a) a = parent_[a] = parent_[parent_[a]];
    return a;
  }
  /// Joins the sets of a and b; returns whether they were apart.
  bool unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    if (a < b)
      parent_[b] = a;
    else
      parent_[a] = b;
    return true;
  }
  /// Whether a and b are in one set.
  [[nodiscard]] bool same(std::uint32_t a, std::uint32_t b) { return find(a) == find(b); }

 private:
  std::vector<std::uint32_t> parent_;
};

}  // namespace voxcut

#pragma once

// Disjoint sets over 0 .. n-1 (union-find with path halving): the connected parts of a mesh,
// of a shell, of a contact's pieces.

#include <cstdint>
#include <numeric>
#include <vector>

namespace gvd {

struct UnionFind {
  std::vector<uint32_t> parent;
  explicit UnionFind(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  /// The representative of x's set.
  uint32_t find(uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  /// Joins the sets of a and b (the representative becomes b's).
  void unite(uint32_t a, uint32_t b) { parent[find(a)] = find(b); }
};

}  // namespace gvd

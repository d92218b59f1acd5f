#include "gvd/octree/vertices.h"

#include <algorithm>

#include "gvd/common/parallel.h"
#include "gvd/common/radix_sort.h"

namespace gvd {

OctreeVertices enumerate_vertices(const Octree& octree, int threads) {
  (void)threads;
  const int dim = octree.dimension;
  OctreeVertices out;
  out.dimension = dim;
  const uint32_t corners = 1u << dim;
  std::vector<uint64_t> keys;
  keys.reserve(octree.leaf_count() * corners);
  for (size_t i = 0; i < octree.leaf_count(); ++i) {
    for_each_corner_key(octree, static_cast<uint32_t>(i),
                        [&](uint64_t key) { keys.push_back(key); });
  }
  radix_sort(keys, [](uint64_t k) { return k; });
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  out.index = FlatMap64(keys.size());
  for (size_t i = 0; i < keys.size(); ++i) out.index.set(keys[i], static_cast<uint32_t>(i));
  out.key = std::move(keys);
  return out;
}

LeafGrid leaf_grid(const Octree& octree, const OctreeVertices& vertices, uint32_t leaf) {
  const int dim = octree.dimension;
  LeafGrid g;
  g.fill(kNoVertex);
  const lattice::Coord c = octree.corner(leaf);
  const uint64_t size = lattice::cell_size(dim, octree.level[leaf]);
  const bool has_mid = size >= 2;
  const uint32_t half = static_cast<uint32_t>(size / 2);
  const int kmax = dim == 3 ? 2 : 0;
  for (int k = 0; k <= kmax; ++k) {
    for (int j = 0; j <= 2; ++j) {
      for (int i = 0; i <= 2; ++i) {
        const bool is_corner = (i != 1) && (j != 1) && (dim == 2 || k != 1);
        const bool is_centre = i == 1 && j == 1 && (dim == 2 || k == 1);
        if (is_centre) continue;
        if (!is_corner && !has_mid) continue;
        lattice::Coord p = c;
        if (is_corner) {
          p.c[0] += (i / 2) * static_cast<uint32_t>(size);
          p.c[1] += (j / 2) * static_cast<uint32_t>(size);
          if (dim == 3) p.c[2] += (k / 2) * static_cast<uint32_t>(size);
        } else {
          p.c[0] += i * half;
          p.c[1] += j * half;
          if (dim == 3) p.c[2] += k * half;
        }
        g[i + 3 * j + 9 * k] = vertices.find(lattice::vertex_key(dim, p));
      }
    }
  }
  return g;
}

}  // namespace gvd

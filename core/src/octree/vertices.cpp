#include "gvd/octree/vertices.h"

#include <algorithm>
#include <atomic>

#include "gvd/common/parallel.h"
#include "gvd/common/radix_sort.h"

namespace gvd::octree {

namespace {
constexpr uint32_t kVertexIndexMaxLoad = 75;  // percent
}  // namespace

OctreeVertices enumerate_vertices(const Octree& octree, int threads) {
  threads = resolve_threads(threads);
  const int dim = octree.dimension;
  OctreeVertices out;
  out.dimension = dim;
  // Leaves sharing a corner are mostly near each other in Z order: a small direct-mapped
  // table of recent keys per chunk drops most repeats before the sort.
  const size_t grain = 4096;
  std::vector<std::vector<uint64_t>> chunks((octree.leaf_count() + grain - 1) / grain);
  parallel_for(
      octree.leaf_count(), threads,
      [&](size_t b, size_t e, int) {
        std::vector<uint64_t> out_keys;  // moved into chunks[] at the end (no false sharing)
        out_keys.reserve((e - b) * 2);
        std::vector<uint64_t> recent(4096, ~0ull);
        for (size_t i = b; i < e; ++i) {
          for_each_corner_key(octree, static_cast<uint32_t>(i), [&](uint64_t key) {
            uint64_t h = key * 0x9e3779b97f4a7c15ull;
            uint64_t& slot = recent[h >> 52];
            if (slot == key) return;
            slot = key;
            out_keys.push_back(key);
          });
        }
        chunks[b / grain] = std::move(out_keys);
      },
      grain);
  size_t total = 0;
  for (const auto& c : chunks) total += c.size();
  std::vector<uint64_t> keys;
  keys.reserve(total);
  for (auto& c : chunks) {
    keys.insert(keys.end(), c.begin(), c.end());
    std::vector<uint64_t>().swap(c);
  }
  radix_sort(
      keys, [](uint64_t k) { return k; }, threads);
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  out.key = std::move(keys);
  out.rebuild_index(threads);
  return out;
}

void OctreeVertices::rebuild_index(int threads, size_t room) {
  // Three quarters full (not half): the largest index of the refinement, and the filter below
  // answers most misses before the table is probed.
  index = FlatMap64();  // the old table goes first
  index = FlatMap64::of_distinct_keys(key, threads, kVertexIndexMaxLoad, room);
  // The filter too has room for `room` more keys (8 bits per key): append inserts in place
  // only while both have it (the maze's third round built both again for want of filter bits
  // alone, ~5 ms of its ~130).
  filter_bits_ = 6;
  while ((size_t{1} << filter_bits_) < 8 * (key.size() + room)) ++filter_bits_;
  filter.assign((size_t{1} << filter_bits_) / 64, 0);
  parallel_for(key.size(), threads, [&](size_t b, size_t e, int) {
    for (size_t i = b; i < e; ++i) {
      const uint64_t h = filter_hash(key[i]);
      std::atomic_ref<uint64_t>(filter[h >> 6])
          .fetch_or(uint64_t{1} << (h & 63), std::memory_order_relaxed);
    }
  });
}

void OctreeVertices::append(std::span<const uint64_t> added, int threads, size_t room) {
  const size_t first = key.size();
  key.insert(key.end(), added.begin(), added.end());
  // In place when the table and the filter (8 bits per key) hold the new keys too: the later
  // refinement rounds add few vertices, and building both again cost every round a table's
  // worth of fresh pages.
  if (index.size() == first && index.has_room(added.size()) && !filter.empty() &&
      (size_t{1} << filter_bits_) >= 8 * key.size()) {
    for (size_t i = first; i < key.size(); ++i) {
      index.insert(key[i], static_cast<uint32_t>(i));
      const uint64_t h = filter_hash(key[i]);
      filter[h >> 6] |= uint64_t{1} << (h & 63);
    }
    return;
  }
  rebuild_index(threads, room);
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
  // The keys that pass the filter first, with their index slots prefetched, then the
  // lookups: the slots' cache misses overlap instead of following one another.
  uint64_t keys[27];
  uint8_t slots[27];
  int n = 0;
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
        const uint64_t key = lattice::vertex_key(dim, p);
        if (!vertices.maybe(key)) continue;
        if (vertices.indexed()) vertices.index.prefetch(key);
        keys[n] = key;
        slots[n++] = static_cast<uint8_t>(i + 3 * j + 9 * k);
      }
    }
  }
  if (vertices.indexed()) {
    for (int m = 0; m < n; ++m) g[slots[m]] = vertices.index.find(keys[m]);
  } else {
    for (int m = 0; m < n; ++m) g[slots[m]] = vertices.find(keys[m]);
  }
  return g;
}

}  // namespace gvd::octree

#include "gvd/octree/build_octree.h"

#include <algorithm>
#include <atomic>
#include <numeric>

#include "gvd/common/error.h"
#include "gvd/common/flat_hash.h"
#include "gvd/common/parallel.h"
#include "gvd/common/peak_memory.h"
#include "gvd/common/radix_sort.h"
#include "gvd/geometry/primitives.h"
#include "gvd/octree/build_octree_data_parallel.h"
#include "gvd/octree/contacts.h"
#include "gvd/octree/octree.h"
#include "gvd/octree/subdivision_rule.h"

namespace gvd::octree {

using namespace gvd::scene;

namespace {

using lattice::Coord;

// Internal (split) nodes of the tree, one hash set of corner Morton codes per level.
using InternalSets = std::vector<FlatMap64>;
// Certified pair cells, one map of corner Morton codes per level to their certified_mark:
// their leaves, and every leaf below them, are marked in Octree::certified.
using CertifiedSets = std::vector<FlatMap64>;

// The mark a child (code, level, simplices) of a split cell with mark `parent` gets: the
// parent's where it holds for sub-cells; else (a cell certified for itself only) the oracle's
// verdict for the child, so that 2:1 balance does not undo certificates round after round.
uint8_t child_mark(int dim, const OctreeOptions& options, uint8_t parent, uint64_t code, int level,
                   const std::vector<uint32_t>& list) {
  const uint8_t inherited = inherited_mark(parent);
  if (inherited != 0 || parent == 0 || options.split_oracle == nullptr) return inherited;
  const Box box = lattice::cell_box(dim, lattice::morton_decode(dim, code), level);
  return certified_mark(options.split_oracle->classify_child(box, list, parent));
}

// The mark of cell (code, level) in `sets`, 0 if none.
uint8_t mark_in(const CertifiedSets& sets, int level, uint64_t code) {
  if (level >= static_cast<int>(sets.size())) return 0;
  const uint32_t m = sets[level].find(code);
  return m == FlatMap64::kMissing ? 0 : static_cast<uint8_t>(m);
}

void check_cancel(const OctreeOptions& options) {
  if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) {
    throw Error(ErrorCode::kCancelled, "octree build cancelled");
  }
}

uint64_t child_code(int dim, uint64_t code, int level, uint32_t child) {
  const int shift = dim * (lattice_bits(dim) - level - 1);
  return code | (static_cast<uint64_t>(child) << shift);
}

uint64_t parent_code(int dim, uint64_t code, int level) {
  const int shift = dim * (lattice_bits(dim) - level + 1);
  return shift >= 64 ? 0 : (code >> shift) << shift;
}

// Does simplex s of `geometry` touch `box`? Conservative: the box is inflated a hair.
bool simplex_touches(const UnitGeometry& g, uint32_t s, const Box& box, double slack) {
  return simplex_overlaps_box(g.dimension, g.points, g.simplices[s], box, slack);
}

ObjectId tag_of(const UnitGeometry& g, const uint32_t* begin, const uint32_t* end) {
  if (begin == end) return kNoObject;
  const ObjectId first = g.object_of[*begin];
  for (const uint32_t* p = begin + 1; p != end; ++p) {
    if (g.object_of[*p] != first) return kManyObjects;
  }
  return first;
}

// A set of cells of one level with their simplex lists (CSR) and whether each lies inside a
// certified pair cell.
struct CellSet {
  std::vector<uint64_t> codes;
  std::vector<uint32_t> begin{0};
  std::vector<uint32_t> pool;
  std::vector<uint8_t> certified;

  size_t size() const { return codes.size(); }
  void add(uint64_t c, const uint32_t* first, const uint32_t* last, uint8_t cert = 0) {
    codes.push_back(c);
    pool.insert(pool.end(), first, last);
    begin.push_back(static_cast<uint32_t>(pool.size()));
    certified.push_back(cert);
  }
  void add(uint64_t c, const std::vector<uint32_t>& list, uint8_t cert = 0) {
    add(c, list.data(), list.data() + list.size(), cert);
  }
};

// The parts one after the other, copied in parallel (each part into its own slot).
CellSet concat(std::vector<CellSet>& parts) {
  // Appended in order, each part freed once copied: the pages of the whole are touched only as
  // the parts are given back, so the cells are held about once, not twice (the copy is a few
  // bytes per cell; a parallel one would need the whole array first).
  size_t cells = 0, refs = 0;
  for (const CellSet& part : parts) {
    cells += part.codes.size();
    refs += part.pool.size();
  }
  CellSet out;
  out.codes.reserve(cells);
  out.certified.reserve(cells);
  out.pool.reserve(refs);
  out.begin.reserve(cells + 1);
  for (CellSet& part : parts) {
    const uint32_t base = static_cast<uint32_t>(out.pool.size());
    out.codes.insert(out.codes.end(), part.codes.begin(), part.codes.end());
    out.certified.insert(out.certified.end(), part.certified.begin(), part.certified.end());
    out.pool.insert(out.pool.end(), part.pool.begin(), part.pool.end());
    for (size_t i = 1; i < part.begin.size(); ++i) out.begin.push_back(part.begin[i] + base);
    part = CellSet();
  }
  return out;
}

// Children of cell (code, level) with the simplices of `list` that touch them, in child
// order; calls out(child_code, child_list).
template <class Out>
void split_cell(const UnitGeometry& g, uint64_t code, int level, const uint32_t* lb,
                const uint32_t* le, std::vector<uint32_t>& scratch, Out&& out) {
  const int dim = g.dimension;
  const uint32_t nchildren = 1u << dim;
  const double slack = overlap_slack(level + 1);
  for (uint32_t c = 0; c < nchildren; ++c) {
    const uint64_t cc = child_code(dim, code, level, c);
    const Box box = lattice::cell_box(dim, lattice::morton_decode(dim, cc), level + 1);
    scratch.clear();
    for (const uint32_t* p = lb; p != le; ++p) {
      if (simplex_touches(g, *p, box, slack)) scratch.push_back(*p);
    }
    out(cc, scratch);
  }
}

// Face-neighbour codes of a cell at `level` (those inside the domain).
template <class F>
void for_each_face_neighbour(int dim, uint64_t code, int level, F&& f) {
  const Coord c = lattice::morton_decode(dim, code);
  const int64_t size = static_cast<int64_t>(lattice::cell_size(dim, level));
  const int64_t limit = static_cast<int64_t>(lattice::side_units(dim));
  for (int axis = 0; axis < dim; ++axis) {
    for (int sign = -1; sign <= 1; sign += 2) {
      const int64_t v = static_cast<int64_t>(c.c[axis]) + sign * size;
      if (v < 0 || v >= limit) continue;
      Coord n = c;
      n.c[axis] = static_cast<uint32_t>(v);
      f(lattice::morton(dim, n));
    }
  }
}

// Calls f(code) with the codes of the parents (level - 1) of the 3^D neighbours of cell (code,
// level) inside the domain (the cell itself included): at most 2^D cells, its parent and, on
// each axis, the parent's neighbour on the side of the half the cell lies in. What 2:1 balance
// requires to be internal when the cell is.
template <class F>
void for_each_neighbour_parent(int dim, uint64_t code, int level, F&& f) {
  const Coord c = lattice::morton_decode(dim, code);
  const int64_t size = static_cast<int64_t>(lattice::cell_size(dim, level));
  const int64_t limit = static_cast<int64_t>(lattice::side_units(dim));
  for (int corner = 0; corner < (1 << dim); ++corner) {
    Coord q;
    bool inside = true;
    for (int a = 0; a < dim; ++a) {
      const int64_t parent = c.c[a] & ~(2 * size - 1);
      const int64_t toward = (c.c[a] & size) ? 2 * size : -2 * size;
      const int64_t x = parent + ((corner >> a) & 1 ? toward : 0);
      inside &= x >= 0 && x < limit;
      q.c[a] = static_cast<uint32_t>(x);
    }
    if (inside) f(parent_code(dim, lattice::morton(dim, q), level));
  }
}

// Per-chunk outputs merged in chunk order, so results do not depend on thread timing.
template <class T>
struct ChunkResults {
  std::vector<T> chunks;
  size_t grain;
  ChunkResults(size_t n, size_t g) : chunks((n + g - 1) / g + 1), grain(g) {}
  T& at(size_t begin) { return chunks[begin / grain]; }
};

// The non-empty cells phase 1 visited on each level, with their simplex lists, and which of
// them it split: phase 2 takes the children's lists from here instead of filtering again.
struct LevelCache {
  std::vector<CellSet> sets;
  std::vector<FlatMap64> index;             // code -> position in sets[level]
  std::vector<std::vector<uint8_t>> split;  // per cell of sets[level]: phase 1 split it
};

// Phase 1: SHOULD_SUBDIVIDE, level by level over the non-empty cells; returns internal sets.
InternalSets subdivide_by_rules(const UnitGeometry& g, const OctreeOptions& options, int max_depth,
                                int threads, LevelCache& cache, CertifiedSets& certified) {
  const int dim = g.dimension;
  const int contact_depth = resolve_contact_depth(dim, options.contact_depth, max_depth);
  InternalSets internal(max_depth + 1);
  certified.assign(max_depth + 1, FlatMap64());
  CellSet current;
  {
    std::vector<uint32_t> all(g.simplices.size());
    std::iota(all.begin(), all.end(), 0u);
    current.add(0, all);
  }
  uint64_t internal_count = 0;
  const uint64_t children_per_split = (1u << dim) - 1;
  // The leaf limit bounds cells, not what they hold: where many objects share cells (a
  // thousand coincident copies of one part) every cell lists every copy's simplices, and those
  // lists (every level's, kept for materialize) take the memory. So they are bounded too, by
  // the same option, while the next level's are made.
  const uint64_t max_references =
      kReferencesPerLeaf * options.max_leaves + 4 * static_cast<uint64_t>(g.simplices.size());
  uint64_t held = 0;  // references in the levels so far
  for (int level = 0; level <= max_depth && current.size() > 0; ++level) {
    check_cancel(options);
    if (options.progress) options.progress(static_cast<double>(level) / std::max(1, max_depth));
    const size_t n = current.size();
    std::vector<ObjectId> tags(n);
    std::vector<CellObjects> sets(n);
    parallel_for(n, threads, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i) {
        sets[i] = cell_objects(g, current.pool.data() + current.begin[i],
                               current.pool.data() + current.begin[i + 1]);
        tags[i] = cell_tag(sets[i], options.contacts);
      }
    });
    FlatMap64 index_of_code = FlatMap64::of_distinct_keys(current.codes, threads);
    if (level == max_depth) break;
    const bool at_contact = level >= contact_depth;
    std::vector<uint8_t> split(n, 0);
    parallel_for(n, threads, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i) {
        bool s = splits_by_itself(tags[i], at_contact);
        if (!s && asks_neighbours(tags[i])) {
          for_each_face_neighbour(dim, current.codes[i], level, [&](uint64_t nc) {
            const uint32_t j = index_of_code.find(nc);
            if (j != FlatMap64::kMissing &&
                must_separate(tags[i], tags[j], sets[j], at_contact, options.contacts))
              s = true;
          });
        }
        split[i] = s ? 1 : 0;
      }
    });
    if (options.split_oracle != nullptr) {
      // The thin-gaps refinement: a cell the rule splits stays a leaf when no GVD enters it
      // or its bisector is certified (split = 1 + certified_mark marks the certified ones).
      parallel_for(
          n, threads,
          [&](size_t b, size_t e, int) {
            for (size_t i = b; i < e; ++i) {
              if (!split[i]) continue;
              const Box box =
                  lattice::cell_box(dim, lattice::morton_decode(dim, current.codes[i]), level);
              const CellVerdict v = options.split_oracle->classify(
                  box, std::span<const uint32_t>(current.pool.data() + current.begin[i],
                                                 current.begin[i + 1] - current.begin[i]));
              if (v == CellVerdict::kSplit) continue;
              const uint8_t mark = certified_mark(v);  // kOneObject: 0, a leaf unmarked
              split[i] = mark == 0 ? 0 : static_cast<uint8_t>(1 + mark);
            }
          },
          16);
    }
    {
      std::vector<uint64_t> split_codes, certified_codes;
      std::vector<uint8_t> marks;
      for (size_t i = 0; i < n; ++i) {
        if (split[i] == 1) split_codes.push_back(current.codes[i]);
        if (split[i] >= 2) {
          certified_codes.push_back(current.codes[i]);
          marks.push_back(static_cast<uint8_t>(split[i] - 1));
        }
      }
      for (size_t i = 0; i < n; ++i) split[i] = split[i] == 1;
      internal[level] = FlatMap64::of_distinct_keys(split_codes, threads);
      if (!certified_codes.empty()) {
        FlatMap64 m(certified_codes.size());
        for (size_t i = 0; i < certified_codes.size(); ++i) m.insert(certified_codes[i], marks[i]);
        certified[level] = std::move(m);
      }
    }
    internal_count += internal[level].size();
    heap_computation_grows(internal_count * children_per_split + 1);  // the leaves so far
    if (internal_count * children_per_split + 1 > options.max_leaves) {
      throw Error(ErrorCode::kLimitExceeded, "octree exceeds the leaf limit of " +
                                                 std::to_string(options.max_leaves) + " at level " +
                                                 std::to_string(level + 1) +
                                                 " (raise --max-leaves or lower --max-depth)");
    }
    const size_t grain = 256;
    ChunkResults<CellSet> out(n, grain);
    held += current.pool.size();
    std::atomic<uint64_t> made{0};
    std::atomic<bool> over{false};
    parallel_for(
        n, threads,
        [&](size_t b, size_t e, int) {
          CellSet local;  // moved in at the end: no false sharing between chunks
          std::vector<uint32_t> scratch;
          for (size_t i = b; i < e && !over.load(std::memory_order_relaxed); ++i) {
            if (!split[i]) continue;
            const size_t before = local.pool.size();
            split_cell(g, current.codes[i], level, current.pool.data() + current.begin[i],
                       current.pool.data() + current.begin[i + 1], scratch,
                       [&](uint64_t cc, const std::vector<uint32_t>& list) {
                         if (!list.empty()) local.add(cc, list);
                       });
            if (held + (made += local.pool.size() - before) > max_references) over = true;
          }
          out.at(b) = std::move(local);
        },
        grain);
    if (over) {
      uint64_t most = 0;
      for (size_t i = 0; i < n; ++i)
        most = std::max<uint64_t>(most, current.begin[i + 1] - current.begin[i]);
      throw Error(ErrorCode::kLimitExceeded,
                  "octree cells up to level " + std::to_string(level + 1) +
                      " hold more simplex references than the limit of " +
                      std::to_string(max_references) + " (" + std::to_string(kReferencesPerLeaf) +
                      " per leaf of --max-leaves and 4 per simplex); a cell at level " +
                      std::to_string(level) + " holds " + std::to_string(most) +
                      " simplices: many objects share cells (coincident or overlapping copies?)");
    }
    CellSet next = concat(out.chunks);
    cache.sets.push_back(std::move(current));
    cache.index.push_back(std::move(index_of_code));
    cache.split.push_back(std::move(split));
    current = std::move(next);
  }
  return internal;
}

// Adds every ancestor of the internal nodes (keeps the sets closed upwards).
void close_upwards(int dim, InternalSets& internal) {
  for (int level = static_cast<int>(internal.size()) - 1; level >= 1; --level) {
    std::vector<uint64_t> parents;
    internal[level].for_each(
        [&](uint64_t code, uint32_t) { parents.push_back(parent_code(dim, code, level)); });
    for (uint64_t p : parents) internal[level - 1].insert(p, 0);
  }
}

// 2:1 balance over faces, edges and corners: every neighbour of an internal node must exist,
// i.e. its parent must be internal. Deepest level first, so splits ripple upwards. The
// required parents are generated in parallel and deduplicated before the (serial) inserts.
void balance(int dim, InternalSets& internal, int threads) {
  for (int level = static_cast<int>(internal.size()) - 1; level >= 1; --level) {
    std::vector<uint64_t> codes;
    codes.reserve(internal[level].size());
    internal[level].for_each([&](uint64_t code, uint32_t) { codes.push_back(code); });
    const int per_code = 1 << dim;
    std::vector<uint64_t> required(codes.size() * per_code, ~0ull);
    parallel_for(codes.size(), threads, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i) {
        uint64_t* out = &required[i * per_code];
        for_each_neighbour_parent(dim, codes[i], level, [&](uint64_t p) { *out++ = p; });
      }
    });
    radix_sort(
        required, [](uint64_t k) { return k; }, threads);
    required.erase(std::unique(required.begin(), required.end()), required.end());
    for (uint64_t p : required)
      if (p != ~0ull) internal[level - 1].insert(p, 0);
  }
}

// Phase 2: walk the tree top-down through the internal sets and emit the leaves with their
// simplex lists, sorted by Morton code.
Octree materialize(const UnitGeometry& g, const InternalSets& internal, int max_depth,
                   const OctreeOptions& options, int threads, const LevelCache* cache,
                   const CertifiedSets& certified, LeafSimplices* simplices) {
  const int dim = g.dimension;
  struct Leaves {
    std::vector<uint64_t> code;
    std::vector<uint8_t> level;
    std::vector<ObjectId> object;
    std::vector<uint8_t> certified;
    CellSet lists;  // codes unused; begin/pool hold the simplex lists
  };
  std::vector<Leaves> per_level;
  CellSet current;
  {
    std::vector<uint32_t> all(g.simplices.size());
    std::iota(all.begin(), all.end(), 0u);
    current.add(0, all);
  }
  uint64_t leaf_count = 0;
  for (int level = 0; current.size() > 0; ++level) {
    check_cancel(options);
    const size_t n = current.size();
    const bool has_internal = level < static_cast<int>(internal.size()) && level < max_depth;
    const size_t grain = 256;
    ChunkResults<CellSet> next_chunks(n, grain);
    ChunkResults<Leaves> leaf_chunks(n, grain);
    parallel_for(
        n, threads,
        [&](size_t b, size_t e, int) {
          // Filled locally and moved in at the end: no false sharing between chunks.
          CellSet next;
          Leaves leaves;
          std::vector<uint32_t> scratch;
          for (size_t i = b; i < e; ++i) {
            const uint64_t code = current.codes[i];
            const uint32_t* lb = current.pool.data() + current.begin[i];
            const uint32_t* le = current.pool.data() + current.begin[i + 1];
            const uint8_t cert =
                current.certified[i] != 0 ? current.certified[i] : mark_in(certified, level, code);
            if (has_internal && internal[level].contains(code)) {
              // Children of a split cell carry its mark when it holds for sub-cells.
              const uint8_t child_cert = inherited_mark(cert);
              bool cached = false;
              if (cache != nullptr && level + 1 < static_cast<int>(cache->sets.size())) {
                const uint32_t at = cache->index[level].find(code);
                cached = at != FlatMap64::kMissing && cache->split[level][at];
              }
              if (cached) {
                // Phase 1 split this cell: its non-empty children and their lists are known.
                const CellSet& below = cache->sets[level + 1];
                for (uint32_t c = 0; c < (1u << g.dimension); ++c) {
                  const uint64_t cc = child_code(g.dimension, code, level, c);
                  const uint32_t j = cache->index[level + 1].find(cc);
                  if (j == FlatMap64::kMissing) {
                    next.add(cc, nullptr, nullptr, child_cert);
                  } else {
                    next.add(cc, below.pool.data() + below.begin[j],
                             below.pool.data() + below.begin[j + 1], child_cert);
                  }
                }
                continue;
              }
              split_cell(g, code, level, lb, le, scratch,
                         [&](uint64_t cc, const std::vector<uint32_t>& list) {
                           next.add(
                               cc, list,
                               child_cert != 0 || cert == 0
                                   ? child_cert
                                   : child_mark(g.dimension, options, cert, cc, level + 1, list));
                         });
            } else {
              leaves.code.push_back(code);
              leaves.level.push_back(static_cast<uint8_t>(level));
              leaves.object.push_back(tag_of(g, lb, le));
              leaves.certified.push_back(cert);
              leaves.lists.add(0, lb, le);
            }
          }
          next_chunks.at(b) = std::move(next);
          leaf_chunks.at(b) = std::move(leaves);
        },
        grain);
    CellSet next = concat(next_chunks.chunks);
    Leaves merged;
    std::vector<CellSet> lists;
    lists.reserve(leaf_chunks.chunks.size());
    for (Leaves& l : leaf_chunks.chunks) {
      merged.code.insert(merged.code.end(), l.code.begin(), l.code.end());
      merged.level.insert(merged.level.end(), l.level.begin(), l.level.end());
      merged.object.insert(merged.object.end(), l.object.begin(), l.object.end());
      merged.certified.insert(merged.certified.end(), l.certified.begin(), l.certified.end());
      lists.push_back(std::move(l.lists));
    }
    merged.lists = concat(lists);
    leaf_count += merged.code.size();
    if (leaf_count + next.size() > options.max_leaves) {
      throw Error(ErrorCode::kLimitExceeded, "octree exceeds the leaf limit of " +
                                                 std::to_string(options.max_leaves) + " at level " +
                                                 std::to_string(level + 1) +
                                                 " (raise --max-leaves or lower --max-depth)");
    }
    per_level.push_back(std::move(merged));
    current = std::move(next);
  }

  // Concatenate and sort by Morton code.
  Octree tree;
  tree.dimension = dim;
  tree.max_depth = max_depth;
  // The levels one after the other (each copied by one task).
  std::vector<size_t> leaf_at(per_level.size() + 1, 0), pool_at(per_level.size() + 1, 0);
  for (size_t l = 0; l < per_level.size(); ++l) {
    leaf_at[l + 1] = leaf_at[l] + per_level[l].code.size();
    pool_at[l + 1] = pool_at[l] + per_level[l].lists.pool.size();
  }
  std::vector<uint64_t> codes(leaf_at.back());
  std::vector<uint8_t> levels(leaf_at.back());
  std::vector<ObjectId> objects(leaf_at.back());
  std::vector<uint8_t> certs(leaf_at.back());
  std::vector<uint32_t> begins(leaf_at.back() + 1, 0);
  std::vector<uint32_t> pool(pool_at.back());
  parallel_for(
      per_level.size(), threads,
      [&](size_t lb, size_t le, int) {
        for (size_t l = lb; l < le; ++l) {
          const Leaves& lv = per_level[l];
          std::copy(lv.code.begin(), lv.code.end(), codes.begin() + leaf_at[l]);
          std::copy(lv.level.begin(), lv.level.end(), levels.begin() + leaf_at[l]);
          std::copy(lv.object.begin(), lv.object.end(), objects.begin() + leaf_at[l]);
          std::copy(lv.certified.begin(), lv.certified.end(), certs.begin() + leaf_at[l]);
          std::copy(lv.lists.pool.begin(), lv.lists.pool.end(), pool.begin() + pool_at[l]);
          for (size_t i = 1; i < lv.lists.begin.size(); ++i)
            begins[leaf_at[l] + i] = lv.lists.begin[i] + static_cast<uint32_t>(pool_at[l]);
        }
      },
      1);
  // Leaves never share a corner code, so the order is total.
  std::vector<std::pair<uint64_t, uint32_t>> order(codes.size());
  parallel_for(codes.size(), threads, [&](size_t b, size_t e, int) {
    for (size_t i = b; i < e; ++i) order[i] = {codes[i], static_cast<uint32_t>(i)};
  });
  radix_sort(
      order, [](const std::pair<uint64_t, uint32_t>& x) { return x.first; }, threads);
  const size_t n = codes.size();
  tree.code.resize(n);
  tree.level.resize(n);
  tree.object.resize(n);
  tree.certified.resize(n);
  if (simplices != nullptr) {
    simplices->begin.assign(n + 1, 0);
    for (size_t i = 0; i < n; ++i) {
      const uint32_t o = order[i].second;
      simplices->begin[i + 1] = simplices->begin[i] + (begins[o + 1] - begins[o]);
    }
    simplices->index.resize(pool.size());
  }
  parallel_for(n, threads, [&](size_t b, size_t e, int) {
    for (size_t i = b; i < e; ++i) {
      const uint32_t o = order[i].second;
      tree.code[i] = codes[o];
      tree.level[i] = levels[o];
      tree.object[i] = objects[o];
      tree.certified[i] = certs[o];
      if (simplices != nullptr) {
        std::copy(pool.begin() + begins[o], pool.begin() + begins[o + 1],
                  simplices->index.begin() + simplices->begin[i]);
      }
    }
  });
  for (uint8_t l : levels) tree.depth = std::max<int>(tree.depth, l);
  return tree;
}

}  // namespace

int resolve_max_depth(int dimension, int requested) {
  const int limit = lattice_bits(dimension);
  if (requested <= 0) return dimension == 2 ? 26 : 21;
  if (requested > limit) {
    throw Error(ErrorCode::kInvalidArgument,
                "max depth " + std::to_string(requested) + " exceeds the lattice limit " +
                    std::to_string(limit) + " for " + std::to_string(dimension) + "D");
  }
  return requested;
}

int resolve_contact_depth(int dimension, int requested, int max_depth) {
  const int depth = requested > 0 ? requested : (dimension == 2 ? 14 : 8);
  return std::min(depth, max_depth);
}

uint32_t Octree::locate_lattice(const lattice::Coord& p) const {
  const uint64_t m = lattice::morton(dimension, p);
  auto it = std::upper_bound(code.begin(), code.end(), m);
  GVD_CHECK(it != code.begin(), "octree leaves must tile the domain");
  return static_cast<uint32_t>(it - code.begin() - 1);
}

LeafLocator::LeafLocator(const Octree& octree) : octree_(&octree) {
  const int bits = octree.dimension * lattice_bits(octree.dimension);
  // About two prefixes per leaf, at most 2^kPrefixBits: a small octree (a junction face's
  // plane GVD builds thousands of them) does not fill a table of 65k entries each time.
  int prefix_bits = 2;
  while (prefix_bits < kPrefixBits && (size_t{1} << prefix_bits) < 2 * octree.code.size())
    ++prefix_bits;
  shift_ = std::max(0, bits - prefix_bits);
  const size_t prefixes = (size_t{1} << (bits - shift_)) + 1;
  start_.assign(prefixes, static_cast<uint32_t>(octree.code.size()));
  // Filled from the back: each prefix starts at the first leaf whose prefix is not smaller.
  size_t i = octree.code.size();
  for (size_t b = prefixes - 1; b-- > 0;) {
    while (i > 0 && (octree.code[i - 1] >> shift_) >= b) --i;
    start_[b] = static_cast<uint32_t>(i);
  }
}

uint32_t LeafLocator::locate_lattice(const lattice::Coord& p) const {
  const uint64_t m = lattice::morton(octree_->dimension, p);
  const size_t b = m >> shift_;
  // The last leaf whose code is <= m: in this prefix's range, else the one just before it.
  const auto first = octree_->code.begin() + start_[b];
  const auto it = std::upper_bound(first, octree_->code.begin() + start_[b + 1], m);
  GVD_CHECK(it != octree_->code.begin(), "octree leaves must tile the domain");
  return static_cast<uint32_t>(it - octree_->code.begin() - 1);
}

uint32_t Octree::locate(Vec3 u) const {
  const uint64_t m = lattice::morton(dimension, lattice::from_unit(dimension, u));
  auto it = std::upper_bound(code.begin(), code.end(), m);
  GVD_CHECK(it != code.begin(), "octree leaves must tile the domain");
  return static_cast<uint32_t>(it - code.begin() - 1);
}

size_t Octree::structure_bytes() const {
  return code.size() * (sizeof(uint64_t) + sizeof(uint8_t) + sizeof(ObjectId)) + certified.size();
}

Octree build_octree(const UnitGeometry& geometry, const OctreeOptions& options,
                    LeafSimplices* simplices) {
  const int dim = geometry.dimension;
  GVD_CHECK(dim == 2 || dim == 3, "dimension must be 2 or 3");
  const int max_depth = resolve_max_depth(dim, options.max_depth);
  const int threads = resolve_threads(options.threads);
  LevelCache cache;
  CertifiedSets certified;
  InternalSets internal =
      subdivide_by_rules(geometry, options, max_depth, threads, cache, certified);
  close_upwards(dim, internal);
  balance(dim, internal, threads);
  return materialize(geometry, internal, max_depth, options, threads, &cache, certified, simplices);
}

Octree octree_from_split_cells(const UnitGeometry& geometry, std::span<const CellRef> split,
                               const OctreeOptions& options, std::span<const CellRef> certified,
                               LeafSimplices* simplices) {
  const int dim = geometry.dimension;
  const int max_depth = resolve_max_depth(dim, options.max_depth);
  InternalSets internal(max_depth + 1);
  for (const CellRef& c : split)
    if (c.level < max_depth) internal[c.level].insert(c.code, 0);
  CertifiedSets certified_sets(max_depth + 1);
  for (const CellRef& c : certified) certified_sets[c.level].insert(c.code, c.mark);
  close_upwards(dim, internal);
  balance(dim, internal, resolve_threads(options.threads));
  return materialize(geometry, internal, max_depth, options, resolve_threads(options.threads),
                     nullptr, certified_sets, simplices);
}

CellRef child_cell(int dimension, CellRef cell, uint32_t child) {
  return {child_code(dimension, cell.code, cell.level, child),
          static_cast<uint8_t>(cell.level + 1)};
}

Octree refine_octree(const Octree& octree, const LeafSimplices& simplices,
                     const UnitGeometry& geometry, std::span<const CellRef> cells_to_split,
                     const OctreeOptions& options, std::span<const CellRef> cells_to_certify,
                     LeafSimplices* refined_simplices) {
  GVD_CHECK(simplices.covers(octree.leaf_count()), "refine_octree: the leaves' simplex lists");
  // Incremental: only the cells that become internal are found (the requested ones, the
  // ancestors between them and the leaf that holds them, and what 2:1 balance then requires,
  // rippling outwards), and only the leaves they replace are re-subdivided; every other leaf
  // is copied with its simplices. O(N) copying + O(new cells x simplices per cell).
  const int dim = octree.dimension;
  const int max_depth = octree.max_depth;
  check_cancel(options);
  InternalSets added(max_depth + 1);
  const LeafLocator locator(octree);
  auto internal = [&](uint64_t code, int level) {
    if (added[level].contains(code)) return true;
    const uint32_t leaf = locator.locate_lattice(lattice::morton_decode(dim, code));
    return octree.level[leaf] > level;
  };
  std::vector<CellRef> work;
  auto request = [&](uint64_t code, int level) {
    if (level >= max_depth || internal(code, level)) return;
    // The cells between the leaf that holds this one and it become internal too.
    const uint32_t leaf = locator.locate_lattice(lattice::morton_decode(dim, code));
    for (int l = octree.level[leaf]; l <= level; ++l) {
      const uint64_t c = (l == level) ? code : parent_code(dim, code, l + 1);
      // parent_code(code, l + 1) clears the bits below level l.
      if (added[l].contains(c)) continue;
      added[l].insert(c, 0);
      work.push_back({c, static_cast<uint8_t>(l)});
    }
  };
  for (const CellRef& c : cells_to_split) request(c.code, c.level);
  CertifiedSets certify(max_depth + 1);
  for (const CellRef& c : cells_to_certify) certify[c.level].insert(c.code, c.mark);
  const bool any_certify = !cells_to_certify.empty();
  while (!work.empty()) {
    const CellRef p = work.back();
    work.pop_back();
    if (p.level == 0) continue;
    // 2:1 balance: every neighbour of an internal cell must exist, i.e. its parent is internal.
    for_each_neighbour_parent(dim, p.code, p.level,
                              [&](uint64_t parent) { request(parent, p.level - 1); });
  }

  // Copy the leaves that stay; subdivide (depth first, so in Morton order) those that split.
  // In parallel over chunks of leaves, each into its own part, then the parts in order.
  struct Part {
    CellSet leaves;  // codes, simplex lists and certified flags
    std::vector<uint8_t> level;
    std::vector<ObjectId> object;
    int depth = 0;
  };
  const size_t n = octree.leaf_count();
  const size_t grain = 4096;
  const int threads = resolve_threads(options.threads);
  auto leaf_limit_error = [&] {
    return Error(ErrorCode::kLimitExceeded,
                 "octree exceeds the leaf limit of " + std::to_string(options.max_leaves) +
                     " during refinement (raise --max-leaves or lower --max-depth)");
  };
  std::vector<Part> parts((n + grain - 1) / grain);
  parallel_for(
      n, threads,
      [&](size_t b, size_t e, int) {
        Part part;  // moved in at the end: no false sharing between chunks
        part.leaves.codes.reserve(e - b);
        part.level.reserve(e - b);
        part.object.reserve(e - b);
        auto emit = [&](uint64_t code, int level, ObjectId object, const uint32_t* lb,
                        const uint32_t* le, uint8_t cert) {
          part.leaves.codes.push_back(code);
          part.leaves.certified.push_back(cert);
          part.level.push_back(static_cast<uint8_t>(level));
          part.object.push_back(object);
          part.leaves.pool.insert(part.leaves.pool.end(), lb, le);
          part.leaves.begin.push_back(static_cast<uint32_t>(part.leaves.pool.size()));
          part.depth = std::max(part.depth, level);
        };
        struct Frame {
          uint64_t code;
          int level;
          std::vector<uint32_t> simplices;
          uint8_t certified;
        };
        std::vector<Frame> stack;
        std::vector<uint32_t> scratch;
        for (size_t i = b; i < e; ++i) {
          const std::span<const uint32_t> row = simplices.of(static_cast<uint32_t>(i));
          const uint32_t* lb = row.data();
          const uint32_t* le = lb + row.size();
          const int level = octree.level[i];
          const uint8_t cert = octree.is_certified(static_cast<uint32_t>(i)) ? octree.certified[i]
                               : any_certify ? mark_in(certify, level, octree.code[i])
                                             : uint8_t{0};
          if (level >= max_depth || !added[level].contains(octree.code[i])) {
            emit(octree.code[i], level, octree.object[i], lb, le, cert);
            continue;
          }
          stack.push_back({octree.code[i], level, std::vector<uint32_t>(lb, le), cert});
          while (!stack.empty()) {
            Frame f = std::move(stack.back());
            stack.pop_back();
            if (f.certified == 0 && any_certify) f.certified = mark_in(certify, f.level, f.code);
            const bool split = f.level < max_depth && added[f.level].contains(f.code);
            if (!split) {
              const uint32_t* fb = f.simplices.data();
              const uint32_t* fe = fb + f.simplices.size();
              emit(f.code, f.level, tag_of(geometry, fb, fe), fb, fe, f.certified);
              continue;
            }
            // Children pushed in reverse so that they pop in Morton order.
            std::vector<Frame> children;
            split_cell(geometry, f.code, f.level, f.simplices.data(),
                       f.simplices.data() + f.simplices.size(), scratch,
                       [&](uint64_t cc, const std::vector<uint32_t>& list) {
                         children.push_back({cc, f.level + 1, list,
                                             child_mark(geometry.dimension, options, f.certified,
                                                        cc, f.level + 1, list)});
                       });
            for (auto it = children.rbegin(); it != children.rend(); ++it)
              stack.push_back(std::move(*it));
          }
          if (part.leaves.size() > options.max_leaves) throw leaf_limit_error();
        }
        parts[b / grain] = std::move(part);
      },
      grain);
  size_t total = 0;
  for (const Part& p : parts) total += p.leaves.size();
  if (total > options.max_leaves) throw leaf_limit_error();
  Octree tree;
  tree.dimension = dim;
  tree.max_depth = max_depth;
  std::vector<size_t> at(parts.size() + 1, 0);
  for (size_t p = 0; p < parts.size(); ++p) {
    at[p + 1] = at[p] + parts[p].leaves.size();
    tree.depth = std::max(tree.depth, parts[p].depth);
  }
  tree.level.resize(total);
  tree.object.resize(total);
  parallel_for(
      parts.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t p = b; p < e; ++p) {
          std::copy(parts[p].level.begin(), parts[p].level.end(), tree.level.begin() + at[p]);
          std::copy(parts[p].object.begin(), parts[p].object.end(), tree.object.begin() + at[p]);
        }
      },
      1);
  std::vector<CellSet> sets;
  sets.reserve(parts.size());
  for (Part& p : parts) sets.push_back(std::move(p.leaves));
  CellSet leaves = concat(sets);
  tree.code = std::move(leaves.codes);
  tree.certified = std::move(leaves.certified);
  if (refined_simplices != nullptr) {
    refined_simplices->begin = std::move(leaves.begin);
    refined_simplices->index = std::move(leaves.pool);
  }
  return tree;
}

}  // namespace gvd::octree

#include "gvd/octree/build_octree_data_parallel.h"

#include <algorithm>
#include <numeric>

#include "gvd/common/error.h"
#include "gvd/common/flat_hash.h"
#include "gvd/common/parallel.h"
#include "gvd/common/radix_sort.h"
#include "gvd/common/stopwatch.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/contacts.h"
#include "gvd/octree/subdivision_rule.h"

namespace gvd::octree {

using namespace gvd::scene;

static_assert(sizeof(item::GvdRadixNode) == 24);

ItemGeometry item_geometry(const UnitGeometry& geometry) {
  ItemGeometry out;
  out.points.resize(geometry.points.size());
  for (size_t i = 0; i < geometry.points.size(); ++i) {
    const Vec3& p = geometry.points[i];
    out.points[i] = {p.x, p.y, p.z};
  }
  out.simplices.resize(3 * geometry.simplices.size());
  for (size_t i = 0; i < geometry.simplices.size(); ++i)
    for (int k = 0; k < 3; ++k) out.simplices[3 * i + k] = geometry.simplices[i].v[k];
  return out;
}

namespace {

// Count pass, exclusive prefix sum, fill pass: the allocation scheme of draft Algorithm 2.
template <class Count, class Fill>
CsrU32 two_pass(size_t rows, int threads, Count&& count, Fill&& fill) {
  CsrU32 out;
  out.begin.assign(rows + 1, 0);
  parallel_for(rows, threads, [&](size_t b, size_t e, int) {
    for (size_t i = b; i < e; ++i) out.begin[i + 1] = count(i);
  });
  for (size_t i = 0; i < rows; ++i) out.begin[i + 1] += out.begin[i];
  out.items.resize(out.begin[rows]);
  parallel_for(rows, threads, [&](size_t b, size_t e, int) {
    for (size_t i = b; i < e; ++i) fill(i, out.items.data() + out.begin[i]);
  });
  return out;
}

class CpuOctreeBuildSteps final : public OctreeBuildSteps {
 public:
  CpuOctreeBuildSteps(const UnitGeometry& g, int threads)
      : dim_(g.dimension), threads_(resolve_threads(threads)) {
    ItemGeometry items = item_geometry(g);
    points_ = std::move(items.points);
    simplices_ = std::move(items.simplices);
  }

  std::vector<uint64_t> vertex_keys(int max_level) override {
    std::vector<uint64_t> keys(points_.size());
    const int shift = dim_ * (lattice_bits(dim_) - max_level);
    parallel_for(points_.size(), threads_, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i) keys[i] = item::gvd_point_code(dim_, points_[i]) >> shift;
    });
    return keys;
  }

  void radix_tree(std::span<const uint64_t> keys, int bits, std::vector<item::GvdRadixNode>& nodes,
                  std::vector<int32_t>& parent) override {
    const int n = static_cast<int>(keys.size());
    nodes.assign(n > 1 ? n - 1 : 0, {});
    parent.assign(nodes.size(), -1);
    parallel_for(nodes.size(), threads_, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i)
        nodes[i] = item::gvd_radix_node(keys.data(), n, bits, static_cast<int>(i));
    });
    link_parents(nodes, parent);
  }

  void facet_cells(int max_level, std::vector<uint32_t>& begin, std::vector<uint64_t>& code,
                   std::vector<int32_t>& level) override {
    const size_t m = simplices_.size() / 3;
    const double slack = item::gvd_slack(0);
    begin.assign(m + 1, 0);
    parallel_for(m, threads_, [&](size_t b, size_t e, int) {
      for (size_t s = b; s < e; ++s)
        begin[s + 1] = static_cast<uint32_t>(
            item::gvd_facet_cells(dim_, points_.data(), simplices_.data(), static_cast<uint32_t>(s),
                                  slack, max_level, nullptr, nullptr));
    });
    for (size_t s = 0; s < m; ++s) begin[s + 1] += begin[s];
    code.assign(begin[m], 0);
    level.assign(begin[m], 0);
    parallel_for(m, threads_, [&](size_t b, size_t e, int) {
      for (size_t s = b; s < e; ++s)
        item::gvd_facet_cells(dim_, points_.data(), simplices_.data(), static_cast<uint32_t>(s),
                              slack, max_level, code.data() + begin[s], level.data() + begin[s]);
    });
  }

  CsrU32 cell_facets(const SccArray& scc, std::span<const uint64_t> cell_code,
                     std::span<const uint8_t> cell_level) override {
    auto run = [&](size_t i, uint32_t* out) {
      return item::gvd_leaf_facets(dim_, points_.data(), simplices_.data(), scc.code.data(),
                                   scc.simplex.data(), scc.lo.data(), scc.hi.data(),
                                   scc.level_begin.data(), cell_code[i], cell_level[i], out);
    };
    return two_pass(
        cell_code.size(), threads_, [&](size_t i) { return run(i, nullptr); },
        [&](size_t i, uint32_t* out) { run(i, out); });
  }

  CsrU32 child_facets(const CsrU32& lists, std::span<const uint32_t> parent,
                      std::span<const uint64_t> child_code,
                      std::span<const uint8_t> child_level) override {
    auto run = [&](size_t i, uint32_t* out) {
      uint32_t count = 0;
      item::GvdPoint lo, hi;
      item::gvd_cell_box(dim_, child_code[i], child_level[i], &lo, &hi);
      const double slack = item::gvd_slack(child_level[i]);
      for (uint32_t k = lists.begin[parent[i]]; k < lists.begin[parent[i] + 1]; ++k) {
        const uint32_t s = lists.items[k];
        if (item::gvd_simplex_touches_box(dim_, points_.data(), simplices_.data(), s, lo, hi,
                                          slack)) {
          if (out) out[count] = s;
          ++count;
        }
      }
      return count;
    };
    return two_pass(
        child_code.size(), threads_, [&](size_t i) { return run(i, nullptr); },
        [&](size_t i, uint32_t* out) { run(i, out); });
  }

  // Each internal node names its internal children (Karras): their parent is this node.
  static void link_parents(const std::vector<item::GvdRadixNode>& nodes,
                           std::vector<int32_t>& parent) {
    for (size_t i = 0; i < nodes.size(); ++i) {
      const item::GvdRadixNode& n = nodes[i];
      if (n.first != n.split) parent[n.split] = static_cast<int32_t>(i);
      if (n.last != n.split + 1) parent[n.split + 1] = static_cast<int32_t>(i);
    }
  }

 private:
  int dim_;
  int threads_;
  std::vector<item::GvdPoint> points_;
  std::vector<uint32_t> simplices_;
};

uint64_t child_code(int dim, uint64_t code, int level, uint32_t child) {
  return code | (static_cast<uint64_t>(child) << (dim * (lattice_bits(dim) - level - 1)));
}

void check_cancel(const OctreeOptions& options) {
  if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) {
    throw Error(ErrorCode::kCancelled, "octree build cancelled");
  }
}

[[noreturn]] void leaf_limit(const OctreeOptions& options, int level) {
  throw Error(ErrorCode::kLimitExceeded, "octree exceeds the leaf limit of " +
                                             std::to_string(options.max_leaves) + " at level " +
                                             std::to_string(level) +
                                             " (raise --max-leaves or lower --max-depth)");
}

}  // namespace

std::unique_ptr<OctreeBuildSteps> make_cpu_octree_build_steps(const UnitGeometry& geometry,
                                                              int threads) {
  return std::make_unique<CpuOctreeBuildSteps>(geometry, threads);
}

Octree build_octree_data_parallel(const UnitGeometry& g, const OctreeOptions& options,
                                  OctreeBuildSteps* steps, DataParallelBuildStats* stats,
                                  LeafSimplices* simplices) {
  const int dim = g.dimension;
  GVD_CHECK(dim == 2 || dim == 3, "dimension must be 2 or 3");
  const int max_depth = resolve_max_depth(dim, options.max_depth);
  const int contact_depth = resolve_contact_depth(dim, options.contact_depth, max_depth);
  const int threads = resolve_threads(options.threads);
  const int bits = lattice_bits(dim);
  const uint32_t nchildren = 1u << dim;
  std::unique_ptr<OctreeBuildSteps> twin;
  if (steps == nullptr) {
    twin = make_cpu_octree_build_steps(g, threads);
    steps = twin.get();
  }
  DataParallelBuildStats st;
  Stopwatch part;

  // (1) Vertex octree: sorted unique Morton keys, Karras radix tree, and the octree cells it
  // implies (each internal radix node contributes the cells between its parent's prefix
  // and its own), per level.
  std::vector<uint64_t> keys = steps->vertex_keys(max_depth);
  radix_sort(
      keys, [](uint64_t k) { return k; }, threads);
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  st.vertex_keys = keys.size();
  std::vector<FlatMap64> internal(max_depth + 1);  // cells split in the resolved octree
  if (keys.size() >= 2) {
    std::vector<item::GvdRadixNode> nodes;
    std::vector<int32_t> parent;
    steps->radix_tree(keys, dim * max_depth, nodes, parent);
    const int full_shift = dim * (bits - max_depth);
    for (size_t i = 0; i < nodes.size(); ++i) {
      const int first = item::gvd_radix_cell_first_level(
          dim, parent[i] < 0 ? -1 : nodes[static_cast<size_t>(parent[i])].prefix);
      const int last = item::gvd_radix_cell_last_level(dim, nodes[i].prefix, max_depth - 1);
      const uint64_t code = keys[static_cast<size_t>(nodes[i].first)] << full_shift;
      for (int l = first; l <= last; ++l) internal[l].insert(item::gvd_truncate(dim, code, l), 0);
    }
  }
  // Leaves: the children of internal cells that are not internal themselves (or the root).
  std::vector<uint64_t> leaf_code;
  std::vector<uint8_t> leaf_level;
  auto collect_leaves = [&]() {
    std::vector<std::pair<uint64_t, uint8_t>> leaves;
    if (internal[0].size() == 0) leaves.push_back({0, 0});
    for (int l = 0; l < max_depth; ++l) {
      internal[l].for_each([&](uint64_t code, uint32_t) {
        for (uint32_t c = 0; c < nchildren; ++c) {
          const uint64_t cc = child_code(dim, code, l, c);
          if (l + 1 > max_depth - 1 || !internal[l + 1].contains(cc))
            leaves.push_back({cc, static_cast<uint8_t>(l + 1)});
        }
      });
    }
    std::sort(leaves.begin(), leaves.end());
    leaf_code.resize(leaves.size());
    leaf_level.resize(leaves.size());
    for (size_t i = 0; i < leaves.size(); ++i) {
      leaf_code[i] = leaves[i].first;
      leaf_level[i] = leaves[i].second;
    }
  };
  collect_leaves();
  st.vertex_octree_leaves = leaf_code.size();
  st.seconds_vertex_octree = part.lap();
  if (leaf_code.size() > options.max_leaves) leaf_limit(options, max_depth);
  check_cancel(options);

  // (2) Smallest containing cells, clamped to the deepest cell of the vertex octree on their
  // path, sorted by (level, code); then every leaf's facets from its ancestors.
  SccArray scc;
  {
    std::vector<uint32_t> begin;
    std::vector<uint64_t> code;
    std::vector<int32_t> level;
    steps->facet_cells(max_depth, begin, code, level);
    // Clamp each cell to the deepest cell of the vertex octree on its path (a cell below a
    // leaf is stored at the leaf); entries are (level, code, simplex), unique.
    struct Entry {
      int32_t level;
      uint64_t code;
      uint32_t simplex;
      bool operator<(const Entry& o) const {
        return level != o.level ? level < o.level
                                : (code != o.code ? code < o.code : simplex < o.simplex);
      }
      bool operator==(const Entry& o) const {
        return level == o.level && code == o.code && simplex == o.simplex;
      }
    };
    std::vector<Entry> entries(code.size());
    const size_t m = begin.size() - 1;
    parallel_for(m, threads, [&](size_t b, size_t e, int) {
      for (size_t s = b; s < e; ++s)
        for (uint32_t k = begin[s]; k < begin[s + 1]; ++k) {
          auto it = std::upper_bound(leaf_code.begin(), leaf_code.end(), code[k]);
          const int leaf_lvl = leaf_level[static_cast<size_t>(it - leaf_code.begin() - 1)];
          const int l = std::min(level[k], leaf_lvl);
          entries[k] = {l, item::gvd_truncate(dim, code[k], l), static_cast<uint32_t>(s)};
        }
    });
    std::sort(entries.begin(), entries.end());
    entries.erase(std::unique(entries.begin(), entries.end()), entries.end());
    scc.level_begin.assign(max_depth + 2, 0);
    for (const Entry& en : entries) {
      scc.code.push_back(en.code);
      scc.simplex.push_back(en.simplex);
      Box box;
      for (int k = 0; k < dim; ++k) box.extend(g.points[g.simplices[en.simplex].v[k]]);
      scc.lo.push_back({box.lo.x, box.lo.y, box.lo.z});
      scc.hi.push_back({box.hi.x, box.hi.y, box.hi.z});
      ++scc.level_begin[en.level + 1];
    }
    for (int l = 0; l <= max_depth; ++l) scc.level_begin[l + 1] += scc.level_begin[l];
  }
  CsrU32 lists = steps->cell_facets(scc, leaf_code, leaf_level);
  st.seconds_facets = part.lap();

  // (3) Conflict cells: refine level by level (Algorithm 3, data-parallel over the frontier).
  auto is_conflict = [&](const CellObjects& s, int level, uint64_t code,
                         std::span<const uint32_t> inside) {
    if (level >= max_depth) return false;
    if (!splits_by_itself(cell_tag(s, options.contacts), level >= contact_depth)) return false;
    // A certified pair cell is resolved as it is (the rule below keeps it too).
    return options.split_oracle == nullptr ||
           options.split_oracle->classify(
               lattice::cell_box(dim, lattice::morton_decode(dim, code), level), inside) ==
               CellVerdict::kSplit;
  };
  // The resolved leaves and their lists, accumulated.
  std::vector<uint64_t> res_code;
  std::vector<uint8_t> res_level;
  CsrU32 res_lists;
  std::vector<uint32_t> frontier;  // rows of `lists` still in conflict
  std::vector<uint64_t> cur_code = leaf_code;
  std::vector<uint8_t> cur_level = leaf_level;
  bool first_round = true;
  while (!cur_code.empty()) {
    check_cancel(options);
    frontier.clear();
    for (size_t i = 0; i < cur_code.size(); ++i) {
      const CellObjects s = cell_objects(g, lists.items.data() + lists.begin[i],
                                         lists.items.data() + lists.begin[i + 1]);
      if (is_conflict(s, cur_level[i], cur_code[i],
                      std::span<const uint32_t>(lists.items.data() + lists.begin[i],
                                                lists.begin[i + 1] - lists.begin[i]))) {
        frontier.push_back(static_cast<uint32_t>(i));
        internal[cur_level[i]].insert(cur_code[i], 0);
        if (first_round) ++st.conflict_cells;
        ++st.refined_cells;
      } else {
        res_code.push_back(cur_code[i]);
        res_level.push_back(cur_level[i]);
        res_lists.items.insert(res_lists.items.end(), lists.items.begin() + lists.begin[i],
                               lists.items.begin() + lists.begin[i + 1]);
        res_lists.begin.push_back(static_cast<uint32_t>(res_lists.items.size()));
      }
    }
    first_round = false;
    if (res_code.size() + frontier.size() * nchildren > options.max_leaves)
      leaf_limit(options, max_depth);
    if (frontier.empty()) break;
    ++st.refine_levels;
    std::vector<uint32_t> parent;
    std::vector<uint64_t> next_code;
    std::vector<uint8_t> next_level;
    for (uint32_t r : frontier)
      for (uint32_t c = 0; c < nchildren; ++c) {
        parent.push_back(r);
        next_code.push_back(child_code(dim, cur_code[r], cur_level[r], c));
        next_level.push_back(static_cast<uint8_t>(cur_level[r] + 1));
      }
    lists = steps->child_facets(lists, parent, next_code, next_level);
    cur_code = std::move(next_code);
    cur_level = std::move(next_level);
  }
  st.resolved_leaves = res_code.size();
  st.seconds_refine = part.lap();

  // Objects of every cell of the resolved octree: leaves from their lists, internal cells as
  // the union of their children (bottom-up).
  std::vector<FlatMap64> cell_index(max_depth + 1);
  std::vector<std::vector<CellObjects>> objects_at(max_depth + 1);
  std::vector<FlatMap64> leaf_index(max_depth + 1);  // resolved leaf -> row of res_lists
  for (size_t i = 0; i < res_code.size(); ++i)
    leaf_index[res_level[i]].insert(res_code[i], static_cast<uint32_t>(i));
  for (int l = max_depth; l >= 0; --l) {
    if (l < max_depth) {
      internal[l].for_each([&](uint64_t code, uint32_t) {
        CellObjects s;
        for (uint32_t c = 0; c < nchildren; ++c) {
          const uint64_t cc = child_code(dim, code, l, c);
          const uint32_t j = cell_index[l + 1].find(cc);
          if (j != FlatMap64::kMissing) {
            s.add(objects_at[l + 1][j]);
            continue;
          }
          const uint32_t r = leaf_index[l + 1].find(cc);
          if (r != FlatMap64::kMissing)
            s.add(cell_objects(g, res_lists.items.data() + res_lists.begin[r],
                               res_lists.items.data() + res_lists.begin[r + 1]));
        }
        cell_index[l].insert(code, static_cast<uint32_t>(objects_at[l].size()));
        objects_at[l].push_back(s);
      });
    }
  }

  // The engine's rule (SHOULD_SUBDIVIDE, as build_octree's first phase) over the visited
  // cells, level by level; a cell's objects come from the resolved octree: an internal cell's
  // from the bottom-up union, a leaf's (or a cell inside a leaf's) from the leaf's list.
  struct Cell {
    uint64_t code;
    std::vector<uint32_t> list;  // only for cells at or below a resolved leaf
    bool has_list;
  };
  auto resolved_leaf_of = [&](uint64_t code, int level) -> uint32_t {
    for (int l = level; l >= 0; --l) {
      const uint32_t r = leaf_index[l].find(item::gvd_truncate(dim, code, l));
      if (r != FlatMap64::kMissing) return r;
    }
    return FlatMap64::kMissing;
  };
  const ItemGeometry items = item_geometry(g);
  std::vector<CellRef> splits, certified;
  std::vector<Cell> current{{0, {}, false}};
  for (int level = 0; level < max_depth && !current.empty(); ++level) {
    check_cancel(options);
    const size_t n = current.size();
    std::vector<CellObjects> sets(n);
    std::vector<ObjectId> tags(n);
    FlatMap64 index_of_code(n);
    parallel_for(n, threads, [&](size_t b, size_t e, int) {
      for (size_t i = b; i < e; ++i) {
        Cell& c = current[i];
        const uint32_t j = cell_index[level].find(c.code);
        if (j != FlatMap64::kMissing) {
          sets[i] = objects_at[level][j];
        } else {
          if (!c.has_list) {
            const uint32_t r = resolved_leaf_of(c.code, level);
            GVD_CHECK(r != FlatMap64::kMissing, "every cell lies in a resolved leaf");
            c.list.assign(res_lists.items.begin() + res_lists.begin[r],
                          res_lists.items.begin() + res_lists.begin[r + 1]);
            c.has_list = true;
          }
          sets[i] = cell_objects(g, c.list.data(), c.list.data() + c.list.size());
        }
        tags[i] = cell_tag(sets[i], options.contacts);
      }
    });
    for (size_t i = 0; i < n; ++i) index_of_code.set(current[i].code, static_cast<uint32_t>(i));
    const bool at_contact = level >= contact_depth;
    std::vector<Cell> next;
    const int64_t size = static_cast<int64_t>(lattice::cell_size(dim, level));
    const int64_t limit = static_cast<int64_t>(lattice::side_units(dim));
    for (size_t i = 0; i < n; ++i) {
      if (tags[i] == kNoObject) continue;  // only non-empty cells are visited
      bool s = splits_by_itself(tags[i], at_contact);
      if (!s && asks_neighbours(tags[i])) {
        const lattice::Coord c = lattice::morton_decode(dim, current[i].code);
        for (int axis = 0; axis < dim && !s; ++axis)
          for (int sign = -1; sign <= 1 && !s; sign += 2) {
            const int64_t v = static_cast<int64_t>(c.c[axis]) + sign * size;
            if (v < 0 || v >= limit) continue;
            lattice::Coord q = c;
            q.c[axis] = static_cast<uint32_t>(v);
            const uint32_t j = index_of_code.find(lattice::morton(dim, q));
            if (j != FlatMap64::kMissing &&
                must_separate(tags[i], tags[j], sets[j], at_contact, options.contacts))
              s = true;
          }
      }
      if (s && options.split_oracle != nullptr) {
        const CellVerdict v = options.split_oracle->classify(
            lattice::cell_box(dim, lattice::morton_decode(dim, current[i].code), level),
            current[i].has_list ? std::span<const uint32_t>(current[i].list)
                                : std::span<const uint32_t>());
        if (certified_mark(v) != 0)
          certified.push_back({current[i].code, static_cast<uint8_t>(level), certified_mark(v)});
        s = v == CellVerdict::kSplit;
      }
      if (!s) continue;
      splits.push_back({current[i].code, static_cast<uint8_t>(level)});
      for (uint32_t ch = 0; ch < nchildren; ++ch) {
        Cell child{child_code(dim, current[i].code, level, ch), {}, false};
        if (current[i].has_list || !cell_index[level].contains(current[i].code)) {
          // Inside a resolved leaf: filter the parent's list (the overlap test of the build).
          const std::vector<uint32_t>& pl = current[i].list;
          for (uint32_t t : pl)
            if (item::gvd_simplex_touches_cell(dim, items.points.data(), items.simplices.data(), t,
                                               child.code, level + 1))
              child.list.push_back(t);
          child.has_list = true;
        }
        next.push_back(std::move(child));
      }
    }
    current = std::move(next);
  }
  st.seconds_rule = part.lap();
  Octree tree = octree_from_split_cells(g, splits, options, certified, simplices);
  st.seconds_materialize = part.lap();
  if (stats) *stats = st;
  return tree;
}

}  // namespace gvd::octree

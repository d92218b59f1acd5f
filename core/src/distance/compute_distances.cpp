#include "gvd/distance/compute_distances.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <queue>
#include <tuple>

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/radix_sort.h"
#include "gvd/distance/closest_points.h"
#include "gvd/distance/distance_field.h"
#include "gvd/octree/lattice.h"

namespace gvd::distance {

using namespace gvd::scene;
using namespace gvd::octree;

double DistanceField::distance(uint32_t v) const {
  if (point[v] == kNoVertex) return std::numeric_limits<double>::infinity();
  return gvd::dist(vertices.position(v), closest[point[v]]);
}

size_t DistanceField::memory_bytes() const {
  return vertices.memory_bytes() + label.size() * sizeof(ObjectId) +
         point.size() * sizeof(uint32_t) + closest.size() * sizeof(Vec3) + exact.size();
}

ClosestHit closest_for_vertex(const SimplexBvh& bvh, Vec3 position, double upper2) {
  return bvh.nearest(position, upper2);
}

namespace {

// Compressed sparse rows.
struct Csr {
  std::vector<uint32_t> begin;
  GrowableArray<uint32_t> items;
};

// Exact closest points of a batch: the backend's solver, or SimplexBvh::nearest (the same
// per-item function, closest_point_item.h) on the CPU.
void solve_closest(const SimplexBvh& bvh, const DistanceOptions& options, std::span<const Vec3> pos,
                   std::span<const double> bound, std::span<ClosestHit> hits, int threads) {
  if (options.solver != nullptr) {
    options.solver->solve(pos, bound, hits);
    return;
  }
  parallel_for(
      pos.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e; ++i) hits[i] = closest_for_vertex(bvh, pos[i], bound[i]);
      },
      256);
}

void check_cancel(const DistanceOptions& options) {
  if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) {
    throw Error(ErrorCode::kCancelled, "distance transform cancelled");
  }
}

// DistanceMethod::kExact: the exact closest point of every vertex, in one batch. With a
// previous field, a vertex it had (same key) keeps its point: the positions are the same, so
// the answer is too; only new vertices are queried. `old_count` > 0: the first old_count
// vertices are the previous field's, by index (incremental topology); else found by key.
// Reserves room for n elements and half again (as many again for a small vertex set, below
// kSmallVertexIndex), unless the vector already has room for n. A refinement round adds
// vertices to these arrays: growing a vector copies it, which would hold the old and the new
// array at once, at the refinement's peak, and writes fresh pages (the maze's refinement
// outgrew the first field's half again in its third round: ~400 page faults, ~4 ms of its
// ~130). The room is address space only until the next round writes it (big blocks are mapped
// on their own, their untouched pages never resident).
template <class T>
void reserve_with_room(std::vector<T>& v, size_t n) {
  if (v.capacity() < n) v.reserve(n + (n < kSmallVertexIndex ? n : n / 2));
}

void exact_everywhere(DistanceField& field, const UnitGeometry& geometry, const SimplexBvh& bvh,
                      const DistanceOptions& options, const DistanceField* previous,
                      uint32_t old_count, DistanceField* owned,
                      std::span<const uint32_t> leaf_vertices, int threads) {
  const size_t nv = field.vertices.size();
  // An owned previous field whose vertices keep their indices (old_count > 0) and whose
  // closest points are indexed by vertex (as this function leaves them) gives its arrays up:
  // they are extended in place instead of copied (36 B per vertex less at the peak).
  bool in_place = owned != nullptr && old_count > 0 && owned->point.size() == old_count &&
                  owned->closest.size() == old_count && owned->label.size() == old_count &&
                  owned->exact.size() == old_count;
  if (in_place) {
    std::atomic<bool> indexed{true};
    parallel_for(old_count, threads, [&](size_t b, size_t e, int) {
      for (size_t v = b; v < e; ++v)
        if (owned->point[v] != kNoVertex && owned->point[v] != v) indexed = false;
    });
    in_place = indexed;
  }
  std::vector<uint8_t> reused(nv, 0);
  if (in_place) {
    field.label = std::move(owned->label);
    field.point = std::move(owned->point);
    field.closest = std::move(owned->closest);
    std::vector<uint8_t> was_exact = std::move(owned->exact);
    // Within the room left by the last allocation (below) when it holds the new vertices;
    // else at their size and half again.
    reserve_with_room(field.label, nv);
    reserve_with_room(field.point, nv);
    reserve_with_room(field.closest, nv);
    field.label.resize(nv, kNoObject);
    field.point.resize(nv, kNoVertex);
    field.closest.resize(nv, Vec3{});
    field.exact.assign(nv, 1);
    field.changed.assign(nv, 1);
    parallel_for(old_count, threads, [&](size_t b, size_t e, int) {
      for (size_t v = b; v < e; ++v) {
        if (!was_exact[v] || field.point[v] == kNoVertex) {
          field.label[v] = kNoObject;
          field.point[v] = kNoVertex;
          field.closest[v] = Vec3{};
          continue;
        }
        field.changed[v] = 0;
        reused[v] = 1;
      }
    });
  } else {
    reserve_with_room(field.label, nv);
    reserve_with_room(field.point, nv);
    reserve_with_room(field.closest, nv);
    field.label.assign(nv, kNoObject);
    field.point.assign(nv, kNoVertex);
    field.closest.assign(nv, Vec3{});
    field.exact.assign(nv, 1);
    field.changed.assign(nv, 1);
  }
  if (previous != nullptr && !in_place) {
    parallel_for(nv, threads, [&](size_t b, size_t e, int) {
      for (size_t v = b; v < e; ++v) {
        const uint32_t pv = old_count > 0 ? (v < old_count ? static_cast<uint32_t>(v) : kNoVertex)
                                          : previous->vertices.find(field.vertices.key[v]);
        if (pv == kNoVertex || !previous->exact[pv] || previous->point[pv] == kNoVertex) continue;
        field.closest[v] = previous->closest[previous->point[pv]];
        field.label[v] = previous->label[pv];
        field.point[v] = static_cast<uint32_t>(v);
        field.changed[v] = 0;
        reused[v] = 1;
      }
    });
  }
  // The vertices to query in the order the leaves (in Z order) first list them: consecutive
  // queries are then near each other and walk the same parts of the BVH, which stay in cache.
  // (Sorting them by Z order would hold 32 bytes per vertex at the distance stage's peak.)
  const size_t queries = nv - static_cast<size_t>(std::count(reused.begin(), reused.end(), 1));
  std::vector<uint32_t> todo;
  todo.reserve(queries);
  for (const uint32_t v : leaf_vertices) {
    if (reused[v]) continue;
    reused[v] = 2;  // listed
    todo.push_back(v);
  }
  GVD_CHECK(todo.size() == queries, "exact distances: a vertex on no leaf's list");
  // In blocks, through buffers reused from one block to the next (less fresh memory, whose
  // first touch costs more than the queries' bookkeeping).
  const size_t block = std::min<size_t>(todo.size(), size_t{1} << 16);
  std::vector<Vec3> pos(block);
  const std::vector<double> bound(block, 1e300);
  std::vector<ClosestHit> hits(block);
  for (size_t first = 0; first < todo.size(); first += block) {
    const size_t m = std::min(block, todo.size() - first);
    parallel_for(m, threads, [&](size_t b, size_t e, int) {
      for (size_t j = b; j < e; ++j) pos[j] = field.vertices.position(todo[first + j]);
    });
    check_cancel(options);
    solve_closest(bvh, options, std::span<const Vec3>(pos).first(m),
                  std::span<const double>(bound).first(m), std::span<ClosestHit>(hits).first(m),
                  threads);
    parallel_for(m, threads, [&](size_t b, size_t e, int) {
      for (size_t j = b; j < e; ++j) {
        if (!hits[j].found()) continue;  // no simplices at all
        const uint32_t v = todo[first + j];
        field.closest[v] = hits[j].point;
        field.label[v] = geometry.object_of[hits[j].simplex];
        field.point[v] = v;
      }
    });
    if (options.progress) options.progress(static_cast<double>(first + m) / todo.size());
  }
  check_cancel(options);
  field.exact_count = nv;
  field.exact_reused = nv - todo.size();
}

// compute_distances; with `owned` (the previous field itself, given up by the caller) its
// parts are moved into the new field instead of copied, or freed once used: the vertices, the
// per-vertex arrays (exact_everywhere) and the per-leaf lists (then `lists` is
// `previous_lists`, given up too, and receives the new ones).
DistanceField distances(const Octree& octree, const UnitGeometry& geometry, const SimplexBvh& bvh,
                        const DistanceOptions& options, const DistanceField* previous,
                        const Octree* previous_octree, const LeafVertices* previous_lists,
                        LeafVertices* lists, DistanceField* owned = nullptr,
                        Octree* owned_octree = nullptr) {
  const int dim = octree.dimension;
  const int threads = resolve_threads(options.threads);
  DistanceField field;
  const size_t nl = octree.leaf_count();
  const int grid_points = dim == 3 ? 27 : 9;

  // Incremental topology after a refinement: the previous vertices keep their indices (new
  // ones are appended), and leaves that did not change keep their boundary vertices unless a
  // new vertex appeared on them.
  const bool incremental = previous != nullptr && previous_octree != nullptr &&
                           previous_lists != nullptr &&
                           previous_lists->covers(previous_octree->leaf_count());
  std::vector<uint32_t> old_leaf;  // per leaf: the same leaf in previous_octree, or kNoVertex
  uint32_t old_count = 0;
  if (incremental) {
    old_leaf.assign(nl, kNoVertex);
    const Octree& po = *previous_octree;
    for (size_t i = 0, j = 0; i < nl && j < po.leaf_count();) {
      if (octree.code[i] < po.code[j]) {
        ++i;
      } else if (octree.code[i] > po.code[j]) {
        ++j;
      } else {
        if (octree.level[i] == po.level[j]) old_leaf[i] = static_cast<uint32_t>(j);
        ++i;
        ++j;
      }
    }
    // Nothing reads the replaced octree after this match: an owned one goes now, before the
    // update's peak (9 B per leaf).
    if (owned_octree != nullptr) *owned_octree = Octree();
    if (owned != nullptr) {
      field.vertices = std::move(owned->vertices);
    } else {
      field.vertices = previous->vertices;
    }
    old_count = static_cast<uint32_t>(field.vertices.size());
    // The new leaves' corners that are not vertices yet (found in parallel: the index is only
    // read), appended in key order.
    const size_t grain = 4096;
    std::vector<std::vector<uint64_t>> fresh((nl + grain - 1) / grain);
    parallel_for(
        nl, threads,
        [&](size_t b, size_t e, int) {
          std::vector<uint64_t> mine;  // moved in at the end (no false sharing)
          uint64_t recent[256];
          std::fill(std::begin(recent), std::end(recent), ~0ull);
          for (size_t i = b; i < e; ++i) {
            if (old_leaf[i] != kNoVertex) continue;
            for_each_corner_key(octree, static_cast<uint32_t>(i), [&](uint64_t key) {
              uint64_t& slot = recent[(key * 0x9e3779b97f4a7c15ull) >> 56];
              if (slot == key) return;
              slot = key;
              if (field.vertices.find(key) == kNoVertex) mine.push_back(key);
            });
          }
          fresh[b / grain] = std::move(mine);
        },
        grain);
    std::vector<uint64_t> added;
    for (const auto& f : fresh) added.insert(added.end(), f.begin(), f.end());
    radix_sort(
        added, [](uint64_t k) { return k; }, threads);
    added.erase(std::unique(added.begin(), added.end()), added.end());
    // Appended: inserted into the index where it has room, else the index is built again at
    // the new size, a small one (as refine_until_resolved keeps across rounds) with room for
    // half as many again, so that the later rounds, which add few vertices, insert in place.
    const size_t total = old_count + added.size();
    reserve_with_room(field.vertices.key, total);
    field.vertices.append(added, threads, total < kSmallVertexIndex ? total / 2 : 0);
    std::vector<uint64_t>().swap(added);
  } else {
    field.vertices = enumerate_vertices(octree, threads);
  }
  const size_t nv = field.vertices.size();

  // Leaf -> boundary vertices (CSR, handed to `lists`) with their slots in the leaf's grid,
  // and its transpose vertex -> leaves.
  Csr leaf_verts;
  leaf_verts.begin.assign(nl + 1, 0);
  std::vector<uint32_t> slots(nl);
  {
    // Leaves whose grid must be looked up: all, or after a refinement the new ones and those
    // touching a new vertex (found by locating the cells around it).
    std::vector<uint8_t> recompute(nl, 1);
    if (incremental) {
      for (size_t i = 0; i < nl; ++i) recompute[i] = old_leaf[i] == kNoVertex;
      const int64_t limit = static_cast<int64_t>(lattice::side_units(dim));
      const LeafLocator locator(octree);
      parallel_for(nv - old_count, threads, [&](size_t b, size_t e, int) {
        for (size_t v = old_count + b; v < old_count + e; ++v) {
          const lattice::Coord p = lattice::vertex_coord(dim, field.vertices.key[v]);
          for (uint32_t o = 0; o < (1u << dim); ++o) {
            lattice::Coord q = p;
            bool inside = true;
            for (int a = 0; a < dim; ++a) {
              const int64_t x = static_cast<int64_t>(p.c[a]) - ((o >> a) & 1 ? 0 : 1);
              inside &= x >= 0 && x < limit;
              q.c[a] = static_cast<uint32_t>(x);
            }
            if (inside) {
              std::atomic_ref<uint8_t>(recompute[locator.locate_lattice(q)])
                  .store(1, std::memory_order_relaxed);
            }
          }
        }
      });
    }
    // Grids of the leaves looked up again, compacted per chunk of leaves into their boundary
    // vertices (no full-size array of grids); the other leaves copy their CSR rows.
    const size_t grain = 2048;
    struct Compact {
      std::vector<uint32_t> vertex;
      size_t begin = 0, end = 0;  // its leaves (parallel_for may hand a thread several grains)
    };
    std::vector<Compact> compact((nl + grain - 1) / grain);
    parallel_for(
        nl, threads,
        [&](size_t b, size_t e, int) {
          Compact mine;  // moved in at the end (no false sharing)
          size_t looked_up = 0;
          for (size_t i = b; i < e; ++i) looked_up += recompute[i];
          mine.vertex.reserve(looked_up * 12);
          for (size_t i = b; i < e; ++i) {
            if (!recompute[i]) {
              const uint32_t ol = old_leaf[i];
              leaf_verts.begin[i + 1] = previous_lists->begin[ol + 1] - previous_lists->begin[ol];
              slots[i] = previous_lists->slots[ol];
              continue;
            }
            const LeafGrid g = leaf_grid(octree, field.vertices, static_cast<uint32_t>(i));
            uint32_t c = 0, mask = 0;
            for (int k = 0; k < grid_points; ++k) {
              if (g[k] == kNoVertex) continue;
              mine.vertex.push_back(g[k]);
              mask |= 1u << k;
              ++c;
            }
            leaf_verts.begin[i + 1] = c;
            slots[i] = mask;
          }
          // Kept until every chunk is done: without unused capacity.
          mine.vertex.shrink_to_fit();
          mine.begin = b;
          mine.end = e;
          compact[b / grain] = std::move(mine);
        },
        grain);
    // Each leaf's count was written to begin[i + 1]: summed in place (no count array).
    for (size_t i = 0; i < nl; ++i) leaf_verts.begin[i + 1] += leaf_verts.begin[i];
    auto count = [&](size_t i) { return leaf_verts.begin[i + 1] - leaf_verts.begin[i]; };
    // A consumed field's lists grow in place into the new ones when every row can move up:
    // no row may land below the end of a row of an earlier leaf that is still to be moved
    // (splits only add vertices to a leaf, so this holds after refine_octree; checked).
    bool in_place = incremental && owned != nullptr;
    if (in_place) {
      uint32_t pending_end = 0;  // end of the old rows of the leaves before i that move
      for (size_t i = 0; i < nl && in_place; ++i) {
        in_place = leaf_verts.begin[i] >= pending_end;
        if (!recompute[i]) pending_end = previous_lists->begin[old_leaf[i] + 1];
      }
    }
    auto fill_row = [&](size_t i, const uint32_t* from) {
      std::memmove(leaf_verts.items.data() + leaf_verts.begin[i], from,
                   count(i) * sizeof(uint32_t));
    };
    if (in_place) {
      // Backwards, so that a row is moved before anything is written over its old place.
      leaf_verts.items = std::move(lists->vertex);
      leaf_verts.items.resize(leaf_verts.begin[nl]);
      for (size_t c = compact.size(); c-- > 0;) {
        size_t from_compact = compact[c].vertex.size();
        for (size_t i = compact[c].end; i-- > compact[c].begin;) {
          if (recompute[i]) {
            from_compact -= count(i);
            fill_row(i, compact[c].vertex.data() + from_compact);
          } else {
            fill_row(i, leaf_verts.items.data() + previous_lists->begin[old_leaf[i]]);
          }
        }
        std::vector<uint32_t>().swap(compact[c].vertex);
      }
    } else if (!incremental) {
      // Every row is in the chunks, in order: appended one chunk after the other, each freed
      // once copied (growing remaps, so the lists are not held twice).
      for (Compact& chunk : compact) {
        const size_t at = leaf_verts.items.size();
        leaf_verts.items.resize(at + chunk.vertex.size());
        std::copy(chunk.vertex.begin(), chunk.vertex.end(), leaf_verts.items.begin() + at);
        std::vector<uint32_t>().swap(chunk.vertex);
      }
      GVD_CHECK(leaf_verts.items.size() == leaf_verts.begin[nl], "leaf lists: chunk sizes");
    } else {
      leaf_verts.items.resize(leaf_verts.begin[nl]);
      parallel_for(
          nl, threads,
          [&](size_t b, size_t e, int) {
            size_t from_compact = 0;  // next entry of this chunk's compact lists
            const Compact& mine = compact[b / grain];
            for (size_t i = b; i < e; ++i) {
              if (!recompute[i]) {
                fill_row(i, previous_lists->vertex.data() + previous_lists->begin[old_leaf[i]]);
                continue;
              }
              fill_row(i, mine.vertex.data() + from_compact);
              from_compact += count(i);
            }
          },
          grain);
    }
  }
  // The previous field's lists are copied where they still hold.
  if (owned != nullptr) lists->release();
  auto hand_over_lists = [&] {
    if (lists == nullptr) return;
    lists->begin = std::move(leaf_verts.begin);
    lists->vertex = std::move(leaf_verts.items);
    lists->slots = std::move(slots);
  };
  if (options.method == DistanceMethod::kExact) {
    exact_everywhere(field, geometry, bvh, options, previous, incremental ? old_count : 0,
                     incremental ? owned : nullptr,
                     std::span<const uint32_t>(leaf_verts.items.data(), leaf_verts.items.size()),
                     threads);
    hand_over_lists();
    return field;
  }

  // The paper's wavefront (DistanceMethod::kWavefront).
  Csr vert_leaves;
  vert_leaves.begin.assign(nv + 1, 0);
  for (uint32_t v : leaf_verts.items) ++vert_leaves.begin[v + 1];
  for (size_t v = 0; v < nv; ++v) vert_leaves.begin[v + 1] += vert_leaves.begin[v];
  vert_leaves.items.resize(leaf_verts.items.size());
  {
    std::vector<uint32_t> fill(vert_leaves.begin.begin(), vert_leaves.begin.end() - 1);
    for (size_t l = 0; l < nl; ++l)
      for (uint32_t k = leaf_verts.begin[l]; k < leaf_verts.begin[l + 1]; ++k)
        vert_leaves.items[fill[leaf_verts.items[k]]++] = static_cast<uint32_t>(l);
  }

  // Non-empty vertices: on the boundary of a leaf that intersects an object.
  field.exact.assign(nv, 0);
  for (size_t l = 0; l < nl; ++l) {
    if (octree.object[l] == kNoObject) continue;
    for (uint32_t k = leaf_verts.begin[l]; k < leaf_verts.begin[l + 1]; ++k)
      field.exact[leaf_verts.items[k]] = 1;
  }
  std::vector<uint32_t> nonempty;
  for (size_t v = 0; v < nv; ++v)
    if (field.exact[v]) nonempty.push_back(static_cast<uint32_t>(v));
  field.exact_count = nonempty.size();

  // Initialisation: exact closest point of every non-empty vertex.
  field.label.assign(nv, kNoObject);
  field.point.assign(nv, kNoVertex);
  field.closest.resize(nonempty.size());
  std::vector<uint8_t> reused(nonempty.size(), 0);
  // Queries of the vertices that need an exact point (the others reuse the previous field):
  // position and a bound on the squared distance, then one batch for the solver.
  std::vector<Vec3> query_pos(nonempty.size());
  std::vector<double> query_bound(nonempty.size(), 0.0);
  check_cancel(options);
  const LeafSimplices* simplices = options.leaf_simplices;
  parallel_for(
      nonempty.size(), threads,
      [&](size_t b, size_t e, int) {
        for (size_t i = b; i < e; ++i) {
          const uint32_t v = nonempty[i];
          if (previous != nullptr) {
            const uint32_t pv = incremental ? (v < old_count ? v : kNoVertex)
                                            : previous->vertices.find(field.vertices.key[v]);
            if (pv != kNoVertex && previous->exact[pv]) {
              field.closest[i] = previous->closest[previous->point[pv]];
              field.label[v] = previous->label[pv];
              field.point[v] = static_cast<uint32_t>(i);
              reused[i] = 1;
              continue;
            }
          }
          // The simplices of an incident non-empty leaf bound the search (the paper searches
          // only cells within reach of them); the BVH then finds the exact closest point.
          const Vec3 pos = field.vertices.position(v);
          double bound2 = 1e300;
          for (uint32_t a = vert_leaves.begin[v]; a < vert_leaves.begin[v + 1]; ++a) {
            const uint32_t leaf = vert_leaves.items[a];
            if (simplices == nullptr || !simplices->covers(nl)) break;
            for (const uint32_t s : simplices->of(leaf)) {
              const Simplex& t = geometry.simplices[s];
              bound2 =
                  std::min(bound2, dist2(pos, closest_point_on_simplex(geometry.dimension,
                                                                       geometry.points, t, pos)));
            }
            if (bound2 < 1e300) break;
          }
          query_pos[i] = pos;
          query_bound[i] = bound2 * (1 + 1e-12) + 1e-300;
        }
      },
      512);
  {
    std::vector<uint32_t> todo;  // indices into nonempty
    for (size_t i = 0; i < nonempty.size(); ++i)
      if (!reused[i]) todo.push_back(static_cast<uint32_t>(i));
    std::vector<Vec3> pos(todo.size());
    std::vector<double> bound(todo.size());
    for (size_t j = 0; j < todo.size(); ++j) {
      pos[j] = query_pos[todo[j]];
      bound[j] = query_bound[todo[j]];
    }
    std::vector<ClosestHit> hits(todo.size());
    // In batches when someone watches the progress (a twentieth each, at least 8k queries).
    const size_t step = options.progress ? std::max<size_t>(8192, (todo.size() + 19) / 20)
                                         : std::max<size_t>(todo.size(), 1);
    for (size_t off = 0; off < todo.size(); off += step) {
      const size_t len = std::min(step, todo.size() - off);
      solve_closest(bvh, options, std::span<const Vec3>(pos).subspan(off, len),
                    std::span<const double>(bound).subspan(off, len),
                    std::span<ClosestHit>(hits).subspan(off, len), threads);
      if (options.progress) options.progress(static_cast<double>(off + len) / todo.size());
      check_cancel(options);
    }
    for (size_t j = 0; j < todo.size(); ++j) {
      const uint32_t i = todo[j];
      const uint32_t v = nonempty[i];
      GVD_CHECK(hits[j].found(), "a non-empty vertex must find a closest simplex");
      field.closest[i] = hits[j].point;
      field.label[v] = geometry.object_of[hits[j].simplex];
      field.point[v] = i;
    }
  }
  for (uint8_t r : reused) field.exact_reused += r;

  // Warm start from the previous field (refinement): every vertex that existed keeps its
  // closest point, and only the neighbourhood of new vertices is expanded again. Old values
  // are valid upper bounds (real points on objects), so the expansion only improves them.
  std::vector<uint32_t> prev_of;
  if (previous != nullptr) {
    prev_of.assign(nv, kNoVertex);
    const uint32_t offset = static_cast<uint32_t>(field.closest.size());
    field.closest.insert(field.closest.end(), previous->closest.begin(), previous->closest.end());
    parallel_for(nv, threads, [&](size_t b, size_t e, int) {
      for (size_t v = b; v < e; ++v) {
        const uint32_t pv = incremental ? (v < old_count ? static_cast<uint32_t>(v) : kNoVertex)
                                        : previous->vertices.find(field.vertices.key[v]);
        prev_of[v] = pv;
        if (pv == kNoVertex || field.point[v] != kNoVertex) continue;
        if (previous->point[pv] == kNoVertex) continue;
        field.point[v] = offset + previous->point[pv];
        field.label[v] = previous->label[pv];
        field.exact[v] = previous->exact[pv];
      }
    });
  }

  // Wavefront expansion (Algorithm 1): Dijkstra-like in the distance to the assigned point.
  check_cancel(options);
  std::vector<double> d2(nv, std::numeric_limits<double>::infinity());
  std::vector<Vec3> position(nv);
  parallel_for(nv, threads, [&](size_t b, size_t e, int) {
    for (size_t v = b; v < e; ++v) {
      position[v] = field.vertices.position(static_cast<uint32_t>(v));
      if (field.point[v] != kNoVertex) d2[v] = dist2(position[v], field.closest[field.point[v]]);
    }
  });
  // Ties are broken by the vertex key, not its index, so the result does not depend on how
  // the vertices happen to be numbered (a fresh enumeration or an incremental update).
  using Item = std::tuple<double, uint64_t, uint32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  if (previous == nullptr) {
    // Seeds: the exact vertices that share a leaf with a vertex still to be reached (the
    // others could only offer their points to exact vertices, which never take them).
    std::vector<uint8_t> seeded(nv, 0);
    for (size_t l = 0; l < nl; ++l) {
      bool open = false;
      for (uint32_t k = leaf_verts.begin[l]; k < leaf_verts.begin[l + 1] && !open; ++k)
        open = !field.exact[leaf_verts.items[k]];
      if (!open) continue;
      for (uint32_t k = leaf_verts.begin[l]; k < leaf_verts.begin[l + 1]; ++k) {
        const uint32_t v = leaf_verts.items[k];
        if (field.exact[v] && !seeded[v]) {
          seeded[v] = 1;
          queue.push({d2[v], field.vertices.key[v], v});
        }
      }
    }
  } else {
    // Seeds: the boundary vertices of every leaf that has a new vertex.
    std::vector<uint8_t> seeded(nv, 0);
    for (size_t l = 0; l < nl; ++l) {
      bool fresh = false;
      for (uint32_t k = leaf_verts.begin[l]; k < leaf_verts.begin[l + 1] && !fresh; ++k)
        fresh = prev_of[leaf_verts.items[k]] == kNoVertex;
      if (!fresh) continue;
      for (uint32_t k = leaf_verts.begin[l]; k < leaf_verts.begin[l + 1]; ++k) {
        const uint32_t v = leaf_verts.items[k];
        if (!seeded[v] && field.point[v] != kNoVertex) {
          seeded[v] = 1;
          queue.push({d2[v], field.vertices.key[v], v});
        }
      }
    }
  }
  uint64_t pops = 0;
  while (!queue.empty()) {
    const auto [dv, key, v] = queue.top();
    queue.pop();
    if (dv > d2[v]) continue;  // stale entry
    if ((++pops & 0xfffff) == 0) check_cancel(options);
    const Vec3 p = field.closest[field.point[v]];
    for (uint32_t a = vert_leaves.begin[v]; a < vert_leaves.begin[v + 1]; ++a) {
      const uint32_t leaf = vert_leaves.items[a];
      for (uint32_t k = leaf_verts.begin[leaf]; k < leaf_verts.begin[leaf + 1]; ++k) {
        const uint32_t w = leaf_verts.items[k];
        if (field.exact[w]) continue;  // already holds its true closest point
        const double dw = dist2(position[w], p);
        if (dw < d2[w]) {
          d2[w] = dw;
          field.point[w] = field.point[v];
          field.label[w] = field.label[v];
          queue.push({dw, field.vertices.key[w], w});
        }
      }
    }
  }
  const int exact_passes = options.exact_near_gvd ? 16 : 0;

  // Exact closest points on the vertices of leaves the GVD crosses (see DistanceOptions).
  for (int pass = 0; pass < exact_passes; ++pass) {
    check_cancel(options);
    std::vector<std::vector<uint32_t>> marked_chunks((nl + 1023) / 1024 + 1);
    parallel_for(
        nl, threads,
        [&](size_t b, size_t e, int) {
          std::vector<uint32_t> marked;  // moved in at the end (no false sharing)
          for (size_t l = b; l < e; ++l) {
            const uint32_t* vb = leaf_verts.items.data() + leaf_verts.begin[l];
            const uint32_t* ve = leaf_verts.items.data() + leaf_verts.begin[l + 1];
            bool mixed = false;
            for (const uint32_t* p = vb + 1; p < ve; ++p)
              mixed |= field.label[*p] != field.label[*vb];
            if (!mixed) continue;
            for (const uint32_t* p = vb; p < ve; ++p)
              if (!field.exact[*p]) marked.push_back(*p);
          }
          marked_chunks[b / 1024] = std::move(marked);
        },
        1024);
    std::vector<uint32_t> marked;
    for (auto& c : marked_chunks) marked.insert(marked.end(), c.begin(), c.end());
    std::sort(marked.begin(), marked.end());
    marked.erase(std::unique(marked.begin(), marked.end()), marked.end());
    if (marked.empty()) break;
    std::vector<ClosestHit> hits(marked.size());
    std::vector<Vec3> pos(marked.size());
    std::vector<double> bound(marked.size());
    for (size_t i = 0; i < marked.size(); ++i) {
      // The wavefront distance bounds the search (the exact one is never larger).
      pos[i] = position[marked[i]];
      bound[i] = d2[marked[i]] * (1 + 1e-9) + 1e-300;
    }
    solve_closest(bvh, options, pos, bound, hits, threads);
    for (size_t i = 0; i < marked.size(); ++i) {
      const uint32_t v = marked[i];
      field.exact[v] = 1;
      ++field.exact_near_gvd;
      if (!hits[i].found()) continue;  // the wavefront point was already the closest
      field.point[v] = static_cast<uint32_t>(field.closest.size());
      field.closest.push_back(hits[i].point);
      field.label[v] = geometry.object_of[hits[i].simplex];
      d2[v] = hits[i].dist2;
    }
  }

  // Which vertices differ from the previous field (new, or another closest point), so that
  // later passes can skip untouched leaves; then drop closest points nobody references.
  field.changed.assign(nv, 1);
  if (previous != nullptr) {
    parallel_for(nv, threads, [&](size_t b, size_t e, int) {
      for (size_t v = b; v < e; ++v) {
        const uint32_t pv = prev_of[v];
        if (pv == kNoVertex || field.point[v] == kNoVertex || previous->point[pv] == kNoVertex)
          continue;
        field.changed[v] = field.label[v] != previous->label[pv] ||
                           field.closest[field.point[v]] != previous->closest[previous->point[pv]];
      }
    });
  }
  std::vector<uint32_t> remap(field.closest.size(), kNoVertex);
  for (size_t v = 0; v < nv; ++v)
    if (field.point[v] != kNoVertex) remap[field.point[v]] = 0;
  uint32_t used = 0;
  for (uint32_t& r : remap)
    if (r != kNoVertex) r = used++;
  std::vector<Vec3> compact(used);
  for (size_t i = 0; i < remap.size(); ++i)
    if (remap[i] != kNoVertex) compact[remap[i]] = field.closest[i];
  for (size_t v = 0; v < nv; ++v)
    if (field.point[v] != kNoVertex) field.point[v] = remap[field.point[v]];
  field.closest = std::move(compact);
  hand_over_lists();
  return field;
}

}  // namespace

DistanceField compute_distances(const Octree& octree, const UnitGeometry& geometry,
                                const SimplexBvh& bvh, const DistanceOptions& options,
                                LeafVertices* lists) {
  return distances(octree, geometry, bvh, options, nullptr, nullptr, nullptr, lists);
}

DistanceField compute_distances(const Octree& octree, const UnitGeometry& geometry,
                                const SimplexBvh& bvh, const DistanceOptions& options,
                                const DistanceField& previous, const Octree* previous_octree,
                                const LeafVertices* previous_lists, LeafVertices* lists) {
  GVD_CHECK(lists == nullptr || lists != previous_lists, "compute_distances: lists in and out");
  return distances(octree, geometry, bvh, options, &previous, previous_octree, previous_lists,
                   lists);
}

DistanceField compute_distances(const Octree& octree, const UnitGeometry& geometry,
                                const SimplexBvh& bvh, const DistanceOptions& options,
                                DistanceField&& previous, Octree&& previous_octree,
                                LeafVertices& lists) {
  if (!lists.covers(previous_octree.leaf_count())) {
    return distances(octree, geometry, bvh, options, &previous, nullptr, nullptr, &lists);
  }
  return distances(octree, geometry, bvh, options, &previous, &previous_octree, &lists, &lists,
                   &previous, &previous_octree);
}

}  // namespace gvd::distance

namespace gvd::distance {

void sort_vertices(DistanceField& field, LeafVertices* lists, int threads) {
  threads = resolve_threads(threads);
  const size_t nv = field.vertices.size();
  const std::vector<uint64_t>& key = field.vertices.key;
  if (std::is_sorted(key.begin(), key.end())) return;
  // Incremental rounds append new vertices behind the sorted old ones: sort the tail and merge.
  size_t prefix = 1;
  while (prefix < nv && key[prefix - 1] < key[prefix]) ++prefix;
  // Only the tail is sorted; the merge writes each vertex's new position (4 bytes per vertex,
  // not a 16-byte pair: this runs at the end of the refinement, near its peak).
  using Keyed = std::pair<uint64_t, uint32_t>;
  std::vector<Keyed> tail(nv - prefix);
  parallel_for(nv - prefix, threads, [&](size_t b, size_t e, int) {
    for (size_t i = b; i < e; ++i) tail[i] = {key[prefix + i], static_cast<uint32_t>(prefix + i)};
  });
  radix_sort(
      tail, [](const Keyed& x) { return x.first; }, threads);
  std::vector<uint32_t> new_index(nv);  // old index -> sorted position
  for (size_t i = 0, h = 0, t = 0; i < nv; ++i) {
    const bool from_head = t == tail.size() || (h < prefix && key[h] < tail[t].first);
    new_index[from_head ? h++ : tail[t++].second] = static_cast<uint32_t>(i);
  }
  std::vector<Keyed>().swap(tail);
  // The per-vertex arrays are permuted in place, cycle by cycle (no copy of any of them: the
  // key array alone is 8 bytes per vertex); a cycle's start is where new_index points back.
  std::vector<uint8_t>* bytes[] = {&field.exact, &field.changed};
  std::vector<uint32_t>* words[] = {&field.label, &field.point};
  for (auto* a : bytes) GVD_CHECK(a->size() == nv || a->empty(), "sort_vertices: array size");
  for (auto* a : words) GVD_CHECK(a->size() == nv || a->empty(), "sort_vertices: array size");
  std::vector<uint64_t>& keys = field.vertices.key;
  std::vector<bool> placed(nv, false);
  for (size_t start = 0; start < nv; ++start) {
    if (placed[start] || new_index[start] == start) continue;
    // Carry the element at `start` to its position, the one found there to its own, and
    // so on until the cycle closes at `start`.
    uint64_t k = keys[start];
    uint8_t b[2];
    uint32_t w[2];
    for (int a = 0; a < 2; ++a) b[a] = bytes[a]->empty() ? 0 : (*bytes[a])[start];
    for (int a = 0; a < 2; ++a) w[a] = words[a]->empty() ? 0 : (*words[a])[start];
    for (size_t at = new_index[start];; at = new_index[at]) {
      std::swap(k, keys[at]);
      for (int a = 0; a < 2; ++a)
        if (!bytes[a]->empty()) std::swap(b[a], (*bytes[a])[at]);
      for (int a = 0; a < 2; ++a)
        if (!words[a]->empty()) std::swap(w[a], (*words[a])[at]);
      placed[at] = true;
      if (at == start) break;
    }
  }
  // Same keys, new positions: the index's values are renumbered in place (no inserts).
  field.vertices.index.transform_values([&](uint32_t v) { return new_index[v]; }, threads);
  if (lists == nullptr) return;
  parallel_for(lists->vertex.size(), threads, [&](size_t b, size_t e, int) {
    for (size_t i = b; i < e; ++i) lists->vertex[i] = new_index[lists->vertex[i]];
  });
}

}  // namespace gvd::distance

#include <algorithm>
#include <cmath>
#include <numeric>

// The ambiguity test runs on the faces the surfacer walks (§5 is defined on them).
#include "../surface/cell_faces.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/geometry/primitives.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/subdivision_rule.h"
#include "gvd/refine/find_cells_to_refine.h"

namespace gvd::refine {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;

namespace {

// Paper §5: collapse boundary-graph edges with equal labels; the cell is unambiguous when
// what is left is a complete graph on at most D + 1 nodes (a simplex).
bool is_ambiguous(const Octree& octree, const DistanceField& field, const LeafGrid& grid,
                  uint32_t leaf) {
  const int dim = octree.dimension;
  // Local union-find over the <= 26 grid slots.
  int parent[27];
  std::iota(parent, parent + 27, 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  bool mixed = false;
  const ObjectId first = field.label[grid[0]];
  for (uint32_t v : grid) mixed |= v != kNoVertex && field.label[v] != first;
  if (!mixed) return false;
  struct Edge {
    int a, b;
  };
  Edge edges[96];
  int ne = 0;
  surface::detail::for_each_face_polygon(
      octree, grid, leaf, [&](const surface::detail::FacePolygon& poly) {
        for (int i = 0; i < poly.n && ne < 96; ++i)
          edges[ne++] = {poly.slot[i], poly.slot[(i + 1) % poly.n]};
      });
  for (int e = 0; e < ne; ++e) {
    if (field.label[grid[edges[e].a]] == field.label[grid[edges[e].b]]) {
      parent[find(edges[e].a)] = find(edges[e].b);
    }
  }
  int roots[27];
  int nr = 0;
  for (int s = 0; s < 27; ++s) {
    if (grid[s] == kNoVertex) continue;
    const int r = find(s);
    if (std::find(roots, roots + nr, r) == roots + nr) roots[nr++] = r;
  }
  if (nr > dim + 1) return true;
  // In 3D a cell seen by only two objects cannot hide a wrong adjacency: two separate sheets
  // of one interface are coned separately (one cone per spoke curve), so only junction cells
  // (three or more objects) are worth refining there.
  if (dim == 3) {
    ObjectId seen[27];
    int ns = 0;
    for (int i = 0; i < nr; ++i) {
      const ObjectId l = field.label[grid[roots[i]]];
      if (std::find(seen, seen + ns, l) == seen + ns) seen[ns++] = l;
    }
    if (ns < 3) return false;
  }
  // Complete: every pair of collapsed nodes joined by an edge.
  bool adjacent[27][27] = {};
  for (int e = 0; e < ne; ++e) {
    const int ra = find(edges[e].a), rb = find(edges[e].b);
    adjacent[ra][rb] = adjacent[rb][ra] = true;
  }
  for (int i = 0; i < nr; ++i)
    for (int j = i + 1; j < nr; ++j)
      if (!adjacent[roots[i]][roots[j]]) return true;
  return false;
}

// Unseen when another object is nearer to p than every object p claims (`allowed`), by more
// than `margin`: in 3D a twentieth of the cell (thinner slivers along junction lines are below
// the resolution), in 2D a hair (junctions are points, cheap to resolve); exact ties (e.g. a
// bisector on an octree plane) never count. `claimed2` bounds the search.
bool nearer_unclaimed(const UnitGeometry& geometry, const SimplexBvh& bvh, Vec3 p, double claimed2,
                      const ObjectId* allowed, int na, double margin) {
  auto ok = [&](uint32_t s) {
    return std::find(allowed, allowed + na, geometry.object_of[s]) != allowed + na;
  };
  // The nearest unclaimed object within claimed2 (the search skips the claimed objects'
  // subtrees), then whether a claimed one is within its distance plus the margin.
  const ClosestHit hit = bvh.nearest_excluding(p, allowed, na, claimed2);
  if (!hit.found()) return false;
  const double d = std::sqrt(hit.dist2) + margin;
  return !bvh.nearest_if(p, ok, d * d).found();
}

double unseen_margin(int dimension, double size) { return (dimension == 2 ? 1e-9 : 0.05) * size; }

// The bisector point of edge (v, w) that surfacing will use (surface::detail::refine_bisector where
// Eq. (1) is coarse, as the surfacer does) and, in `claimed2`, the larger squared distance
// from it to the edge's two objects, exact where it was refined.
Vec3 edge_bisector(const DistanceField& field, const SimplexBvh& bvh, uint32_t v, uint32_t w,
                   double& claimed2) {
  if (v > w) std::swap(v, w);
  Vec3 a = field.closest[field.point[v]], b = field.closest[field.point[w]];
  Vec3 p = surface::detail::bisector_point(field, v, w);
  if (surface::detail::coarse_edge(field, v, w, p)) {
    p = surface::detail::refine_bisector(field, bvh, v, w, p, &a, &b);
    // The exact distances at the final point.
    const ClosestHit ha = bvh.nearest_in_object(p, field.label[v], dist2(p, a));
    const ClosestHit hb = bvh.nearest_in_object(p, field.label[w], dist2(p, b));
    if (ha.found()) a = ha.point;
    if (hb.found()) b = hb.point;
  }
  claimed2 = std::max(dist2(p, a), dist2(p, b));
  return p;
}

// The per-cell part of the unseen test (RefineOptions): true when a face or cell centroid of
// the GVD is nearer to an object that no vertex of the leaf carries. The edge bisectors are
// tested once per edge by the caller: their edges (smaller vertex << 32 | larger) are appended
// to `edges`.
bool has_unseen_object(const Octree& octree, const DistanceField& field, const LeafGrid& grid,
                       uint32_t leaf, const UnitGeometry& geometry, const SimplexBvh& bvh,
                       std::vector<uint64_t>& edges) {
  ObjectId labels[27];
  int nl = 0;
  for (uint32_t v : grid) {
    if (v == kNoVertex) continue;
    const ObjectId l = field.label[v];
    if (std::find(labels, labels + nl, l) == labels + nl) labels[nl++] = l;
  }
  if (nl < 2) return false;
  const Box box = octree.box(leaf);
  const double margin = unseen_margin(octree.dimension, box.hi.x - box.lo.x);
  // The cell's vertices' closest points bound the nearest-object search at a centroid.
  auto bound_at = [&](Vec3 q) {
    double b = 1e300;
    for (uint32_t v : grid)
      if (v != kNoVertex) b = std::min(b, dist2(q, field.closest[field.point[v]]));
    return b;
  };
  bool found = false;
  Vec3 all;
  int count = 0;
  surface::detail::for_each_face_polygon(
      octree, grid, leaf, [&](const surface::detail::FacePolygon& poly) {
        if (found) return;
        Vec3 sum;
        int n = 0;
        for (int i = 0; i < poly.n; ++i) {
          const uint32_t v = poly.v[i], w = poly.v[(i + 1) % poly.n];
          if (field.label[v] == field.label[w]) continue;
          // Per-edge claims are checked in 2D only: there junctions are points and refining them
          // converges, while along 3D junction lines a third object's wedge intrudes into a/b
          // edges at every scale (the check would refine forever); the centroid checks below
          // still catch regions that no vertex of the cell sees.
          if (octree.dimension == 2) {
            edges.push_back(v < w ? (uint64_t{v} << 32 | w) : (uint64_t{w} << 32 | v));
          }
          sum = sum + surface::detail::bisector_point(field, v, w);
          ++n;
        }
        // Face centroids in 2D (the cell is the face); in 3D one check at the cell centroid
        // below is enough to see a region hidden inside, at a sixth of the cost.
        if (n > 0) {
          if (octree.dimension == 2) {
            found = nearer_unclaimed(geometry, bvh, sum / n, bound_at(sum / n), labels, nl, margin);
          }
          all = all + sum;
          count += n;
        }
      });
  if (!found && octree.dimension == 3 && count > 0) {
    found = nearer_unclaimed(geometry, bvh, all / count, bound_at(all / count), labels, nl, margin);
  }
  return found;
}

// The one object of `simplices`, kManyObjects for several, kNoObject for none.
template <class Range>
ObjectId object_of_list(const UnitGeometry& geometry, const Range& simplices) {
  ObjectId obj = kNoObject;
  for (uint32_t s : simplices) {
    const ObjectId o = geometry.object_of[s];
    if (obj == kNoObject) obj = o;
    if (o != obj) return kManyObjects;
  }
  return obj;
}

// Whether a cell at `level` holding the simplices `simplices` of several objects may stay a
// leaf without a certificate: only at the contact depth, when every two of its objects touch
// (the depth limit is checked by the callers).
template <class Range>
bool touching_only(const UnitGeometry& geometry, const Range& simplices, int level,
                   const ContactPairs* contacts, int contact_depth) {
  if (contacts == nullptr || level < contact_depth) return false;
  std::vector<ObjectId> objects;
  for (uint32_t s : simplices) {
    const ObjectId o = geometry.object_of[s];
    if (std::find(objects.begin(), objects.end(), o) == objects.end()) objects.push_back(o);
  }
  for (size_t i = 0; i < objects.size(); ++i)
    for (size_t j = i + 1; j < objects.size(); ++j)
      if (!contacts->touching(objects[i], objects[j])) return false;
  return true;
}

}  // namespace

RefineReport find_cells_to_refine(const Octree& octree, const DistanceField& field,
                                  const RefineOptions& options) {
  const int threads = resolve_threads(options.threads);
  const size_t n = octree.leaf_count();
  // 0 = fine, 1 = ambiguous, 2 = foreign label in a non-empty leaf, 3 = unseen object;
  // +4 when at the limit.
  std::vector<uint8_t> flag(n, 0);
  const bool check_unseen = options.geometry != nullptr && options.bvh != nullptr;
  const LeafVertices* rows = options.leaf_vertices != nullptr && options.leaf_vertices->covers(n)
                                 ? options.leaf_vertices
                                 : nullptr;
  const LeafSimplices* inside_of =
      options.leaf_simplices != nullptr && options.leaf_simplices->covers(n)
          ? options.leaf_simplices
          : nullptr;
  // (edge, leaf) pairs of the leaves whose bisectors still need the unseen test.
  const size_t grain = 1024;
  std::vector<std::vector<std::pair<uint64_t, uint32_t>>> edge_chunks((n + grain - 1) / grain + 1);
  parallel_for(
      n, threads,
      [&](size_t b, size_t e, int) {
        std::vector<uint64_t> edges;
        std::vector<std::pair<uint64_t, uint32_t>> pairs;  // moved in at the end
        for (size_t i = b; i < e; ++i) {
          const uint32_t leaf = static_cast<uint32_t>(i);
          const ObjectId obj = octree.object[leaf];
          if (octree.is_certified(leaf)) continue;
          if (rows != nullptr) {
            // From the leaf's row of vertices: an empty leaf seen by one object only (most
            // of them), or one that did not change, has nothing to check.
            const std::span<const uint32_t> row = rows->of(leaf);
            const uint32_t* vb = row.data();
            const uint32_t* ve = vb + row.size();
            bool changed = !options.changed_only, mixed = false;
            for (const uint32_t* v = vb; v != ve; ++v) {
              changed |= field.changed[*v] != 0;
              mixed |= field.label[*v] != field.label[*vb];
            }
            if (obj != kManyObjects && (!changed || (obj == kNoObject && !mixed))) continue;
          }
          const LeafGrid grid =
              rows != nullptr ? rows->grid(octree, field.vertices, leaf) : field.grid(octree, leaf);
          if (options.changed_only && obj != kManyObjects) {
            bool changed = false;
            for (uint32_t v : grid) changed |= v != kNoVertex && field.changed[v];
            if (!changed) continue;
          }
          uint8_t f = 0;
          if (obj == kManyObjects && options.geometry != nullptr && inside_of != nullptr) {
            // Several objects in an uncertified leaf above the depth limit (a sub-cell of a
            // certified cell that 2:1 balance split and whose own certificate failed): the
            // paper's rule splits it, unless only touching pairs meet there.
            const std::span<const uint32_t> inside = inside_of->of(leaf);
            if (!touching_only(*options.geometry, inside, octree.level[leaf], options.contacts,
                               options.contact_depth))
              f = 2;
          }
          if (obj != kNoObject && obj != kManyObjects) {
            const bool at_contact =
                options.contacts != nullptr && octree.level[leaf] >= options.contact_depth;
            for (uint32_t v : grid) {
              if (v == kNoVertex || field.label[v] == obj) continue;
              if (at_contact && options.contacts->touching(obj, field.label[v])) continue;
              f = 2;
            }
          }
          if (f == 0 && obj != kManyObjects && is_ambiguous(octree, field, grid, leaf)) f = 1;
          if (f == 0 && obj == kNoObject && check_unseen) {
            edges.clear();
            if (has_unseen_object(octree, field, grid, leaf, *options.geometry, *options.bvh,
                                  edges)) {
              f = 3;
            } else {
              for (uint64_t edge : edges) pairs.push_back({edge, leaf});
            }
          }
          int limit = octree.max_depth;
          if (f == 1 && !options.base_level.empty()) {
            limit = std::min(limit, options.base_level[leaf] + options.ambiguity_levels);
          }
          if (f != 0 && octree.level[leaf] >= limit) f |= 4;
          flag[i] = f;
        }
        edge_chunks[b / grain] = std::move(pairs);
      },
      grain);
  if (check_unseen) {
    // Each transition edge is shared by up to 4 leaves and 2 faces of each: test it once.
    std::vector<std::pair<uint64_t, uint32_t>> pairs;
    for (auto& c : edge_chunks) pairs.insert(pairs.end(), c.begin(), c.end());
    std::sort(pairs.begin(), pairs.end());
    std::vector<size_t> starts;
    for (size_t i = 0; i < pairs.size(); ++i)
      if (i == 0 || pairs[i].first != pairs[i - 1].first) starts.push_back(i);
    starts.push_back(pairs.size());
    std::vector<uint8_t> flagged(starts.size() - 1, 0);
    parallel_for(
        flagged.size(), threads,
        [&](size_t b, size_t e, int) {
          for (size_t k = b; k < e; ++k) {
            const uint64_t edge = pairs[starts[k]].first;
            const uint32_t v = static_cast<uint32_t>(edge >> 32);
            const uint32_t w = static_cast<uint32_t>(edge);
            double claimed = 0;
            const Vec3 p = edge_bisector(field, *options.bvh, v, w, claimed);
            const ObjectId pair[2] = {field.label[v], field.label[w]};
            const double length = dist(field.vertices.position(v), field.vertices.position(w));
            flagged[k] = nearer_unclaimed(*options.geometry, *options.bvh, p, claimed, pair, 2,
                                          unseen_margin(octree.dimension, length));
          }
        },
        256);
    for (size_t k = 0; k < flagged.size(); ++k) {
      if (!flagged[k]) continue;
      for (size_t i = starts[k]; i < starts[k + 1]; ++i) {
        const uint32_t leaf = pairs[i].second;
        if (flag[leaf] == 0) flag[leaf] = octree.level[leaf] >= octree.max_depth ? 3 | 4 : 3;
      }
    }
  }
  RefineReport report;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t f = flag[i];
    if (octree.object[i] == kManyObjects && !octree.is_certified(static_cast<uint32_t>(i)))
      ++report.touching_leaves;
    if (f == 0) continue;
    const bool at_limit = f & 4;
    const uint32_t leaf = static_cast<uint32_t>(i);
    switch (f & 3) {
      case 1:
        ++report.ambiguous_count;
        report.ambiguous_at_limit += at_limit;
        if (!at_limit) report.ambiguous_leaves.push_back(leaf);
        break;
      case 2:
        ++report.foreign_count;
        report.foreign_at_limit += at_limit;
        if (!at_limit) report.foreign_leaves.push_back(leaf);
        break;
      default:
        ++report.unseen_count;
        report.unseen_at_limit += at_limit;
        if (!at_limit) report.unseen_leaves.push_back(leaf);
        break;
    }
  }
  return report;
}

SeparationPlan plan_separation_splits(const Octree& octree, const LeafSimplices& leaf_simplices,
                                      const UnitGeometry& geometry, const SimplexBvh& bvh,
                                      std::span<const uint32_t> leaves, int threads,
                                      const ContactPairs* contacts, int contact_depth,
                                      const SplitOracle* oracle) {
  threads = resolve_threads(threads);
  const int dim = octree.dimension;
  const uint32_t nchildren = 1u << dim;
  GVD_CHECK(leaf_simplices.covers(octree.leaf_count()), "plan_separation_splits: leaf simplices");
  std::vector<std::vector<CellRef>> per_leaf(leaves.size()), certified(leaves.size());
  parallel_for(
      leaves.size(), threads,
      [&](size_t b, size_t e, int) {
        std::vector<std::pair<CellRef, std::vector<uint32_t>>> stack;
        for (size_t i = b; i < e; ++i) {
          const uint32_t leaf = leaves[i];
          const std::span<const uint32_t> row = leaf_simplices.of(leaf);
          std::vector<uint32_t> list(row.begin(), row.end());
          stack.clear();
          stack.push_back({cell_of(octree, leaf), std::move(list)});
          while (!stack.empty()) {
            auto [cell, simplices] = std::move(stack.back());
            stack.pop_back();
            if (cell.level >= octree.max_depth) continue;
            if (oracle != nullptr) {
              const CellVerdict v = oracle->classify(
                  lattice::cell_box(dim, lattice::morton_decode(dim, cell.code), cell.level),
                  simplices);
              // Only certificates that hold for every sub-cell: a cone's (kCone...)
              // is checked on the lines of its children, and 2:1 balance after this round can
              // split its grandchildren, which then need this plan again, round after round.
              const bool whole = !is_cone(v);
              if (whole && certified_mark(v) != 0) {
                cell.mark = certified_mark(v);
                certified[i].push_back(cell);
              }
              if (whole && v != CellVerdict::kSplit) continue;
            }
            per_leaf[i].push_back(cell);
            const double slack = overlap_slack(cell.level + 1);
            // The object nearest to each of the 3^D points of the cell's half-size grid (the
            // children's corners, most shared by several children), found once.
            ObjectId near_at[27];
            bool known[27] = {};
            const Box cell_box =
                lattice::cell_box(dim, lattice::morton_decode(dim, cell.code), cell.level);
            const Vec3 half = (cell_box.hi - cell_box.lo) * 0.5;
            for (uint32_t c = 0; c < nchildren; ++c) {
              const CellRef child = child_cell(dim, cell, c);
              const lattice::Coord lo = lattice::morton_decode(dim, child.code);
              const Box box = lattice::cell_box(dim, lo, child.level);
              std::vector<uint32_t> inside;
              for (uint32_t s : simplices)
                if (simplex_overlaps_box(dim, geometry.points, geometry.simplices[s], box, slack))
                  inside.push_back(s);
              if (inside.empty()) continue;
              // Several objects in the child: split on, but at the contact depth where they
              // all touch (as the leaf's own rule in find_cells_to_refine).
              const ObjectId own = object_of_list(geometry, inside);
              if (own == kManyObjects) {
                if (!touching_only(geometry, inside, child.level, contacts, contact_depth))
                  stack.push_back({child, std::move(inside)});
                continue;
              }
              bool foreign = false;
              for (uint32_t k = 0; k < nchildren && !foreign; ++k) {
                int local[3] = {0, 0, 0};
                for (int a = 0; a < dim; ++a) local[a] = ((c >> a) & 1) + ((k >> a) & 1);
                const int slot = local[0] + 3 * local[1] + 9 * local[2];
                if (!known[slot]) {
                  known[slot] = true;
                  Vec3 corner = cell_box.lo;
                  for (int a = 0; a < dim; ++a) corner[a] += local[a] * half[a];
                  // A simplex of this object touches the child: its distance bounds the
                  // search (the nearest simplex, hence its object, is the same).
                  const double bound2 = dist2(
                      corner, closest_point_on_simplex(dim, geometry.points,
                                                       geometry.simplices[inside[0]], corner));
                  ClosestHit hit = bvh.nearest(corner, bound2 * (1 + 1e-9) + 1e-300);
                  if (!hit.found()) hit = bvh.nearest(corner);
                  near_at[slot] = hit.found() ? geometry.object_of[hit.simplex] : kNoObject;
                }
                const ObjectId near = near_at[slot];
                if (near == kNoObject) continue;
                foreign = near != own && !(contacts != nullptr && child.level >= contact_depth &&
                                           contacts->touching(own, near));
              }
              if (foreign) stack.push_back({child, std::move(inside)});
            }
          }
        }
      },
      16);
  SeparationPlan out;
  for (auto& v : per_leaf) out.splits.insert(out.splits.end(), v.begin(), v.end());
  for (auto& v : certified) out.certified.insert(out.certified.end(), v.begin(), v.end());
  return out;
}

}  // namespace gvd::refine

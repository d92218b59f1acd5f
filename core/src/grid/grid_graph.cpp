// The dual graph of the uniform-grid discrete GVD (grid_graph.h).

#include "gvd/grid/grid_graph.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/graph/build_dual_graph.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/contacts.h"
#include "gvd/octree/octree.h"

namespace gvd::grid {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::graph;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// What one pass keeps per object pair (key: a << 32 | b, a < b).
struct PairFaces {
  uint64_t faces = 0;
  double least = kInf;  ///< pass 1: the least estimate; pass 2: the least exact clearance
  uint64_t face = 0;    ///< the face where `least` was found (cell * 3 + axis)
  Vec3 point;           ///< pass 2: that face's centre (user units)
};
using PairMap = std::unordered_map<uint64_t, PairFaces>;

/// Calls visit(cell, axis, neighbour, a, b) for every face between two cells of different
/// objects (a < b) in the slices [begin, end) (along z in 3D, y in 2D); reads `cancel` every
/// row.
template <class Visit>
void for_each_interface_face(const DistanceGrid& grid, size_t begin, size_t end,
                             const std::atomic<bool>* cancel, Visit&& visit) {
  const GridSpec& spec = grid.spec;
  const int dim = spec.dimension;
  const uint64_t nx = static_cast<uint64_t>(spec.n[0]), ny = static_cast<uint64_t>(spec.n[1]);
  const uint64_t stride[3] = {1, nx, nx * ny};
  for (size_t s = begin; s < end; ++s) {
    const uint64_t rows = dim == 3 ? ny : 1;
    for (uint64_t r = 0; r < rows; ++r) {
      throw_if_cancelled(cancel, "the grid's dual graph");
      const uint64_t j = dim == 3 ? r : s, k = dim == 3 ? s : 0;
      for (uint64_t i = 0; i < nx; ++i) {
        const uint64_t cell = i + j * stride[1] + k * stride[2];
        const int32_t la = grid.label[cell];
        if (la < 0) continue;
        const uint64_t at[3] = {i, j, k};
        for (int a = 0; a < dim; ++a) {
          if (at[a] + 1 >= static_cast<uint64_t>(spec.n[a])) continue;
          const uint64_t next = cell + stride[a];
          const int32_t lb = grid.label[next];
          if (lb < 0 || lb == la) continue;
          visit(cell, a, next, static_cast<ObjectId>(std::min(la, lb)),
                static_cast<ObjectId>(std::max(la, lb)));
        }
      }
    }
  }
}

/// The centre of the face between `cell` and its upper neighbour along `axis`.
Vec3 face_centre(const GridSpec& spec, uint64_t cell, int axis) {
  const uint64_t nx = static_cast<uint64_t>(spec.n[0]), ny = static_cast<uint64_t>(spec.n[1]);
  const int i = static_cast<int>(cell % nx), j = static_cast<int>(cell / nx % ny),
            k = static_cast<int>(cell / (nx * ny));
  Vec3 p = spec.centre(i, j, k);
  p[axis] += 0.5 * spec.h;
  return p;
}

/// The per-thread maps merged: faces summed, the least `least` kept (ties: the lower face,
/// so that the answer does not depend on the thread count).
PairMap merge(std::vector<PairMap>& parts) {
  PairMap all;
  for (PairMap& part : parts) {
    for (const auto& [key, p] : part) {
      PairFaces& q = all[key];
      q.faces += p.faces;
      if (p.least < q.least || (p.least == q.least && p.face < q.face)) {
        q.least = p.least;
        q.face = p.face;
        q.point = p.point;
      }
    }
  }
  return all;
}

}  // namespace

DualGraph grid_dual_graph(const DistanceGrid& grid, const Scene& scene,
                          const GridGraphOptions& options) {
  const GridSpec& spec = grid.spec;
  const int dim = spec.dimension;
  GVD_CHECK(dim == scene.dimension && grid.label.size() == spec.cell_count() &&
                grid.distance.size() == spec.cell_count(),
            "grid_dual_graph: the grid is not one of this scene");
  const int threads = resolve_threads(options.threads);
  const std::atomic<bool>* cancel = options.cancel;
  const size_t slices = static_cast<size_t>(dim == 3 ? spec.n[2] : spec.n[1]);
  // Progress, reported from the calling thread (index 0 of parallel_for): each pass over the
  // faces is 0.45 of the work, the contacts and gaps at the end the rest.
  std::atomic<size_t> done{0};
  auto advance = [&](size_t count, int t, double base) {
    const size_t now = done.fetch_add(count) + count;
    if (t == 0 && options.progress) options.progress(base + 0.45 * now / slices);
  };
  auto magnitude = [&](uint64_t cell) { return std::abs(grid.distance[cell]); };

  // Pass 1: faces per pair, and the face whose cells are nearest the objects.
  std::vector<PairMap> parts(static_cast<size_t>(threads));
  parallel_for(
      slices, threads,
      [&](size_t b, size_t e, int t) {
        PairMap& m = parts[static_cast<size_t>(t)];
        for (size_t slice = b; slice < e; ++slice) {
          for_each_interface_face(
              grid, slice, slice + 1, cancel,
              [&](uint64_t cell, int axis, uint64_t next, ObjectId a, ObjectId o) {
                PairFaces& p = m[uint64_t{a} << 32 | o];
                ++p.faces;
                const double estimate = magnitude(cell) + magnitude(next);
                const uint64_t face = cell * 3 + static_cast<uint64_t>(axis);
                if (estimate < p.least || (estimate == p.least && face < p.face)) {
                  p.least = estimate;
                  p.face = face;
                }
              });
          advance(1, t, 0.0);
        }
      },
      1);
  const PairMap counted = merge(parts);

  // The scene in the unit domain along x, y, z, for exact distances.
  DomainOptions world;
  world.frame = DomainFrame::kWorld;
  const Domain domain = make_domain(scene, world);
  const UnitGeometry geometry = make_unit_geometry(scene, domain);
  const SimplexBvh bvh(dim, geometry.points, geometry.simplices, geometry.object_of);
  auto clearance = [&](Vec3 user) {
    return std::sqrt(bvh.nearest(domain.to_unit(user)).dist2) * domain.side;
  };

  // Pass 2: the least exact clearance over each pair's faces. The estimated face gives an
  // upper bound; a face is measured only when its cells' distances allow it to be lower (a
  // face centre is h / 2 from each cell centre; an L1 distance is at most sqrt(D) times the
  // Euclidean one, an L-infinity distance at most the Euclidean one).
  std::unordered_map<uint64_t, double> upper;
  for (const auto& [key, p] : counted)
    upper[key] = clearance(face_centre(spec, p.face / 3, static_cast<int>(p.face % 3)));
  const double shrink = grid.metric == GridMetric::kL1 ? 1 / std::sqrt(double(dim)) : 1.0;
  for (PairMap& m : parts) m.clear();
  done = 0;
  throw_if_cancelled(cancel, "the grid's dual graph");
  parallel_for(
      slices, threads,
      [&](size_t b, size_t e, int t) {
        PairMap& m = parts[static_cast<size_t>(t)];
        for (size_t slice = b; slice < e; ++slice) {
          for_each_interface_face(
              grid, slice, slice + 1, cancel,
              [&](uint64_t cell, int axis, uint64_t next, ObjectId a, ObjectId o) {
                const uint64_t key = uint64_t{a} << 32 | o;
                const double bound =
                    shrink * std::min(magnitude(cell), magnitude(next)) - 0.5 * spec.h;
                if (bound > upper.at(key)) return;
                const Vec3 centre = face_centre(spec, cell, axis);
                const double c = clearance(centre);
                PairFaces& p = m[key];
                const uint64_t face = cell * 3 + static_cast<uint64_t>(axis);
                if (c < p.least || (c == p.least && face < p.face)) {
                  p.least = c;
                  p.face = face;
                  p.point = centre;
                }
              });
          advance(1, t, 0.45);
        }
      },
      1);
  const PairMap measured = merge(parts);

  DualGraph graph;
  graph.node_count = static_cast<uint32_t>(scene.objects.size());
  const double face_area = dim == 3 ? spec.h * spec.h : spec.h;
  for (const auto& [key, p] : counted) {
    DualEdge e;
    e.a = static_cast<ObjectId>(key >> 32);
    e.b = static_cast<ObjectId>(key & 0xFFFFFFFFu);
    e.area = static_cast<double>(p.faces) * face_area;
    const auto m = measured.find(key);
    if (m != measured.end() && m->second.least <= upper.at(key)) {
      e.min_clearance = m->second.least;
      e.tightest_point = m->second.point;
    } else {  // rounding: the estimated face itself
      e.min_clearance = upper.at(key);
      e.tightest_point = face_centre(spec, p.face / 3, static_cast<int>(p.face % 3));
    }
    graph.edges.push_back(e);
  }
  std::sort(graph.edges.begin(), graph.edges.end(), [](const DualEdge& x, const DualEdge& y) {
    return std::pair{x.a, x.b} < std::pair{y.a, y.b};
  });
  // Contacts as the adaptive pipeline finds them.
  const ContactPairs contacts = find_contact_pairs(
      geometry, bvh, contact_tolerance(resolve_max_depth(dim, 0)), threads, cancel);
  throw_if_cancelled(cancel, "the grid's dual graph");
  measure_gaps(graph, bvh, domain, contacts.pairs(), threads, cancel);
  if (options.progress) options.progress(1);
  return graph;
}

}  // namespace gvd::grid

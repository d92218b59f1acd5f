// A uniform grid sampled exactly from a finished adaptive result: the octree's closest points
// bound each cell centre's distance, exact searches over the scene's simplices decide.

#include "gvd/grid/sample_result_grid.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/stopwatch.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/grid/grid_evaluator.h"

namespace gvd::grid {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;
using namespace gvd::result;

GridSpec make_result_grid_spec(const GvdResult& result, const ResultGridOptions& options) {
  GridOptions o;
  o.resolution = options.resolution;
  o.metric = options.metric;
  o.box = options.box ? *options.box : result.domain.box();
  o.max_cells = options.max_cells;
  if (result.scene.objects.empty() || result.scene.simplex_count() == 0) {
    throw Error(ErrorCode::kInvalidScene, "the result has no objects: nothing to sample");
  }
  return make_grid_spec(result.scene, o);
}

namespace {

/// What one cell's search needs: the sites as compute_grid sees them, one BVH over all of
/// them, and the result's octree and field for the first bound.
struct Sampler {
  const GridGeometry& g;
  const SimplexBvh& all;
  int metric = GVD_METRIC_L2;
  double slack = 0;  ///< absolute slack (user units) on search radii, far above rounding

  const item::GvdPoint* points() const {
    return reinterpret_cast<const item::GvdPoint*>(g.points.data());
  }
  /// The exact key from q to object o (compute_grid's per-object walk), or > bound.
  double object_key(ObjectId o, Vec3 q, double bound) const {
    return item::gvd_grid_object_key(g.dimension, metric, g.nodes.data(), g.order.data(),
                                     g.roots.data(), points(), g.simplices.data(), o,
                                     item::gvd_pt(q.x, q.y, q.z), bound);
  }
  double point_key(Vec3 q, Vec3 c) const {
    return item::gvd_metric_key(item::gvd_pt(q.x - c.x, q.y - c.y, q.z - c.z), metric);
  }
  /// A distance a little enlarged for rounding, as a key.
  double enlarged_key(double key) const {
    const double d = item::gvd_key_distance(key, metric) * (1 + 1e-9) + slack;
    return metric == GVD_METRIC_L2 ? d * d : d;
  }
  /// The Euclidean radius within which every object of metric distance <= key lies (L1 >= L2,
  /// sqrt(D) L-infinity >= L2), enlarged for rounding; squared.
  double euclidean_radius2(double key) const {
    double d = item::gvd_key_distance(key, metric);
    if (metric == GVD_METRIC_LINF) d *= std::sqrt(static_cast<double>(g.dimension));
    d = d * (1 + 1e-9) + slack;
    return d * d;
  }
};

/// The distinct closest points (user units) and their objects on a leaf's vertices.
struct LeafBound {
  uint32_t leaf = 0xFFFFFFFFu;
  std::vector<std::pair<Vec3, ObjectId>> points;
};

}  // namespace

DistanceGrid sample_result_grid(const GvdResult& result, const ResultGridOptions& options) {
  const Stopwatch total;
  DistanceGrid out;
  out.spec = make_result_grid_spec(result, options);
  out.metric = options.metric;
  out.units = result.scene.units;
  const GridSpec& spec = out.spec;
  const int dim = spec.dimension;
  const Scene& scene = result.scene;
  const GridGeometry g = make_grid_geometry(scene, options.cancel);
  GVD_CHECK(g.object_of.size() < GVD_NO_SIMPLEX, "too many simplices for 32-bit indices");
  std::vector<Simplex> simplices(g.object_of.size());
  for (size_t s = 0; s < simplices.size(); ++s)
    for (int i = 0; i < 3; ++i) simplices[s].v[i] = g.simplices[3 * s + static_cast<size_t>(i)];
  const SimplexBvh all(dim, g.points, simplices, g.object_of);

  Sampler sampler{g, all};
  sampler.metric = make_item_spec(spec, options.metric).metric;
  double extent = 0;
  for (int i = 0; i < dim; ++i) extent = std::max(extent, spec.n[static_cast<size_t>(i)] * spec.h);
  sampler.slack = 1e-12 * extent;

  const Octree& octree = result.octree;
  const DistanceField& field = result.field;
  const Domain& domain = result.domain;
  // A leaf's vertices are found by key (the hash index of a loaded result, or binary search
  // of the sorted keys of a computed one, whose index the pipeline dropped).
  const bool use_octree = octree.leaf_count() > 0 && field.size() > 0;
  const uint32_t objects = g.object_count();
  const size_t cells = spec.cell_count();
  out.distance.resize(cells);
  out.label.resize(cells);
  std::atomic<uint64_t> evaluated{0}, bounded{0};
  const size_t rows = static_cast<size_t>(spec.n[1]) * static_cast<size_t>(spec.n[2]);
  // Sampling is ~all of the work; signing the rest. Progress from the calling thread (index 0
  // of parallel_for) as rows are finished by any thread.
  constexpr double kSampleShare = 0.95;
  std::atomic<size_t> rows_done{0};
  const std::atomic<bool>* cancel = options.cancel;
  if (options.progress) options.progress(0);
  parallel_for(
      rows, resolve_threads(options.threads),
      [&](size_t b, size_t e, int t) {
        LeafBound cache;
        std::vector<uint32_t> excluded;
        uint64_t my_evaluated = 0, my_bounded = 0;
        for (size_t row = b; row < e; ++row) {
          throw_if_cancelled(cancel, "sampling the grid");
          const size_t finished = rows_done.fetch_add(1);  // rows before this one
          if (t == 0 && options.progress) options.progress(kSampleShare * finished / rows);
          const int j = static_cast<int>(row % static_cast<size_t>(spec.n[1]));
          const int k = static_cast<int>(row / static_cast<size_t>(spec.n[1]));
          for (int i = 0; i < spec.n[0]; ++i) {
            const Vec3 q = spec.centre(i, j, k);
            double best = GVD_GRID_FAR;
            uint32_t site = GVD_NO_SIMPLEX;
            excluded.clear();
            // The leaf's closest points: the nearest of them is on some object, so its key
            // bounds the cell's from above, and its object is the first candidate.
            if (use_octree && domain.contains(q)) {
              const uint32_t leaf = octree.locate(domain.to_unit(q));
              if (leaf != cache.leaf) {
                cache.leaf = leaf;
                cache.points.clear();
                for (const uint32_t v : field.grid(octree, leaf)) {
                  if (v == kNoVertex || field.point[v] == kNoVertex) continue;
                  if (field.label[v] >= objects) continue;
                  Vec3 c = domain.from_unit(field.closest[field.point[v]]);
                  if (dim == 2) c.z = 0;
                  cache.points.emplace_back(c, field.label[v]);
                }
              }
              double bound = GVD_GRID_FAR;
              ObjectId first = kNoObject;
              for (const auto& [c, o] : cache.points) {
                const double key = sampler.point_key(q, c);
                if (key < bound) {
                  bound = key;
                  first = o;
                }
              }
              if (first != kNoObject) {
                ++my_bounded;
                ++my_evaluated;
                // Found unless the vertex's label is not its point's object (then the
                // search below, unbounded, finds everything).
                const double key = sampler.object_key(first, q, sampler.enlarged_key(bound));
                if (key < GVD_GRID_FAR) {
                  best = key;
                  site = first;
                  excluded.push_back(first);
                }
              }
            }
            // Every other object that may be as near: nearest first, pruned by the best so
            // far, until none is left within it.
            for (;;) {
              const double radius2 =
                  site == GVD_NO_SIMPLEX ? 1e300 : sampler.euclidean_radius2(best);
              const ClosestHit hit = all.nearest_excluding(
                  q, excluded.data(), static_cast<int>(excluded.size()), radius2);
              if (!hit.found()) break;
              const ObjectId o = g.object_of[hit.simplex];
              GVD_CHECK(std::find(excluded.begin(), excluded.end(), o) == excluded.end(),
                        "nearest_excluding returned an excluded object");
              excluded.push_back(o);
              ++my_evaluated;
              const double key = sampler.object_key(o, q, best);
              if (item::gvd_grid_better(key, o, best, site)) {
                best = key;
                site = o;
              }
            }
            const size_t c = row * static_cast<size_t>(spec.n[0]) + static_cast<size_t>(i);
            const bool found = site != GVD_NO_SIMPLEX;
            out.label[c] = found ? static_cast<int32_t>(site) : -1;
            out.distance[c] = found ? item::gvd_key_distance(best, sampler.metric)
                                    : std::numeric_limits<double>::infinity();
          }
        }
        evaluated += my_evaluated;
        bounded += my_bounded;
      },
      1);
  out.stats.pairs_evaluated = evaluated.load();
  out.stats.octree_bounded = bounded.load();
  out.stats.brute_force_pairs = cells * objects;
  out.stats.sites = objects;
  out.stats.backend = "cpu (sampled from the adaptive result)";
  out.stats.evaluate_seconds = total.seconds();

  if (options.progress) options.progress(kSampleShare);
  sign_closed_objects(scene, g, spec, options.signed_distance, options.threads, out, cancel);
  if (options.progress) options.progress(1);
  out.stats.seconds = total.seconds();
  return out;
}

}  // namespace gvd::grid

#include "gvd/grid/grid_evaluator.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/compute/compute_backend.h"
#include "gvd/geometry/bvh_build.h"

namespace gvd::grid {

using namespace gvd::scene;
using namespace gvd::compute;

static_assert(sizeof(item::GvdGridSpec) == 64, "GvdGridSpec must match the device layout");
static_assert(sizeof(item::GvdGridJob) == 40, "GvdGridJob must match the device layout");
static_assert(sizeof(Vec3) == sizeof(item::GvdPoint));

GridGeometry make_grid_geometry(const Scene& scene, const std::atomic<bool>* cancel) {
  GridGeometry g;
  std::vector<Box> boxes;  // per simplex
  uint32_t work = 0;
  g.dimension = scene.dimension;
  for (ObjectId o = 0; o < scene.objects.size(); ++o) {
    throw_if_cancelled(cancel, "the grid");
    const SceneObject& obj = scene.objects[o];
    const uint32_t base = static_cast<uint32_t>(g.points.size());
    for (Vec3 v : obj.vertices) {
      if (scene.dimension == 2) v.z = 0;
      g.points.push_back(v);
    }
    const uint32_t first = static_cast<uint32_t>(g.object_of.size());
    for (const Simplex& s : obj.simplices) {
      g.simplices.push_back(base + s.v[0]);
      g.simplices.push_back(base + s.v[1]);
      g.simplices.push_back(base + (scene.dimension == 2 ? s.v[0] : s.v[2]));
      g.object_of.push_back(o);
    }
    const uint32_t count = static_cast<uint32_t>(g.object_of.size()) - first;
    GVD_CHECK(count > 0, "make_grid_geometry: an object without simplices");
    const uint32_t begin = static_cast<uint32_t>(g.order.size());
    for (uint32_t s = 0; s < count; ++s) g.order.push_back(first + s);
    boxes.resize(first + count);
    for (uint32_t s = first; s < first + count; ++s) {
      for (uint32_t k = 0; k < 3; ++k) boxes[s].extend(g.points[g.simplices[3 * s + k]]);
    }
    g.roots.push_back(static_cast<uint32_t>(g.nodes.size()));
    build_bvh_nodes(
        g.order, begin, begin + count, [&](uint32_t s) -> const Box& { return boxes[s]; },
        [&](uint32_t s) { return boxes[s].center(); }, g.nodes, cancel, work, "the grid");
  }
  return g;
}

item::GvdGridSpec make_item_spec(const GridSpec& spec, GridMetric metric) {
  item::GvdGridSpec s{};
  s.origin[0] = spec.origin.x;
  s.origin[1] = spec.origin.y;
  s.origin[2] = spec.origin.z;
  s.h = spec.h;
  for (int i = 0; i < 3; ++i) s.n[i] = spec.n[static_cast<size_t>(i)];
  s.dimension = spec.dimension;
  s.metric = metric == GridMetric::kL2   ? GVD_METRIC_L2
             : metric == GridMetric::kL1 ? GVD_METRIC_L1
                                         : GVD_METRIC_LINF;
  // Conservative sampling (§5.3): a region that reaches a point of a cell reaches within one
  // cell diagonal (in the metric) of the best distance at the cell's centre: a point is at
  // most half a diagonal from the centre, and both distances are 1-Lipschitz. Enlarged by
  // 1e-9 relative for rounding.
  const double d = spec.dimension;
  const double diagonal = metric == GridMetric::kL2   ? spec.h * std::sqrt(d)
                          : metric == GridMetric::kL1 ? spec.h * d
                                                      : spec.h;
  s.threshold = diagonal * (1 + 1e-9);
  return s;
}

namespace {

class CpuGridEvaluator final : public GridEvaluator {
 public:
  CpuGridEvaluator(const GridGeometry& geometry, const item::GvdGridSpec& spec, int threads)
      : geometry_(geometry), spec_(spec), threads_(resolve_threads(threads)) {
    const size_t cells = static_cast<size_t>(spec.n[0]) * static_cast<size_t>(spec.n[1]) *
                         static_cast<size_t>(spec.n[2]);
    best_key_.assign(cells, std::numeric_limits<double>::infinity());
    best_site_.assign(cells, GVD_NO_SIMPLEX);
  }

  void evaluate(std::span<const item::GvdGridJob> jobs, std::span<const uint32_t> sites,
                uint32_t items, std::span<int32_t> visible) override {
    GVD_CHECK(visible.size() == sites.size(), "grid evaluator: one flag per site entry");
    if (jobs.empty() || items == 0) return;
    // Only lists longer than the private key array (GVD_GRID_LOCAL) touch dist.
    uint64_t pairs = 0;
    for (const item::GvdGridJob& j : jobs) {
      if (j.site_count <= GVD_GRID_LOCAL) continue;
      pairs = std::max<uint64_t>(
          pairs, j.dist_first + uint64_t{j.site_count} * j.size[0] * j.size[1] * j.size[2]);
    }
    if (dist_.size() < pairs) dist_.resize(pairs);
    const item::GvdPoint* points = reinterpret_cast<const item::GvdPoint*>(geometry_.points.data());
    const uint32_t* simplices = geometry_.simplices.data();
    const uint32_t job_count = static_cast<uint32_t>(jobs.size());
    parallel_for(
        items, threads_,
        [&](size_t b, size_t e, int) {
          for (size_t i = b; i < e; ++i) {
            // One row of a range: at most a few ms even for many sites per range.
            throw_if_cancelled(cancel_, "the grid's evaluation");
            item::gvd_grid_item(&spec_, geometry_.nodes.data(), geometry_.order.data(),
                                geometry_.roots.data(), points, simplices, jobs.data(), job_count,
                                sites.data(), static_cast<uint32_t>(i), best_key_.data(),
                                best_site_.data(), dist_.data(), visible.data());
          }
        },
        4);
  }

  void read_best(std::span<double> key, std::span<uint32_t> site) override {
    GVD_CHECK(key.size() == best_key_.size() && site.size() == best_site_.size(),
              "grid evaluator: read_best wants one entry per cell");
    std::copy(best_key_.begin(), best_key_.end(), key.begin());
    std::copy(best_site_.begin(), best_site_.end(), site.begin());
  }

 private:
  const GridGeometry& geometry_;
  item::GvdGridSpec spec_;
  int threads_;
  std::vector<double> best_key_;
  std::vector<uint32_t> best_site_;
  std::vector<double> dist_;
};

}  // namespace

std::unique_ptr<GridEvaluator> make_cpu_grid_evaluator(const GridGeometry& geometry,
                                                       const item::GvdGridSpec& spec, int threads) {
  return std::make_unique<CpuGridEvaluator>(geometry, spec, threads);
}

}  // namespace gvd::grid

namespace gvd::compute {

// The default of ComputeBackend (no kernel: compute_grid runs the CPU twin). Defined here, with
// the type it returns, so that the backend interface does not depend on the grid module.
std::unique_ptr<grid::GridEvaluator> ComputeBackend::grid_evaluator(const grid::GridGeometry&,
                                                                    const grid::GridSpec&,
                                                                    grid::GridMetric) {
  return nullptr;
}

}  // namespace gvd::compute

#include "gvd/grid/grid_evaluator.h"

#include <cmath>
#include <limits>

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"

namespace gvd {

static_assert(sizeof(item::GvdGridSpec) == 64, "GvdGridSpec must match the device layout");
static_assert(sizeof(item::GvdGridJob) == 40, "GvdGridJob must match the device layout");
static_assert(sizeof(Vec3) == sizeof(item::GvdPoint));

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
    uint64_t pairs = 0;
    for (const item::GvdGridJob& j : jobs) {
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
            item::gvd_grid_item(&spec_, points, simplices, jobs.data(), job_count, sites.data(),
                                static_cast<uint32_t>(i), best_key_.data(), best_site_.data(),
                                dist_.data(), visible.data());
          }
        },
        64);
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

}  // namespace gvd

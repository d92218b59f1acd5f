#include "gvd/compute/compute_backend.h"

#include "gvd/distance/closest_points.h"
#include "gvd/octree/build_octree_data_parallel.h"

namespace gvd::compute {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;

namespace {

class CpuClosestPointSolver final : public ClosestPointSolver {
 public:
  CpuClosestPointSolver(const SimplexBvh& bvh, int threads)
      : data_(make_closest_point_data(bvh)), threads_(threads) {}
  void solve(std::span<const Vec3> queries, std::span<const double> bound2,
             std::span<ClosestHit> hits) override {
    closest_points_cpu_coherent(data_, queries, bound2, hits, threads_);
  }

 private:
  ClosestPointData data_;  // a view of the BVH, which the pipeline keeps beside the solver
  int threads_;
};

}  // namespace

std::unique_ptr<OctreeBuildSteps> ComputeBackend::octree_build_steps(const UnitGeometry&) {
  return nullptr;
}

std::unique_ptr<ClosestPointSolver> make_cpu_closest_point_solver(const SimplexBvh& bvh,
                                                                  int threads) {
  return std::make_unique<CpuClosestPointSolver>(bvh, threads);
}

}  // namespace gvd::compute

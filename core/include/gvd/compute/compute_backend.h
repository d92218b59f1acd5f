#pragma once

// ComputeBackend, the interface to the data-parallel parts of the pipeline (closest points, the
// data-parallel octree build's steps, the uniform grid's per-range evaluation) that `kernels/`
// implements on OpenCL, so that core stays free of it; where no backend is passed, or it has no
// such part (null), the CPU twins run. Also the CPU closest-point solver, which views a BVH's
// arrays (the BVH must outlive it).

#include <memory>
#include <string>

// Declared in gvd/distance/closest_points.h, gvd/octree/build_octree_data_parallel.h and
// gvd/grid/grid_evaluator.h; forward declarations keep the device-shared headers out of
// everything that includes pipeline.h.
namespace gvd {
class SimplexBvh;
}
namespace gvd::scene {
struct UnitGeometry;
}
namespace gvd::distance {
class ClosestPointSolver;
}
namespace gvd::octree {
class OctreeBuildSteps;
}
namespace gvd::grid {
class GridEvaluator;
struct GridGeometry;
struct GridSpec;
enum class GridMetric;
}  // namespace gvd::grid

namespace gvd::compute {

/// The data-parallel parts of the pipeline behind one interface, so that core stays free of
/// OpenCL: `kernels/` implements it on OpenCL (PoCL on this machine), the CLI and the server
/// choose and pass it in PipelineOptions::compute. Without one, the CPU twins run.
class ComputeBackend {
 public:
  virtual ~ComputeBackend() = default;
  /// What runs, for logs and ResultStats::backend ("opencl (<platform> / <device>)").
  virtual std::string name() const = 0;
  /// A closest-point solver bound to one scene (uploads it once). `geometry` and `bvh` must
  /// outlive the solver. Throws gvd::Error when the device fails.
  virtual std::unique_ptr<distance::ClosestPointSolver> closest_points(
      const scene::UnitGeometry& geometry, const SimplexBvh& bvh) = 0;
  /// The steps of the data-parallel octree build (build_octree_data_parallel.h) bound to one scene;
  /// null when the backend has none (the CPU twins then run).
  virtual std::unique_ptr<octree::OctreeBuildSteps> octree_build_steps(
      const scene::UnitGeometry& geometry);
  /// The per-range evaluation of the uniform-grid GVD (gvd/grid/grid_evaluator.h) bound to
  /// one grid and its sites; null when the backend has none (the CPU twin then runs).
  /// `geometry` must outlive the evaluator.
  virtual std::unique_ptr<grid::GridEvaluator> grid_evaluator(const grid::GridGeometry& geometry,
                                                              const grid::GridSpec& spec,
                                                              grid::GridMetric metric);
};

/// The CPU twin as a solver over `bvh`'s arrays (viewed, not copied: `bvh` must outlive the
/// solver): closest_points_cpu's answers, by closest_points_cpu_coherent (the pipeline's
/// batches are in Z order).
std::unique_ptr<distance::ClosestPointSolver> make_cpu_closest_point_solver(const SimplexBvh& bvh,
                                                                            int threads = 0);

}  // namespace gvd::compute

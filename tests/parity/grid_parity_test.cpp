// Parity of the uniform grid's per-range kernel (kernels/cl/grid_distance.cl) with its CPU
// twin: compute_grid on the OpenCL backend and on the twin must give identical labels and
// bit-identical distances (they share gvd_grid_item, built without FP contraction), on random
// and adversarial input — segments on cell-centre rows and range boundaries, exact ties
// (mirror images), more sites in one range than the private key array holds, all three
// metrics, 2D and 3D, ranges clipped at the grid's end.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <random>
#include <thread>

#include "gvd/common/error.h"
#include "gvd/grid/compute_grid.h"
#include "parity/opencl_env.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::compute;
using namespace gvd::grid;

namespace {

void expect_same_grid(const Scene& scene, GridOptions o,
                      const std::shared_ptr<ComputeBackend>& backend) {
  o.compute = nullptr;
  const DistanceGrid twin = compute_grid(scene, o);
  o.compute = backend;
  const DistanceGrid kernel = compute_grid(scene, o);
  EXPECT_EQ(twin.stats.backend, "cpu");
  EXPECT_EQ(kernel.stats.backend, backend->name());
  ASSERT_EQ(twin.label.size(), kernel.label.size());
  size_t labels = 0, distances = 0;
  for (size_t i = 0; i < twin.label.size(); ++i) {
    labels += twin.label[i] != kernel.label[i];
    distances += std::memcmp(&twin.distance[i], &kernel.distance[i], sizeof(double)) != 0;
  }
  EXPECT_EQ(labels, 0u) << grid_metric_name(o.metric);
  EXPECT_EQ(distances, 0u) << grid_metric_name(o.metric);
  EXPECT_EQ(twin.stats.pairs_evaluated, kernel.stats.pairs_evaluated);
}

Scene random_segments(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<SceneObject> objs;
  for (int i = 0; i < n; ++i) {
    const Vec3 a{u(rng), u(rng), 0};
    objs.push_back(test::make_segment("s" + std::to_string(i), a,
                                      a + Vec3{0.05 * (u(rng) - 0.5), 0.05 * (u(rng) - 0.5), 0}));
  }
  return test::make_scene(2, std::move(objs));
}

TEST(GridParity, RandomSegmentsAllMetrics) {
  GVD_REQUIRE_OPENCL(backend);
  const Scene scene = random_segments(300, 42);
  for (GridMetric m : {GridMetric::kL2, GridMetric::kL1, GridMetric::kLinf}) {
    GridOptions o;
    o.resolution = 100;  // 100 / 8: ranges clipped at the end
    o.range_cells = 8;
    o.metric = m;
    expect_same_grid(scene, o, backend);
  }
}

TEST(GridParity, TiesRowsAndRangeBoundaries) {
  GVD_REQUIRE_OPENCL(backend);
  // Mirror-image segments (exact ties on x = 0.5), segments along rows of cell centres and
  // along range boundaries, a closed square with corners on cell centres.
  std::vector<SceneObject> objs;
  objs.push_back(test::make_segment("l", {0.25, 0.2, 0}, {0.25, 0.8, 0}));
  objs.push_back(test::make_segment("r", {0.75, 0.2, 0}, {0.75, 0.8, 0}));
  objs.push_back(test::make_segment("row", {0.105, 0.905, 0}, {0.895, 0.905, 0}));
  objs.push_back(test::make_segment("edge", {0.32, 0.08, 0}, {0.64, 0.08, 0}));
  objs.push_back(test::make_rect("sq", {0.405, 0.405, 0}, {0.595, 0.595, 0}));
  const Scene scene = test::make_scene(2, std::move(objs));
  for (GridMetric m : {GridMetric::kL2, GridMetric::kL1, GridMetric::kLinf}) {
    GridOptions o;
    o.resolution = 100;
    o.box = Box{{0, 0, 0}, {1, 1, 0}};
    o.range_cells = 4;
    o.metric = m;
    expect_same_grid(scene, o, backend);
  }
}

TEST(GridParity, CrowdedRangeSpillsPastThePrivateKeys) {
  GVD_REQUIRE_OPENCL(backend);
  // 400 short segments in a small square: ranges see far more than 64 candidate sites.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0.45, 0.55);
  std::vector<SceneObject> objs;
  for (int i = 0; i < 400; ++i) {
    const Vec3 a{u(rng), u(rng), 0};
    objs.push_back(test::make_segment("c" + std::to_string(i), a, a + Vec3{0.001, 0.0005, 0}));
  }
  objs.push_back(test::make_segment("far", {0, 0, 0}, {0.01, 0, 0}));
  const Scene scene = test::make_scene(2, std::move(objs));
  GridOptions o;
  o.resolution = 64;
  o.range_cells = 32;
  expect_same_grid(scene, o, backend);
}

TEST(GridParity, ClosedMeshes3D) {
  GVD_REQUIRE_OPENCL(backend);
  std::vector<SceneObject> objs;
  objs.push_back(test::make_sphere("ball", {0.3, 0.3, 0.3}, 0.2, 6, 10));
  objs.push_back(test::make_box("box", {0.55, 0.55, 0.2}, {0.9, 0.9, 0.8}));
  objs.push_back(test::make_sphere("small", {0.3, 0.75, 0.7}, 0.1, 4, 6));
  const Scene scene = test::make_scene(3, std::move(objs));
  for (GridMetric m : {GridMetric::kL2, GridMetric::kLinf}) {
    GridOptions o;
    o.resolution = 20;
    o.range_cells = 6;
    o.metric = m;
    expect_same_grid(scene, o, backend);
  }
}

// The kernel launch is sliced and the flag read between slices: 400 coincident spheres (no
// site can be culled; one batch alone takes seconds) stop within a second of the flag.
TEST(GridParity, CancelStopsAKernelLaunchWithinASecond) {
  GVD_REQUIRE_OPENCL(backend);
  std::vector<SceneObject> objs;
  for (int i = 0; i < 400; ++i)
    objs.push_back(test::make_sphere("s" + std::to_string(i), {0, 0, 0}, 1, 8, 16));
  const Scene scene = test::make_scene(3, std::move(objs));
  std::atomic<bool> cancel{false};
  GridOptions o;
  o.resolution = 64;
  o.compute = backend;
  o.cancel = &cancel;
  std::atomic<int> outcome{-1};  // 0: finished, 1: cancelled, 2: another error
  std::chrono::steady_clock::time_point ended;
  std::thread worker([&] {
    try {
      const DistanceGrid g = compute_grid(scene, o);
      EXPECT_EQ(g.stats.backend, backend->name());
      outcome = 0;
    } catch (const Error& e) {
      outcome = e.code() == ErrorCode::kCancelled ? 1 : 2;
    }
    ended = std::chrono::steady_clock::now();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const auto asked = std::chrono::steady_clock::now();
  cancel = true;
  worker.join();
  EXPECT_EQ(outcome.load(), 1);
  EXPECT_LT(std::chrono::duration<double>(ended - asked).count(), 1.0);
}

}  // namespace
}  // namespace gvd

// Cancellation and progress of the uniform-grid path: a cancel flag set from another thread
// stops compute_grid (culled and brute force), grid_dual_graph and sample_result_grid within a
// second, inside their stages, and their progress callbacks advance within the stage.
// Coincident spheres are the slow case on purpose: no site can be culled (every range sees all
// of them at the same distance), so the evaluation alone would take minutes.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <thread>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/grid/grid_evaluator.h"
#include "gvd/grid/grid_graph.h"
#include "gvd/grid/sample_result_grid.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/label_volume.h"
#include "support/cancel.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::grid;
using namespace gvd::pipeline;

namespace {

// The latency asked of a release build; sanitizer builds run 10-20 times slower (see
// tests/unit/pipeline/cancel_test.cpp), so there only the outcome is held to account.
#if defined(__SANITIZE_ADDRESS__)
constexpr double kCancelLatency = 60.0;
#else
constexpr double kCancelLatency = 1.0;
#endif

Scene coincident_spheres(int count) {
  std::vector<SceneObject> objects;
  for (int i = 0; i < count; ++i)
    objects.push_back(test::make_sphere("s" + std::to_string(i), {0, 0, 0}, 1, 8, 16));
  return test::make_scene(3, std::move(objects));
}

/// Runs `work` on a thread, sets `cancel` after `delay`, and expects kCancelled within
/// kCancelLatency of that.
void expect_stops_within_a_second(
    std::atomic<bool>& cancel, const std::function<void()>& work,
    std::chrono::milliseconds delay = std::chrono::milliseconds(300)) {
  std::atomic<int> outcome{-1};  // 0: finished, 1: cancelled, 2: another error
  std::string other;
  std::chrono::steady_clock::time_point ended;
  std::thread worker([&] {
    try {
      work();
      outcome = 0;
    } catch (const Error& e) {
      outcome = e.code() == ErrorCode::kCancelled ? 1 : 2;
      other = e.what();
    }
    ended = std::chrono::steady_clock::now();
  });
  std::this_thread::sleep_for(delay);
  const auto asked = std::chrono::steady_clock::now();
  cancel = true;
  worker.join();
  EXPECT_EQ(outcome.load(), 1) << "0: it ran to the end before the flag was read; " << other;
  EXPECT_LT(std::chrono::duration<double>(ended - asked).count(), kCancelLatency);
}

TEST(Cancel, GridSweepsStopWithinASecond) {
  const Scene scene = coincident_spheres(400);
  std::atomic<bool> cancel{false};
  GridOptions o;
  o.resolution = 64;
  o.threads = 2;
  o.cancel = &cancel;
  expect_stops_within_a_second(cancel, [&] { compute_grid(scene, o); });
}

TEST(Cancel, BruteForceGridStopsWithinASecond) {
  const Scene scene = coincident_spheres(400);
  std::atomic<bool> cancel{false};
  GridOptions o;
  o.resolution = 64;
  o.cull = false;
  o.threads = 2;
  o.cancel = &cancel;
  expect_stops_within_a_second(cancel, [&] { compute_grid(scene, o); });
}

TEST(Cancel, GridGraphStopsWithinASecond) {
  // A small grid (fast), whose graph's touching-pair pass over 800 coincident spheres is not.
  const Scene scene = coincident_spheres(800);
  GridOptions o;
  o.resolution = 4;
  o.threads = 2;
  const DistanceGrid grid = compute_grid(scene, o);
  std::atomic<bool> cancel{false};
  GridGraphOptions go;
  go.threads = 2;
  go.cancel = &cancel;
  expect_stops_within_a_second(cancel, [&] { grid_dual_graph(grid, scene, go); });
}

TEST(Cancel, SampledGridStopsWithinASecond) {
  const Scene scene = test::make_scene(
      3, {test::make_sphere("a", {-1.2, 0, 0}, 1, 12, 24), test::make_sphere("b", {1.2, 0, 0}, 1),
          test::make_box("c", {-2, -2, -2}, {2, -1.5, 2})});
  PipelineOptions po;
  po.threads = 2;
  po.max_depth = 7;
  const GvdResult r = compute_gvd(scene, po);
  std::atomic<bool> cancel{false};
  ResultGridOptions o;
  o.resolution = 250;  // 15.6M cells: many seconds
  o.threads = 2;
  o.cancel = &cancel;
  expect_stops_within_a_second(cancel, [&] { sample_result_grid(r, o); });
}

TEST(Cancel, SetFlagStopsEveryGridStageAtOnce) {
  const Scene scene = test::make_scene(2, {test::make_segment("a", {0, 0, 0}, {1, 0, 0}),
                                           test::make_rect("b", {0, 1, 0}, {1, 2, 0})});
  std::atomic<bool> cancel{true};
  using test::expect_cancelled;
  GridOptions o;
  o.resolution = 32;
  o.cancel = &cancel;
  expect_cancelled([&] { compute_grid(scene, o); }, "compute_grid");
  o.cull = false;
  expect_cancelled([&] { compute_grid(scene, o); }, "compute_grid (brute force)");
  o.cancel = nullptr;
  const DistanceGrid grid = compute_grid(scene, o);
  GridGraphOptions go;
  go.cancel = &cancel;
  expect_cancelled([&] { grid_dual_graph(grid, scene, go); }, "grid_dual_graph");
  LabelVolume v;
  v.dimension = 2;
  v.size = {4, 4, 1};
  v.labels.assign(16, 1);
  LabelVolumeOptions vo;
  vo.cancel = &cancel;
  expect_cancelled([&] { scene_from_label_volume(v, vo); }, "scene_from_label_volume");
  expect_cancelled([&] { make_grid_geometry(scene, &cancel); }, "make_grid_geometry");
  // Unset, the same calls finish.
  cancel = false;
  o.cancel = &cancel;
  EXPECT_EQ(compute_grid(scene, o).label, grid.label);
  EXPECT_EQ(grid_dual_graph(grid, scene, go).edges.size(), 1u);
  EXPECT_EQ(scene_from_label_volume(v, vo).objects.size(), 1u);
  const GridGeometry with = make_grid_geometry(scene, &cancel), without = make_grid_geometry(scene);
  EXPECT_EQ(with.order, without.order);
  EXPECT_EQ(with.roots, without.roots);
  EXPECT_EQ(with.nodes.size(), without.nodes.size());
}

/// Records the fractions a progress callback gets.
struct Fractions {
  std::vector<double> seen;
  std::function<void(double)> callback() {
    return [this](double f) { seen.push_back(f); };
  }
  void expect_advancing(const char* what, size_t at_least) const {
    ASSERT_GE(seen.size(), at_least) << what << ": too few reports to show progress in a stage";
    for (size_t i = 1; i < seen.size(); ++i)
      EXPECT_GE(seen[i], seen[i - 1]) << what << ": progress went back at report " << i;
    EXPECT_GE(seen.front(), 0.0) << what;
    EXPECT_EQ(seen.back(), 1.0) << what;
    // Reports in between, not only the ends.
    size_t inside = 0;
    for (double f : seen) inside += f > 0 && f < 1;
    EXPECT_GE(inside, at_least - 2) << what;
  }
};

TEST(GridProgress, EveryStageReportsFractionsWithinIt) {
  std::vector<SceneObject> objects;
  for (int i = 0; i < 12; ++i)
    objects.push_back(test::make_segment("s" + std::to_string(i), {0.1 * i, 0, 0},
                                         {0.1 * i + 0.05, 0.3 + 0.05 * i, 0}));
  const Scene scene = test::make_scene(2, std::move(objects));
  GridOptions o;
  o.resolution = 128;
  o.threads = 2;
  Fractions culled, brute, graph;
  o.progress = culled.callback();
  const DistanceGrid grid = compute_grid(scene, o);
  culled.expect_advancing("compute_grid", 10);
  o.cull = false;
  o.progress = brute.callback();
  compute_grid(scene, o);
  brute.expect_advancing("compute_grid (brute force)", 3);
  GridGraphOptions go;
  go.threads = 1;
  go.progress = graph.callback();
  grid_dual_graph(grid, scene, go);
  graph.expect_advancing("grid_dual_graph", 10);

  PipelineOptions po;
  po.threads = 2;
  po.max_depth = 8;
  const GvdResult r = compute_gvd(scene, po);
  Fractions sampled;
  ResultGridOptions ro;
  ro.resolution = 64;
  ro.threads = 1;
  ro.progress = sampled.callback();
  sample_result_grid(r, ro);
  sampled.expect_advancing("sample_result_grid", 10);
}

}  // namespace
}  // namespace gvd

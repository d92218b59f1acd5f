// Cancellation: a set flag stops compute_gvd promptly in every stage, including the scene
// stage (validation, the octree's frame, the BVHs) and the touching-pair pass, whose cost grows
// as the square of the number of coincident objects.
#include "support/cancel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/common/json_input.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/graph/build_dual_graph.h"
#include "gvd/graph/dual_graph.h"
#include "gvd/io/write_grid.h"
#include "gvd/octree/contacts.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/refine/pair_certificate.h"
#include "gvd/scene/label_volume.h"
#include "gvd/scene/load_scene.h"
#include "gvd/surface/compact_gvd.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::surface;
using namespace gvd::refine;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

Scene coincident_spheres(int count) {
  std::vector<SceneObject> objects;
  for (int i = 0; i < count; ++i)
    objects.push_back(test::make_sphere("s" + std::to_string(i), {0, 0, 0}, 1, 8, 16));
  return test::make_scene(3, std::move(objects));
}

using test::expect_cancelled;

// The scene's validation (and the JSON reader, which validates) stop with the flag; unset,
// the scene is normalised as without one: the same triangles (some reversed by the
// orientation pass) and warnings.
TEST(Cancel, SceneValidationStopsAtOnce) {
  Scene raw;
  raw.dimension = 3;
  for (int i = 0; i < 20; ++i) {
    SceneObject o = test::make_sphere("s" + std::to_string(i), {3.0 * i, 0, 0}, 1, 8, 16);
    for (size_t t = 0; t < o.simplices.size(); t += 7)  // for the orientation pass to mend
      std::swap(o.simplices[t].v[1], o.simplices[t].v[2]);
    raw.objects.push_back(std::move(o));
  }
  std::atomic<bool> cancel{true};
  Scene a = raw;
  expect_cancelled([&] { validate_scene(a, {}, &cancel); }, "validate_scene");
  expect_cancelled([&] { parse_scene_json(scene_to_json(raw), {}, &cancel); }, "parse_scene_json");
  cancel = false;
  Scene with = raw, without = raw;
  validate_scene(with, {}, &cancel);
  validate_scene(without);
  EXPECT_EQ(scene_to_json(with), scene_to_json(without));
  EXPECT_EQ(warnings_to_json(with.warnings), warnings_to_json(without.warnings));
  EXPECT_NE(scene_to_json(with), scene_to_json(raw)) << "the orientation pass mended nothing";
}

// The JSON parse itself reads the flag (a 64 MB scene takes about a second to parse, more
// than the cancel latency allows): set, parse_json_input stops inside nlohmann's parse with
// kCancelled; unset, the document is the one parsed without a flag.
TEST(Cancel, JsonParseStopsWithinIt) {
  std::vector<SceneObject> objects;
  for (int i = 0; i < 40; ++i)  // ~180k values and keys: the flag is read a few times
    objects.push_back(test::make_sphere("s" + std::to_string(i), {3.0 * i, 0, 0}, 1, 16, 32));
  const std::string text = scene_to_json(test::make_scene(3, std::move(objects)));
  std::atomic<bool> cancel{true};
  expect_cancelled([&] { parse_json_input(text, "the scene", ErrorCode::kInvalidScene, &cancel); },
                   "parse_json_input");
  cancel = false;
  EXPECT_EQ(parse_json_input(text, "the scene", ErrorCode::kInvalidScene, &cancel),
            parse_json_input(text, "the scene", ErrorCode::kInvalidScene));
}

// The octree's frame (its BVH over the scene, the facing search, the roofs' apexes over
// straddled rims) stops with the flag, through make_domain too; unset, and on one thread or
// two, it finds the frame, rims and domain it finds without a flag.
TEST(Cancel, SceneFrameStopsAtOnce) {
  test::ShaftInBoreOptions so;
  so.sides = 5;  // straddled rims at the pentagon's corners: their roofs' apexes are searched
  so.gap = 1e-3;
  so.cell = 0.1;
  const Scene scene = test::make_shaft_in_bore(so);
  std::atomic<bool> cancel{true};
  DomainOptions options;
  options.threads = 2;
  options.cancel = &cancel;
  expect_cancelled([&] { analyse_scene_frame(scene, true, 2, &cancel); }, "analyse_scene_frame");
  expect_cancelled([&] { make_domain(scene, options); }, "make_domain");
  cancel = false;
  const SceneFrame plain = analyse_scene_frame(scene);
  size_t rims = 0;
  for (const auto& axis : plain.straddled) rims += axis.size();
  ASSERT_GT(rims, 0u) << "the scene has no straddled rims to search";
  for (const int threads : {1, 2}) {
    const SceneFrame f = analyse_scene_frame(scene, true, threads, &cancel);
    EXPECT_EQ(f.axes, plain.axes) << threads << " threads";
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(f.straddled[k].size(), plain.straddled[k].size()) << "axis " << k;
      for (size_t i = 0; i < f.straddled[k].size(); ++i) {
        EXPECT_EQ(f.straddled[k][i].apex, plain.straddled[k][i].apex) << "axis " << k;
        EXPECT_EQ(f.straddled[k][i].length, plain.straddled[k][i].length) << "axis " << k;
      }
    }
  }
  const Domain d = make_domain(scene, options), reference = make_domain(scene);
  EXPECT_EQ(d.origin, reference.origin);
  EXPECT_EQ(d.side, reference.side);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(d.axis[i], reference.axis[i]);
}

// The BVH's build (the scene stage's last step; over 4096 simplices the per-object trees are
// built on a second thread) stops with the flag; unset, it builds the tree it builds without.
TEST(Cancel, BvhBuildStopsAtOnce) {
  const Scene scene = coincident_spheres(50);
  const UnitGeometry g = make_unit_geometry(scene, make_domain(scene));
  ASSERT_GE(g.simplices.size(), 4096u);
  std::atomic<bool> cancel{true};
  expect_cancelled([&] { SimplexBvh(3, g.points, g.simplices, g.object_of, &cancel); },
                   "SimplexBvh");
  cancel = false;
  const SimplexBvh with(3, g.points, g.simplices, g.object_of, &cancel);
  const SimplexBvh without(3, g.points, g.simplices, g.object_of);
  ASSERT_EQ(with.nodes().size(), without.nodes().size());
  for (size_t i = 0; i < with.nodes().size(); ++i) {
    const SimplexBvh::Node &a = with.nodes()[i], &b = without.nodes()[i];
    EXPECT_TRUE(std::equal(a.lo, a.lo + 3, b.lo) && std::equal(a.hi, a.hi + 3, b.hi) &&
                a.first == b.first && a.tag == b.tag)
        << "node " << i;
  }
  EXPECT_TRUE(std::equal(with.order().begin(), with.order().end(), without.order().begin(),
                         without.order().end()));
  for (const Vec3 p : {Vec3{0.5, 0.5, 0.5}, Vec3{0.1, 0.9, 0.3}})
    EXPECT_EQ(with.nearest_in_object(p, 7).dist2, without.nearest_in_object(p, 7).dist2);
}

// The certifier's construction at the octree stage's start (sorts of the points and of the
// triangles' sides, a quarter second on the 327k-triangle lattice) stops with the flag; unset,
// it classifies cells as it does without one.
TEST(Cancel, CertifierConstructionStopsAtOnce) {
  const Scene scene = coincident_spheres(20);
  const UnitGeometry g = make_unit_geometry(scene, make_domain(scene));
  const SimplexBvh bvh(3, g.points, g.simplices, g.object_of);
  std::atomic<bool> cancel{true};
  expect_cancelled([&] { PairCertifier(g, bvh, nullptr, true, true, &cancel); }, "PairCertifier");
  cancel = false;
  const PairCertifier with(g, bvh, nullptr, true, true, &cancel);
  const PairCertifier without(g, bvh, nullptr, true, true);
  for (const double size : {1.0, 0.25, 1.0 / 64}) {
    for (const double x : {0.0, 0.5 - size / 2}) {
      const Box box{{x, x, x}, {x + size, x + size, x + size}};
      EXPECT_EQ(with.classify(box), without.classify(box)) << size << " at " << x;
    }
  }
}

// A labelled volume's reading and conversion (a server worker's first step for a volume)
// stop with the flag; unset, they give the scene they give without one, reporting progress.
TEST(Cancel, LabelVolumeStopsAtOnce) {
  const int n = 24;
  std::vector<int32_t> values(n * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) values[(z * n + y) * n + x] = 1 + (x / 8) + 3 * (z / 12);
  const uint64_t shape[3] = {n, n, n};
  const std::vector<uint8_t> bytes = npy_bytes(GridValueType::kInt32, shape, values.data());
  std::atomic<bool> cancel{true};
  expect_cancelled([&] { read_label_volume_npy(bytes, "v.npy", &cancel); },
                   "read_label_volume_npy");
  const LabelVolume volume = read_label_volume_npy(bytes, "v.npy");
  LabelVolumeOptions options;
  options.cancel = &cancel;
  expect_cancelled([&] { scene_from_label_volume(volume, options); }, "scene_from_label_volume");
  cancel = false;
  std::vector<double> seen;
  options.progress = [&](double f) { seen.push_back(f); };
  const Scene with = scene_from_label_volume(volume, options);
  const Scene without = scene_from_label_volume(volume, {});
  EXPECT_EQ(with.objects.size(), 6u);
  EXPECT_EQ(scene_to_json(with), scene_to_json(without));
  EXPECT_EQ(read_label_volume_npy(bytes, "v.npy", &cancel).labels, volume.labels);
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.front(), 0);
  EXPECT_GT(seen.back(), 0.9);
  EXPECT_TRUE(std::is_sorted(seen.begin(), seen.end()));
}

TEST(Cancel, TouchingPairPassStopsAtOnce) {
  const Scene scene = coincident_spheres(50);
  const Domain domain = make_domain(scene);
  const UnitGeometry g = make_unit_geometry(scene, domain);
  const SimplexBvh bvh(3, g.points, g.simplices, g.object_of);
  std::atomic<bool> cancel{true};
  try {
    find_contact_pairs(g, bvh, 1e-6, 2, &cancel);
    ADD_FAILURE() << "a cancelled pass ran to the end";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled);
  }
  cancel = false;
  EXPECT_EQ(find_contact_pairs(g, bvh, 1e-6, 2, &cancel).pairs().size(), 50u * 49 / 2);
}

// The graph stage's exact measurements (an edge between two large objects is a long search)
// stop with the flag; unset, they give the pipeline's own figures again.
TEST(Cancel, GraphMeasurementsStopAtOnce) {
  const Scene scene = test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                           test::make_sphere("b", {2.5, 0, 0}, 1, 8, 16),
                                           test::make_sphere("c", {0, 2.5, 0}, 1, 8, 16)});
  GvdResult r = compute_gvd(scene);
  ASSERT_FALSE(r.graph.edges.empty());
  const SimplexBvh bvh(3, r.geometry.points, r.geometry.simplices, r.geometry.object_of);
  std::atomic<bool> cancel{true};
  DualGraph graph = r.graph;
  for (DualEdge& e : graph.edges) e.gap = -1;
  expect_cancelled([&] { measure_gaps(graph, bvh, r.domain, {}, 2, &cancel); }, "measure_gaps");
  expect_cancelled([&] { tighten_clearances(graph, r.gvd, bvh, r.domain, 2, &cancel); },
                   "tighten_clearances");
  cancel = false;
  measure_gaps(graph, bvh, r.domain, {}, 2, &cancel);
  for (size_t i = 0; i < graph.edges.size(); ++i)
    EXPECT_DOUBLE_EQ(graph.edges[i].gap, r.graph.edges[i].gap) << "edge " << i;
}

// The compaction of the output (the last stage): with the flag set it stops; unset, it gives
// the pipeline's compact GVD from the full-resolution one.
TEST(Cancel, CompactionStopsAtOnce) {
  const Scene scene = test::make_scene(3, {test::make_sphere("a", {0, 0, 0}, 1, 8, 16),
                                           test::make_sphere("b", {2.5, 0, 0}, 1, 8, 16)});
  PipelineOptions full;
  full.resolution = GvdResolution::kFull;
  const GvdResult r = compute_gvd(scene, full);
  const GvdResult compacted = compute_gvd(scene);
  std::atomic<bool> cancel{true};
  CompactOptions co;
  co.cancel = &cancel;
  Gvd gvd = r.gvd;
  expect_cancelled([&] { compact_gvd(gvd, co); }, "compact_gvd");
  cancel = false;
  gvd = r.gvd;
  compact_gvd(gvd, co);
  ASSERT_EQ(gvd.cells.size(), compacted.gvd.cells.size());
  for (size_t c = 0; c < gvd.cells.size(); ++c) {
    EXPECT_EQ(gvd.cells[c].indices, compacted.gvd.cells[c].indices) << "cell " << c;
    EXPECT_EQ(gvd.cells[c].positions.size(), compacted.gvd.cells[c].positions.size());
  }
}

// The latency asked of a release build. Sanitizer builds run 10-20 times slower.
#if defined(__SANITIZE_ADDRESS__)
constexpr double kCancelLatency = 60.0;
constexpr double kSceneLatency = 2.0;
#else
constexpr double kCancelLatency = 1.0;
constexpr double kSceneLatency = 0.1;
#endif

// compute_gvd on a thread of its own, for a test to cancel it meanwhile: how it ended
// (0: finished, 1: cancelled, 2: another error) and when.
struct BackgroundCompute {
  BackgroundCompute(const Scene& scene, const PipelineOptions& o)
      : worker([this, &scene, &o] {
          try {
            compute_gvd(scene, o);
            outcome = 0;
          } catch (const Error& e) {
            outcome = e.code() == ErrorCode::kCancelled ? 1 : 2;
          }
          ended = std::chrono::steady_clock::now();
        }) {}
  std::atomic<int> outcome{-1};
  std::chrono::steady_clock::time_point ended;
  std::thread worker;  // last: it starts once the members it writes exist
};

// 800 copies of one sphere (the attack run's coincident balls): the pair pass alone would
// take minutes; cancelled 0.3 s in, compute_gvd ends with kCancelled within a second.
TEST(Cancel, CoincidentObjectsStopWithinASecond) {
  const Scene scene = coincident_spheres(800);
  std::atomic<bool> cancel{false};
  PipelineOptions o;
  o.threads = 2;
  o.cancel = &cancel;
  BackgroundCompute run(scene, o);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto asked = std::chrono::steady_clock::now();
  cancel = true;
  run.worker.join();
  EXPECT_EQ(run.outcome.load(), 1);
  EXPECT_LT(std::chrono::duration<double>(run.ended - asked).count(), kCancelLatency);
}

// The scene stage of those 800 spheres (the frame's facing search meets 800 copies of every
// triangle; the BVHs index 180k triangles) takes about 0.4 s here, 12 s under ASan. Cancelled
// 50 ms into it, compute_gvd stops inside it: no later stage starts, and the answer comes
// within kSceneLatency. (Before the stage read the flag, the octree stage's pair pass was the
// first to see it, when the scene stage had ended.)
TEST(Cancel, SceneStageStopsWithinIt) {
  const Scene scene = coincident_spheres(800);
  std::atomic<bool> cancel{false}, in_scene{false}, past_scene{false};
  PipelineOptions o;
  o.threads = 2;
  o.cancel = &cancel;
  o.progress = [&](const std::string& stage, double) {
    (stage == "scene" ? in_scene : past_scene) = true;
  };
  BackgroundCompute run(scene, o);
  while (!in_scene) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const bool ended_early = past_scene;
  const auto asked = std::chrono::steady_clock::now();
  cancel = true;
  run.worker.join();
  ASSERT_FALSE(ended_early) << "the scene stage took under 50 ms: the test needs a larger scene";
  EXPECT_EQ(run.outcome.load(), 1);
  EXPECT_FALSE(past_scene) << "the cancel waited for the scene stage to end";
  EXPECT_LT(std::chrono::duration<double>(run.ended - asked).count(), kSceneLatency);
}

}  // namespace
}  // namespace gvd

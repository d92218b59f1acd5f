// Benchmarks of the OpenCL backend, linked into gvd_bench next to gvd_bench.cpp:
//  - BM_ClosestPoints/<scene>/{opencl,twin,scalar}: the closest-point kernel, its CPU twin on
//    2 threads (PoCL's CPU device also uses the 2 cores) and the same per-item loop on one
//    thread, on the same batch: the exact queries of the scene's first distance field as
//    compute_distances issues them (recorded once, outside the timing).
//  - BM_KernelBuild/{cold,cached}: creating the backend (device, context, program, warm-up
//    launch). Cold = a build-option nonce no cache has seen (ours and PoCL's); cached = the
//    same program again, loaded from our binary cache.
//  - BM_OctreeBuild/<scene>/{cpu,dp_twin,dp_opencl}: build_octree (level-synchronous) against
//    the data-parallel build with its CPU twins and with the OpenCL kernels (same options and
//    contact pairs as the pipeline); same_leaves = 1 when the leaves equal build_octree's.
//  - BM_PipelineBackend/<scene>/{cpu,opencl}: compute_gvd end to end with each backend
//    (backend created once, outside the timing).
// The CPU column is the process CPU time (all threads, PoCL's included): on a shared machine
// it is the steadier figure.
// Skipped with a message when there is no OpenCL platform.

#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench/table1_scenes.h"
#include "gvd/distance/closest_points.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/distance/distance_field.h"
#include "gvd/kernels/opencl_backend.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/build_octree_data_parallel.h"
#include "gvd/octree/contacts.h"
#include "gvd/pipeline/pipeline.h"

namespace {

constexpr int kThreads = 2;

std::shared_ptr<gvd::kernels::OpenClBackend> backend(std::string* why) {
  static std::string reason;
  static std::shared_ptr<gvd::kernels::OpenClBackend> b = [] {
    std::shared_ptr<gvd::kernels::OpenClBackend> r;
    if (gvd::kernels::opencl_available(&reason)) r = gvd::kernels::make_opencl_backend();
    return r;
  }();
  *why = reason;
  return b;
}

const gvd::scene::Scene& scene_named(const std::string& name) {
  static std::map<std::string, gvd::scene::Scene> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  gvd::scene::Scene s = name == "blades"       ? gvd::bench::make_blades()
                        : name == "polygons2d" ? gvd::bench::make_polygons2d()
                        : name == "gears3d"    ? gvd::bench::make_gears3d()
                                               : gvd::bench::make_spheres();
  return cache.emplace(name, std::move(s)).first->second;
}

// One scene's geometry, BVH and a batch of queries near its simplices.
struct Workload {
  gvd::scene::Domain domain;
  gvd::scene::UnitGeometry geometry;
  std::unique_ptr<gvd::SimplexBvh> bvh;
  gvd::distance::ClosestPointData data;
  std::vector<gvd::Vec3> queries;
  std::vector<double> bound2;
};

// Records the batches compute_distances hands to its solver, answering with the CPU twin.
class RecordingSolver final : public gvd::distance::ClosestPointSolver {
 public:
  RecordingSolver(const gvd::distance::ClosestPointData& data, Workload& w) : data_(data), w_(w) {}
  void solve(std::span<const gvd::Vec3> q, std::span<const double> b,
             std::span<gvd::ClosestHit> hits) override {
    w_.queries.insert(w_.queries.end(), q.begin(), q.end());
    w_.bound2.insert(w_.bound2.end(), b.begin(), b.end());
    gvd::distance::closest_points_cpu(data_, q, b, hits, kThreads);
  }

 private:
  const gvd::distance::ClosestPointData& data_;
  Workload& w_;
};

// The queries of the first distance field of the scene, as the pipeline issues them: every
// non-empty octree vertex in vertex-key order with the bound from an incident leaf, then the
// vertices near the GVD with their wavefront bound.
const Workload& workload(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Workload>> cache;
  auto& w = cache[name];
  if (w) return *w;
  w = std::make_unique<Workload>();
  const gvd::scene::Scene& scene = scene_named(name);
  w->domain = gvd::scene::make_domain(scene);
  w->geometry = gvd::scene::make_unit_geometry(scene, w->domain);
  const gvd::scene::UnitGeometry& g = w->geometry;
  w->bvh = std::make_unique<gvd::SimplexBvh>(g.dimension, g.points, g.simplices);
  w->data = gvd::distance::make_closest_point_data(*w->bvh);
  gvd::octree::OctreeOptions oo;
  oo.threads = kThreads;
  const gvd::octree::Octree octree = gvd::octree::build_octree(g, oo);
  RecordingSolver recorder(w->data, *w);
  gvd::distance::DistanceOptions dopt;
  dopt.threads = kThreads;
  dopt.solver = &recorder;
  gvd::distance::compute_distances(octree, g, *w->bvh, dopt);
  return *w;
}

void BM_ClosestPoints(benchmark::State& state, std::string scene, std::string impl) {
  std::string why;
  const auto cl = backend(&why);
  if (impl == "opencl" && !cl) {
    state.SkipWithError(("no OpenCL: " + why).c_str());
    return;
  }
  const Workload& w = workload(scene);
  std::vector<gvd::ClosestHit> hits(w.queries.size());
  std::unique_ptr<gvd::distance::ClosestPointSolver> solver;
  if (impl == "opencl") solver = cl->closest_points(w.geometry, *w.bvh);
  for (auto _ : state) {
    if (impl == "opencl")
      solver->solve(w.queries, w.bound2, hits);
    else if (impl == "twin")
      gvd::distance::closest_points_cpu(w.data, w.queries, w.bound2, hits, kThreads);
    else
      gvd::distance::closest_points_scalar(w.data, w.queries, w.bound2, hits);
    benchmark::DoNotOptimize(hits.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * w.queries.size()));
  state.counters["queries"] = static_cast<double>(w.queries.size());
  state.counters["simplices"] = static_cast<double>(w.geometry.simplices.size());
}

void BM_KernelBuild(benchmark::State& state, bool cached) {
  std::string why;
  if (!backend(&why)) {  // also initialises OpenCL once, before the timed creations
    state.SkipWithError(("no OpenCL: " + why).c_str());
    return;
  }
  static const std::string dir = [] {
    char tmpl[] = "/tmp/gvd-kernel-cache-XXXXXX";
    const char* d = mkdtemp(tmpl);
    return std::string(d ? d : "");
  }();
  static int nonce =
      static_cast<int>(std::chrono::steady_clock::now().time_since_epoch().count() % 1000000007);
  double build = 0, warm = 0;
  int from_cache = 0;
  if (cached) {  // make sure the binary of this nonce is in the cache, outside the timing
    gvd::kernels::OpenClOptions o;
    o.cache_dir = dir;
    o.extra_build_options = "-DGVD_BENCH_NONCE=" + std::to_string(nonce);
    gvd::kernels::make_opencl_backend(o);
  }
  for (auto _ : state) {
    gvd::kernels::OpenClOptions o;
    o.cache_dir = dir;
    if (!cached) ++nonce;  // a program nobody compiled before
    o.extra_build_options = "-DGVD_BENCH_NONCE=" + std::to_string(nonce);
    const auto b = gvd::kernels::make_opencl_backend(o);
    build += b->build_report().seconds;
    warm += b->build_report().warm_up_seconds;
    from_cache += b->build_report().from_cache;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["program_ms"] = 1e3 * build / n;
  state.counters["warm_up_ms"] = 1e3 * warm / n;
  state.counters["from_cache"] = from_cache / n;
}

void BM_OctreeBuild(benchmark::State& state, std::string scene, std::string impl) {
  std::string why;
  const auto cl = backend(&why);
  if (impl == "dp_opencl" && !cl) {
    state.SkipWithError(("no OpenCL: " + why).c_str());
    return;
  }
  const gvd::scene::Scene& sc = scene_named(scene);
  const gvd::scene::Domain domain = gvd::scene::make_domain(sc);
  const gvd::scene::UnitGeometry g = gvd::scene::make_unit_geometry(sc, domain);
  const gvd::SimplexBvh bvh(g.dimension, g.points, g.simplices);
  const int max_depth = gvd::octree::resolve_max_depth(g.dimension, 0);
  const gvd::octree::ContactPairs contacts = gvd::octree::find_contact_pairs(
      g, bvh, 2.0 * std::sqrt(double(g.dimension)) * std::ldexp(1.0, -max_depth), kThreads);
  gvd::octree::OctreeOptions o;
  o.threads = kThreads;
  o.contacts = &contacts;
  const gvd::octree::Octree reference = gvd::octree::build_octree(g, o);
  gvd::octree::Octree t;
  gvd::octree::DataParallelBuildStats stats;
  for (auto _ : state) {
    if (impl == "cpu") {
      t = gvd::octree::build_octree(g, o);
    } else if (impl == "dp_twin") {
      t = gvd::octree::build_octree_data_parallel(g, o, nullptr, &stats);
    } else {
      const auto steps = cl->octree_build_steps(g);
      t = gvd::octree::build_octree_data_parallel(g, o, steps.get(), &stats);
    }
  }
  state.counters["leaves"] = static_cast<double>(t.leaf_count());
  state.counters["same_leaves"] =
      t.code == reference.code && t.level == reference.level && t.object == reference.object;
  if (impl != "cpu") {
    state.counters["vertex_leaves"] = static_cast<double>(stats.vertex_octree_leaves);
    state.counters["conflicts"] = static_cast<double>(stats.conflict_cells);
    state.counters["resolved_leaves"] = static_cast<double>(stats.resolved_leaves);
    state.counters["vertex_octree_s"] = stats.seconds_vertex_octree;
    state.counters["facets_s"] = stats.seconds_facets;
    state.counters["refine_s"] = stats.seconds_refine;
    state.counters["rule_s"] = stats.seconds_rule;
    state.counters["balance_leaves_s"] = stats.seconds_materialize;
  }
}

void BM_PipelineBackend(benchmark::State& state, std::string scene, std::string impl) {
  std::string why;
  const auto cl = backend(&why);
  if (impl == "opencl" && !cl) {
    state.SkipWithError(("no OpenCL: " + why).c_str());
    return;
  }
  gvd::pipeline::PipelineOptions o;
  o.threads = kThreads;
  if (impl == "opencl") {
    o.backend = gvd::pipeline::BackendRequest::kOpenCl;
    o.compute = cl;
  }
  gvd::result::ResultStats stats;
  for (auto _ : state) {
    state.PauseTiming();
    gvd::scene::Scene copy = scene_named(scene);
    state.ResumeTiming();
    stats = gvd::pipeline::compute_gvd(std::move(copy), o).stats;
  }
  for (const gvd::result::StageStats& s : stats.stages) state.counters[s.name + "_s"] = s.seconds;
  state.counters["total_s"] = stats.total_seconds;
  state.counters["leaves"] = static_cast<double>(stats.leaves);
}

const bool registered = [] {
  for (const char* scene : {"blades", "spheres"})
    for (const char* impl : {"opencl", "twin", "scalar"})
      benchmark::RegisterBenchmark((std::string("BM_ClosestPoints/") + scene + "/" + impl).c_str(),
                                   [s = std::string(scene), i = std::string(impl)](
                                       benchmark::State& st) { BM_ClosestPoints(st, s, i); })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->MeasureProcessCPUTime()  // the CPU column: all threads, PoCL's included
          ->MinTime(1.0);
  benchmark::RegisterBenchmark("BM_KernelBuild/cold",
                               [](benchmark::State& st) { BM_KernelBuild(st, false); })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->Iterations(3);
  benchmark::RegisterBenchmark("BM_KernelBuild/cached",
                               [](benchmark::State& st) { BM_KernelBuild(st, true); })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->Iterations(10);
  for (const char* scene : {"polygons2d", "gears3d", "blades", "spheres"})
    for (const char* impl : {"cpu", "dp_twin", "dp_opencl"})
      benchmark::RegisterBenchmark((std::string("BM_OctreeBuild/") + scene + "/" + impl).c_str(),
                                   [s = std::string(scene), i = std::string(impl)](
                                       benchmark::State& st) { BM_OctreeBuild(st, s, i); })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->MeasureProcessCPUTime()
          ->Iterations(1);
  for (const char* scene : {"blades", "spheres"})
    for (const char* impl : {"cpu", "opencl"})
      benchmark::RegisterBenchmark(
          (std::string("BM_PipelineBackend/") + scene + "/" + impl).c_str(),
          [s = std::string(scene), i = std::string(impl)](benchmark::State& st) {
            BM_PipelineBackend(st, s, i);
          })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->MeasureProcessCPUTime()
          ->Iterations(1);
  return true;
}();

}  // namespace

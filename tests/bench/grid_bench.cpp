// The uniform-grid discrete GVD (CuRV range culling, Sud et al. 2006) on the paper's headline
// case — 20,000 segments on a 1200^2 grid — and on two 3D scenes of >= 60k triangles on a
// 256^3 grid (5,120 small boxes; 64 large spheres, whose insides are the costly case), each beside
// a brute-force grid (every site at every cell; measured on a coarser grid of the same scene and
// scaled by the pair count, which is what its cost is proportional to) and beside the adaptive
// octree (compute_gvd) on the same scene. Counters: seconds, the fraction of brute-force site-cell
// pairs evaluated, and the backend. A summary table follows Google Benchmark's report.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "gvd/common/stopwatch.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/grid/sample_result_grid.h"
#include "gvd/kernels/opencl_backend.h"
#include "gvd/pipeline/pipeline.h"
#include "support/scenes.h"

using namespace gvd::scene;

namespace {

using gvd::scene::Scene;

constexpr int kThreads = 2;

/// 20,000 segments, one object each, no two touching: a jittered 142 x 142 lattice of cells
/// (20,000 of its 20,164 cells used), in each a segment of random direction and length up to
/// 0.8 of the cell, kept 10 % clear of the cell's sides.
Scene make_segments20k() {
  std::mt19937 rng(2006);
  std::uniform_real_distribution<double> u(0, 1);
  const int side = 142;
  const double w = 1.0 / side;
  std::vector<gvd::scene::SceneObject> objs;
  for (int c = 0; c < 20000; ++c) {
    const int cx = c % side, cy = c / side;
    const double len = w * (0.2 + 0.6 * u(rng));
    const double t = 2 * 3.141592653589793 * u(rng);
    const double dx = 0.5 * len * std::cos(t), dy = 0.5 * len * std::sin(t);
    // Centre anywhere that keeps both ends within [0.1, 0.9] of the cell.
    const double hx = 0.4 * w - std::abs(dx), hy = 0.4 * w - std::abs(dy);
    const double mx = (cx + 0.5) * w + (2 * u(rng) - 1) * std::max(0.0, hx);
    const double my = (cy + 0.5) * w + (2 * u(rng) - 1) * std::max(0.0, hy);
    objs.push_back(gvd::test::make_segment("s" + std::to_string(c), {mx - dx, my - dy, 0},
                                           {mx + dx, my + dy, 0}));
  }
  return gvd::test::make_scene(2, std::move(objs));
}

/// 64 closed spheres (4 x 4 x 4, 16 rings x 32 segments: 61,440 triangles), radii 0.35-0.45
/// of their spacing.
Scene make_spheres64() {
  std::mt19937 rng(64);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<gvd::scene::SceneObject> objs;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const double r = 0.35 + 0.1 * u(rng);
        objs.push_back(gvd::test::make_sphere("ball_" + std::to_string(objs.size()),
                                              {i + 0.5, j + 0.5, k + 0.5}, r, 16, 32));
      }
  return gvd::test::make_scene(3, std::move(objs));
}

/// 5,120 closed boxes (a jittered 16 x 16 x 20 lattice, one box per lattice cell, sides
/// 0.3-0.7 of the cell, kept clear of its faces): 61,440 triangles in many small objects,
/// the 3D counterpart of the segments (most cells are near some object's surface, few deep
/// inside one).
Scene make_boxes5k() {
  std::mt19937 rng(5120);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<gvd::scene::SceneObject> objs;
  for (int k = 0; k < 20; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) {
        gvd::Vec3 lo, hi;
        const int c[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) {
          const double side = 0.3 + 0.4 * u(rng);
          const double start = c[a] + 0.1 + (0.8 - side) * u(rng);
          lo[a] = start;
          hi[a] = start + side;
        }
        objs.push_back(gvd::test::make_box("box_" + std::to_string(objs.size()), lo, hi));
      }
  return gvd::test::make_scene(3, std::move(objs));
}

const Scene& scene_named(const std::string& name) {
  static std::map<std::string, Scene> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    it = cache
             .emplace(name, name == "segments20k" ? make_segments20k()
                            : name == "boxes5k"   ? make_boxes5k()
                                                  : make_spheres64())
             .first;
  }
  return it->second;
}

int resolution_of(const std::string& name) { return name == "segments20k" ? 1200 : 256; }

std::shared_ptr<gvd::kernels::OpenClBackend> opencl(std::string* why) {
  static std::string reason;
  static std::shared_ptr<gvd::kernels::OpenClBackend> b = [] {
    std::shared_ptr<gvd::kernels::OpenClBackend> r;
    if (gvd::kernels::opencl_available(&reason)) r = gvd::kernels::make_opencl_backend();
    return r;
  }();
  *why = reason;
  return b;
}

struct Row {
  std::string scene, impl, backend;
  double seconds = 0, fraction = 0;
  uint64_t cells = 0, sites = 0, pairs = 0;
  std::string note;
};
std::vector<Row>& rows() {
  static auto* all = new std::vector<Row>;  // never destroyed: printed at exit
  return *all;
}

/// impl: "curv" (CPU twin), "curv_opencl", "brute" (no culling, scaled from a coarser grid),
/// "octree" (compute_gvd, the adaptive pipeline), "from_result" (sample_result_grid on the
/// finished adaptive result).
void BM_Grid(benchmark::State& state, const std::string& scene_name, const std::string& impl) {
  const Scene& scene = scene_named(scene_name);
  Row row;
  row.scene = scene_name;
  row.impl = impl;
  row.sites = scene.simplex_count();
  gvd::grid::GridOptions o;
  o.resolution = resolution_of(scene_name);
  o.threads = kThreads;
  if (impl == "curv_opencl") {
    std::string why;
    o.compute = opencl(&why);
    if (!o.compute) {
      state.SkipWithError(("no OpenCL: " + why).c_str());
      return;
    }
  }
  for (auto _ : state) {
    if (impl == "octree") {
      gvd::pipeline::PipelineOptions p;
      p.threads = kThreads;
      Scene copy = scene;
      const gvd::Stopwatch sw;
      const gvd::result::GvdResult r = gvd::pipeline::compute_gvd(std::move(copy), p);
      row.seconds = sw.seconds();
      row.cells = r.stats.leaves;
      row.backend = r.stats.backend;
      row.note = std::to_string(r.stats.leaves) + " leaves, depth " + std::to_string(r.stats.depth);
      continue;
    }
    if (impl == "from_result") {
      // gvd grid RESULT.gvd: the adaptive result is computed first (not timed), then the
      // grid is sampled from it (sample_result_grid) on its domain (a cube: N^3 cells).
      gvd::pipeline::PipelineOptions p;
      p.threads = kThreads;
      Scene copy = scene;
      const gvd::result::GvdResult r = gvd::pipeline::compute_gvd(std::move(copy), p);
      gvd::grid::ResultGridOptions ro;
      ro.resolution = o.resolution;
      ro.threads = kThreads;
      const gvd::grid::DistanceGrid g = gvd::grid::sample_result_grid(r, ro);
      row.seconds = g.stats.seconds;
      row.cells = g.spec.cell_count();
      row.pairs = g.stats.pairs_evaluated;
      row.fraction = g.stats.culled_fraction();
      row.backend = g.stats.backend;
      char note[200];
      std::snprintf(note, sizeof note, "after compute_gvd %.3f s (%llu leaves); sign %.3f s",
                    r.stats.total_seconds, static_cast<unsigned long long>(r.stats.leaves),
                    g.stats.sign_seconds);
      row.note = note;
      continue;
    }
    if (impl == "brute") {
      // Brute force (every object at every cell, through the same per-range kernel; an
      // object's BVH walk still stops at the cell's best distance so far) costs in
      // proportion to cells x objects: measured on a grid with 1/100 of the cells (2D;
      // 1/512 in 3D) and scaled by the cell count.
      gvd::grid::GridOptions b = o;
      b.cull = false;
      b.resolution = scene.dimension == 2 ? o.resolution / 10 : o.resolution / 8;
      const gvd::grid::DistanceGrid g = gvd::grid::compute_grid(scene, b);
      const gvd::grid::GridSpec full = gvd::grid::make_grid_spec(scene, o);
      const double scale =
          static_cast<double>(full.cell_count()) / static_cast<double>(g.spec.cell_count());
      row.seconds = g.stats.seconds * scale;
      row.cells = full.cell_count();
      row.pairs = full.cell_count() * scene.simplex_count();
      row.fraction = 1;
      row.backend = g.stats.backend;
      row.note = "measured at resolution " + std::to_string(b.resolution) + " (" +
                 std::to_string(g.stats.seconds) + " s), x" + std::to_string(scale);
      continue;
    }
    const gvd::grid::DistanceGrid g = gvd::grid::compute_grid(scene, o);
    row.seconds = g.stats.seconds;
    row.cells = g.spec.cell_count();
    row.pairs = g.stats.pairs_evaluated;
    row.fraction = g.stats.culled_fraction();
    row.backend = g.stats.backend;
    char note[200];
    std::snprintf(note, sizeof note,
                  "%llu batches, range %d; evaluate %.3f s, binning %.3f s, sign %.3f s",
                  static_cast<unsigned long long>(g.stats.batches), g.range_cells,
                  g.stats.evaluate_seconds, g.stats.bin_seconds, g.stats.sign_seconds);
    row.note = note;
  }
  state.counters["seconds"] = row.seconds;
  state.counters["pair_fraction"] = row.fraction;
  state.counters["cells"] = static_cast<double>(row.cells);
  rows().push_back(row);
}

void print_grid_summary() {
  if (rows().empty()) return;
  std::printf("\nUniform grid (CuRV range culling) vs brute force vs adaptive octree:\n");
  std::printf("%-12s %-12s %10s %12s %14s  %s\n", "scene", "method", "seconds", "pairs/brute",
              "cells|leaves", "backend; note");
  for (const Row& r : rows()) {
    std::printf("%-12s %-12s %10.3f %12.4f %14llu  %s; %s\n", r.scene.c_str(), r.impl.c_str(),
                r.seconds, r.fraction, static_cast<unsigned long long>(r.cells), r.backend.c_str(),
                r.note.c_str());
  }
}

const bool registered = [] {
  for (const char* scene : {"segments20k", "boxes5k", "spheres64"})
    for (const char* impl : {"curv", "curv_opencl", "brute", "octree", "from_result"})
      benchmark::RegisterBenchmark((std::string("BM_Grid/") + scene + "/" + impl).c_str(),
                                   [s = std::string(scene), i = std::string(impl)](
                                       benchmark::State& st) { BM_Grid(st, s, i); })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->Iterations(1);
  std::atexit(print_grid_summary);
  return true;
}();

}  // namespace

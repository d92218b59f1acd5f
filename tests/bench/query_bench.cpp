// Benchmarks of the GvdIndex queries on the packed-spheres scene (200 spheres, 64.8k
// triangles), each next to a baseline run in the same process: nearest object vs an exact
// AABB-tree (BVH) query and brute force over every triangle; k-rings vs scanning the edge
// list; roadmap paths vs a uniform-grid planner. Accuracy of the nearest answers is measured
// against the exact answers. Single-threaded figures (queries per second per core).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <memory>
#include <random>
#include <vector>

#include "bench/table1_scenes.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/query/gvd_index.h"
#include "support/oracles.h"

using namespace gvd::octree;

namespace {

using gvd::Vec3;

struct QueryFixture {
  std::shared_ptr<const gvd::result::GvdResult> result;
  std::unique_ptr<gvd::query::GvdIndex> index;
  gvd::SimplexBvh bvh;
  std::vector<Vec3> points;  // random points in the domain (user units)
  double compute_seconds = 0, index_seconds = 0;
  double tables_seconds = 0;  // the fast path's tables, built by its first query
};

QueryFixture& fixture() {
  static QueryFixture* f = [] {
    auto* q = new QueryFixture;
    gvd::pipeline::PipelineOptions options;
    options.threads = 2;
    auto t0 = std::chrono::steady_clock::now();
    q->result = std::make_shared<const gvd::result::GvdResult>(
        gvd::pipeline::compute_gvd(gvd::bench::make_spheres(), options));
    auto t1 = std::chrono::steady_clock::now();
    q->index = std::make_unique<gvd::query::GvdIndex>(q->result);
    auto t2 = std::chrono::steady_clock::now();
    q->compute_seconds = std::chrono::duration<double>(t1 - t0).count();
    q->index_seconds = std::chrono::duration<double>(t2 - t1).count();
    // The first fast query builds the tables every later one reads: outside the timings.
    q->index->nearest(q->result->domain.box().center(), true);
    q->tables_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t2).count();
    const gvd::scene::UnitGeometry& g = q->result->geometry;
    q->bvh = gvd::SimplexBvh(g.dimension, g.points, g.simplices);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const gvd::Box box = q->result->domain.box();
    for (int i = 0; i < 1 << 18; ++i) {
      Vec3 p;
      for (int a = 0; a < 3; ++a) p[a] = box.lo[a] + u(rng) * (box.hi[a] - box.lo[a]);
      q->points.push_back(p);
    }
    return q;
  }();
  return *f;
}

/// The default mode: exact, one BVH query per point (and the inside test on closed objects).
void BM_NearestIndex(benchmark::State& state) {
  const QueryFixture& f = fixture();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.index->nearest(f.points[i]).distance);
    i = (i + 1) & (f.points.size() - 1);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["leaves"] = static_cast<double>(f.result->octree.leaf_count());
  state.counters["triangles"] = static_cast<double>(f.result->geometry.simplices.size());
  state.counters["index_build_s"] = f.index_seconds;
  state.counters["nearest_tables_s"] = f.tables_seconds;
}

/// The fast mode's two kinds of queries apart: answered by the leaf's vertices (arg 0) or by
/// the exact fallback (arg 1).
void BM_NearestIndexSplit(benchmark::State& state) {
  const QueryFixture& f = fixture();
  static const std::array<std::vector<Vec3>, 2> split = [&] {
    std::array<std::vector<Vec3>, 2> out;
    for (const Vec3& p : f.points) out[f.index->nearest(p, true).exact ? 1 : 0].push_back(p);
    return out;
  }();
  const std::vector<Vec3>& points = split[state.range(0)];
  if (points.empty()) {
    state.SkipWithError("no point of this kind");
    return;
  }
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.index->nearest(points[i], true).distance);
    if (++i == points.size()) i = 0;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["share_pct"] = 100.0 * static_cast<double>(points.size()) /
                                static_cast<double>(split[0].size() + split[1].size());
}

/// The fast mode: the paper's §4 rule in empty leaves, the leaf's answer where its corners
/// prove it within 3/2 elsewhere.
void BM_NearestIndexApproximate(benchmark::State& state) {
  const QueryFixture& f = fixture();
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.index->nearest(f.points[i], true).distance);
    i = (i + 1) & (f.points.size() - 1);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}

void BM_NearestBvhExact(benchmark::State& state) {
  const QueryFixture& f = fixture();
  size_t i = 0;
  for (auto _ : state) {
    const gvd::ClosestHit h = f.bvh.nearest(f.result->domain.to_unit(f.points[i]));
    benchmark::DoNotOptimize(h.dist2);
    i = (i + 1) & (f.points.size() - 1);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}

void BM_NearestBruteForce(benchmark::State& state) {
  const QueryFixture& f = fixture();
  size_t i = 0;
  for (auto _ : state) {
    const auto a = gvd::test::brute_nearest(f.result->scene, f.points[i]);
    benchmark::DoNotOptimize(a.distance);
    i = (i + 1) & (f.points.size() - 1);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}

/// Accuracy of the index against the exact answers (BVH; itself checked against brute force on
/// a sample): how often the object differs, and the distance ratio reported / true.
void BM_NearestAccuracy(benchmark::State& state) {
  const QueryFixture& f = fixture();
  const size_t samples = 50000;
  size_t differ = 0, exact = 0, bvh_wrong = 0, exact_in_nonempty = 0, approx_differ = 0;
  double approx_worst = 1;
  double worst_ratio = 1, sum_ratio = 0, worst_differ_gap = 0;
  for (auto _ : state) {
    for (size_t i = 0; i < samples; ++i) {
      const Vec3 p = f.points[i];
      const gvd::query::NearestAnswer a = f.index->nearest(p);
      const gvd::ClosestHit h = f.bvh.nearest(f.result->domain.to_unit(p));
      const double truth = std::sqrt(h.dist2) * f.result->domain.side;
      const gvd::scene::ObjectId object = f.result->geometry.object_of[h.simplex];
      const gvd::query::NearestAnswer fast = f.index->nearest(p, true);
      approx_worst = std::max(approx_worst, truth > 0 ? fast.distance / truth : 1);
      approx_differ += fast.object != object ? 1 : 0;
      const double ratio = truth > 0 ? a.distance / truth : 1;
      worst_ratio = std::max(worst_ratio, ratio);
      sum_ratio += ratio;
      exact += a.exact ? 1 : 0;
      if (a.exact) {
        const uint32_t leaf = f.result->octree.locate(f.result->domain.to_unit(p));
        exact_in_nonempty += f.result->octree.object[leaf] != gvd::scene::kNoObject ? 1 : 0;
      }
      if (a.object != object) {
        ++differ;
        worst_differ_gap = std::max(worst_differ_gap, (a.distance - truth) / f.result->domain.side);
      }
      if (i % 250 == 0) {  // the BVH against brute force
        const auto b = gvd::test::brute_nearest(f.result->scene, p);
        if (std::abs(b.distance - truth) > 1e-9 * f.result->domain.side) ++bvh_wrong;
      }
    }
  }
  state.counters["samples"] = static_cast<double>(samples);
  state.counters["object_differs_pct"] = 100.0 * static_cast<double>(differ) / samples;
  state.counters["differ_gap_domain"] = worst_differ_gap;
  state.counters["ratio_max"] = worst_ratio;
  state.counters["ratio_mean"] = sum_ratio / samples;
  state.counters["exact_pct"] = 100.0 * static_cast<double>(exact) / samples;
  state.counters["exact_nonempty_leaf_pct"] =
      100.0 * static_cast<double>(exact_in_nonempty) / samples;
  state.counters["bvh_vs_brute_wrong"] = static_cast<double>(bvh_wrong);
  state.counters["approx_ratio_max"] = approx_worst;
  state.counters["approx_differs_pct"] = 100.0 * static_cast<double>(approx_differ) / samples;
}

void BM_Neighbors(benchmark::State& state) {
  const QueryFixture& f = fixture();
  const int ring = static_cast<int>(state.range(0));
  const uint32_t n = f.result->graph.node_count;
  uint32_t o = 0;
  size_t total = 0;
  for (auto _ : state) {
    const auto r = f.index->neighbors(o, ring);
    total += r.size();
    o = (o + 37) % n;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["mean_found"] =
      static_cast<double>(total) / std::max<int64_t>(state.iterations(), 1);
}

/// Baseline: k rings by scanning the whole edge list once per ring (no adjacency index).
void BM_NeighborsEdgeScan(benchmark::State& state) {
  const QueryFixture& f = fixture();
  const int ring = static_cast<int>(state.range(0));
  const auto& edges = f.result->graph.edges;
  const uint32_t n = f.result->graph.node_count;
  uint32_t o = 0;
  std::vector<int> depth(n);
  for (auto _ : state) {
    std::fill(depth.begin(), depth.end(), -1);
    depth[o] = 0;
    for (int r = 1; r <= ring; ++r) {
      for (const gvd::graph::DualEdge& e : edges) {
        if (depth[e.a] == r - 1 && depth[e.b] < 0) depth[e.b] = r;
        if (depth[e.b] == r - 1 && depth[e.a] < 0) depth[e.a] = r;
      }
    }
    benchmark::DoNotOptimize(depth.data());
    o = (o + 37) % n;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}

/// Start/goal pairs in free space (clearance >= 1e-3 of the domain), fixed for both planners.
const std::vector<std::pair<Vec3, Vec3>>& path_pairs() {
  static const std::vector<std::pair<Vec3, Vec3>> pairs = [] {
    const QueryFixture& f = fixture();
    std::vector<Vec3> free;
    for (const Vec3& p : f.points) {
      const gvd::ClosestHit h = f.bvh.nearest(f.result->domain.to_unit(p));
      if (std::sqrt(h.dist2) > 1e-3) free.push_back(p);
      if (free.size() == 200) break;
    }
    std::vector<std::pair<Vec3, Vec3>> out;
    for (size_t i = 0; i + 1 < free.size(); i += 2) out.emplace_back(free[i], free[i + 1]);
    return out;
  }();
  return pairs;
}

void BM_Path(benchmark::State& state) {
  const QueryFixture& f = fixture();
  const auto& pairs = path_pairs();
  size_t i = 0, found = 0, n = 0;
  double clearance = 0;
  for (auto _ : state) {
    gvd::query::PathQuery q;
    q.from = pairs[i].first;
    q.to = pairs[i].second;
    q.cost =
        state.range(0) == 0 ? gvd::query::PathCost::kShortest : gvd::query::PathCost::kClearance;
    const gvd::query::PathAnswer a = f.index->path(q);
    found += a.found ? 1 : 0;
    if (a.found) clearance += a.min_clearance;
    ++n;
    i = (i + 1) % pairs.size();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["found_pct"] = 100.0 * static_cast<double>(found) / std::max<size_t>(n, 1);
  state.counters["mean_min_clearance"] = clearance / std::max<size_t>(found, 1);
}

/// Baseline: a uniform-grid planner (the approach the paper contrasts with): `res`^3 cells,
/// a cell is free when its centre is farther from every object than half its diagonal
/// (exact BVH distance), breadth-first search between the cells of start and goal. The grid
/// is built once, outside the timing (reported as grid_build_s).
void BM_PathUniformGrid(benchmark::State& state) {
  const QueryFixture& f = fixture();
  const int res = static_cast<int>(state.range(0));
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<uint8_t> free(static_cast<size_t>(res) * res * res, 0);
  const double h = 1.0 / res;
  for (int z = 0; z < res; ++z)
    for (int y = 0; y < res; ++y)
      for (int x = 0; x < res; ++x) {
        const Vec3 c{(x + 0.5) * h, (y + 0.5) * h, (z + 0.5) * h};
        const gvd::ClosestHit hit = f.bvh.nearest(c, 0.75 * h * h);
        free[(static_cast<size_t>(z) * res + y) * res + x] = hit.found() ? 0 : 1;
      }
  const double build = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  auto cell_of = [&](Vec3 p) {
    const Vec3 u = f.result->domain.to_unit(p);
    int c[3];
    for (int a = 0; a < 3; ++a) c[a] = std::clamp(static_cast<int>(u[a] * res), 0, res - 1);
    return (static_cast<size_t>(c[2]) * res + c[1]) * res + c[0];
  };
  const auto& pairs = path_pairs();
  std::vector<int32_t> dist(free.size());
  size_t i = 0, found = 0, n = 0;
  for (auto _ : state) {
    const size_t s = cell_of(pairs[i].first), g = cell_of(pairs[i].second);
    std::fill(dist.begin(), dist.end(), -1);
    bool ok = false;
    if (free[s] && free[g]) {
      std::deque<size_t> queue{s};
      dist[s] = 0;
      while (!queue.empty() && !ok) {
        const size_t c = queue.front();
        queue.pop_front();
        const int x = static_cast<int>(c % res), y = static_cast<int>((c / res) % res),
                  z = static_cast<int>(c / (static_cast<size_t>(res) * res));
        const int nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z},
                              {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
        for (const auto& q : nb) {
          if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= res || q[1] >= res || q[2] >= res)
            continue;
          const size_t k = (static_cast<size_t>(q[2]) * res + q[1]) * res + q[0];
          if (!free[k] || dist[k] >= 0) continue;
          dist[k] = dist[c] + 1;
          if (k == g) ok = true;
          queue.push_back(k);
        }
      }
      ok = ok || s == g;
    }
    found += ok ? 1 : 0;
    ++n;
    i = (i + 1) % pairs.size();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["found_pct"] = 100.0 * static_cast<double>(found) / std::max<size_t>(n, 1);
  state.counters["grid_build_s"] = build;
}

BENCHMARK(BM_NearestIndex)->MinTime(1.0);
BENCHMARK(BM_NearestIndexSplit)->Arg(0)->Arg(1);
BENCHMARK(BM_NearestIndexApproximate)->MinTime(1.0);
BENCHMARK(BM_NearestBvhExact)->MinTime(1.0);
BENCHMARK(BM_NearestBruteForce)->MinTime(1.0);
BENCHMARK(BM_NearestAccuracy)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Neighbors)->Arg(1)->Arg(3);
BENCHMARK(BM_NeighborsEdgeScan)->Arg(1)->Arg(3);
BENCHMARK(BM_Path)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PathUniformGrid)->Arg(64)->Unit(benchmark::kMillisecond);

}  // namespace

// The uniform-grid discrete GVD with CuRV range culling (Sud et al. 2006, §4-5).
//
// Sites are the scene's objects (each evaluated through a BVH of its own simplices); a cell's
// label is its nearest object. The paper's pivot point becomes the whole site: an object is
// in the swept set S(T) of every range its geometry touches. With that, the chain argument of
// Theorems 1-2 holds for any objects (connected or not) under any norm: for a cell centre q
// in V(p) with nearest point s(q) on p, the straight segment [s(q), q] lies in V(p) and
// crosses ranges monotonically, in the sweep direction given by the signs of q - s(q); every
// range it crosses sees p as visible (conservatively, §5.3), so p is carried along to q's
// range.

#include "gvd/grid/compute_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/stopwatch.h"
#include "gvd/compute/compute_backend.h"
#include "gvd/geometry/primitives.h"
#include "gvd/grid/grid_evaluator.h"

namespace gvd::grid {

using namespace gvd::scene;

GridMetric parse_grid_metric(const std::string& name) {
  if (name == "l2") return GridMetric::kL2;
  if (name == "l1") return GridMetric::kL1;
  if (name == "linf") return GridMetric::kLinf;
  throw Error(ErrorCode::kInvalidArgument,
              "unknown metric '" + name + "' (expected l2, l1 or linf)");
}

const char* grid_metric_name(GridMetric metric) {
  switch (metric) {
    case GridMetric::kL2:
      return "l2";
    case GridMetric::kL1:
      return "l1";
    case GridMetric::kLinf:
      return "linf";
  }
  return "?";
}

Vec3 GridSpec::centre(int i, int j, int k) const {
  return {origin.x + (i + 0.5) * h, origin.y + (j + 0.5) * h,
          dimension == 2 ? 0.0 : origin.z + (k + 0.5) * h};
}

GridSpec make_grid_spec(const Scene& scene, const GridOptions& options) {
  const int dim = scene.dimension;
  if (dim != 2 && dim != 3) {
    throw Error(ErrorCode::kInvalidScene, "dimension must be 2 or 3");
  }
  if (scene.objects.empty() || scene.simplex_count() == 0) {
    throw Error(ErrorCode::kInvalidScene, "the scene has no objects: nothing to compute");
  }
  if (options.resolution < 1) {
    throw Error(ErrorCode::kInvalidArgument,
                "resolution must be at least 1 cell along the longest side (got " +
                    std::to_string(options.resolution) + ")");
  }
  if (!(options.padding >= 0 && options.padding <= 10)) {
    throw Error(ErrorCode::kInvalidArgument, "padding must be in [0, 10]");
  }
  Box verts;
  for (const SceneObject& o : scene.objects)
    for (const Simplex& s : o.simplices)
      for (int i = 0; i < (dim == 2 ? 2 : 3); ++i) verts.extend(o.vertices[s.v[i]]);
  Box box;
  if (options.box) {
    box = *options.box;
    for (int i = 0; i < dim; ++i) {
      if (!(box.lo[i] < box.hi[i])) {
        throw Error(ErrorCode::kInvalidArgument,
                    "the domain box is empty along axis " + std::string(1, "xyz"[i]));
      }
      if (verts.lo[i] < box.lo[i] || verts.hi[i] > box.hi[i]) {
        throw Error(ErrorCode::kInvalidArgument,
                    "the domain box must hold every vertex of the scene (the culling needs "
                    "all sites inside the domain); the vertices span " +
                        std::to_string(verts.lo[i]) + " .. " + std::to_string(verts.hi[i]) +
                        " along " + std::string(1, "xyz"[i]));
      }
    }
  } else {
    double longest = 0;
    for (int i = 0; i < dim; ++i) longest = std::max(longest, verts.hi[i] - verts.lo[i]);
    const double pad = options.padding * longest;
    box.lo = verts.lo;
    box.hi = verts.hi;
    for (int i = 0; i < dim; ++i) {
      box.lo[i] -= pad;
      box.hi[i] += pad;
    }
  }
  double longest = 0;
  for (int i = 0; i < dim; ++i) longest = std::max(longest, box.hi[i] - box.lo[i]);
  GridSpec spec;
  spec.dimension = dim;
  spec.h = longest / options.resolution;
  const uint64_t limit = std::min<uint64_t>(options.max_cells, 0xFFFFFFFFull);
  uint64_t cells = 1;
  for (int i = 0; i < dim; ++i) {
    const double extent = box.hi[i] - box.lo[i];
    const double n = std::max(1.0, std::ceil(extent / spec.h - 1e-9));
    if (n > static_cast<double>(limit)) {
      cells = limit + 1;
      break;
    }
    spec.n[static_cast<size_t>(i)] = static_cast<int>(n);
    cells *= static_cast<uint64_t>(n);
    if (cells > limit) break;
    spec.origin[i] = 0.5 * (box.lo[i] + box.hi[i]) - 0.5 * n * spec.h;
  }
  if (cells > limit) {
    throw Error(ErrorCode::kLimitExceeded,
                "a grid of resolution " + std::to_string(options.resolution) + " has more than " +
                    std::to_string(limit) +
                    " cells (the cell limit; raise it or lower the resolution)");
  }
  if (!(spec.h > 0) || !std::isfinite(spec.h)) {
    throw Error(ErrorCode::kInvalidArgument, "the domain has no extent");
  }
  return spec;
}

namespace {

using Sites = std::vector<uint32_t>;

/// The ranges: a box of tiles, each `b` cells on a side (the last ones clipped).
struct Ranges {
  int b = 16;
  std::array<int, 3> k = {1, 1, 1};
  size_t count() const { return static_cast<size_t>(k[0]) * k[1] * k[2]; }
  size_t index(int x, int y, int z) const { return (static_cast<size_t>(z) * k[1] + y) * k[0] + x; }
  std::array<int, 3> coords(size_t t) const {
    return {static_cast<int>(t % k[0]), static_cast<int>((t / k[0]) % k[1]),
            static_cast<int>(t / (static_cast<size_t>(k[0]) * k[1]))};
  }
};

/// Simplices binned or signed between two reads of the cancel flag.
constexpr uint32_t kCancelSimplices = 4096;

/// S(T) for every range: the objects whose geometry touches the closed range box (sorted).
std::vector<Sites> swept_sets(const GridGeometry& g, const GridSpec& spec, const Ranges& r,
                              const std::atomic<bool>* cancel) {
  std::vector<Sites> swept(r.count());
  const double slack = spec.h * 1e-6;
  const double side = spec.h * r.b;
  const uint32_t sites = static_cast<uint32_t>(g.object_of.size());
  for (uint32_t s = 0; s < sites; ++s) {
    if (s % kCancelSimplices == 0) throw_if_cancelled(cancel, "the grid's binning");
    const Vec3 a = g.points[g.simplices[3 * s]];
    const Vec3 b = g.points[g.simplices[3 * s + 1]];
    const Vec3 c = g.points[g.simplices[3 * s + 2]];
    std::array<int, 3> lo = {0, 0, 0}, hi = {0, 0, 0};
    for (int i = 0; i < spec.dimension; ++i) {
      const double mn = std::min({a[i], b[i], c[i]}) - slack - spec.origin[i];
      const double mx = std::max({a[i], b[i], c[i]}) + slack - spec.origin[i];
      const size_t ii = static_cast<size_t>(i);
      lo[ii] = std::clamp(static_cast<int>(std::floor(mn / side)), 0, r.k[ii] - 1);
      hi[ii] = std::clamp(static_cast<int>(std::floor(mx / side)), 0, r.k[ii] - 1);
    }
    for (int z = lo[2]; z <= hi[2]; ++z) {
      for (int y = lo[1]; y <= hi[1]; ++y) {
        for (int x = lo[0]; x <= hi[0]; ++x) {
          Box box;
          box.lo = {spec.origin.x + x * side, spec.origin.y + y * side,
                    spec.dimension == 2 ? 0.0 : spec.origin.z + z * side};
          box.hi = {box.lo.x + side, box.lo.y + side, spec.dimension == 2 ? 0.0 : box.lo.z + side};
          const bool touches = spec.dimension == 2 ? segment_overlaps_box_2d(a, b, box, slack)
                                                   : triangle_overlaps_box(a, b, c, box, slack);
          Sites& into = swept[r.index(x, y, z)];
          // Simplices come object by object: one entry per object.
          if (touches && (into.empty() || into.back() != g.object_of[s]))
            into.push_back(g.object_of[s]);
        }
      }
    }
  }
  return swept;
}

/// One range's share of a batch.
struct Pending {
  size_t tile = 0;
  Sites fresh;       ///< candidates not yet evaluated in this range
  Sites kept;        ///< candidates evaluated before and visible there
  size_t first = 0;  ///< where `fresh` starts in the batch's site list
};

class Culler {
 public:
  /// `report(f)` gets the fraction of the evaluation done (0 .. 1) after each wavefront.
  Culler(const GridGeometry& g, const GridSpec& spec, const Ranges& r, GridEvaluator& eval,
         GridStats& stats, std::vector<RangeBounds>& bounds, const std::atomic<bool>* cancel,
         std::function<void(double)> report)
      : g_(g),
        spec_(spec),
        r_(r),
        eval_(eval),
        stats_(stats),
        bounds_(bounds),
        cancel_(cancel),
        report_(std::move(report)) {}

  void run(bool cull) {
    evaluated_.assign(r_.count(), {});
    visible_.assign(r_.count(), {});
    if (!cull) {
      brute_force();
      return;
    }
    const Stopwatch sw;
    const std::vector<Sites> swept = swept_sets(g_, spec_, r_, cancel_);
    stats_.bin_seconds = sw.seconds();
    const int dirs = 1 << spec_.dimension;
    for (int sigma = 0; sigma < dirs; ++sigma) sweep(sigma, dirs, swept);
  }

 private:
  std::array<int, 3> size_of(size_t t) const {
    const std::array<int, 3> c = r_.coords(t);
    std::array<int, 3> s = {1, 1, 1};
    for (size_t i = 0; i < static_cast<size_t>(spec_.dimension); ++i)
      s[i] = std::min(r_.b, spec_.n[i] - c[i] * r_.b);
    return s;
  }
  uint32_t cells_of(size_t t) const {
    const std::array<int, 3> s = size_of(t);
    return static_cast<uint32_t>(s[0] * s[1] * s[2]);
  }
  /// Work items of a range: one per row of cells along x.
  uint32_t rows_of(size_t t) const {
    const std::array<int, 3> s = size_of(t);
    return static_cast<uint32_t>(s[1] * s[2]);
  }

  /// One sweep direction (bit i of sigma set = towards -axis i): ranges in wavefronts of
  /// equal distance from the sweep's start corner; a range depends only on its predecessor
  /// along each axis (Theorem 2), so the ranges of one wavefront run as one batch. In 3D the
  /// wavefronts cut across slices; the order within a slice is the paper's (Algorithm 1).
  void sweep(int sigma, int dirs, const std::vector<Sites>& swept) {
    const int dim = spec_.dimension;
    std::vector<Sites> pis(r_.count());
    std::vector<std::vector<size_t>> fronts;
    for (size_t t = 0; t < r_.count(); ++t) {
      const std::array<int, 3> c = r_.coords(t);
      size_t w = 0;
      for (int i = 0; i < dim; ++i) {
        const size_t ii = static_cast<size_t>(i);
        w += static_cast<size_t>((sigma >> i) & 1 ? r_.k[ii] - 1 - c[ii] : c[ii]);
      }
      if (fronts.size() <= w) fronts.resize(w + 1);
      fronts[w].push_back(t);
    }
    Sites merged, tmp;
    for (size_t f = 0; f < fronts.size(); ++f) {
      throw_if_cancelled(cancel_, "the grid's sweeps");
      const std::vector<size_t>& front = fronts[f];
      std::vector<Pending> pending;
      pending.reserve(front.size());
      for (size_t t : front) {
        // Candidates: PIS of the predecessor along each axis, and S(T) (Theorem 2).
        merged = swept[t];
        const std::array<int, 3> c = r_.coords(t);
        for (int i = 0; i < dim; ++i) {
          std::array<int, 3> p = c;
          const size_t ii = static_cast<size_t>(i);
          p[ii] += (sigma >> i) & 1 ? 1 : -1;
          if (p[ii] < 0 || p[ii] >= r_.k[ii]) continue;
          const Sites& from = pis[r_.index(p[0], p[1], p[2])];
          tmp.clear();
          std::set_union(merged.begin(), merged.end(), from.begin(), from.end(),
                         std::back_inserter(tmp));
          std::swap(merged, tmp);
        }
        Pending job;
        job.tile = t;
        std::set_difference(merged.begin(), merged.end(), evaluated_[t].begin(),
                            evaluated_[t].end(), std::back_inserter(job.fresh));
        std::set_intersection(merged.begin(), merged.end(), visible_[t].begin(), visible_[t].end(),
                              std::back_inserter(job.kept));
        pending.push_back(std::move(job));
      }
      evaluate(pending);
      for (Pending& job : pending) pis[job.tile] = std::move(job.kept);
      if (report_) report_((sigma + static_cast<double>(f + 1) / fronts.size()) / dirs);
    }
  }

  /// Evaluates the fresh candidates of `pending` (in batches of at most max_pairs site x
  /// cell distances), records them as evaluated, and leaves in `kept` every candidate
  /// visible in its range.
  void evaluate(std::vector<Pending>& pending) {
    std::vector<item::GvdGridJob> jobs;
    Sites sites;
    uint64_t pairs = 0, items = 0;
    std::vector<size_t> in_batch;
    auto flush = [&] {
      if (jobs.empty()) return;
      throw_if_cancelled(cancel_, "the grid's evaluation");
      std::vector<int32_t> visible(sites.size(), 0);
      const Stopwatch sw;
      eval_.evaluate(jobs, sites, static_cast<uint32_t>(items), visible);
      stats_.evaluate_seconds += sw.seconds();
      ++stats_.batches;
      stats_.pairs_evaluated += pairs;
      for (size_t n = 0; track_ && n < in_batch.size(); ++n) {
        Pending& job = pending[in_batch[n]];
        const size_t t = job.tile;
        Sites now_visible;
        for (size_t k = 0; k < job.fresh.size(); ++k) {
          if (visible[job.first + k] == 0) continue;
          now_visible.push_back(job.fresh[k]);
          update_bounds(job.fresh[k], t);
        }
        merge_into(evaluated_[t], job.fresh);
        merge_into(visible_[t], now_visible);
        merge_into(job.kept, now_visible);
      }
      jobs.clear();
      sites.clear();
      in_batch.clear();
      pairs = 0;
      items = 0;
    };
    for (size_t n = 0; n < pending.size(); ++n) {
      Pending& job = pending[n];
      if (job.fresh.empty()) continue;
      const uint64_t cells = cells_of(job.tile);
      // One range's block must fit the scratch buffer: split its sites if it does not.
      const uint64_t per_chunk = std::max<uint64_t>(1, GridEvaluator::max_pairs() / cells);
      if (job.fresh.size() > per_chunk) {
        flush();
        evaluate_split(job, per_chunk);
        continue;
      }
      const uint64_t block = cells * job.fresh.size();
      if (pairs + block > GridEvaluator::max_pairs()) flush();
      job.first = sites.size();
      jobs.push_back(make_job(job.tile, static_cast<uint32_t>(sites.size()),
                              static_cast<uint32_t>(job.fresh.size()), static_cast<uint32_t>(items),
                              static_cast<uint32_t>(pairs)));
      sites.insert(sites.end(), job.fresh.begin(), job.fresh.end());
      pairs += block;
      items += rows_of(job.tile);
      in_batch.push_back(n);
    }
    flush();
  }

  /// A range with more fresh sites than one batch holds: batch after batch on its own.
  void evaluate_split(Pending& job, uint64_t per_chunk) {
    const uint64_t cells = cells_of(job.tile);
    Sites now_visible;
    for (size_t first = 0; first < job.fresh.size(); first += per_chunk) {
      throw_if_cancelled(cancel_, "the grid's evaluation");
      const size_t count = std::min<size_t>(per_chunk, job.fresh.size() - first);
      const Sites chunk(job.fresh.begin() + static_cast<std::ptrdiff_t>(first),
                        job.fresh.begin() + static_cast<std::ptrdiff_t>(first + count));
      std::vector<int32_t> visible(count, 0);
      const Stopwatch sw;
      const item::GvdGridJob j = make_job(job.tile, 0, static_cast<uint32_t>(count), 0, 0);
      eval_.evaluate(std::span<const item::GvdGridJob>(&j, 1), chunk, static_cast<uint32_t>(cells),
                     visible);
      ++stats_.batches;
      stats_.pairs_evaluated += cells * count;
      for (size_t k = 0; k < count; ++k)
        if (visible[k] != 0) now_visible.push_back(chunk[k]);
    }
    // A later chunk may lower a cell's best below what an earlier chunk was compared with:
    // the earlier flags stay conservative (visible against a larger best).
    for (uint32_t s : now_visible) update_bounds(s, job.tile);
    merge_into(evaluated_[job.tile], job.fresh);
    merge_into(visible_[job.tile], now_visible);
    merge_into(job.kept, now_visible);
  }

  item::GvdGridJob make_job(size_t t, uint32_t site_first, uint32_t site_count, uint32_t item_first,
                            uint32_t dist_first) const {
    item::GvdGridJob j{};
    const std::array<int, 3> c = r_.coords(t);
    const std::array<int, 3> s = size_of(t);
    for (size_t i = 0; i < 3; ++i) {
      j.lo[i] = c[i] * r_.b;
      j.size[i] = s[i];
    }
    if (spec_.dimension == 2) j.lo[2] = 0;
    j.site_first = site_first;
    j.site_count = site_count;
    j.item_first = item_first;
    j.dist_first = dist_first;
    return j;
  }

  /// UpdateBounds of Algorithm 2: the site's Voronoi region reaches range t.
  void update_bounds(uint32_t s, size_t t) {
    RangeBounds& b = bounds_[s];
    const std::array<int, 3> c = r_.coords(t);
    if (b.empty()) {
      b.lo = {c[0], c[1], c[2]};
      b.hi = b.lo;
      return;
    }
    for (size_t i = 0; i < 3; ++i) {
      b.lo[i] = std::min(b.lo[i], c[i]);
      b.hi[i] = std::max(b.hi[i], c[i]);
    }
  }

  static void merge_into(Sites& into, const Sites& add) {
    if (add.empty()) return;
    Sites out;
    out.reserve(into.size() + add.size());
    std::set_union(into.begin(), into.end(), add.begin(), add.end(), std::back_inserter(out));
    into.swap(out);
  }

  /// Every site at every cell, ranges batched and sites chunked to the scratch buffer.
  void brute_force() {
    track_ = false;  // nothing is culled: no sets to keep
    const uint32_t sites = g_.object_count();
    std::vector<Pending> pending;
    for (size_t t = 0; t < r_.count(); ++t) {
      Pending job;
      job.tile = t;
      pending.push_back(std::move(job));
    }
    // Chunks of sites over all ranges: a batch takes as many ranges as fit.
    const uint32_t chunk = std::max<uint32_t>(
        1, static_cast<uint32_t>(GridEvaluator::max_pairs() / (uint64_t{1} << 12)));
    for (uint32_t first = 0; first < sites; first += chunk) {
      const uint32_t count = std::min(chunk, sites - first);
      for (Pending& job : pending) {
        job.fresh.resize(count);
        std::iota(job.fresh.begin(), job.fresh.end(), first);
        job.kept.clear();
      }
      evaluate(pending);
      if (report_) report_(static_cast<double>(first + count) / sites);
    }
  }

  const GridGeometry& g_;
  const GridSpec& spec_;
  const Ranges& r_;
  GridEvaluator& eval_;
  GridStats& stats_;
  std::vector<RangeBounds>& bounds_;
  const std::atomic<bool>* cancel_;
  std::function<void(double)> report_;
  std::vector<Sites> evaluated_, visible_;  // per range, sorted
  bool track_ = true;
};

/// A crossing of a grid row by a closed object's boundary.
struct Crossing {
  double x;
  ObjectId object;
};

}  // namespace

void sign_grid_distances(const Scene& scene, const GridGeometry& g, const GridSpec& spec,
                         const std::vector<uint8_t>& closed, DistanceGrid& out, int threads,
                         const std::atomic<bool>* cancel) {
  const int dim = spec.dimension;
  const size_t rows = static_cast<size_t>(spec.n[1]) * static_cast<size_t>(spec.n[2]);
  std::vector<std::vector<Crossing>> crossings(rows);
  const uint32_t sites = static_cast<uint32_t>(g.object_of.size());
  for (uint32_t s = 0; s < sites; ++s) {
    if (s % kCancelSimplices == 0) throw_if_cancelled(cancel, "the grid's signs");
    const ObjectId o = g.object_of[s];
    if (!closed[o]) continue;
    const Vec3 a = g.points[g.simplices[3 * s]];
    const Vec3 b = g.points[g.simplices[3 * s + 1]];
    const Vec3 c = g.points[g.simplices[3 * s + 2]];
    // Rows whose centre line may cross the simplex.
    auto row_range = [&](int axis, double lo, double hi, int& first, int& last) {
      const double f = (lo - spec.origin[axis]) / spec.h - 0.5;
      const double l = (hi - spec.origin[axis]) / spec.h - 0.5;
      first = std::max(0, static_cast<int>(std::ceil(f)) - 1);
      last = std::min(spec.n[static_cast<size_t>(axis)] - 1, static_cast<int>(std::floor(l)) + 1);
    };
    if (dim == 2) {
      if (a.y == b.y) continue;  // parallel to the rows: the perturbed row misses it
      int j0, j1;
      row_range(1, std::min(a.y, b.y), std::max(a.y, b.y), j0, j1);
      for (int j = j0; j <= j1; ++j) {
        double x;
        if (row_crosses_segment(a, b, spec.origin.y + (j + 0.5) * spec.h, x))
          crossings[static_cast<size_t>(j)].push_back({x, o});
      }
      continue;
    }
    int j0, j1, k0, k1;
    row_range(1, std::min({a.y, b.y, c.y}), std::max({a.y, b.y, c.y}), j0, j1);
    row_range(2, std::min({a.z, b.z, c.z}), std::max({a.z, b.z, c.z}), k0, k1);
    if ((b.y - a.y) * (c.z - a.z) == (b.z - a.z) * (c.y - a.y)) continue;  // edge-on
    for (int k = k0; k <= k1; ++k) {
      const double z = spec.origin.z + (k + 0.5) * spec.h;
      for (int j = j0; j <= j1; ++j) {
        double x;
        if (row_crosses_triangle(a, b, c, spec.origin.y + (j + 0.5) * spec.h, z, x))
          crossings[static_cast<size_t>(k) * spec.n[1] + static_cast<size_t>(j)].push_back({x, o});
      }
    }
  }
  parallel_for(
      rows, resolve_threads(threads),
      [&](size_t b, size_t e, int) {
        std::vector<uint8_t> parity(scene.objects.size(), 0);
        for (size_t row = b; row < e; ++row) {
          throw_if_cancelled(cancel, "the grid's signs");
          std::vector<Crossing>& cr = crossings[row];
          if (cr.empty()) continue;
          std::sort(cr.begin(), cr.end(),
                    [](const Crossing& l, const Crossing& r) { return l.x < r.x; });
          size_t next = 0;
          const size_t base = row * static_cast<size_t>(spec.n[0]);
          for (int i = 0; i < spec.n[0]; ++i) {
            const double x = spec.origin.x + (i + 0.5) * spec.h;
            while (next < cr.size() && cr[next].x < x) parity[cr[next++].object] ^= 1;
            const int32_t l = out.label[base + static_cast<size_t>(i)];
            if (l >= 0 && parity[static_cast<size_t>(l)])
              out.distance[base + static_cast<size_t>(i)] =
                  -out.distance[base + static_cast<size_t>(i)];
          }
          for (const Crossing& c : cr) parity[c.object] = 0;
        }
      },
      1);
}

void sign_closed_objects(const Scene& scene, const GridGeometry& geometry, const GridSpec& spec,
                         bool signed_distance, int threads, DistanceGrid& out,
                         const std::atomic<bool>* cancel) {
  out.closed.assign(scene.objects.size(), 0);
  if (!signed_distance) return;
  for (size_t o = 0; o < scene.objects.size(); ++o)
    out.closed[o] = is_closed_object(scene.objects[o], scene.dimension);
  out.stats.closed_objects =
      static_cast<uint32_t>(std::count(out.closed.begin(), out.closed.end(), uint8_t{1}));
  if (out.stats.closed_objects == 0) return;
  const Stopwatch sw;
  sign_grid_distances(scene, geometry, spec, out.closed, out, threads, cancel);
  out.stats.sign_seconds = sw.seconds();
}

DistanceGrid compute_grid(const Scene& scene, const GridOptions& options) {
  const Stopwatch total;
  DistanceGrid out;
  out.spec = make_grid_spec(scene, options);
  out.metric = options.metric;
  out.units = scene.units;
  const GridSpec& spec = out.spec;
  const std::atomic<bool>* cancel = options.cancel;
  // The evaluation is ~all of the work; signing the rest.
  constexpr double kEvaluateShare = 0.95;
  auto report = [&](double f) {
    if (options.progress) options.progress(f);
  };
  if (options.range_cells < 0) {
    throw Error(ErrorCode::kInvalidArgument, "range_cells must be positive (0 = default)");
  }
  throw_if_cancelled(cancel, "the grid");
  const GridGeometry g = make_grid_geometry(scene, cancel);
  GVD_CHECK(g.object_of.size() < GVD_NO_SIMPLEX, "too many simplices for 32-bit indices");
  throw_if_cancelled(cancel, "the grid");
  report(0);
  Ranges r;
  r.b = options.range_cells > 0 ? options.range_cells : (spec.dimension == 2 ? 8 : 4);
  for (size_t i = 0; i < static_cast<size_t>(spec.dimension); ++i)
    r.k[i] = (spec.n[i] + r.b - 1) / r.b;
  out.range_cells = r.b;

  const item::GvdGridSpec item_spec = make_item_spec(spec, options.metric);
  std::unique_ptr<GridEvaluator> eval;
  if (options.compute) eval = options.compute->grid_evaluator(g, spec, options.metric);
  out.stats.backend = eval ? options.compute->name() : "cpu";
  if (!eval) eval = make_cpu_grid_evaluator(g, item_spec, options.threads);
  eval->set_cancel(cancel);

  out.stats.sites = g.object_count();
  out.stats.ranges = r.count();
  out.stats.brute_force_pairs = spec.cell_count() * g.object_count();
  out.site_bounds.assign(g.object_count(), RangeBounds{});
  Culler culler(g, spec, r, *eval, out.stats, out.site_bounds, cancel,
                [&](double f) { report(kEvaluateShare * f); });
  culler.run(options.cull);
  throw_if_cancelled(cancel, "the grid");

  const size_t cells = spec.cell_count();
  std::vector<double> key(cells);
  std::vector<uint32_t> site(cells);
  eval->read_best(key, site);
  eval.reset();
  out.distance.resize(cells);
  out.label.resize(cells);
  parallel_for(cells, resolve_threads(options.threads), [&](size_t b, size_t e, int) {
    for (size_t c = b; c < e; ++c) {
      const bool found = site[c] != GVD_NO_SIMPLEX;
      out.label[c] = found ? static_cast<int32_t>(site[c]) : -1;
      out.distance[c] = found ? item::gvd_key_distance(key[c], item_spec.metric)
                              : std::numeric_limits<double>::infinity();
    }
  });

  report(kEvaluateShare);
  sign_closed_objects(scene, g, spec, options.signed_distance, options.threads, out, cancel);
  report(1);
  out.stats.seconds = total.seconds();
  return out;
}

}  // namespace gvd::grid

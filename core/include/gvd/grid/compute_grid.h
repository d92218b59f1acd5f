#pragma once

// The uniform-grid discrete GVD of Sud, Govindaraju and Manocha 2006 ("CuRV", "Interactive
// Computation of Discrete Generalized Voronoi Diagrams using Range Culling"; docs/ALGORITHM.md):
// for every cell of a uniform grid, the nearest object and the distance to it (signed for closed
// objects), computed with the paper's range culling so that each range evaluates only the sites
// whose Voronoi region may reach it. docs/ALGORITHM.md ("Uniform grid (CuRV)") says what is
// guaranteed.

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gvd/geometry/vec.h"
#include "gvd/scene/scene.h"

namespace gvd::compute {
class ComputeBackend;
}

namespace gvd::grid {

/// The distance of the grid: Euclidean, Manhattan or Chebyshev. All three are metrics, so
/// every site's Voronoi region is connected (paper §3.3), which the culling relies on.
enum class GridMetric { kL2, kL1, kLinf };

/// "l2" / "l1" / "linf"; throws gvd::Error{kInvalidArgument} for anything else.
GridMetric parse_grid_metric(const std::string& name);
const char* grid_metric_name(GridMetric metric);

/// A uniform grid of cubic cells: cell (i, j, k) is the box origin + [i, i+1] x [j, j+1] x
/// [k, k+1] times h (user units) and is sampled at its centre. 2D grids have n[2] = 1 and
/// z = 0. Cells are stored x fastest: index = (k * n[1] + j) * n[0] + i.
struct GridSpec {
  int dimension = 3;
  std::array<int, 3> n = {1, 1, 1};
  Vec3 origin;     ///< the corner of cell (0, 0, 0)
  double h = 1.0;  ///< edge length of a cell
  uint64_t cell_count() const {
    return static_cast<uint64_t>(n[0]) * static_cast<uint64_t>(n[1]) * static_cast<uint64_t>(n[2]);
  }
  Vec3 centre(int i, int j, int k) const;
};

/// Options of `compute_grid`.
struct GridOptions {
  /// Cells along the longest side of the domain (>= 1); the other sides get as many cells of
  /// the same size as cover them (the grid is centred on the domain).
  int resolution = 256;
  GridMetric metric = GridMetric::kL2;
  /// Domain (user units); it must hold every vertex (the culling's connectivity argument
  /// needs all sites inside, paper §3.1). Default: the bounding box of all vertices padded
  /// by `padding` of its longest side on every side.
  std::optional<Box> box;
  double padding = 0.05;
  /// Cells along each side of a range (the paper's tile; 3D: a cube). 0 = 8 in 2D, 4 in 3D
  /// (the fastest on the bench scenes: smaller ranges cull more, but cost more bookkeeping).
  int range_cells = 0;
  /// false = no culling: every site is evaluated at every cell (the brute-force baseline).
  bool cull = true;
  /// Negative distances inside closed objects (a closed polygon / watertight mesh).
  bool signed_distance = true;
  /// Refused before any work: more cells than this (gvd::Error{kLimitExceeded}). At most
  /// 2^32 - 1 (cells are numbered by 32-bit integers on the device).
  uint64_t max_cells = uint64_t{1} << 27;
  int threads = 0;  ///< 0 = all cores (CPU twin)
  /// Where the per-range evaluation runs (the OpenCL backend, or null for the CPU twin).
  std::shared_ptr<compute::ComputeBackend> compute;
  /// Set to true by another thread to stop with gvd::Error{kCancelled}. Read between the
  /// sweeps' wavefronts and batches, every few thousand sites while binning and signing, and
  /// inside a batch: every row of cells on the CPU twin, every slice of a kernel launch
  /// (slices of ~0.1 s) on OpenCL. So a set flag stops the computation within a fraction of
  /// a second whatever the grid's size.
  const std::atomic<bool>* cancel = nullptr;
  /// Called on the calling thread with the fraction done (0 .. 1, non-decreasing) after each
  /// wavefront of ranges and while signing; an exception it throws stops the computation.
  std::function<void(double)> progress;
};

/// What the computation did (for logs, the bench and the culling ratio).
struct GridStats {
  uint64_t pairs_evaluated = 0;    ///< site-cell distance evaluations
  uint64_t brute_force_pairs = 0;  ///< sites x cells
  uint64_t ranges = 0;
  uint64_t batches = 0;  ///< launches of the per-range evaluation
  uint32_t sites = 0;    ///< simplices (the paper's primitive sites)
  uint32_t closed_objects = 0;
  /// sample_result_grid: cells whose search the result's octree bounded (the closest points of
  /// the leaf holding the cell centre); 0 for compute_grid.
  uint64_t octree_bounded = 0;
  double seconds = 0;           ///< whole computation
  double sign_seconds = 0;      ///< the inside test
  double evaluate_seconds = 0;  ///< in the per-range evaluation (kernel or CPU twin)
  double bin_seconds = 0;       ///< binning the sites into ranges (the swept sets S(T))
  std::string backend;          ///< "cpu" or "opencl (<platform> / <device>)"
  double culled_fraction() const {
    return brute_force_pairs == 0 ? 0.0 : static_cast<double>(pairs_evaluated) / brute_force_pairs;
  }
};

/// A box of ranges (inclusive range indices), or empty.
struct RangeBounds {
  std::array<int32_t, 3> lo = {1, 1, 1};
  std::array<int32_t, 3> hi = {0, 0, 0};
  bool empty() const { return lo[0] > hi[0]; }
};

/// The grid's answer.
struct DistanceGrid {
  GridSpec spec;
  GridMetric metric = GridMetric::kL2;
  /// Per cell: the distance (metric, user units) from its centre to the nearest object;
  /// negative when the centre lies inside that object and the object is closed.
  std::vector<double> distance;
  /// Per cell: index of the nearest object (exact ties: the lower index); -1 for none.
  std::vector<int32_t> label;
  /// Per object: whether it is closed (its distances are signed).
  std::vector<uint8_t> closed;
  /// Per object: the conservative bound V^(p) of §5 in ranges — the box of ranges in which it
  /// was found visible; its Voronoi region lies in it (empty when culling was off).
  std::vector<RangeBounds> site_bounds;
  int range_cells = 0;
  /// The scene's length unit ("mm", ...; Scene::units): the distances, the origin and the
  /// cell size are in it. Empty: none declared. A label only (NRRD's "space units").
  std::string units;
  GridStats stats;
};

/// The grid a scene and options give (validated: resolution >= 1, the box holds every
/// vertex, the cell count within options.max_cells; gvd::Error{kInvalidArgument} /
/// {kLimitExceeded} otherwise). Cheap: use it to check limits before work starts.
GridSpec make_grid_spec(const scene::Scene& scene, const GridOptions& options = {});

/// The discrete GVD of paper §4-5 on make_grid_spec's grid: the sites (the scene's objects,
/// each searched through a BVH of its simplices) are binned into ranges; 2^D sweeps (3D: slice
/// after slice) carry each range's potentially intersecting swept set from the preceding ranges
/// along every axis (Theorems 1-2), evaluate it at every cell centre of the range (the per-range
/// kernel, on options.compute or the CPU twin) and keep the sites visible there, conservatively
/// (§5.3: within one cell diagonal of the nearest distance). A site evaluated in a range by
/// one sweep is not evaluated there again by the next. Labels are the exact nearest object at
/// each cell centre (no cell is lost to culling: docs/ALGORITHM.md), distances exact in
/// double. Signs by ray parity along grid rows (symbolic perturbation for rows through
/// vertices and edges). Cost O(cells x average PIS + sites); memory O(cells).
DistanceGrid compute_grid(const scene::Scene& scene, const GridOptions& options = {});

}  // namespace gvd::grid

#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gvd/compute/compute_backend.h"
#include "gvd/result/gvd_result.h"
#include "gvd/scene/scene.h"

namespace gvd {

/// Options of the whole computation.
struct PipelineOptions {
  DomainOptions domain;
  int max_depth = 0;  ///< 0 = default (2D 26, 3D 21)
  /// Depth at which refinement between touching/intersecting objects stops (0 = default:
  /// 14 in 2D, 8 in 3D).
  int contact_depth = 0;
  uint64_t max_leaves = 12'000'000;  ///< limit on octree leaves (~1 KB peak memory each)
  int max_refine_rounds = 48;        ///< refinement rounds for the separation guarantee
  /// Rounds that also split ambiguous cells (§5); < 0 picks the default: all rounds in 2D
  /// (junctions are points, cheap to resolve), 3 in 3D (junctions are lines).
  int ambiguity_rounds = -1;
  /// Rounds that also split cells hiding an object's thin region (RefineOptions); < 0 picks
  /// the default: all rounds in 2D (the dual graph is then exact), 4 in 3D.
  int unseen_rounds = -1;
  /// Levels below the §3 octree to which ambiguity is resolved; < 0 picks the default: down
  /// to max_depth in 2D, 2 in 3D.
  int ambiguity_levels = -1;
  int threads = 0;  ///< 0 = all cores
  /// "cpu" (the CPU twins) or "opencl"; "opencl" needs `compute` (core has no OpenCL: the
  /// caller makes one with gvd::kernels::choose_backend).
  std::string backend = "cpu";
  /// The data-parallel backend (closest-point initialisation); null = the CPU twins.
  std::shared_ptr<ComputeBackend> compute;
  /// How the first octree is built: "levels" (build_octree, level-synchronous; the faster on
  /// 2 cores) or "data-parallel" (build_octree_data_parallel: the draft's Karras / conflict-
  /// cell construction, on the backend's kernels when it has them). Same leaves either way.
  std::string octree_build = "levels";
  /// Closest points of the vertices of empty leaves: "exact" (every vertex by the BVH or the
  /// backend's kernel; the default) or "wavefront" (the paper's Algorithm 1). DistanceMethod.
  std::string distance = "exact";
  /// Where different objects come close: "certified" (the default: a cell is not split where
  /// exact distances certify that two objects' bisector in it is one plane, or a curve swept
  /// along a straight rim parallel to an axis, so cost follows the geometry, not 1/gap;
  /// PairCertifier) or "paper" (the paper's rule of §3 alone: cells shrink to the gap over
  /// the whole contact).
  std::string refine = "certified";
  /// "compact" (default: flat parts of the GVD merged into large pieces, compact_gvd.h) or
  /// "full" (one piece per octree leaf it crosses, as surfaced).
  std::string resolution = "compact";
  /// With "compact": curved parts are merged too while they stay within this fraction of the
  /// local clearance of the surfaced GVD (compact_gvd.h); 0 = flat parts only.
  double curved_tolerance = 0;
  /// Why the CPU runs when OpenCL was wanted ("no OpenCL platform ..."); appended to
  /// ResultStats::backend so that `gvd info` says so.
  std::string backend_note;
  ProgressFn progress;  ///< optional
  const std::atomic<bool>* cancel = nullptr;
};

/// The whole pipeline (docs/ARCHITECTURE.md draws it):
/// Scene -> make_domain/make_unit_geometry -> build_octree -> Octree -> compute_distances ->
/// DistanceField -> (find_cells_to_refine -> refine_octree -> compute_distances)* ->
/// extract_gvd -> Gvd -> build_dual_graph -> DualGraph. Adds warnings for objects that touch
/// (leaves at the depth limit holding several objects) and for ambiguity left at the limit.
GvdResult compute_gvd(Scene scene, const PipelineOptions& options = {});

}  // namespace gvd

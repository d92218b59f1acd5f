#pragma once

// The whole computation: PipelineOptions (pipeline_options makes them from the parameters) and
// compute_gvd, which takes a scene through the octree build, the distance transform, the
// refinement rounds, surfacing and the dual graph to a GvdResult, with warnings for touching
// objects and for ambiguity left at the depth limit. A set PipelineOptions::cancel stops it
// with gvd::Error{kCancelled}.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gvd/compute/compute_backend.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/octree/build_octree.h"
#include "gvd/pipeline/parameters.h"
#include "gvd/result/gvd_result.h"
#include "gvd/scene/scene.h"

namespace gvd::pipeline {

/// Options of the whole computation.
struct PipelineOptions {
  scene::DomainOptions domain;
  int max_depth = 0;  ///< 0 = default (2D 26, 3D 21)
  /// Depth at which refinement between touching/intersecting objects stops (0 = default:
  /// 14 in 2D, 8 in 3D).
  int contact_depth = 0;
  uint64_t max_leaves = 12'000'000;  ///< limit on octree leaves (up to ~1 KB peak memory each)
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
  /// kCpu (the CPU twins) or kOpenCl; kOpenCl needs `compute` (core has no OpenCL: the
  /// caller makes one with gvd::kernels::choose_backend, which resolves kAuto).
  BackendRequest backend = BackendRequest::kCpu;
  /// The data-parallel backend (closest-point initialisation); null = the CPU twins.
  std::shared_ptr<compute::ComputeBackend> compute;
  /// How the first octree is built: kLevels (build_octree, level-synchronous; the faster on
  /// 2 cores) or kDataParallel (build_octree_data_parallel: the draft's Karras / conflict-
  /// cell construction, on the backend's kernels when it has them). Same leaves either way.
  OctreeBuild octree_build = OctreeBuild::kLevels;
  /// Closest points of the vertices of empty leaves: kExact (every vertex by the BVH or the
  /// backend's kernel; the default) or kWavefront (the paper's Algorithm 1).
  distance::DistanceMethod distance = distance::DistanceMethod::kExact;
  /// Where different objects come close: kCertified (the default: a cell is not split where
  /// exact distances certify that two objects' bisector in it is one plane, or a curve swept
  /// along a straight rim parallel to an axis, so cost follows the geometry, not 1/gap;
  /// PairCertifier) or kPaper (the paper's rule of §3 alone: cells shrink to the gap over
  /// the whole contact).
  RefineRule refine = RefineRule::kCertified;
  /// With kCertified, 3D: also certify junction cells, where three or more objects meet along
  /// a straight line along an axis (packed boxes' corners, a part in the corner of two others),
  /// surfaced as their faces' plane GVD swept along it (junction_face.h; docs/ALGORITHM.md,
  /// "Junction lines"). On by default; off, such lines cost length / gap.
  bool junctions = true;
  /// kCompact (default: flat parts of the GVD merged into large pieces, compact_gvd.h) or
  /// kFull (one piece per octree leaf it crosses, as surfaced).
  GvdResolution resolution = GvdResolution::kCompact;
  /// With kCompact: curved parts are merged too while they stay within this fraction of the
  /// local clearance of the surfaced GVD (compact_gvd.h); 0 = flat parts only.
  double curved_tolerance = 0;
  /// Why the CPU runs when OpenCL was wanted ("no OpenCL platform ..."); appended to
  /// ResultStats::backend so that `gvd info` says so.
  std::string backend_note;
  octree::ProgressFn progress;  ///< optional
  const std::atomic<bool>* cancel = nullptr;
};

/// The engine options of `params` (parameters.h): the octree and refinement parameters, the
/// domain box, threads, leaf limit, frame and the choices. `backend`, `compute` and the
/// progress are the caller's (params.backend is a request that kernels::choose_backend
/// resolves). Call params.check(dimension, ...) first.
PipelineOptions pipeline_options(const PipelineParams& params);

/// The whole pipeline (docs/ARCHITECTURE.md draws it):
/// Scene -> make_domain/make_unit_geometry -> build_octree -> Octree -> compute_distances ->
/// DistanceField -> (find_cells_to_refine -> refine_octree -> compute_distances)* ->
/// extract_gvd -> Gvd -> build_dual_graph -> DualGraph. Adds warnings for objects that touch
/// (leaves at the depth limit holding several objects) and for ambiguity left at the limit.
result::GvdResult compute_gvd(scene::Scene scene, const PipelineOptions& options = {});

}  // namespace gvd::pipeline

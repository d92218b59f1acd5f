#pragma once

// A finished computation as one value: GvdResult holds the scene, domain, unit geometry, octree,
// distance field, GVD and dual graph, and ResultStats the figures `gvd info` prints (stage times,
// sizes, memory). kAlgorithmVersion is part of job ids and of the saved result.

#include <cstdint>
#include <string>
#include <vector>

#include "gvd/distance/distance_field.h"
#include "gvd/graph/dual_graph.h"
#include "gvd/octree/octree.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd::result {

/// Version of the algorithm; part of job ids and of the saved result.
inline constexpr uint32_t kAlgorithmVersion = 5;

/// Wall time, size and memory of one stage.
struct StageStats {
  std::string name;
  double seconds = 0;
  uint64_t bytes = 0;  ///< size of the stage's output data
  uint64_t items = 0;  ///< leaves, vertices, simplices... (stage specific)
};

/// Figures of a finished computation (what `gvd info` prints).
struct ResultStats {
  std::vector<StageStats> stages;
  std::string backend = "cpu";  ///< "cpu", "cpu (<why not OpenCL>)" or "opencl (<device>)"
  int threads = 1;
  int max_depth = 0;
  int depth = 0;
  uint64_t leaves = 0;
  uint64_t vertices = 0;
  uint64_t octree_bytes = 0;    ///< leaves (code, level, object) + vertex keys
  double bytes_per_leaf = 0;    ///< octree_bytes / leaves
  uint64_t distance_bytes = 0;  ///< labels + closest points
  uint64_t gvd_simplices = 0;   ///< per side, i.e. each interface simplex counted twice
  uint64_t graph_edges = 0;
  int refine_rounds = 0;
  uint64_t ambiguous_at_limit = 0;
  uint64_t unseen_left = 0;  ///< cells still hiding a thin region (see PipelineOptions)
  uint64_t touching_leaves = 0;
  uint64_t certified_leaves = 0;  ///< leaves inside certified pair cells (refine "certified")
  double total_seconds = 0;
  /// The process's peak resident memory when the job finished (common/peak_memory.h; 0:
  /// unknown). Process-wide, so in a server it can include earlier jobs; per leaf it is what
  /// `gvd info` and the benchmark report as peak bytes per leaf.
  uint64_t peak_rss_bytes = 0;
  /// The process's resident memory when compute_gvd began (the OpenCL runtime, the scene as
  /// read; 0: unknown). In a process that ran nothing bigger before, peak_rss_bytes minus this
  /// is at least what the computation itself added at its peak.
  uint64_t start_rss_bytes = 0;
  /// The id of the server job that computed this result (empty when the CLI or the library
  /// did). A stored result is served as a job only when it names that job (a file of another
  /// job copied or restored under its name says so).
  std::string job;
};

/// A finished GVD: everything later commands and the server need.
struct GvdResult {
  scene::Scene scene;
  scene::Domain domain;
  scene::UnitGeometry geometry;
  octree::Octree octree;  ///< without the leaf -> simplex incidence after loading from disk
  distance::DistanceField field;
  surface::Gvd gvd;
  graph::DualGraph graph;
  ResultStats stats;
};

}  // namespace gvd::result

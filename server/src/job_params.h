#pragma once

#include <map>
#include <string>
#include <vector>

#include "gvd/grid/compute_grid.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/scene.h"
#include "server_options.h"

namespace gvd::server {

/// The compute parameters a job may carry (query string, a "params" member of the scene JSON,
/// or a "params" part of a multipart upload). Part of the job id in normalized form.
struct JobParams {
  int max_depth = 0;          ///< 0 = the engine's default
  int contact_depth = 0;      ///< 0 = default
  int ambiguity_levels = -1;  ///< < 0 = default
  int ambiguity_rounds = -1;
  int unseen_rounds = -1;
  std::vector<double> domain;          ///< empty, or x0,y0[,z0],x1,y1[,z1]
  std::string frame = "auto";          ///< DomainOptions::frame: auto or world
  std::string refine = "certified";    ///< PipelineOptions::refine: certified or paper
  std::string resolution = "compact";  ///< PipelineOptions::resolution: compact or full
  double curved_tolerance = 0;         ///< PipelineOptions::curved_tolerance, in [0, 1)

  /// "adaptive" (the octree pipeline, compute_gvd) or "grid" (the uniform-grid discrete GVD
  /// of compute_grid and its dual graph, as `gvd compute --mode grid`).
  std::string mode = "adaptive";
  /// mode=grid: cells along the longest side of the domain (GridOptions::resolution). Given
  /// as `resolution=N`: with mode=grid the name means the grid, else compact/full.
  int grid_resolution = 0;
  std::string metric = "l2";       ///< mode=grid: GridOptions::metric (l2, l1, linf)
  bool float64 = false;            ///< mode=grid: field.npy as float64 instead of float32
  bool unsigned_distance = false;  ///< mode=grid: no negative distances inside closed objects
  int range_cells = 0;             ///< mode=grid: GridOptions::range_cells (0 = default)
  /// The scene's length unit (canonical, gvd/scene/units.h); empty: the scene's own, if any.
  /// Not a compute parameter: submit sets it on the scene, over the scene's own "units",
  /// before the scene is normalized, so it reaches the job id through the scene; to_json
  /// leaves it out.
  std::string units;

  bool is_grid() const { return mode == "grid"; }

  /// Sets one parameter from its text form; gvd::Error{kInvalidArgument} for an unknown name
  /// or a bad value.
  void set(const std::string& name, const std::string& value);
  /// Checks against the scene's dimension and the server's caps (max_depth): gvd::Error
  /// kInvalidArgument / kLimitExceeded.
  void check(int dimension, const ServerOptions& server) const;

  /// Normalized JSON (keys sorted, defaults written out): the text hashed into the job id.
  std::string to_json() const;
  static JobParams from_json(const std::string& text);

  /// The engine options for this job under the server's limits.
  PipelineOptions pipeline_options(const ServerOptions& server) const;
  /// mode=grid: the grid options under the server's limits (max_cells = --max-grid-cells,
  /// the job threads and backend).
  GridOptions grid_options(const ServerOptions& server) const;
};

/// Query-string names that are compute parameters.
bool is_job_param(const std::string& name);

}  // namespace gvd::server

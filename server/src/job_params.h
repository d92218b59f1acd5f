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
/// or a "params" part of a multipart upload): the job parameters of the core's table
/// (gvd/pipeline/parameters.h), parsed and checked by it. Part of the job id in normalized
/// form. `units` is not a compute parameter: submit sets it on the scene, over the scene's own
/// "units", before the scene is normalized, so it reaches the job id through the scene;
/// to_json leaves it out.
struct JobParams : pipeline::PipelineParams {
  /// Sets one parameter from its text form; gvd::Error{kInvalidArgument} for an unknown name
  /// or a bad value (`parameter "max_depth" must be ...`).
  void set(const std::string& name, const std::string& value);
  /// Checks against the scene's dimension and the server's caps (max_depth): gvd::Error
  /// kInvalidArgument / kLimitExceeded.
  void check(int dimension, const ServerOptions& server) const;

  /// Normalized JSON (keys sorted, defaults written out): the text hashed into the job id.
  /// The job parameters of the job's mode; an adaptive job's text leaves out "mode" (it is
  /// what it was before mode=grid existed, and so are its ids).
  std::string to_json() const;
  static JobParams from_json(const std::string& text);

  /// The engine options for this job under the server's limits.
  pipeline::PipelineOptions pipeline_options(const ServerOptions& server) const;
  /// mode=grid: the grid options under the server's limits (max_cells = --max-grid-cells,
  /// the job threads and backend).
  grid::GridOptions grid_options(const ServerOptions& server) const;
};

/// Query-string names that are compute parameters.
bool is_job_param(const std::string& name);

}  // namespace gvd::server

#pragma once

// What a worker computes for a job, whichever queue runs it (JobManager, RedisJobQueue): the
// adaptive pipeline (compute_gvd) or, with mode=grid, the uniform-grid discrete GVD
// (compute_grid + grid_dual_graph, as `gvd compute --mode grid`).

#include <atomic>
#include <memory>
#include <string>

#include "gvd/octree/build_octree.h"
#include "gvd/pipeline/pipeline.h"
#include "job_params.h"
#include "server_options.h"

namespace gvd::server {

/// Computes a job. mode=adaptive: compute_gvd's result. mode=grid: a result that holds the
/// scene, its domain, the grid's dual graph and the stage timings (stages "grid" and
/// "graph"), with no octree, distance field or GVD surface (one empty root leaf, so that the
/// result file reads back); the grid itself is written first as `<results_dir>/<id>.field.npy`
/// (distance: float32, or float64 with the job's float64) and `<id>.labels.npy` (int32), so a
/// result file in the store means its grid files are complete. `progress` gets the stages
/// "scene", "grid" and "graph", each with fractions as it advances. Throws gvd::Error
/// (kCancelled when `cancel` is set: every stage reads it at bounded intervals, the grid's
/// too, so DELETE, --job-seconds and the memory watchdog stop a job within about a second).
std::shared_ptr<const result::GvdResult> compute_job(scene::Scene scene, const JobParams& params,
                                                     const ServerOptions& server,
                                                     const std::atomic<bool>* cancel,
                                                     const octree::ProgressFn& progress,
                                                     const std::string& results_dir,
                                                     const std::string& id);

/// Whether `result` is a grid job's (it has a "grid" stage; adaptive results never do).
bool is_grid_result(const result::GvdResult& result);

/// The files of a grid job's grid beside its result file (empty names for none).
std::string grid_field_path(const std::string& results_dir, const std::string& id);
std::string grid_labels_path(const std::string& results_dir, const std::string& id);

/// Throws ProblemError{kAdaptiveOnly} naming `what` when `result` is a grid job's: `what`
/// needs the adaptive result (octree, distance field, GVD surface).
void require_adaptive(const result::GvdResult& result, const std::string& id,
                      const std::string& what);

}  // namespace gvd::server

#pragma once

#include <cstdint>

#include "job_params.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace gvd::server {

class JobQueue;

/// The query endpoints on a finished job (neighbours, nearest, paths, exploded view,
/// clearance report, sampled grids): parse the request, ask the job's GvdIndex (or
/// sample_result_grid), write its answer. Throw ProblemError / gvd::Error for the catch
/// boundary of the HTTP layer.
class QueryHandlers {
 public:
  /// `max_grid_cells`: the cell limit of grid(); `grid_threads`: its threads (0 = all cores).
  QueryHandlers(JobQueue& jobs, uint64_t max_grid_cells, uint64_t max_batch_points,
                int grid_threads)
      : jobs_(jobs),
        max_grid_cells_(max_grid_cells),
        max_batch_points_(max_batch_points),
        grid_threads_(grid_threads) {}
  void neighbors(const httplib::Request& req, httplib::Response& res);
  void nearest(const httplib::Request& req, httplib::Response& res);
  void nearest_batch(const httplib::Request& req, httplib::Response& res);
  void paths(const httplib::Request& req, httplib::Response& res);
  void explode(const httplib::Request& req, httplib::Response& res);
  void tight(const httplib::Request& req, httplib::Response& res);
  void contacts(const httplib::Request& req, httplib::Response& res);
  /// GET .../field.npy (`labels` false: distances) or .../labels.npy: the job's result sampled
  /// on a uniform grid (sample_result_grid), as a numpy .npy file.
  /// A grid job's (mode=grid): its own grid, the files computed with it, no parameters.
  void grid(const httplib::Request& req, httplib::Response& res, bool labels);

 private:
  /// grid() of a grid job: the job's field.npy / labels.npy from the store.
  void grid_job_file(const httplib::Request& req, httplib::Response& res, const JobParams& params,
                     bool labels);

  JobQueue& jobs_;
  uint64_t max_grid_cells_;
  uint64_t max_batch_points_;  ///< points of one batch nearest query
  int grid_threads_;
};

}  // namespace gvd::server

#include "job_compute.h"

#include <algorithm>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/peak_memory.h"
#include "gvd/common/stopwatch.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/grid/grid_graph.h"
#include "gvd/io/write_grid.h"
#include "gvd/io/write_outputs.h"
#include "gvd/octree/build_octree.h"
#include "problem.h"

namespace gvd::server {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::grid;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

void check_cancel(const std::atomic<bool>* cancel) {
  if (cancel != nullptr && cancel->load()) throw Error(ErrorCode::kCancelled, "cancelled");
}

std::shared_ptr<const GvdResult> compute_grid_job(Scene scene, const JobParams& params,
                                                  const ServerOptions& server,
                                                  const std::atomic<bool>* cancel,
                                                  const ProgressFn& progress,
                                                  const std::string& results_dir,
                                                  const std::string& id) {
  const auto report = [&](const char* stage, double fraction) {
    if (progress) progress(stage, fraction);
  };
  Stopwatch total;
  report("scene", 1);
  GridOptions options = params.grid_options(server);
  (void)make_grid_spec(scene, options);  // the limits, before any memory is taken
  check_cancel(cancel);
  report("grid", 0);
  options.cancel = cancel;
  options.progress = [&](double f) { report("grid", f); };
  const DistanceGrid grid = compute_grid(scene, options);
  report("grid", 1);
  check_cancel(cancel);
  report("graph", 0);
  Stopwatch graph_watch;
  GridGraphOptions graph_options;
  graph_options.threads = options.threads;
  graph_options.cancel = cancel;
  graph_options.progress = [&](double f) { report("graph", f); };
  DualGraph graph = grid_dual_graph(grid, scene, graph_options);
  const double graph_seconds = graph_watch.seconds();
  report("graph", 1);
  check_cancel(cancel);

  // The grid first (atomic writes): a result file in the store means its grid is there.
  const std::vector<uint8_t> field = grid_npy_bytes(grid, false, params.float64);
  write_file_atomic(grid_field_path(results_dir, id), field.data(), field.size());
  const std::vector<uint8_t> labels = grid_npy_bytes(grid, true, false);
  write_file_atomic(grid_labels_path(results_dir, id), labels.data(), labels.size());

  auto result = std::make_shared<GvdResult>();
  const int dim = scene.dimension;
  DomainOptions domain_options;
  domain_options.frame = DomainFrame::kWorld;  // the grid runs along the user's axes
  if (options.box) domain_options.box = *options.box;
  result->domain = make_domain(scene, domain_options);
  result->octree.dimension = dim;
  result->octree.code = {0};  // one empty root leaf: the result file needs a leaf
  result->octree.level = {0};
  result->octree.object = {kNoObject};
  result->field.vertices.dimension = dim;
  result->gvd.dimension = dim;
  result->graph = std::move(graph);
  ResultStats& s = result->stats;
  s.backend = grid.stats.backend;
  s.threads = resolve_threads(options.threads);
  s.graph_edges = result->graph.edges.size();
  s.stages.push_back({"grid", grid.stats.seconds,
                      grid.spec.cell_count() * (sizeof(double) + sizeof(int32_t)),
                      grid.spec.cell_count()});
  s.stages.push_back({"graph", graph_seconds, 0, result->graph.edges.size()});
  s.total_seconds = total.seconds();
  s.peak_rss_bytes = peak_rss_bytes();
  s.job = id;
  result->scene = std::move(scene);
  return result;
}

}  // namespace

std::shared_ptr<const GvdResult> compute_job(Scene scene, const JobParams& params,
                                             const ServerOptions& server,
                                             const std::atomic<bool>* cancel,
                                             const ProgressFn& progress,
                                             const std::string& results_dir,
                                             const std::string& id) {
  if (params.is_grid())
    return compute_grid_job(std::move(scene), params, server, cancel, progress, results_dir, id);
  PipelineOptions options = params.pipeline_options(server);
  options.cancel = cancel;
  options.progress = progress;
  auto result = std::make_shared<GvdResult>(compute_gvd(std::move(scene), options));
  result->stats.job = id;  // the stored file names its job (ResultCache checks it)
  return result;
}

bool is_grid_result(const GvdResult& result) {
  return std::any_of(result.stats.stages.begin(), result.stats.stages.end(),
                     [](const StageStats& s) { return s.name == "grid"; });
}

std::string grid_field_path(const std::string& results_dir, const std::string& id) {
  return results_dir + "/" + id + ".field.npy";
}

std::string grid_labels_path(const std::string& results_dir, const std::string& id) {
  return results_dir + "/" + id + ".labels.npy";
}

void require_adaptive(const GvdResult& result, const std::string& id, const std::string& what) {
  if (!is_grid_result(result)) return;
  throw ProblemError(ProblemKind::kAdaptiveOnly,
                     "job " + id + " is a grid job (mode=grid): " + what +
                         " needs the adaptive result (octree, distance field, GVD surface). A "
                         "grid job has graph, field.npy and labels.npy; submit the scene "
                         "without mode=grid for the rest");
}

}  // namespace gvd::server

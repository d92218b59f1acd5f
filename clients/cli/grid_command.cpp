// `gvd grid`: the uniform-grid discrete GVD (CuRV range culling, core/include/gvd/grid):
// distance (signed inside closed objects) and nearest object per cell, as .npy or NRRD; from a
// scene, or sampled exactly from a saved adaptive result (sample_result_grid.h).

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/stopwatch.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/grid/grid_graph.h"
#include "gvd/grid/sample_result_grid.h"
#include "gvd/io/result_file.h"
#include "gvd/io/write_grid.h"
#include "gvd/io/write_outputs.h"
#include "gvd/kernels/opencl_backend.h"
#include "gvd/pipeline/parameters.h"
#include "gvd/scene/load_scene.h"
#include "gvd/scene/units.h"

namespace gvd::cli {

using namespace gvd::scene;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::grid;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

/// The grid's parameters from the flags `surface` takes (kCliFlag: gvd compute --mode grid;
/// kGridFlag: gvd grid), through the parameter table: ranges, choices, defaults and errors
/// (UsageError naming the flag) are the table's.
PipelineParams grid_params(const Args& args, ParamSurface surface, const std::string& command) {
  if (!args.value("--resolution")) throw UsageError{command + " needs --resolution N"};
  PipelineParams params = params_from_flags(args, surface);
  params.mode = ComputeMode::kGrid;
  return params;
}

/// A bad output name fails before any work.
void check_grid_outputs(const std::optional<std::string>& output,
                        const std::optional<std::string>& labels) {
  for (const auto& p : {output, labels}) {
    if (p && !(p->ends_with(".npy") || p->ends_with(".nrrd") || p->ends_with(".nhdr")))
      throw UsageError{"grid outputs must end in .npy, .nrrd or .nhdr (got " + *p + ")"};
  }
}

void log_spec(const GridSpec& spec, GridMetric metric, const std::string& units) {
  std::fprintf(stderr,
               "gvd: grid %d x %d%s%s cells of %.6g%s (%llu cells), metric %s; computing...\n",
               spec.n[0], spec.n[1], spec.dimension == 3 ? " x " : "",
               spec.dimension == 3 ? std::to_string(spec.n[2]).c_str() : "", spec.h,
               units_suffix(units).c_str(), static_cast<unsigned long long>(spec.cell_count()),
               grid_metric_name(metric));
}

std::vector<std::string> write_outputs(const DistanceGrid& grid,
                                       const std::optional<std::string>& output,
                                       const std::optional<std::string>& labels, bool float64) {
  std::vector<std::string> written;
  if (output) {
    for (const std::string& f : write_grid_distance(grid, *output, float64)) written.push_back(f);
  }
  if (labels) {
    for (const std::string& f : write_grid_labels(grid, *labels)) written.push_back(f);
  }
  return written;
}

/// The grid options of `params` over `scene` (checked against its dimension), their limits
/// (cell count, box: checked before the backend starts or any memory is taken) and the
/// backend, logged unless `quiet`.
GridOptions prepare_grid(const PipelineParams& params, const Scene& scene, bool quiet) {
  check_params(params, scene.dimension);
  GridOptions options = grid_options(params);
  const GridSpec spec = make_grid_spec(scene, options);
  const kernels::BackendChoice choice =
      kernels::choose_backend(std::string(choice_name(params.backend)));
  options.compute = choice.compute;
  if (!quiet) {
    std::fprintf(stderr, "gvd: %zu objects, %llu simplices, %dD; %s; %d threads\n",
                 scene.objects.size(), static_cast<unsigned long long>(scene.simplex_count()),
                 scene.dimension, choice.log.c_str(), resolve_threads(options.threads));
    log_spec(spec, options.metric, scene.units);
  }
  return options;
}

/// `gvd grid RESULT.gvd`: the grid sampled from a saved adaptive result.
int grid_from_result(const Args& args, const PipelineParams& params, bool quiet,
                     const std::optional<std::string>& output,
                     const std::optional<std::string>& labels) {
  for (const ParamSpec& p : pipeline_parameters()) {
    if (p.on(kGridFlag) && !p.on(kResultGridFlag) && args.has(flag_name(p))) {
      throw UsageError{flag_name(p) +
                       " applies to scenes; a saved result is sampled through its own octree "
                       "on the CPU"};
    }
  }
  GvdResult result = load_result(args.positional[0]);
  apply_units(args, result.scene);  // --units labels a result saved without (or with others)
  check_params(params, result.scene.dimension);
  const ResultGridOptions options = result_grid_options(params);
  // The limits (cell count, box) before any work.
  const GridSpec spec = make_result_grid_spec(result, options);
  if (!quiet) {
    std::fprintf(stderr,
                 "gvd: result %s: %zu objects, %llu simplices, %dD, %llu octree leaves; sampled "
                 "exactly on %d threads\n",
                 args.positional[0].c_str(), result.scene.objects.size(),
                 static_cast<unsigned long long>(result.scene.simplex_count()),
                 result.scene.dimension,
                 static_cast<unsigned long long>(result.octree.leaf_count()),
                 resolve_threads(options.threads));
    log_spec(spec, options.metric, result.scene.units);
  }
  const DistanceGrid grid = sample_result_grid(result, options);
  const std::vector<std::string> written = write_outputs(grid, output, labels, params.float64);
  if (!quiet) {
    const GridStats& s = grid.stats;
    std::fprintf(stderr,
                 "gvd: grid done in %.3f s from the adaptive result: %llu of %llu cells bounded "
                 "by their octree leaf, %llu exact object distances (%.3f %% of brute force), "
                 "%u closed objects (signed)%s\n",
                 s.seconds, static_cast<unsigned long long>(s.octree_bounded),
                 static_cast<unsigned long long>(spec.cell_count()),
                 static_cast<unsigned long long>(s.pairs_evaluated), 100 * s.culled_fraction(),
                 s.closed_objects, options.signed_distance ? "" : ", --unsigned: not signed");
    for (const std::string& w : written) std::fprintf(stderr, "  wrote %s\n", w.c_str());
  }
  return kExitOk;
}

}  // namespace

int cmd_grid(int argc, char** argv) {
  // The flags: the outputs, and the table's parameters that gvd grid takes.
  std::vector<std::string> value_flags = {"-o", "--output", "--labels"};
  std::vector<std::string> boolean = {"-q", "--quiet"};
  for (const ParamSpec& p : pipeline_parameters()) {
    if (p.on(kGridFlag))
      (p.kind == ParamKind::kFlag ? boolean : value_flags).push_back(flag_name(p));
  }
  const Args args = parse_args(argc, argv, 2, value_flags, boolean);
  if (args.positional.empty()) throw UsageError{"grid needs a scene file or a saved result"};
  const bool quiet = args.has("-q") || args.has("--quiet");
  const auto output = args.value("-o") ? args.value("-o") : args.value("--output");
  const auto labels = args.value("--labels");
  if (!output && !labels) throw UsageError{"grid needs -o FIELD.npy and/or --labels LABELS.npy"};
  const PipelineParams params = grid_params(args, kGridFlag, "grid");
  check_grid_outputs(output, labels);

  if (args.positional.size() == 1 && is_result_file(args.positional[0]))
    return grid_from_result(args, params, quiet, output, labels);

  SceneLimits limits;
  limits.max_objects = params.max_objects;
  limits.max_simplices = params.max_simplices;
  Scene scene = load_scene(args.positional, limits);
  apply_units(args, scene);
  const GridOptions options = prepare_grid(params, scene, quiet);
  if (!quiet && scene.objects.size() == 1)
    std::fprintf(stderr, "gvd: one object: every cell's label is 0 (a distance field)\n");
  const DistanceGrid grid = compute_grid(scene, options);

  const std::vector<std::string> written = write_outputs(grid, output, labels, params.float64);
  if (!quiet) {
    const GridStats& s = grid.stats;
    std::fprintf(stderr,
                 "gvd: grid done in %.3f s on %s: %llu of %llu site-cell pairs evaluated "
                 "(%.3f %% of brute force), %llu ranges of %d cells, %u closed objects "
                 "(signed)%s\n",
                 s.seconds, s.backend.c_str(), static_cast<unsigned long long>(s.pairs_evaluated),
                 static_cast<unsigned long long>(s.brute_force_pairs), 100 * s.culled_fraction(),
                 static_cast<unsigned long long>(s.ranges), grid.range_cells, s.closed_objects,
                 options.signed_distance ? "" : ", --unsigned: not signed");
    for (const std::string& w : written) std::fprintf(stderr, "  wrote %s\n", w.c_str());
  }
  return kExitOk;
}

// The table's flags of the grid mode (but --resolution, which the adaptive mode has too).
std::vector<std::string> grid_flags(bool boolean) {
  std::vector<std::string> flags;
  for (const ParamSpec& p : pipeline_parameters()) {
    if (p.on(kCliFlag) && p.mode == ParamMode::kGrid && p.name != "resolution" &&
        (p.kind == ParamKind::kFlag) == boolean) {
      flags.push_back(flag_name(p));
    }
  }
  return flags;
}

const std::vector<std::string>& grid_mode_value_flags() {
  static const std::vector<std::string> flags = [] {
    std::vector<std::string> f = {"--labels"};
    for (const std::string& flag : grid_flags(false)) f.push_back(flag);
    return f;
  }();
  return flags;
}

const std::vector<std::string>& grid_mode_boolean_flags() {
  static const std::vector<std::string> flags = grid_flags(true);
  return flags;
}

int compute_grid_mode(const Args& args) {
  std::vector<std::string> adaptive_only = {"--json", "--save"};
  for (const ParamSpec& p : pipeline_parameters()) {
    if (p.on(kCliFlag) && p.mode == ParamMode::kAdaptive && p.name != "resolution")
      adaptive_only.push_back(flag_name(p));
  }
  for (const std::string& flag : adaptive_only) {
    if (args.has(flag)) {
      throw UsageError{flag +
                       " applies to the adaptive octree; --mode grid computes on a uniform grid "
                       "(see \"grid options\")"};
    }
  }
  const bool quiet = args.has("-q") || args.has("--quiet");
  const auto output = args.value("-o") ? args.value("-o") : args.value("--output");
  const auto labels = args.value("--labels");
  const auto graph_path = args.value("--graph");
  if (output && (output->ends_with(".glb") || output->ends_with(".gltf"))) {
    throw UsageError{
        "--mode grid writes the dual graph (--graph FILE.json), the distance per cell "
        "(-o FIELD.npy|.nrrd) and the labels (--labels LABELS.npy); the GVD as a "
        "surface (" +
        *output + ") comes from the adaptive mode"};
  }
  if (!output && !labels && !graph_path) {
    throw UsageError{
        "--mode grid needs an output: --graph FILE.json, -o FIELD.npy and/or --labels LABELS.npy"};
  }
  const PipelineParams params = grid_params(args, kCliFlag, "--mode grid");
  check_grid_outputs(output, labels);
  const Scene scene = load_compute_scene(args, args.positional);
  const GridOptions options = prepare_grid(params, scene, quiet);
  const DistanceGrid grid = compute_grid(scene, options);
  Stopwatch sw;
  GridGraphOptions graph_options;
  graph_options.threads = options.threads;
  const DualGraph graph = grid_dual_graph(grid, scene, graph_options);
  const double graph_seconds = sw.seconds();
  std::vector<std::string> written = write_outputs(grid, output, labels, params.float64);
  if (graph_path) {
    write_file_atomic(*graph_path, graph_to_json(graph, scene));
    written.push_back(*graph_path + " (dual graph)");
  }
  if (!quiet) {
    const GridStats& s = grid.stats;
    size_t touching = 0;
    for (const DualEdge& e : graph.edges) touching += e.touching;
    std::fprintf(stderr,
                 "gvd: grid done in %.3f s on %s (%.3f %% of the brute-force site-cell pairs); "
                 "dual graph in %.3f s: %zu neighbour pairs (%zu touching), areas from the cell "
                 "faces, gaps and clearances exact\n",
                 s.seconds, s.backend.c_str(), 100 * s.culled_fraction(), graph_seconds,
                 graph.edges.size(), touching);
    for (const std::string& w : written) std::fprintf(stderr, "  wrote %s\n", w.c_str());
  }
  return kExitOk;
}

}  // namespace gvd::cli

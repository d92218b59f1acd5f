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
namespace {

/// --domain for a scene or result of `dimension`.
std::optional<Box> domain_arg(const Args& args, int dimension) {
  const auto box = args.numbers("--domain");
  if (!box) return std::nullopt;
  const size_t d = static_cast<size_t>(dimension);
  if (box->size() != 2 * d) {
    throw UsageError{"--domain expects " + std::to_string(2 * d) + " numbers for a " +
                     std::to_string(d) + "D input (x0,y0[,z0],x1,y1[,z1])"};
  }
  Box b;
  for (size_t i = 0; i < d; ++i) {
    b.lo[static_cast<int>(i)] = (*box)[i];
    b.hi[static_cast<int>(i)] = (*box)[d + i];
  }
  if (d == 2) b.lo.z = b.hi.z = 0;
  return b;
}

/// The grid options of the command line (`command` names it in errors).
GridOptions grid_options(const Args& args, const std::string& command) {
  if (!args.value("--resolution")) throw UsageError{command + " needs --resolution N"};
  GridOptions options;
  options.resolution = args.int_value("--resolution", 0);
  if (options.resolution < 1) throw UsageError{"--resolution must be a positive cell count"};
  try {
    options.metric = parse_grid_metric(args.value("--metric").value_or("l2"));
  } catch (const Error& e) {
    throw UsageError{e.detail()};  // a bad flag value: exit 2, as for every other flag
  }
  options.threads = args.int_value("--threads", 0);
  if (options.threads < 0) throw UsageError{"--threads must be positive"};
  options.max_cells = args.u64_value("--max-cells", options.max_cells);
  options.range_cells = args.int_value("--range-cells", 0);
  if (options.range_cells < 0) throw UsageError{"--range-cells must be positive"};
  options.signed_distance = !args.has("--unsigned");
  return options;
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

/// The box (--domain), the limits (cell count, domain: checked before the backend starts or
/// any memory is taken) and the backend of a grid over `scene`, logged unless `quiet`.
void prepare_grid(const Args& args, const Scene& scene, GridOptions& options, bool quiet) {
  options.box = domain_arg(args, scene.dimension);
  const GridSpec spec = make_grid_spec(scene, options);
  const kernels::BackendChoice choice =
      kernels::choose_backend(args.value("--backend").value_or("auto"));
  options.compute = choice.compute;
  if (!quiet) {
    std::fprintf(stderr, "gvd: %zu objects, %llu simplices, %dD; %s; %d threads\n",
                 scene.objects.size(), static_cast<unsigned long long>(scene.simplex_count()),
                 scene.dimension, choice.log.c_str(), resolve_threads(options.threads));
    log_spec(spec, options.metric, scene.units);
  }
}

/// `gvd grid RESULT.gvd`: the grid sampled from a saved adaptive result.
int grid_from_result(const Args& args, const GridOptions& scene_options, bool quiet,
                     const std::optional<std::string>& output,
                     const std::optional<std::string>& labels) {
  for (const char* flag : {"--range-cells", "--backend", "--max-objects", "--max-simplices"}) {
    if (args.value(flag)) {
      throw UsageError{std::string(flag) +
                       " applies to scenes; a saved result is sampled through its own octree "
                       "on the CPU"};
    }
  }
  GvdResult result = load_result(args.positional[0]);
  apply_units(args, result.scene);  // --units labels a result saved without (or with others)
  ResultGridOptions options;
  options.resolution = scene_options.resolution;
  options.metric = scene_options.metric;
  options.threads = scene_options.threads;
  options.max_cells = scene_options.max_cells;
  options.signed_distance = scene_options.signed_distance;
  options.box = domain_arg(args, result.scene.dimension);
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
  const std::vector<std::string> written =
      write_outputs(grid, output, labels, args.has("--float64"));
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
  const Args args = parse_args(
      argc, argv, 2,
      {"-o", "--output", "--labels", "--resolution", "--metric", "--domain", "--threads",
       "--backend", "--max-cells", "--range-cells", "--max-objects", "--max-simplices", "--units"},
      {"--float64", "--unsigned", "-q", "--quiet"});
  if (args.positional.empty()) throw UsageError{"grid needs a scene file or a saved result"};
  const bool quiet = args.has("-q") || args.has("--quiet");
  const auto output = args.value("-o") ? args.value("-o") : args.value("--output");
  const auto labels = args.value("--labels");
  if (!output && !labels) throw UsageError{"grid needs -o FIELD.npy and/or --labels LABELS.npy"};
  GridOptions options = grid_options(args, "grid");
  check_grid_outputs(output, labels);

  if (args.positional.size() == 1 && is_result_file(args.positional[0]))
    return grid_from_result(args, options, quiet, output, labels);

  SceneLimits limits;
  limits.max_objects = args.u64_value("--max-objects", limits.max_objects);
  limits.max_simplices = args.u64_value("--max-simplices", limits.max_simplices);
  Scene scene = load_scene(args.positional, limits);
  apply_units(args, scene);
  prepare_grid(args, scene, options, quiet);
  if (!quiet && scene.objects.size() == 1)
    std::fprintf(stderr, "gvd: one object: every cell's label is 0 (a distance field)\n");
  const DistanceGrid grid = compute_grid(scene, options);

  const std::vector<std::string> written =
      write_outputs(grid, output, labels, args.has("--float64"));
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
  GridOptions options = grid_options(args, "--mode grid");
  check_grid_outputs(output, labels);
  const Scene scene = load_compute_scene(args, args.positional);
  prepare_grid(args, scene, options, quiet);
  const DistanceGrid grid = compute_grid(scene, options);
  Stopwatch sw;
  GridGraphOptions graph_options;
  graph_options.threads = options.threads;
  const DualGraph graph = grid_dual_graph(grid, scene, graph_options);
  const double graph_seconds = sw.seconds();
  std::vector<std::string> written = write_outputs(grid, output, labels, args.has("--float64"));
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

// `gvd`: compute generalized Voronoi diagrams from the command line and inspect results.

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cli_options.h"
#include "commands.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/peak_memory.h"
#include "gvd/grid/grid_advice.h"
#include "gvd/io/result_file.h"
#include "gvd/io/write_outputs.h"
#include "gvd/kernels/opencl_backend.h"
#include "gvd/pipeline/parameters.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/label_volume.h"
#include "gvd/scene/load_scene.h"
#include "gvd/scene/units.h"
#include "http_client.h"
#include "remote_commands.h"
#include "usage.h"

namespace gvd::cli {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::grid;
using namespace gvd::io;
using namespace gvd::pipeline;

namespace {

int exit_code_for(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidScene:
    case ErrorCode::kInvalidArgument:
    case ErrorCode::kUnsupportedFormat:
    case ErrorCode::kOutsideDomain:
      return kExitBadInput;
    case ErrorCode::kLimitExceeded:
      return kExitLimit;
    case ErrorCode::kNotFound:
    case ErrorCode::kIo:
      return kExitIo;
    case ErrorCode::kCancelled:
      return kExitCancelled;
    case ErrorCode::kInternal:
      return kExitInternal;
  }
  return kExitInternal;
}

// A one-line progress display on stderr: a bar on a terminal, one line per stage otherwise.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0) {}
  void operator()(const std::string& stage, double fraction) {
    if (!enabled_) return;
    if (tty_) {
      const int width = 30;
      const int filled = static_cast<int>(fraction * width + 0.5);
      std::fprintf(stderr, "\r  %-10s [%s%s] %3d%%", stage.c_str(),
                   std::string(filled, '#').c_str(), std::string(width - filled, '-').c_str(),
                   static_cast<int>(fraction * 100));
      if (stage == "done") std::fprintf(stderr, "\n");
      std::fflush(stderr);
    } else if (stage != last_) {
      std::fprintf(stderr, "  stage: %s\n", stage.c_str());
    }
    last_ = stage;
  }

 private:
  bool enabled_;
  bool tty_;
  std::string last_;
};

/// When a uniform grid would do: the resolution that separates the closest pair.
void print_grid_advice(const GvdResult& r, std::FILE* out) {
  const GridAdvice a = grid_advice(r.scene, r.graph);
  if (!a.measured) return;
  if (a.touching_pairs > 0) {
    std::fprintf(out,
                 "  uniform grid: %llu neighbour pair(s) touch or intersect (gap 0): no grid "
                 "separates them\n",
                 static_cast<unsigned long long>(a.touching_pairs));
  }
  if (a.gap <= 0) return;
  std::fprintf(out,
               "  uniform grid: the closest objects, %s and %s, are %.3g%s apart; a grid with a "
               "cell diagonal below that needs resolution %.0f (%.3g cells): %s\n",
               r.scene.objects[a.a].label.c_str(), r.scene.objects[a.b].label.c_str(), a.gap,
               units_suffix(r.scene.units).c_str(), a.resolution, a.cells,
               a.fits ? "within gvd grid's default limit, so `gvd grid --resolution` that high "
                        "resolves it too"
                      : ("beyond gvd grid's default limit of " + std::to_string(a.cell_limit) +
                         " cells: the octree is the right tool here")
                            .c_str());
}

void print_summary(const GvdResult& r, std::FILE* out) {
  const ResultStats& s = r.stats;
  const std::string unit = units_suffix(r.scene.units);  // " mm", or nothing
  std::fprintf(out, "  objects %zu, simplices %llu, dimension %d%s%s\n", r.scene.objects.size(),
               static_cast<unsigned long long>(r.scene.simplex_count()), r.scene.dimension,
               r.scene.units.empty() ? "" : ", units ", r.scene.units.c_str());
  std::fprintf(out, "  backend %s, %d threads\n", s.backend.c_str(), s.threads);
  const Domain& d = r.domain;
  std::fprintf(out, "  domain: a %s of side %.9g%s from (%.9g, %.9g%s",
               d.dimension == 2 ? "square" : "cube", d.side, unit.c_str(), d.origin.x, d.origin.y,
               d.dimension == 2 ? ")" : "");
  if (d.dimension == 3) std::fprintf(out, ", %.9g)", d.origin.z);
  if (!d.aligned()) {
    std::fprintf(out, ", its edges along the scene's faces:");
    for (const Vec3& a : d.axis) std::fprintf(out, " (%.6f, %.6f, %.6f)", a.x, a.y, a.z);
  }
  std::fprintf(out, "\n");
  std::fprintf(out,
               "  octree: depth %d (limit %d), %llu leaves (%llu in certified pair cells), %llu "
               "vertices, %.1f bytes/leaf\n",
               s.depth, s.max_depth, static_cast<unsigned long long>(s.leaves),
               static_cast<unsigned long long>(s.certified_leaves),
               static_cast<unsigned long long>(s.vertices), s.bytes_per_leaf);
  std::fprintf(out,
               "  gvd: %llu simplices (both sides), %llu neighbour pairs, %d refinement rounds\n",
               static_cast<unsigned long long>(s.gvd_simplices),
               static_cast<unsigned long long>(s.graph_edges), s.refine_rounds);
  std::fprintf(out, "  stages:");
  for (const StageStats& st : s.stages)
    std::fprintf(out, " %s %.3f s;", st.name.c_str(), st.seconds);
  std::fprintf(out, " total %.3f s\n", s.total_seconds);
  std::fprintf(out, "  memory:");
  for (const StageStats& st : s.stages) {
    if (st.bytes > 0) std::fprintf(out, " %s %.1f MB;", st.name.c_str(), st.bytes / 1e6);
  }
  std::fprintf(out, " (data each stage produced)\n");
  if (s.peak_rss_bytes > 0) {
    std::fprintf(out, "  peak memory %.1f MB (process high-water mark), %.0f bytes/leaf",
                 s.peak_rss_bytes / 1e6,
                 s.leaves > 0 ? static_cast<double>(s.peak_rss_bytes) / s.leaves : 0.0);
    if (s.start_rss_bytes > 0 && s.start_rss_bytes < s.peak_rss_bytes) {
      // What the computation added: the process held start_rss_bytes before it (the OpenCL
      // runtime, the scene as read).
      const double added = static_cast<double>(s.peak_rss_bytes - s.start_rss_bytes);
      std::fprintf(out, "; %.1f MB above the %.1f MB held before the computation, %.0f bytes/leaf",
                   added / 1e6, s.start_rss_bytes / 1e6, s.leaves > 0 ? added / s.leaves : 0.0);
    }
    std::fprintf(out, "\n");
  }
  print_grid_advice(r, out);
  // At most kShown warnings of one kind in full (a segmentation has one per label); the rest
  // are counted. `gvd info --json` lists every one.
  constexpr int kShown = 5;
  std::map<std::string, std::pair<int, uint64_t>> kinds;  // kind -> warnings, their counts
  for (const SceneWarning& w : r.scene.warnings) {
    auto& [warnings, total] = kinds[warning_kind_name(w.kind)];
    ++warnings;
    total += w.count;
    if (warnings > kShown) continue;
    std::fprintf(out, "  warning [%s]%s%s (%llu): %s\n", warning_kind_name(w.kind),
                 w.object.empty() ? "" : " ", w.object.c_str(),
                 static_cast<unsigned long long>(w.count), w.detail.c_str());
  }
  for (const auto& [kind, seen] : kinds) {
    if (seen.first <= kShown) continue;
    std::fprintf(
        out,
        "  warning [%s]: %d more objects (%llu in all of this kind; gvd info --json lists them)\n",
        kind.c_str(), seen.first - kShown, static_cast<unsigned long long>(seen.second));
  }
}

}  // namespace

std::function<void(const std::string&, double)> progress_display(bool enabled) {
  auto progress = std::make_shared<Progress>(enabled);
  return [progress](const std::string& stage, double f) { (*progress)(stage, f); };
}

const std::vector<std::string>& compute_value_flags() {
  static const std::vector<std::string> flags = [] {
    // The table's flags of the adaptive mode and of any mode (--mode is compute's own; the
    // labelled volume's among them), and the volume itself.
    std::vector<std::string> f = {"--volume"};
    for (const ParamSpec& p : pipeline_parameters()) {
      if (p.on(kCliFlag) && p.kind != ParamKind::kFlag && p.mode != ParamMode::kGrid &&
          p.name != "mode") {
        f.push_back(flag_name(p));
      }
    }
    return f;
  }();
  return flags;
}

PipelineParams params_from_flags(const Args& args, ParamSurface surface) {
  PipelineParams params;
  for (const ParamSpec& p : pipeline_parameters()) {
    if (!p.on(surface) || find_parameter_on(p.name, surface) != &p) continue;  // "resolution" once
    const std::string flag = flag_name(p);
    try {
      if (p.kind == ParamKind::kFlag) {
        if (args.has(flag)) params.set(p.name, "true", ParamSpelling::kCli, surface);
      } else if (const auto v = args.value(flag)) {
        params.set(p.name, *v, ParamSpelling::kCli, surface);
      }
    } catch (const Error& e) {
      // A malformed flag value, an unknown unit among them, is a command-line mistake
      // (exit 2); a scene file's own unknown "units" are invalid input (exit 3).
      throw UsageError{e.detail()};
    }
  }
  return params;
}

void check_params(const PipelineParams& params, int dimension) {
  try {
    params.check(dimension, ParamSpelling::kCli);
  } catch (const Error& e) {
    throw UsageError{e.detail()};
  }
}

Scene load_compute_scene(const Args& args, const std::vector<std::string>& files) {
  const PipelineParams params = params_from_flags(args);  // the limits, the volume's voxels
  SceneLimits limits;
  limits.max_objects = params.max_objects;
  limits.max_simplices = params.max_simplices;
  if (const auto volume = args.value("--volume")) {
    if (!files.empty()) throw UsageError{"--volume takes the place of the scene files"};
    const LabelVolume labels = read_label_volume_npy(read_file_bytes(*volume), *volume);
    LabelVolumeOptions vo;
    try {
      vo = label_volume_options(params, labels.dimension, ParamSpelling::kCli);
    } catch (const Error& e) {
      throw UsageError{e.detail()};
    }
    Scene scene = scene_from_label_volume(labels, vo, limits);
    apply_units(args, scene);
    return scene;
  }
  if (args.has("--spacing") || args.has("--background") || args.has("--volume-faces"))
    throw UsageError{"--spacing, --background and --volume-faces go with --volume LABELS.npy"};
  Scene scene = load_scene(files, limits);
  apply_units(args, scene);
  return scene;
}

void apply_units(const Args& args, Scene& scene) {
  const auto units = args.value("--units");
  if (!units) return;
  // The command line's word over the file's: a scene JSON's "units" are replaced (said on
  // stderr when they differ), meshes and volumes (which have none) get them.
  std::string name;
  try {
    name = parse_units(*units, "--units", ErrorCode::kInvalidArgument);
  } catch (const Error& e) {
    throw UsageError{e.detail()};  // a bad flag value: exit 2, as for every other flag
  }
  if (!scene.units.empty() && scene.units != name && !(args.has("-q") || args.has("--quiet"))) {
    std::fprintf(stderr, "gvd: --units %s replaces the input's units \"%s\"\n", name.c_str(),
                 scene.units.c_str());
  }
  scene.units = name;
}

ComputeSetup compute_setup(const Args& args, const std::vector<std::string>& files) {
  const bool quiet = args.has("-q") || args.has("--quiet");
  ComputeSetup setup;
  setup.scene = load_compute_scene(args, files);
  const Scene& scene = setup.scene;

  const PipelineParams params = params_from_flags(args);
  check_params(params, scene.dimension);
  PipelineOptions& options = setup.options;
  options = pipeline_options(params);
  // OpenCL is initialised here, once, before any computation (kernels/opencl_backend.h).
  const kernels::BackendChoice choice =
      kernels::choose_backend(std::string(choice_name(params.backend)));
  options.backend = parse_choice<BackendRequest>(choice.backend);
  options.compute = choice.compute;
  options.backend_note = choice.note;
  if (!quiet) {
    std::fprintf(stderr, "gvd: %zu objects, %llu simplices, %dD; %s; %d threads\n",
                 scene.objects.size(), static_cast<unsigned long long>(scene.simplex_count()),
                 scene.dimension, choice.log.c_str(), resolve_threads(options.threads));
  }
  options.progress = progress_display(!quiet);
  return setup;
}

namespace {

/// Writes the outputs asked for by -o/--output, --graph, --json (and --save where allowed);
/// returns what it wrote, for the summary.
std::vector<std::string> write_requested_outputs(const GvdResult& result, const Args& args) {
  std::vector<std::string> written;
  const auto glb_path = args.value("-o") ? args.value("-o") : args.value("--output");
  if (glb_path) {
    write_glb_file(*glb_path, result.gvd, result.scene);
    written.push_back(*glb_path + " (GVD, binary glTF)");
  }
  if (const auto p = args.value("--graph")) {
    write_file_atomic(*p, graph_to_json(result.graph, result.scene));
    written.push_back(*p + " (dual graph)");
  }
  if (const auto p = args.value("--json")) {
    write_json_file(*p, result.gvd, result.scene);
    written.push_back(*p + " (GVD, float64 JSON)");
  }
  if (const auto p = args.value("--save")) {
    save_result(result, *p);
    written.push_back(*p + " (result, for gvd info and later queries)");
  }
  return written;
}

int cmd_compute(int argc, char** argv) {
  std::vector<std::string> value_flags = {"-o",     "--output", "--graph",
                                          "--json", "--save",   "--mode"};
  value_flags.insert(value_flags.end(), compute_value_flags().begin(), compute_value_flags().end());
  value_flags.insert(value_flags.end(), grid_mode_value_flags().begin(),
                     grid_mode_value_flags().end());
  std::vector<std::string> boolean = {"-q", "--quiet"};
  boolean.insert(boolean.end(), grid_mode_boolean_flags().begin(), grid_mode_boolean_flags().end());
  const Args args = parse_args(argc, argv, 2, value_flags, boolean);
  if (args.positional.empty() && !args.has("--volume"))
    throw UsageError{"compute needs at least one scene file (or --volume LABELS.npy)"};
  for (const std::string& file : args.positional) {
    if (is_result_file(file)) {
      throw UsageError{"\"" + file +
                       "\" is a saved result, not a scene: to write its outputs without "
                       "recomputing, use gvd export " +
                       file + " -o gvd.glb [--graph g.json] [--json gvd.json]"};
    }
  }
  if (params_from_flags(args).is_grid()) return compute_grid_mode(args);
  for (const std::string& flag : grid_mode_value_flags()) {
    if (args.has(flag)) throw UsageError{flag + " goes with --mode grid"};
  }
  for (const std::string& flag : grid_mode_boolean_flags()) {
    if (args.has(flag)) throw UsageError{flag + " goes with --mode grid"};
  }
  const bool quiet = args.has("-q") || args.has("--quiet");
  ComputeSetup setup = compute_setup(args, args.positional);
  Scene scene = std::move(setup.scene);
  const PipelineOptions& options = setup.options;

  const GvdResult result = compute_gvd(std::move(scene), options);

  const std::vector<std::string> written = write_requested_outputs(result, args);
  if (!quiet) {
    print_summary(result, stderr);
    for (const std::string& w : written) std::fprintf(stderr, "  wrote %s\n", w.c_str());
    if (written.empty())
      std::fprintf(stderr, "  (no output requested: use -o, --graph, --json or --save)\n");
  }
  return kExitOk;
}

int cmd_export(int argc, char** argv) {
  const Args args = parse_args(argc, argv, 2, {"-o", "--output", "--graph", "--json", "--units"},
                               {"-q", "--quiet"});
  if (args.positional.size() != 1) throw UsageError{"export needs exactly one result file"};
  const std::string& file = args.positional[0];
  if (!args.value("-o") && !args.value("--output") && !args.value("--graph") &&
      !args.value("--json")) {
    throw UsageError{"export needs an output: -o FILE.glb, --graph FILE.json or --json FILE.json"};
  }
  if (std::filesystem::exists(file) && !is_result_file(file)) {  // load_result names a missing file
    throw Error(
        ErrorCode::kUnsupportedFormat,
        "\"" + file + "\" is not a saved result (a .gvd file written by gvd compute --save)");
  }
  GvdResult result = load_result(file);
  apply_units(args, result.scene);  // --units labels a result saved without (or with others)
  const std::vector<std::string> written = write_requested_outputs(result, args);
  if (!(args.has("-q") || args.has("--quiet"))) {
    for (const std::string& w : written) std::fprintf(stderr, "gvd: wrote %s\n", w.c_str());
  }
  return kExitOk;
}

int cmd_info(int argc, char** argv) {
  const Args args = parse_args(argc, argv, 2, {}, {"--json"});
  if (args.positional.size() != 1) throw UsageError{"info needs exactly one result file"};
  const GvdResult result = load_result(args.positional[0]);
  if (args.has("--json")) {
    std::cout << result_info_json(result) << "\n";
  } else {
    std::printf("%s\n", args.positional[0].c_str());
    print_summary(result, stdout);
  }
  return kExitOk;
}

/// Takes `--server URL` / `--server=URL` and `--local` out of argv (they may stand anywhere)
/// and moves the other remote options (--retries, --timeout) behind the command; returns the
/// server to use: the flag, else $GVD_SERVER, unless --local.
std::optional<std::string> take_server(int& argc, char** argv) {
  std::optional<std::string> server;
  bool local = false;
  int out = 1;
  std::vector<char*> moved;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--retries" || a == "--timeout") && i + 1 < argc) {
      moved.push_back(argv[i]);
      moved.push_back(argv[++i]);
    } else if (a.rfind("--retries=", 0) == 0 || a.rfind("--timeout=", 0) == 0) {
      moved.push_back(argv[i]);
    } else if (a == "--server") {
      if (i + 1 >= argc) throw UsageError{"--server needs a URL"};
      server = argv[++i];
    } else if (a.rfind("--server=", 0) == 0) {
      server = a.substr(9);
    } else if (a == "--local") {
      local = true;
    } else {
      argv[out++] = argv[i];
    }
  }
  for (char* m : moved) argv[out++] = m;
  argc = out;
  if (local) return std::nullopt;
  if (!server) {
    if (const char* env = std::getenv("GVD_SERVER"); env != nullptr && *env != '\0') server = env;
  }
  if (server && server->empty()) throw UsageError{"--server needs a URL"};
  return server;
}

int run(int argc, char** argv) {
  const std::optional<std::string> server = take_server(argc, argv);
  if (argc < 2) {
    std::fputs(usage().c_str(), stderr);
    return kExitUsage;
  }
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    std::fputs(usage().c_str(), stdout);
    return kExitOk;
  }
  // `gvd COMMAND --help`: that command's usage, whatever else is given; not an error.
  for (int i = 2; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      const std::optional<std::string> text = command_usage(command);
      if (!text) throw UsageError{"unknown command \"" + command + "\""};
      std::fputs(text->c_str(), stdout);
      return kExitOk;
    }
  }
  if (command == "--version") {
    std::printf("gvd %s (algorithm %u, backends: opencl, cpu)\n", GVD_VERSION, kAlgorithmVersion);
    return kExitOk;
  }
  if (server) return run_remote(*server, argc, argv);
  if (command == "compute") return cmd_compute(argc, argv);
  if (command == "info") return cmd_info(argc, argv);
  if (command == "export") return cmd_export(argc, argv);
  if (command == "nearest") return cmd_nearest(argc, argv);
  if (command == "neighbors" || command == "neighbours") return cmd_neighbors(argc, argv);
  if (command == "path") return cmd_path(argc, argv);
  if (command == "explode") return cmd_explode(argc, argv);
  if (command == "tight") return cmd_tight(argc, argv);
  if (command == "contacts") return cmd_contacts(argc, argv);
  if (command == "grid") return cmd_grid(argc, argv);
  throw UsageError{"unknown command \"" + command + "\""};
}

}  // namespace
}  // namespace gvd::cli

int main(int argc, char** argv) {
  using namespace gvd::cli;
  gvd::use_returning_heap(true);
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "gvd: %s\n(see gvd --help)\n", e.message.c_str());
    return kExitUsage;
  } catch (const RemoteError& e) {
    std::fprintf(stderr, "gvd: error: %s\n", e.message.c_str());
    return e.exit_code;
  } catch (const NetworkError& e) {
    std::fprintf(stderr, "gvd: network error: %s\n", e.message.c_str());
    return kExitNetwork;
  } catch (const gvd::Error& e) {
    std::fprintf(stderr, "gvd: error: %s\n", e.what());
    return exit_code_for(e.code());
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "gvd: error: out of memory (lower --max-depth or --max-leaves)\n");
    return kExitLimit;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gvd: internal error: %s\n", e.what());
    return kExitInternal;
  }
}

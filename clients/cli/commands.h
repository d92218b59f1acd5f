#pragma once

// The `gvd` subcommands and what they share: reading compute options and computing a scene.

#include <functional>
#include <string>
#include <vector>

#include "cli_options.h"
#include "gvd/pipeline/parameters.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/scene.h"

namespace gvd::cli {

/// The flags of `compute` that take a value and configure the computation (also accepted by
/// the query commands when their input is a scene).
const std::vector<std::string>& compute_value_flags();

/// The parameters of the table (gvd/pipeline/parameters.h) given as the flags that `surface`
/// takes (kCliFlag: gvd compute, kGridFlag: gvd grid), parsed by it: a malformed value (an
/// unknown --units too) is a UsageError naming the flag (exit 2).
pipeline::PipelineParams params_from_flags(const Args& args,
                                           pipeline::ParamSurface surface = pipeline::kCliFlag);
/// params.check for a scene of `dimension`, its errors as UsageError.
void check_params(const pipeline::PipelineParams& params, int dimension);

/// A loaded scene and the pipeline options from the command line (with a progress display on
/// stderr unless -q/--quiet). Logs the scene size and the backend.
struct ComputeSetup {
  scene::Scene scene;
  pipeline::PipelineOptions options;
};
ComputeSetup compute_setup(const Args& args, const std::vector<std::string>& files);
/// The scene of `compute`: the files, or --volume (with --spacing, --background), within the
/// --max-objects / --max-simplices limits.
scene::Scene load_compute_scene(const Args& args, const std::vector<std::string>& files);
/// --units: the length unit of a scene (or of a loaded result's scene), set over its own
/// "units" (said on stderr, unless -q/--quiet, when they differ). A UsageError (exit 2)
/// naming --units for a unit gvd does not know (gvd/scene/units.h). Nothing without --units.
void apply_units(const Args& args, scene::Scene& scene);

/// The progress display on stderr (a bar on a terminal, one line per stage otherwise;
/// nothing when `enabled` is false): call with the stage name and the fraction done, 0..1.
std::function<void(const std::string&, double)> progress_display(bool enabled);

/// True when the file starts with the result file magic (a result saved by `compute --save`).
bool is_result_file(const std::string& path);

// Query commands (query_commands.cpp): answers as JSON on stdout.
int cmd_nearest(int argc, char** argv);
int cmd_neighbors(int argc, char** argv);
int cmd_path(int argc, char** argv);
int cmd_explode(int argc, char** argv);
int cmd_tight(int argc, char** argv);
int cmd_contacts(int argc, char** argv);

// The uniform grid (grid_command.cpp): distance and labels per cell to .npy / NRRD.
int cmd_grid(int argc, char** argv);
/// `gvd compute --mode grid`: the discrete GVD on a uniform grid and its dual graph.
int compute_grid_mode(const Args& args);
/// The flags only --mode grid takes (beyond those it shares with the adaptive mode).
const std::vector<std::string>& grid_mode_value_flags();
const std::vector<std::string>& grid_mode_boolean_flags();

}  // namespace gvd::cli

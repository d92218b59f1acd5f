#pragma once

// The `gvd` subcommands and what they share: reading compute options and computing a scene.

#include <string>
#include <vector>

#include "cli_options.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/scene.h"

namespace gvd::cli {

/// The flags of `compute` that take a value and configure the computation (also accepted by
/// the query commands when their input is a scene).
const std::vector<std::string>& compute_value_flags();

/// A loaded scene and the pipeline options from the command line (with a progress display on
/// stderr unless -q/--quiet). Logs the scene size and the backend.
struct ComputeSetup {
  Scene scene;
  PipelineOptions options;
};
ComputeSetup compute_setup(const Args& args, const std::vector<std::string>& files);

// Query commands (query_commands.cpp): answers as JSON on stdout.
int cmd_nearest(int argc, char** argv);
int cmd_neighbors(int argc, char** argv);
int cmd_path(int argc, char** argv);
int cmd_explode(int argc, char** argv);
int cmd_tight(int argc, char** argv);

}  // namespace gvd::cli

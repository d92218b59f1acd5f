// The help texts of `gvd`: the whole usage (`gvd --help`) and one command's (`gvd COMMAND
// --help`), both assembled from the same pieces so that they cannot disagree.

#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace gvd::cli {

/// `gvd --help`: every command, its options, remote mode and the exit codes. The compute and
/// grid parameters' lines come from the parameter table (gvd/pipeline/parameters.h).
std::string usage();

/// `gvd COMMAND --help`: the command's synopsis and only the options it reads, then the exit
/// codes; nullopt for a name that is no command.
std::optional<std::string> command_usage(std::string_view command);

}  // namespace gvd::cli

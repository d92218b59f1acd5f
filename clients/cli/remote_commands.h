#pragma once

// `gvd --server URL <command>`: the commands of `gvd` against gvd-server (docs/API.md).
// HTTP stays in http_client.cpp; this interface carries no HTTP library.

#include <string>

namespace gvd::cli {

/// An error answer of the server (its problem document), or a job that ended without a
/// result. `exit_code` comes from exit_code_for_problem.
struct RemoteError {
  int exit_code = 1;
  std::string message;
};

/// The exit code for a problem `type` of docs/API.md; an unknown type falls back on its HTTP
/// `status`. The one table that maps server answers to exit codes.
int exit_code_for_problem(const std::string& type, int status);

/// Runs the command argv[1] (compute, info, nearest, neighbors, path, explode, tight) against
/// the server at `url`; argv is the command line without the --server option. Throws
/// UsageError, RemoteError, NetworkError (http_client.h) or gvd::Error (local files).
int run_remote(const std::string& url, int argc, char** argv);

}  // namespace gvd::cli

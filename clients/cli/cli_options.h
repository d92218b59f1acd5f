#pragma once

// Command-line parsing for the `gvd` tool: flags with values, positional arguments, and
// typed conversions that report the flag they came from.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace gvd::cli {

/// Exit codes of `gvd` (documented in `gvd --help` and the README).
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,   ///< a bug
  kExitUsage = 2,      ///< bad command line
  kExitBadInput = 3,   ///< invalid scene, argument or format
  kExitLimit = 4,      ///< a configured limit was exceeded
  kExitIo = 5,         ///< a file could not be read or written / not found
  kExitCancelled = 6,  ///< interrupted
  kExitNoPath = 7,     ///< `gvd path`: no path joins the points (the JSON says why)
  kExitBusy = 8,       ///< --server: still 503 after the retries, or the job is not done yet
  kExitNetwork = 9,    ///< --server: the server cannot be reached (refused, reset, timeout)
};

/// Thrown for command-line mistakes; the message is shown with a hint to --help.
struct UsageError {
  std::string message;
};

/// Parsed command line: `flags` maps "--name" to its values (a flag may repeat),
/// `positional` keeps the rest in order. Boolean flags have an empty value.
struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::vector<std::string>> flags;

  bool has(const std::string& flag) const { return flags.count(flag) > 0; }
  std::optional<std::string> value(const std::string& flag) const;
  int int_value(const std::string& flag, int fallback) const;
  uint64_t u64_value(const std::string& flag, uint64_t fallback) const;
  /// Comma-separated numbers ("0,0,0,1,1,1").
  std::optional<std::vector<double>> numbers(const std::string& flag) const;
};

/// The value of a flag that must be given (UsageError "missing --flag" otherwise).
std::string required_value(const Args& args, const std::string& flag);

/// The coordinates of a point given as "x,y[,z]" for `flag`, checked to have `dimension`
/// numbers (UsageError saying what was expected otherwise).
std::vector<double> point_value(const std::string& flag, const std::string& text, int dimension);

/// Parses argv[first..]. `with_value` lists the flags that take a value (also accepted as
/// --flag=value); `boolean` those that do not. Unknown flags are a UsageError.
Args parse_args(int argc, char** argv, int first, const std::vector<std::string>& with_value,
                const std::vector<std::string>& boolean);

}  // namespace gvd::cli

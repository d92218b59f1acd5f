#pragma once

// The pipeline's parameters in one table: name, type, range, default (per dimension where the
// engine picks one), choices and help text of every parameter a caller can set, and which
// surfaces take it (the `gvd` flags, the server's job parameters, gvd.compute's keywords).
// The CLI parses its flags and prints their --help lines from it, the server parses its job
// parameters through it, and tests check server/openapi.json and the Python module's
// keywords against it (docs/ARCHITECTURE.md, "One definition each").

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/distance/distance_field.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/scene/scene.h"

namespace gvd {

/// Where different objects come close (`refine`): certified pair cells, or the paper's rule
/// of §3 alone.
enum class RefineRule { kCertified, kPaper };
/// The GVD's pieces (`resolution` of the adaptive mode): flat parts merged (compact_gvd.h),
/// or one piece per octree leaf it crosses.
enum class GvdResolution { kCompact, kFull };
/// How the first octree is built (`octree_build`): level by level, or the data-parallel
/// Karras / conflict-cell construction. The same leaves either way.
enum class OctreeBuild { kLevels, kDataParallel };
/// Where the data-parallel steps run (`backend`). kAuto is for callers that make the backend
/// (kernels::choose_backend); PipelineOptions holds kCpu or kOpenCl.
enum class BackendRequest { kAuto, kOpenCl, kCpu };
/// The octree pipeline (compute_gvd) or the uniform grid (compute_grid) (`mode`).
enum class ComputeMode { kAdaptive, kGrid };

/// The type of a parameter's value, and so how its text is read.
enum class ParamKind {
  kInt,     ///< an integer in [min, max]
  kCount,   ///< an unsigned 64-bit integer >= min
  kNumber,  ///< a finite number in [min, max)
  kFlag,    ///< true/false (1/0); a CLI flag without a value
  kChoice,  ///< one of `choices`, an enum in that order
  kBox,     ///< x0,y0[,z0],x1,y1[,z1]: 4 or 6 finite numbers
  kUnits,   ///< a length unit (gvd/scene/units.h), kept by its canonical name
};

/// Which computation a parameter configures: a parameter of one mode given with the other is
/// refused (PipelineParams::check).
enum class ParamMode { kAny, kAdaptive, kGrid };

/// The surfaces that take a parameter (bit mask).
enum ParamSurface : unsigned {
  kCliFlag = 1u,        ///< `gvd compute --name-with-dashes`
  kJobParam = 2u,       ///< gvd-server's job parameter `name` (query, "params"; OpenAPI)
  kPythonKeyword = 4u,  ///< gvd.compute(..., name=)
};

/// How a message names a parameter: `--max-depth` (CLI), `parameter "max_depth"` (server),
/// `max_depth` (the C++ and Python API).
enum class ParamSpelling { kCli, kServer, kApi };

/// One parameter. Its name is the job parameter and the Python keyword; the CLI flag is the
/// name with dashes (`flag_name`). Two entries share the name "resolution": compact|full in the
/// adaptive mode, a cell count with mode=grid (the value's form tells them apart).
struct ParamSpec {
  std::string_view name;
  ParamKind kind = ParamKind::kInt;
  ParamMode mode = ParamMode::kAny;
  unsigned surfaces = 0;
  double min = 0;    ///< kInt, kCount: least value; kNumber: least value (inclusive)
  double max = 0;    ///< kInt: greatest value; kNumber: the bound (exclusive); kCount: none
  double value = 0;  ///< the value of an unset kInt/kCount/kNumber/kFlag parameter
  /// kInt whose unset `value` (0 or -1) lets the engine choose: what it chooses in 2D, 3D.
  bool by_dimension = false;
  std::array<double, 2> per_dimension{};
  std::span<const std::string_view> choices;  ///< kChoice: names in enum order; first = default
  std::string_view metavar;                   ///< the CLI value's name in --help ("N", "F")
  std::string_view help;                      ///< the --help text, one paragraph

  bool on(ParamSurface s) const { return (surfaces & s) != 0; }
};

/// The table, in the order `gvd --help` lists the flags.
std::span<const ParamSpec> pipeline_parameters();
/// The entry named `name` of `mode` (kAny: the first of that name), or null.
const ParamSpec* find_parameter(std::string_view name, ParamMode mode = ParamMode::kAny);
/// "--max-depth" for "max_depth".
std::string flag_name(const ParamSpec& spec);
/// How `spelling` names the parameter in a message: `--max-depth`, `parameter "max_depth"`,
/// `max_depth`.
std::string spelled(const ParamSpec& spec, ParamSpelling spelling);
/// The value of an unset parameter as text ("0", "-1", "auto", "12000000", "false", "").
std::string default_text(const ParamSpec& spec);
/// The --help lines of the table's CLI flags of `mode` (kAny: those of every mode's...
/// parameters that apply to any mode too): "  --flag VALUE" padded to column 29, the help
/// wrapped at 93 columns, per-dimension defaults appended.
std::string parameter_help(ParamMode mode);

/// The name of a choice (`choice_name(RefineRule::kPaper)` = "paper") and back; parse_choice
/// throws gvd::Error{kInvalidArgument} naming the parameter as `spelling` does and the choices.
template <class E>
struct ChoiceParameter;
template <>
struct ChoiceParameter<RefineRule> {
  static constexpr std::string_view name = "refine";
};
template <>
struct ChoiceParameter<GvdResolution> {
  static constexpr std::string_view name = "resolution";
};
template <>
struct ChoiceParameter<OctreeBuild> {
  static constexpr std::string_view name = "octree_build";
};
template <>
struct ChoiceParameter<BackendRequest> {
  static constexpr std::string_view name = "backend";
};
template <>
struct ChoiceParameter<ComputeMode> {
  static constexpr std::string_view name = "mode";
};
template <>
struct ChoiceParameter<DistanceMethod> {
  static constexpr std::string_view name = "distance";
};
template <>
struct ChoiceParameter<DomainFrame> {
  static constexpr std::string_view name = "frame";
};
template <>
struct ChoiceParameter<GridMetric> {
  static constexpr std::string_view name = "metric";
};

/// The index of `text` among the choices of `spec`; gvd::Error{kInvalidArgument} otherwise.
int parse_choice_index(const ParamSpec& spec, std::string_view text, ParamSpelling spelling);
const ParamSpec& choice_spec(std::string_view name);

template <class E>
std::string_view choice_name(E e) {
  return choice_spec(ChoiceParameter<E>::name).choices[static_cast<size_t>(e)];
}
template <class E>
E parse_choice(std::string_view text, ParamSpelling spelling = ParamSpelling::kApi) {
  return static_cast<E>(parse_choice_index(choice_spec(ChoiceParameter<E>::name), text, spelling));
}

/// Every parameter of the table with its value: what the CLI flags and the job parameters are
/// parsed into. The defaults are the table's (a test checks them).
struct PipelineParams {
  int max_depth = 0;           ///< 0 = default (table: per dimension)
  int contact_depth = 0;       ///< 0 = default
  std::vector<double> domain;  ///< empty, or x0,y0[,z0],x1,y1[,z1]
  DomainFrame frame = DomainFrame::kAuto;
  int threads = 0;
  BackendRequest backend = BackendRequest::kAuto;
  OctreeBuild octree_build = OctreeBuild::kLevels;
  DistanceMethod distance = DistanceMethod::kExact;
  RefineRule refine = RefineRule::kCertified;
  GvdResolution resolution = GvdResolution::kCompact;
  double curved_tolerance = 0;
  int ambiguity_levels = -1;  ///< < 0 = default
  int ambiguity_rounds = -1;
  int unseen_rounds = -1;
  uint64_t max_leaves = 12'000'000;
  uint64_t max_objects = 100'000;
  uint64_t max_simplices = 20'000'000;
  ComputeMode mode = ComputeMode::kAdaptive;
  int grid_resolution = 0;  ///< mode=grid: cells along the longest side (0 = not given)
  GridMetric metric = GridMetric::kL2;
  bool float64 = false;
  bool unsigned_distance = false;  ///< the parameter "unsigned"
  int range_cells = 0;             ///< 0 = default
  uint64_t max_cells = 134'217'728;
  std::string units;  ///< canonical name, or empty

  bool is_grid() const { return mode == ComputeMode::kGrid; }

  /// Sets the parameter `name` from its text (for "resolution": a cell count when the text is
  /// digits, else compact|full). gvd::Error{kInvalidArgument} naming it as `spelling` does for
  /// an unknown name, a malformed value or one out of the table's range.
  void set(std::string_view name, std::string_view text, ParamSpelling spelling);
  /// The table's range for every number held (for callers that set the fields directly, as
  /// the C++ API does): gvd::Error{kInvalidArgument} naming the first one out of it.
  void check_ranges(ParamSpelling spelling) const;
  /// The value of `spec`: kInt, kCount, kNumber, kFlag (0 or 1) as a number; kChoice as its
  /// name. (kBox and kUnits are `domain` and `units`.)
  double number_of(const ParamSpec& spec) const;
  std::string_view choice_of(const ParamSpec& spec) const;
  /// Whether `spec` holds its unset value.
  bool is_default(const ParamSpec& spec) const;
  /// The checks across parameters for a scene of `dimension` (2 or 3): the domain's size and
  /// order, a mode's parameters only with that mode, mode=grid needs a resolution, max_depth
  /// within the lattice. gvd::Error{kInvalidArgument} naming the parameter as `spelling` does.
  void check(int dimension, ParamSpelling spelling) const;
};

}  // namespace gvd

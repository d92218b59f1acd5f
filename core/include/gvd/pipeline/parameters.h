#pragma once

// The pipeline's parameters in one table: name, type, range, default (per dimension where the
// engine picks one), choices and help text of every parameter a caller can set, and which
// surfaces take it (the flags of `gvd compute` and `gvd grid`, the server's job parameters and
// grid queries, the keywords of gvd.compute, gvd.grid and Result.grid). The CLI parses its
// flags and prints their --help lines from it, the server parses its job parameters and
// field.npy/labels.npy queries through it, and tests check server/openapi.json and the Python
// module's keywords against it (docs/ARCHITECTURE.md, "One definition each").

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/distance/compute_distances.h"
#include "gvd/distance/distance_field.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/grid/sample_result_grid.h"
#include "gvd/scene/label_volume.h"
#include "gvd/scene/scene.h"

namespace gvd::pipeline {

/// Where different objects come close (`refine`): certified pair cells, or the paper's rule
/// of §3 alone.
enum class RefineRule { kCertified, kPaper };
/// The GVD's pieces (`resolution` of the adaptive mode): flat parts merged (compact_gvd.h),
/// or one piece per octree leaf it crosses.
enum class GvdResolution { kCompact, kFull };
/// Junction cells (`junctions`, PipelineOptions::junctions): on (default) or off.
enum class JunctionCells { kOn, kOff };  // the default first, as every choice's
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
  kInt,      ///< an integer in [min, max]
  kCount,    ///< an unsigned 64-bit integer >= min
  kNumber,   ///< a finite number in [min, max)
  kFlag,     ///< true/false (1/0); a CLI flag without a value
  kChoice,   ///< one of `choices`, an enum in that order
  kBox,      ///< x0,y0[,z0],x1,y1[,z1]: 4 or 6 finite numbers
  kUnits,    ///< a length unit (gvd/scene/units.h), kept by its canonical name
  kSpacing,  ///< x,y[,z]: positive finite numbers, one per axis (of a volume read later)
  kLabel,    ///< a label (an integer >= 0) or none
};

/// Which computation a parameter configures: a parameter of one mode given with the other is
/// refused (PipelineParams::check).
enum class ParamMode { kAny, kAdaptive, kGrid };

/// The surfaces that take a parameter (bit mask). Each is checked against the table by a test.
enum ParamSurface : unsigned {
  kCliFlag = 1u,          ///< `gvd compute --name-with-dashes`
  kJobParam = 2u,         ///< gvd-server's job parameter `name` (query, "params"; OpenAPI)
  kPythonKeyword = 4u,    ///< gvd.compute(..., name=)
  kGridFlag = 8u,         ///< `gvd grid SCENE --name-with-dashes`
  kResultGridFlag = 16u,  ///< `gvd grid RESULT.gvd --name-with-dashes` (sampling a saved result)
  /// GET /v1/jobs/{id}/field.npy and labels.npy `?name=` on an adaptive job (sampling its
  /// result; OpenAPI)
  kGridQuery = 32u,
  kPythonGrid = 64u,         ///< gvd.grid(scene, ..., keyword=)
  kPythonResultGrid = 128u,  ///< Result.grid(..., keyword=)
};

/// How a message names a parameter: `--max-depth` (CLI), `parameter "max_depth"` (server),
/// `max_depth` (the C++ and Python API).
enum class ParamSpelling { kCli, kServer, kApi };

/// One parameter. Its name is the job parameter and the Python keyword (but `keyword`); the
/// CLI flag is the name with dashes (`flag_name`). Two entries share the name "resolution":
/// compact|full in the adaptive mode, a cell count with mode=grid (the value's form tells them
/// apart where a surface takes both).
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
  /// The --help text under "grid options" (gvd grid) where it reads otherwise there (the
  /// grid's box is not made a cube); empty: the entry is listed there only if of mode kGrid.
  std::string_view grid_help;
  /// A labelled volume's (`gvd compute --volume`, a volume upload): how its voxels become
  /// the scene.
  bool of_volume = false;
  /// The Python keyword where it is not `name`, and whether it is the flag's negation
  /// (gvd.grid's `signed=True` is `unsigned` false).
  std::string_view keyword;
  bool keyword_negated = false;
  /// The Python keyword's default where the flag and the job parameter have none (must be
  /// given): gvd.grid's and Result.grid's resolution, GridOptions' 256. NaN: `value`.
  double keyword_value = std::numeric_limits<double>::quiet_NaN();

  bool on(ParamSurface s) const { return (surfaces & s) != 0; }
  /// A property of the scene (its units, a volume's voxels), not of the computation: it
  /// reaches a job's id through the normalized scene, not through the parameters' text.
  bool of_scene() const { return kind == ParamKind::kUnits || of_volume; }
};

/// The table, in the order `gvd --help` lists the flags.
std::span<const ParamSpec> pipeline_parameters();
/// The entry named `name` of `mode` (kAny: the first of that name), or null.
const ParamSpec* find_parameter(std::string_view name, ParamMode mode = ParamMode::kAny);
/// The first entry named `name` that `surface` takes, or null.
const ParamSpec* find_parameter_on(std::string_view name, ParamSurface surface);
/// "--max-depth" for "max_depth".
std::string flag_name(const ParamSpec& spec);
/// How `spelling` names the parameter in a message: `--max-depth`, `parameter "max_depth"`,
/// `max_depth`.
std::string spelled(const ParamSpec& spec, ParamSpelling spelling);
/// The value of an unset parameter as text ("0", "-1", "auto", "12000000", "false", "").
std::string default_text(const ParamSpec& spec);
/// The --help lines of one flag: "  --flag VALUE" padded to column 29, the help (with
/// kGridFlag: `grid_help` when there is one) wrapped at 93 columns, per-dimension defaults
/// appended.
std::string flag_help(const ParamSpec& spec, ParamSurface surface = kCliFlag);
/// The flag_help of the table's entries on `surface` of `mode`, in the table's order, but a
/// labelled volume's (`gvd --help` lists those after --volume); for kGridFlag and kGrid then
/// the entries of other modes with a `grid_help`.
std::string parameter_help(ParamMode mode, ParamSurface surface = kCliFlag);

/// The name of a choice (`choice_name(RefineRule::kPaper)` = "paper") and back; parse_choice
/// throws gvd::Error{kInvalidArgument} naming the parameter as `spelling` does and the choices.
template <class E>
struct ChoiceParameter;
template <>
struct ChoiceParameter<RefineRule> {
  static constexpr std::string_view name = "refine";
};
template <>
struct ChoiceParameter<JunctionCells> {
  static constexpr std::string_view name = "junctions";
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
struct ChoiceParameter<distance::DistanceMethod> {
  static constexpr std::string_view name = "distance";
};
template <>
struct ChoiceParameter<scene::DomainFrame> {
  static constexpr std::string_view name = "frame";
};
template <>
struct ChoiceParameter<grid::GridMetric> {
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
  scene::DomainFrame frame = scene::DomainFrame::kAuto;
  int threads = 0;
  BackendRequest backend = BackendRequest::kAuto;
  OctreeBuild octree_build = OctreeBuild::kLevels;
  distance::DistanceMethod distance = distance::DistanceMethod::kExact;
  RefineRule refine = RefineRule::kCertified;
  JunctionCells junctions = JunctionCells::kOn;
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
  grid::GridMetric metric = grid::GridMetric::kL2;
  bool float64 = false;
  bool unsigned_distance = false;  ///< the parameter "unsigned"
  int range_cells = 0;             ///< 0 = default
  uint64_t max_cells = 134'217'728;
  std::string units;            ///< canonical name, or empty
  std::vector<double> spacing;  ///< a labelled volume's voxel size x,y[,z]; empty = 1 each
  std::optional<uint64_t> background = 0;  ///< a labelled volume's non-object label; none
  scene::VolumeFaces volume_faces =
      scene::VolumeFaces::kMerged;  ///< a labelled volume's boundary simplices

  bool is_grid() const { return mode == ComputeMode::kGrid; }

  /// Sets the parameter `name` from its text (for "resolution": a cell count when the text is
  /// digits, else compact|full). gvd::Error{kInvalidArgument} naming it as `spelling` does for
  /// an unknown name, a malformed value or one out of the table's range. The names taken are
  /// those of the surface that spells them so (kCli: kCliFlag, kServer: kJobParam, kApi: all).
  void set(std::string_view name, std::string_view text, ParamSpelling spelling);
  /// The same for the names `surfaces` (a mask of ParamSurface) take: the names of the
  /// others are unknown, and "resolution" is a cell count where none takes compact|full.
  void set(std::string_view name, std::string_view text, ParamSpelling spelling, unsigned surfaces);
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

/// The uniform grid's options of `params` (mode=grid): resolution, metric, signs, range
/// cells, the box (`domain`), threads and max_cells. `compute` (the backend) and the progress
/// are the caller's. Call params.check(dimension, ...) first.
grid::GridOptions grid_options(const PipelineParams& params);
/// The options of sampling a saved result on a grid (sample_result_grid): resolution, metric,
/// signs, the box, threads and max_cells. Call params.check(dimension, ...) first.
grid::ResultGridOptions result_grid_options(const PipelineParams& params);
/// How a labelled volume of `dimension` becomes a scene (scene_from_label_volume): `spacing`
/// (one number per axis; gvd::Error{kInvalidArgument} naming it as `spelling` does
/// otherwise), `background` and `volume_faces`.
scene::LabelVolumeOptions label_volume_options(const PipelineParams& params, int dimension,
                                               ParamSpelling spelling);

}  // namespace gvd::pipeline

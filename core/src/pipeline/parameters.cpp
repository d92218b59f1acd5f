#include "gvd/pipeline/parameters.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "gvd/common/error.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/units.h"

namespace gvd::pipeline {

using namespace gvd::scene;
using namespace gvd::distance;
using namespace gvd::grid;

namespace {

constexpr std::string_view kFrames[] = {"auto", "world"};
constexpr std::string_view kBackends[] = {"auto", "opencl", "cpu"};
constexpr std::string_view kOctreeBuilds[] = {"levels", "data-parallel"};
constexpr std::string_view kDistances[] = {"exact", "wavefront"};
constexpr std::string_view kRefines[] = {"certified", "paper"};
constexpr std::string_view kResolutions[] = {"compact", "full"};
constexpr std::string_view kJunctions[] = {"on", "off"};
constexpr std::string_view kModes[] = {"adaptive", "grid"};
constexpr std::string_view kMetrics[] = {"l2", "l1", "linf"};
constexpr std::string_view kVolumeFaces[] = {"merged", "voxel"};

constexpr unsigned kAll = kCliFlag | kJobParam | kPythonKeyword;
constexpr unsigned kLocal = kCliFlag | kPythonKeyword;  // the server sets these itself
constexpr unsigned kJob = kCliFlag | kJobParam;
// The grid's parameters: gvd compute --mode grid and gvd grid on a scene, a grid job,
// gvd.grid; and, sampling a saved result, gvd grid RESULT.gvd, the field.npy query of an
// adaptive job and Result.grid.
constexpr unsigned kSceneGrid = kCliFlag | kGridFlag | kJobParam | kPythonGrid;
constexpr unsigned kResultGrid = kResultGridFlag | kGridQuery | kPythonResultGrid;
constexpr double kIntMax = std::numeric_limits<int>::max();

// The table. Per-dimension defaults are {2D, 3D}; the engine applies them
// (resolve_max_depth, resolve_contact_depth, compute_gvd's refinement options,
// compute_grid's range cells), and ParamTable.* checks that they agree.
const ParamSpec kParams[] = {
    {.name = "max_depth",
     .kind = ParamKind::kInt,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .min = 0,
     .max = 31,
     .value = 0,
     .by_dimension = true,
     .per_dimension = {26, 21},
     .metavar = "N",
     .help = "deepest octree level; 0 = the default, 21 in 3D is the lattice's limit"},
    {.name = "contact_depth",
     .kind = ParamKind::kInt,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .min = 0,
     .max = 31,
     .value = 0,
     .by_dimension = true,
     .per_dimension = {14, 8},
     .metavar = "N",
     .help = "depth at which refinement between touching or intersecting objects stops"},
    {.name = "domain",
     .kind = ParamKind::kBox,
     .mode = ParamMode::kAny,
     .surfaces = kAll | kSceneGrid | kResultGrid,
     .metavar = "x0,y0[,z0],x1,y1[,z1]",
     .help = "domain box (made a cube); default: bounding box + 5 % padding",
     .grid_help = "domain box; it must hold every vertex (default: bounding box + 5 % of its "
                  "longest side on every side; from RESULT.gvd: the result's domain)"},
    {.name = "frame",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .choices = kFrames,
     .help = "the octree's axes: auto (default) turns them to the scene's faces in 3D when "
             "more of their area lies square to another frame than to x, y, z (a tilted part: "
             "its straight rims then cost what they cost untilted) and shifts the domain "
             "within its padding (and grows it by up to 10 %) to put shafts' corners on octree "
             "planes; world keeps x, y, z and the plain bounding cube. Results are in your "
             "coordinates either way"},
    {.name = "threads",
     .kind = ParamKind::kInt,
     .mode = ParamMode::kAny,
     .surfaces = kLocal | kGridFlag | kPythonGrid | kResultGridFlag | kPythonResultGrid,
     .min = 0,
     .max = kIntMax,
     .value = 0,
     .metavar = "N",
     .help = "worker threads (default 0: all cores)",
     .grid_help = "threads of the CPU twin, or of sampling a result (default 0: all cores)"},
    {.name = "backend",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAny,
     .surfaces = kLocal | kGridFlag | kPythonGrid,
     .choices = kBackends,
     .help = "where the data-parallel steps run (default auto: OpenCL when a device with fp64 "
             "exists, else the CPU twins, saying why; an explicit opencl without one is an "
             "error, exit 3). The device: GVD_OPENCL_DEVICE=\"P:D\" or a name part; kernel "
             "binary cache: GVD_KERNEL_CACHE_DIR (default $XDG_CACHE_HOME/gvd/kernels)",
     .grid_help = "where the per-range kernel runs (default auto, as for compute)"},
    {.name = "octree_build",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAdaptive,
     .surfaces = kLocal,
     .choices = kOctreeBuilds,
     .help = "first octree: level by level (default) or the data-parallel Karras/conflict-cell "
             "build (on OpenCL with that backend); the same leaves"},
    {.name = "distance",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAdaptive,
     .surfaces = kLocal,
     .choices = kDistances,
     .help = "closest points of the vertices of empty cells: exact for every vertex (default; "
             "data-parallel) or the paper's wavefront expansion (§4, serial, within 3/2 of the "
             "truth)"},
    {.name = "refine",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .choices = kRefines,
     .help = "where objects come close: certified pair cells (default: a cell is not split "
             "where exact distances prove that the GVD in it is the plane between two flat "
             "patches or mirror images, or a curve swept along a straight rim parallel or "
             "square to an axis (a shaft's corner too, once --frame auto put it on an octree "
             "plane), so thin gaps cost what their geometry needs) or the paper's rule alone "
             "(§3: cells shrink to the gap over the whole contact)"},
    {.name = "junctions",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .choices = kJunctions,
     .help = "3D, with certified refinement: also certify cells where three or more objects "
             "meet along a straight line along an axis (packed boxes, a part in the corner of "
             "two others), their GVD the sections' plane GVD swept along it, so such lines cost "
             "what their sections cost instead of length/gap (default on; off: the earlier "
             "rules alone)"},
    {.name = "resolution",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .choices = kResolutions,
     .help = "GVD output: flat parts merged into large pieces (default; the dual graph is "
             "measured before) or one piece per octree leaf, as surfaced"},
    {.name = "curved_tolerance",
     .kind = ParamKind::kNumber,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .min = 0,
     .max = 1,
     .value = 0,
     .metavar = "F",
     .help = "with compact output, merge curved parts too while they stay within F of the "
             "local clearance of the surfaced GVD and clear of every object by half of it "
             "(default 0: flat parts only)"},
    {.name = "ambiguity_levels",
     .kind = ParamKind::kInt,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .min = -1,
     .max = 31,
     .value = -1,
     .by_dimension = true,
     .per_dimension = {31, 2},
     .metavar = "N",
     .help = "levels of ambiguity refinement below the §3 octree; -1 = the default, 31 in 2D "
             "is as deep as the octree goes"},
    {.name = "ambiguity_rounds",
     .kind = ParamKind::kInt,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .min = -1,
     .max = 1000,
     .value = -1,
     .by_dimension = true,
     .per_dimension = {48, 3},
     .metavar = "N",
     .help = "rounds of ambiguity refinement; -1 = the default, 48 in 2D is every round"},
    {.name = "unseen_rounds",
     .kind = ParamKind::kInt,
     .mode = ParamMode::kAdaptive,
     .surfaces = kAll,
     .min = -1,
     .max = 1000,
     .value = -1,
     .by_dimension = true,
     .per_dimension = {48, 4},
     .metavar = "N",
     .help = "rounds that refine cells hiding a thin region of another object; -1 = the "
             "default"},
    {.name = "max_leaves",
     .kind = ParamKind::kCount,
     .mode = ParamMode::kAdaptive,
     .surfaces = kLocal,
     .min = 0,
     .value = 12'000'000,
     .metavar = "N",
     .help = "octree leaf limit (default 12000000; peak memory is up to about 1 KB per leaf, "
             "200-700 B on large scenes); it "
             "also bounds the cells' simplex lists (8 references per leaf), which many objects "
             "sharing cells fill"},
    {.name = "max_objects",
     .kind = ParamKind::kCount,
     .mode = ParamMode::kAny,
     .surfaces = kLocal | kGridFlag,
     .min = 0,
     .value = 100'000,
     .metavar = "N",
     .help = "object limit (default 100000)"},
    {.name = "max_simplices",
     .kind = ParamKind::kCount,
     .mode = ParamMode::kAny,
     .surfaces = kLocal | kGridFlag,
     .min = 0,
     .value = 20'000'000,
     .metavar = "N",
     .help = "simplex limit (default 20000000)"},
    {.name = "units",
     .kind = ParamKind::kUnits,
     .mode = ParamMode::kAny,
     .surfaces = kJob | kGridFlag | kResultGridFlag,
     .metavar = "U",
     .help = "the length unit of the coordinates: nm, um (= µm), mm, cm, m, km, in, ft or Å; "
             "over a scene JSON's own \"units\" (meshes and volumes have none). A label only, "
             "nothing is scaled: every length reported says it (graph, queries, info, GLB "
             "extras). Queries and export also take it for a saved result",
     .grid_help = "the length unit of the coordinates (as for compute: over the scene's or "
                  "result's own \"units\"); a NRRD output says it as \"space units\" (a .npy "
                  "has no place for it)"},
    {.name = "spacing",
     .kind = ParamKind::kSpacing,
     .mode = ParamMode::kAny,
     .surfaces = kJob,
     .metavar = "X,Y[,Z]",
     .help = "--volume: the voxel size on each axis (default 1; anisotropic voxels are "
             "honoured throughout)",
     .of_volume = true},
    {.name = "background",
     .kind = ParamKind::kLabel,
     .mode = ParamMode::kAny,
     .surfaces = kJob,
     .value = 0,
     .metavar = "N|none",
     .help = "--volume: the label that is no object (default 0; none: every label is one)",
     .of_volume = true},
    // A local flag only: the server's volumes take the default, as the merged surface is the
    // same surface in fewer triangles.
    {.name = "volume_faces",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAny,
     .surfaces = kCliFlag,
     .choices = kVolumeFaces,
     .help = "--volume: a label's boundary as merged faces (default: coplanar voxel faces as "
             "rectangles, collinear pixel edges as segments) or voxel (two triangles per "
             "voxel face, one segment per pixel edge); the same surface",
     .of_volume = true},
    {.name = "mode",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kAny,
     .surfaces = kJob,
     .choices = kModes,
     .help = "adaptive (default): the octree pipeline; grid: the discrete GVD on a uniform "
             "grid and its dual graph (see \"grid options\")"},
    {.name = "resolution",
     .kind = ParamKind::kInt,
     .mode = ParamMode::kGrid,
     .surfaces = kSceneGrid | kResultGrid,
     .min = 1,
     .max = 1 << 20,
     .value = 0,
     .metavar = "N",
     .help = "cells along the longest side of the domain (cells are cubes; the other sides "
             "get as many as cover them)",
     .keyword_value = 256},
    {.name = "metric",
     .kind = ParamKind::kChoice,
     .mode = ParamMode::kGrid,
     .surfaces = kSceneGrid | kResultGrid,
     .choices = kMetrics,
     .help = "the distance (default l2)"},
    {.name = "float64",
     .kind = ParamKind::kFlag,
     .mode = ParamMode::kGrid,
     .surfaces = kSceneGrid | kResultGrid,
     .value = 0,
     .help = "distances as float64"},
    {.name = "unsigned",
     .kind = ParamKind::kFlag,
     .mode = ParamMode::kGrid,
     .surfaces = kSceneGrid | kResultGrid,
     .value = 0,
     .help = "no signs (by default distances are negative inside closed objects)",
     .keyword = "signed",
     .keyword_negated = true},
    {.name = "range_cells",
     .kind = ParamKind::kInt,
     .mode = ParamMode::kGrid,
     .surfaces = kSceneGrid,
     .min = 0,
     .max = 4096,
     .value = 0,
     .by_dimension = true,
     .per_dimension = {8, 4},
     .metavar = "N",
     .help = "cells along a side of a culling range (0 = the default)"},
    {.name = "max_cells",
     .kind = ParamKind::kCount,
     .mode = ParamMode::kGrid,
     .surfaces = kCliFlag | kGridFlag | kPythonGrid | kResultGridFlag | kPythonResultGrid,
     .min = 0,
     .value = 134'217'728,
     .metavar = "N",
     .help = "refuse grids of more cells (default 134217728; checked before any work, exit 4)"},
};

[[noreturn]] void bad(const std::string& detail) {
  throw Error(ErrorCode::kInvalidArgument, detail);
}

std::string quoted(std::string_view text) { return "\"" + std::string(text) + "\""; }

// "a or b", "a, b or c".
std::string alternatives(std::span<const std::string_view> choices) {
  std::string out;
  for (size_t i = 0; i < choices.size(); ++i) {
    if (i > 0) out += i + 1 == choices.size() ? " or " : ", ";
    out += choices[i];
  }
  return out;
}

std::string mode_words(ComputeMode mode, ParamSpelling spelling) {
  const std::string_view name = kModes[static_cast<size_t>(mode)];
  switch (spelling) {
    case ParamSpelling::kCli:
      return "--mode " + std::string(name);
    case ParamSpelling::kServer:
      return "mode=" + std::string(name);
    case ParamSpelling::kApi:
      break;
  }
  return "mode " + std::string(name);
}

int parse_int(const ParamSpec& spec, std::string_view text, ParamSpelling spelling) {
  int v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end) {
    bad(spelled(spec, spelling) + " must be an integer, got " + quoted(text));
  }
  if (v < spec.min || v > spec.max) {
    bad(spelled(spec, spelling) + " must be between " + std::to_string(int(spec.min)) + " and " +
        std::to_string(int(spec.max)) + ", got " + std::string(text));
  }
  return v;
}

uint64_t parse_count(const ParamSpec& spec, std::string_view text, ParamSpelling spelling) {
  uint64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end || double(v) < spec.min) {
    bad(spelled(spec, spelling) + " must be a non-negative integer, got " + quoted(text));
  }
  return v;
}

double parse_number(const ParamSpec& spec, std::string_view text, ParamSpelling spelling) {
  double v = -1;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end || !(v >= spec.min && v < spec.max)) {
    char range[64];
    std::snprintf(range, sizeof range, "[%g, %g)", spec.min, spec.max);
    bad(spelled(spec, spelling) + " must be a number in " + range + ", got " + quoted(text));
  }
  return v;
}

bool parse_flag(const ParamSpec& spec, std::string_view text, ParamSpelling spelling) {
  if (text == "1" || text == "true") return true;
  if (text == "0" || text == "false") return false;
  bad(spelled(spec, spelling) + " is true or false (1 or 0), got " + quoted(text));
}

/// Comma-separated finite numbers (all > 0 when `positive`); nullopt at the first item that
/// is not one.
std::optional<std::vector<double>> parse_numbers(std::string_view text, bool positive) {
  std::vector<double> numbers;
  size_t start = 0;
  while (start <= text.size()) {
    size_t stop = text.find(',', start);
    if (stop == std::string_view::npos) stop = text.size();
    const std::string_view item = text.substr(start, stop - start);
    double v = 0;
    const char* end = item.data() + item.size();
    const auto [ptr, ec] = std::from_chars(item.data(), end, v);
    if (item.empty() || ec != std::errc() || ptr != end || !std::isfinite(v) ||
        (positive && v <= 0)) {
      return std::nullopt;
    }
    numbers.push_back(v);
    start = stop + 1;
  }
  return numbers;
}

std::vector<double> parse_box(const ParamSpec& spec, std::string_view text,
                              ParamSpelling spelling) {
  const std::optional<std::vector<double>> box = parse_numbers(text, false);
  if (!box) {
    bad(spelled(spec, spelling) + " must be numbers x0,y0[,z0],x1,y1[,z1], got " + quoted(text));
  }
  if (box->size() != 4 && box->size() != 6) {
    bad(spelled(spec, spelling) + " needs 4 (2D) or 6 (3D) numbers, got " +
        std::to_string(box->size()));
  }
  return *box;
}

std::vector<double> parse_spacing(const ParamSpec& spec, std::string_view text,
                                  ParamSpelling spelling) {
  const std::optional<std::vector<double>> spacing = parse_numbers(text, true);
  if (!spacing) {
    bad(spelled(spec, spelling) + " must be positive numbers x,y[,z], got " + quoted(text));
  }
  return *spacing;  // one per axis of the volume: label_volume_options, once it is read
}

std::optional<uint64_t> parse_label(const ParamSpec& spec, std::string_view text,
                                    ParamSpelling spelling) {
  if (text == "none") return std::nullopt;
  uint64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end) {
    bad(spelled(spec, spelling) + " is a label (an integer >= 0) or none, got " + quoted(text));
  }
  return v;
}

// The box of a domain (x0,y0[,z0],x1,y1[,z1]; check() has refused any other), z = 0 in 2D.
Box box_of(const std::vector<double>& domain) {
  const size_t d = domain.size() / 2;
  Box b;
  Vec3 lo, hi;
  for (size_t i = 0; i < d; ++i) {
    lo[static_cast<int>(i)] = domain[i];
    hi[static_cast<int>(i)] = domain[d + i];
  }
  b.extend(lo);
  b.extend(hi);
  return b;
}

// Where each entry's value lives in PipelineParams: one function per kind, so that set() and
// is_default() read the same slot.
struct Slot {
  int* i = nullptr;
  uint64_t* count = nullptr;
  double* number = nullptr;
  bool* flag = nullptr;
  std::vector<double>* numbers = nullptr;  // kBox, kSpacing
  std::optional<uint64_t>* label = nullptr;
  std::string* text = nullptr;
  int choice = -1;  // the current choice (kChoice)
  void (*set_choice)(PipelineParams&, int) = nullptr;
};

template <class E>
Slot choice_slot(E& field, void (*set)(PipelineParams&, int)) {
  Slot s;
  s.choice = static_cast<int>(field);
  s.set_choice = set;
  return s;
}

Slot slot_of(PipelineParams& p, const ParamSpec& spec) {
  const std::string_view n = spec.name;
  Slot s;
  if (n == "max_depth")
    s.i = &p.max_depth;
  else if (n == "contact_depth")
    s.i = &p.contact_depth;
  else if (n == "domain")
    s.numbers = &p.domain;
  else if (n == "frame")
    s = choice_slot(p.frame, [](PipelineParams& q, int c) { q.frame = DomainFrame(c); });
  else if (n == "threads")
    s.i = &p.threads;
  else if (n == "backend")
    s = choice_slot(p.backend, [](PipelineParams& q, int c) { q.backend = BackendRequest(c); });
  else if (n == "octree_build")
    s = choice_slot(p.octree_build,
                    [](PipelineParams& q, int c) { q.octree_build = OctreeBuild(c); });
  else if (n == "distance")
    s = choice_slot(p.distance, [](PipelineParams& q, int c) { q.distance = DistanceMethod(c); });
  else if (n == "refine")
    s = choice_slot(p.refine, [](PipelineParams& q, int c) { q.refine = RefineRule(c); });
  else if (n == "junctions")
    s = choice_slot(p.junctions, [](PipelineParams& q, int c) { q.junctions = JunctionCells(c); });
  else if (n == "resolution" && spec.kind == ParamKind::kChoice)
    s = choice_slot(p.resolution,
                    [](PipelineParams& q, int c) { q.resolution = GvdResolution(c); });
  else if (n == "resolution")
    s.i = &p.grid_resolution;
  else if (n == "curved_tolerance")
    s.number = &p.curved_tolerance;
  else if (n == "ambiguity_levels")
    s.i = &p.ambiguity_levels;
  else if (n == "ambiguity_rounds")
    s.i = &p.ambiguity_rounds;
  else if (n == "unseen_rounds")
    s.i = &p.unseen_rounds;
  else if (n == "max_leaves")
    s.count = &p.max_leaves;
  else if (n == "max_objects")
    s.count = &p.max_objects;
  else if (n == "max_simplices")
    s.count = &p.max_simplices;
  else if (n == "units")
    s.text = &p.units;
  else if (n == "mode")
    s = choice_slot(p.mode, [](PipelineParams& q, int c) { q.mode = ComputeMode(c); });
  else if (n == "metric")
    s = choice_slot(p.metric, [](PipelineParams& q, int c) { q.metric = GridMetric(c); });
  else if (n == "float64")
    s.flag = &p.float64;
  else if (n == "unsigned")
    s.flag = &p.unsigned_distance;
  else if (n == "range_cells")
    s.i = &p.range_cells;
  else if (n == "max_cells")
    s.count = &p.max_cells;
  else if (n == "spacing")
    s.numbers = &p.spacing;
  else if (n == "background")
    s.label = &p.background;
  else if (n == "volume_faces")
    s = choice_slot(p.volume_faces,
                    [](PipelineParams& q, int c) { q.volume_faces = VolumeFaces(c); });
  GVD_CHECK(s.i || s.count || s.number || s.flag || s.numbers || s.label || s.text || s.set_choice,
            "every parameter of the table has a field in PipelineParams");
  return s;
}

bool all_digits(std::string_view text) {
  return !text.empty() && text.find_first_not_of("0123456789") == std::string_view::npos;
}

}  // namespace

std::span<const ParamSpec> pipeline_parameters() { return kParams; }

const ParamSpec* find_parameter(std::string_view name, ParamMode mode) {
  for (const ParamSpec& p : kParams) {
    if (p.name == name && (mode == ParamMode::kAny || p.mode == mode)) return &p;
  }
  return nullptr;
}

const ParamSpec* find_parameter_on(std::string_view name, ParamSurface surface) {
  for (const ParamSpec& p : kParams) {
    if (p.name == name && p.on(surface)) return &p;
  }
  return nullptr;
}

const ParamSpec& choice_spec(std::string_view name) {
  for (const ParamSpec& p : kParams) {
    if (p.name == name && p.kind == ParamKind::kChoice) return p;
  }
  GVD_CHECK(false, "a choice parameter of the table");
  return kParams[0];
}

std::string flag_name(const ParamSpec& spec) {
  std::string flag = "--" + std::string(spec.name);
  for (char& c : flag) {
    if (c == '_') c = '-';
  }
  return flag;
}

std::string spelled(const ParamSpec& spec, ParamSpelling spelling) {
  switch (spelling) {
    case ParamSpelling::kCli:
      return flag_name(spec);
    case ParamSpelling::kServer:
      return "parameter " + quoted(spec.name);
    case ParamSpelling::kApi:
      break;
  }
  return std::string(spec.name);
}

std::string default_text(const ParamSpec& spec) {
  switch (spec.kind) {
    case ParamKind::kInt:
      return std::to_string(int(spec.value));
    case ParamKind::kCount:
      return std::to_string(uint64_t(spec.value));
    case ParamKind::kNumber: {
      char text[32];
      std::snprintf(text, sizeof text, "%g", spec.value);
      return text;
    }
    case ParamKind::kFlag:
      return spec.value != 0 ? "true" : "false";
    case ParamKind::kChoice:
      return std::string(spec.choices.front());
    case ParamKind::kLabel:
      return std::to_string(uint64_t(spec.value));
    case ParamKind::kBox:
    case ParamKind::kUnits:
    case ParamKind::kSpacing:
      break;
  }
  return "";
}

int parse_choice_index(const ParamSpec& spec, std::string_view text, ParamSpelling spelling) {
  for (size_t i = 0; i < spec.choices.size(); ++i) {
    if (spec.choices[i] == text) return static_cast<int>(i);
  }
  bad(spelled(spec, spelling) + " must be " + alternatives(spec.choices) + ", got " + quoted(text));
}

void PipelineParams::set(std::string_view name, std::string_view text, ParamSpelling spelling) {
  // The surface that spells the name takes only its own parameters (the server sets threads,
  // backend and the limits itself); the API takes all.
  const unsigned surfaces = spelling == ParamSpelling::kServer ? unsigned{kJobParam}
                            : spelling == ParamSpelling::kCli  ? unsigned{kCliFlag}
                                                               : ~0u;
  set(name, text, spelling, surfaces);
}

void PipelineParams::set(std::string_view name, std::string_view text, ParamSpelling spelling,
                         unsigned surfaces) {
  // The entries of that name the surfaces take: one, or both "resolution"s.
  const ParamSpec* spec = nullptr;
  const ParamSpec* cells = nullptr;  // the grid's "resolution" when the adaptive one is taken too
  for (const ParamSpec& p : kParams) {
    if (p.name != name || (p.surfaces & surfaces) == 0) continue;
    if (spec == nullptr) {
      spec = &p;
    } else {
      cells = &p;
    }
  }
  if (spec == nullptr) {
    std::string known;
    std::vector<std::string_view> listed;  // "resolution" once
    for (const ParamSpec& p : kParams) {
      if ((p.surfaces & surfaces) == 0 ||
          std::find(listed.begin(), listed.end(), p.name) != listed.end())
        continue;
      listed.push_back(p.name);
      known += (known.empty() ? "" : ", ") +
               (spelling == ParamSpelling::kCli ? flag_name(p) : std::string(p.name));
    }
    bad("unknown parameter " + quoted(name) + " (known: " + known + ")");
  }
  if (cells != nullptr && all_digits(text)) {
    spec = cells;  // a cell count: mode=grid (check())
  } else if (cells != nullptr &&
             std::find(spec->choices.begin(), spec->choices.end(), text) == spec->choices.end()) {
    bad(spelled(*spec, spelling) + " must be compact or full (" +
        mode_words(ComputeMode::kAdaptive, spelling) +
        "), or a number of cells along the longest side (" +
        mode_words(ComputeMode::kGrid, spelling) + "), got " + quoted(text));
  }
  const Slot s = slot_of(*this, *spec);
  switch (spec->kind) {
    case ParamKind::kInt:
      *s.i = parse_int(*spec, text, spelling);
      break;
    case ParamKind::kCount:
      *s.count = parse_count(*spec, text, spelling);
      break;
    case ParamKind::kNumber:
      *s.number = parse_number(*spec, text, spelling);
      break;
    case ParamKind::kFlag:
      *s.flag = parse_flag(*spec, text, spelling);
      break;
    case ParamKind::kChoice:
      s.set_choice(*this, parse_choice_index(*spec, text, spelling));
      break;
    case ParamKind::kBox:
      *s.numbers = parse_box(*spec, text, spelling);
      break;
    case ParamKind::kUnits:
      *s.text = parse_units(text, spelled(*spec, spelling), ErrorCode::kInvalidArgument);
      break;
    case ParamKind::kSpacing:
      *s.numbers = parse_spacing(*spec, text, spelling);
      break;
    case ParamKind::kLabel:
      *s.label = parse_label(*spec, text, spelling);
      break;
  }
}

double PipelineParams::number_of(const ParamSpec& spec) const {
  const Slot s = slot_of(const_cast<PipelineParams&>(*this), spec);
  if (s.i) return *s.i;
  if (s.count) return double(*s.count);
  if (s.number) return *s.number;
  if (s.flag) return *s.flag ? 1 : 0;
  GVD_CHECK(false, "number_of: a numeric parameter");
  return 0;
}

std::string_view PipelineParams::choice_of(const ParamSpec& spec) const {
  const Slot s = slot_of(const_cast<PipelineParams&>(*this), spec);
  GVD_CHECK(s.set_choice != nullptr, "choice_of: a choice parameter");
  return spec.choices[static_cast<size_t>(s.choice)];
}

bool PipelineParams::is_default(const ParamSpec& spec) const {
  const Slot s = slot_of(const_cast<PipelineParams&>(*this), spec);
  switch (spec.kind) {
    case ParamKind::kInt:
      return *s.i == spec.value;
    case ParamKind::kCount:
      return double(*s.count) == spec.value;
    case ParamKind::kNumber:
      return *s.number == spec.value;
    case ParamKind::kFlag:
      return *s.flag == (spec.value != 0);
    case ParamKind::kChoice:
      return s.choice == 0;
    case ParamKind::kBox:
    case ParamKind::kSpacing:
      return s.numbers->empty();
    case ParamKind::kUnits:
      return s.text->empty();
    case ParamKind::kLabel:
      return *s.label == uint64_t(spec.value);
  }
  return true;
}

void PipelineParams::check_ranges(ParamSpelling spelling) const {
  for (const ParamSpec& p : kParams) {
    if (is_default(p)) continue;  // an unset value (0, -1) may lie outside the range
    const Slot s = slot_of(const_cast<PipelineParams&>(*this), p);
    if (p.kind == ParamKind::kInt && (*s.i < p.min || *s.i > p.max)) {
      bad(spelled(p, spelling) + " must be between " + std::to_string(int(p.min)) + " and " +
          std::to_string(int(p.max)) + ", got " + std::to_string(*s.i));
    }
    if (p.kind == ParamKind::kNumber && !(*s.number >= p.min && *s.number < p.max)) {
      char range[64];
      std::snprintf(range, sizeof range, "[%g, %g), got %g", p.min, p.max, *s.number);
      bad(spelled(p, spelling) + " must be a number in " + range);
    }
  }
}

void PipelineParams::check(int dimension, ParamSpelling spelling) const {
  const ParamSpec& box = *find_parameter("domain");
  if (!domain.empty() && domain.size() != static_cast<size_t>(2 * dimension)) {
    bad(spelled(box, spelling) + " needs " + std::to_string(2 * dimension) + " numbers for a " +
        std::to_string(dimension) + "D scene");
  }
  for (size_t i = 0; i < domain.size() / 2; ++i) {
    if (!(domain[i] < domain[i + domain.size() / 2])) {
      bad(spelled(box, spelling) + ": the lower corner must be below the upper corner");
    }
  }
  const ParamSpec& cells = *find_parameter("resolution", ParamMode::kGrid);
  if (is_grid() && grid_resolution < 1) {
    bad(spelled(cells, spelling) + ": " + mode_words(ComputeMode::kGrid, spelling) +
        " needs the number of cells along the longest side of the domain");
  }
  if (!is_grid() && grid_resolution != 0) {
    bad(spelled(cells, spelling) + " = " + std::to_string(grid_resolution) +
        " (a cell count) needs " + mode_words(ComputeMode::kGrid, spelling) +
        "; the adaptive mode takes compact or full");
  }
  for (const ParamSpec& p : kParams) {
    if (p.mode == ParamMode::kAny || &p == &cells || is_default(p)) continue;
    if (is_grid() && p.mode == ParamMode::kAdaptive) {
      bad(spelled(p, spelling) + " applies to the adaptive octree; " +
          mode_words(ComputeMode::kGrid, spelling) + " computes on a uniform grid");
    }
    if (!is_grid() && p.mode == ParamMode::kGrid) {
      bad(spelled(p, spelling) + " goes with " + mode_words(ComputeMode::kGrid, spelling));
    }
  }
  if (!is_grid()) {
    const int limit = lattice_bits(dimension);
    if (max_depth > limit) {
      bad(spelled(*find_parameter("max_depth"), spelling) + " " + std::to_string(max_depth) +
          " is beyond the lattice limit " + std::to_string(limit) + " of a " +
          std::to_string(dimension) + "D scene");
    }
  }
}

std::string parameter_help(ParamMode mode, ParamSurface surface) {
  std::string out;
  for (const ParamSpec& p : kParams) {
    if (!p.on(surface) || p.of_volume) continue;
    const bool grid_text = surface == kGridFlag && mode == ParamMode::kGrid && !p.grid_help.empty();
    if (p.mode == mode || grid_text) out += flag_help(p, surface);
  }
  return out;
}

std::string flag_help(const ParamSpec& p, ParamSurface surface) {
  constexpr size_t kColumn = 29, kWidth = 93;
  std::string out;
  {
    std::string head = "  " + flag_name(p);
    if (p.kind == ParamKind::kChoice) {
      head += ' ';
      for (size_t i = 0; i < p.choices.size(); ++i)
        head += (i ? "|" : "") + std::string(p.choices[i]);
    } else if (p.kind != ParamKind::kFlag) {
      head += " " + std::string(p.metavar);
    }
    std::string text(surface == kGridFlag && !p.grid_help.empty() ? p.grid_help : p.help);
    if (p.by_dimension) {
      text += " (default " + std::to_string(int(p.per_dimension[0])) + " in 2D, " +
              std::to_string(int(p.per_dimension[1])) + " in 3D)";
    }
    // The head, then the words wrapped at kWidth from kColumn (on the next line when the
    // head is too long to share it).
    std::string line = head;
    if (line.size() + 1 > kColumn) {
      out += line + "\n";
      line.clear();
    }
    line.resize(kColumn, ' ');
    size_t start = 0;
    bool first = true;
    while (start < text.size()) {
      size_t stop = text.find(' ', start);
      if (stop == std::string::npos) stop = text.size();
      const std::string word = text.substr(start, stop - start);
      if (!first && line.size() + 1 + word.size() > kWidth) {
        out += line + "\n";
        line = std::string(kColumn, ' ');
        first = true;
      }
      line += (first ? "" : " ") + word;
      first = false;
      start = stop + 1;
    }
    out += line + "\n";
  }
  return out;
}

GridOptions grid_options(const PipelineParams& params) {
  GridOptions o;
  o.resolution = params.grid_resolution;
  o.metric = params.metric;
  o.signed_distance = !params.unsigned_distance;
  o.range_cells = params.range_cells;
  o.max_cells = params.max_cells;
  o.threads = params.threads;
  if (!params.domain.empty()) o.box = box_of(params.domain);
  return o;
}

ResultGridOptions result_grid_options(const PipelineParams& params) {
  ResultGridOptions o;
  o.resolution = params.grid_resolution;
  o.metric = params.metric;
  o.signed_distance = !params.unsigned_distance;
  o.max_cells = params.max_cells;
  o.threads = params.threads;
  if (!params.domain.empty()) o.box = box_of(params.domain);
  return o;
}

LabelVolumeOptions label_volume_options(const PipelineParams& params, int dimension,
                                        ParamSpelling spelling) {
  LabelVolumeOptions o;
  const size_t d = static_cast<size_t>(dimension);
  if (!params.spacing.empty() && params.spacing.size() != d) {
    bad(spelled(*find_parameter("spacing"), spelling) + " needs " + std::to_string(d) +
        " numbers for this " + std::to_string(d) + "D volume, got " +
        std::to_string(params.spacing.size()));
  }
  for (size_t a = 0; a < params.spacing.size(); ++a) o.spacing[a] = params.spacing[a];
  o.background = params.background;
  o.faces = params.volume_faces;
  return o;
}

PipelineOptions pipeline_options(const PipelineParams& params) {
  PipelineOptions o;
  o.max_depth = params.max_depth;
  o.contact_depth = params.contact_depth;
  o.ambiguity_levels = params.ambiguity_levels;
  o.ambiguity_rounds = params.ambiguity_rounds;
  o.unseen_rounds = params.unseen_rounds;
  o.threads = params.threads;
  o.max_leaves = params.max_leaves;
  o.octree_build = params.octree_build;
  o.distance = params.distance;
  o.refine = params.refine;
  o.junctions = params.junctions == JunctionCells::kOn;
  o.resolution = params.resolution;
  o.curved_tolerance = params.curved_tolerance;
  o.domain.frame = params.frame;
  if (!params.domain.empty()) o.domain.box = box_of(params.domain);
  return o;
}

}  // namespace gvd::pipeline

#include "usage.h"

#include <string_view>

#include "gvd/pipeline/parameters.h"

namespace gvd::cli {

using namespace gvd::scene;
using namespace gvd::pipeline;

namespace {

/// One command's synopsis in the usage's list: the command line, then what it does.
struct Synopsis {
  std::string_view command;
  std::string_view text;
};

constexpr Synopsis kSynopses[] = {
    {"compute", "  gvd compute SCENE... [options]   compute the GVD of a scene\n"},
    {"compute",
     R"(  gvd compute SCENE... --mode grid --resolution N [--graph FILE.json] [grid options]
                                   the discrete GVD on a uniform grid (CuRV) and its dual
                                   graph: interface area from the cell faces, gap and
                                   clearance exact (see "grid options")
)"},
    {"info",
     "  gvd info RESULT.gvd [--json]     depth, leaves, bytes per leaf, stage timings, warnings\n"},
    {"export",
     R"(  gvd export RESULT.gvd [-o FILE.glb] [--graph FILE.json] [--json FILE.json] [--units U]
                                   the outputs of compute from a saved result, without
                                   recomputing
)"},
    {"nearest",
     R"(  gvd nearest INPUT (--points FILE.json | --point x,y[,z]...) [--fast]
                                   nearest object, distance (signed, with inside, for
                                   closed objects), one JSON line per point
)"},
    {"neighbors",
     R"(  gvd neighbors INPUT --object LABEL [--ring K]
                                   objects within K rings of the dual graph (default 1)
)"},
    {"path",
     R"(  gvd path INPUT --from x,y[,z] --to x,y[,z] [--min-clearance R] [--cost shortest|clearance]
                                   a path on the GVD that crosses no object
)"},
    {"explode",
     R"(  gvd explode INPUT --anchor LABEL [-o FILE.glb] [--scale S] [--seconds T]
                                   exploded view: displacement per object (+ animated GLB)
)"},
    {"tight",
     "  gvd tight INPUT --below B        object pairs whose interface comes closer than B\n"},
    {"contacts",
     R"(  gvd contacts INPUT --max-gap G   object pairs closer than G (and every pair that touches or
                                   intersects): exact gap, closest points, interface area,
                                   contact sites; intersecting pairs' penetration depth
                                   (exact where both objects are convex)
)"},
    {"grid",
     R"(  gvd grid SCENE --resolution N (-o FIELD.npy | --labels LABELS.npy) [grid options]
                                   uniform-grid discrete GVD: distance and nearest object
                                   per cell (CuRV range culling, Sud et al. 2006)
)"},
    {"grid",
     R"(  gvd grid RESULT.gvd --resolution N (-o FIELD.npy | --labels LABELS.npy) [grid options]
                                   the same grid sampled from a saved adaptive result, exactly
                                   (see "grid options")
)"},
};

constexpr std::string_view kTitle = R"(gvd — generalized Voronoi diagrams of closely spaced objects

Usage:
)";

constexpr std::string_view kServerAndHelp =
    R"(  gvd --server URL COMMAND ...     the same commands against gvd-server (see "remote mode")
  gvd --help | --version
)";

constexpr std::string_view kInput = R"(
INPUT is a result saved with `compute --save`, or a scene (computed first; the compute
options below apply). Query answers are JSON on stdout (docs/FORMATS.md).
)";

// The same for one query's help, where the compute options are not listed.
constexpr std::string_view kQueryInput = R"(
INPUT is a result saved with `compute --save` (--units labels its lengths), or a scene,
computed first with any compute option (gvd compute --help). Query answers are JSON on
stdout (docs/FORMATS.md).
)";

constexpr std::string_view kScene = R"(
SCENE is the scene JSON ({"dimension":2|3,"objects":[...]}), an OBJ whose o/g groups are
the objects, a GLB/glTF with one node per object, or several PLY/STL/OFF/OBJ files, one
object each, labelled by file stem (gvd compute a.stl b.stl c.stl).
)";

constexpr std::string_view kOutputGlb =
    "  -o, --output FILE.glb      the GVD as binary glTF (one node per object, "
    "EXT_mesh_features)\n";
constexpr std::string_view kOutputGraph =
    R"(  --graph FILE.json          the dual graph (neighbouring objects, interface area, clearance,
                             gap between the objects, touching)
)";
constexpr std::string_view kOutputJson =
    "  --json FILE.json           the GVD with float64 coordinates (for gaps below float32 "
    "resolution)\n";
constexpr std::string_view kOutputSave =
    "  --save FILE.gvd            the whole result (octree, distance field, GVD, graph), "
    "reloadable\n";

constexpr std::string_view kVolume =
    R"(  --volume LABELS.npy        a labelled voxel volume instead of scene files: an integer .npy
                             (shape (ny, nx) or (nz, ny, nx), x fastest, as gvd grid writes);
                             each label becomes an object "label_<id>", its boundary the
                             voxel faces it shares with other labels or the background
)";

constexpr std::string_view kQuiet =
    "  -q, --quiet                no progress or summary on stderr\n";

constexpr std::string_view kGridOutputs =
    R"(  --graph FILE.json          compute --mode grid: the dual graph of the labels (objects whose
                             cells share a face; area = the shared faces; gap, touching and
                             clearance measured exactly on the objects, as in the adaptive
                             mode; Euclidean whatever --metric)
  -o, --output FILE          distance per cell (negative inside closed objects: closed
                             polygons in 2D, watertight meshes in 3D), float32 by default;
                             FILE.npy (numpy), FILE.nrrd (NRRD, data attached) or FILE.nhdr
                             (NRRD header + FILE.raw)
  --labels FILE              index of the nearest object per cell (int32, -1 = none), same
                             formats. Arrays are [y, x] (2D) / [z, y, x] (3D), x fastest
)";

constexpr std::string_view kGridFromResult =
    R"(  From RESULT.gvd (compute --save): the box defaults to the result's domain (a cube: N^D
  cells); each cell's search is bounded by the closest points stored on its octree leaf's
  vertices, then decided by exact distances to the scene's simplices. Guaranteed: the labels
  are the exact nearest object at every cell centre (exact ties: the lower index) and the
  distances exact (float32 in the file), the same cells as `gvd grid SCENE` over that box,
  bit for bit; not interpolated from the octree. --range-cells, --backend and the scene
  limits (--max-objects, --max-simplices) do not apply.
)";

/// The query options and the commands that read each.
constexpr Synopsis kQueryOptions[] = {
    {"nearest",
     "  --points FILE.json         points as [[x,y,z],...] or {\"points\":[...]} (\"-\" = "
     "stdin)\n"},
    {"nearest", "  --point x,y[,z]            one point (repeatable)\n"},
    {"nearest",
     R"(  --fast                     nearest: the octree leaf's answer where it is provably within
                             3/2 of the true distance, the paper's rule alone away from
                             objects (faster; the distance may exceed the true one, the
                             object may flip near a Voronoi boundary). Default: exact
)"},
    {"neighbors",
     "  --ring K                   rings around the object (default 1; large K = all reachable)\n"},
    {"path", "  --min-clearance R          passages narrower than R are not used (default 0)\n"},
    {"path",
     "  --cost shortest|clearance  path cost: length, or length / clearance (default shortest)\n"},
    {"explode",
     "  --scale S                  explode: displacement per ring (default: 1/4 of the mean "
     "object size)\n"},
    {"explode", "  --seconds T                explode: animation length of the GLB (default 2)\n"},
};

constexpr std::string_view kRemote =
    R"(
remote mode (--server URL, or the environment variable GVD_SERVER; --local ignores it):
  gvd --server http://host:8080 compute SCENE... [-o gvd.glb] [--graph g.json] [--json gvd.json]
        [--save r.gvd] [--no-wait]
                             submits the scene, prints the job id on stdout, shows the job's
                             progress, downloads the outputs asked for; --no-wait: only submit.
                             Job parameters: --max-depth, --contact-depth, --domain, --frame,
                             --ambiguity-levels, --ambiguity-rounds, --unseen-rounds, --refine,
                             --resolution, --curved-tolerance, --units (threads, backend and
                             limits are the server's own settings). --mode grid --resolution N [--metric,
                             --range-cells, --float64, --unsigned]: a grid job, whose outputs are
                             --graph, -o FIELD.npy and --labels LABELS.npy. --volume LABELS.npy
                             --spacing X,Y[,Z] [--background N|none]: a labelled volume (the
                             server needs --spacing)
  gvd --server URL neighbors|nearest|path|explode|tight|contacts --job ID [query options]
                             a query on a finished job; the same JSON on stdout as locally.
                             Scene files instead of --job ID: submitted and waited for first
  gvd --server URL info --job ID [--json]
                             the job's status, progress or result summary
  --job ID                   a job on the server (the id `compute` printed)
  --retries N                how often a busy server (503) is asked again, waiting what its
                             Retry-After says (default 5)
  --timeout S                seconds to connect and to wait for each answer (default 60)
)";

constexpr std::string_view kExitCodes = R"(
Exit codes: 0 ok, 1 internal error, 2 bad command line, 3 invalid input (scene, option,
format, or a point outside the domain), 4 limit exceeded, 5 file not readable/writable or
not found (also an unknown object label or job id), 6 cancelled, 7 no path joins the points,
8 server busy (still 503 after the retries) or job not finished yet, 9 network error (server
not reachable: connection refused, reset or timed out).
)";

bool is_query(std::string_view command) {
  for (std::string_view q : {"nearest", "neighbors", "path", "explode", "tight", "contacts"}) {
    if (command == q) return true;
  }
  return false;
}

std::string synopses_of(std::string_view command) {
  std::string out;
  for (const Synopsis& s : kSynopses) {
    if (s.command == command) out += s.text;
  }
  return out;
}

/// compute's options: its outputs, the table's flags of any mode, the labelled volume's
/// after --volume, the adaptive mode's, then --quiet.
std::string compute_options() {
  std::string volume;
  for (const ParamSpec& p : pipeline_parameters()) {
    if (p.of_volume && p.on(kCliFlag)) volume += flag_help(p);
  }
  return "\ncompute options:\n" + std::string(kOutputGlb) + std::string(kOutputGraph) +
         std::string(kOutputJson) + std::string(kOutputSave) + parameter_help(ParamMode::kAny) +
         std::string(kVolume) + volume + parameter_help(ParamMode::kAdaptive) + std::string(kQuiet);
}

/// The grid's options: its outputs, the table's grid flags (with the grid's own text where it
/// reads otherwise there), and what sampling a saved result guarantees.
std::string grid_options() {
  return "\ngrid options (gvd grid, and gvd compute --mode grid):\n" + std::string(kGridOutputs) +
         parameter_help(ParamMode::kGrid, kGridFlag) + std::string(kGridFromResult);
}

std::string query_options(std::string_view command) {
  std::string out;
  for (const Synopsis& o : kQueryOptions) {
    if (o.command == command) out += o.text;
  }
  return out;
}

}  // namespace

std::string usage() {
  std::string out(kTitle);
  for (const Synopsis& s : kSynopses) out += s.text;
  out += kServerAndHelp;
  out += kInput;
  out += kScene;
  out += compute_options();
  out += grid_options();
  out += "\nquery options:\n";
  for (const Synopsis& o : kQueryOptions) out += o.text;
  out += kRemote;
  out += kExitCodes;
  return out;
}

std::optional<std::string> command_usage(std::string_view command) {
  if (command == "neighbours") command = "neighbors";
  std::string out = synopses_of(command);
  if (out.empty()) return std::nullopt;
  out = "Usage:\n" + out;
  if (command == "compute") {
    out += kScene;
    out += compute_options();
    out += grid_options();
  } else if (command == "grid") {
    out += kScene;
    out += grid_options();
    out += kQuiet;
  } else if (command == "export") {
    out += "\noptions:\n" + std::string(kOutputGlb) + std::string(kOutputGraph) +
           std::string(kOutputJson);
    if (const ParamSpec* units = find_parameter("units")) out += flag_help(*units);
    out += kQuiet;
  } else if (command == "info") {
    out += "\n  --json                     the summary as one JSON document on stdout\n";
  } else if (is_query(command)) {
    out += kQueryInput;
    out += "\noptions:\n" + query_options(command) + std::string(kQuiet);
  }
  out += "\n  With --server URL: the same against gvd-server (gvd --help, \"remote mode\").\n";
  out += kExitCodes;
  return out;
}

}  // namespace gvd::cli

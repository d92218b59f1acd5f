// `gvd nearest | neighbors | path | explode | tight`: answers from a finished GVD (GvdIndex),
// read from a saved result or computed from a scene first.
#include <cstdio>
#include <iostream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "gvd/common/error.h"
#include "gvd/io/result_file.h"
#include "gvd/io/write_outputs.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/query/contact_report.h"
#include "gvd/query/gvd_index.h"

namespace gvd::cli {

using namespace gvd::scene;
using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::io;
using namespace gvd::pipeline;

bool is_result_file(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return false;
  char magic[6] = {};
  const size_t n = std::fread(magic, 1, sizeof magic, f);
  std::fclose(f);
  return n == sizeof magic && std::string(magic, sizeof magic) == "GVDRES";
}

namespace {

/// Parses the command line of a query: its own flags plus the compute flags.
Args parse_query(int argc, char** argv, std::vector<std::string> value_flags,
                 std::vector<std::string> boolean = {}) {
  value_flags.insert(value_flags.end(), compute_value_flags().begin(), compute_value_flags().end());
  boolean.insert(boolean.end(), {"-q", "--quiet"});
  return parse_args(argc, argv, 2, value_flags, boolean);
}

/// The index of the command's input: a saved result, or the GVD of a scene computed now.
GvdIndex load_index(const Args& args) {
  if (args.positional.empty() && !args.has("--volume"))
    throw UsageError{"give a result file (.gvd), a scene or --volume LABELS.npy"};
  std::shared_ptr<const GvdResult> result;
  if (args.positional.size() == 1 && is_result_file(args.positional[0])) {
    GvdResult loaded = load_result(args.positional[0]);
    apply_units(args, loaded.scene);
    result = std::make_shared<const GvdResult>(std::move(loaded));
  } else {
    ComputeSetup setup = compute_setup(args, args.positional);
    result = std::make_shared<const GvdResult>(compute_gvd(std::move(setup.scene), setup.options));
  }
  return GvdIndex(std::move(result));
}

/// A point from "x,y[,z]" of a flag value, with the dimension checked.
Vec3 point_arg(const std::string& flag, const std::string& text, int dimension) {
  const std::vector<double> v = point_value(flag, text, dimension);
  Vec3 p;
  for (size_t a = 0; a < v.size(); ++a) p[static_cast<int>(a)] = v[a];
  return p;
}

std::string read_text(const std::string& path) {
  if (path == "-") {
    return std::string(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
  }
  const std::vector<uint8_t> bytes = read_file_bytes(path);
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace

int cmd_nearest(int argc, char** argv) {
  const Args args = parse_query(argc, argv, {"--points", "--point"}, {"--fast"});
  if (!args.has("--points") && !args.has("--point")) {
    throw UsageError{"nearest needs --points FILE.json or --point x,y[,z]"};
  }
  const GvdIndex index = load_index(args);
  std::vector<Vec3> points;
  if (const auto file = args.value("--points")) {
    points = parse_points_json(read_text(*file), index.dimension());
  }
  if (args.has("--point")) {
    for (const std::string& text : args.flags.at("--point")) {
      points.push_back(point_arg("--point", text, index.dimension()));
    }
  }
  // Every point gets its line; one outside the domain gets an error entry (and says so on
  // stderr), and the exit status is then kExitBadInput.
  std::string out;
  size_t outside = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    try {
      out += nearest_to_json(index, index.nearest(points[i], args.has("--fast")));
    } catch (const Error& e) {
      if (e.code() != ErrorCode::kOutsideDomain) throw;
      out += nearest_error_to_json(index, points[i], e);
      std::fprintf(stderr, "gvd: point %zu: %s\n", i, e.detail().c_str());
      ++outside;
    }
    out += '\n';
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  return outside > 0 ? kExitBadInput : kExitOk;
}

int cmd_neighbors(int argc, char** argv) {
  const Args args = parse_query(argc, argv, {"--object", "--ring"});
  const std::string label = required_value(args, "--object");
  const int ring = args.int_value("--ring", 1);
  if (ring < 1) throw UsageError{"--ring must be at least 1"};
  const GvdIndex index = load_index(args);
  const ObjectId object = index.object(label);
  std::printf("%s\n",
              neighbors_to_json(index, object, ring, index.neighbors(object, ring)).c_str());
  return kExitOk;
}

int cmd_path(int argc, char** argv) {
  const Args args = parse_query(argc, argv, {"--from", "--to", "--min-clearance", "--cost"});
  const std::string from = required_value(args, "--from"), to = required_value(args, "--to");
  const GvdIndex index = load_index(args);
  PathQuery query;
  query.from = point_arg("--from", from, index.dimension());
  query.to = point_arg("--to", to, index.dimension());
  if (const auto r = args.numbers("--min-clearance")) {
    if (r->size() != 1 || (*r)[0] < 0) throw UsageError{"--min-clearance expects one number >= 0"};
    query.min_clearance = (*r)[0];
  }
  const std::string cost = args.value("--cost").value_or("shortest");
  if (cost == "shortest") {
    query.cost = PathCost::kShortest;
  } else if (cost == "clearance") {
    query.cost = PathCost::kClearance;
  } else {
    throw UsageError{"--cost is shortest or clearance, not \"" + cost + "\""};
  }
  const PathAnswer path = index.path(query);
  std::printf("%s\n", path_to_json(index, query, path).c_str());
  if (!path.found) {
    std::fprintf(stderr, "gvd: no path: %s\n", path.reason.c_str());
    return kExitNoPath;
  }
  return kExitOk;
}

int cmd_explode(int argc, char** argv) {
  const Args args = parse_query(argc, argv, {"--anchor", "-o", "--output", "--scale", "--seconds"});
  const std::string anchor = required_value(args, "--anchor");
  ExplodeOptions options;
  if (const auto s = args.numbers("--scale")) {
    if (s->size() != 1 || (*s)[0] <= 0) throw UsageError{"--scale expects one number > 0"};
    options.scale = (*s)[0];
  }
  double seconds = 2.0;
  if (const auto t = args.numbers("--seconds")) {
    if (t->size() != 1 || (*t)[0] <= 0) throw UsageError{"--seconds expects one number > 0"};
    seconds = (*t)[0];
  }
  const GvdIndex index = load_index(args);
  const ExplodedView view = index.explode(index.object(anchor), options);
  std::printf("%s\n", exploded_to_json(index, view).c_str());
  const auto glb_path = args.value("-o") ? args.value("-o") : args.value("--output");
  if (glb_path) {
    std::vector<Vec3> displacement;
    for (const ExplodedObject& o : view.objects) displacement.push_back(o.displacement);
    const std::vector<uint8_t> glb = exploded_to_glb(index.result().scene, displacement, seconds);
    write_file_atomic(*glb_path, glb.data(), glb.size());
    if (!args.has("-q") && !args.has("--quiet")) {
      std::fprintf(stderr, "gvd: wrote %s (animated exploded view, %.3g s)\n", glb_path->c_str(),
                   seconds);
    }
  }
  return kExitOk;
}

int cmd_tight(int argc, char** argv) {
  const Args args = parse_query(argc, argv, {"--below"});
  const auto below = args.numbers("--below");
  if (!below || below->size() != 1 || (*below)[0] < 0) {
    throw UsageError{"tight needs --below B (a distance >= 0)"};
  }
  const GvdIndex index = load_index(args);
  const std::vector<TightSpot> spots = index.tight((*below)[0]);
  std::printf("%s\n", tight_to_json(index, (*below)[0], spots).c_str());
  return kExitOk;
}

int cmd_contacts(int argc, char** argv) {
  const Args args = parse_query(argc, argv, {"--max-gap"});
  const auto bound = args.numbers("--max-gap");
  if (!bound || bound->size() != 1 || !((*bound)[0] >= 0)) {
    throw UsageError{"contacts needs --max-gap G (a distance >= 0)"};
  }
  const GvdIndex index = load_index(args);
  const std::vector<Contact> contacts = find_contacts(index, (*bound)[0]);
  std::printf("%s\n", contacts_to_json(index, (*bound)[0], contacts).c_str());
  return kExitOk;
}

}  // namespace gvd::cli

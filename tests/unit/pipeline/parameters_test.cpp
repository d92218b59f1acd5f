// The parameter table (gvd/pipeline/parameters.h): its defaults are the engine's, its choices
// the enums', its errors name the parameter as each surface spells it, and server/openapi.json
// documents every job parameter and every grid query parameter (field.npy, labels.npy) with
// the table's type, range, default and choices.

#include "gvd/pipeline/parameters.h"

#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "gvd/common/error.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/octree.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/label_volume.h"
#include "gvd/scene/units.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;
using namespace gvd::grid;
using namespace gvd::pipeline;

namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << e.detail();
    return e.detail();
  }
  ADD_FAILURE() << "no error";
  return "";
}

TEST(ParamTable, UnsetParametersHoldTheTablesDefaults) {
  const PipelineParams p;
  for (const ParamSpec& spec : pipeline_parameters()) {
    EXPECT_TRUE(p.is_default(spec)) << spec.name;
  }
  // The engine's option structs start from the same values.
  const PipelineOptions o;
  EXPECT_EQ(o.max_leaves, p.max_leaves);
  EXPECT_EQ(o.max_depth, p.max_depth);
  EXPECT_EQ(o.contact_depth, p.contact_depth);
  EXPECT_EQ(o.ambiguity_levels, p.ambiguity_levels);
  EXPECT_EQ(o.ambiguity_rounds, p.ambiguity_rounds);
  EXPECT_EQ(o.unseen_rounds, p.unseen_rounds);
  EXPECT_EQ(o.octree_build, p.octree_build);
  EXPECT_EQ(o.distance, p.distance);
  EXPECT_EQ(o.refine, p.refine);
  EXPECT_EQ(o.resolution, p.resolution);
  EXPECT_EQ(o.curved_tolerance, p.curved_tolerance);
  EXPECT_EQ(o.domain.frame, p.frame);
  const GridOptions g;
  EXPECT_EQ(g.max_cells, p.max_cells);
  EXPECT_EQ(g.metric, p.metric);
  EXPECT_EQ(g.range_cells, p.range_cells);
  EXPECT_EQ(g.signed_distance, !p.unsigned_distance);
  EXPECT_EQ(g.threads, p.threads);
  // The grid's resolution must be given (0 = not given), but gvd.grid's keyword defaults to
  // the engine's.
  EXPECT_EQ(find_parameter("resolution", ParamMode::kGrid)->keyword_value, g.resolution);
  const ResultGridOptions r;
  EXPECT_EQ(r.max_cells, p.max_cells);
  EXPECT_EQ(r.metric, p.metric);
  EXPECT_EQ(r.signed_distance, !p.unsigned_distance);
  EXPECT_EQ(r.resolution, g.resolution);
  const SceneLimits limits;
  EXPECT_EQ(limits.max_objects, p.max_objects);
  EXPECT_EQ(limits.max_simplices, p.max_simplices);
  const LabelVolumeOptions v;
  EXPECT_EQ(v.background, p.background);
  EXPECT_EQ(v.spacing, (std::array<double, 3>{1, 1, 1}));  // spacing empty: 1 on each axis
}

// grid_options, result_grid_options and label_volume_options carry every parameter they
// take, and nothing else is left at a default that differs from the table's.
TEST(ParamTable, GridAndVolumeOptionsAreMadeFromTheParameters) {
  PipelineParams p;
  p.set("mode", "grid", ParamSpelling::kServer);
  p.set("resolution", "40", ParamSpelling::kServer);
  p.set("metric", "linf", ParamSpelling::kServer);
  p.set("unsigned", "true", ParamSpelling::kServer);
  p.set("range_cells", "16", ParamSpelling::kServer);
  p.set("domain", "-1,-2,3,4", ParamSpelling::kServer);
  p.set("threads", "3", ParamSpelling::kCli);
  p.set("max_cells", "5000", ParamSpelling::kCli);
  ASSERT_NO_THROW(p.check(2, ParamSpelling::kCli));
  const GridOptions g = grid_options(p);
  EXPECT_EQ(g.resolution, 40);
  EXPECT_EQ(g.metric, GridMetric::kLinf);
  EXPECT_FALSE(g.signed_distance);
  EXPECT_EQ(g.range_cells, 16);
  EXPECT_EQ(g.threads, 3);
  EXPECT_EQ(g.max_cells, 5000u);
  ASSERT_TRUE(g.box.has_value());
  EXPECT_EQ(g.box->lo.x, -1);
  EXPECT_EQ(g.box->lo.y, -2);
  EXPECT_EQ(g.box->lo.z, 0);
  EXPECT_EQ(g.box->hi.x, 3);
  EXPECT_EQ(g.box->hi.y, 4);
  EXPECT_EQ(g.box->hi.z, 0);
  const ResultGridOptions r = result_grid_options(p);
  EXPECT_EQ(r.resolution, 40);
  EXPECT_EQ(r.metric, GridMetric::kLinf);
  EXPECT_FALSE(r.signed_distance);
  EXPECT_EQ(r.threads, 3);
  EXPECT_EQ(r.max_cells, 5000u);
  ASSERT_TRUE(r.box.has_value());
  EXPECT_EQ(r.box->hi.y, 4);
  EXPECT_FALSE(grid_options(PipelineParams{}).box.has_value());

  PipelineParams v;
  v.set("spacing", "0.5,2,3", ParamSpelling::kServer);
  v.set("background", "none", ParamSpelling::kServer);
  const LabelVolumeOptions o = label_volume_options(v, 3, ParamSpelling::kServer);
  EXPECT_EQ(o.spacing, (std::array<double, 3>{0.5, 2, 3}));
  EXPECT_FALSE(o.background.has_value());
  EXPECT_EQ(error_of([&] { (void)label_volume_options(v, 2, ParamSpelling::kCli); }),
            "--spacing needs 2 numbers for this 2D volume, got 3");
  v.set("background", "7", ParamSpelling::kCli);
  EXPECT_EQ(label_volume_options(v, 3, ParamSpelling::kApi).background, 7u);
  EXPECT_EQ(error_of([&] { v.set("spacing", "1,0", ParamSpelling::kCli); }),
            "--spacing must be positive numbers x,y[,z], got \"1,0\"");
  EXPECT_EQ(error_of([&] { v.set("background", "-1", ParamSpelling::kServer); }),
            "parameter \"background\" is a label (an integer >= 0) or none, got \"-1\"");
}

// A surface takes its own names only: the grid query of an adaptive job takes the sampling
// parameters (its resolution is a cell count, never compact|full), gvd grid no octree flag.
TEST(ParamTable, EachSurfaceTakesItsOwnNames) {
  PipelineParams p;
  EXPECT_EQ(error_of([&] { p.set("max_depth", "5", ParamSpelling::kServer, kGridQuery); }),
            "unknown parameter \"max_depth\" (known: domain, resolution, metric, float64, "
            "unsigned)");
  EXPECT_EQ(error_of([&] { p.set("resolution", "full", ParamSpelling::kServer, kGridQuery); }),
            "parameter \"resolution\" must be an integer, got \"full\"");
  p.set("resolution", "12", ParamSpelling::kServer, kGridQuery);
  EXPECT_EQ(p.grid_resolution, 12);
  EXPECT_NE(error_of([&] {
              p.set("refine", "paper", ParamSpelling::kCli, kGridFlag);
            }).find("unknown parameter \"refine\" (known: --domain, --threads, --backend"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              p.set("range_cells", "8", ParamSpelling::kCli, kResultGridFlag);
            }).find("unknown parameter \"range_cells\""),
            std::string::npos);
  // Where a surface takes both resolutions, the value's form decides (as before).
  p.set("resolution", "full", ParamSpelling::kCli, kCliFlag);
  EXPECT_EQ(p.resolution, GvdResolution::kFull);
  // Every entry is on some surface, and the flags of gvd grid are flags of gvd compute too
  // (--mode grid), so that `gvd --help` describes each once.
  for (const ParamSpec& spec : pipeline_parameters()) {
    SCOPED_TRACE(spec.name);
    EXPECT_NE(spec.surfaces, 0u);
    EXPECT_TRUE(!(spec.on(kGridFlag) || spec.on(kResultGridFlag)) || spec.on(kCliFlag));
    EXPECT_TRUE(!spec.on(kResultGridFlag) || spec.on(kGridFlag));
    EXPECT_TRUE(!spec.on(kGridQuery) || spec.on(kJobParam));
  }
}

TEST(ParamTable, PerDimensionDefaultsAreTheEngines) {
  const auto per_dim = [](std::string_view name, int dim) {
    const ParamSpec* p = find_parameter(name);
    EXPECT_TRUE(p != nullptr && p->by_dimension) << name;
    return static_cast<int>(p->per_dimension[static_cast<size_t>(dim - 2)]);
  };
  for (const int dim : {2, 3}) {
    const int depth = resolve_max_depth(dim, 0);
    EXPECT_EQ(per_dim("max_depth", dim), depth);
    EXPECT_EQ(per_dim("contact_depth", dim), resolve_contact_depth(dim, 0, lattice_bits(dim)));
  }
  // compute_gvd's refinement: every round and level in 2D; 3 rounds, 2 levels, 4 unseen
  // rounds in 3D.
  const PipelineOptions o;
  EXPECT_EQ(per_dim("ambiguity_rounds", 2), o.max_refine_rounds);
  EXPECT_EQ(per_dim("unseen_rounds", 2), o.max_refine_rounds);
  EXPECT_EQ(per_dim("ambiguity_levels", 2), lattice_bits(2));
  EXPECT_EQ(per_dim("ambiguity_rounds", 3), 3);
  EXPECT_EQ(per_dim("ambiguity_levels", 3), 2);
  EXPECT_EQ(per_dim("unseen_rounds", 3), 4);
  // The lattice limits the depth: the range's top is the 2D one.
  EXPECT_EQ(find_parameter("max_depth")->max, lattice_bits(2));
}

TEST(ParamTable, ChoicesAreTheEnumsInOrder) {
  for (const DomainFrame f : {DomainFrame::kAuto, DomainFrame::kWorld}) {
    EXPECT_EQ(parse_domain_frame(std::string(choice_name(f))), f);
    EXPECT_EQ(choice_name(f), domain_frame_name(f));
  }
  for (const GridMetric m : {GridMetric::kL2, GridMetric::kL1, GridMetric::kLinf}) {
    EXPECT_EQ(choice_name(m), grid_metric_name(m));
  }
  EXPECT_EQ(choice_name(RefineRule::kPaper), "paper");
  EXPECT_EQ(choice_name(GvdResolution::kFull), "full");
  EXPECT_EQ(choice_name(OctreeBuild::kDataParallel), "data-parallel");
  EXPECT_EQ(choice_name(DistanceMethod::kWavefront), "wavefront");
  EXPECT_EQ(choice_name(BackendRequest::kCpu), "cpu");
  EXPECT_EQ(choice_name(ComputeMode::kGrid), "grid");
  EXPECT_EQ(parse_choice<RefineRule>("certified"), RefineRule::kCertified);
  EXPECT_EQ(parse_choice<BackendRequest>("opencl"), BackendRequest::kOpenCl);
  EXPECT_EQ(error_of([] { (void)parse_choice<RefineRule>("sometimes"); }),
            "refine must be certified or paper, got \"sometimes\"");
}

TEST(ParamTable, ErrorsNameTheParameterAsEachSurfaceSpellsIt) {
  PipelineParams p;
  EXPECT_EQ(error_of([&] { p.set("max_depth", "12.5", ParamSpelling::kCli); }),
            "--max-depth must be an integer, got \"12.5\"");
  EXPECT_EQ(error_of([&] { p.set("max_depth", "99", ParamSpelling::kServer); }),
            "parameter \"max_depth\" must be between 0 and 31, got 99");
  EXPECT_EQ(error_of([&] { p.set("ambiguity_rounds", "1001", ParamSpelling::kCli); }),
            "--ambiguity-rounds must be between -1 and 1000, got 1001");
  EXPECT_EQ(error_of([&] { p.set("refine", "maybe", ParamSpelling::kCli); }),
            "--refine must be certified or paper, got \"maybe\"");
  EXPECT_EQ(error_of([&] { p.set("metric", "l3", ParamSpelling::kServer); }),
            "parameter \"metric\" must be l2, l1 or linf, got \"l3\"");
  EXPECT_EQ(error_of([&] { p.set("curved_tolerance", "1", ParamSpelling::kCli); }),
            "--curved-tolerance must be a number in [0, 1), got \"1\"");
  EXPECT_NE(error_of([&] {
              p.set("units", "furlong", ParamSpelling::kCli);
            }).find("--units must name a length unit"),
            std::string::npos);
  // The server sets threads, backend and the limits itself: not job parameters.
  EXPECT_NE(error_of([&] {
              p.set("threads", "4", ParamSpelling::kServer);
            }).find("unknown parameter \"threads\""),
            std::string::npos);
  p.set("threads", "4", ParamSpelling::kCli);
  EXPECT_EQ(p.threads, 4);
  p.set("octree_build", "data-parallel", ParamSpelling::kCli);
  EXPECT_EQ(p.octree_build, OctreeBuild::kDataParallel);
  p.set("domain", "0,0,1,1", ParamSpelling::kCli);
  EXPECT_EQ(error_of([&] { p.check(3, ParamSpelling::kCli); }),
            "--domain needs 6 numbers for a 3D scene");
  EXPECT_NO_THROW(p.check(2, ParamSpelling::kCli));
  PipelineParams deep;
  deep.set("max_depth", "25", ParamSpelling::kApi);
  EXPECT_NO_THROW(deep.check(2, ParamSpelling::kApi));
  EXPECT_EQ(error_of([&] { deep.check(3, ParamSpelling::kApi); }),
            "max_depth 25 is beyond the lattice limit 21 of a 3D scene");
}

TEST(ParamTable, ResolutionIsAChoiceOrACellCountAndModesKeepTheirOwn) {
  PipelineParams p;
  p.set("resolution", "full", ParamSpelling::kServer);
  EXPECT_EQ(p.resolution, GvdResolution::kFull);
  p.set("resolution", "64", ParamSpelling::kServer);
  EXPECT_EQ(p.grid_resolution, 64);
  EXPECT_NE(error_of([&] { p.check(2, ParamSpelling::kServer); }).find("needs mode=grid"),
            std::string::npos);
  p.set("mode", "grid", ParamSpelling::kCli);
  EXPECT_EQ(error_of([&] { p.check(2, ParamSpelling::kCli); }),
            "--resolution applies to the adaptive octree; --mode grid computes on a uniform grid");
  p.resolution = GvdResolution::kCompact;
  EXPECT_NO_THROW(p.check(2, ParamSpelling::kCli));
  PipelineParams a;
  a.set("float64", "true", ParamSpelling::kServer);
  EXPECT_EQ(error_of([&] { a.check(2, ParamSpelling::kServer); }),
            "parameter \"float64\" goes with mode=grid");
  EXPECT_NE(error_of([&] {
              a.set("resolution", "coarse", ParamSpelling::kServer);
            }).find("must be compact or full (mode=adaptive), or a number of cells"),
            std::string::npos);
}

TEST(ParamTable, HelpListsEveryFlagWithItsChoicesAndDefaults) {
  // The sections of `gvd --help`: compute's flags of any mode, the volume's, the adaptive
  // mode's, and the grid options (gvd grid and --mode grid).
  std::string volume;
  for (const ParamSpec& p : pipeline_parameters()) {
    if (p.of_volume) volume += flag_help(p);
  }
  const std::string grid = parameter_help(ParamMode::kGrid, kGridFlag);
  std::string help;  // the lines, runs of blanks and line breaks as one blank
  for (const char c :
       parameter_help(ParamMode::kAny) + volume + parameter_help(ParamMode::kAdaptive) + grid) {
    const char b = c == '\n' ? ' ' : c;
    if (!(b == ' ' && !help.empty() && help.back() == ' ')) help += b;
  }
  for (const ParamSpec& p : pipeline_parameters()) {
    if (!p.on(kCliFlag)) continue;
    EXPECT_NE(help.find(" " + flag_name(p) + " "), std::string::npos) << p.name;
    // gvd grid's flags are in the grid options, but those described under compute that
    // read the same there (the limits).
    if (p.on(kGridFlag) && (p.mode == ParamMode::kGrid || !p.grid_help.empty())) {
      EXPECT_NE(grid.find("  " + flag_name(p) + " "), std::string::npos) << p.name;
    }
    if (p.by_dimension) {
      const std::string d = "(default " + std::to_string(int(p.per_dimension[0])) + " in 2D, " +
                            std::to_string(int(p.per_dimension[1])) + " in 3D)";
      EXPECT_NE(help.find(d), std::string::npos) << p.name;
    }
  }
  EXPECT_NE(help.find(" --refine certified|paper "), std::string::npos) << help;
  EXPECT_NE(help.find(" --backend auto|opencl|cpu "), std::string::npos) << help;
  // The grid's box is not made a cube: its own text there.
  EXPECT_NE(grid.find("it must hold every vertex"), std::string::npos) << grid;
  EXPECT_EQ(grid.find("made a cube"), std::string::npos) << grid;
  EXPECT_EQ(grid.find("--refine"), std::string::npos) << grid;
}

// The query parameters of `method` `path` in server/openapi.json, by name.
std::map<std::string, nlohmann::json> documented_query(const std::string& path,
                                                       const std::string& method) {
  std::ifstream in(std::string(GVD_TEST_DATA_DIR) + "/../../server/openapi.json");
  EXPECT_TRUE(in.good());
  const nlohmann::json doc = nlohmann::json::parse(in);
  std::map<std::string, nlohmann::json> documented;
  for (const nlohmann::json& p : doc.at("paths").at(path).at(method).at("parameters")) {
    if (p.value("in", "") == "query") documented[p.at("name").get<std::string>()] = p.at("schema");
  }
  return documented;
}

// The table's parameters on `surface` are documented in `documented` with their type, range,
// default and choices; returns their names.
std::set<std::string> expect_documented(std::map<std::string, nlohmann::json>& documented,
                                        ParamSurface surface, const std::string& where) {
  std::set<std::string> table;
  for (const ParamSpec& p : pipeline_parameters()) {
    if (!p.on(surface)) continue;
    const std::string name(p.name);
    table.insert(name);
    if (!documented.count(name)) {
      ADD_FAILURE() << name << " is not documented for " << where << " in server/openapi.json";
      continue;
    }
    nlohmann::json schema = documented[name];
    if (schema.contains("oneOf")) {  // "resolution": compact|full or a cell count
      nlohmann::json mine;
      for (const nlohmann::json& s : schema["oneOf"]) {
        const bool is_choice = s.contains("enum");
        if (is_choice == (p.kind == ParamKind::kChoice)) mine = s;
      }
      schema = mine;
    }
    SCOPED_TRACE(where + " " + name + ": " + schema.dump());
    switch (p.kind) {
      case ParamKind::kInt:
        EXPECT_EQ(schema.value("type", ""), "integer");
        EXPECT_EQ(schema.value("minimum", -1e9), p.min);
        EXPECT_EQ(schema.value("maximum", -1e9), p.max);
        if (p.value >= p.min) {
          EXPECT_EQ(schema.value("default", -1e9), p.value);
        } else {
          EXPECT_FALSE(schema.contains("default"));  // unset means "not given"
        }
        break;
      case ParamKind::kNumber:
        EXPECT_EQ(schema.value("type", ""), "number");
        EXPECT_EQ(schema.value("minimum", -1e9), p.min);
        EXPECT_EQ(schema.value("exclusiveMaximum", -1e9), p.max);
        EXPECT_EQ(schema.value("default", -1e9), p.value);
        break;
      case ParamKind::kFlag:
        EXPECT_EQ(schema.value("type", ""), "boolean");
        EXPECT_EQ(schema.value("default", true), p.value != 0);
        break;
      case ParamKind::kChoice: {
        EXPECT_EQ(schema.value("type", ""), "string");
        std::vector<std::string> choices(p.choices.begin(), p.choices.end());
        EXPECT_EQ(schema.at("enum").get<std::vector<std::string>>(), choices);
        EXPECT_EQ(schema.value("default", ""), default_text(p));
        break;
      }
      case ParamKind::kBox:
        EXPECT_EQ(schema.value("type", ""), "string");
        break;
      case ParamKind::kUnits: {
        EXPECT_EQ(schema.value("type", ""), "string");
        for (const std::string& u : schema.at("enum").get<std::vector<std::string>>()) {
          EXPECT_TRUE(canonical_units(u).has_value()) << u;
        }
        break;
      }
      case ParamKind::kSpacing:
        EXPECT_EQ(schema.value("type", ""), "string");
        break;
      case ParamKind::kLabel:
        EXPECT_EQ(schema.value("type", ""), "string");  // an integer or "none"
        EXPECT_EQ(schema.value("default", ""), default_text(p));
        break;
      case ParamKind::kCount:
        ADD_FAILURE() << "no count is a job or query parameter";
        break;
    }
  }
  return table;
}

// The OpenAPI document's job parameters (POST /v1/jobs) are the table's: same names, types,
// ranges, defaults and choices, and none besides (but the label of a single-object upload).
TEST(ParamTable, OpenApiDocumentsEveryJobParameterAsTheTableSaysIt) {
  std::map<std::string, nlohmann::json> documented = documented_query("/v1/jobs", "post");
  const std::set<std::string> table = expect_documented(documented, kJobParam, "POST /v1/jobs");
  for (const auto& [name, schema] : documented) {
    if (name == "label") continue;
    EXPECT_TRUE(table.count(name)) << name << " is documented but not a job parameter";
  }
}

// The grid queries of an adaptive job (GET field.npy and labels.npy, which take one query
// string) take the table's kGridQuery parameters: documented as the table says them, none
// besides.
TEST(ParamTable, OpenApiDocumentsEveryGridQueryParameterAsTheTableSaysIt) {
  for (const std::string file : {"field.npy", "labels.npy"}) {
    const std::string path = "/v1/jobs/{id}/" + file;
    std::map<std::string, nlohmann::json> documented = documented_query(path, "get");
    const std::set<std::string> table = expect_documented(documented, kGridQuery, "GET " + path);
    for (const auto& [name, schema] : documented) {
      EXPECT_TRUE(table.count(name))
          << name << " is documented for " << path << " but not a grid query parameter";
    }
  }
}

}  // namespace
}  // namespace gvd

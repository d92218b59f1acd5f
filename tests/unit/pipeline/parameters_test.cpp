// The parameter table (gvd/pipeline/parameters.h): its defaults are the engine's, its choices
// the enums', its errors name the parameter as each surface spells it, and server/openapi.json
// documents every job parameter with the table's type, range, default and choices.

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
#include "gvd/grid/compute_grid.h"
#include "gvd/octree/octree.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/units.h"

namespace gvd {
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
  const SceneLimits limits;
  EXPECT_EQ(limits.max_objects, p.max_objects);
  EXPECT_EQ(limits.max_simplices, p.max_simplices);
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
  std::string help;  // the lines, runs of blanks and line breaks as one blank
  for (const char c : parameter_help(ParamMode::kAny) + parameter_help(ParamMode::kAdaptive) +
                          parameter_help(ParamMode::kGrid)) {
    const char b = c == '\n' ? ' ' : c;
    if (!(b == ' ' && !help.empty() && help.back() == ' ')) help += b;
  }
  for (const ParamSpec& p : pipeline_parameters()) {
    if (!p.on(kCliFlag)) continue;
    EXPECT_NE(help.find(" " + flag_name(p) + " "), std::string::npos) << p.name;
    if (p.by_dimension) {
      const std::string d = "(default " + std::to_string(int(p.per_dimension[0])) + " in 2D, " +
                            std::to_string(int(p.per_dimension[1])) + " in 3D)";
      EXPECT_NE(help.find(d), std::string::npos) << p.name;
    }
  }
  EXPECT_NE(help.find(" --refine certified|paper "), std::string::npos) << help;
  EXPECT_NE(help.find(" --backend auto|opencl|cpu "), std::string::npos) << help;
}

// The OpenAPI document's job parameters (POST /v1/jobs) are the table's: same names, types,
// ranges, defaults and choices, and none besides (but the labelled volume's and the label).
TEST(ParamTable, OpenApiDocumentsEveryJobParameterAsTheTableSaysIt) {
  std::ifstream in(std::string(GVD_TEST_DATA_DIR) + "/../../server/openapi.json");
  ASSERT_TRUE(in.good());
  const nlohmann::json doc = nlohmann::json::parse(in);
  std::map<std::string, nlohmann::json> documented;
  for (const nlohmann::json& p : doc.at("paths").at("/v1/jobs").at("post").at("parameters")) {
    if (p.value("in", "") == "query") documented[p.at("name").get<std::string>()] = p.at("schema");
  }
  std::set<std::string> table;
  for (const ParamSpec& p : pipeline_parameters()) {
    if (!p.on(kJobParam)) continue;
    const std::string name(p.name);
    table.insert(name);
    ASSERT_TRUE(documented.count(name)) << name << " is not in server/openapi.json";
    nlohmann::json schema = documented[name];
    if (schema.contains("oneOf")) {  // "resolution": compact|full or a cell count
      nlohmann::json mine;
      for (const nlohmann::json& s : schema["oneOf"]) {
        const bool is_choice = s.contains("enum");
        if (is_choice == (p.kind == ParamKind::kChoice)) mine = s;
      }
      schema = mine;
    }
    SCOPED_TRACE(name + ": " + schema.dump());
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
      case ParamKind::kCount:
        ADD_FAILURE() << "no count is a job parameter";
        break;
    }
  }
  for (const auto& [name, schema] : documented) {
    if (name == "spacing" || name == "background" || name == "label") continue;
    EXPECT_TRUE(table.count(name)) << name << " is documented but not a job parameter";
  }
}

}  // namespace
}  // namespace gvd

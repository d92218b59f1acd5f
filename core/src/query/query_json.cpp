// JSON bodies of the GvdIndex answers (docs/API.md), shared by the CLI and the server.
#include <cmath>
#include <nlohmann/json.hpp>

#include "gvd/common/error.h"
#include "gvd/common/json_depth.h"
#include "gvd/query/gvd_index.h"

namespace gvd::query {

using namespace gvd::scene;

namespace {

using nlohmann::json;

json point_json(Vec3 p, int dimension) {
  return dimension == 2 ? json::array({p.x, p.y}) : json::array({p.x, p.y, p.z});
}

const std::string& label(const GvdIndex& index, ObjectId object) {
  return index.result().scene.objects.at(object).label;
}

/// A number, or null when it is not finite (JSON has no infinity).
json number(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

/// An answer with the scene's length unit at its top level ("units"), when it has one.
std::string with_units(json doc, const GvdIndex& index) {
  const std::string& units = index.result().scene.units;
  if (!units.empty()) doc["units"] = units;
  return doc.dump();
}

}  // namespace

std::vector<Vec3> parse_points_json(std::string_view text, int dimension) {
  check_json_depth(text, "points", ErrorCode::kInvalidArgument);
  const json doc = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) {
    throw Error(ErrorCode::kInvalidArgument, "points: not valid JSON");
  }
  const json* list = &doc;
  if (doc.is_object()) {
    if (!doc.contains("points")) {
      throw Error(ErrorCode::kInvalidArgument, "points: expected an array or {\"points\": [...]}");
    }
    list = &doc["points"];
  }
  if (!list->is_array()) {
    throw Error(ErrorCode::kInvalidArgument, "points: expected an array of points");
  }
  std::vector<Vec3> out;
  out.reserve(list->size());
  for (size_t i = 0; i < list->size(); ++i) {
    const json& p = (*list)[i];
    const std::string where = "point " + std::to_string(i);
    const size_t n = p.is_array() ? p.size() : 0;
    if (!p.is_array() || (n != static_cast<size_t>(dimension) && !(dimension == 2 && n == 3))) {
      throw Error(ErrorCode::kInvalidArgument,
                  where + ": expected an array of " + std::to_string(dimension) + " numbers");
    }
    Vec3 v;
    for (size_t a = 0; a < n; ++a) {
      if (!p[a].is_number() || !std::isfinite(p[a].get<double>())) {
        throw Error(ErrorCode::kInvalidArgument,
                    where + ": coordinate " + std::to_string(a) + " is not a finite number");
      }
      v[static_cast<int>(a)] = p[a].get<double>();
    }
    if (dimension == 2 && v.z != 0) {
      throw Error(ErrorCode::kInvalidArgument, where + ": a 2D point has z = 0");
    }
    out.push_back(v);
  }
  return out;
}

std::string nearest_to_json(const GvdIndex& index, const NearestAnswer& answer) {
  const int dim = index.dimension();
  return with_units({{"point", point_json(answer.point, dim)},
                     {"object", answer.object},
                     {"label", label(index, answer.object)},
                     {"distance", answer.distance},
                     {"signed_distance", answer.signed_distance()},
                     {"inside", answer.inside < 0 ? json(nullptr) : json(answer.inside == 1)},
                     {"closest", point_json(answer.closest, dim)}},
                    index);
}

std::string nearest_error_to_json(const GvdIndex& index, Vec3 point, const Error& error) {
  return with_units(
      {{"point", point_json(point, index.dimension())},
       {"object", nullptr},
       {"label", nullptr},
       {"distance", nullptr},
       {"signed_distance", nullptr},
       {"inside", nullptr},
       {"closest", nullptr},
       {"error", {{"code", error_code_name(error.code())}, {"detail", error.detail()}}}},
      index);
}

std::string neighbors_to_json(const GvdIndex& index, ObjectId object, int ring,
                              std::span<const RingNeighbor> neighbors) {
  const int dim = index.dimension();
  json list = json::array();
  for (const RingNeighbor& n : neighbors) {
    list.push_back({{"object", n.object},
                    {"label", label(index, n.object)},
                    {"ring", n.ring},
                    {"via", n.via},
                    {"area", n.area},
                    {"min_clearance", n.min_clearance},
                    {"tightest_point", point_json(n.tightest_point, dim)},
                    {"gap", n.gap >= 0 ? json(n.gap) : json(nullptr)},
                    {"touching", n.touching}});
  }
  return with_units({{"object", object},
                     {"label", label(index, object)},
                     {"ring", ring},
                     {"neighbors", std::move(list)}},
                    index);
}

std::string path_to_json(const GvdIndex& index, const PathQuery& query, const PathAnswer& path) {
  const int dim = index.dimension();
  json points = json::array();
  for (const Vec3& p : path.points) points.push_back(point_json(p, dim));
  json out{{"from", point_json(query.from, dim)},
           {"to", point_json(query.to, dim)},
           {"points", std::move(points)},
           {"length", path.found ? number(path.length) : json(nullptr)},
           {"min_clearance", path.found ? number(path.min_clearance) : json(nullptr)},
           {"cost", query.cost == PathCost::kShortest ? "shortest" : "clearance"}};
  if (query.min_clearance > 0) out["required_clearance"] = query.min_clearance;
  if (!path.found) out["reason"] = path.reason;
  return with_units(std::move(out), index);
}

std::string exploded_to_json(const GvdIndex& index, const ExplodedView& view) {
  const int dim = index.dimension();
  json objects = json::array();
  for (const ExplodedObject& o : view.objects) {
    objects.push_back({{"object", o.object},
                       {"label", label(index, o.object)},
                       {"ring", o.ring},
                       {"direction", point_json(o.direction, dim)},
                       {"displacement", point_json(o.displacement, dim)},
                       {"factor", o.factor}});
  }
  return with_units({{"anchor", view.anchor},
                     {"label", label(index, view.anchor)},
                     {"scale", view.scale},
                     {"objects", std::move(objects)}},
                    index);
}

std::string tight_to_json(const GvdIndex& index, double below, std::span<const TightSpot> spots) {
  const int dim = index.dimension();
  json pairs = json::array();
  for (const TightSpot& t : spots) {
    pairs.push_back({{"a", t.a},
                     {"b", t.b},
                     {"label_a", label(index, t.a)},
                     {"label_b", label(index, t.b)},
                     {"min_clearance", t.min_clearance},
                     {"point", point_json(t.point, dim)},
                     {"gap", t.gap >= 0 ? json(t.gap) : json(nullptr)},
                     {"touching", t.touching}});
  }
  return with_units({{"below", below}, {"pairs", std::move(pairs)}}, index);
}

}  // namespace gvd::query

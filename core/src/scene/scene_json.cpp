// The native scene JSON (docs/FORMATS.md): parse, check the structure, validate;
// and write it back.
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/json_depth.h"
#include "gvd/common/json_input.h"
#include "gvd/scene/load_scene.h"
#include "gvd/scene/units.h"

namespace gvd::scene {

namespace {

using Json = nlohmann::json;

[[noreturn]] void invalid(std::string detail, ErrorLocation where = {}) {
  throw Error(ErrorCode::kInvalidScene, std::move(detail), std::move(where));
}

/// The location of objects[index] (and of one of its elements), with its JSON pointer.
ErrorLocation at(size_t index, const std::string& label, const std::string& pointer = "",
                 const char* element = "", size_t element_index = static_cast<size_t>(-1)) {
  return {static_cast<int64_t>(index), label, element,
          element_index == static_cast<size_t>(-1) ? -1 : static_cast<int64_t>(element_index),
          "/objects/" + std::to_string(index) + pointer};
}

std::string object_where(size_t index, const std::string& label) {
  return label.empty() ? "objects[" + std::to_string(index) + "]"
                       : "objects[" + std::to_string(index) + "] (\"" + label + "\")";
}

const char* type_name(const Json& j) { return j.type_name(); }

/// A value for an error message: short ones as they are, arrays and objects by their type
/// and size, long strings cut (never the whole of an unbounded value).
std::string brief(const Json& j) {
  if (j.is_array() || j.is_object()) {
    return std::string(j.is_array() ? "an array" : "an object") + " of " +
           std::to_string(j.size()) + (j.size() == 1 ? " element" : " elements");
  }
  std::string text = j.dump(-1, ' ', false, Json::error_handler_t::replace);
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return text;
}

/// An index of a simplex: a non-negative integral JSON number.
uint32_t read_index(const Json& j, const std::string& where, const ErrorLocation& loc) {
  if (j.is_number_unsigned()) {
    const uint64_t v = j.get<uint64_t>();
    if (v > 0xFFFFFFFFull) invalid(where + " = " + std::to_string(v) + " is out of range", loc);
    return static_cast<uint32_t>(v);
  }
  if (j.is_number_integer()) {
    invalid(where + " = " + std::to_string(j.get<int64_t>()) + " is negative", loc);
  }
  if (j.is_number_float()) {
    const double v = j.get<double>();
    if (v < 0) invalid(where + " = " + j.dump() + " is negative", loc);
    if (v != std::floor(v)) invalid(where + " = " + j.dump() + " is not an integer", loc);
    if (v > 4294967295.0) invalid(where + " = " + j.dump() + " is out of range", loc);
    return static_cast<uint32_t>(v);
  }
  invalid(where + " must be a vertex index (a non-negative integer), got " + type_name(j), loc);
}

/// a + b, or UINT64_MAX when that overflows (limits may be set as large as a user likes).
uint64_t saturating_add(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }
uint64_t saturating_mul(uint64_t a, uint64_t b) {
  return b != 0 && a > UINT64_MAX / b ? UINT64_MAX : a * b;
}

/// The first pass over a scene's JSON text, which builds nothing: counts the objects, vertices
/// and simplices of /objects and every JSON value, and stops at the first that passes its
/// limit. Only a document within the limits is then parsed into a DOM, about a hundred bytes
/// per value: the 66 MB body of 11M vertices took 10-15 s and 1.4 GB as a DOM before it was
/// refused. Driven by scan_json's events (the handler shape of nlohmann's SAX interface).
class SceneCounter {
 public:
  explicit SceneCounter(const SceneLimits& limits)
      : limits_(limits),
        max_vertices_(limits.vertex_limit()),
        max_values_(saturating_add(
            saturating_add(saturating_mul(4, saturating_add(max_vertices_, limits.max_simplices)),
                           saturating_mul(16, limits.max_objects)),
            kSpareValues)) {}

  /// A number, true, false or null.
  void literal() { element(); }
  /// A string value (its text as written, escapes and all).
  void string(std::string_view text) {
    if (depth_ == 3 && in_objects_ && key_ == "label") label_ = text;
    element();
  }
  void start(bool array) { open(array); }
  /// False when nothing is open (the text is malformed: the DOM parse will say where).
  bool end() { return close(); }
  void key(std::string_view text) {
    count_value();
    if (depth_ == 1) root_key_ = text;
    if (depth_ == 3) key_ = text;
  }

 private:
  /// Values besides those of the objects (the dimension, units, a request's params, ...).
  static constexpr uint64_t kSpareValues = 65536;
  enum class List { kNone, kVertices, kSimplices };

  /// An element starts at the current depth: a value, or an array or object opening.
  void element() {
    count_value();
    if (depth_ == 2 && in_objects_) {
      ++objects_;
      label_.clear();
      key_.clear();
      if (objects_ > limits_.max_objects) {
        throw Error(ErrorCode::kLimitExceeded,
                    "the scene has more than the limit of " + std::to_string(limits_.max_objects) +
                        " objects (objects[" + std::to_string(objects_ - 1) + "] is one too many)",
                    at(static_cast<size_t>(objects_ - 1), ""));
      }
    } else if (depth_ == 4 && list_ != List::kNone) {
      const size_t index = list_index_++;
      const size_t object = static_cast<size_t>(objects_ - 1);
      const auto pointer = [&] { return "/" + list_key_ + "/" + std::to_string(index); };
      if (list_ == List::kVertices && ++vertices_ > max_vertices_) {
        throw Error(ErrorCode::kLimitExceeded,
                    "the scene has more than the limit of " + std::to_string(max_vertices_) +
                        " vertices" + vertex_limit_note() + " (reached at " +
                        object_where(object, label_) + ")",
                    at(object, label_, pointer(), "vertex", index));
      }
      if (list_ == List::kSimplices && ++simplices_ > limits_.max_simplices) {
        throw Error(
            ErrorCode::kLimitExceeded,
            "the scene has more than the limit of " + std::to_string(limits_.max_simplices) +
                " simplices (reached at " + object_where(object, label_) + ")",
            at(object, label_, pointer(), list_key_ == "segments" ? "segment" : "triangle", index));
      }
    }
  }
  void open(bool array) {
    element();
    if (array && depth_ == 1 && root_key_ == "objects") in_objects_ = true;
    if (array && depth_ == 3 && in_objects_) {
      list_ = key_ == "vertices"                          ? List::kVertices
              : key_ == "segments" || key_ == "triangles" ? List::kSimplices
                                                          : List::kNone;
      list_key_ = key_;
      list_index_ = 0;
    }
    ++depth_;
  }
  bool close() {
    if (depth_ == 0) return false;
    --depth_;
    if (depth_ == 3) list_ = List::kNone;
    if (depth_ == 1) in_objects_ = false;
    return true;
  }
  void count_value() {
    if (++values_ > max_values_) {
      throw Error(ErrorCode::kLimitExceeded,
                  "the scene JSON holds more than " + std::to_string(max_values_) +
                      " values, more than the limits allow (4 per vertex and simplex, 16 per "
                      "object and " +
                      std::to_string(kSpareValues) + " besides)");
    }
  }
  std::string vertex_limit_note() const {
    return limits_.max_vertices != 0 ? ""
                                     : " (3 per simplex of the limit of " +
                                           std::to_string(limits_.max_simplices) + " simplices)";
  }
  const SceneLimits& limits_;
  uint64_t max_vertices_;
  uint64_t max_values_;
  size_t depth_ = 0;
  std::string root_key_;  ///< the last key of the top-level object
  std::string key_;       ///< the last key of the current object of /objects
  std::string list_key_;  ///< the key of the list being counted
  std::string label_;     ///< the current object's label, once read
  bool in_objects_ = false;
  List list_ = List::kNone;
  size_t list_index_ = 0;  ///< the next element's index in that list
  uint64_t objects_ = 0;
  uint64_t vertices_ = 0;
  uint64_t simplices_ = 0;
  uint64_t values_ = 0;
};

/// Walks JSON text as a stream of events for `counter` (SceneCounter): openings and closings,
/// keys, strings and other literals, without decoding anything (nlohmann's SAX parser, which
/// converts every number, took 0.56 s over 33 MB where this takes a tenth of that). It does not
/// check the grammar: it stops at the first thing that cannot be JSON (an unterminated string,
/// a closing with nothing open) and leaves malformed text to the DOM parse, which says where;
/// a malformed text over a limit may be refused for the limit instead. Iterative, so deep
/// nesting costs nothing here (parse_json_input refuses it).
void scan_json(std::string_view text, SceneCounter& counter) {
  const char* p = text.data();
  const char* const end = p + text.size();
  const auto is_delimiter = [](char c) {
    return c == ',' || c == ':' || c == ']' || c == '}' || c == ' ' || c == '\n' || c == '\r' ||
           c == '\t' || c == '[' || c == '{' || c == '"';
  };
  while (p < end) {
    switch (*p) {
      case ' ':
      case '\n':
      case '\r':
      case '\t':
      case ',':
      case ':':
        ++p;
        break;
      case '{':
      case '[':
        counter.start(*p == '[');
        ++p;
        break;
      case '}':
      case ']':
        if (!counter.end()) return;
        ++p;
        break;
      case '"': {
        const char* q = p + 1;
        for (;;) {
          q = static_cast<const char*>(std::memchr(q, '"', static_cast<size_t>(end - q)));
          if (q == nullptr) return;  // unterminated
          size_t backslashes = 0;
          while (q - backslashes > p + 1 && q[-1 - static_cast<ptrdiff_t>(backslashes)] == '\\') {
            ++backslashes;
          }
          if (backslashes % 2 == 0) break;
          ++q;
        }
        const std::string_view token(p + 1, static_cast<size_t>(q - p - 1));
        p = q + 1;
        const char* after = p;
        while (after < end &&
               (*after == ' ' || *after == '\n' || *after == '\r' || *after == '\t')) {
          ++after;
        }
        if (after < end && *after == ':') {
          counter.key(token);
        } else {
          counter.string(token);
        }
        break;
      }
      default:
        while (p < end && !is_delimiter(*p)) ++p;
        counter.literal();
        break;
    }
  }
}

}  // namespace

nlohmann::json parse_scene_json_value(std::string_view text, const SceneLimits& limits,
                                      const std::atomic<bool>* cancel) {
  SceneCounter counter(limits);
  scan_json(text, counter);
  return parse_json_input(text, "the scene", ErrorCode::kInvalidScene, cancel);
}

/// Builds and validates a scene from an already parsed native scene JSON document (shared with
/// the format sniffer of load_scene.cpp, which parses the text once).
Scene scene_from_json_value(const Json& doc, const SceneLimits& limits,
                            const std::atomic<bool>* cancel = nullptr);

Scene scene_from_json_value(const Json& doc, const SceneLimits& limits,
                            const std::atomic<bool>* cancel) {
  if (!doc.is_object())
    invalid(std::string("the scene must be a JSON object, got ") + type_name(doc));
  const auto dim_it = doc.find("dimension");
  if (dim_it == doc.end()) invalid("missing \"dimension\" (2 or 3)");
  if (!dim_it->is_number() || !(dim_it->get<double>() == 2.0 || dim_it->get<double>() == 3.0)) {
    invalid("\"dimension\" must be the number 2 or 3, got " + brief(*dim_it));
  }
  Scene scene;
  scene.dimension = dim_it->get<double>() == 2.0 ? 2 : 3;
  const int dim = scene.dimension;
  if (const auto units_it = doc.find("units"); units_it != doc.end()) {
    ErrorLocation where;
    where.pointer = "/units";
    if (!units_it->is_string()) {
      invalid(std::string("\"units\" must be a string naming a length unit (one of ") +
                  std::string(kKnownUnits) + "), got " + brief(*units_it),
              where);
    }
    scene.units =
        parse_units(units_it->get<std::string>(), "\"units\"", ErrorCode::kInvalidScene, where);
  }

  const auto objects_it = doc.find("objects");
  if (objects_it == doc.end()) invalid("missing \"objects\"");
  if (!objects_it->is_array()) {
    invalid(std::string("\"objects\" must be an array, got ") + type_name(*objects_it));
  }
  const Json& objects = *objects_it;
  if (objects.empty()) invalid("\"objects\" is empty: the scene has no objects");
  if (objects.size() > limits.max_objects) {
    throw Error(ErrorCode::kLimitExceeded, "the scene has " + std::to_string(objects.size()) +
                                               " objects, more than the limit of " +
                                               std::to_string(limits.max_objects));
  }
  uint64_t total_simplices = 0;
  const char* simplex_key = dim == 2 ? "segments" : "triangles";
  const char* wrong_key = dim == 2 ? "triangles" : "segments";
  const size_t arity = dim == 2 ? 2 : 3;

  scene.objects.reserve(objects.size());
  for (size_t oi = 0; oi < objects.size(); ++oi) {
    throw_if_cancelled(cancel, "reading the scene");
    const Json& o = objects[oi];
    if (!o.is_object()) {
      invalid(object_where(oi, "") + " must be a JSON object, got " + type_name(o), at(oi, ""));
    }
    SceneObject object;
    const auto label_it = o.find("label");
    if (label_it == o.end()) invalid(object_where(oi, "") + " has no \"label\"", at(oi, ""));
    if (!label_it->is_string()) {
      invalid(object_where(oi, "") + ": \"label\" must be a string, got " + brief(*label_it),
              at(oi, "", "/label"));
    }
    object.label = label_it->get<std::string>();
    if (object.label.empty()) {
      invalid(object_where(oi, "") + " has an empty label", at(oi, "", "/label"));
    }
    const std::string where = object_where(oi, object.label);

    if (o.contains(wrong_key)) {
      invalid(where + " has \"" + wrong_key + "\" but the scene is " + std::to_string(dim) +
                  "D (expected \"" + simplex_key + "\")",
              at(oi, object.label, std::string("/") + wrong_key));
    }
    const auto verts_it = o.find("vertices");
    if (verts_it == o.end()) invalid(where + " has no \"vertices\"", at(oi, object.label));
    if (!verts_it->is_array()) {
      invalid(where + ": \"vertices\" must be an array", at(oi, object.label, "/vertices"));
    }
    object.vertices.reserve(verts_it->size());
    for (size_t vi = 0; vi < verts_it->size(); ++vi) {
      const Json& v = (*verts_it)[vi];
      const std::string vwhere = where + ": vertices[" + std::to_string(vi) + "]";
      const ErrorLocation vloc =
          at(oi, object.label, "/vertices/" + std::to_string(vi), "vertex", vi);
      if (!v.is_array() || v.size() != static_cast<size_t>(dim)) {
        invalid(vwhere + " must be an array of " + std::to_string(dim) + " numbers, got " +
                    (v.is_array() ? std::to_string(v.size()) + " values" : type_name(v)),
                vloc);
      }
      Vec3 p;
      for (int c = 0; c < dim; ++c) {
        const Json& x = v[static_cast<size_t>(c)];
        if (!x.is_number()) {
          invalid(vwhere + "[" + std::to_string(c) + "] is not a number (" + brief(x) + ")", vloc);
        }
        p[c] = x.get<double>();
        if (!std::isfinite(p[c])) {
          invalid(vwhere + "[" + std::to_string(c) + "] is not finite", vloc);
        }
        if (std::fabs(p[c]) > limits.max_abs_coordinate) {
          invalid(vwhere + "[" + std::to_string(c) + "] = " + x.dump() +
                      " exceeds the limit of +-" + Json(limits.max_abs_coordinate).dump(),
                  vloc);
        }
      }
      object.vertices.push_back(p);
    }

    const auto simp_it = o.find(simplex_key);
    const std::string simplices_pointer = std::string("/") + simplex_key;
    if (simp_it == o.end()) {
      invalid(where + " has no \"" + simplex_key + "\"", at(oi, object.label));
    }
    if (!simp_it->is_array()) {
      invalid(where + ": \"" + simplex_key + "\" must be an array",
              at(oi, object.label, simplices_pointer));
    }
    if (simp_it->empty()) {
      invalid(where + " has no " + simplex_key + " (the array is empty)",
              at(oi, object.label, simplices_pointer));
    }
    total_simplices += simp_it->size();
    if (total_simplices > limits.max_simplices) {
      throw Error(ErrorCode::kLimitExceeded,
                  "the scene has more than the limit of " + std::to_string(limits.max_simplices) +
                      " simplices (reached at " + where + ")",
                  at(oi, object.label));
    }
    object.simplices.reserve(simp_it->size());
    for (size_t si = 0; si < simp_it->size(); ++si) {
      const Json& s = (*simp_it)[si];
      const std::string swhere = where + ": " + simplex_key + "[" + std::to_string(si) + "]";
      const std::string spointer = simplices_pointer + "/" + std::to_string(si);
      const char* element = dim == 2 ? "segment" : "triangle";
      if (!s.is_array() || s.size() != arity) {
        invalid(swhere + " must be an array of " + std::to_string(arity) + " vertex indices",
                at(oi, object.label, spointer, element, si));
      }
      Simplex simplex;
      for (size_t k = 0; k < arity; ++k) {
        const ErrorLocation kloc =
            at(oi, object.label, spointer + "/" + std::to_string(k), element, si);
        simplex.v[k] = read_index(s[k], swhere + "[" + std::to_string(k) + "]", kloc);
        if (simplex.v[k] >= object.vertices.size()) {
          invalid(swhere + "[" + std::to_string(k) + "] = " + std::to_string(simplex.v[k]) +
                      " is out of range (the object has " + std::to_string(object.vertices.size()) +
                      " vertices)",
                  kloc);
        }
      }
      object.simplices.push_back(simplex);
    }
    scene.objects.push_back(std::move(object));
  }
  validate_scene(scene, limits, cancel);
  return scene;
}

Scene parse_scene_json(std::string_view text, const SceneLimits& limits,
                       const std::atomic<bool>* cancel) {
  return scene_from_json_value(parse_scene_json_value(text, limits, cancel), limits, cancel);
}

std::string scene_to_json(const Scene& scene) {
  Json objects = Json::array();
  const int dim = scene.dimension;
  for (const SceneObject& object : scene.objects) {
    Json vertices = Json::array();
    for (const Vec3& p : object.vertices) {
      vertices.push_back(dim == 2 ? Json::array({p.x, p.y}) : Json::array({p.x, p.y, p.z}));
    }
    Json simplices = Json::array();
    for (const Simplex& s : object.simplices) {
      simplices.push_back(dim == 2 ? Json::array({s.v[0], s.v[1]})
                                   : Json::array({s.v[0], s.v[1], s.v[2]}));
    }
    objects.push_back({{"label", object.label},
                       {"vertices", std::move(vertices)},
                       {dim == 2 ? "segments" : "triangles", std::move(simplices)}});
  }
  Json doc = {{"dimension", dim}, {"objects", std::move(objects)}};
  if (!scene.units.empty()) doc["units"] = scene.units;  // none: no key (old job ids stay)
  // Labels come from files and may not be valid UTF-8: replace rather than throw.
  return doc.dump(-1, ' ', false, Json::error_handler_t::replace);
}

std::string warnings_to_json(const std::vector<SceneWarning>& warnings) {
  nlohmann::json array = nlohmann::json::array();
  for (const SceneWarning& w : warnings) {
    array.push_back({{"kind", warning_kind_name(w.kind)},
                     {"object", w.object},
                     {"count", w.count},
                     {"detail", w.detail}});
  }
  return array.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::vector<SceneWarning> warnings_from_json(std::string_view text) {
  check_json_depth(text, "the warnings", ErrorCode::kInvalidArgument);
  const nlohmann::json array = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
  if (!array.is_array())
    throw Error(ErrorCode::kInvalidArgument, "the warnings are not a JSON array");
  std::vector<SceneWarning> out;
  for (size_t i = 0; i < array.size(); ++i) {
    const nlohmann::json& w = array[i];
    const auto fail = [&](const std::string& why) {
      throw Error(ErrorCode::kInvalidArgument, "warning " + std::to_string(i) + ": " + why);
    };
    if (!w.is_object() || !w.contains("kind") || !w["kind"].is_string()) fail("no kind");
    const std::optional<WarningKind> kind = warning_kind_from_name(w["kind"].get<std::string>());
    if (!kind) fail("unknown kind \"" + w["kind"].get<std::string>().substr(0, 40) + "\"");
    const nlohmann::json& object = w.contains("object") ? w["object"] : nlohmann::json("");
    const nlohmann::json& count = w.contains("count") ? w["count"] : nlohmann::json(0);
    const nlohmann::json& detail = w.contains("detail") ? w["detail"] : nlohmann::json("");
    const bool count_ok =
        count.is_number_unsigned() || (count.is_number_integer() && count.get<int64_t>() >= 0);
    if (!object.is_string() || !count_ok || !detail.is_string())
      fail("object, count or detail of the wrong type");
    out.push_back(
        {*kind, object.get<std::string>(), count.get<uint64_t>(), detail.get<std::string>()});
  }
  return out;
}

}  // namespace gvd::scene

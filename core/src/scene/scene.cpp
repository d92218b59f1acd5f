#include "gvd/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/union_find.h"

namespace gvd::scene {

namespace {

constexpr std::pair<WarningKind, const char*> kWarningNames[] = {
    {WarningKind::kDegenerateSimplices, "degenerate_simplices"},
    {WarningKind::kOpenMesh, "open_mesh"},
    {WarningKind::kNonManifold, "non_manifold"},
    {WarningKind::kMultipleComponents, "multiple_components"},
    {WarningKind::kLabelsTouch, "labels_touch"},
    {WarningKind::kObjectsTouch, "objects_touch"},
    {WarningKind::kThinRegionsLeft, "thin_regions_left"},
    {WarningKind::kAmbiguousCellsLeft, "ambiguous_cells_left"},
    {WarningKind::kConesDropped, "cones_dropped"},
    {WarningKind::kReorientedTriangles, "reoriented_triangles"},
    {WarningKind::kFacesSnapped, "faces_snapped"},
};

/// Vertices or simplices validate_scene handles between two reads of the cancel flag (about a
/// millisecond of its slowest loop, the orientation's walk).
constexpr size_t kCancelGrain = size_t{1} << 15;
constexpr const char* kValidating = "validating the scene";

[[noreturn]] void invalid(std::string detail, ErrorLocation where = {}) {
  throw Error(ErrorCode::kInvalidScene, std::move(detail), std::move(where));
}

/// The location of object `index` (and of one of its elements).
ErrorLocation at(size_t index, const std::string& label, const char* element = "",
                 size_t element_index = static_cast<size_t>(-1)) {
  return {static_cast<int64_t>(index), label, element,
          element_index == static_cast<size_t>(-1) ? -1 : static_cast<int64_t>(element_index), ""};
}

std::string where(size_t index, const std::string& label) {
  return "object " + std::to_string(index) + " (\"" + label + "\")";
}

/// Relative tolerance of the degeneracy tests: twice the area of a triangle must exceed
/// this fraction of its longest squared edge (a height of 1e-14 of its length).
constexpr double kDegenerateTolerance = 1e-14;

bool is_degenerate(const SceneObject& object, const Simplex& s, int dimension) {
  const std::vector<Vec3>& p = object.vertices;
  if (dimension == 2) {
    return s.v[0] == s.v[1] || p[s.v[0]] == p[s.v[1]];
  }
  if (s.v[0] == s.v[1] || s.v[1] == s.v[2] || s.v[0] == s.v[2]) return true;
  // Relative to the triangle's own size, so that a scene drawn at 1e-100 (whose squared
  // lengths and cross products underflow) is judged as the same scene at 1.
  const Vec3 u = p[s.v[1]] - p[s.v[0]], w = p[s.v[2]] - p[s.v[0]];
  double size = 0;
  for (int i = 0; i < 3; ++i) size = std::max({size, std::abs(u[i]), std::abs(w[i])});
  if (!(size > 0)) return true;
  const Vec3 a = u / size, b = w / size;
  const double longest = std::max({norm2(a), norm2(b), dist2(a, b)});
  return norm(cross(a, b)) <= kDegenerateTolerance * longest;
}

}  // namespace

MeshTopology mesh_topology(const SceneObject& object, int dimension) {
  uint64_t open = 0, non_manifold = 0;
  if (dimension == 2) {
    std::vector<uint32_t> degree(object.vertices.size(), 0);
    for (const Simplex& s : object.simplices) {
      ++degree[s.v[0]];
      ++degree[s.v[1]];
    }
    for (uint32_t d : degree) {
      open += d == 1;
      non_manifold += d > 2;
    }
  } else {
    std::vector<std::pair<uint32_t, uint32_t>> edges;
    edges.reserve(object.simplices.size() * 3);
    for (const Simplex& s : object.simplices) {
      for (int i = 0; i < 3; ++i) {
        const uint32_t a = s.v[i], b = s.v[(i + 1) % 3];
        edges.emplace_back(std::min(a, b), std::max(a, b));
      }
    }
    std::sort(edges.begin(), edges.end());
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      while (j < edges.size() && edges[j] == edges[i]) ++j;
      open += (j - i) == 1;
      non_manifold += (j - i) > 2;
      i = j;
    }
  }
  return {open, non_manifold};
}

bool is_closed_object(const SceneObject& object, int dimension) {
  if (object.simplices.empty()) return false;
  const MeshTopology t = mesh_topology(object, dimension);
  return t.open == 0 && t.non_manifold == 0;
}

std::vector<uint32_t> triangles_across(const SceneObject& object, const std::atomic<bool>* cancel,
                                       const char* what) {
  const size_t n = object.simplices.size();
  // Sorted undirected edges, 16 bytes per triangle side (as mesh_topology's pairs).
  struct Side {
    uint64_t edge;
    uint32_t side;  ///< 3 * triangle + e
  };
  std::vector<Side> sides;
  sides.reserve(3 * n);
  for (uint32_t t = 0; t < n; ++t) {
    const Simplex& s = object.simplices[t];
    for (uint32_t e = 0; e < 3; ++e) {
      const uint32_t a = s.v[e], b = s.v[(e + 1) % 3];
      sides.push_back({uint64_t{std::min(a, b)} << 32 | std::max(a, b), 3 * t + e});
    }
  }
  throw_if_cancelled(cancel, what);
  std::sort(sides.begin(), sides.end(),
            [](const Side& x, const Side& y) { return x.edge < y.edge; });
  throw_if_cancelled(cancel, what);
  std::vector<uint32_t> across(3 * n, kNoNeighbour);
  for (size_t i = 0; i < sides.size();) {
    size_t j = i;
    while (j < sides.size() && sides[j].edge == sides[i].edge) ++j;
    if (j - i == 2) {
      across[sides[i].side] = sides[i + 1].side / 3;
      across[sides[i + 1].side] = sides[i].side / 3;
    }
    i = j;
  }
  return across;
}

namespace {

/// Makes the triangles of each edge-connected part of a 3D object agree in orientation: two
/// triangles that share an edge used by exactly those two must run it in opposite directions
/// (CAD and scan exports often flip some faces). In each part the orientation of the larger
/// area is kept and the other triangles are reversed; a part that cannot be oriented (a Moebius
/// strip) is left as it is. Returns the number of triangles reversed. Reads `cancel` between
/// its steps and every kCancelGrain triangles of the walk.
uint64_t orient_consistently(SceneObject& object, const std::atomic<bool>* cancel) {
  const size_t n = object.simplices.size();
  const std::vector<uint32_t> across = triangles_across(object, cancel, kValidating);
  // Whether triangles t and u (sharing an edge) run it the same way.
  auto same_way = [&](uint32_t t, uint32_t u) {
    const Simplex& a = object.simplices[t];
    const Simplex& b = object.simplices[u];
    for (int e = 0; e < 3; ++e)
      for (int f = 0; f < 3; ++f)
        if (a.v[e] == b.v[f] && a.v[(e + 1) % 3] == b.v[(f + 1) % 3]) return true;
    return false;
  };
  auto area = [&](uint32_t t) {
    const Simplex& s = object.simplices[t];
    const Vec3 a = object.vertices[s.v[0]];
    return norm(cross(object.vertices[s.v[1]] - a, object.vertices[s.v[2]] - a));
  };
  std::vector<int8_t> flip(n, -1);  // -1: not reached; 0 keep; 1 reverse (relative to seed)
  std::vector<uint32_t> part, stack;
  uint64_t reversed = 0;
  size_t walked = 0;
  for (uint32_t seed = 0; seed < n; ++seed) {
    if (flip[seed] >= 0) continue;
    part.clear();
    stack.assign(1, seed);
    flip[seed] = 0;
    bool orientable = true;
    double kept = 0, other = 0;
    while (!stack.empty()) {
      const uint32_t t = stack.back();
      stack.pop_back();
      if (++walked % kCancelGrain == 0) throw_if_cancelled(cancel, kValidating);
      part.push_back(t);
      (flip[t] ? other : kept) += area(t);
      for (int e = 0; e < 3; ++e) {
        const uint32_t u = across[3 * t + e];
        if (u == kNoNeighbour) continue;
        // Agreeing neighbours run the shared edge in opposite directions.
        const int8_t want = static_cast<int8_t>(flip[t] ^ (same_way(t, u) ? 1 : 0));
        if (flip[u] < 0) {
          flip[u] = want;
          stack.push_back(u);
        } else if (flip[u] != want) {
          orientable = false;
        }
      }
    }
    if (!orientable) continue;
    const int8_t reverse = other > kept ? 0 : 1;  // the smaller area's triangles turn
    for (uint32_t t : part) {
      if (flip[t] != reverse) continue;
      std::swap(object.simplices[t].v[1], object.simplices[t].v[2]);
      ++reversed;
    }
  }
  return reversed;
}

/// Structural warnings of one object (its simplices are valid and non-degenerate).
void add_topology_warnings(const SceneObject& object, int dimension,
                           std::vector<SceneWarning>& out) {
  const int arity = dimension == 2 ? 2 : 3;
  const auto [open, non_manifold] = mesh_topology(object, dimension);
  const char* unit = dimension == 2 ? "vertices" : "edges";
  if (open > 0) {
    out.push_back({WarningKind::kOpenMesh, object.label, open,
                   "object \"" + object.label + "\": " + std::to_string(open) + " boundary " +
                       unit + (dimension == 2 ? " (degree 1)" : " (used by one triangle)")});
  }
  if (non_manifold > 0) {
    out.push_back({WarningKind::kNonManifold, object.label, non_manifold,
                   "object \"" + object.label + "\": " + std::to_string(non_manifold) +
                       " non-manifold " + unit +
                       (dimension == 2 ? " (degree > 2)" : " (used by more than two triangles)")});
  }

  UnionFind uf(object.vertices.size());
  std::vector<char> used(object.vertices.size(), 0);
  for (const Simplex& s : object.simplices) {
    for (int i = 0; i < arity; ++i) used[s.v[i]] = 1;
    for (int i = 1; i < arity; ++i) uf.unite(s.v[0], s.v[i]);
  }
  uint64_t components = 0;
  for (uint32_t v = 0; v < object.vertices.size(); ++v) components += used[v] && uf.find(v) == v;
  if (components > 1) {
    out.push_back({WarningKind::kMultipleComponents, object.label, components,
                   "object \"" + object.label + "\" has " + std::to_string(components) +
                       " connected components"});
  }
}

}  // namespace

const char* warning_kind_name(WarningKind kind) {
  for (const auto& [k, name] : kWarningNames)
    if (k == kind) return name;
  return "unknown";
}

std::optional<WarningKind> warning_kind_from_name(std::string_view name) {
  for (const auto& [k, n] : kWarningNames)
    if (name == n) return k;
  return std::nullopt;
}

namespace {

bool is_topology_warning(const SceneWarning& w) {
  return w.kind == WarningKind::kOpenMesh || w.kind == WarningKind::kNonManifold ||
         w.kind == WarningKind::kMultipleComponents;
}

}  // namespace

uint64_t Scene::simplex_count() const {
  uint64_t n = 0;
  for (const SceneObject& o : objects) n += o.simplices.size();
  return n;
}

uint64_t Scene::vertex_count() const {
  uint64_t n = 0;
  for (const SceneObject& o : objects) n += o.vertices.size();
  return n;
}

std::optional<ObjectId> Scene::find(const std::string& label) const {
  for (size_t i = 0; i < objects.size(); ++i) {
    if (objects[i].label == label) return static_cast<ObjectId>(i);
  }
  return std::nullopt;
}

void validate_scene(Scene& scene, const SceneLimits& limits, const std::atomic<bool>* cancel) {
  if (scene.dimension != 2 && scene.dimension != 3) {
    invalid("dimension must be 2 or 3, got " + std::to_string(scene.dimension));
  }
  if (scene.objects.empty()) invalid("the scene has no objects");
  if (scene.objects.size() > limits.max_objects) {
    throw Error(ErrorCode::kLimitExceeded, "the scene has " + std::to_string(scene.objects.size()) +
                                               " objects, more than the limit of " +
                                               std::to_string(limits.max_objects));
  }
  if (scene.objects.size() >= kManyObjects) invalid("too many objects");
  const uint64_t simplices = scene.simplex_count();
  if (simplices > limits.max_simplices) {
    throw Error(ErrorCode::kLimitExceeded, "the scene has " + std::to_string(simplices) +
                                               " simplices, more than the limit of " +
                                               std::to_string(limits.max_simplices));
  }
  if (const uint64_t vertices = scene.vertex_count(); vertices > limits.vertex_limit()) {
    throw Error(
        ErrorCode::kLimitExceeded,
        "the scene has " + std::to_string(vertices) + " vertices, more than the limit of " +
            std::to_string(limits.vertex_limit()) +
            (limits.max_vertices != 0 ? std::string()
                                      : " (3 per simplex of the limit of " +
                                            std::to_string(limits.max_simplices) + " simplices)"));
  }

  std::unordered_map<std::string, size_t> first_index;
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const std::string& label = scene.objects[i].label;
    if (label.empty()) invalid("object " + std::to_string(i) + " has an empty label", at(i, ""));
    auto [it, inserted] = first_index.emplace(label, i);
    if (!inserted) {
      invalid("duplicate label \"" + label + "\": objects " + std::to_string(it->second) + " and " +
                  std::to_string(i),
              at(i, label));
    }
  }

  const int dim = scene.dimension;
  const int arity = dim == 2 ? 2 : 3;
  std::erase_if(scene.warnings, is_topology_warning);
  for (size_t oi = 0; oi < scene.objects.size(); ++oi) {
    throw_if_cancelled(cancel, kValidating);
    SceneObject& object = scene.objects[oi];
    if (object.vertices.size() > 0xFFFFFFFFull)
      invalid(where(oi, object.label) + ": too many vertices", at(oi, object.label));
    for (size_t vi = 0; vi < object.vertices.size(); ++vi) {
      if (vi % kCancelGrain == kCancelGrain - 1) throw_if_cancelled(cancel, kValidating);
      Vec3& p = object.vertices[vi];
      if (dim == 2) p.z = 0.0;
      for (int c = 0; c < dim; ++c) {
        if (!std::isfinite(p[c])) {
          invalid(where(oi, object.label) + ": vertex " + std::to_string(vi) + " coordinate " +
                      std::to_string(c) + " is not finite",
                  at(oi, object.label, "vertex", vi));
        }
        if (std::fabs(p[c]) > limits.max_abs_coordinate) {
          invalid(where(oi, object.label) + ": vertex " + std::to_string(vi) + " coordinate " +
                      std::to_string(c) + " = " + std::to_string(p[c]) +
                      " exceeds the limit of +-" + std::to_string(limits.max_abs_coordinate),
                  at(oi, object.label, "vertex", vi));
        }
      }
    }
    if (object.simplices.empty()) {
      invalid(where(oi, object.label) + " has no " + (dim == 2 ? "segments" : "triangles"),
              at(oi, object.label));
    }
    for (size_t si = 0; si < object.simplices.size(); ++si) {
      if (si % kCancelGrain == kCancelGrain - 1) throw_if_cancelled(cancel, kValidating);
      Simplex& s = object.simplices[si];
      if (dim == 2) s.v[2] = 0;
      for (int k = 0; k < arity; ++k) {
        if (s.v[k] >= object.vertices.size()) {
          invalid(where(oi, object.label) + ": " + (dim == 2 ? "segment " : "triangle ") +
                      std::to_string(si) + " vertex index " + std::to_string(s.v[k]) +
                      " is out of range (the object has " + std::to_string(object.vertices.size()) +
                      " vertices)",
                  at(oi, object.label, dim == 2 ? "segment" : "triangle", si));
        }
      }
    }
    const size_t before = object.simplices.size();
    std::erase_if(object.simplices,
                  [&](const Simplex& s) { return is_degenerate(object, s, dim); });
    const uint64_t removed = before - object.simplices.size();
    if (object.simplices.empty()) {
      invalid(where(oi, object.label) + ": all " + std::to_string(before) +
                  (dim == 2 ? " segments" : " triangles") + " are degenerate",
              at(oi, object.label));
    }
    if (removed > 0) {
      scene.warnings.push_back({WarningKind::kDegenerateSimplices, object.label, removed,
                                "object \"" + object.label + "\": removed " +
                                    std::to_string(removed) + " degenerate " +
                                    (dim == 2 ? "segments" : "triangles")});
    }
    if (dim == 3) {
      if (const uint64_t reversed = orient_consistently(object, cancel); reversed > 0) {
        scene.warnings.push_back(
            {WarningKind::kReorientedTriangles, object.label, reversed,
             "object \"" + object.label + "\": " + std::to_string(reversed) +
                 " triangles ran an edge the same way as their neighbour across it; reversed, "
                 "so that each connected part is oriented one way (as the larger area of it "
                 "was)"});
      }
    }
    throw_if_cancelled(cancel, kValidating);
    add_topology_warnings(object, dim, scene.warnings);
  }
}

bool Domain::aligned() const {
  return axis[0] == Vec3{1, 0, 0} && axis[1] == Vec3{0, 1, 0} && axis[2] == Vec3{0, 0, 1};
}

Vec3 Domain::to_unit(Vec3 p) const {
  Vec3 u;
  if (aligned()) {
    u = (p - origin) / side;
  } else {
    const Vec3 d = p - origin;
    u = Vec3{dot(d, axis[0]), dot(d, axis[1]), dot(d, axis[2])} / side;
  }
  if (dimension == 2) u.z = 0.0;
  return u;
}

Vec3 Domain::from_unit(Vec3 u) const {
  Vec3 p = aligned() ? origin + u * side
                     : origin + (axis[0] * u.x + axis[1] * u.y + axis[2] * u.z) * side;
  if (dimension == 2) p.z = 0.0;
  return p;
}

Box Domain::box() const {
  Box b;
  if (aligned()) {
    b.lo = origin;
    b.hi = origin + Vec3{side, side, dimension == 2 ? 0.0 : side};
  } else {
    for (int corner = 0; corner < 8; ++corner)
      b.extend(from_unit(Vec3{double(corner & 1), double(corner >> 1 & 1), double(corner >> 2)}));
  }
  if (dimension == 2) b.lo.z = b.hi.z = 0.0;
  return b;
}

bool Domain::contains(Vec3 p, double slack) const {
  const Vec3 u = to_unit(p);
  for (int i = 0; i < dimension; ++i)
    if (!(u[i] >= -slack && u[i] <= 1 + slack)) return false;
  return true;
}

DomainFrame parse_domain_frame(const std::string& name) {
  if (name == "auto") return DomainFrame::kAuto;
  if (name == "world") return DomainFrame::kWorld;
  throw Error(ErrorCode::kInvalidArgument, "the frame must be auto or world, got \"" + name + "\"");
}

const char* domain_frame_name(DomainFrame frame) {
  return frame == DomainFrame::kWorld ? "world" : "auto";
}

namespace {

/// How much larger than the padded bounds make_domain may make the cube to put a second
/// roof's apex on an axis on a lattice plane, and the finest level it may use.
constexpr double kMaxApexGrowth = 0.1;
constexpr int kMaxApexLevel = 12;
/// Coordinates within this of a lattice plane (unit domain) count as on it (the apexes are
/// found numerically).
constexpr double kOnPlane = 1e-9;

/// The side and lower corner (frame coordinates) of the cube around `bounds`: side0, centred,
/// with each axis' longest straddled rims' apex moved onto the nearest plane of level
/// kRimAlignLevel where the padding leaves room (its coordinate then maps to a multiple of
/// 2^-kRimAlignLevel, to within rounding). Where an axis has a second apex, a side up to
/// kMaxApexGrowth larger can put it on a plane of level <= kMaxApexLevel too: the side
/// d 2^L / n for their distance d. One side serves all axes, so of those sides the one that
/// puts the most rim length on planes wins (ties: the smaller side), and it is taken only when
/// it puts more there than side0 does.
std::pair<double, Vec3> align_to_apexes(const SceneFrame& frame, const Box& bounds, double side0) {
  const double step = std::ldexp(1.0, -kRimAlignLevel);
  auto layout = [&](double side, double* on_planes) {
    Vec3 lo = bounds.center() - Vec3{side, side, side} * 0.5;
    double length = 0;
    for (int i = 0; i < 3; ++i) {
      const std::vector<StraddledRims>& rims = frame.straddled[i];
      if (rims.empty()) continue;
      const double at = rims.front().apex;
      const double unit = (at - lo[i]) / side;
      const double target = std::clamp(std::round(unit / step), 1.0, 1.0 / step - 1) * step;
      const double shifted = at - target * side;
      if (!(shifted <= bounds.lo[i] && shifted + side >= bounds.hi[i])) continue;
      lo[i] = shifted;
      for (const StraddledRims& r : rims) {
        const double u = std::ldexp((r.apex - lo[i]) / side, kMaxApexLevel);
        if (std::abs(u - std::round(u)) <= std::ldexp(kOnPlane, kMaxApexLevel)) length += r.length;
      }
    }
    if (on_planes != nullptr) *on_planes = length;
    return lo;
  };
  double best_length = 0;
  layout(side0, &best_length);
  double best_side = side0;
  for (int i = 0; i < 3; ++i) {
    const std::vector<StraddledRims>& rims = frame.straddled[i];
    for (size_t j = 1; j < rims.size(); ++j) {
      const double d = std::abs(rims[j].apex - rims.front().apex);
      if (!(d > kOnPlane * side0)) continue;
      for (int level = kRimAlignLevel; level <= kMaxApexLevel; ++level) {
        const double span = std::ldexp(d, level);
        // side = span / n within [side0, side0 (1 + kMaxApexGrowth)]
        const double n_hi = std::floor(span / side0);
        const double n_lo = std::ceil(span / (side0 * (1 + kMaxApexGrowth)));
        for (double n = n_hi; n >= std::max(1.0, n_lo); --n) {
          double length = 0;
          const double side = span / n;
          layout(side, &length);
          if (length > best_length || (length == best_length && side < best_side)) {
            best_length = length;
            best_side = side;
          }
        }
      }
    }
  }
  return {best_side, layout(best_side, nullptr)};
}

}  // namespace

Domain make_domain(const Scene& scene, const DomainOptions& options, SceneFrame* analysed) {
  const int dim = scene.dimension;
  Domain domain;
  domain.dimension = dim;
  if (!std::isfinite(options.padding) || options.padding < 0.0) {
    throw Error(ErrorCode::kInvalidArgument, "domain padding must be a finite fraction >= 0, got " +
                                                 std::to_string(options.padding));
  }
  if (options.box) {
    const Box& user = *options.box;
    double extent = 0.0;
    for (int i = 0; i < dim; ++i) {
      if (!std::isfinite(user.lo[i]) || !std::isfinite(user.hi[i]) || user.lo[i] > user.hi[i]) {
        throw Error(ErrorCode::kInvalidArgument, "the domain box is empty or not finite");
      }
      extent = std::max(extent, user.hi[i] - user.lo[i]);
    }
    if (!(extent > 0.0)) {
      throw Error(ErrorCode::kInvalidArgument, "the domain box has zero extent");
    }
    for (size_t oi = 0; oi < scene.objects.size(); ++oi) {
      const SceneObject& object = scene.objects[oi];
      for (size_t vi = 0; vi < object.vertices.size(); ++vi) {
        if (!user.contains(object.vertices[vi], dim)) {
          throw Error(ErrorCode::kInvalidArgument, "the domain box does not contain " +
                                                       where(oi, object.label) + " vertex " +
                                                       std::to_string(vi));
        }
      }
    }
    const Vec3 c = user.center();
    domain.side = extent;
    domain.origin = c - Vec3{extent, extent, extent} * 0.5;
  } else {
    SceneFrame frame;
    if (dim == 3 && options.frame == DomainFrame::kAuto) {
      frame = analyse_scene_frame(scene, true, options.threads, options.cancel);
      std::copy(frame.axes.begin(), frame.axes.end(), domain.axis);
    }
    // The bounds in the frame's coordinates.
    const bool aligned = domain.aligned();
    Box bounds;
    for (const SceneObject& object : scene.objects) {
      for (const Vec3& p : object.vertices) {
        bounds.extend(
            aligned ? p
                    : Vec3{dot(p, domain.axis[0]), dot(p, domain.axis[1]), dot(p, domain.axis[2])});
      }
    }
    if (bounds.is_empty()) {
      domain.origin = {};
      domain.side = 1.0;
    } else {
      double extent = 0.0;
      for (int i = 0; i < dim; ++i) extent = std::max(extent, bounds.hi[i] - bounds.lo[i]);
      if (!(extent > 0.0)) extent = 1.0;
      const auto [side, lo] =
          align_to_apexes(frame, bounds, extent * (1.0 + 2.0 * options.padding));
      domain.side = side;
      domain.origin =
          aligned ? lo : domain.axis[0] * lo.x + domain.axis[1] * lo.y + domain.axis[2] * lo.z;
    }
    if (analysed != nullptr) *analysed = std::move(frame);
  }
  if (dim == 2) domain.origin.z = 0.0;
  return domain;
}

UnitGeometry make_unit_geometry(const Scene& scene, const Domain& domain) {
  // Slack for rounding in to_unit of vertices that lie exactly on the domain boundary.
  constexpr double kSlack = 1e-12;
  UnitGeometry g;
  g.dimension = scene.dimension;
  g.object_count = static_cast<uint32_t>(scene.objects.size());
  g.points.reserve(scene.vertex_count());
  g.simplices.reserve(scene.simplex_count());
  g.object_of.reserve(scene.simplex_count());
  double largest = 0;
  for (const SceneObject& object : scene.objects)
    for (const Vec3& v : object.vertices)
      largest = std::max({largest, std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  g.rounding = std::ldexp(largest, -53) / domain.side;
  for (size_t oi = 0; oi < scene.objects.size(); ++oi) {
    const SceneObject& object = scene.objects[oi];
    const auto offset = static_cast<uint32_t>(g.points.size());
    for (size_t vi = 0; vi < object.vertices.size(); ++vi) {
      Vec3 u = domain.to_unit(object.vertices[vi]);
      for (int c = 0; c < 3; ++c) {
        if (c >= scene.dimension) {
          u[c] = 0.0;
          continue;
        }
        if (!(u[c] >= -kSlack && u[c] <= 1.0 + kSlack)) {
          throw Error(ErrorCode::kInvalidArgument, where(oi, object.label) + " vertex " +
                                                       std::to_string(vi) +
                                                       " lies outside the domain");
        }
        const double snapped = std::ldexp(std::nearbyint(std::ldexp(u[c], 48)), -48);
        u[c] = std::clamp(snapped, 0.0, 1.0);
      }
      g.points.push_back(u);
    }
    for (const Simplex& s : object.simplices) {
      Simplex t = s;
      t.v[0] += offset;
      t.v[1] += offset;
      t.v[2] = scene.dimension == 2 ? 0u : t.v[2] + offset;  // 2D keeps v[2] = 0 (scene.h)
      g.simplices.push_back(t);
      g.object_of.push_back(static_cast<ObjectId>(oi));
    }
  }
  return g;
}

}  // namespace gvd::scene

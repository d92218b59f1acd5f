#pragma once

// Queries on a finished GVD: GvdIndex answers the nearest object at a point, inside tests,
// k-ring neighbours in the dual graph, paths on the GVD roadmap, exploded views and tight spots,
// and the functions below write the answers as JSON. The index is built once from a shared
// result; its methods are const and thread-safe, and throw gvd::Error on bad input.

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/common/error.h"
#include "gvd/geometry/vec.h"
#include "gvd/result/gvd_result.h"

namespace gvd {
class SimplexBvh;
}

namespace gvd::query {

/// Nearest object at a point: by default exact (the true nearest object, distance and closest
/// point, found by the BVH); on the fast path the paper's §4 rule (the closest of the closest
/// points stored on the vertices of the leaf that contains the point). `distance` is the distance
/// to `closest`, a point on the object, so it is never below the true distance.
struct NearestAnswer {
  Vec3 point;  ///< the query point, user units, as given
  scene::ObjectId object = scene::kNoObject;
  double distance = 0;  ///< user units
  Vec3 closest;         ///< the point on `object` the distance is measured to
  /// True when the BVH answered (exactly): always by default; on the fast path where the
  /// leaf's vertices could not prove the 3/2 bound.
  bool exact = false;
  /// Whether the point is inside `object`: 1 inside, 0 outside, -1 unknown (the object is not
  /// closed, so it has no inside; is_closed_object). Exact (ray parity with symbolic
  /// perturbation), also on the fast path.
  int8_t inside = -1;
  /// The distance, negative inside a closed object (equal to `distance` for an open one).
  double signed_distance() const { return inside == 1 ? -distance : distance; }
};

/// An object within k rings of another in the dual graph (paper §7.3).
struct RingNeighbor {
  scene::ObjectId object = scene::kNoObject;
  int ring = 0;  ///< 1 = shares boundary with the query object
  scene::ObjectId via =
      scene::kNoObject;      ///< a neighbour in ring - 1 it is reached from (ring 1: the query)
  double area = 0;           ///< interface area (length in 2D) between `via` and `object`
  double min_clearance = 0;  ///< least clearance on that interface
  Vec3 tightest_point;       ///< where it is attained
  double gap = -1;           ///< least distance between `via` and `object` (< 0: not measured)
  bool touching = false;     ///< a contact pair (DualEdge::touching)
};

/// What a path minimises.
enum class PathCost {
  kShortest,   ///< polyline length
  kClearance,  ///< length weighted by 1 / clearance (prefers wide passages)
};

struct PathQuery {
  Vec3 from;  ///< user units (z ignored in 2D)
  Vec3 to;
  double min_clearance = 0;  ///< passages narrower than this (user units) are not used
  PathCost cost = PathCost::kShortest;
};

/// A path on the GVD (the retraction roadmap of §7.2): `from`, a straight piece to the GVD,
/// a polyline along GVD edges, a straight piece to `to`. No piece crosses an object.
struct PathAnswer {
  bool found = false;
  std::vector<Vec3> points;  ///< from ... to; empty when !found
  double length = 0;         ///< user units
  double min_clearance = 0;  ///< exact least distance from the polyline to any object
  /// When !found: why ("start is inside object 'a'", "no path joins start and goal", ...).
  std::string reason;
};

/// Exploded view (paper §7.4) around an anchor object.
struct ExplodedObject {
  scene::ObjectId object = scene::kNoObject;
  int ring = -1;  ///< ring around the anchor (0 = anchor, -1 = not connected to it)
  /// The direction used, |.| <= 1: D_i of the paper (area-weighted mean interface normal) or,
  /// where that points at a ring-mate (GvdIndex::explode), a unit direction turned away from
  /// the ring-mates.
  Vec3 direction;
  Vec3 displacement;  ///< factor * scale * ring * direction, user units
  /// The share of scale * ring * direction kept, in [0, 1], so that, with every object moving
  /// along its displacement at once, no two come closer than half of their gap or of the
  /// scale, whichever is less, and objects that are not dual-graph neighbours do not approach
  /// by more than 1 % of the scale (ExplodeMotion). 0: held where it is; 1 for objects that
  /// have no direction.
  double factor = 1;
};

struct ExplodeOptions {
  /// Displacement per ring along the direction, user units; <= 0 picks 1/4 of the mean
  /// object bounding-box diagonal.
  double scale = 0;
};

struct ExplodedView {
  scene::ObjectId anchor = scene::kNoObject;
  double scale = 0;                     ///< the scale used
  std::vector<ExplodedObject> objects;  ///< one per object, by index
};

/// An object pair whose interface comes closer to the objects than a bound.
struct TightSpot {
  scene::ObjectId a = scene::kNoObject;
  scene::ObjectId b = scene::kNoObject;
  double min_clearance = 0;
  Vec3 point;       ///< tightest point of the interface
  double gap = -1;  ///< least distance between a and b (< 0: not measured)
  bool touching = false;
};

/// Answers from a finished GVD. Built once (O(result size)): the BVH and the dual graph at
/// construction, the nearest-point tables and the roadmap by the first nearest / path query
/// (once, under std::call_once); every method is const and thread-safe, so one index serves
/// many threads. Keeps a shared reference to
/// the result. Methods throw gvd::Error: kOutsideDomain for points outside the domain box,
/// kNotFound for unknown labels/objects, kInvalidArgument for bad parameters.
class GvdIndex {
 public:
  explicit GvdIndex(std::shared_ptr<const result::GvdResult> result);
  ~GvdIndex();
  GvdIndex(GvdIndex&&) noexcept;
  GvdIndex& operator=(GvdIndex&&) noexcept;

  const result::GvdResult& result() const;
  int dimension() const;

  /// The object with this label; throws kNotFound naming the label.
  scene::ObjectId object(std::string_view label) const;

  /// Nearest object at a point (user units): exact, one BVH query (O(log simplices) for
  /// well-spread input). With `approximate`, the paper's §4 rule (the closest of the leaf vertices'
  /// closest points) in every leaf that holds no object, and elsewhere that answer where the leaf's
  /// corners prove it within 3/2 of the true distance away from Voronoi boundaries (the BVH
  /// otherwise): faster; the distance is still never below the true one, but its 3/2 bound
  /// is only the paper's conjecture in empty leaves, and the object may flip within a cell of
  /// a Voronoi boundary.
  NearestAnswer nearest(Vec3 point, bool approximate = false) const;

  /// Whether the object is closed (is_closed_object), so that nearest answers say whether a
  /// point is inside it.
  bool is_closed(scene::ObjectId object) const;
  /// Whether a point (user units) is inside the object: 1 inside, 0 outside, -1 when the
  /// object is not closed (NearestAnswer::inside's test, for any object).
  int8_t inside(Vec3 point, scene::ObjectId object) const;
  /// The exact search structure over the scene's simplices (unit coordinates; with the object
  /// of every simplex), for queries built on this index (find_contacts).
  const SimplexBvh& bvh() const;

  /// Objects within `ring` rings of `object` (1 <= ring; rings beyond the graph's reach just
  /// return everything connected), sorted by (ring, object). Breadth-first on the dual graph.
  std::vector<RingNeighbor> neighbors(scene::ObjectId object, int ring) const;

  /// Eccentricity of `object` in the dual graph (the largest useful ring).
  int max_ring(scene::ObjectId object) const;

  /// A path on the GVD roadmap; never through an object. Not found (with a reason) when start
  /// or goal is inside an object or closer to one than min_clearance, or no roadmap path joins
  /// them. A* over the GVD's vertex graph.
  PathAnswer path(const PathQuery& query) const;

  /// Paper §7.4: D_1 for the anchor's 1-ring, D_i for ring i from the (i-1)-ring neighbours
  /// adjacent to the object, weighted by interface area (a neighbour that does not move counts
  /// with its interface normal, as the anchor does). Under an anchor that carries or surrounds
  /// the objects D points at their ring-mates (dual-graph neighbours in the same ring): ring by
  /// ring, object by object, the direction is chosen among D with the part pointing at any
  /// ring-mate removed (then a unit vector: out through an opening), that turned away from
  /// the ring-mates, and straight away from them (apart inside a closed anchor); D is kept
  /// unless another moves the object at least twice as far. Collision-free: all objects
  /// moving at once along their displacements (t = 0 to 1, as the animated GLB does), no two
  /// come closer than half of their gap or half the scale and non-neighbours do not approach
  /// by more than 1 % of the scale; each object keeps the largest share of its displacement
  /// proved safe (ExplodedObject::factor) by conservative advancement on exact mesh distances
  /// against the motions already fixed (certified for every t, not sampled). Cost: a few exact
  /// mesh-distance marches per candidate direction and nearby pair.
  ExplodedView explode(scene::ObjectId anchor, const ExplodeOptions& options = {}) const;

  /// Dual-graph edges with min_clearance < below, sorted by clearance (tightest first).
  std::vector<TightSpot> tight(double below) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Query points from JSON: an array of points or {"points": [...]}, each point an array of
/// `dimension` numbers (a 2D point may also have a third coordinate 0). Throws
/// gvd::Error{kInvalidArgument} saying which point is wrong and why.
std::vector<Vec3> parse_points_json(std::string_view text, int dimension);

/// JSON of the answers (docs/API.md and docs/FORMATS.md); labels are added next to object indices.
/// Each answer also carries "units" (the scene's length unit, Scene::units) at its top level
/// when the scene declares one, and no such key when it does not.
/// Nearest: {"point":[...],"object":i,"label":"...","distance":d,"signed_distance":s,
/// "inside":true|false|null,"closest":[...]} (inside null: the object is not closed; then
/// signed_distance = distance).
std::string nearest_to_json(const GvdIndex& index, const NearestAnswer& answer);
/// A batch entry for a point without an answer (outside the domain): {"point":[...],
/// "object":null,"label":null,"distance":null,"signed_distance":null,"inside":null,
/// "closest":null,"error":{"code":"outside_domain","detail":"..."}}.
std::string nearest_error_to_json(const GvdIndex& index, Vec3 point, const Error& error);
/// {"object":i,"label":"...","ring":k,"neighbors":[{"object","label","ring","via","area",
/// "min_clearance","tightest_point"}]}
std::string neighbors_to_json(const GvdIndex& index, scene::ObjectId object, int ring,
                              std::span<const RingNeighbor> neighbors);
/// {"from":[...],"to":[...],"points":[[...],...],"length":L,"min_clearance":c} and, when not
/// found, "points":[], "length":null, "min_clearance":null, "reason":"...".
std::string path_to_json(const GvdIndex& index, const PathQuery& query, const PathAnswer& path);
/// {"anchor":i,"label":"...","scale":s,"objects":[{"object","label","ring","direction",
/// "displacement"}]}
std::string exploded_to_json(const GvdIndex& index, const ExplodedView& view);
/// {"below":b,"pairs":[{"a","b","label_a","label_b","min_clearance","point"}]}
std::string tight_to_json(const GvdIndex& index, double below, std::span<const TightSpot> spots);

}  // namespace gvd::query

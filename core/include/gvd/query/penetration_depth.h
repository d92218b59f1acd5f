#pragma once

// The penetration depth of two intersecting convex objects: how far one must move to leave
// the other, exactly (the separating-axis test over the axes that can realise it). Contacts
// (contact_report.h) report it for interfering pairs where both objects are convex.

#include <cstdint>
#include <optional>
#include <vector>

#include "gvd/geometry/vec.h"
#include "gvd/scene/scene.h"

namespace gvd::query {

/// At most this many separating-axis evaluations per object (its convexity check: faces times
/// vertices) and per pair of objects (edge pairs in 3D, face normals times vertices): about
/// 0.4 s of one core (two faceted spheres of 3,600 triangles each take 0.05 s). Larger ones are
/// not measured.
inline constexpr uint64_t kPenetrationBudget = 100'000'000;

/// A convex object as the separating-axis test reads it: its vertices, its faces' outward
/// normals and its edges where the surface bends, relative to its centre (for precision).
class ConvexShape {
 public:
  /// What `of` found.
  enum class Verdict { kConvex, kNotConvex, kOverBudget };

  /// The shape of `object` when it is the boundary of a convex region: closed (every edge of
  /// two triangles; 2D: every vertex of two segments), one connected part, consistently
  /// oriented, every vertex on or behind the plane (2D: line) of every face within 1e-9 of the
  /// object's size, and in 2D turning once around (a pentagram is not convex). Empty
  /// otherwise, or when the check would take more than `budget` vertex-face tests; `verdict`
  /// (optional) says which.
  static std::optional<ConvexShape> of(const scene::SceneObject& object, int dimension,
                                       uint64_t budget = kPenetrationBudget,
                                       Verdict* verdict = nullptr);

  /// How far and along which direction one convex shape must move to leave another.
  struct Penetration {
    double depth = 0;  ///< user units; 0 when they do not overlap
    Vec3 direction;    ///< unit: moving the second shape by depth along it separates them
  };
  /// The penetration of two convex shapes: the shortest translation of `b` after which
  /// their interiors are disjoint; depth 0 when they do not overlap. Exact up to rounding:
  /// the least overlap of their projections over the face normals of both (2D: edge normals)
  /// and, in 3D, over the cross products of the edge pairs whose normal arcs cross on the
  /// Gauss map (the faces of the Minkowski difference); the least overlap over all directions
  /// is attained at one of them. Empty when it would take more than `budget` evaluations.
  static std::optional<Penetration> penetration(const ConvexShape& a, const ConvexShape& b,
                                                uint64_t budget = kPenetrationBudget);

 private:
  struct Edge {
    Vec3 point;      ///< an end, relative to the centre
    Vec3 direction;  ///< the other end minus `point`
    Vec3 n1, n2;     ///< outward unit normals of its two faces
    Vec3 arc;        ///< cross(n2, n1): the plane of its arc on the Gauss map
  };
  Vec3 centre_;
  std::vector<Vec3> points_;    ///< the vertices the faces use, relative to the centre
  std::vector<Vec3> normal_;    ///< per face: outward unit normal
  std::vector<double> offset_;  ///< per face: its plane's distance from the centre along it
  std::vector<Edge> edges_;     ///< 3D: the edges whose two faces are not coplanar
};

}  // namespace gvd::query

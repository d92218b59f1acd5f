#pragma once

// Contacts: every pair of objects closer than a bound, with the exact gap between them, the
// GVD's interface between them and the connected sites of that interface where they come
// closer than the bound (the "touching neurons" and clearance-check questions).

#include <cstddef>
#include <string>
#include <vector>

#include "gvd/geometry/vec.h"
#include "gvd/query/gvd_index.h"

namespace gvd::query {

/// A connected region of the interface between two objects where twice the clearance (the
/// distance across the interface from one object to the other) is below the bound.
struct ContactSite {
  /// Area (2D: length) of the region, user units: the GVD pieces between the pair cut where
  /// 2 x clearance < bound (exact clearances, pieces that straddle the bound split five times,
  /// then interpolated linearly).
  double area = 0;
  Vec3 centroid;  ///< of that region
  /// The least gap measured across the site: the exact distance between the closest points
  /// on the two objects of the site's lowest-clearance GVD vertices. Never below the pair's
  /// `gap`, and below the bound.
  double min_gap = 0;
  Vec3 on_a, on_b;  ///< the closest points of that measurement, on a and on b
};

/// A pair of objects closer than the bound.
struct Contact {
  scene::ObjectId a = scene::kNoObject;  ///< a < b
  scene::ObjectId b = scene::kNoObject;
  /// The exact least distance between the two objects, from their simplices (not read off the
  /// GVD); 0 when they touch or intersect.
  double gap = 0;
  Vec3 on_a, on_b;  ///< a closest pair of points, one on each (where they meet: a crossing)
  /// They touch or intersect (gap 0).
  bool interference = false;
  /// With interference: the deepest vertex of either object inside the other, measured to
  /// the other's surface (exact there). A lower bound of the penetration depth (the deepest
  /// point of the overlap need not be a vertex); < 0 when not computable (neither object is
  /// closed) or no vertex lies inside.
  double depth_lower_bound = -1;
  /// With interference, where both objects are convex (ConvexShape, penetration_depth.h): the
  /// penetration depth, the length of the shortest translation of one that leaves their
  /// interiors disjoint (0 when they only touch), exact. < 0 when either object is not convex
  /// or the pair is larger than kPenetrationBudget allows. Never below depth_lower_bound.
  double penetration_depth = -1;
  /// The GVD interface between them (area in 3D, length in 2D; 0 when their cells do not
  /// meet, e.g. a third object lies between them).
  double interface_area = 0;
  std::vector<ContactSite> sites;  ///< largest first
};

/// At most this many object pairs with bounding boxes within the bound are measured.
inline constexpr size_t kMaxContactCandidates = 10'000'000;

/// Every pair whose gap is below `max_gap` (user units, >= 0), and every pair that touches
/// or intersects, sorted by (gap, a, b). Candidates by bounding boxes within `max_gap`, then
/// exact BVH distances (SimplexBvh::object_distance). gvd::Error{kInvalidArgument} for a
/// negative or non-finite bound, {kLimitExceeded} when more than kMaxContactCandidates pairs
/// have bounding boxes within it (before any exact distance is computed).
std::vector<Contact> find_contacts(const GvdIndex& index, double max_gap,
                                   size_t max_candidates = kMaxContactCandidates);

/// {"max_gap":G,"contacts":[{"a","label_a","b","label_b","gap","on_a","on_b","interference",
/// "depth_lower_bound", "penetration_depth" (each null when <
/// 0),"interface_area","sites":[{"area","centroid","min_gap", "on_a","on_b"}]}]} (docs/FORMATS.md),
/// and "units" when the scene declares them.
std::string contacts_to_json(const GvdIndex& index, double max_gap,
                             const std::vector<Contact>& contacts);

}  // namespace gvd::query

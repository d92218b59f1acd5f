#pragma once

// The linear, 2:1-balanced octree (quadtree in 2D): its leaves in Morton order with their level,
// object and certified mark, and point location in O(log N) (LeafLocator for many queries on
// one octree). Also the verdicts by which the refinement may keep a cell that the paper's rule
// (§3) would split, and the marks they leave on leaves.

#include <cstdint>
#include <span>
#include <vector>

#include "gvd/octree/lattice.h"
#include "gvd/scene/scene.h"

namespace gvd::octree {

/// What the refinement decides for a cell that the paper's rule (§3) would split.
enum class CellVerdict : uint8_t {
  kSplit,      ///< split it (the paper's rule)
  kOneObject,  ///< only one object can be nearest anywhere in the cell: no GVD enters it
  kPair,       ///< certified pair cell: only two objects can be nearest in it and their
               ///< bisector there is known exactly (refine/pair_certificate.h)
  /// Extruded pair cells (3D): two objects, whose surfaces near the cell are invariant along
  /// axis 0, 1 or 2, so the bisector is a curve of the cross-section swept along that axis.
  kExtrudedX,
  kExtrudedY,
  kExtrudedZ,
  /// The same where the gradients straddle one cross-section axis m, a cone (the cell's
  /// lines along m were checked one by one, pair_certificate.h): its children are certified
  /// too, its grandchildren must be asked. kCone + 4 axis + 2 k + twice (cone_verdict), for
  /// m = (axis + 1 + k) % 3; twice: some of those lines cross the bisector twice.
  kCone,
  kConeLast = kCone + 11,
  /// Slanted extruded pair cells (3D): the same along a direction e perpendicular to axis 0, 1
  /// or 2 but along neither of the other two (a hexagonal bore's edge at 60 degrees in the
  /// plane of its end); ...Opposite: e's two non-zero components have opposite signs.
  kSlantedX,
  kSlantedXOpposite,
  kSlantedY,
  kSlantedYOpposite,
  kSlantedZ,
  kSlantedZOpposite,
  /// Skew extruded pair cells (3D): the same along a direction e square to no axis (a faceted
  /// sphere's rims), every octree edge crossing the bisector at most once (the gradients in
  /// one octant). e is not in the mark: the certificate of the cell's own box gives it again
  /// (PairCertifier::certify), so its children are asked again rather than inheriting it.
  kSkew,
  /// The same where the gradients straddle one axis m (a sphere's rims across its great
  /// circles): a cone, whose lines along m at the quarters of the cell across both other axes
  /// were counted. kSkewCone + 2 m + twice (skew_cone_verdict); children are asked again.
  kSkewCone,
  kSkewConeLast = kSkewCone + 5,
  /// The same where the gradients straddle two axes and keep one sign along the third, k
  /// only (a part turned about two axes against the frame, whose rims are square to k, or
  /// about a skew axis, whose rims are square to none): a wedge, whose lines along both other
  /// axes at the quarters of the cell were counted.
  /// kSkewWedge + 2 k + twice (skew_wedge_verdict); children are asked again.
  kSkewWedge,
  kSkewWedgeLast = kSkewWedge + 5,
  /// Junction cells (3D): three or more objects meet along a line along axis 0, 1 or 2, and
  /// every distance function is invariant along it in the cell, so the GVD there is the plane
  /// GVD of the objects' sections swept along the axis (PairCertifier::certify_junction).
  /// Their children are asked again.
  kJunctionX,
  kJunctionY,
  kJunctionZ,
};

/// Whether a verdict is a cone's (kCone...): certified for the cell and its children.
inline bool is_cone(CellVerdict v) {
  return (v >= CellVerdict::kCone && v <= CellVerdict::kConeLast) ||
         (v >= CellVerdict::kSkewCone && v <= CellVerdict::kSkewWedgeLast);
}

/// The Octree::certified mark of a verdict: 0 (not certified), 1 (kPair), 2 + axis (the
/// extruded pair cells) or 5 + (v - kCone) (the cones); children of a cone cell carry 12 more
/// (certified; their own children must be asked again); 29 + 2 axis + opposite (kSlanted...);
/// kSkewMark (kSkew); kSkewMark + 1 + 2 m + twice (kSkewCone...); kSkewWedgeMark + 2 k + twice
/// (kSkewWedge...); kJunctionMark + axis (kJunctionX...).
inline constexpr uint8_t kSkewMark = 35;
inline constexpr uint8_t kSkewWedgeMark = kSkewMark + 7;
inline constexpr uint8_t kSkewLastMark = kSkewWedgeMark + 5;
inline constexpr uint8_t kJunctionMark = kSkewLastMark + 1;  ///< + axis (kJunctionX...)
/// The axis of a junction cell's mark (kJunctionMark + axis), or -1 for any other mark.
inline int junction_axis_of_mark(uint8_t mark) {
  return mark >= kJunctionMark && mark <= kJunctionMark + 2 ? mark - kJunctionMark : -1;
}

inline uint8_t certified_mark(CellVerdict v) {
  const int i = static_cast<int>(v);
  if (v == CellVerdict::kPair) return 1;
  if (i >= static_cast<int>(CellVerdict::kExtrudedX) &&
      i <= static_cast<int>(CellVerdict::kConeLast))
    return static_cast<uint8_t>(2 + i - static_cast<int>(CellVerdict::kExtrudedX));
  if (i >= static_cast<int>(CellVerdict::kSlantedX) &&
      i <= static_cast<int>(CellVerdict::kSlantedZOpposite))
    return static_cast<uint8_t>(29 + i - static_cast<int>(CellVerdict::kSlantedX));
  if (v >= CellVerdict::kSkew && v <= CellVerdict::kSkewWedgeLast)
    return static_cast<uint8_t>(kSkewMark + i - static_cast<int>(CellVerdict::kSkew));
  if (v >= CellVerdict::kJunctionX && v <= CellVerdict::kJunctionZ)
    return static_cast<uint8_t>(kJunctionMark + i - static_cast<int>(CellVerdict::kJunctionX));
  return 0;
}

/// The mark the children of a cell with mark `mark` carry without asking again (0: ask).
inline uint8_t inherited_mark(uint8_t mark) {
  if (mark >= kSkewMark) return 0;  // skew and junction cells: ask again
  if (mark <= 4 || mark >= 29) return mark;
  return mark <= 16 ? static_cast<uint8_t>(mark + 12) : uint8_t{0};
}

/// The slanted verdict for a direction perpendicular to `axis` whose other two components
/// have opposite signs or not.
inline CellVerdict slanted_verdict(int axis, bool opposite) {
  return static_cast<CellVerdict>(static_cast<int>(CellVerdict::kSlantedX) + 2 * axis +
                                  (opposite ? 1 : 0));
}

/// The skew cone's verdict whose gradients straddle axis `mixed`; `twice`: some of its lines
/// along `mixed` cross the bisector twice.
inline CellVerdict skew_cone_verdict(int mixed, bool twice) {
  return static_cast<CellVerdict>(static_cast<int>(CellVerdict::kSkewCone) + 2 * mixed +
                                  (twice ? 1 : 0));
}

/// The skew wedge's verdict whose gradients keep one sign along axis `monotone` alone;
/// `twice`: some of its lines along the other two axes cross the bisector twice.
inline CellVerdict skew_wedge_verdict(int monotone, bool twice) {
  return static_cast<CellVerdict>(static_cast<int>(CellVerdict::kSkewWedge) + 2 * monotone +
                                  (twice ? 1 : 0));
}

/// The extruded verdict along `axis` (0, 1, 2), its sub-cells certified too.
inline CellVerdict extruded_verdict(int axis) {
  return static_cast<CellVerdict>(static_cast<int>(CellVerdict::kExtrudedX) + axis);
}

/// The cone's verdict along `axis` whose gradients straddle cross-section axis `mixed`;
/// `twice`: some of its lines along `mixed` cross the bisector twice.
inline CellVerdict cone_verdict(int axis, int mixed, bool twice) {
  return static_cast<CellVerdict>(static_cast<int>(CellVerdict::kCone) + 4 * axis +
                                  (mixed == (axis + 1) % 3 ? 0 : 2) + (twice ? 1 : 0));
}

/// A linear, 2:1-balanced octree (quadtree in 2D) over the unit domain. Leaves only, sorted
/// by the Morton code of their lower corner (Z order), so point location is a binary search
/// and neighbours are O(1) hash lookups of lattice keys. Every leaf knows which object it
/// intersects (conservatively); which simplices, the builds hand over beside it
/// (leaf_simplices.h).
struct Octree {
  int dimension = 3;
  int max_depth = 0;           ///< the depth limit used
  int depth = 0;               ///< deepest leaf level
  std::vector<uint64_t> code;  ///< per leaf: Morton code of the lower corner (lattice units)
  std::vector<uint8_t> level;  ///< per leaf
  std::vector<scene::ObjectId> object;  ///< per leaf: kNoObject, an object, or kManyObjects
  /// Per leaf: the certified_mark of the certified pair cell it lies in (0: none): at most two
  /// objects are nearest anywhere in it, and their bisector there is one exact sheet (1: a
  /// plane; 2 ... 28: a curve swept along an axis, 5 ... 28 the cones; 29 ... 34: along a
  /// direction perpendicular to one axis; 35 ... 47: along a skew direction, 36 ... 41 the
  /// skew cones, 42 ... 47 the wedges; 48 ... 50: a junction cell of three or more objects
  /// along axis 0, 1, 2), so it may hold both objects and the GVD (refinement checks skip
  /// it). Empty after loading from disk.
  std::vector<uint8_t> certified;

  size_t leaf_count() const { return code.size(); }
  bool is_certified(uint32_t leaf) const { return !certified.empty() && certified[leaf] != 0; }
  /// The axis of the extruded pair cell the leaf lies in, or -1.
  int extruded_axis(uint32_t leaf) const {
    if (certified.empty() || certified[leaf] < 2 || certified[leaf] > 28) return -1;
    return certified[leaf] <= 4 ? certified[leaf] - 2 : (certified[leaf] - 5) % 12 / 4;
  }
  /// The cross-section axis whose lines may cross the bisector twice in the cone cell the leaf
  /// lies in (CellVerdict::kCone...), or -1 (a wedge: the first of its two, straddled_axes);
  /// `twice`: whether some of them do.
  int cone_axis(uint32_t leaf, bool* twice = nullptr) const {
    if (certified.empty()) return -1;
    if (certified[leaf] >= kSkewWedgeMark && certified[leaf] <= kSkewLastMark) {
      if (twice != nullptr) *twice = (certified[leaf] - kSkewWedgeMark) % 2 == 1;
      return ((certified[leaf] - kSkewWedgeMark) / 2 + 1) % 3;
    }
    if (certified[leaf] > kSkewMark && certified[leaf] < kSkewWedgeMark) {
      if (twice != nullptr) *twice = (certified[leaf] - kSkewMark - 1) % 2 == 1;
      return (certified[leaf] - kSkewMark - 1) / 2;
    }
    if (certified[leaf] < 5 || certified[leaf] > 28) return -1;
    const int k = (certified[leaf] - 5) % 12;
    if (twice != nullptr) *twice = k % 2 == 1;
    return (k / 4 + 1 + k / 2 % 2) % 3;
  }
  /// The axis perpendicular to the direction of the slanted extruded pair cell the leaf lies
  /// in, or -1; `opposite`: whether the direction's other two components differ in sign.
  int slanted_axis(uint32_t leaf, bool* opposite = nullptr) const {
    if (certified.empty() || certified[leaf] < 29 || certified[leaf] > 34) return -1;
    if (opposite != nullptr) *opposite = (certified[leaf] - 29) % 2 == 1;
    return (certified[leaf] - 29) / 2;
  }
  /// The axes whose lines may cross the bisector twice in the cone or wedge cell the leaf
  /// lies in, as bits 1 << axis (0: none); `twice`: whether some of them do.
  unsigned straddled_axes(uint32_t leaf, bool* twice = nullptr) const {
    const int m = cone_axis(leaf, twice);
    if (m < 0) return 0;
    if (certified[leaf] < kSkewWedgeMark || certified[leaf] > kSkewLastMark) return 1u << m;
    return 7u & ~(1u << (certified[leaf] - kSkewWedgeMark) / 2);
  }
  /// Whether the leaf is a skew extruded pair cell (CellVerdict::kSkew, kSkewCone...,
  /// kSkewWedge...).
  bool is_skew(uint32_t leaf) const {
    return !certified.empty() && certified[leaf] >= kSkewMark && certified[leaf] <= kSkewLastMark;
  }
  /// The axis of the junction cell (CellVerdict::kJunctionX...) the leaf is, or -1.
  int junction_axis(uint32_t leaf) const {
    return certified.empty() ? -1 : junction_axis_of_mark(certified[leaf]);
  }
  lattice::Coord corner(uint32_t leaf) const {
    return lattice::morton_decode(dimension, code[leaf]);
  }
  Box box(uint32_t leaf) const { return lattice::cell_box(dimension, corner(leaf), level[leaf]); }
  /// The leaf containing unit point u (points on shared faces go to the upper cell); u must
  /// be inside [0,1]^D (it is clamped). O(log N).
  uint32_t locate(Vec3 u) const;
  /// The leaf containing the finest lattice cell with lower corner p. O(log N).
  uint32_t locate_lattice(const lattice::Coord& p) const;
  /// Bytes of the leaf arrays (code, level, object) — the octree proper.
  size_t structure_bytes() const;
  /// Frees all but the leaves' codes and levels (what locate and the cells need): for an
  /// octree that is only looked up, such as the one a refinement round replaced.
  void keep_cells_only() {
    std::vector<scene::ObjectId>().swap(object);
    std::vector<uint8_t>().swap(certified);
  }
};

/// Leaf location for many queries on one octree: where each top Morton prefix (up to 16 bits,
/// about two prefixes per leaf) starts in the sorted leaf codes, so that a query searches only
/// its prefix's range (a few steps instead of log N cache misses). Same answers as
/// Octree::locate_lattice. The octree must outlive it and not change.
class LeafLocator {
 public:
  explicit LeafLocator(const Octree& octree);
  uint32_t locate_lattice(const lattice::Coord& p) const;

 private:
  static constexpr int kPrefixBits = 16;
  const Octree* octree_;
  int shift_ = 0;
  /// Per prefix (and one past the last): the first leaf with that prefix or a later one.
  std::vector<uint32_t> start_;
};

/// A cell of the lattice octree, by the Morton code of its lower corner and its level.
struct CellRef {
  uint64_t code = 0;
  uint8_t level = 0;
  uint8_t mark = 0;  ///< in cells_to_certify: the certified_mark to give
};

/// The cell of leaf `leaf` as a CellRef.
inline CellRef cell_of(const Octree& octree, uint32_t leaf) {
  return {octree.code[leaf], octree.level[leaf]};
}
/// Child `child` (0 .. 2^D - 1, bit a = upper half along axis a) of a cell.
CellRef child_cell(int dimension, CellRef cell, uint32_t child);

}  // namespace gvd::octree

#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "gvd/octree/lattice.h"
#include "gvd/scene/scene.h"

namespace gvd::octree {

class ContactPairs;

/// Progress report of a long stage: stage name and fraction done in [0, 1].
using ProgressFn = std::function<void(const std::string& stage, double fraction)>;

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
};

/// Whether a verdict is a cone's (kCone...): certified for the cell and its children.
inline bool is_cone(CellVerdict v) {
  return (v >= CellVerdict::kCone && v <= CellVerdict::kConeLast) ||
         (v >= CellVerdict::kSkewCone && v <= CellVerdict::kSkewConeLast);
}

/// The Octree::certified mark of a verdict: 0 (not certified), 1 (kPair), 2 + axis (the
/// extruded pair cells) or 5 + (v - kCone) (the cones); children of a cone cell carry 12 more
/// (certified; their own children must be asked again); 29 + 2 axis + opposite (kSlanted...);
/// kSkewMark (kSkew); kSkewMark + 1 + 2 m + twice (kSkewCone...).
inline constexpr uint8_t kSkewMark = 35;
inline constexpr uint8_t kSkewConeLastMark = kSkewMark + 6;
inline uint8_t certified_mark(CellVerdict v) {
  const int i = static_cast<int>(v);
  if (v == CellVerdict::kPair) return 1;
  if (i >= static_cast<int>(CellVerdict::kExtrudedX) &&
      i <= static_cast<int>(CellVerdict::kConeLast))
    return static_cast<uint8_t>(2 + i - static_cast<int>(CellVerdict::kExtrudedX));
  if (i >= static_cast<int>(CellVerdict::kSlantedX) &&
      i <= static_cast<int>(CellVerdict::kSlantedZOpposite))
    return static_cast<uint8_t>(29 + i - static_cast<int>(CellVerdict::kSlantedX));
  if (v >= CellVerdict::kSkew && v <= CellVerdict::kSkewConeLast)
    return static_cast<uint8_t>(kSkewMark + i - static_cast<int>(CellVerdict::kSkew));
  return 0;
}

/// The mark the children of a cell with mark `mark` carry without asking again (0: ask).
inline uint8_t inherited_mark(uint8_t mark) {
  if (mark >= kSkewMark && mark <= kSkewConeLastMark) return 0;
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

/// Decides, for a cell the paper's rule would split, whether it must be split (the
/// thin-gaps refinement of refine/; the octree module only asks). Thread-safe.
class SplitOracle {
 public:
  virtual ~SplitOracle() = default;
  /// The verdict for the closed cell `box` (unit domain). `inside` (optional) lists the
  /// simplices that touch the cell, which lets most cells that must split be told cheaply.
  virtual CellVerdict classify(const Box& box, std::span<const uint32_t> inside = {}) const = 0;
};

/// Simplex references per leaf of OctreeOptions::max_leaves that the cells' lists may hold.
/// Scenes hold one to three per cell; a thousand coincident copies of one part, a thousand.
constexpr uint64_t kReferencesPerLeaf = 8;

/// Options of the octree build (paper §3).
struct OctreeOptions {
  /// Deepest level a cell may reach; <= 0 picks the default: 26 in 2D (separates gaps of
  /// ~1e-7 of the domain), 21 in 3D (~1e-6 of the domain; 21 is also the lattice limit).
  int max_depth = 0;
  /// Upper bound on leaves; exceeding it is gvd::Error{kLimitExceeded} (checked per level).
  uint64_t max_leaves = 12'000'000;
  /// The cells' simplex lists are bounded by it too: at most kReferencesPerLeaf references
  /// per leaf of max_leaves (plus 4 per simplex of the scene), checked at each level of the
  /// level-by-level build (many objects sharing cells: gvd::Error{kLimitExceeded}).
  /// Worker threads (0 = all cores).
  int threads = 0;
  /// Set to true by another thread to stop with gvd::Error{kCancelled}.
  const std::atomic<bool>* cancel = nullptr;
  /// Object pairs that touch or intersect (find_contact_pairs). Splits that only separate
  /// such a pair stop at `contact_depth` (<= 0: 14 in 2D, 8 in 3D; at most max_depth).
  const ContactPairs* contacts = nullptr;
  int contact_depth = 0;
  /// With an oracle, a cell the paper's rule would split is asked first, and kept as a leaf
  /// when no GVD enters it (kOneObject) or its bisector is certified (kPair; the leaf and its
  /// descendants are marked in Octree::certified). Null: the paper's rule alone.
  const SplitOracle* split_oracle = nullptr;
  /// Optional: called from the calling thread after each level of the level-by-level build
  /// with level / max_depth (the build often ends well before max_depth; then it jumps to 1).
  std::function<void(double)> progress;
};

/// Resolved contact depth (applies the defaults, clamps to the max depth).
int resolve_contact_depth(int dimension, int requested, int max_depth);

/// Resolved maximum depth for a dimension (applies the defaults, clamps to the lattice).
int resolve_max_depth(int dimension, int requested);

/// A linear, 2:1-balanced octree (quadtree in 2D) over the unit domain. Leaves only, sorted
/// by the Morton code of their lower corner (Z order), so point location is a binary search
/// and neighbours are O(1) hash lookups of lattice keys. Every leaf knows which object it
/// intersects (conservatively) and, for non-empty leaves, which simplices.
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
  /// direction perpendicular to one axis), so it may hold both objects and the GVD
  /// (refinement checks skip it). Empty after loading from disk.
  std::vector<uint8_t> certified;
  /// Simplices intersecting each leaf (CSR: simplex_begin has leaves + 1 entries). Only the
  /// refinement reads them: empty in compute_gvd's result and in a loaded one.
  std::vector<uint32_t> simplex_begin;
  std::vector<uint32_t> simplex_index;

  size_t leaf_count() const { return code.size(); }
  bool is_certified(uint32_t leaf) const { return !certified.empty() && certified[leaf] != 0; }
  /// The axis of the extruded pair cell the leaf lies in, or -1.
  int extruded_axis(uint32_t leaf) const {
    if (certified.empty() || certified[leaf] < 2 || certified[leaf] > 28) return -1;
    return certified[leaf] <= 4 ? certified[leaf] - 2 : (certified[leaf] - 5) % 12 / 4;
  }
  /// The cross-section axis whose lines may cross the bisector twice in the cone cell the leaf
  /// lies in (CellVerdict::kCone...), or -1; `twice`: whether some of them do.
  int cone_axis(uint32_t leaf, bool* twice = nullptr) const {
    if (certified.empty()) return -1;
    if (certified[leaf] > kSkewMark && certified[leaf] <= kSkewConeLastMark) {
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
  /// Whether the leaf is a skew extruded pair cell (CellVerdict::kSkew, kSkewCone...).
  bool is_skew(uint32_t leaf) const {
    return !certified.empty() && certified[leaf] >= kSkewMark &&
           certified[leaf] <= kSkewConeLastMark;
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
    std::vector<uint32_t>().swap(simplex_begin);
    std::vector<uint32_t>().swap(simplex_index);
  }
};

/// Leaf location for many queries on one octree: where each top Morton prefix (16 bits) starts
/// in the sorted leaf codes, so that a query searches only its prefix's range (a few steps
/// instead of log N cache misses). Same answers as Octree::locate_lattice. The octree must
/// outlive it and not change.
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

/// Builds the octree with the paper's SHOULD_SUBDIVIDE (§3): a cell is split when it
/// intersects more than one object, or when a face-neighbour intersects a different object,
/// until `max_depth`; then balanced so that leaves sharing a face, edge or corner differ by
/// at most one level (so that surfacing stays watertight across level changes). Cell–simplex
/// tests are conservative. Level-synchronous and parallel over cells;
/// O(sum over levels of non-empty cells x simplices per cell).
Octree build_octree(const scene::UnitGeometry& geometry, const OctreeOptions& options = {});

/// A cell of the lattice octree, by the Morton code of its lower corner and its level.
struct CellRef {
  uint64_t code = 0;
  uint8_t level = 0;
  uint8_t mark = 0;  ///< in cells_to_certify: the certified_mark to give
};

/// Splits the given cells (existing leaves, or cells inside leaves, whose ancestors are then
/// split too; cells at max_depth are ignored), re-balances and recomputes the leaf -> simplex
/// incidence. Leaves inside a certified leaf stay certified; the leaves that end up inside one
/// of `cells_to_certify` (cells at or below an existing leaf) are marked certified too. Used
/// for ambiguity resolution (§5) and the separation guarantee.
Octree refine_octree(const Octree& octree, const scene::UnitGeometry& geometry,
                     std::span<const CellRef> cells_to_split, const OctreeOptions& options = {},
                     std::span<const CellRef> cells_to_certify = {});

/// The cell of leaf `leaf` as a CellRef.
inline CellRef cell_of(const Octree& octree, uint32_t leaf) {
  return {octree.code[leaf], octree.level[leaf]};
}
/// Child `child` (0 .. 2^D - 1, bit a = upper half along axis a) of a cell.
CellRef child_cell(int dimension, CellRef cell, uint32_t child);

}  // namespace gvd::octree

#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/contacts.h"
#include "gvd/octree/octree.h"
#include "gvd/scene/scene.h"

namespace gvd {

/// The flat-pair certificate of the thin-gaps refinement (docs/ALGORITHM.md, "Certified pair
/// cells"). The paper's rule (§3) splits every cell that holds or borders two objects, so
/// cells shrink to the gap g over the whole contact: area/g^2 leaves in 3D, length/g in 2D.
/// A GVD between two flat faces is one plane, whatever g is; this class proves, for one cell,
/// that it may stay a leaf:
///
/// - Active objects (exact BVH distances at the centre c; r = half the cell's diagonal, D the
///   distance to the nearest object): an object farther than D + 2r from c is nearer to no
///   point of the cell. One active object: no GVD enters the cell (kOneObject).
/// - Two active objects A and B: their simplices that can be nearest to a point of the cell
///   (within d_k(c) + 2r of c and within d_k(c) + r of the cell) must all lie on one plane
///   (2D: line) per object, and every edge (2D: end point) of them within reach of the cell
///   must continue, unfolded, into another simplex on that plane. Then every point of the
///   cell has its foot on each plane inside the object, so d_A = |s_A| and d_B = |s_B| exactly
///   (s = signed distance to the plane). The planes must not meet inside the cell (that would
///   be a contact), and exactly one of the two bisector branches s_A = s_B, s_A = -s_B may
///   cross the cell: the GVD in the cell is then that plane, exactly (kPair).
///
/// Anything else (three objects, curved or folded patches, open edges, contact pairs, more
/// than kMaxActive simplices in reach) is kSplit: the paper's rule applies. Thread-safe;
/// the geometry and BVH must outlive it.
class PairCertifier final : public SplitOracle {
 public:
  PairCertifier(const UnitGeometry& geometry, const SimplexBvh& bvh,
                const ContactPairs* contacts = nullptr);

  CellVerdict classify(const Box& box, std::span<const uint32_t> inside = {}) const override;

  /// A verdict with its witnesses (tests and audits use them).
  struct Certificate {
    CellVerdict verdict = CellVerdict::kSplit;
    ObjectId a = kNoObject;  ///< kOneObject: the object; kPair: the lower of the two
    ObjectId b = kNoObject;  ///< kPair: the higher one
    /// kPair: the plane (2D: line) of a and of b, as unit normal . x = offset (unit domain).
    Vec3 normal[2];
    double offset[2] = {0, 0};
  };
  Certificate certify(const Box& box) const;

  /// Cells with more simplices than this in reach are not certified (their children are).
  static constexpr size_t kMaxActive = 256;
  /// Largest distance of a vertex from its patch's plane (unit domain) accepted as flat. The
  /// lattice snaps coordinates to 2^-48, so exactly coplanar input stays within ~1e-14.
  static constexpr double kFlat = 1e-12;

 private:
  static constexpr uint32_t kOpen = 0xFFFFFFFFu;         ///< a side with no simplex across
  static constexpr uint32_t kNonManifold = 0xFFFFFFFEu;  ///< a side with several

  const UnitGeometry& geometry_;
  const SimplexBvh& bvh_;
  const ContactPairs* contacts_;
  /// Per point: the lowest index of a point at the same position (soups share no indices).
  std::vector<uint32_t> canonical_;
  /// Per simplex side (3D: edge v[e] v[e+1]; 2D: end v[e]): the simplex of the same object
  /// across it, kOpen or kNonManifold.
  std::vector<uint32_t> across_;
};

}  // namespace gvd

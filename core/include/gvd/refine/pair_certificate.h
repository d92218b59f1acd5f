#pragma once

// PairCertifier, the split oracle of the thin-gaps refinement: from exact distances it proves
// that only one object is nearest anywhere in a cell, or only two, whose bisector there is a
// plane, a curve swept along a straight rim (axis-aligned, slanted or skew), or crosses the lines
// along an axis at most twice (cones), so that the cell may stay a leaf. Anything else is kSplit:
// the paper's rule (§3) applies. Thread-safe; the geometry and BVH must outlive it.

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>
#include <set>
#include <span>
#include <utility>
#include <vector>

#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/contacts.h"
#include "gvd/octree/octree.h"
#include "gvd/scene/scene.h"

namespace gvd::refine {

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
/// - Mirror pairs (3D; folded patches, e.g. the rims of flush stacked plates): when B's surface
///   near the cell is A's reflected in a plane P that strictly separates them, every point on
///   A's side of P is nearer to A (its nearest point q on B reflects to a point of A, nearer
///   to it), so the GVD in the cell is P, exactly (kPair, `mirror`). Checked on the polygons
///   of each object's triangles clipped to the box Q around the cell that holds every
///   simplex that can be nearest (the cell inflated by max d_k(c) + r): each one, reflected,
///   must be covered by the other object's coplanar, equally oriented triangles (areas, to
///   kMirrorRound) and lie strictly on its own side of P. Only across thin gaps (kMirrorGap:
///   wider ones the paper's rule resolves cheaply, with finer pieces) and in cells small
///   enough that rounding cannot tilt the bisector visibly (kMirrorTolerance). 2D needs no
///   mirrors: its rims are points, and flat cells already cost log(1/g) there.
/// - Extruded pairs (3D; straight rims: an edge facing a face or a corner across g): both
///   objects are closed (T-junctions count as closed: match_split_sides; their normals taken
///   out of the material, each of up to 16 shells oriented by walking it and turned by its
///   nesting, whatever the input's vertex order; parts of one object that share edges paired
///   around them, and faces glued between parts left out), every simplex that can be nearest has
///   its normal perpendicular to one axis e, and on each of their planes the object's triangles
///   cover, within the box Q, a full strip across Q along e. Then both distance functions are
///   invariant along e in the cell, and the bisector is C x e for a curve C of the cross-section
///   (kExtrudedX + e). Also, all outward normals of a and all inward normals of b lie in one
///   quadrant of the cross-section (`rise`, its diagonal): the Clarke gradient of the signed
///   d_a - d_b lies in that quadrant and has a component >= 1 along `rise`, so C is a monotone
///   curve that meets every line along `rise` at most once and every side of a cross-section
///   square at most once (no saddles, no hidden arcs: the corners' labels show where it runs).
///   The surfacer traces C on the faces perpendicular to e and sweeps it along e. With `cones`,
///   where the normals lie in a cone of at most 2 kMaxCone that straddles a cross-section axis
///   (a hexagonal shaft's corner on an axis), C stays a graph but a line along that axis can
///   meet it twice, beside the apex of C's roof: the lines along it where octree edges of the
///   cell and its children can run (at quarters of the cell) are counted exactly
///   (line_crossings), at most two each (`twice` when some has two: the surfacer then finds
///   both crossings on such edges), and the cell's grandchildren are asked again (kCone...).
/// - Slanted extruded pairs (kSlanted...): the same along a direction e square to one axis a
///   but along neither other one (a hexagonal bore's edge at 60 degrees in its end plane):
///   the quadrant is taken on a and on w, the unit vector square to e in the plane of the
///   other two axes, onto which every octree edge not along a projects; so every octree edge
///   still meets the bisector at most once. The surfacer traces C on the four faces e
///   crosses and keeps the rungs on the two square to a. No cones here.
/// - Skew extruded pairs (kSkew): the same along a direction e square to no axis (the rims of
///   a faceted sphere, which run in every direction), e the common perpendicular of the
///   normals. Every octree edge crosses the cross-section, so the gradients must keep one
///   sign along each of the three axes (one octant): each edge then meets the bisector at
///   most once, and f is monotone along both axes of every face, which the tracer needs. The
///   surfacer traces C on all six faces and builds the ladder between the three faces e enters
///   by and the three it leaves by; it gets e again from the certificate of the leaf's own box
///   (the mark does not hold it), so children are asked again, never inherit. Where the
///   normals straddle one axis m (or a slanted rim straddles its own axis), a skew cone
///   (kSkewCone...): the normals within kMaxCone of their middle, and the lines along m at the
///   quarters of the cell across both other axes counted (at most two crossings, `twice`).
///
/// Anything else (three objects, curved or folded patches, open edges, contact pairs, more
/// than kMaxActive simplices in reach) is kSplit: the paper's rule applies. Thread-safe;
/// the geometry and BVH must outlive it.
class PairCertifier final : public octree::SplitOracle {
 public:
  /// `extruded`: also certify extruded pairs (the surfacer must then sweep their bisectors).
  /// `cones`: also the cones across an axis (kCone...). Their certificate covers the cell and
  /// its children only; where grandchildren fail it again round after round (lines that meet
  /// C more than twice, or whose count gives up), the pipeline builds the octree again without
  /// cones (RefineLoopOptions::cone_certifier). `cancel` (may be null) is read between the steps of
  /// the construction (sorts of the points and of the triangles' sides: a quarter second on
  /// 327k triangles): set, it stops with gvd::Error{kCancelled}.
  PairCertifier(const scene::UnitGeometry& geometry, const SimplexBvh& bvh,
                const octree::ContactPairs* contacts = nullptr, bool extruded = false,
                bool cones = false, const std::atomic<bool>* cancel = nullptr);

  octree::CellVerdict classify(const Box& box,
                               std::span<const uint32_t> inside = {}) const override;
  /// classify's verdict, but a child of a junction cell that it would split is a junction cell
  /// of two objects when certify_junction(box, 2) holds along the parent's axis: one level
  /// below a junction cell, beside the line, a cell may see two of its objects only, a rim of
  /// one in reach of the other (no pair certificate). Split into pair cells, such a cell forces
  /// the junction cell beside it along the line to split by 2:1 balance, whose children are
  /// such cells again: a split that runs along the whole line, a cell per round.
  octree::CellVerdict classify_child(const Box& box, std::span<const uint32_t> inside,
                                     uint8_t parent) const override;

  bool cones() const { return cones_; }
  /// Also certify junction cells (certify_junction: kJunctionX...); the surfacer must then
  /// sweep their faces' plane GVDs (SurfaceOptions::junction_face). Set before use.
  void enable_junctions(bool on = true) { junctions_ = on; }
  bool junctions() const { return junctions_; }
  /// No junction cell inside `box` (a lattice cell) from now on: one there could not be
  /// surfaced (surface::unswept_junction_leaves: a junction on a face between two cells, where
  /// the octree's labels show another crossing). Its cells follow the other certificates and
  /// the paper's rule. Thread-safe.
  void refuse_junctions_in(const Box& box);

  /// A verdict with its witnesses (tests and audits use them).
  struct Certificate {
    octree::CellVerdict verdict = octree::CellVerdict::kSplit;
    scene::ObjectId a = scene::kNoObject;  ///< kOneObject: the object; kPair: the lower of the two
    scene::ObjectId b = scene::kNoObject;  ///< kPair: the higher one
    /// kPair: the plane (2D: line) of a and of b, as unit normal . x = offset (unit domain).
    Vec3 normal[2];
    double offset[2] = {0, 0};
    /// kPair of mirror images: the bisector is the plane normal[0] . x = offset[0] (normal
    /// pointing from a to b; normal[1], offset[1] the same plane).
    bool mirror = false;
    /// Extruded pairs: the axis e (else -1) and the unit diagonal of the cross-section along
    /// which d_a - d_b increases (signed distances: at a rate of at least sqrt(2)).
    int axis = -1;
    Vec3 rise;
    /// Extruded pairs: whether every sub-cell is certified too (one quadrant). A cone that
    /// straddles an axis is checked on the lines of the cell and its children only, so
    /// grandchildren are asked again.
    bool inherited = true;
    int mixed = -1;  ///< then: the cross-section axis the cone straddles
    /// A skew wedge (kSkewWedge...): the one axis along which d_a - d_b is monotone; it
    /// straddles both others (mixed is the first of them).
    int monotone = -1;
    bool twice = false;  ///< and whether some of its lines along it cross the bisector twice
    /// Slanted extruded pairs (kSlanted...): the axis perpendicular to e (axis is -1 then).
    int slanted = -1;
    /// Skew extruded pairs (kSkew): e square to no axis (axis and slanted are -1 then).
    bool skew = false;
    Vec3 along;  ///< extruded pairs: e, a unit vector (the axis, the slanted or skew direction)
  };
  Certificate certify(const Box& box) const;

  /// A junction cell (3D): `min_objects` (three, or two: classify_child) to kMaxJunction objects
  /// can be nearest somewhere in the cell (two: only where every plane in reach is square to
  /// two axes, so that their plane GVD is made of straight pieces),
  /// none of them a contact pair, and every simplex of theirs that can be nearest to a point of
  /// the cell has its normal square to one axis e, its object closed, and on each of their
  /// planes the object's triangles cover a full strip across the box that holds them along e
  /// (the extruded pairs' conditions, for every object). Then every distance function is
  /// invariant along e in the cell, and the GVD there is G x e for the GVD G of the cross-section
  /// (a plane GVD of the objects' sections: the junction lines where packed boxes meet, a blade
  /// in the corner of two parts). certify and classify ask it once enable_junctions is set
  /// (docs/ALGORITHM.md, "Junction lines").
  static constexpr int kMaxJunction = 8;
  struct Junction {
    bool certified = false;
    int axis = -1;      ///< e
    int n_objects = 0;  ///< the active objects, ascending
    scene::ObjectId objects[kMaxJunction] = {};
  };
  /// `axis_first`: the axis tried first where the planes are square to two (-1: x, y, z).
  Junction certify_junction(const Box& box, int min_objects = 3, int axis_first = -1) const;

  /// Cells with more simplices than this in reach are not certified (their children are).
  static constexpr size_t kMaxActive = 256;
  /// Largest distance of a vertex from its patch's plane (unit domain) accepted as flat. The
  /// lattice snaps coordinates to 2^-48, so exactly coplanar input stays within ~1e-14. (The
  /// least: flat_ and mirror_round_ grow with the input's own rounding, UnitGeometry::rounding,
  /// for a scene far from the origin.)
  static constexpr double kFlat = 1e-12;
  /// Mirror pairs are certified only across gaps (between the facing planes) up to this,
  /// as a fraction of the domain side.
  static constexpr double kMirrorGap = 1.0 / 64;
  /// How far a mirror image may be off (unit domain): the lattice's 2^-48 and a little.
  static constexpr double kMirrorRound = 4.0 / (1ull << 48);
  /// Mirror cells are at most kMirrorTolerance * gap^2 / kMirrorRound in half-diagonal, so
  /// that the bisector's tilt from kMirrorRound stays within this part of the gap.
  static constexpr double kMirrorTolerance = 1e-4;
  /// Extruded pairs whose gradient directions straddle a cross-section axis: they must lie
  /// within this angle of the middle of their span, so that d_a - d_b grows along the middle
  /// at a rate of at least cos(kMaxCone) (C is a graph across it). 140 degrees in all holds a
  /// triangle's corners (120); the tracer's lines run along the middle of the gradients at a
  /// chord's ends, which meets a curve that turns one way once for any turn below 180.
  static constexpr double kMaxCone = 70.0 * 3.14159265358979323846 / 180.0;
  /// Skew wedges: the largest angle their gradient directions may span seen on the faces
  /// square to the monotone axis, where the surfacer pairs the bisector's pieces by sorting
  /// them across the middle of that span (a graph across it for any span below 180 degrees;
  /// the surfacer accepts up to 179).
  static constexpr double kMaxFaceSpan = 175.0 * 3.14159265358979323846 / 180.0;

 private:
  Certificate certify_mirror(const Box& box, const scene::ObjectId pair[2], const double dist[2],
                             double r, const std::vector<uint32_t> patch[2]) const;
  Certificate certify_extruded(const Box& box, const scene::ObjectId pair[2], const double dist[2],
                               double r, const std::vector<uint32_t> patch[2]) const;
  /// Whether, on each plane n[i] . x = offset[i] (unit normals, out of `object`'s material) of
  /// its simplices that can be nearest, `object`'s triangles clipped to `near` add up to a
  /// full strip across `near` along `along` (`axis` >= 0: that coordinate axis): a closed
  /// mesh's triangles do not overlap, so equal areas mean the strip is covered.
  bool strips_cover(const Box& near, int axis, Vec3 along, scene::ObjectId object,
                    std::span<const Vec3> n, std::span<const double> offset) const;
  /// How often d_0 - d_1 (the distances to the objects of patch[0] and patch[1]) changes sign
  /// on the segment [p0, p1] along axis `along` inside the cell whose nearest simplices are
  /// `patch` (3: more than twice, or undecided).
  int line_crossings(Vec3 p0, Vec3 p1, int along, const std::vector<uint32_t> patch[2]) const;

  static constexpr uint32_t kOpen = 0xFFFFFFFFu;         ///< a side with no simplex across
  static constexpr uint32_t kNonManifold = 0xFFFFFFFEu;  ///< a side with several
  /// 3D: a side with several simplices across it end to end along its line (a T-junction: a
  /// vertex of the neighbours lies inside the side), each once (split_).
  static constexpr uint32_t kSplit = 0xFFFFFFFDu;
  /// Simplices across one kSplit side at most.
  static constexpr int kMaxSplit = 8;
  /// One simplex across a kSplit side: its side `other_side` lies on the side's line, and
  /// `alike` says whether it runs that line the same way.
  struct SplitLink {
    uint32_t side;
    uint32_t simplex;
    uint8_t other_side;
    bool alike;
  };
  /// Marks kSplit the open sides covered once, along their whole length, by open sides of
  /// other simplices of the same object on their line (end points within kMirrorRound of it),
  /// and records those in split_.
  void match_split_sides(const std::atomic<bool>* cancel);
  /// The first of a kSplit side's links in split_.
  std::vector<SplitLink>::const_iterator split_links(uint32_t side) const;

  const scene::UnitGeometry& geometry_;
  const SimplexBvh& bvh_;
  const octree::ContactPairs* contacts_;
  bool extruded_;
  bool cones_;
  bool junctions_ = false;
  /// The lattice cells refuse_junctions_in named, as (level, x, y, z).
  mutable std::mutex refused_mutex_;
  std::set<std::array<uint32_t, 4>> refused_;
  bool junction_refused(const Box& box) const;
  /// Per point: the lowest index of a point at the same position (soups share no indices).
  std::vector<uint32_t> canonical_;
  /// Per simplex side (3D: edge v[e] v[e+1]; 2D: end v[e]): the simplex of the same object
  /// across it, kOpen, kNonManifold or kSplit.
  std::vector<uint32_t> across_;
  /// The simplices across each kSplit side, sorted by side (3D).
  std::vector<SplitLink> split_;
  /// Per simplex (3D): +1 when the normal of its vertex order points out of its object's
  /// material, -1 when it points in, 0 when the object is not closed (an open or non-manifold
  /// edge, more than 16 shells, a shell that cannot be oriented or encloses no volume). The
  /// material is found by the object's shells' nesting, not by the input's vertex order: each
  /// shell is oriented by walking it and turned so that its volume takes the sign its nesting
  /// asks, so a cavity drawn the wrong way or triangles flipped in a closed mesh cost nothing.
  std::vector<int8_t> facing_;
  /// Per simplex (empty: none): 1 where it is a face glued between two parts of its object,
  /// inside the object (see the constructor); certificates leave it out.
  std::vector<uint8_t> buried_;
  bool buried(uint32_t s) const { return s < buried_.size() && buried_[s] != 0; }
  /// kFlat and kMirrorRound, or 8 and 4 times the input coordinates' own rounding where that
  /// is larger (a scene 1000 times its size from the origin: its doubles carry ~1e-13 of it,
  /// and flush faces turned with it are coplanar only to that).
  double flat_ = kFlat;
  double mirror_round_ = kMirrorRound;
};

}  // namespace gvd::refine

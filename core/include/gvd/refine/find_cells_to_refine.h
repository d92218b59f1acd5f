#pragma once

// The decisions of the refinement loop (refine/refine.h): which leaves must be split before
// surfacing (paper §5, the separation guarantee, unseen regions) and, for the separation,
// which cells below them in one pass.

#include <cstdint>
#include <span>
#include <vector>

#include "gvd/distance/distance_field.h"
#include "gvd/distance/leaf_vertices.h"
#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/contacts.h"
#include "gvd/octree/leaf_simplices.h"
#include "gvd/octree/octree.h"
#include "gvd/scene/scene.h"

namespace gvd::refine {

/// Why leaves must be split before surfacing (paper §5 and the separation guarantee).
struct RefineReport {
  std::vector<uint32_t> ambiguous_leaves;  ///< ambiguous leaves to split (all below their limit)
  /// Non-empty leaves with a vertex labelled by another object, to split (below the limit).
  std::vector<uint32_t> foreign_leaves;
  std::vector<uint32_t> unseen_leaves;  ///< leaves hiding an object's region (below the limit)
  uint64_t ambiguous_count = 0;         ///< ambiguous cells found (any depth)
  uint64_t ambiguous_at_limit = 0;      ///< of those, at the depth limit
  uint64_t foreign_count = 0;     ///< non-empty leaves with a vertex labelled by another object
  uint64_t foreign_at_limit = 0;  ///< of those, at the depth limit
  uint64_t touching_leaves = 0;   ///< leaves that intersect several objects (at the limit)
  uint64_t unseen_count = 0;      ///< cells whose GVD points are nearest to an unseen object
  uint64_t unseen_at_limit = 0;   ///< of those, at the depth limit
};

/// Finds the leaves to subdivide (paper §5): a cell is ambiguous when collapsing the edges of
/// its boundary graph whose ends carry the same label does not leave a simplex of dimension
/// <= D (a complete graph on at most D + 1 distinct labels). In addition, a leaf that
/// intersects object o but has a vertex labelled with another object is split, so that the GVD
/// never passes through a non-empty leaf (and so never crosses an object) above the depth limit.
/// Ambiguity is resolved at most `ambiguity_levels` levels below the level the leaf's region
/// had in the octree of the rules of §3 (`base_level`), so degenerate configurations (four or more
/// cells meeting where three would be generic, e.g. symmetric arrays) do not refine to the
/// depth limit; those cells count as `ambiguous_at_limit` and are surfaced by the centroid rule.
/// Certified leaves (Octree::certified) are never flagged: their certificate proves that only
/// their two objects are nearest in them and that the bisector there is one exact sheet.
struct RefineOptions {
  int threads = 0;
  /// Per leaf of the octree examined: the level of the leaf of the first octree (the rules of
  /// §3) that holds it. Empty: ambiguity is resolved down to max_depth.
  std::span<const uint8_t> base_level;
  int ambiguity_levels = 3;
  /// With both set, a leaf the GVD crosses is also split when one of its GVD points has an
  /// exact nearest object it does not claim — in 2D an edge bisector one other than the edge's
  /// two labels; a face or cell centroid one that no vertex of the leaf carries — by more than
  /// a margin (2D: a hair; 3D: a twentieth of the leaf): a region hides between the vertices, and
  /// the dual graph would otherwise gain a false edge or miss one. Such leaves go to `unseen`.
  const scene::UnitGeometry* geometry = nullptr;
  const SimplexBvh* bvh = nullptr;
  /// Only examine leaves with a vertex whose `DistanceField::changed` flag is set (between
  /// refinement rounds: untouched leaves were already examined). Counts then cover only those.
  bool changed_only = false;
  /// Touching object pairs: a leaf of one of them is not split for a vertex labelled by the
  /// other below `contact_depth` (they cannot be separated there).
  const octree::ContactPairs* contacts = nullptr;
  int contact_depth = 0;
  /// Optional: the octree's leaf simplices (with `geometry`, a leaf holding several objects
  /// is split unless only touching pairs meet there) and the field's leaf vertices (read
  /// instead of looking the vertices up by key).
  const octree::LeafSimplices* leaf_simplices = nullptr;
  const distance::LeafVertices* leaf_vertices = nullptr;
};
RefineReport find_cells_to_refine(const octree::Octree& octree,
                                  const distance::DistanceField& field,
                                  const RefineOptions& options = {});

/// For non-empty leaves with a vertex labelled by another object: the cells to split below
/// them, recursively, until no non-empty descendant has a corner whose exact nearest object
/// (BVH) differs from the one it intersects, or max_depth is reached. Plans in one pass what
/// would otherwise take one global refinement round per level.
/// With `oracle`, a cell it certifies (a certified_mark verdict) or finds seen by one object only
/// is not split: certified ones go to `certified`, for refine_octree to mark.
struct SeparationPlan {
  std::vector<octree::CellRef> splits;
  std::vector<octree::CellRef> certified;
};
SeparationPlan plan_separation_splits(const octree::Octree& octree,
                                      const octree::LeafSimplices& simplices,
                                      const scene::UnitGeometry& geometry, const SimplexBvh& bvh,
                                      std::span<const uint32_t> leaves, int threads = 0,
                                      const octree::ContactPairs* contacts = nullptr,
                                      int contact_depth = 0,
                                      const octree::SplitOracle* oracle = nullptr);

}  // namespace gvd::refine

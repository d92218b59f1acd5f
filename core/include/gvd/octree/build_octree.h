#pragma once

// The octree builds (paper §3): the level-synchronous build with its options, the refinement
// of given cells, and the oracle through which the thin-gaps refinement (refine/) decides
// splits.

#include <atomic>
#include <cstdint>
#include <functional>
#include <span>
#include <string>

#include "gvd/octree/leaf_simplices.h"
#include "gvd/octree/octree.h"
#include "gvd/scene/scene.h"

namespace gvd::octree {

class ContactPairs;

/// Progress report of a long stage: stage name and fraction done in [0, 1].
using ProgressFn = std::function<void(const std::string& stage, double fraction)>;

/// Decides, for a cell the paper's rule would split, whether it must be split (the
/// thin-gaps refinement of refine/; the octree module only asks). Thread-safe.
class SplitOracle {
 public:
  virtual ~SplitOracle() = default;
  /// The verdict for the closed cell `box` (unit domain). `inside` (optional) lists the
  /// simplices that touch the cell, which lets most cells that must split be told cheaply.
  virtual CellVerdict classify(const Box& box, std::span<const uint32_t> inside = {}) const = 0;
  /// The verdict for a child of a certified cell whose mark (certified_mark) is `parent` and
  /// which does not pass it on (inherited_mark 0). By default classify's.
  virtual CellVerdict classify_child(const Box& box, std::span<const uint32_t> inside,
                                     uint8_t parent) const {
    (void)parent;
    return classify(box, inside);
  }
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

/// Builds the octree with the paper's SHOULD_SUBDIVIDE (§3): a cell is split when it
/// intersects more than one object, or when a face-neighbour intersects a different object,
/// until `max_depth`; then balanced so that leaves sharing a face, edge or corner differ by
/// at most one level (so that surfacing stays watertight across level changes). Cell–simplex
/// tests are conservative. Level-synchronous and parallel over cells;
/// O(sum over levels of non-empty cells x simplices per cell). `simplices` (optional)
/// receives the simplices that touch each leaf, which refine_octree needs.
Octree build_octree(const scene::UnitGeometry& geometry, const OctreeOptions& options = {},
                    LeafSimplices* simplices = nullptr);

/// Splits the given cells (existing leaves, or cells inside leaves, whose ancestors are then
/// split too; cells at max_depth are ignored), re-balances and recomputes the leaf -> simplex
/// incidence from `simplices` (the octree's, from its build): only the leaves that split are
/// tested again. Leaves inside a certified leaf stay certified; the leaves that end up inside
/// one of `cells_to_certify` (cells at or below an existing leaf) are marked certified too.
/// `refined_simplices` (optional; not `simplices` itself) receives the new octree's lists.
/// Used for ambiguity resolution (§5) and the separation guarantee.
Octree refine_octree(const Octree& octree, const LeafSimplices& simplices,
                     const scene::UnitGeometry& geometry, std::span<const CellRef> cells_to_split,
                     const OctreeOptions& options = {},
                     std::span<const CellRef> cells_to_certify = {},
                     LeafSimplices* refined_simplices = nullptr);

}  // namespace gvd::octree

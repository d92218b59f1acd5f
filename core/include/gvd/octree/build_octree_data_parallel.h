#pragma once

// The data-parallel octree build: Morton codes and a binary radix tree of the object vertices,
// the cells each simplex is stored in, conflict cells refined level by level, then the engine's
// rule, 2:1 balance and leaves as in build_octree. Its steps sit behind OctreeBuildSteps (CPU
// twins here, OpenCL kernels in kernels/), which run the same per-item functions
// (octree_build_item.h), so both agree exactly and the leaves are build_octree's.

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "gvd/octree/build_octree.h"
#include "gvd/octree/octree.h"
#include "gvd/octree/octree_build_item.h"

namespace gvd::octree {

/// The geometry in the layout of the steps' per-item functions (octree_build_item.h): points
/// as GvdPoint, each simplex as three point indices (the third repeats in 2D). Made once here
/// for the CPU twins and the OpenCL steps alike.
struct ItemGeometry {
  std::vector<item::GvdPoint> points;
  std::vector<uint32_t> simplices;
};
ItemGeometry item_geometry(const scene::UnitGeometry& geometry);

/// Rows of a compressed sparse table (begin has rows + 1 entries).
struct CsrU32 {
  std::vector<uint32_t> begin{0};
  std::vector<uint32_t> items;
  size_t rows() const { return begin.size() - 1; }
};

/// The cells the simplices are stored in (gvd_facet_cells), clamped to the tree and sorted by
/// (level, code): entries of level l are [level_begin[l], level_begin[l + 1]).
struct SccArray {
  std::vector<uint64_t> code;
  std::vector<uint32_t> simplex;
  std::vector<item::GvdPoint> lo, hi;  ///< the simplex's bounding box (an early reject)
  std::vector<uint32_t> level_begin;   ///< max_level + 2 entries
};

/// The data-parallel steps of the octree build (parallel-quadtree-construction draft §3.2-3.5
/// after Karras 2012), bound to one scene's geometry. The CPU twins are in core
/// (make_cpu_octree_build_steps); kernels/ implements them as OpenCL kernels. Every step runs
/// the per-item functions of octree_build_item.h, so both agree exactly.
class OctreeBuildSteps {
 public:
  virtual ~OctreeBuildSteps() = default;
  /// Morton codes of every point, truncated to `max_level` levels (code >> D (B - max_level)).
  virtual std::vector<uint64_t> vertex_keys(int max_level) = 0;
  /// The n - 1 internal nodes of the binary radix tree over n >= 2 sorted unique keys of
  /// `bits` bits, and each one's parent (-1 for the root).
  virtual void radix_tree(std::span<const uint64_t> keys, int bits,
                          std::vector<item::GvdRadixNode>& nodes, std::vector<int32_t>& parent) = 0;
  /// The cells every simplex is stored in (gvd_facet_cells: its smallest containing cell,
  /// the draft's container(f), or the <= 2^D cells of its size), at most max_level; CSR over
  /// simplices (`begin`, then `code` and `level` per entry). Two passes: count, fill.
  virtual void facet_cells(int max_level, std::vector<uint32_t>& begin, std::vector<uint64_t>& code,
                           std::vector<int32_t>& level) = 0;
  /// Draft Algorithm 2, lines 10-28: for every cell (code, level) the facets stored at its
  /// ancestors (and itself) in `scc` that touch it. Two passes: count, exclusive prefix sum,
  /// fill.
  virtual CsrU32 cell_facets(const SccArray& scc, std::span<const uint64_t> cell_code,
                             std::span<const uint8_t> cell_level) = 0;
  /// Draft Algorithm 3 (one level of refinement): for child cell i of parent[i], the facets of
  /// the parent's list (row parent[i] of `lists`) that touch it. Two passes as above.
  virtual CsrU32 child_facets(const CsrU32& lists, std::span<const uint32_t> parent,
                              std::span<const uint64_t> child_code,
                              std::span<const uint8_t> child_level) = 0;
};

/// The CPU twins of the steps, over `threads` threads (0 = all cores).
std::unique_ptr<OctreeBuildSteps> make_cpu_octree_build_steps(const scene::UnitGeometry& geometry,
                                                              int threads = 0);

/// Figures of one data-parallel build.
struct DataParallelBuildStats {
  uint64_t vertex_keys = 0;  ///< unique vertex codes (radix tree leaves)
  uint64_t vertex_octree_leaves = 0;
  uint64_t conflict_cells = 0;   ///< leaves of the vertex octree touching >1 object
  uint64_t refined_cells = 0;    ///< cells split while resolving conflicts
  uint64_t resolved_leaves = 0;  ///< leaves of the conflict-free octree
  int refine_levels = 0;
  /// Wall time of the parts (seconds): vertex octree (keys, sort, radix tree, cells), facet
  /// lists (SCC + Algorithm 2), conflict refinement, the engine's rule, balance + leaves.
  double seconds_vertex_octree = 0, seconds_facets = 0, seconds_refine = 0, seconds_rule = 0,
         seconds_materialize = 0;
};

/// The octree of build_octree, built the data-parallel way of the draft: (1) Morton codes of
/// the object vertices, radix sort, Karras binary radix tree and the octree it implies (the
/// "vertex octree": every leaf holds at most one vertex code); (2) the smallest containing
/// cell of every simplex from the longest common Morton prefix of its (slack-inflated)
/// bounding box — a small simplex straddling a coarse boundary goes to the <= 2^D cells of its
/// own size instead (gvd_facet_cells) — sorted by (level, code), and per leaf the facets
/// stored at its ancestors that touch it (two-pass count / prefix sum / fill); (3) conflict cells
/// (leaves touching more than one object, contact pairs exempt below the contact depth) refined
/// level by level until none is left or the depth limit is hit. The engine's rules then decide the
/// final tree from the contents of this conflict-free octree: SHOULD_SUBDIVIDE's buffer-cell rule
/// (§3), the closure, the 2:1 balance and the leaf -> simplex incidence are the CPU build's (the
/// draft gives no data-parallel form for them). Same leaves as build_octree. `steps` = null runs
/// the CPU twins. `simplices` (optional) receives the leaves' simplex lists, as build_octree's.
Octree build_octree_data_parallel(const scene::UnitGeometry& geometry,
                                  const OctreeOptions& options = {},
                                  OctreeBuildSteps* steps = nullptr,
                                  DataParallelBuildStats* stats = nullptr,
                                  LeafSimplices* simplices = nullptr);

/// The last steps of build_octree from a set of cells to split (SHOULD_SUBDIVIDE's outcome):
/// the ancestors of every split cell, 2:1 balance over faces, edges and corners, and the
/// leaves with their simplices; the leaves at or below a cell of `certified` are marked
/// certified; `simplices` (optional) receives the leaves' simplex lists. Used by
/// build_octree_data_parallel.
Octree octree_from_split_cells(const scene::UnitGeometry& geometry, std::span<const CellRef> split,
                               const OctreeOptions& options = {},
                               std::span<const CellRef> certified = {},
                               LeafSimplices* simplices = nullptr);

}  // namespace gvd::octree

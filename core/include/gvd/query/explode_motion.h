#pragma once

// Collision-free exploded views (GvdIndex::explode): how much of an object's displacement can
// be kept so that no two objects meet while all of them move at once, each along its vector
// from t = 0 to t = 1 (the animation of exploded_to_glb).

#include <cstdint>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "gvd/geometry/simplex_bvh.h"
#include "gvd/graph/dual_graph.h"
#include "gvd/scene/scene.h"

namespace gvd::query {

/// Shares of a displacement tried first, largest first; between the last safe one and the
/// one before it, the share is refined by kExplodeRefinements bisection steps. Below the
/// last, the object stays (share 0, always safe).
inline constexpr double kExplodeShares[] = {1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125, 0.015625};
inline constexpr int kExplodeRefinements = 4;
/// How much of the margin objects that are not neighbours may approach: a slack, so that a
/// pair that slides past at a constant distance is certified in at most 1 / kExplodeSlack
/// advancement steps.
inline constexpr double kExplodeSlack = 0.01;

/// Objects given their motion one at a time (GvdIndex::explode: ring by ring). An object
/// not yet committed stays where it is; a committed one moves along its displacement over
/// t in [0, 1]. A displacement is safe when, for every t in [0, 1], the object keeps from
/// every other object at least
///   - half of min(their gap at t = 0, `margin`) when the two are neighbours in the dual
///     graph (their cells share an interface), and
///   - their gap at t = 0 less kExplodeSlack * `margin` (but never less than the neighbours'
///     bound) when they are not: objects that are not neighbours do not approach.
/// Pairs touching at t = 0 are checked from t = 1e-4 on and must come apart. Certified, not
/// sampled: conservative advancement on exact mesh distances (a pair whose distance is d at
/// t cannot meet before t + d / |relative motion|), and on the gap along the direction n of
/// the closest pair (min over one object of x.n - max over the other of y.n, a lower bound of
/// the distance that changes linearly with the motion: a pair moving apart along n is
/// certified at once instead of in steps of its room). Every pair is checked when the later of
/// its two objects is committed, with both motions final, so a view built by largest_share
/// + commit is collision-free as a whole.
class ExplodeMotion {
 public:
  /// `geometry` / `bvh`: the result's unit-domain scene (bvh built with the objects of the
  /// simplices); `graph` says which pairs are neighbours; `margin` in user units (the explode
  /// scale).
  ExplodeMotion(const scene::UnitGeometry& geometry, const SimplexBvh& bvh,
                const scene::Domain& domain, const graph::DualGraph& graph, double margin);

  /// The largest share s in [0, 1] found such that moving `object` by s * `displacement`
  /// (user units) is safe against the committed objects' motions and the others standing:
  /// the first safe one of kExplodeShares, refined by bisection towards the next larger
  /// one; 0 when none is safe. 1 for a zero displacement or an object without simplices.
  double largest_share(uint32_t object, Vec3 displacement);

  /// Fixes the object's motion (user units); later shares are checked against it.
  void commit(uint32_t object, Vec3 displacement);

 private:
  double distance(uint32_t a, uint32_t b, Vec3 shift) const;
  /// min over a's vertices of x.n - max over b's of y.n (both unmoved): a lower bound of
  /// their distance for unit n.
  double support_gap(uint32_t a, uint32_t b, Vec3 n) const;
  double gap(uint32_t a, uint32_t b);
  bool stays_apart(uint32_t a, uint32_t b, Vec3 move_a, Vec3 move_b);
  Vec3 to_unit_vector(Vec3 displacement) const;

  const scene::UnitGeometry& geometry_;
  const SimplexBvh& bvh_;
  const scene::Domain& domain_;
  double unit_margin_;
  std::vector<std::vector<uint32_t>> simplices_;  ///< per object
  std::vector<std::vector<uint32_t>> vertices_;   ///< per object, each once
  std::vector<Box> box_;                          ///< per object, unit coordinates
  std::vector<Vec3> move_;                        ///< committed motion, unit coordinates
  std::unordered_set<uint64_t> neighbours_;       ///< dual-graph pairs (lo << 32 | hi)
  std::unordered_map<uint64_t, double> gaps_;     ///< unit gap at t = 0 by pair (lo << 32 | hi)
};

}  // namespace gvd::query

// Collision-free exploded views (explode_motion.h).

#include "explode_motion.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace gvd {

namespace {

/// The motion of two objects over t in [0, 1], in unit coordinates.
struct PairMotion {
  uint32_t a, b;
  Vec3 move_a, move_b;  ///< displacement of each at t = 1
};

class MeshDistance {
 public:
  MeshDistance(const UnitGeometry& geometry, const SimplexBvh& bvh)
      : geometry_(geometry), bvh_(bvh), simplices_(geometry.object_count) {
    for (uint32_t s = 0; s < geometry.simplices.size(); ++s)
      simplices_[geometry.object_of[s]].push_back(s);
  }

  /// The simplices of one object.
  const std::vector<uint32_t>& simplices_of(uint32_t object) const { return simplices_[object]; }

  /// Exact distance between object a moved by `shift` and object b, unit coordinates: the
  /// smaller object's simplices against the other's own tree.
  double distance(uint32_t a, uint32_t b, Vec3 shift) const {
    if (simplices_[a].size() > simplices_[b].size()) {
      std::swap(a, b);
      shift = shift * -1.0;
    }
    const int arity = geometry_.dimension == 2 ? 2 : 3;
    double best = 1e300;
    for (uint32_t s : simplices_[a]) {
      Vec3 q[3];
      for (int k = 0; k < arity; ++k) q[k] = geometry_.points[geometry_.simplices[s].v[k]] + shift;
      const ClosestHit hit = bvh_.closest_to_simplex_in_object(q, b, best);
      if (hit.found()) best = hit.dist2;
      if (best == 0) break;
    }
    return std::sqrt(best);
  }

  /// Whether the pair stays at least `keep` apart for t in [0, 1] (keep = half of
  /// min(gap at 0, margin); see collision_free_factors).
  bool stays_apart(const PairMotion& m, double margin) const {
    const Vec3 relative = m.move_a - m.move_b;
    const double speed = norm(relative);
    if (!(speed > 0)) return true;  // nothing changes between them
    const double gap = distance(m.a, m.b, Vec3{});
    double t = 0;
    const double keep = 0.5 * std::min(gap, margin);
    if (!(gap > 0)) {
      t = 1e-4;  // touching at the start: they must come apart
      if (!(distance(m.a, m.b, relative * t) > 0)) return false;
    }
    for (int step = 0; step < 256; ++step) {
      const double d = distance(m.a, m.b, relative * t);
      const double room = d - keep;
      // Not closer than `keep` anywhere in [t, t + room / speed] (distance changes at most by
      // the relative speed); a step too small to get anywhere is a meeting.
      if (!(room > 1e-9 * (keep + speed))) return false;
      t += room / speed;
      if (t >= 1) return true;
    }
    return false;
  }

 private:
  const UnitGeometry& geometry_;
  const SimplexBvh& bvh_;
  std::vector<std::vector<uint32_t>> simplices_;
};

Box object_box(const UnitGeometry& g, const std::vector<uint32_t>& simplices) {
  Box b;
  const int arity = g.dimension == 2 ? 2 : 3;
  for (uint32_t s : simplices)
    for (int k = 0; k < arity; ++k) b.extend(g.points[g.simplices[s].v[k]]);
  return b;
}

/// The box swept by `box` moving by 0..move, grown by `grow` on every side.
Box swept(const Box& box, Vec3 move, double grow) {
  Box b = box;
  b.extend(Box{box.lo + move, box.hi + move});
  b.lo = b.lo - Vec3{grow, grow, grow};
  b.hi = b.hi + Vec3{grow, grow, grow};
  return b;
}

bool overlap(const Box& x, const Box& y) {
  for (int i = 0; i < 3; ++i)
    if (x.lo[i] > y.hi[i] || y.lo[i] > x.hi[i]) return false;
  return true;
}

}  // namespace

std::vector<double> collision_free_factors(const UnitGeometry& geometry, const SimplexBvh& bvh,
                                           const Domain& domain, std::span<const Vec3> displacement,
                                           std::span<const uint32_t> order, double margin) {
  const uint32_t n = geometry.object_count;
  std::vector<double> factor(n, 0.0);
  const Vec3 zero = domain.to_unit(Vec3{});
  std::vector<Vec3> move(n);  // unit coordinates, the whole displacement
  for (uint32_t o = 0; o < n && o < displacement.size(); ++o)
    move[o] = domain.to_unit(displacement[o]) - zero;
  const double unit_margin = margin / domain.side;
  const MeshDistance distance(geometry, bvh);
  auto empty = [&](uint32_t o) { return distance.simplices_of(o).empty(); };
  std::vector<Box> box(n);
  for (uint32_t o = 0; o < n; ++o) box[o] = object_box(geometry, distance.simplices_of(o));

  // Candidate pairs: boxes swept by the whole displacements, grown by half the margin (the
  // most any pair must keep), that meet. Sorted on x, then tested in full.
  std::vector<Box> reach(n);
  for (uint32_t o = 0; o < n; ++o) reach[o] = swept(box[o], move[o], 0.25 * unit_margin);
  std::vector<uint32_t> by_x(n);
  std::iota(by_x.begin(), by_x.end(), 0u);
  std::sort(by_x.begin(), by_x.end(),
            [&](uint32_t x, uint32_t y) { return reach[x].lo.x < reach[y].lo.x; });
  std::vector<std::vector<uint32_t>> near(n);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t a = by_x[i];
    if (empty(a)) continue;
    for (size_t j = i + 1; j < n && reach[by_x[j]].lo.x <= reach[a].hi.x; ++j) {
      const uint32_t b = by_x[j];
      if (empty(b) || !overlap(reach[a], reach[b])) continue;
      near[a].push_back(b);
      near[b].push_back(a);
    }
  }

  std::vector<uint8_t> done(n, 0);
  for (uint32_t a : order) {
    if (a >= n || done[a]) continue;
    done[a] = 1;
    if (!(norm(move[a]) > 0) || empty(a)) continue;  // stays: factor 0 is exact
    for (double f : kExplodeFactors) {
      if (f == 0) break;
      bool safe = true;
      for (uint32_t b : near[a]) {
        const Vec3 mb = done[b] ? move[b] * factor[b] : Vec3{};
        safe = distance.stays_apart({a, b, move[a] * f, mb}, unit_margin);
        if (!safe) break;
      }
      if (safe) {
        factor[a] = f;
        break;
      }
    }
  }
  return factor;
}

}  // namespace gvd

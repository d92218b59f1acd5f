// Collision-free exploded views (explode_motion.h).

#include "gvd/query/explode_motion.h"

#include <algorithm>
#include <cmath>

namespace gvd::query {

using namespace gvd::scene;
using namespace gvd::graph;

namespace {

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

uint64_t pair_key(uint32_t a, uint32_t b) {
  return (uint64_t{std::min(a, b)} << 32) | std::max(a, b);
}

bool overlap(const Box& x, const Box& y) {
  for (int i = 0; i < 3; ++i)
    if (x.lo[i] > y.hi[i] || y.lo[i] > x.hi[i]) return false;
  return true;
}

}  // namespace

ExplodeMotion::ExplodeMotion(const UnitGeometry& geometry, const SimplexBvh& bvh,
                             const Domain& domain, const DualGraph& graph, double margin)
    : geometry_(geometry),
      bvh_(bvh),
      domain_(domain),
      unit_margin_(margin / domain.side),
      simplices_(geometry.object_count),
      vertices_(geometry.object_count),
      box_(geometry.object_count),
      move_(geometry.object_count) {
  for (uint32_t s = 0; s < geometry.simplices.size(); ++s)
    simplices_[geometry.object_of[s]].push_back(s);
  const int arity = geometry.dimension == 2 ? 2 : 3;
  for (uint32_t o = 0; o < geometry.object_count; ++o) {
    box_[o] = object_box(geometry, simplices_[o]);
    std::vector<uint32_t>& v = vertices_[o];
    for (uint32_t s : simplices_[o])
      for (int k = 0; k < arity; ++k) v.push_back(geometry.simplices[s].v[k]);
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  for (const DualEdge& e : graph.edges) neighbours_.insert(pair_key(e.a, e.b));
}

Vec3 ExplodeMotion::to_unit_vector(Vec3 displacement) const {
  return domain_.to_unit(displacement) - domain_.to_unit(Vec3{});
}

/// Exact distance between object a moved by `shift` and object b, unit coordinates: both
/// objects' trees walked together.
double ExplodeMotion::distance(uint32_t a, uint32_t b, Vec3 shift) const {
  return std::sqrt(bvh_.object_distance(a, b, 1e300, shift).dist2);
}

double ExplodeMotion::gap(uint32_t a, uint32_t b) {
  const uint64_t key = pair_key(a, b);
  const auto it = gaps_.find(key);
  if (it != gaps_.end()) return it->second;
  const double d = distance(a, b, Vec3{});
  gaps_.emplace(key, d);
  return d;
}

/// Whether the pair keeps its distance bound (explode_motion.h) for t in [0, 1].
bool ExplodeMotion::stays_apart(uint32_t a, uint32_t b, Vec3 move_a, Vec3 move_b) {
  const Vec3 relative = move_a - move_b;
  const double speed = norm(relative);
  if (!(speed > 0)) return true;  // nothing changes between them
  const double at_start = gap(a, b);
  double t = 0;
  double keep = 0.5 * std::min(at_start, unit_margin_);
  if (!neighbours_.contains(pair_key(a, b)))
    keep = std::max(keep, at_start - kExplodeSlack * unit_margin_);
  if (!(at_start > 0)) {
    t = 1e-4;  // touching at the start: they must come apart
    if (!(distance(a, b, relative * t) > 0)) return false;
  }
  for (int step = 0; step < 1024; ++step) {
    // Beyond keep + speed * (1 - t) the pair is apart for the rest of the motion: nothing
    // farther needs its exact distance (fewer boxes opened).
    const double cap = (keep + speed * (1 - t)) * (1 + 1e-6);
    const SimplexBvh::ObjectPair pair = bvh_.object_distance(a, b, cap * cap, relative * t);
    const double d = pair.found ? std::sqrt(pair.dist2) : cap;
    const double room = d - keep;
    // Not closer than `keep` anywhere in [t, t + room / speed] (distance changes at most by
    // the relative speed); a step too small to get anywhere is a meeting.
    if (!(room > 1e-9 * (keep + speed))) return false;
    double advance = room / speed;
    const Vec3 between = pair.on_a - pair.on_b;
    if (pair.found && norm(between) > 0) {
      // The gap along n, the direction of the closest pair, is a lower bound of the
      // distance that changes exactly linearly: min over a of x.n - max over b of y.n, a
      // moved by relative * t (1-Lipschitz projection). Where it is above keep it holds
      // until it has fallen to keep at the rate relative.n, or for good when a moves away
      // along n: a pair moving apart is certified in one step instead of crawling at
      // room / speed (a slack of 1 % of the margin for pairs that are not neighbours).
      const Vec3 n = between * (1.0 / norm(between));
      const double along = support_gap(a, b, n) + dot(relative * t, n);
      const double rate = dot(relative, n);
      if (along > keep) advance = std::max(advance, rate >= 0 ? 2.0 : (along - keep) / -rate);
    }
    t += advance;
    if (t >= 1) return true;
  }
  return false;
}

double ExplodeMotion::largest_share(uint32_t a, Vec3 displacement) {
  const uint32_t n = geometry_.object_count;
  const Vec3 move = to_unit_vector(displacement);
  if (a >= n || !(norm(move) > 0) || simplices_[a].empty()) return 1;
  // Candidates: objects whose boxes, swept by their motions and grown by half the margin
  // (the most any pair must keep), meet this one's swept by the whole displacement.
  const double grow = 0.25 * unit_margin_;
  const Box reach = swept(box_[a], move, grow);
  std::vector<uint32_t> near;
  for (uint32_t b = 0; b < n; ++b) {
    if (b != a && !simplices_[b].empty() && overlap(reach, swept(box_[b], move_[b], grow)))
      near.push_back(b);
  }
  auto safe = [&](double share) {
    for (uint32_t b : near)
      if (!stays_apart(a, b, move * share, move_[b])) return false;
    return true;
  };
  double lo = 0, hi = 0;
  for (double share : kExplodeShares) {
    if (safe(share)) {
      lo = share;
      break;
    }
    hi = share;
  }
  if (lo == 0 || hi == 0) return lo;  // nothing safe, or the whole displacement
  for (int step = 0; step < kExplodeRefinements; ++step) {
    const double mid = 0.5 * (lo + hi);
    (safe(mid) ? lo : hi) = mid;
  }
  return lo;
}

double ExplodeMotion::support_gap(uint32_t a, uint32_t b, Vec3 n) const {
  double lo_a = 1e300, hi_b = -1e300;
  for (uint32_t v : vertices_[a]) lo_a = std::min(lo_a, dot(geometry_.points[v], n));
  for (uint32_t v : vertices_[b]) hi_b = std::max(hi_b, dot(geometry_.points[v], n));
  return lo_a - hi_b;
}

void ExplodeMotion::commit(uint32_t object, Vec3 displacement) {
  if (object < move_.size()) move_[object] = to_unit_vector(displacement);
}

}  // namespace gvd::query

#include "gvd/octree/contacts.h"

#include <algorithm>
#include <set>

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/geometry/primitives.h"

namespace gvd::octree {

using namespace gvd::scene;

ContactPairs::ContactPairs(const std::vector<std::pair<ObjectId, ObjectId>>& pairs)
    : pairs_(pairs), set_(pairs.size()) {
  for (auto& [a, b] : pairs_)
    if (a > b) std::swap(a, b);
  std::sort(pairs_.begin(), pairs_.end());
  pairs_.erase(std::unique(pairs_.begin(), pairs_.end()), pairs_.end());
  for (const auto& [a, b] : pairs_) set_.insert(uint64_t{a} << 32 | b, 0);
}

ContactPairs find_contact_pairs(const UnitGeometry& g, const SimplexBvh& bvh, double tolerance,
                                int threads, const std::atomic<bool>* cancel) {
  threads = resolve_threads(threads);
  const size_t m = g.simplices.size();
  const int arity = g.dimension == 2 ? 2 : 3;
  const double tol2 = tolerance * tolerance;
  std::vector<std::set<std::pair<ObjectId, ObjectId>>> found(static_cast<size_t>(threads));
  parallel_for(
      m, threads,
      [&](size_t b, size_t e, int t) {
        auto& local = found[static_cast<size_t>(t)];
        for (size_t s = b; s < e; ++s) {
          // Coincident objects make each simplex's walk long (n copies overlap it): the flag
          // is read per simplex.
          if (cancel != nullptr && cancel->load(std::memory_order_relaxed))
            throw Error(ErrorCode::kCancelled, "cancelled while finding the touching pairs");
          const Simplex& x = g.simplices[s];
          Box box;
          for (int k = 0; k < arity; ++k) box.extend(g.points[x.v[k]]);
          box.lo = box.lo - Vec3{tolerance, tolerance, tolerance};
          box.hi = box.hi + Vec3{tolerance, tolerance, tolerance};
          const ObjectId a = g.object_of[s];
          bvh.for_each_overlapping(
              box,
              [&](uint32_t y) {
                if (y <= s) return;
                const ObjectId c = g.object_of[y];
                if (c == a) return;
                const std::pair<ObjectId, ObjectId> key{std::min(a, c), std::max(a, c)};
                if (local.count(key)) return;
                const Simplex& z = g.simplices[y];
                double d2;
                if (g.dimension == 2) {
                  d2 = segment_segment_dist2(g.points[x.v[0]], g.points[x.v[1]], g.points[z.v[0]],
                                             g.points[z.v[1]]);
                } else {
                  const Vec3 ta[3] = {g.points[x.v[0]], g.points[x.v[1]], g.points[x.v[2]]};
                  const Vec3 tb[3] = {g.points[z.v[0]], g.points[z.v[1]], g.points[z.v[2]]};
                  d2 = triangle_triangle_dist2(ta, tb);
                }
                if (d2 <= tol2) local.insert(key);
              },
              a);
        }
      },
      256);
  std::vector<std::pair<ObjectId, ObjectId>> all;
  for (const auto& s : found) all.insert(all.end(), s.begin(), s.end());
  return ContactPairs(all);
}

}  // namespace gvd::octree

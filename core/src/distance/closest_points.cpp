#include "gvd/distance/closest_points.h"

#include "gvd/common/error.h"
#include "gvd/common/parallel.h"

namespace gvd::distance {

// The layouts the device sees (sizes asserted on the host: a mismatch would
// read garbage on the device, not fail).
static_assert(sizeof(item::GvdPoint) == 24 && sizeof(Vec3) == 24);
static_assert(sizeof(item::GvdBvhNode) == 56);
static_assert(sizeof(item::GvdHit) == 40);

ClosestPointData make_closest_point_data(const SimplexBvh& bvh) {
  return ClosestPointData{bvh.dimension(), bvh.nodes(), bvh.order(), bvh.corner(), bvh.points()};
}

namespace {

ClosestHit run_item(const ClosestPointData& data, Vec3 q, double bound2) {
  return to_closest_hit(item::gvd_nearest_item(
      data.dimension, static_cast<item::gvd_uint>(data.nodes.size()), data.nodes.data(),
      data.order.data(), data.corner.data(), data.points.data(), {q.x, q.y, q.z}, bound2));
}

void run_items(const ClosestPointData& data, std::span<const Vec3> queries,
               std::span<const double> bound2, std::span<ClosestHit> hits, size_t b, size_t e) {
  for (size_t i = b; i < e; ++i) hits[i] = run_item(data, queries[i], bound2[i]);
}

// The previous item's answer is a point on a simplex: its distance (with a margin far above
// rounding) bounds this item's search. Every simplex that could be the answer is within that
// bound, so the answer is the same; the search only skips more of the tree. Should rounding
// leave nothing within it, the item is searched again with its own bound.
void run_items_coherent(const ClosestPointData& data, std::span<const Vec3> queries,
                        std::span<const double> bound2, std::span<ClosestHit> hits, size_t b,
                        size_t e) {
  for (size_t i = b; i < e; ++i) {
    double bound = bound2[i];
    if (i > b && hits[i - 1].found())
      bound = std::min(bound, dist2(queries[i], hits[i - 1].point) * (1 + 1e-9) + 1e-300);
    hits[i] = run_item(data, queries[i], bound);
    if (!hits[i].found() && bound < bound2[i]) hits[i] = run_item(data, queries[i], bound2[i]);
  }
}

void check_sizes(std::span<const Vec3> queries, std::span<const double> bound2,
                 std::span<ClosestHit> hits) {
  GVD_CHECK(queries.size() == bound2.size() && queries.size() == hits.size(),
            "closest_points: queries, bounds and hits must have the same length");
}

}  // namespace

void closest_points_cpu(const ClosestPointData& data, std::span<const Vec3> queries,
                        std::span<const double> bound2, std::span<ClosestHit> hits, int threads) {
  check_sizes(queries, bound2, hits);
  parallel_for(
      queries.size(), resolve_threads(threads),
      [&](size_t b, size_t e, int) { run_items(data, queries, bound2, hits, b, e); }, 256);
}

void closest_points_cpu_coherent(const ClosestPointData& data, std::span<const Vec3> queries,
                                 std::span<const double> bound2, std::span<ClosestHit> hits,
                                 int threads) {
  check_sizes(queries, bound2, hits);
  parallel_for(
      queries.size(), resolve_threads(threads),
      [&](size_t b, size_t e, int) { run_items_coherent(data, queries, bound2, hits, b, e); }, 256);
}

void closest_points_scalar(const ClosestPointData& data, std::span<const Vec3> queries,
                           std::span<const double> bound2, std::span<ClosestHit> hits) {
  check_sizes(queries, bound2, hits);
  run_items(data, queries, bound2, hits, 0, queries.size());
}

}  // namespace gvd::distance

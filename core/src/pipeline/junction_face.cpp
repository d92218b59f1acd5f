#include "gvd/pipeline/junction_face.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>

#include "gvd/common/cancel.h"
#include "gvd/common/peak_memory.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/result/gvd_result.h"

namespace gvd::pipeline {

using namespace gvd::scene;

namespace {

constexpr int kMaxObjects = 8;

// Clips the segment [p0, p1] (x, y) to the box (x, y): false when nothing is left. Ends inside
// stay bitwise as they are.
bool clip_segment(Vec3& p0, Vec3& p1, const Box& box) {
  double t0 = 0, t1 = 1;
  const Vec3 d = p1 - p0;
  for (int i = 0; i < 2; ++i) {
    for (const double sign : {-1.0, 1.0}) {
      // sign * (p0 + t d)[i] <= sign * bound
      const double bound = sign < 0 ? -box.lo[i] : box.hi[i];
      const double q = bound - sign * p0[i], rate = sign * d[i];
      if (rate == 0) {
        if (q < 0) return false;
      } else if (rate > 0) {
        t1 = std::min(t1, q / rate);
      } else {
        t0 = std::max(t0, q / rate);
      }
    }
  }
  if (!(t0 <= t1)) return false;
  const Vec3 a = p0;
  // Cut ends land on the box up to rounding: held inside it.
  auto onto = [&](Vec3 p) {
    for (int i = 0; i < 2; ++i) p[i] = std::clamp(p[i], box.lo[i], box.hi[i]);
    return p;
  };
  if (t0 > 0) p0 = onto(a + d * t0);
  if (t1 < 1) p1 = onto(a + d * t1);
  return true;
}

// Appends the bytes of `v` to `key`.
template <class T>
void append(std::string& key, T v) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  key.append(bytes, sizeof(T));
}

}  // namespace

bool JunctionSectionCache::find(const std::string& key, int axis, double at,
                                surface::FaceGvd& out) const {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    const auto it = map_.find(key);
    if (it == map_.end()) return false;
    out = it->second;
  }
  for (Vec3& p : out.points) p[axis] = at;
  return true;
}

void JunctionSectionCache::add(std::string key, const surface::FaceGvd& gvd) {
  const std::lock_guard<std::mutex> lock(mutex_);
  map_.emplace(std::move(key), gvd);
}

bool junction_face_gvd(const UnitGeometry& g, const SimplexBvh& bvh, const Box& face, int axis,
                       surface::FaceGvd& out, const std::atomic<bool>* cancel,
                       JunctionSectionCache* sections) {
  out = surface::FaceGvd();
  const int u = (axis + 1) % 3, w = (axis + 2) % 3;
  auto widen = [](double d) { return d * (1 + 1e-9) + 1e-15; };
  const Vec3 c = face.center();
  const double r = 0.5 * norm(face.hi - face.lo);
  // The objects that can be nearest to a point of the face (PairCertifier::certify, step 1);
  // more than a junction cell may hold: none of its faces (the surfacer refuses it).
  uint32_t found[kMaxObjects + 1];
  double dist[kMaxObjects + 1];
  const int n = objects_in_reach(bvh, g.object_of, c, r, kMaxObjects, found, dist);
  if (n < 2) return false;
  // In a canonical order (the plane scene's object ids), each with its distance at c.
  std::vector<std::pair<uint32_t, double>> by_id;
  for (int k = 0; k < n; ++k) by_id.emplace_back(found[k], dist[k]);
  std::sort(by_id.begin(), by_id.end());
  std::vector<uint32_t> objects;
  for (const auto& [o, d] : by_id) objects.push_back(o);
  // Their simplices in reach, square to the axis, projected along it: exact (a coordinate
  // dropped), and the two far ends of a triangle's three projected corners make its segment.
  // Every point of an object that can be nearest to a point of the face lies within its
  // distance at the centre + r of the face (PairCertifier::certify): the plane scene's domain
  // holds the face grown by the largest of those on every side, a square of 2^m faces with the
  // face one of its cells, and the segments are clipped to it (only parts nearer than the
  // growth can be nearest, so the GVD inside the face is the whole scene's).
  double grow = 0;
  double slack[kMaxObjects];
  for (int k = 0; k < n; ++k) {
    slack[k] = widen(by_id[k].second + r);
    grow = std::max(grow, slack[k]);
  }
  const double side = face.hi[u] - face.lo[u];
  const double cells = std::ceil(grow / side);  // faces on each side of the face
  int m = 0;
  while (std::ldexp(1.0, m) < 2 * cells + 1) ++m;
  const Vec3 lo{face.lo[u] - cells * side, face.lo[w] - cells * side, 0};
  const double extent = std::ldexp(side, m);
  const Box domain{lo, lo + Vec3{extent, extent, 0}};
  Scene plane;
  plane.dimension = 2;
  plane.objects.resize(n);
  for (int k = 0; k < n; ++k) {
    const uint32_t o = objects[k];
    const double range = widen(slack[k] + r);
    Box query = face;
    for (int i = 0; i < 3; ++i) {
      query.lo[i] -= slack[k];
      query.hi[i] += slack[k];
    }
    std::vector<std::tuple<double, double, double, double>> segments;
    bvh.for_each_overlapping_in_object(o, query, [&](uint32_t s) {
      const Simplex& t = g.simplices[s];
      if (dist2(c, closest_point_on_simplex(3, g.points, t, c)) > range * range ||
          !simplex_overlaps_box(3, g.points, t, face, slack[k]))
        return;
      const Vec3 a = g.points[t.v[0]], b = g.points[t.v[1]], e = g.points[t.v[2]];
      const Vec3 normal = cross(b - a, e - a);
      if (!(std::abs(normal[axis]) <= 1e-9 * norm(normal))) return;
      Vec3 p[3] = {{a[u], a[w], 0}, {b[u], b[w], 0}, {e[u], e[w], 0}};
      int i0 = 0, i1 = 1;
      for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j)
          if (dist2(p[i], p[j]) > dist2(p[i0], p[i1])) i0 = i, i1 = j;
      Vec3 p0 = p[i0], p1 = p[i1];
      if (!clip_segment(p0, p1, domain)) return;
      if (std::tie(p1.x, p1.y) < std::tie(p0.x, p0.y)) std::swap(p0, p1);
      if (!(dist2(p0, p1) > 0)) return;
      segments.emplace_back(p0.x, p0.y, p1.x, p1.y);
    });
    std::sort(segments.begin(), segments.end());
    segments.erase(std::unique(segments.begin(), segments.end()), segments.end());
    SceneObject& object = plane.objects[k];
    object.label = std::to_string(o);
    for (const auto& [x0, y0, x1, y1] : segments) {
      const uint32_t first = static_cast<uint32_t>(object.vertices.size());
      object.vertices.push_back({x0, y0, 0});
      object.vertices.push_back({x1, y1, 0});
      object.simplices.push_back(Simplex{{first, first + 1, 0}});
    }
  }
  throw_if_cancelled(cancel, "a junction cell's face");
  // The section: the face across the axis, the square around it and the objects' segments
  // (exact bits), which is all the plane GVD below is computed from.
  std::string key;
  if (sections != nullptr) {
    append(key, axis);
    for (const double v : {face.lo[u], face.lo[w], face.hi[u], face.hi[w], lo.x, lo.y, extent})
      append(key, v);
    for (int k = 0; k < n; ++k) {
      append(key, objects[k]);
      append(key, plane.objects[k].vertices.size());
      for (const Vec3& v : plane.objects[k].vertices) {
        append(key, v.x);
        append(key, v.y);
      }
    }
    if (sections->find(key, axis, face.lo[axis], out)) return true;
  }
  PipelineOptions options;
  options.threads = 1;
  options.cancel = cancel;
  options.domain.box = domain;
  options.domain.padding = 0;
  options.domain.frame = DomainFrame::kWorld;
  const NestedComputation nested;  // the heap policy is the computation around it's
  const result::GvdResult result = compute_gvd(std::move(plane), options);
  // One side of each interface (the lower object's cell), its points shared by position.
  std::map<std::tuple<double, double>, uint32_t> index;
  auto point = [&](Vec3 p) {
    const auto [it, added] =
        index.try_emplace({p.x, p.y}, static_cast<uint32_t>(out.points.size()));
    if (added) {
      Vec3 q;
      q[u] = p.x;
      q[w] = p.y;
      q[axis] = face.lo[axis];
      out.points.push_back(q);
    }
    return it->second;
  };
  // The pieces inside the face (their ends on its border cut there; the 3D surfacer puts
  // those on its exact edge points).
  const Box flat{Vec3{face.lo[u], face.lo[w], 0}, Vec3{face.hi[u], face.hi[w], 0}};
  for (const surface::GvdCell& cell : result.gvd.cells) {
    for (size_t i = 0; i + 1 < cell.indices.size(); i += 2) {
      const uint32_t i0 = cell.indices[i], i1 = cell.indices[i + 1];
      const ObjectId other = cell.other[i0];
      if (other == kNoObject || other <= cell.object) continue;
      Vec3 p0 = cell.positions[i0], p1 = cell.positions[i1];
      if (!clip_segment(p0, p1, flat) || !(dist2(p0, p1) > 0)) continue;
      out.segments.emplace_back(point(p0), point(p1));
      out.pairs.emplace_back(objects[cell.object], objects[other]);
    }
  }
  if (sections != nullptr) sections->add(std::move(key), out);
  return true;
}

}  // namespace gvd::pipeline

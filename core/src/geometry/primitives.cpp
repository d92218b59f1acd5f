#include "gvd/geometry/primitives.h"

#include <algorithm>
#include <cmath>

#include "gvd/geometry/closest_point_item.h"

namespace gvd {

// The closest-point primitives are the per-item functions the OpenCL kernel and its CPU twin
// run (closest_point_item.h): one source, so every CPU path gives the kernel's results bit
// for bit.
namespace {
item::GvdPoint to_item(Vec3 v) { return item::gvd_pt(v.x, v.y, v.z); }
Vec3 from_item(item::GvdPoint v) { return {v.x, v.y, v.z}; }
}  // namespace

Vec3 closest_point_on_segment(Vec3 p, Vec3 a, Vec3 b) {
  return from_item(item::gvd_closest_on_segment(to_item(p), to_item(a), to_item(b)));
}

Vec3 closest_point_on_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c) {
  return from_item(item::gvd_closest_on_triangle(to_item(p), to_item(a), to_item(b), to_item(c)));
}

namespace {

// Projection interval of the triangle (relative to the box centre) on `axis` against the
// box's projection radius; true when separated.
bool separated_on_axis(Vec3 axis, Vec3 v0, Vec3 v1, Vec3 v2, Vec3 half) {
  const double p0 = dot(v0, axis);
  const double p1 = dot(v1, axis);
  const double p2 = dot(v2, axis);
  const double r =
      half.x * std::fabs(axis.x) + half.y * std::fabs(axis.y) + half.z * std::fabs(axis.z);
  const double lo = std::min({p0, p1, p2});
  const double hi = std::max({p0, p1, p2});
  // Slack for rounding in the products, relative to the magnitudes involved.
  const double eps = 1e-12 * (r + std::max(std::fabs(lo), std::fabs(hi)));
  return lo > r + eps || hi < -r - eps;
}

}  // namespace

bool triangle_overlaps_box(Vec3 a, Vec3 b, Vec3 c, const Box& box, double slack) {
  const Vec3 center = box.center();
  const Vec3 half = (box.hi - box.lo) * 0.5 + Vec3{slack, slack, slack};
  const Vec3 v0 = a - center;
  const Vec3 v1 = b - center;
  const Vec3 v2 = c - center;
  // Box face normals; a triangle inside the box on every axis overlaps it (no more tests).
  bool inside = true;
  for (int i = 0; i < 3; ++i) {
    const double lo = std::min({v0[i], v1[i], v2[i]});
    const double hi = std::max({v0[i], v1[i], v2[i]});
    if (lo > half[i] || hi < -half[i]) return false;
    inside &= lo >= -half[i] && hi <= half[i];
  }
  if (inside) return true;
  const Vec3 e[3] = {v1 - v0, v2 - v1, v0 - v2};
  // Triangle normal.
  const Vec3 n = cross(e[0], e[1]);
  if (norm2(n) > 0 && separated_on_axis(n, v0, v1, v2, half)) return false;
  // The plane crosses the box. If the box also lies inside the triangle's prism, farther
  // than its half-diagonal from every edge line, the plane's section of the box is inside
  // the triangle: they overlap (the usual case of a cell on a large facet).
  if (norm2(n) > 0) {
    const double r = std::sqrt(norm2(half)) * (1 + 1e-9);
    const double nn = std::sqrt(norm2(n));
    const Vec3* v[3] = {&v0, &v1, &v2};
    bool deep = true;
    for (int k = 0; k < 3 && deep; ++k) {
      // cross(n, e_k) points into the triangle; its length is |n| |e_k|.
      deep = -dot(cross(n, e[k]), *v[k]) > r * nn * std::sqrt(norm2(e[k]));
    }
    if (deep) return true;
  }
  // Edge x box axis cross products.
  const Vec3 axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (const Vec3& edge : e) {
    for (const Vec3& ax : axes) {
      const Vec3 axis = cross(edge, ax);
      if (norm2(axis) > 0 && separated_on_axis(axis, v0, v1, v2, half)) return false;
    }
  }
  return true;
}

bool segment_overlaps_box_2d(Vec3 a, Vec3 b, const Box& box, double slack) {
  const double lox = box.lo.x - slack, hix = box.hi.x + slack;
  const double loy = box.lo.y - slack, hiy = box.hi.y + slack;
  if (std::max(a.x, b.x) < lox || std::min(a.x, b.x) > hix) return false;
  if (std::max(a.y, b.y) < loy || std::min(a.y, b.y) > hiy) return false;
  if (std::min(a.x, b.x) >= lox && std::max(a.x, b.x) <= hix && std::min(a.y, b.y) >= loy &&
      std::max(a.y, b.y) <= hiy) {
    return true;  // both ends inside
  }
  // Segment normal axis: the box corners must not all lie strictly on one side.
  const double nx = -(b.y - a.y);
  const double ny = b.x - a.x;
  const double cx = 0.5 * (lox + hix), cy = 0.5 * (loy + hiy);
  const double hx = 0.5 * (hix - lox), hy = 0.5 * (hiy - loy);
  const double s = nx * (cx - a.x) + ny * (cy - a.y);
  const double r = hx * std::fabs(nx) + hy * std::fabs(ny);
  const double eps = 1e-12 * (r + std::fabs(s));
  return std::fabs(s) <= r + eps;
}

double segment_segment_closest(Vec3 p0, Vec3 p1, Vec3 q0, Vec3 q1, Vec3& on_p, Vec3& on_q) {
  // Ericson, Real-Time Collision Detection §5.1.9, with degenerate segments handled.
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  double s = 0, t = 0;
  if (a <= 0 && e <= 0) {
    on_p = p0;
    on_q = q0;
    return dist2(p0, q0);
  }
  if (a <= 0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = dot(d1, r);
    if (e <= 0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = dot(d1, d2);
      const double denom = a * e - b * b;
      s = denom > 0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  on_p = p0 + d1 * s;
  on_q = q0 + d2 * t;
  return dist2(on_p, on_q);
}

double segment_segment_dist2(Vec3 p0, Vec3 p1, Vec3 q0, Vec3 q1) {
  Vec3 on_p, on_q;
  return segment_segment_closest(p0, p1, q0, q1, on_p, on_q);
}

double segment_segment_dist2_2d(Vec3 p0, Vec3 p1, Vec3 q0, Vec3 q1) {
  auto orient = [](Vec3 a, Vec3 b, Vec3 c) {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  };
  const double o1 = orient(p0, p1, q0), o2 = orient(p0, p1, q1);
  const double o3 = orient(q0, q1, p0), o4 = orient(q0, q1, p1);
  if (((o1 < 0 && o2 > 0) || (o1 > 0 && o2 < 0)) && ((o3 < 0 && o4 > 0) || (o3 > 0 && o4 < 0))) {
    return 0;
  }
  const Vec3 a{p0.x, p0.y, 0}, b{p1.x, p1.y, 0}, c{q0.x, q0.y, 0}, d{q1.x, q1.y, 0};
  return segment_segment_dist2(a, b, c, d);
}

namespace {

// Does segment [p, q] cross triangle t (Möller–Trumbore, segment parameter in [0, 1])? A
// segment (nearly) parallel to the triangle's plane — det below 1e-12 of |d| |e1| |e2|, an
// angle under ~1e-12 — does not count: there the test's rounding is unbounded (coplanar faces
// of flush parts, once rotated, looked like crossings), and the callers' vertex and edge
// distances already give the distance of such a segment to within ~1e-12 of its length.
bool segment_crosses_triangle(Vec3 p, Vec3 q, const Vec3 t[3]) {
  const Vec3 d = q - p;
  const Vec3 e1 = t[1] - t[0], e2 = t[2] - t[0];
  const Vec3 h = cross(d, e2);
  const double det = dot(e1, h);
  if (!(std::abs(det) > 1e-12 * norm(d) * norm(e1) * norm(e2))) return false;
  const double inv = 1.0 / det;
  const Vec3 s = p - t[0];
  const double u = dot(s, h) * inv;
  if (u < 0 || u > 1) return false;
  const Vec3 w = cross(s, e1);
  const double v = dot(d, w) * inv;
  if (v < 0 || u + v > 1) return false;
  const double x = dot(e2, w) * inv;
  return x >= 0 && x <= 1;
}

}  // namespace

double triangle_triangle_dist2(const Vec3 a[3], const Vec3 b[3]) {
  for (int i = 0; i < 3; ++i) {
    if (segment_crosses_triangle(a[i], a[(i + 1) % 3], b)) return 0;
    if (segment_crosses_triangle(b[i], b[(i + 1) % 3], a)) return 0;
  }
  double best = 1e300;
  for (int i = 0; i < 3; ++i) {
    best = std::min(best, dist2(a[i], closest_point_on_triangle(a[i], b[0], b[1], b[2])));
    best = std::min(best, dist2(b[i], closest_point_on_triangle(b[i], a[0], a[1], a[2])));
    for (int j = 0; j < 3; ++j) {
      best = std::min(best, segment_segment_dist2(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]));
    }
  }
  return best;
}

double segment_triangle_dist2(Vec3 p0, Vec3 p1, Vec3 a, Vec3 b, Vec3 c) {
  const Vec3 t[3] = {a, b, c};
  if (segment_crosses_triangle(p0, p1, t)) return 0;
  double best = std::min(dist2(p0, closest_point_on_triangle(p0, a, b, c)),
                         dist2(p1, closest_point_on_triangle(p1, a, b, c)));
  for (int i = 0; i < 3; ++i) {
    best = std::min(best, segment_segment_dist2(p0, p1, t[i], t[(i + 1) % 3]));
  }
  return best;
}

double segment_box_distance2_bound(Vec3 p0, Vec3 p1, const Box& b) {
  double boxes = 0;
  for (int i = 0; i < 3; ++i) {
    const double lo = std::min(p0[i], p1[i]), hi = std::max(p0[i], p1[i]);
    const double gap = std::max({b.lo[i] - hi, lo - b.hi[i], 0.0});
    boxes += gap * gap;
  }
  const double mid = std::sqrt(box_distance2((p0 + p1) * 0.5, b)) - 0.5 * dist(p0, p1);
  return mid > 0 ? std::max(boxes, mid * mid) : boxes;
}

double simplex_simplex_closest(int dimension, const Vec3* q, const Vec3* s, Vec3& on_q) {
  Vec3 a, b;
  if (dimension == 2) {
    const double d2 = segment_segment_dist2_2d(q[0], q[1], s[0], s[1]);
    segment_segment_closest(Vec3{q[0].x, q[0].y, 0}, Vec3{q[1].x, q[1].y, 0},
                            Vec3{s[0].x, s[0].y, 0}, Vec3{s[1].x, s[1].y, 0}, on_q, b);
    return d2;
  }
  for (int i = 0; i < 3; ++i) {
    if (segment_crosses_triangle(s[i], s[(i + 1) % 3], q)) {
      on_q = closest_point_on_triangle(s[i], q[0], q[1], q[2]);
      return 0;
    }
    if (segment_crosses_triangle(q[i], q[(i + 1) % 3], s)) {
      on_q = q[i];
      return 0;
    }
  }
  double best = 1e300;
  for (int i = 0; i < 3; ++i) {
    const Vec3 on = closest_point_on_triangle(s[i], q[0], q[1], q[2]);
    const double d2 = dist2(s[i], on);
    if (d2 < best) {
      best = d2;
      on_q = on;
    }
    const double e2 = dist2(q[i], closest_point_on_triangle(q[i], s[0], s[1], s[2]));
    if (e2 < best) {
      best = e2;
      on_q = q[i];
    }
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double d2 = segment_segment_closest(q[i], q[(i + 1) % 3], s[j], s[(j + 1) % 3], a, b);
      if (d2 < best) {
        best = d2;
        on_q = a;
      }
    }
  }
  return best;
}

namespace {

/// Which side of the directed line u -> w (in the (y, z) plane) the point (py, pz) perturbed
/// by (eps, eps^2) lies on: +1 left, -1 right; never on it. Computed from the
/// lexicographically smaller end, so both triangles of an edge get the same answer bit for bit.
int side_of_edge(double uy, double uz, double wy, double wz, double py, double pz) {
  if (uy > wy || (uy == wy && uz > wz)) return -side_of_edge(wy, wz, uy, uz, py, pz);
  const double e = (wy - uy) * (pz - uz) - (wz - uz) * (py - uy);
  if (e > 0) return 1;
  if (e < 0) return -1;
  // On the line: the perturbation decides (dE = (wy - uy) eps^2 - (wz - uz) eps).
  if (wz != uz) return wz > uz ? -1 : 1;
  return wy > uy ? 1 : -1;
}

}  // namespace

bool row_crosses_triangle(Vec3 a, Vec3 b, Vec3 c, double y, double z, double& x) {
  const double area = (b.y - a.y) * (c.z - a.z) - (b.z - a.z) * (c.y - a.y);
  if (area == 0) return false;  // edge-on: its neighbours decide
  const int s0 = side_of_edge(a.y, a.z, b.y, b.z, y, z);
  const int s1 = side_of_edge(b.y, b.z, c.y, c.z, y, z);
  const int s2 = side_of_edge(c.y, c.z, a.y, a.z, y, z);
  if (s0 != s1 || s1 != s2) return false;
  // Barycentric coordinates of (y, z) in the projected triangle: x on its plane.
  const double wa = ((b.y - y) * (c.z - z) - (b.z - z) * (c.y - y)) / area;
  const double wb = ((c.y - y) * (a.z - z) - (c.z - z) * (a.y - y)) / area;
  x = wa * a.x + wb * b.x + (1 - wa - wb) * c.x;
  return true;
}

bool row_crosses_segment(Vec3 a, Vec3 b, double y, double& x) {
  if (a.y == b.y) return false;  // along the line: the perturbed line misses it
  if ((a.y <= y) == (b.y <= y)) return false;
  x = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
  return true;
}

}  // namespace gvd

#pragma once

// The independent brute-force oracle of the uniform-grid tests (compute_grid_test.cpp,
// sample_result_grid_test.cpp): for every cell centre, the exact distance to every simplex
// of every object (L2 by projection onto the segment / the triangle's plane; L1 and L-infinity
// by nested ternary search on the convex distance along the simplex), the nearest object, and
// inside tests of its own (winding angle in 2D, solid angle in 3D). Nothing in it comes from
// the code under test.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "gvd/grid/compute_grid.h"

namespace gvd::test {

inline double norm(Vec3 v, grid::GridMetric m) {
  switch (m) {
    case grid::GridMetric::kL1:
      return std::abs(v.x) + std::abs(v.y) + std::abs(v.z);
    case grid::GridMetric::kLinf:
      return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
    case grid::GridMetric::kL2:
      break;
  }
  return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
}

// Our own products (vec.h has dot/cross; the oracle does not borrow them).
inline double odot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 ocross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// Minimum of a convex function on [lo, hi] by ternary search (then the ends).
template <class F>
inline double ternary_min(F f, double lo, double hi, int iterations = 90) {
  double a = lo, b = hi;
  for (int i = 0; i < iterations; ++i) {
    const double m1 = a + (b - a) / 3, m2 = b - (b - a) / 3;
    if (f(m1) < f(m2))
      b = m2;
    else
      a = m1;
  }
  return std::min({f(0.5 * (a + b)), f(lo), f(hi)});
}

inline double oracle_segment(Vec3 p, Vec3 a, Vec3 b, grid::GridMetric m) {
  if (m == grid::GridMetric::kL2) {
    const Vec3 d = b - a;
    const double t = std::clamp(odot(p - a, d) / odot(d, d), 0.0, 1.0);
    return norm(p - (a + d * t), m);
  }
  return ternary_min([&](double t) { return norm(p - (a + (b - a) * t), m); }, 0.0, 1.0);
}

inline double oracle_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c, grid::GridMetric m) {
  if (m == grid::GridMetric::kL2) {
    // Inside the prism: distance to the plane; else the nearest edge.
    const Vec3 n = ocross(b - a, c - a);
    const double nn = odot(n, n);
    const Vec3 q = p - n * (odot(p - a, n) / nn);
    const bool inside = odot(ocross(b - a, q - a), n) >= 0 && odot(ocross(c - b, q - b), n) >= 0 &&
                        odot(ocross(a - c, q - c), n) >= 0;
    if (inside) return std::abs(odot(p - a, n)) / std::sqrt(nn);
    return std::min(
        {oracle_segment(p, a, b, m), oracle_segment(p, b, c, m), oracle_segment(p, c, a, m)});
  }
  // g(u) = min over v of |p - a - u (b - a) - v (c - a)|, v in [0, 1 - u]: convex in u.
  auto g = [&](double u) {
    return ternary_min([&](double v) { return norm(p - (a + (b - a) * u + (c - a) * v), m); }, 0.0,
                       1.0 - u, 50);
  };
  // (2/3)^50 = 2e-9 of the parameter range: far inside the tolerance of the checks.
  return ternary_min(g, 0.0, 1.0, 50);
}

struct OracleCell {
  int first = -1;                 // nearest object
  double d1 = 1e300, d2 = 1e300;  // nearest and second-nearest object distances
};

inline OracleCell oracle_cell(const scene::Scene& scene, Vec3 p, grid::GridMetric m) {
  OracleCell r;
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const scene::SceneObject& obj = scene.objects[o];
    double d = 1e300;
    for (const Simplex& s : obj.simplices) {
      const Vec3 a = obj.vertices[s.v[0]], b = obj.vertices[s.v[1]];
      d = std::min(d, scene.dimension == 2 ? oracle_segment(p, a, b, m)
                                           : oracle_triangle(p, a, b, obj.vertices[s.v[2]], m));
    }
    if (d < r.d1) {
      r.d2 = r.d1;
      r.d1 = d;
      r.first = static_cast<int>(o);
    } else if (d < r.d2) {
      r.d2 = d;
    }
  }
  return r;
}

// Inside tests of the oracle: total turning angle (2D), total solid angle (3D,
// Van Oosterom-Strackee); |winding| > 1/2 = inside.
inline bool oracle_inside(const scene::SceneObject& obj, int dimension, Vec3 p) {
  double total = 0;
  for (const Simplex& s : obj.simplices) {
    if (dimension == 2) {
      const Vec3 a = obj.vertices[s.v[0]] - p, b = obj.vertices[s.v[1]] - p;
      total += std::atan2(a.x * b.y - a.y * b.x, a.x * b.x + a.y * b.y);
    } else {
      const Vec3 a = obj.vertices[s.v[0]] - p, b = obj.vertices[s.v[1]] - p,
                 c = obj.vertices[s.v[2]] - p;
      const double la = norm(a, grid::GridMetric::kL2), lb = norm(b, grid::GridMetric::kL2),
                   lc = norm(c, grid::GridMetric::kL2);
      const double num = odot(a, ocross(b, c));
      const double den = la * lb * lc + odot(a, b) * lc + odot(b, c) * la + odot(c, a) * lb;
      total += 2 * std::atan2(num, den);
    }
  }
  const double turn = dimension == 2 ? 2 * std::numbers::pi : 4 * std::numbers::pi;
  return std::abs(total / turn) > 0.5;
}

inline double cell_diagonal(const grid::GridSpec& spec, grid::GridMetric m) {
  const double d = spec.dimension;
  return m == grid::GridMetric::kL2 ? spec.h * std::sqrt(d)
                                    : (m == grid::GridMetric::kL1 ? spec.h * d : spec.h);
}

struct Checked {
  size_t cells = 0, label_mismatch = 0, unexplained_mismatch = 0, distance_bad = 0, sign_bad = 0;
};

// Compares every cell with the oracle. A label may differ only where the oracle's two nearest
// objects are within one cell diagonal of each other (the paper's one-cell bound); distances
// must be within float32 precision of the exact ones; signs negative exactly inside closed
// objects (the `closed` flags come from the test, not from the code).
inline Checked check_against_oracle(const scene::Scene& scene, const grid::DistanceGrid& grid,
                                    const std::vector<bool>& closed, int stride = 1) {
  Checked c;
  const grid::GridSpec& s = grid.spec;
  const double diag = cell_diagonal(s, grid.metric);
  for (int k = 0; k < s.n[2]; k += stride) {
    for (int j = 0; j < s.n[1]; j += stride) {
      for (int i = 0; i < s.n[0]; i += stride) {
        const size_t idx = (static_cast<size_t>(k) * s.n[1] + j) * s.n[0] + i;
        const Vec3 p{s.origin.x + (i + 0.5) * s.h, s.origin.y + (j + 0.5) * s.h,
                     s.dimension == 2 ? 0.0 : s.origin.z + (k + 0.5) * s.h};
        const OracleCell o = oracle_cell(scene, p, grid.metric);
        ++c.cells;
        if (grid.label[idx] != o.first) {
          ++c.label_mismatch;
          if (o.d2 - o.d1 >= diag) ++c.unexplained_mismatch;
        }
        const double d = std::abs(grid.distance[idx]);
        const double tol = 1.2e-7 * std::max(o.d1, s.h) + 1e-9 * s.h;
        if (!(std::abs(d - o.d1) <= tol)) ++c.distance_bad;
        const bool want_negative =
            closed[static_cast<size_t>(o.first)] &&
            oracle_inside(scene.objects[static_cast<size_t>(o.first)], s.dimension, p);
        // On the boundary (distance ~0) either sign is right.
        if (o.d1 > 1e-9 * s.h && (grid.distance[idx] < 0) != want_negative) ++c.sign_bad;
      }
    }
  }
  return c;
}

}  // namespace gvd::test

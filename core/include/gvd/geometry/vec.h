#pragma once

// The basic geometry types: Vec3, a point or vector in 2D or 3D (2D data keeps z = 0), with its
// arithmetic, dot and cross products, norms and distances; Box, an axis-aligned box (empty when
// lo > hi on some axis); and PositionHash, an exact-bit hash of a position that agrees with
// Vec3's operator==.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace gvd {

/// A point or vector in 2D or 3D; 2D data keeps z = 0, so one set of routines serves both.
struct Vec3 {
  double x = 0, y = 0, z = 0;

  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

constexpr Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
constexpr Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
constexpr Vec3 operator*(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
constexpr Vec3 operator*(double s, Vec3 a) { return a * s; }
constexpr Vec3 operator/(Vec3 a, double s) { return {a.x / s, a.y / s, a.z / s}; }
constexpr bool operator==(Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
constexpr bool operator!=(Vec3 a, Vec3 b) { return !(a == b); }
constexpr double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
constexpr double norm2(Vec3 a) { return dot(a, a); }
inline double norm(Vec3 a) { return std::sqrt(norm2(a)); }
constexpr double dist2(Vec3 a, Vec3 b) { return norm2(a - b); }
inline double dist(Vec3 a, Vec3 b) { return std::sqrt(dist2(a, b)); }

/// Axis-aligned box; empty when lo > hi on some axis.
struct Box {
  Vec3 lo{1e300, 1e300, 1e300};
  Vec3 hi{-1e300, -1e300, -1e300};

  void extend(Vec3 p) {
    for (int i = 0; i < 3; ++i) {
      lo[i] = p[i] < lo[i] ? p[i] : lo[i];
      hi[i] = p[i] > hi[i] ? p[i] : hi[i];
    }
  }
  void extend(const Box& b) {
    extend(b.lo);
    extend(b.hi);
  }
  bool is_empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  Vec3 center() const { return (lo + hi) * 0.5; }
  bool contains(Vec3 p, int dim) const {
    for (int i = 0; i < dim; ++i)
      if (p[i] < lo[i] || p[i] > hi[i]) return false;
    return true;
  }
};

/// A position as a hash key, exact bits (FNV-1a over the coordinates), with -0 and +0 alike so
/// that it agrees with operator==: for maps that merge or look up identical positions.
struct PositionHash {
  size_t operator()(const Vec3& p) const {
    uint64_t h = 1469598103934665603ull;
    for (int i = 0; i < 3; ++i) {
      uint64_t bits;
      const double c = p[i] == 0 ? 0.0 : p[i];
      std::memcpy(&bits, &c, sizeof bits);
      h = (h ^ bits) * 1099511628211ull;
    }
    return static_cast<size_t>(h);
  }
};

}  // namespace gvd

#pragma once

// Deterministic generators for scenes like the paper's Table 1 (Edwards et al. 2015, §7.1):
// meshing gears (Fig. 1b), blades in slots (Fig. 1c), many 2D polygons at widely varying
// spacings (Fig. 13), plus a packed-spheres scene of our own. Every generator is seeded and
// checks the property it promises (closed meshes, no two objects intersecting) and throws
// std::runtime_error when violated, so a benchmark never runs on a broken scene.

#include <cstdint>
#include <string>

#include "gvd/scene/scene.h"

namespace gvd::bench {

/// Two meshing spur gears (extruded trapezoidal tooth profiles, closed triangle meshes) and a
/// shaft through a bore of the larger gear. Lengths in scene units; the scene spans ~4.3 and
/// its default domain 4.68, so the default gaps are 1.3e-2 of the domain: depth 8 (Table 1).
struct Gears3dOptions {
  double tooth_gap = 0.06;  ///< least distance between the two gears' profiles
  double shaft_gap = 0.06;  ///< radial clearance between shaft and bore
  int samples_per_tooth = 20;
};
scene::Scene make_gears3d(const Gears3dOptions& options = {});

/// A block with three slots along z, a thin blade (knife, a plate) standing in each. A slot is
/// a narrow lip at the block's top (`lip_height` high, `clearance` on each side of the blade)
/// over a wider cavity (`cavity_clearance`); the blade ends `floor_clearance` above the cavity
/// floor. So the tight places are the lips, not whole faces (whose area would make the leaf
/// count explode as area / clearance^2). The scene is 4 x 3 x 1 (domain 4.4). The default
/// clearance, 8e-4 of the domain, gives depth 12 (Table 1); clearance 4e-4 (1e-4 of the scene)
/// gives depth 15 and ~4.6M leaves. `cell` is the tessellation size (~14k triangles).
struct BladesOptions {
  double clearance = 3.5e-3;
  double blade_thickness = 0.02;
  double lip_height = 0.005;
  double floor_clearance = 0.02;
  double cavity_clearance = 0.25;
  double cell = 0.09;
};
scene::Scene make_blades(const BladesOptions& options = {});

/// 2D: `grid` x `grid` cells of the unit square, one random convex or star polygon per cell,
/// except `empty` cells left free (gaps up to ~1e-1) and `pairs` cells holding two polygons
/// pushed together until their gap is log-spaced in [min_gap, max_gap] (unit square = scene
/// size; the domain is 1.093). Objects: grid^2 - empty + pairs. The default min_gap (2.7e-7 of
/// the domain) gives depth 24 (Table 1). Throws if any two segments of different polygons (or
/// non-adjacent segments of one polygon) intersect.
struct Polygons2dOptions {
  uint64_t seed = 13;
  int grid = 20;
  int pairs = 75;
  int empty = 5;
  double min_gap = 3e-7;
  double max_gap = 2e-3;
  int min_sides = 5;
  int max_sides = 16;
};
scene::Scene make_polygons2d(const Polygons2dOptions& options = {});

/// 3D: UV spheres (`rings` x `segments`, 324 triangles by default) in vertical columns on a
/// jittered square lattice of pitch 1. Within a column the spheres are pole to pole, so the
/// mesh gap is exactly the vertical gap, log-spaced in [min_gap, max_gap] and shuffled (scene
/// units; the domain is ~7.0, so the default min_gap is 1e-5 of it). Spheres of different
/// columns are checked by their bounding spheres.
struct SpheresOptions {
  uint64_t seed = 7;
  int columns = 5;  ///< columns x columns columns
  int per_column = 8;
  int rings = 10;
  int segments = 18;
  double min_gap = 7e-5;
  double max_gap = 5e-2;
};
scene::Scene make_spheres(const SpheresOptions& options = {});

/// Least distance between two 2D objects (their segments). O(n m).
double polyline_distance_2d(const scene::SceneObject& a, const scene::SceneObject& b);

}  // namespace gvd::bench

#pragma once

// Small, readable scene builders for tests and benchmarks.

#include <string>

#include "gvd/scene/scene.h"

namespace gvd::test {

/// A closed box [lo, hi] as 12 outward triangles.
scene::SceneObject make_box(const std::string& label, Vec3 lo, Vec3 hi);

/// make_box with its face z = lo.z as a k x k grid of quads (2 k^2 triangles), the other faces
/// two triangles each: the grid's points on the face's sides are T-junctions, where the side
/// faces' edges run past them. Closed as a solid, though no edge of the bottom's rim has one
/// triangle across it.
scene::SceneObject make_box_with_split_bottom(const std::string& label, Vec3 lo, Vec3 hi, int k);

/// A slot [0,1] x [0,0.5] x [0,1] with its opening x in [0.45, 0.55] above the floor y = 0.2,
/// and a blade x in [0.45 + gap, 0.55 - gap], y in [0.2 + gap, 0.8] in it (gap in scene units,
/// on both faces and the floor, whole length). The slot as a quick script builds it: a floor
/// box and two wall boxes in one object, the walls standing on the floor (walls_from 0.2: their
/// undersides glued to its top, their edges there used by four triangles) or pushed into it
/// (0.1), with every part's own corners or (`weld`, as an STL is read) corners at one
/// position welded; or as one closed mesh (`boxes` false: the U's prism, walls_from unused).
struct SlotOfPartsOptions {
  bool boxes = true;
  double walls_from = 0.2;
  bool weld = false;
  double gap = 1e-3;
};
/// Objects "slot", "blade".
scene::Scene make_slot_of_parts(const SlotOfPartsOptions& options);

/// n x n boxes ("c<i><j>"), columns along z over [0, 1], `pitch` apart with `gap` between
/// neighbours: lines along z where four meet.
scene::Scene make_packed_columns(int n, double pitch, double gap);
/// A blade in a slot of three separate parts, all `gap` apart: "floor" [0,1] x [0,0.2] x [0,1],
/// walls "left" [0,0.45] and "right" [0.55,1] from 0.2 + gap up to 0.5, and "blade" between
/// them from 0.2 + gap up to 0.6, running past both ends along z: lines where three meet.
scene::Scene make_slot_of_separate_parts(double gap);
/// p rotated by `angle` (radians) about the unit axis `axis` through the origin (Rodrigues).
Vec3 rotate(Vec3 p, Vec3 axis, double angle);
/// A closed UV sphere with `rings` x `segments` quads split into triangles.
scene::SceneObject make_sphere(const std::string& label, Vec3 centre, double radius, int rings = 12,
                               int segments = 24);
/// A tiny triangle standing in for a point object (3D), size `size` around `centre`.
scene::SceneObject make_point3(const std::string& label, Vec3 centre, double size = 1e-4);
/// A closed polygon approximating a circle (2D).
scene::SceneObject make_circle(const std::string& label, Vec3 centre, double radius,
                               int segments = 32);
/// A closed axis-aligned rectangle (2D).
scene::SceneObject make_rect(const std::string& label, Vec3 lo, Vec3 hi);
/// A single segment (2D).
scene::SceneObject make_segment(const std::string& label, Vec3 a, Vec3 b);
/// A 2D gear outline (closed polygon) with `teeth` teeth.
scene::SceneObject make_gear2d(const std::string& label, Vec3 centre, double r_in, double r_out,
                               int teeth, double phase, int samples_per_tooth = 8);

/// The bounding box of an object's vertices.
Box bounds(const scene::SceneObject& object);

/// Wraps objects into a validated scene.
scene::Scene make_scene(int dimension, std::vector<scene::SceneObject> objects);

/// Every coordinate rounded to float32, as STL and glTF store them. (Through a volatile
/// float: GCC 12.2 at -O2 drops a vectorised double -> float -> double round trip of a Vec3's
/// x and y.)
void round_to_float32(scene::Scene& scene);
/// Every coordinate rounded to `places` decimals, as an OBJ or ASCII STL writer prints them.
void round_to_decimals(scene::Scene& scene, int places);

}  // namespace gvd::test

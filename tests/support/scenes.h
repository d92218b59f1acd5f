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

}  // namespace gvd::test

#pragma once

// Independent oracles: brute force over every simplex of a scene, no octree involved.

#include <functional>
#include <vector>

#include "gvd/scene/scene.h"
#include "gvd/surface/gvd.h"

namespace gvd::test {

struct NearestAnswer {
  scene::ObjectId object = scene::kNoObject;
  double distance = 1e300;
  scene::ObjectId second = scene::kNoObject;  ///< the nearest other object
  double second_distance = 1e300;
};

/// Nearest and second-nearest object to p (user coordinates) by brute force.
NearestAnswer brute_nearest(const scene::Scene& scene, Vec3 p);

/// Distance from p to object o by brute force.
double brute_distance(const scene::Scene& scene, scene::ObjectId o, Vec3 p);

/// The least distance between two 3D triangle meshes by brute force: 0 when an edge of one
/// crosses or touches a triangle of the other, else the least of the vertex-to-triangle
/// distances (both ways) and the edge-to-edge distances. O(V M + E^2).
double brute_mesh_distance(const scene::SceneObject& a, const scene::SceneObject& b);

/// True when segment [a, b] crosses or touches triangle (t0, t1, t2) (3D): the ends' signed
/// distances to the triangle's plane, then the point where the segment meets it tested in the
/// triangle; a segment in the plane (to 1e-12 of the sizes: rounding) is a 2D question.
bool segment_hits_triangle(Vec3 a, Vec3 b, Vec3 t0, Vec3 t1, Vec3 t2);

/// True when 2D segments [a, b] and [c, d] intersect (proper or touching).
bool segments_intersect_2d(Vec3 a, Vec3 b, Vec3 c, Vec3 d);

/// Number of GVD simplices (of all cells) that cross some object simplex; with `budget`, an
/// evenly spread sample of about that many simplices per cell is checked.
size_t count_gvd_object_crossings(const scene::Scene& scene, const surface::Gvd& gvd,
                                  size_t budget = 0);

/// Whether p lies inside a closed 3D cell boundary: parity of the crossings of three rays in
/// skew directions with the cell's triangles, decided by majority (a ray grazing an edge can
/// miscount, three rarely do together).
bool inside_cell(const surface::GvdCell& cell, Vec3 p);

/// Watertightness of one 3D cell: every directed edge (by vertex position) is matched by the
/// opposite directed edge as often as it occurs. 2D: every position is entered as often as
/// it is left. Returns the number of unmatched edges / vertices.
size_t count_open_edges(const surface::GvdCell& cell, int dimension);

/// Orientation of the GVD's simplices by area (2D: length): from each sampled simplex's
/// centroid c, a step of step_at(c) along its normal (3D: into the cell; 2D: to the left of
/// the segment), but at most half the pair's clearance at c (farther, across a thin gap, both
/// probes would land in the objects' material), must be nearer to the cell's object than to
/// the object across, and the step the other way nearer to that one (brute force). Where the GVD
/// runs (nearly) along an octree plane the marching construction leaves folded slivers whose own
/// normals may point either way, though the surface stays closed and consistently oriented: hence a
/// share, not a count. About `budget` simplices of each cell are sampled, evenly spread; `counted`
/// (optional) limits the measure to the pairs (cell's object, other) it accepts.
struct Orientation {
  double tested = 0;   ///< area of the sampled simplices
  double flipped = 0;  ///< of it, facing the wrong way
};
Orientation measure_orientation(
    const scene::Scene& scene, const surface::Gvd& gvd, const std::function<double(Vec3)>& step_at,
    size_t budget, const std::function<bool(scene::ObjectId, scene::ObjectId)>& counted = nullptr);

}  // namespace gvd::test

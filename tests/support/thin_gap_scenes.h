#pragma once

// Deterministic "thin gap" scenes: objects facing each other over a large area at a small gap g,
// the hard case of an octree GVD (every cell along the whole facing area must refine down to
// ~g, so the leaf count grows as area / g^2). Unit tests and benchmarks share them, so each
// generator checks what it promises and throws std::runtime_error naming the object and what
// failed: every 3D object a closed, welded, edge-manifold, outward mesh without T-junctions
// (verify_closed_mesh), every 2D object a closed CCW polygon (verify_closed_polygon), no two
// objects intersecting or nested, and the least distance of each facing pair equal to g within
// 1e-9 relative (brute force over the simplex pairs whose boxes come within 2 g). Invalid
// options throw std::invalid_argument.
//
// Gaps are FRACTIONS OF THE DEFAULT DOMAIN SIDE (gvd::scene::make_domain without a box): the
// bounding box of all vertices made a cube of its largest extent E and padded by 5 % of E on every
// side, so the side is 1.1 E. A generator computes its scene's E first and builds the gap g = gap
// * 1.1 * E in scene units; the option is then the gap as the octree sees it, whatever the scene's
// size. Lengths other than gaps (widths, `cell`) are in scene units.
//
// Large flat faces are grids of coplanar triangles about `cell` on a side, with the same
// subdivision points on both faces of every shared edge, so the meshes stay watertight.

#include <cstdint>

#include "gvd/scene/scene.h"

namespace gvd::test {

/// make_blade_in_slot: a block [0,1] x [0,0.5] x [0,1] (x, y, z) with a straight slot cut into
/// its top face along z over the whole length, x in [0.5 - width/2 - g, 0.5 + width/2 + g],
/// y in [0.5 - depth, 0.5] (a U cross-section extruded along z), and a blade (box)
/// x in [0.5 - width/2, 0.5 + width/2], y in [0.5 - depth + g, 0.8], z in [0.1, 0.9]: clearance
/// g to both slot walls and to the floor over the whole facing faces (not just along a lip),
/// sticking out above the block. E = 1. Defaults: 3872 + 880 triangles.
struct BladeInSlotOptions {
  double width = 0.05;  ///< blade thickness along x (scene units), < 1 - 2 g
  double depth = 0.3;   ///< slot depth below the block top (scene units), in (g, 0.5)
  double gap = 1e-3;    ///< clearance, fraction of the domain side (g = gap * 1.1)
  double cell = 0.05;   ///< target triangle edge length (scene units)
};
/// Objects "block", "blade". Checks the gap and that every blade vertex on the two side faces
/// below the block top and on the bottom face is exactly g from the block.
scene::Scene make_blade_in_slot(const BladeInSlotOptions& options = {});

/// make_stacked_plates: `count` boxes [0,1] x [y_i, y_i + thickness] x [0,1] along y, with
/// y_i = i (thickness + g): consecutive plates face each other over their whole 1 x 1 faces at
/// gap g, sides flush. E = max(1, count * thickness + (count - 1) g). Defaults: 6 x 1920
/// triangles.
struct StackedPlatesOptions {
  int count = 6;           ///< number of plates, >= 2
  double thickness = 0.1;  ///< plate thickness along y (scene units)
  double gap = 1e-5;       ///< gap between consecutive plates, fraction of the domain side
  double cell = 0.05;      ///< target triangle edge length (scene units)
  /// Every other plate (odd indices) inset by this much on its four sides, x and z in
  /// [inset, 1 - inset]: its rims are edges over the next plates' faces, not mirror images.
  /// In [0, 0.5); 0: flush.
  double inset = 0;
};
/// Objects "plate_0" .. "plate_<count-1>". Checks the gap of each consecutive pair (and that
/// every vertex of each facing face — of the inset plate's, with an inset — is exactly g from
/// the other plate), the others > 2 g apart.
scene::Scene make_stacked_plates(const StackedPlatesOptions& options = {});

/// make_shaft_in_bore: a housing block [-0.5,0.5] x [-0.5,0.5] x [0,0.6] with a bore along z,
/// a regular `sides`-gon of circumradius `radius` centred on the z axis with a vertex on +x; and
/// a shaft, the same polygon with its apothem smaller by exactly g (every flat shaft face is g
/// from its bore face), z in [-0.2, 0.8], sticking out of both ends. The housing's end caps
/// (squares with a polygonal hole) are meshed in rings of quads along rays from the axis through
/// the wall subdivision points. E = 1. Defaults: 7728 + 1296 triangles.
struct ShaftInBoreOptions {
  int sides = 6;        ///< bore polygon sides, >= 3
  double radius = 0.2;  ///< bore circumradius (scene units), < 0.5
  double gap = 1e-4;    ///< face-to-face clearance, fraction of the domain side
  double cell = 0.05;   ///< target triangle edge length (scene units)
};
/// Objects "housing", "shaft". The least distance is exactly g (faces; the shaft's corners are
/// g / cos(pi / sides) from the bore's). Checks it, and that every shaft vertex with z in
/// [0, 0.6] is exactly g from the housing.
scene::Scene make_shaft_in_bore(const ShaftInBoreOptions& options = {});

/// make_ball_in_socket: a ball, the UV sphere of test::make_sphere (`rings` x `segments`,
/// radius `radius`, centred at the origin), sealed in a socket: the box [-0.5,0.5]^3 with a
/// cavity that is the same sphere scaled by 1 + g / d, d the least distance from the centre to
/// a face's plane, and turned inside out. Every ball face is parallel to its cavity face at a
/// gap between g (the faces nearest the centre) and g times the largest over the least plane
/// distance (1.005 at 12 x 24): a spherical joint or a ball in a race, whose rims between
/// facets run along no axis. The socket has two shells (box and cavity), so its scene carries
/// a `multiple_components` warning and nothing else. E = 1. Defaults: 528 + 540 triangles.
struct BallInSocketOptions {
  int rings = 12;       ///< latitude bands, >= 3
  int segments = 24;    ///< longitude segments, >= 3
  double radius = 0.3;  ///< ball radius (scene units), < 0.5
  double gap = 1e-3;    ///< least clearance, fraction of the domain side (g = gap * 1.1)
};
/// Objects "socket", "ball". Checks the gap.
scene::Scene make_ball_in_socket(const BallInSocketOptions& options = {});

/// make_cube_in_cavity: the cube [0.3, 0.7]^3 sealed in a cubic cavity of the block
/// [0,1]^3, g from it on all six faces: the cube's edges face the cavity's concave edges across
/// g. With `cavity_inside_out` the cavity's shell is written with its normals into the
/// block's material (as an outer skin's), as exporters that ignore nesting write it; the scene
/// is the same solid. The block has two shells, so its scene carries a `multiple_components`
/// warning. E = 1.
struct CubeInCavityOptions {
  double gap = 1e-4;               ///< face gap, fraction of the domain side (g = gap * 1.1)
  bool cavity_inside_out = false;  ///< the cavity's triangles in the order of an outer skin
};
/// Objects "block", "cube". Checks the gap (before turning the cavity).
scene::Scene make_cube_in_cavity(const CubeInCavityOptions& options = {});

/// make_parallel_bars_2d: two rectangles, bar_a = [0,1] x [-0.1,0] and bar_b = [0,1] x
/// [g, g + 0.1]: long edges parallel at g over their whole length. Each outline has its long
/// edges split into `segments` equal segments and its short edges one segment (82 segments per
/// bar by default, 164 in all). E = max(1, 0.2 + g).
struct ParallelBarsOptions {
  double gap = 1e-3;  ///< gap between the long edges, fraction of the domain side
  int segments = 40;  ///< segments per long edge, >= 1
};
/// Objects "bar_a", "bar_b". Checks the gap and that every vertex of the facing edges is
/// exactly g from the other bar.
scene::Scene make_parallel_bars_2d(const ParallelBarsOptions& options = {});

/// make_polygon_pairs_2d: `pairs` pairs of convex polygons in distinct cells of a
/// grid_x x grid_y grid over the unit square (cells drawn by a seeded shuffle, pairs numbered in
/// raster order). For each pair a random convex polygon (min_sides..max_sides sides, inscribed
/// in a circle of radius ~0.3 of the cell at a jittered centre, random sorted angles) is cut by
/// a random line through its interior into two convex pieces, which are moved apart along the
/// cut's normal by g/2 each: their cut edges are exactly parallel (one is a translate of the
/// other), of the same length, without offset along the cut (< 1e-9 of its length) and exactly g
/// apart. A pair's gap is log-spaced in [min_gap, max_gap] (fractions of the domain side) and
/// shuffled across pairs. Pieces with an edge < 1e-3 or an area < 5 % of the polygon are
/// resampled. Vertices lie on the 2^-53 lattice (every multiple of 2^-53 in (-1, 1) is a
/// double, so the moves are exact) and each move is a lattice vector whose component along the
/// normal is g to ~1e-19 absolute: the measured gaps are then right to ~2e-11 relative at a
/// gap of 1e-7 (the measurement's own rounding), where rounding the ideal pieces to doubles would
/// leave ~7e-10. Below ~1e-8 the measurement itself (~1e-18 absolute) exceeds the 1e-9 check.
/// E (< 1) depends on the moves; it is solved for by fixed-point iteration. Objects: 2 * pairs,
/// labels "p<pair>_a", "p<pair>_b"; defaults: 470 objects, 2749 segments.
struct PolygonPairsOptions {
  uint64_t seed = 17;
  int pairs = 235;        ///< number of pairs, <= grid_x * grid_y
  int grid_x = 16;        ///< cells along x
  int grid_y = 15;        ///< cells along y
  double min_gap = 1e-7;  ///< smallest pair gap, fraction of the domain side
  double max_gap = 1e-3;  ///< largest pair gap, fraction of the domain side
  int min_sides = 5;      ///< sides of the polygon before the cut
  int max_sides = 12;
};
/// Checks each piece convex and CCW, each pair's least distance equal to its g, the cut edges
/// facing each other fully, and objects of different pairs more than 1e-2 apart.
scene::Scene make_polygon_pairs_2d(const PolygonPairsOptions& options = {});

/// Least distance between two 3D objects (triangle soups; 0 when they touch or intersect),
/// exact up to rounding: brute force over the triangle pairs whose bounding boxes come within a
/// radius r (hashed grid), r starting at the distance of the objects' boxes and grown (x4, or to
/// the best distance found so far) until the answer is within it. Coordinates are taken relative
/// to a vertex of each pair, so tiny gaps are measured to ~1e-18 rather than to the ulp of the
/// coordinates. Cost ~ the number of triangle pairs within a few times the answer.
double min_distance_3d(const scene::SceneObject& a, const scene::SceneObject& b);

/// Least distance between two 2D objects (segments, z ignored; 0 when two segments touch), as
/// min_distance_3d.
double min_distance_2d(const scene::SceneObject& a, const scene::SceneObject& b);

/// Throws std::runtime_error (naming the object, triangle, edge or vertex) unless `object` is a
/// closed, welded (no two vertices at one position, every vertex used), edge-manifold, outward
/// triangle mesh without degenerate triangles or T-junctions: every directed edge (a, b) used
/// once and matched by exactly one (b, a), and a positive signed volume. O(n log n).
void verify_closed_mesh(const scene::SceneObject& object);

/// Throws std::runtime_error unless `object` is one closed, simple, counter-clockwise 2D
/// polygon (z = 0): segments v[0] -> v[1] chained through shared indices, every vertex the end
/// of exactly two segments (once as v[0], once as v[1]), no two vertices at one position,
/// positive signed area, no two non-adjacent segments touching. O(n^2) for the simplicity test.
void verify_closed_polygon(const scene::SceneObject& object);

}  // namespace gvd::test

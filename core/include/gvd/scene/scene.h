#pragma once

// The pipeline's input and its map to the octree: labelled objects (polygon soups), their
// validation with warnings and limits, mesh topology, the cubic domain and its frame
// (make_domain), and the scene in the unit domain (make_unit_geometry), its coordinates snapped
// to exact dyadic numbers. Errors are gvd::Error (kInvalidScene, kInvalidArgument, kCancelled).

#include <array>
#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/geometry/simplex.h"
#include "gvd/geometry/vec.h"

namespace gvd::scene {

/// Index of an object in its scene (its position in `Scene::objects`).
using ObjectId = uint32_t;
/// No object: an empty octree cell, or the domain box on the other side of a GVD simplex.
inline constexpr ObjectId kNoObject = 0xFFFFFFFFu;
/// Several objects in one octree cell (only at the depth limit, where objects touch).
inline constexpr ObjectId kManyObjects = 0xFFFFFFFEu;

/// One labelled object: a polygon soup (2D segments or 3D triangles) in user coordinates.
struct SceneObject {
  std::string label;
  std::vector<Vec3> vertices;  ///< 2D objects keep z = 0
  std::vector<Simplex> simplices;
};

/// What a warning is about. Each has a stable name (warning_kind_name), the "kind" of the
/// JSON documents (docs/FORMATS.md); warnings_to_json / warnings_from_json (load_scene.h)
/// are the one writer and reader.
enum class WarningKind {
  kDegenerateSimplices,  ///< simplices of zero length or area, removed
  kOpenMesh,             ///< edges with one triangle (3D) / vertices with one segment (2D)
  kNonManifold,          ///< edges shared by more than two triangles
  kMultipleComponents,   ///< an object made of several connected pieces
  kLabelsTouch,          ///< labels of a volume that share voxel faces
  kObjectsTouch,         ///< pairs closer than the finest cells separate (the pipeline)
  kThinRegionsLeft,      ///< cells still hiding a thin region (the pipeline)
  kAmbiguousCellsLeft,   ///< cells still ambiguous at the refinement limit (the pipeline)
  kConesDropped,         ///< the refinement did not settle with cones; built without (the pipeline)
  kReorientedTriangles,  ///< triangles reversed to agree with their neighbours (3D)
  kFacesSnapped,         ///< float32 faces moved onto exact planes (the pipeline, snap_faces.h)
};

/// The stable name of a kind ("degenerate_simplices", "open_mesh", ...).
const char* warning_kind_name(WarningKind kind);
/// The kind of a stable name; nullopt for a name no kind has.
std::optional<WarningKind> warning_kind_from_name(std::string_view name);

/// A condition that was accepted but that the user should know about.
struct SceneWarning {
  WarningKind kind = WarningKind::kDegenerateSimplices;
  std::string object;  ///< label, empty when it concerns the whole scene
  uint64_t count = 0;  ///< how many instances (simplices, edges, components, pairs)
  std::string detail;  ///< human readable, says where
};

/// The validated input of the pipeline: labels unique, indices in range, coordinates
/// finite, degenerate simplices removed (counted in `warnings`).
struct Scene {
  int dimension = 3;
  std::vector<SceneObject> objects;
  /// The length unit of the coordinates, by its canonical name ("mm", "µm", ...; units.h);
  /// empty: none declared. A label only: every reported length says it, nothing is scaled.
  std::string units;
  std::vector<SceneWarning> warnings;

  uint64_t simplex_count() const;
  uint64_t vertex_count() const;
  /// Index of the object with this label, if any.
  std::optional<ObjectId> find(const std::string& label) const;
};

/// Limits enforced before any work starts (the service and CLI expose them as options).
struct SceneLimits {
  uint64_t max_objects = 100000;
  uint64_t max_simplices = 20000000;
  /// Vertices of all objects; 0: 3 per simplex of max_simplices (a soup of separate
  /// triangles), so that a file of vertices without simplices cannot fill the memory.
  uint64_t max_vertices = 0;
  double max_abs_coordinate = 1e15;  ///< larger magnitudes lose all precision in the lattice

  /// max_vertices, or 3 x max_simplices when it is 0 (saturated at UINT64_MAX).
  uint64_t vertex_limit() const {
    if (max_vertices != 0) return max_vertices;
    return max_simplices > UINT64_MAX / 3 ? UINT64_MAX : 3 * max_simplices;
  }
};

/// Checks the structure of a parsed scene and normalises it in place: throws
/// gvd::Error{kInvalidScene} naming the object label and simplex/vertex index for missing or
/// duplicate labels, out-of-range indices, non-finite or too large coordinates, an empty
/// scene or empty objects; removes degenerate simplices (zero length/area, repeated
/// indices) and records warnings for them; in 3D reverses triangles that run an edge the
/// same way as their only neighbour across it, so that each edge-connected part is oriented
/// one way (the way of its larger area; a warning says how many); records warnings for open
/// or non-manifold meshes and for objects with several connected components. O(V + S log S).
/// `cancel` (may be null) is read between objects and every few tens of thousands of vertices
/// and simplices: set, it stops with gvd::Error{kCancelled} (the scene is then half
/// normalised).
void validate_scene(Scene& scene, const SceneLimits& limits = {},
                    const std::atomic<bool>* cancel = nullptr);

/// No triangle across a side (triangles_across).
inline constexpr uint32_t kNoNeighbour = 0xFFFFFFFFu;
/// Per side of each triangle of a 3D object (index 3 t + e: the edge v[e] v[e+1]), the
/// triangle across it where exactly two triangles use that edge (vertices matched by index),
/// else kNoNeighbour. O(S log S). `cancel` (may be null) is read between its steps: set, it
/// stops with gvd::Error{kCancelled} naming `what`.
std::vector<uint32_t> triangles_across(const SceneObject& object,
                                       const std::atomic<bool>* cancel = nullptr,
                                       const char* what = "validating the scene");

/// An object's boundary and non-manifold elements: in 2D vertices of degree 1 and > 2, in 3D
/// edges used by one and by more than two triangles (vertices matched by index). Both 0: the
/// object is closed (validate_scene's open_mesh and non_manifold warnings count the same).
struct MeshTopology {
  uint64_t open = 0;
  uint64_t non_manifold = 0;
};
MeshTopology mesh_topology(const SceneObject& object, int dimension);
/// Whether an object is closed: it has simplices, and mesh_topology finds no open and no
/// non-manifold element (2D: every vertex of its segments has degree 2; 3D: every edge of its
/// triangles is used by exactly two). Vertices are matched by index, so an unwelded mesh is
/// open. Closed objects have an inside: ray parity (row_crosses_triangle) decides it.
bool is_closed_object(const SceneObject& object, int dimension);

/// The computational domain: a square/cube in user coordinates, and the map to the unit
/// lattice [0,1]^D in which the octree works. The cube's edges run along `axis` (the octree's
/// frame): the user's x, y, z unless make_domain turned it to the scene's faces (3D).
struct Domain {
  int dimension = 3;
  Vec3 origin;        ///< the corner at unit (0, 0, 0) (user units)
  double side = 1.0;  ///< edge length (user units)
  /// Unit vectors (user coordinates) of the unit domain's x, y, z: a rotation (orthonormal,
  /// right-handed). 2D: always the identity.
  Vec3 axis[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};

  Vec3 to_unit(Vec3 p) const;
  Vec3 from_unit(Vec3 u) const;
  /// Whether the frame is the user's own (axis = identity).
  bool aligned() const;
  /// The smallest axis-aligned box (user units) holding the domain (z = 0..0 in 2D); the
  /// domain itself when aligned().
  Box box() const;
  /// Whether a point (user units) lies in the domain, up to `slack` of the side.
  bool contains(Vec3 p, double slack = 0) const;
};

/// How make_domain orients the octree.
enum class DomainFrame {
  /// 3D: along the scene's faces when more of their area lies on planes perpendicular to one
  /// frame than to the user's axes (a tilted part, an assembly drawn at an angle): the octree's
  /// certified cells follow straight rims only along its axes (docs/ALGORITHM.md). 2D, a user
  /// box, or no such frame: the user's axes.
  kAuto,
  kWorld,  ///< always the user's axes
};
/// "auto" / "world"; throws gvd::Error{kInvalidArgument} for anything else.
DomainFrame parse_domain_frame(const std::string& name);
const char* domain_frame_name(DomainFrame frame);

/// Options of `make_domain`.
struct DomainOptions {
  /// User-given box (user units); it is made a cube of its largest extent, centred.
  std::optional<Box> box;
  /// Padding on every side as a fraction of the largest extent (default 5 %).
  double padding = 0.05;
  DomainFrame frame = DomainFrame::kAuto;
  /// Threads of the frame's search (analyse_scene_frame); 0: all hardware threads.
  /// compute_gvd sets it to PipelineOptions::threads.
  int threads = 0;
  /// Set by another thread to stop with gvd::Error{kCancelled}; read every few thousand
  /// triangles of the frame's search. compute_gvd sets it to PipelineOptions::cancel.
  const std::atomic<bool>* cancel = nullptr;
};

/// The frame of a 3D scene's faces: three orthonormal right-handed axes such that the area
/// of triangles perpendicular (within 1e-7 rad) to one of them is as large as the greedy
/// choice finds: for each of the directions with the most such area, the one perpendicular
/// to it with the most; ordered and signed to stay nearest the user's x, y, z. A triangle
/// that faces another object's flat face (a parallel triangle of it whose plane lies within
/// 1/64 of the scene's largest extent of the centroid, which projects into it; at most 64 of
/// the other objects' triangles are looked at) weighs 1000 times its area: only rims across
/// a thin gap cost octree cells, so a round shaft in a bore turns the octree to the shaft's
/// facets even when the housing's outside is drawn along x, y, z. The user's axes unless that frame
/// holds at least 10 % of the weighted area on its planes and 5 % more than they do (curved meshes,
/// scenes already drawn along x, y, z keep them). O(T log T) for T triangles (one BVH query per
/// triangle).
std::array<Vec3, 3> scene_frame(const Scene& scene);

/// Straight rims across a thin gap, along one axis of the frame, whose two faces' normals
/// have components of both signs along another axis k (a hexagonal shaft's corner on the x
/// axis: normals at +-30 degrees from x, k = y), at one coordinate along axes[k]. The
/// bisector over them is a roof that a line along axes[k] can meet twice: cells that hold its
/// apex strictly inside are not certified and refine to the gap along the whole rim, cells on
/// either side of it are (the cones of pair_certificate.h).
struct StraddledRims {
  int axis = 0;  ///< k
  /// The roof's apex: its coordinate along axes[k] (user units), found numerically on exact
  /// distances for the longest edge (not a vertex's coordinate in general).
  double apex = 0;
  double length = 0;  ///< of all the rims' edges
  /// The edges (user coordinates), at most kMaxStraddledEdges of them (the longest).
  std::vector<std::array<Vec3, 2>> edges;
};
constexpr size_t kMaxStraddledEdges = 256;

/// What make_domain lays the octree along (3D; 2D: the identity and no rims).
struct SceneFrame {
  std::array<Vec3, 3> axes = {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  /// Per axis k, the straddled rims at distinct coordinates, the most length first (at most
  /// kMaxStraddledGroups per axis: a roof's apex costs a few thousand exact distances).
  std::array<std::vector<StraddledRims>, 3> straddled;
};
constexpr size_t kMaxStraddledGroups = 16;
/// scene_frame (turned only when `turn`) and the straddled rims along its axes: one pass over
/// the facing triangles, on `threads` threads (0: all hardware threads). `cancel` (may be
/// null) is read every few thousand triangles and every root of a roof's apex: set, it stops
/// with gvd::Error{kCancelled}.
SceneFrame analyse_scene_frame(const Scene& scene, bool turn = true, int threads = 0,
                               const std::atomic<bool>* cancel = nullptr);

/// The default domain: bounding box of all vertices in the frame (options.frame) made a cube
/// (side = largest extent, centred) and padded by `padding` of the side on every side. With
/// DomainFrame::kAuto in 3D, the cube is then shifted along each axis, within the padding, so
/// that the apex of the longest straddled rims of analyse_scene_frame along it lies on a
/// lattice plane from level kRimAlignLevel down. A user box (always in the user's axes) must
/// contain every vertex, else gvd::Error{kInvalidArgument}. `frame`, when given, receives the
/// analysis (the default: none for a user box, 2D or DomainFrame::kWorld).
Domain make_domain(const Scene& scene, const DomainOptions& options = {},
                   SceneFrame* frame = nullptr);
/// The coarsest octree level whose planes make_domain puts the straddled rims on (a shift of
/// at most 2^-(kRimAlignLevel+1) of the side).
constexpr int kRimAlignLevel = 5;

/// Bits of the unit lattice in which octree cells live: cells at level l span 2^(bits-l)
/// lattice units. 3D: 21 (so (2^21+1)^3 lattice points fit 64 bits), 2D: 31.
constexpr int lattice_bits(int dimension) { return dimension == 2 ? 31 : 21; }

/// The scene mapped to the unit domain: one flat array of points and simplices with the
/// object of each simplex, coordinates snapped to multiples of 2^-48 so that every coordinate
/// is an exact dyadic number (octree tests on lattice-aligned cells stay reproducible).
struct UnitGeometry {
  int dimension = 3;
  std::vector<Vec3> points;
  std::vector<Simplex> simplices;   ///< indices into `points`
  std::vector<ObjectId> object_of;  ///< per simplex
  uint32_t object_count = 0;
  /// The input coordinates' own rounding in unit lengths: 2^-53 of the largest coordinate
  /// magnitude (user units) over the domain's side. Below the lattice's 2^-49 unless the
  /// scene lies far from the origin.
  double rounding = 0;
};

/// Maps every object of the scene into the unit domain. Vertices outside the domain are an
/// error (gvd::Error{kInvalidArgument} naming object and vertex).
UnitGeometry make_unit_geometry(const Scene& scene, const Domain& domain);

}  // namespace gvd::scene

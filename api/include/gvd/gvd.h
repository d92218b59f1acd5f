#pragma once

// gvd/gvd.h — the stable C++ API of gvd: generalized Voronoi diagrams of labelled objects,
// in-process (the calls the Python module exposes too). See docs/CPP.md.
//
// Stable: this header and gvd/common/error.h (gvd::Error, gvd::ErrorCode), the CMake target
// gvd::core and the pkg-config package gvd. Within a 0.MINOR series (0.2.x) they change only
// compatibly; a new minor version may change them (the package's version file accepts only
// the same major.minor).
// Internal: every other installed header (gvd/pipeline, gvd/graph, gvd/scene, gvd/io,
// gvd/kernels, ...). They are installed for callers who need more than this facade, but may
// change in any release. `Result::internal()` is the bridge from here to them.
//
// Conventions: coordinates are in the caller's units, as doubles; an array of points holds
// dimension() numbers per point (x, y or x, y, z), back to back, so that an (n, D) array in
// row-major order can be passed and returned as it is. Objects are numbered by the order of
// Scene::add (0, 1, ...); kNone (-1) means "no object". Errors are thrown as gvd::Error whose
// code() says what kind (ErrorCode) and detail() where (object label, simplex or point index);
// "nothing found" (no path) is an answer, not an error. Result and its queries are const and
// thread-safe: one Result may serve many threads.

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gvd/common/error.h"

namespace gvd::result {
struct GvdResult;
}

namespace gvd::api {

/// The library's version ("0.2.0"), the same as the CMake package's.
std::string_view version();

/// An object's index in its scene (the order of Scene::add).
using Object = int32_t;
/// No object: the domain box on the other side of a cell boundary, or a point that has none.
inline constexpr Object kNone = -1;

/// Labelled objects built from arrays: 3D triangle meshes or 2D segment sets (polygon soups;
/// open, non-manifold and several-component meshes are accepted with a warning).
class Scene {
 public:
  /// An empty scene of dimension 2 or 3 (else gvd::Error{kInvalidArgument}).
  explicit Scene(int dimension = 3);
  ~Scene();
  Scene(const Scene& other);
  Scene& operator=(const Scene& other);
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;

  /// Reads scene files, as `gvd compute` does: one scene JSON, OBJ (o/g groups = objects) or
  /// GLB/glTF (nodes = objects), or several PLY/STL/OFF/OBJ files, one object each, labelled
  /// by file stem. Validated: gvd::Error{kInvalidScene/kUnsupportedFormat/kIo} says what and
  /// where.
  static Scene load(std::span<const std::string> paths);
  static Scene load(const std::string& path);

  /// A labelled voxel volume (a segmentation) as a scene, as `gvd compute --volume` reads it:
  /// `labels` holds shape[0] x ... values, x fastest (shape = {nx, ny} or {nx, ny, nz});
  /// every label but `background` (< 0: none) becomes an object "label_<id>" (increasing id)
  /// bounded by the voxel faces it shares with other labels, the background or the outside,
  /// voxel (i, j, k) spanning origin + [i, i + 1] x spacing (dimension() numbers each).
  /// gvd::Error{kInvalidArgument} for sizes that do not match, {kInvalidScene} when no
  /// label is left.
  static Scene from_labels(std::span<const uint64_t> labels, std::span<const uint64_t> shape,
                           std::span<const double> spacing = {},
                           std::span<const double> origin = {}, int64_t background = 0);

  /// Adds an object and returns its index. `vertices`: dimension() numbers per vertex, user
  /// units; `simplices`: dimension() 0-based indices into this object's vertices per simplex
  /// (3D: triangles, 2D: segments). Copies both. Throws gvd::Error{kInvalidArgument} when an
  /// array's length is not a multiple of dimension(), {kInvalidScene} for an empty or
  /// duplicate label; indices and coordinates are checked by compute() (kInvalidScene, naming
  /// the label and the index). O(size of the arrays).
  Object add(std::string label, std::span<const double> vertices,
             std::span<const uint32_t> simplices);

  int dimension() const;
  /// The length unit of the coordinates by its canonical name ("mm", "µm", ...); empty when
  /// none is declared. A scene JSON's "units" (load()); never scaled, only reported.
  const std::string& units() const;
  /// Sets (or, with "", clears) the length unit: nm, um/µm, mm, cm, m, km, in, ft or Å, kept
  /// by its canonical name; gvd::Error{kInvalidArgument} naming "units" for any other.
  void set_units(std::string_view units);
  /// Number of objects.
  int size() const;
  const std::string& label(Object object) const;

 private:
  friend class Access;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Options of compute(): the options of `gvd compute`, with the same defaults (`gvd --help`
/// and the README explain each).
struct ComputeOptions {
  int max_depth = 0;  ///< --max-depth: deepest octree level; 0 = default (2D 26, 3D 21)
  /// --domain: the domain box as lo..., hi... (2 x dimension numbers, user units), made a
  /// cube; empty = the bounding box of the scene + 5 % of its side on every side.
  std::vector<double> domain;
  std::string frame = "auto";  ///< --frame auto|world: the octree's axes (3D)
  int threads = 0;             ///< --threads: worker threads, 0 = all cores
  /// --backend auto|opencl|cpu: where the data-parallel steps run. auto = OpenCL when a device
  /// with fp64 exists (chosen once per process), else the CPU; opencl without one is
  /// gvd::Error{kInvalidArgument}.
  std::string backend = "auto";
  std::string octree_build = "levels";  ///< --octree-build levels|data-parallel
  std::string distance = "exact";       ///< --distance exact|wavefront
  std::string refine = "certified";     ///< --refine certified|paper
  std::string junctions = "on";         ///< --junctions on|off (junction cells; 3D)
  std::string resolution = "compact";   ///< --resolution compact|full (the GVD's pieces)
  double curved_tolerance = 0;          ///< --curved-tolerance in [0, 1)
  int contact_depth = 0;                ///< --contact-depth; 0 = default (2D 14, 3D 8)
  uint64_t max_leaves = 12'000'000;     ///< --max-leaves (peak memory up to ~1 KB per leaf)
  uint64_t max_objects = 100'000;       ///< --max-objects
  uint64_t max_simplices = 20'000'000;  ///< --max-simplices
  int ambiguity_levels = -1;            ///< --ambiguity-levels; < 0 = default
  int ambiguity_rounds = -1;            ///< --ambiguity-rounds; < 0 = default
  int unseen_rounds = -1;               ///< --unseen-rounds; < 0 = default
  /// Called from the computing thread with the stage name ("octree", "distance", ...,
  /// "done") and the fraction done in [0, 1]. Optional.
  std::function<void(std::string_view stage, double fraction)> progress;
  /// When it becomes true, compute() stops soon and throws gvd::Error{kCancelled}. Optional;
  /// must outlive the call.
  const std::atomic<bool>* cancel = nullptr;
};

/// A dual-graph edge: objects a < b whose Voronoi cells share boundary (paper §7.3).
struct Edge {
  Object a = kNone;
  Object b = kNone;
  double area = 0;                         ///< interface area (3D) or length (2D) inside the domain
  double min_clearance = 0;                ///< least distance from the interface to the objects
  std::array<double, 3> tightest_point{};  ///< where it is attained (z = 0 in 2D)
  double gap = -1;        ///< least distance between a and b, exact (< 0: not measured)
  bool touching = false;  ///< closer than the finest cells separate (then min_clearance 0)
};

/// An object within k rings of another in the dual graph.
struct Neighbor {
  Object object = kNone;
  int ring = 0;        ///< 1 = shares boundary with the query object
  Object via = kNone;  ///< a ring - 1 neighbour it is reached from (ring 1: the query)
  double area = 0;     ///< interface area (length in 2D) between `via` and `object`
  double min_clearance = 0;
  double gap = -1;
  bool touching = false;
};

/// Nearest objects of a batch of points, one entry per point in each array.
struct NearestBatch {
  std::vector<Object> object;    ///< kNone for a point outside the domain or not finite
  std::vector<double> distance;  ///< to `closest` (never below the true distance); NaN: none
  std::vector<double> closest;   ///< dimension() numbers per point: the point on `object`
  /// 1 inside `object`, 0 outside, -1 when `object` is not closed (then it has no inside) or
  /// there is none. Closed: every edge (2D: vertex) of the object is shared by exactly two of
  /// its simplices; exact ray parity decides.
  std::vector<int8_t> inside;
  /// `distance`, negative inside a closed object (equal to `distance` for an open one).
  std::vector<double> signed_distance;
};

struct PathOptions {
  double min_clearance = 0;   ///< passages narrower than this are not used
  bool by_clearance = false;  ///< minimise length / clearance (prefer wide passages), not length
};

/// A path on the GVD (retraction roadmap, paper §7.2) that crosses no object.
struct Path {
  bool found = false;
  std::vector<double> points;  ///< dimension() numbers per point, from ... to; empty if !found
  double length = 0;
  double min_clearance = 0;  ///< exact least distance from the polyline to the objects
  std::string reason;        ///< why there is none, when !found
};

/// The boundary of one object's Voronoi cell as arrays. 3D: triangles whose normal (right
/// hand, (b-a)x(c-a)) points into the cell, closed and consistently oriented; 2D: segments
/// with the cell on their left. A vertex is duplicated per object on the other side.
struct Cell {
  std::vector<double> vertices;     ///< dimension() numbers per vertex
  std::vector<uint32_t> simplices;  ///< dimension() vertex indices per triangle/segment
  std::vector<Object> other;        ///< per vertex: the object across (kNone = domain box)
  std::vector<double> clearance;    ///< per vertex: distance to the nearest object
};

/// Exploded view around an anchor object (paper §7.4), one entry per object in each array.
struct Explosion {
  double scale = 0;                  ///< displacement per ring used
  std::vector<int> ring;             ///< ring around the anchor (0 = anchor, -1 = unreachable)
  std::vector<double> displacement;  ///< dimension() numbers per object
  /// Per object: the share of scale * ring * direction kept (in [0, 1]; GvdIndex::explode) so
  /// that, all moving at once, no two come closer than half of their gap or of the scale.
  std::vector<double> factor;
};

/// A connected region of the GVD interface between a contact's objects where twice the
/// clearance (the distance across the interface) is below the bound.
struct ContactSite {
  double area = 0;                   ///< area (2D: length), clearance interpolated per piece
  std::array<double, 3> centroid{};  ///< z = 0 in 2D
  /// The least gap measured across the site (exact closest points on both objects of its
  /// lowest-clearance GVD vertices): >= the pair's gap, < the bound.
  double min_gap = 0;
  std::array<double, 3> on_a{}, on_b{};  ///< the closest points of that measurement
};

/// A pair of objects closer than the bound of Result::contacts.
struct Contact {
  Object a = kNone;  ///< a < b
  Object b = kNone;
  double gap = 0;  ///< exact least distance between the objects' simplices; 0: they meet
  std::array<double, 3> on_a{}, on_b{};  ///< a closest pair of points, one on each
  bool interference = false;             ///< they touch or intersect (gap 0)
  /// With interference: the deepest vertex of either object inside the other (closed)
  /// object, to its surface: a lower bound of the penetration depth; < 0: not computable.
  double depth_lower_bound = -1;
  /// With interference, where both objects are convex (closed, one part, convex at every
  /// edge): the penetration depth, the length of the shortest translation that separates
  /// them, exact; < 0 otherwise (or for pairs too large to measure).
  double penetration_depth = -1;
  double interface_area = 0;  ///< of their GVD interface (2D: length); 0 when cells do not meet
  std::vector<ContactSite> sites;  ///< largest first
};

/// Options of grid() and Result::grid(): the options of `gvd grid` (`gvd grid --help`).
struct GridOptions {
  /// --resolution: cells along the longest side of the box (>= 1); the other sides get as many
  /// cells of the same size as cover them.
  int resolution = 256;
  std::string metric = "l2";    ///< --metric l2|l1|linf
  bool signed_distance = true;  ///< negative inside closed objects (false: --unsigned)
  /// --domain: the box as lo..., hi... (2 x dimension numbers, user units); it must hold every
  /// vertex. Empty: grid(): the scene's bounding box + 5 % of its longest side on every side;
  /// Result::grid(): the result's domain (a square / cube: resolution^D cells).
  std::vector<double> domain;
  int range_cells = 0;  ///< --range-cells (grid() only): cells per range side; 0 = default
  /// --max-cells: more cells are refused before any work (gvd::Error{kLimitExceeded}).
  uint64_t max_cells = uint64_t{1} << 27;
  int threads = 0;  ///< --threads: worker threads, 0 = all cores
  /// --backend auto|opencl|cpu (grid() only): where the per-range evaluation runs, chosen as
  /// compute() chooses it. Result::grid() samples on the CPU.
  std::string backend = "auto";
  /// Called from the computing thread with the stage ("grid") and the fraction done in
  /// [0, 1], within the stage. Optional.
  std::function<void(std::string_view stage, double fraction)> progress;
  /// When it becomes true, the computation stops within a fraction of a second and throws
  /// gvd::Error{kCancelled}. Optional; must outlive the call.
  const std::atomic<bool>* cancel = nullptr;
};

/// A uniform grid of cubic cells with, per cell centre, the nearest object and its distance.
/// Cell (i, j, k) spans origin + [i, i+1] x [j, j+1] x [k, k+1] times `cell`; arrays hold
/// one value per cell, x fastest: index (k * shape[1] + j) * shape[0] + i (numpy's C order
/// for an array of shape (nz, ny, nx) / (ny, nx)).
struct Grid {
  int dimension = 3;
  std::array<int, 3> shape{1, 1, 1};  ///< nx, ny, nz (nz = 1 in 2D)
  std::array<double, 3> origin{};     ///< the corner of cell (0, 0, 0) (z = 0 in 2D)
  double cell = 0;                    ///< edge length of a cell
  std::string metric;                 ///< "l2", "l1" or "linf"
  std::string units;  ///< the scene's length unit (Scene::units), "" when none declared
  /// Per cell: the metric distance from its centre to the nearest object; negative inside a
  /// closed object (with signed_distance); +inf for none.
  std::vector<double> distance;
  std::vector<Object> label;  ///< per cell: the nearest object (exact ties: the lower); kNone
  std::string backend;        ///< where it ran ("cpu", "opencl (...)", "cpu (sampled ...)")
  double seconds = 0;
};

/// A finished GVD and the queries on it. Cheap to copy (copies share the immutable result).
/// The query index is built at the first query (O(result size)), once.
class Result {
 public:
  int dimension() const;
  /// The scene's length unit (Scene::units()): every length of the result is in it; empty
  /// when the scene declared none.
  const std::string& units() const;
  /// Number of objects.
  int size() const;
  const std::string& label(Object object) const;
  /// The object with this label; gvd::Error{kNotFound} naming it otherwise.
  Object object(std::string_view label) const;

  /// The dual graph's edges, sorted by (a, b).
  std::vector<Edge> graph() const;
  /// Objects within `ring` >= 1 rings of `object`, sorted by (ring, object). Breadth-first.
  std::vector<Neighbor> neighbors(Object object, int ring = 1) const;
  std::vector<Neighbor> neighbors(std::string_view label, int ring = 1) const;
  /// Nearest object of every point (dimension() numbers each; gvd::Error{kInvalidArgument}
  /// when the length is not a multiple of it): exact (`gvd nearest`); `fast` = the octree
  /// leaf's answer where it is provably within 3/2 of the true distance, the paper's §4 rule
  /// alone away from objects (faster; the distance may exceed the true one). A point outside the
  /// domain gets kNone and NaN, not an error. Runs on `threads` threads (0 = all cores); O(log
  /// leaves) per point.
  NearestBatch nearest(std::span<const double> points, bool fast = false, int threads = 0) const;
  /// A path from `from` to `to` (dimension() numbers each) on the GVD; not found (with a
  /// reason) when one of them is inside an object or no passage is wide enough.
  /// gvd::Error{kOutsideDomain} when a point lies outside the domain.
  Path path(std::span<const double> from, std::span<const double> to,
            const PathOptions& options = {}) const;
  /// The boundary of the object's cell (empty arrays when it has none).
  Cell cell(Object object) const;
  Cell cell(std::string_view label) const;
  /// Displacements of an exploded view; `scale` <= 0 picks 1/4 of the mean object size.
  Explosion explode(std::string_view anchor, double scale = 0) const;
  /// Every pair of objects whose gap is below `max_gap` (>= 0, user units) and every pair
  /// that touches or intersects, sorted by (gap, a, b), with the sites of their interface
  /// below the bound (`gvd contacts`). The gaps are measured exactly from the simplices, not
  /// read off the GVD. gvd::Error{kInvalidArgument} for a negative or non-finite bound.
  std::vector<Contact> contacts(double max_gap) const;
  /// The uniform grid sampled exactly from this result (`gvd grid RESULT.gvd`; the same labels
  /// and distances as grid() on the scene over the same box): gvd::Error{kInvalidArgument} for
  /// a bad option, {kLimitExceeded} over max_cells, {kCancelled}. options.range_cells and
  /// options.backend do not apply.
  Grid grid(const GridOptions& options = {}) const;

  /// Writes the whole result (reloadable by load()), atomically; gvd::Error{kIo} on failure.
  void save(const std::string& path) const;
  /// The GVD as binary glTF (`gvd compute -o`: one node per object, EXT_mesh_features).
  void write_glb(const std::string& path) const;
  /// The GVD with float64 coordinates as JSON (`gvd compute --json`).
  void write_json(const std::string& path) const;
  /// The dual graph as JSON (`gvd compute --graph`; docs/FORMATS.md).
  void write_graph_json(const std::string& path) const;
  /// What `gvd info --json` prints: sizes, depth, leaves, timings, backend, warnings.
  std::string info_json() const;

  /// The core's result (internal, unstable: gvd/pipeline/pipeline.h).
  const result::GvdResult& internal() const;

 private:
  friend class Access;
  struct Impl;
  Result() = default;  ///< made by compute() and load()
  std::shared_ptr<const Impl> impl_;
};

/// Computes the GVD of a scene (the pipeline of `gvd compute`). Throws gvd::Error: the scene
/// is invalid (kInvalidScene, naming the object and index), an option is malformed
/// (kInvalidArgument), a limit is hit (kLimitExceeded), or options.cancel was set
/// (kCancelled).
Result compute(const Scene& scene, const ComputeOptions& options = {});

/// The uniform-grid discrete GVD of a scene (`gvd grid SCENE`: Sud et al. 2006's range
/// culling): per cell centre the exact nearest object and distance in the metric, signed
/// inside closed objects. Throws gvd::Error: an invalid scene (kInvalidScene), a bad option
/// (kInvalidArgument), more cells than options.max_cells (kLimitExceeded, before any work),
/// options.cancel set (kCancelled).
Grid grid(const Scene& scene, const GridOptions& options = {});

/// Loads a result written by Result::save or `gvd compute --save`.
Result load(const std::string& path);

}  // namespace gvd::api

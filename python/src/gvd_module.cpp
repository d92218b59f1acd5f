// The Python module gvd._gvd (re-exported by the package gvd): the facade gvd/gvd.h on numpy
// arrays. Scene.add reads (n, D) float64 arrays in place; every array returned owns the
// facade's vector (py_arrays.h); compute and the queries run without the GIL; gvd::Error
// becomes gvd.Error's subclass of its code (py_errors.h). docs/PYTHON.md is the user's guide.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "gvd/gvd.h"
#include "gvd/pipeline/parameters.h"
#include "py_arrays.h"
#include "py_compute.h"
#include "py_errors.h"

namespace gvd::python {

using namespace gvd::scene;
using namespace gvd::pipeline;

namespace {

using namespace pybind11::literals;

/// The named-tuple types of the answers (created in the module at import; kept alive by it).
struct Types {
  py::handle nearest, path, explosion, grid;
};
Types types;

/// gvd.Cell: the boundary of an object's cell. Iterates as (vertices, faces), so that
/// `V, F = r.cell("a")` works, and has .vertices/.faces like a trimesh mesh, so a cell can be
/// passed back to Scene.add or to trimesh.Trimesh(*cell).
struct PyCell {
  py::array vertices, faces, other, clearance;
};

std::string path_string(const py::handle& path) {
  return py::str(py::module_::import("os").attr("fspath")(path)).cast<std::string>();
}

PyScene load_scene(const py::handle& paths) {
  std::vector<std::string> files;
  if (py::isinstance<py::str>(paths) || py::hasattr(paths, "__fspath__")) {
    files.push_back(path_string(paths));
  } else {
    for (const py::handle& p : paths) files.push_back(path_string(p));
  }
  py::gil_scoped_release unlocked;
  return PyScene(api::Scene::load(files));
}

/// A labelled volume (numpy (ny, nx) or (nz, ny, nx) integers, x fastest) as a scene.
PyScene scene_from_labels(const py::array& labels, const py::object& spacing,
                          const py::object& origin, const py::object& background) {
  if (labels.ndim() != 2 && labels.ndim() != 3) {
    throw Error(ErrorCode::kInvalidArgument,
                "labels must be a 2D or 3D integer array, shape (ny, nx) or (nz, ny, nx)");
  }
  const char kind = labels.dtype().kind();
  if (kind != 'i' && kind != 'u') {
    throw Error(ErrorCode::kInvalidArgument, "labels must be integers, not dtype " +
                                                 py::str(labels.dtype()).cast<std::string>());
  }
  if (kind == 'i' && labels.attr("__lt__")(0).attr("any")().cast<bool>()) {
    throw Error(ErrorCode::kInvalidScene, "labels must not be negative");
  }
  const auto values =
      py::array_t<uint64_t, py::array::c_style | py::array::forcecast>::ensure(labels);
  std::vector<uint64_t> shape;  // x fastest: numpy's shape reversed
  for (py::ssize_t a = labels.ndim() - 1; a >= 0; --a)
    shape.push_back(static_cast<uint64_t>(labels.shape(a)));
  auto numbers = [](const py::object& o) {
    std::vector<double> out;
    if (!o.is_none())
      for (const py::handle& v : o) out.push_back(v.cast<double>());
    return out;
  };
  const std::vector<double> sp = numbers(spacing), org = numbers(origin);
  const int64_t bg = background.is_none() ? -1 : background.cast<int64_t>();
  const std::span<const uint64_t> data(values.data(), static_cast<size_t>(values.size()));
  py::gil_scoped_release unlocked;
  return PyScene(api::Scene::from_labels(data, shape, sp, org, bg));
}

/// An object given by label (str) or index (int).
api::Object object_arg(const api::Result& r, const py::handle& object) {
  if (py::isinstance<py::str>(object)) {
    const std::string label = object.cast<std::string>();
    return r.object(label);
  }
  if (PyIndex_Check(object.ptr())) return object.cast<api::Object>();
  throw Error(ErrorCode::kInvalidArgument, "an object is a label (str) or an index (int)");
}

int scene_add(PyScene& s, const std::string& label, const py::object& vertices,
              const py::object& faces) {
  const api::Object index = s.scene.size();
  try {
    if (s.computing > 0) {
      throw Error(ErrorCode::kInvalidArgument,
                  "the scene is being computed: add objects before or after compute()");
    }
    py::object v = vertices, f = faces;
    if (f.is_none()) {  // add(label, mesh): anything with .vertices and .faces (trimesh, ...)
      if (!py::hasattr(vertices, "vertices")) {
        throw Error(ErrorCode::kInvalidArgument,
                    "add(label, vertices, faces), or add(label, mesh) with a mesh that has "
                    ".vertices and .faces");
      }
      v = vertices.attr("vertices");
      for (const char* name : {"faces", "triangles", "segments", "simplices"}) {
        if (py::hasattr(vertices, name)) {
          f = vertices.attr(name);
          break;
        }
      }
      if (f.is_none()) {
        throw Error(ErrorCode::kInvalidArgument,
                    "the mesh has .vertices but no .faces (or .triangles, .segments)");
      }
    }
    const int dim = s.scene.dimension();
    const PointsIn points = points_in(v, dim, "the vertices");
    const SimplicesIn simplices = simplices_in(f, dim);
    return s.scene.add(label, points.span(), simplices.span);
  } catch (const Error& e) {
    throw error_for(e, {label, index});
  }
}

/// Points per slice of a batch nearest (a slice takes ~10-100 ms on 2 cores).
constexpr size_t kNearestSlice = 1 << 16;

py::object nearest(const api::Result& r, const py::handle& points, bool fast, int threads) {
  const int dim = r.dimension();
  const PointsIn in = points_in(points, dim, "the points");
  // In slices of kNearestSlice points, the GIL released for each: between slices Ctrl-C
  // (or a signal handler's exception) stops the batch and is raised.
  api::NearestBatch batch;
  const std::span<const double> all = in.span();
  const size_t d = static_cast<size_t>(dim);
  for (size_t first = 0; first < in.count; first += kNearestSlice) {
    const size_t count = std::min(kNearestSlice, in.count - first);
    api::NearestBatch part;
    {
      py::gil_scoped_release unlocked;
      part = r.nearest(all.subspan(first * d, count * d), fast, threads);
    }
    if (first == 0) {
      batch = std::move(part);
      batch.object.reserve(in.count);
      batch.distance.reserve(in.count);
      batch.closest.reserve(in.count * d);
      batch.inside.reserve(in.count);
      batch.signed_distance.reserve(in.count);
    } else {
      auto append = [](auto& to, const auto& from) {
        to.insert(to.end(), from.begin(), from.end());
      };
      append(batch.object, part.object);
      append(batch.distance, part.distance);
      append(batch.closest, part.closest);
      append(batch.inside, part.inside);
      append(batch.signed_distance, part.signed_distance);
    }
    if (first + count < in.count && PyErr_CheckSignals() != 0) throw py::error_already_set();
  }
  if (in.single) {
    const int8_t inside = batch.inside[0];
    return types.nearest(batch.object[0], batch.signed_distance[0],
                         to_numpy(std::move(batch.closest), {dim}),
                         inside < 0 ? py::object(py::none()) : py::object(py::bool_(inside == 1)));
  }
  const auto n = static_cast<py::ssize_t>(in.count);
  return types.nearest(
      to_numpy(std::move(batch.object), {n}), to_numpy(std::move(batch.signed_distance), {n}),
      to_numpy(std::move(batch.closest), {n, dim}), to_numpy(std::move(batch.inside), {n}));
}

py::object path(const api::Result& r, const py::handle& from, const py::handle& to,
                double min_clearance, bool by_clearance) {
  const int dim = r.dimension();
  const PointsIn a = points_in(from, dim, "the start point");
  const PointsIn b = points_in(to, dim, "the end point");
  if (!a.single || !b.single) {
    throw Error(ErrorCode::kInvalidArgument,
                "path() takes two points of " + std::to_string(dim) + " numbers each");
  }
  api::PathOptions options;
  options.min_clearance = min_clearance;
  options.by_clearance = by_clearance;
  api::Path p;
  {
    py::gil_scoped_release unlocked;
    p = r.path(a.span(), b.span(), options);
  }
  const auto k = static_cast<py::ssize_t>(p.points.size() / static_cast<size_t>(dim));
  return types.path(p.found, to_numpy(std::move(p.points), {k, dim}), p.length, p.min_clearance,
                    p.reason);
}

PyCell cell(const api::Result& r, const py::handle& object) {
  const api::Object o = object_arg(r, object);
  api::Cell c;
  {
    py::gil_scoped_release unlocked;
    c = r.cell(o);
  }
  const int dim = r.dimension();
  const auto nv = static_cast<py::ssize_t>(c.other.size());
  const auto ns = static_cast<py::ssize_t>(c.simplices.size() / static_cast<size_t>(dim));
  return PyCell{to_numpy(std::move(c.vertices), {nv, dim}),
                to_numpy(std::move(c.simplices), {ns, dim}), to_numpy(std::move(c.other), {nv}),
                to_numpy(std::move(c.clearance), {nv})};
}

py::object explode(const api::Result& r, const py::handle& anchor, double scale) {
  const api::Object o = object_arg(r, anchor);
  const std::string label = r.label(o);
  api::Explosion e;
  {
    py::gil_scoped_release unlocked;
    e = r.explode(label, scale);
  }
  const auto n = static_cast<py::ssize_t>(e.ring.size());
  return types.explosion(e.scale, to_numpy(std::move(e.ring), {n}),
                         to_numpy(std::move(e.displacement), {n, r.dimension()}),
                         to_numpy(std::move(e.factor), {n}));
}

/// The options gvd.grid and Result.grid share.
api::GridOptions grid_options(int resolution, const std::string& metric, bool signed_distance,
                              const std::optional<std::vector<double>>& domain, uint64_t max_cells,
                              int threads) {
  api::GridOptions o;
  o.resolution = resolution;
  o.metric = metric;
  o.signed_distance = signed_distance;
  if (domain) o.domain = *domain;
  o.max_cells = max_cells;
  o.threads = threads;
  return o;
}

/// An api::Grid as a gvd.Grid whose arrays have numpy's shape (ny, nx) / (nz, ny, nx) (x
/// fastest, as the facade lays them out) and own the facade's vectors: the labels and float64
/// distances are moved, not copied; float32 distances are converted once, without the GIL.
py::object grid_tuple(api::Grid&& g, bool float64) {
  std::vector<py::ssize_t> shape;
  if (g.dimension == 3) shape.push_back(g.shape[2]);
  shape.push_back(g.shape[1]);
  shape.push_back(g.shape[0]);
  py::array distance;
  if (float64) {
    distance = to_numpy(std::move(g.distance), shape);
  } else {
    std::vector<float> narrow;
    {
      py::gil_scoped_release unlocked;
      narrow.assign(g.distance.begin(), g.distance.end());
      std::vector<double>().swap(g.distance);  // the doubles go now, not with the grid
    }
    distance = to_numpy(std::move(narrow), shape);
  }
  py::array labels = to_numpy(std::move(g.label), shape);
  py::array_t<double> origin(g.dimension);
  for (int a = 0; a < g.dimension; ++a) origin.mutable_at(a) = g.origin[static_cast<size_t>(a)];
  py::object units = g.units.empty() ? py::object(py::none()) : py::object(py::str(g.units));
  return types.grid(distance, labels, origin, g.cell, g.metric, units, g.backend);
}

/// gvd.grid: the scene's uniform-grid GVD on a worker thread (run_in_python).
py::object scene_grid(const py::object& scene, int resolution, const std::string& metric,
                      bool signed_distance, bool float64,
                      const std::optional<std::vector<double>>& domain, int range_cells,
                      uint64_t max_cells, int threads, const std::string& backend,
                      const py::object& progress, CancelToken* token) {
  api::GridOptions o =
      grid_options(resolution, metric, signed_distance, domain, max_cells, threads);
  o.range_cells = range_cells;
  o.backend = backend;
  std::optional<PyScene> loaded;
  if (!py::isinstance<PyScene>(scene)) loaded.emplace(load_scene(scene));
  PyScene& s = loaded ? *loaded : scene.cast<PyScene&>();
  Reading reading(s);
  std::optional<api::Grid> g;
  run_in_python(
      [&](const std::atomic<bool>* cancel, const WorkProgress& report) {
        o.cancel = cancel;
        o.progress = report;
        g.emplace(api::grid(s.scene, o));
      },
      progress, token);
  return grid_tuple(std::move(*g), float64);
}

/// Result.grid: the grid sampled from the result on a worker thread (run_in_python).
py::object result_grid(const api::Result& r, int resolution, const std::string& metric,
                       bool signed_distance, bool float64,
                       const std::optional<std::vector<double>>& domain, uint64_t max_cells,
                       int threads, const py::object& progress, CancelToken* token) {
  api::GridOptions o =
      grid_options(resolution, metric, signed_distance, domain, max_cells, threads);
  std::optional<api::Grid> g;
  run_in_python(
      [&](const std::atomic<bool>* cancel, const WorkProgress& report) {
        o.cancel = cancel;
        o.progress = report;
        g.emplace(r.grid(o));
      },
      progress, token);
  return grid_tuple(std::move(*g), float64);
}

/// Contacts as a list of dicts (the keys of `gvd contacts`' JSON; points as (D,) arrays).
py::list contacts(const api::Result& r, double max_gap) {
  std::vector<api::Contact> found;
  {
    py::gil_scoped_release unlocked;
    found = r.contacts(max_gap);
  }
  const int dim = r.dimension();
  auto point = [dim](const std::array<double, 3>& p) {
    py::array_t<double> a(dim);
    for (int k = 0; k < dim; ++k) a.mutable_at(k) = p[static_cast<size_t>(k)];
    return a;
  };
  py::list out;
  for (const api::Contact& c : found) {
    py::list sites;
    for (const api::ContactSite& s : c.sites) {
      py::dict site;
      site["area"] = s.area;
      site["centroid"] = point(s.centroid);
      site["min_gap"] = s.min_gap;
      site["on_a"] = point(s.on_a);
      site["on_b"] = point(s.on_b);
      sites.append(site);
    }
    py::dict d;
    d["a"] = c.a;
    d["label_a"] = r.label(c.a);
    d["b"] = c.b;
    d["label_b"] = r.label(c.b);
    d["gap"] = c.gap;
    d["on_a"] = point(c.on_a);
    d["on_b"] = point(c.on_b);
    d["interference"] = c.interference;
    d["depth_lower_bound"] = c.depth_lower_bound < 0 ? py::object(py::none())
                                                     : py::object(py::float_(c.depth_lower_bound));
    d["penetration_depth"] = c.penetration_depth < 0 ? py::object(py::none())
                                                     : py::object(py::float_(c.penetration_depth));
    d["interface_area"] = c.interface_area;
    d["sites"] = sites;
    out.append(d);
  }
  return out;
}

/// A writer of the result to a path (str or os.PathLike), without the GIL.
template <void (api::Result::*write)(const std::string&) const>
void write_to(const api::Result& r, const py::handle& path) {
  const std::string p = path_string(path);
  py::gil_scoped_release unlocked;
  (r.*write)(p);
}

py::object make_namedtuple(py::module_& m, const char* name, std::vector<const char*> fields,
                           const char* doc) {
  py::list names;
  for (const char* f : fields) names.append(f);
  py::object type =
      py::module_::import("collections").attr("namedtuple")(name, names, "module"_a = "gvd");
  type.attr("__doc__") = doc;
  m.attr(name) = type;
  return type;
}

constexpr const char* kModuleDoc =
    R"doc(Generalized Voronoi diagrams of labelled 3D triangle meshes and 2D segment sets.

The engine of `gvd compute` in-process, on numpy arrays (docs/PYTHON.md)::

    import numpy as np, gvd
    scene = gvd.Scene(dimension=3)
    scene.add("a", vertices_a, triangles_a)   # (n, 3) float64, (m, 3) integers
    scene.add("b", mesh_b)                    # anything with .vertices and .faces
    r = gvd.compute(scene, threads=0, progress=True)
    r.graph                                   # dual-graph edges (numpy structured array)
    r.neighbors("a", ring=2)
    near = r.nearest(points)                  # near.object, near.distance, near.closest
    r.path(p, q, min_clearance=0.01)
    V, F = r.cell("a")
    r.save("r.gvd"); gvd.load("r.gvd"); r.write_glb("gvd.glb")

Objects are numbered in the order of Scene.add (0, 1, ...); -1 means no object. Errors are
gvd.Error, one subclass per code (gvd.InvalidScene, gvd.NotFound, ...).)doc";

constexpr const char* kComputeDoc =
    R"doc(The GVD of a scene: the pipeline of `gvd compute`, with the same options and defaults.

scene     a gvd.Scene, or a scene file path (str / os.PathLike: scene JSON, OBJ, GLB/glTF) or a
          list of mesh file paths (PLY/STL/OFF/OBJ, one object each, labelled by file stem)
progress  None; True for a text bar on sys.stderr; or a callable(stage: str, fraction: float)
          called on the calling thread with the stages "scene", "octree", "distance",
          "ambiguity", "surface", "graph", ("compact",) "done". An exception it raises stops
          the computation and propagates.
cancel    a gvd.CancelToken: token.cancel() (from another thread or the callback) stops the
          computation, which raises gvd.Cancelled.

The options (the flags of `gvd compute`; units are the scene's):
  max_depth         deepest octree level; 0 = default (2D 26, 3D 21)
  domain            the domain box as [lo..., hi...] (2*D numbers), made a cube; None = the
                    scene's bounding box + 5 % of its side on every side
  frame             'auto' | 'world': the octree's axes (3D)
  threads           worker threads, 0 = all cores
  backend           'auto' | 'opencl' | 'cpu' (auto: OpenCL when a device with fp64 exists)
  octree_build      'levels' | 'data-parallel'
  distance          'exact' | 'wavefront'
  refine            'certified' | 'paper'
  junctions         'on' | 'off': junction cells (3D), where three or more objects meet along
                    a straight line (on by default: see docs/ALGORITHM.md)
  resolution        'compact' | 'full'
  curved_tolerance  in [0, 1)
  contact_depth     0 = default (2D 14, 3D 8)
  max_leaves, max_objects, max_simplices   limits (gvd.LimitExceeded when hit)
  ambiguity_levels, ambiguity_rounds, unseen_rounds   < 0 = default

The computation runs on its own threads without the GIL: other Python threads keep running,
and Ctrl-C stops it within milliseconds (the call then raises KeyboardInterrupt).
Raises gvd.InvalidScene (naming label, object, element and index), gvd.InvalidArgument,
gvd.LimitExceeded, gvd.Cancelled, gvd.NotFound / gvd.IoError (files).)doc";

}  // namespace

void define_module(py::module_& m) {
  m.doc() = kModuleDoc;
  m.attr("__version__") = std::string(api::version());
  register_errors(m);

  types.nearest =
      make_namedtuple(m, "Nearest", {"object", "distance", "closest", "inside"},
                      "Nearest objects of points (Result.nearest), one entry per point:\n"
                      "  object    int32 (n,): the object's index, -1 for a point outside the "
                      "domain\n"
                      "  distance  float64 (n,): distance to `closest` (never below the true "
                      "one, within 3/2 of it), negative inside a closed object (the CLI's "
                      "signed_distance; abs() is its distance); NaN when none\n"
                      "  closest   float64 (n, D): the point on the object (NaN when none)\n"
                      "  inside    int8 (n,): 1 inside the (closed) object, 0 outside, -1 when "
                      "the object is open (it has no inside) or there is none; for one point "
                      "True, False or None\n"
                      "Fields may be added in later versions: read them by name.")
          .inc_ref();
  types.path =
      make_namedtuple(m, "Path", {"found", "points", "length", "min_clearance", "reason"},
                      "A path on the GVD (Result.path): found (bool), points (k, D) float64 from "
                      "start to end, length, min_clearance (exact least distance to the objects), "
                      "reason (why there is none when not found).")
          .inc_ref();
  types.explosion =
      make_namedtuple(m, "Explosion", {"scale", "ring", "displacement", "factor"},
                      "An exploded view (Result.explode): scale (displacement per ring), ring "
                      "int32 (n,) per object (0 = anchor, -1 = unreachable), displacement "
                      "float64 (n, D) per object, factor float64 (n,): the share of scale x ring x "
                      "direction kept so that no two objects collide while they move.")
          .inc_ref();

  types.grid =
      make_namedtuple(
          m, "Grid", {"distance", "labels", "origin", "cell", "metric", "units", "backend"},
          "A uniform grid (gvd.grid, Result.grid): per cell centre the nearest object and the "
          "distance to it. Arrays of shape (ny, nx) in 2D, (nz, ny, nx) in 3D (x fastest: "
          "distance[k, j, i] is cell (i, j, k)):\n"
          "  distance  float32 (float64 with float64=True): the metric distance from the cell "
          "centre to the nearest object, negative inside a closed object (signed=True); inf "
          "when there is none\n"
          "  labels    int32: the nearest object's index (exact ties: the lower), -1 for none\n"
          "  origin    float64 (D,): the corner of cell 0; cell (i, j, k) spans origin + "
          "[i, i+1] x [j, j+1] x [k, k+1] times cell, its centre origin + (i+0.5, j+0.5, "
          "k+0.5) * cell\n"
          "  cell      float: the cells' edge length\n"
          "  metric    'l2', 'l1' or 'linf'\n"
          "  units     the scene's length unit ('mm', ...) of distance, origin and cell; None "
          "when it declared none\n"
          "  backend   where it ran ('cpu', 'opencl (...)', 'cpu (sampled from the adaptive "
          "result)')\n"
          "Fields may be added in later versions: read them by name.")
          .inc_ref();

  py::class_<CancelToken>(m, "CancelToken",
                          "A flag that stops a running gvd.compute(..., cancel=token): call "
                          "cancel() from another thread or a progress callback.")
      .def(py::init<>())
      .def("cancel", &CancelToken::cancel, "Asks the computation to stop (gvd.Cancelled).")
      .def("reset", &CancelToken::reset, "Clears the flag, to reuse the token.")
      .def_property_readonly("cancelled", &CancelToken::cancelled);

  py::class_<PyScene>(m, "Scene",
                      "Labelled objects: 3D triangle meshes or 2D segment sets (polygon soups; "
                      "open, non-manifold and several-component meshes are accepted).")
      .def(py::init<int>(), "dimension"_a = 3, "An empty scene of dimension 2 or 3.")
      .def_static("load", &load_scene, "paths"_a,
                  "Reads scene files as `gvd compute` does: one scene JSON, OBJ (o/g groups = "
                  "objects) or GLB/glTF (nodes = objects), or a list of PLY/STL/OFF/OBJ files, "
                  "one object each, labelled by file stem.")
      .def_static("from_labels", &scene_from_labels, "labels"_a, "spacing"_a = py::none(),
                  "origin"_a = py::none(), "background"_a = 0,
                  R"doc(from_labels(labels, spacing=None, origin=None, background=0) -> Scene

A labelled voxel volume (a segmentation) as a scene, as `gvd compute --volume` reads it:
labels  an integer array of shape (ny, nx) or (nz, ny, nx), x fastest (numpy's C order; the
        layout `gvd grid --labels` writes), no negative values
spacing the voxel size along x, y(, z) (default 1 each; anisotropic voxels are honoured)
origin  the lower corner of voxel (0, 0, 0), x, y(, z) (default 0)
background the label that is no object (default 0; None: every label is an object)
Every other label becomes an object "label_<id>" (in increasing id), bounded by the voxel
faces it shares with other labels, the background or the outside of the volume.)doc")
      .def("add", &scene_add, "label"_a, "vertices"_a, "faces"_a = py::none(),
           R"doc(add(label, vertices, faces) or add(label, mesh) -> int

Adds an object and returns its index (0, 1, ... in the order of add).
vertices  (n, D) numbers in the scene's units; a C-contiguous float64 array is read in place,
          anything else (float32, Fortran order, lists) is converted
faces     (m, D) vertex indices (0-based) per triangle (3D) or segment (2D); uint32 or int32
          C-contiguous arrays are read in place, other integer types converted
mesh      any object with .vertices and .faces (or .triangles / .segments): a trimesh.Trimesh,
          a gvd.Cell, Open3D's legacy mesh after np.asarray, ...
The facade copies both into the scene. Raises gvd.InvalidArgument (shape, dtype),
gvd.InvalidScene (empty or duplicate label, a negative index; indices and coordinates are
checked by compute(), which names the label, object, element and index).)doc")
      .def_property_readonly("dimension", [](const PyScene& s) { return s.scene.dimension(); })
      .def_property(
          "units",
          [](const PyScene& s) -> std::optional<std::string> {
            if (s.scene.units().empty()) return std::nullopt;
            return s.scene.units();
          },
          [](PyScene& s, const std::optional<std::string>& units) {
            s.scene.set_units(units.value_or(""));
          },
          "The length unit of the coordinates ('mm', 'µm', ...; None: none declared): a scene "
          "JSON's \"units\", or set here (nm, um/µm, mm, cm, m, km, in, ft, Å; others raise "
          "gvd.InvalidArgument). A label only: nothing is scaled; the result reports it.")
      .def("__len__", [](const PyScene& s) { return s.scene.size(); })
      .def_property_readonly(
          "labels",
          [](const PyScene& s) {
            py::list out;
            for (int i = 0; i < s.scene.size(); ++i) out.append(s.scene.label(i));
            return py::tuple(out);
          },
          "The objects' labels, in the order of add.")
      .def("__repr__", [](const PyScene& s) {
        return "<gvd.Scene " + std::to_string(s.scene.dimension()) + "D, " +
               std::to_string(s.scene.size()) + " objects>";
      });

  py::class_<PyCell>(m, "Cell",
                     "The boundary of one object's Voronoi cell (Result.cell). Unpacks as "
                     "V, F = cell.\n"
                     "  vertices   float64 (n, D)\n"
                     "  faces      uint32 (m, D): triangles (3D; normals point into the cell) "
                     "or segments (2D; the cell on their left)\n"
                     "  other      int32 (n,): per vertex, the object across (-1 = domain box)\n"
                     "  clearance  float64 (n,): per vertex, distance to the nearest object")
      .def_readonly("vertices", &PyCell::vertices)
      .def_readonly("faces", &PyCell::faces)
      .def_readonly("other", &PyCell::other)
      .def_readonly("clearance", &PyCell::clearance)
      .def("__len__", [](const PyCell&) { return 2; })
      .def("__iter__",
           [](const PyCell& c) { return py::iter(py::make_tuple(c.vertices, c.faces)); })
      .def("__getitem__",
           [](const PyCell& c, int i) -> py::array {
             if (i == 0 || i == -2) return c.vertices;
             if (i == 1 || i == -1) return c.faces;
             throw py::index_error("a cell unpacks as (vertices, faces)");
           })
      .def("__repr__", [](const PyCell& c) {
        return "<gvd.Cell " + std::to_string(c.vertices.shape(0)) + " vertices, " +
               std::to_string(c.faces.shape(0)) + " faces>";
      });

  py::class_<api::Result>(m, "Result",
                          "A finished GVD and the queries on it (gvd.compute, gvd.load). "
                          "Immutable; its queries are thread-safe and run without the GIL.")
      .def_property_readonly("dimension", &api::Result::dimension)
      .def_property_readonly(
          "units",
          [](const api::Result& r) -> std::optional<std::string> {
            if (r.units().empty()) return std::nullopt;
            return r.units();
          },
          "The scene's length unit ('mm', ...), in which every length of the result is; None "
          "when the scene declared none.")
      .def("__len__", &api::Result::size, "Number of objects.")
      .def_property_readonly(
          "labels",
          [](const api::Result& r) {
            py::list out;
            for (int i = 0; i < r.size(); ++i) out.append(r.label(i));
            return py::tuple(out);
          },
          "The objects' labels, by index: r.labels[i].")
      .def(
          "object", [](const api::Result& r, const std::string& label) { return r.object(label); },
          "label"_a, "The index of the object with this label (gvd.NotFound otherwise).")
      .def_property_readonly(
          "graph",
          [](const api::Result& r) { return struct_array(r.graph(), edge_dtype(r.dimension())); },
          "The dual graph's edges (`gvd compute --graph`), sorted by (a, b), as a numpy "
          "structured array with fields a, b (int32 object indices, a < b), area (interface "
          "area, length in 2D), min_clearance, tightest_point (D,), gap (exact least distance "
          "between a and b; < 0: not measured), touching (bool). Labels: r.labels[e['a']]. "
          "As dicts: [dict(zip(g.dtype.names, row)) for row in g.tolist()].")
      .def(
          "neighbors",
          [](const api::Result& r, const py::handle& object, int ring) {
            const api::Object o = object_arg(r, object);
            std::vector<api::Neighbor> n;
            {
              py::gil_scoped_release unlocked;
              n = r.neighbors(o, ring);
            }
            return struct_array(std::move(n), neighbor_dtype());
          },
          "object"_a, "ring"_a = 1,
          "Objects within `ring` >= 1 rings of `object` (label or index) in the dual graph, "
          "sorted by (ring, object) (`gvd neighbors`): a structured array with fields object, "
          "ring, via (the ring - 1 neighbour it is reached from), area, min_clearance, gap, "
          "touching (of the edge via-object).")
      .def("nearest", &nearest, "points"_a, "fast"_a = false, "threads"_a = 0,
           R"doc(nearest(points, fast=False, threads=0) -> gvd.Nearest

Nearest object of every point (`gvd nearest`), vectorised: `points` is an (n, D) array (read in
place when C-contiguous float64) or one point (D,) (then the fields are scalars and a (D,)
array). Returns gvd.Nearest(object, distance, closest, inside): object int32 (n,) (-1 for a
point outside the domain or not finite, with NaN distance and closest), distance float64 (n,),
negative inside a closed object (signed; abs() is the CLI's distance), closest float64 (n, D),
the point on the object, inside int8 (n,): 1 inside, 0 outside, -1 for an open object (no
inside; exact ray parity for closed ones). Exact; fast=True keeps the octree leaf's answer
where it is provably within 3/2 of the true distance and uses the paper's rule alone away from
objects (faster; the distance may exceed the true one).
Runs on `threads` threads (0 = all cores) without the GIL, in slices of 65536 points:
Ctrl-C between slices raises KeyboardInterrupt. Read the fields by name: later versions may
add fields.)doc")
      .def("path", &path, "a"_a, "b"_a, py::kw_only(), "min_clearance"_a = 0.0,
           "by_clearance"_a = false,
           "A path on the GVD from point a to point b (`gvd path`) that crosses no object: "
           "gvd.Path(found, points (k, D), length, min_clearance, reason). Passages narrower "
           "than min_clearance are not used; by_clearance=True prefers wide passages. Not found "
           "(with a reason) when a point is inside an object or no passage is wide enough; "
           "gvd.OutsideDomain when a point is outside the domain.")
      .def("cell", &cell, "object"_a,
           "The boundary of the object's (label or index) Voronoi cell as a gvd.Cell: "
           "V, F = r.cell('a'), plus .other and .clearance per vertex.")
      .def("explode", &explode, "anchor"_a, "scale"_a = 0.0,
           "Displacements of an exploded view around `anchor` (`gvd explode`): gvd.Explosion("
           "scale, ring, displacement); scale <= 0 picks 1/4 of the mean object size.")
      .def("contacts", &contacts, "max_gap"_a,
           "Every pair of objects whose gap is below max_gap, and every pair that touches or "
           "intersects, sorted by gap (`gvd contacts`): a list of dicts with a, label_a, b, "
           "label_b, gap (exact, from the meshes), on_a, on_b (closest points), interference, "
           "depth_lower_bound (None unless computable), penetration_depth (exact where both "
           "objects are convex, else None), interface_area (of the GVD between "
           "them) and sites (connected regions of that interface below the bound: area, "
           "centroid, min_gap, on_a, on_b).")
      .def(
          "grid", &result_grid, "resolution"_a = 256, py::kw_only(), "metric"_a = "l2",
          "signed"_a = true, "float64"_a = false, "domain"_a = py::none(),
          "max_cells"_a = api::GridOptions{}.max_cells, "threads"_a = 0, "progress"_a = py::none(),
          "cancel"_a = static_cast<CancelToken*>(nullptr),
          R"doc(grid(resolution=256, *, metric='l2', signed=True, float64=False, domain=None, max_cells=2**27, threads=0, progress=None, cancel=None) -> gvd.Grid

The uniform grid sampled exactly from this result (`gvd grid RESULT.gvd`): per cell centre the
nearest object and its distance in the metric, not interpolated: the same labels and distances
as gvd.grid(scene) over the same box. The box is the result's domain (a square / cube:
resolution**D cells) unless domain=[lo..., hi...] gives one (it must hold every vertex).
metric 'l2' | 'l1' | 'linf'; signed=False: no negative distances inside closed objects;
float64=True: distance as float64 (the computed array itself) instead of float32; max_cells:
more cells raise gvd.LimitExceeded before any work. Runs on `threads` threads (0 = all
cores) without the GIL; progress and cancel as for gvd.compute (the stage "grid"); Ctrl-C
stops it within a fraction of a second (KeyboardInterrupt).)doc")
      .def("save", &write_to<&api::Result::save>, "path"_a,
           "Writes the whole result, reloadable by gvd.load (`gvd compute --save`).")
      .def("write_glb", &write_to<&api::Result::write_glb>, "path"_a,
           "The GVD as binary glTF (`gvd compute -o`: one node per object).")
      .def("write_json", &write_to<&api::Result::write_json>, "path"_a,
           "The GVD with float64 coordinates as JSON (`gvd compute --json`).")
      .def("write_graph_json", &write_to<&api::Result::write_graph_json>, "path"_a,
           "The dual graph as JSON (`gvd compute --graph`).")
      .def("info_json", &api::Result::info_json,
           "What `gvd info --json` prints: sizes, depth, leaves, timings, backend, warnings.")
      .def_property_readonly(
          "info",
          [](const api::Result& r) {
            return py::module_::import("json").attr("loads")(r.info_json());
          },
          "info_json() as a dict.")
      .def("__repr__", [](const api::Result& r) {
        return "<gvd.Result " + std::to_string(r.dimension()) + "D, " + std::to_string(r.size()) +
               " objects, " + std::to_string(r.graph().size()) + " dual-graph edges>";
      });

  const api::ComputeOptions d;
  m.def(
      "compute",
      [](const py::object& scene, const py::object& progress, CancelToken* cancel, int max_depth,
         std::optional<std::vector<double>> domain, std::string frame, int threads,
         std::string backend, std::string octree_build, std::string distance, std::string refine,
         std::string junctions, std::string resolution, double curved_tolerance, int contact_depth,
         uint64_t max_leaves, uint64_t max_objects, uint64_t max_simplices, int ambiguity_levels,
         int ambiguity_rounds, int unseen_rounds) {
        api::ComputeOptions o;
        o.max_depth = max_depth;
        if (domain) o.domain = std::move(*domain);
        o.frame = std::move(frame);
        o.threads = threads;
        o.backend = std::move(backend);
        o.octree_build = std::move(octree_build);
        o.distance = std::move(distance);
        o.refine = std::move(refine);
        o.junctions = std::move(junctions);
        o.resolution = std::move(resolution);
        o.curved_tolerance = curved_tolerance;
        o.contact_depth = contact_depth;
        o.max_leaves = max_leaves;
        o.max_objects = max_objects;
        o.max_simplices = max_simplices;
        o.ambiguity_levels = ambiguity_levels;
        o.ambiguity_rounds = ambiguity_rounds;
        o.unseen_rounds = unseen_rounds;
        if (py::isinstance<PyScene>(scene)) {
          return compute_in_python(scene.cast<PyScene&>(), std::move(o), progress, cancel);
        }
        PyScene loaded = load_scene(scene);
        return compute_in_python(loaded, std::move(o), progress, cancel);
      },
      "scene"_a, py::kw_only(), "progress"_a = py::none(),
      "cancel"_a = static_cast<CancelToken*>(nullptr), "max_depth"_a = d.max_depth,
      "domain"_a = py::none(), "frame"_a = d.frame, "threads"_a = d.threads,
      "backend"_a = d.backend, "octree_build"_a = d.octree_build, "distance"_a = d.distance,
      "refine"_a = d.refine, "junctions"_a = d.junctions, "resolution"_a = d.resolution,
      "curved_tolerance"_a = d.curved_tolerance, "contact_depth"_a = d.contact_depth,
      "max_leaves"_a = d.max_leaves, "max_objects"_a = d.max_objects,
      "max_simplices"_a = d.max_simplices, "ambiguity_levels"_a = d.ambiguity_levels,
      "ambiguity_rounds"_a = d.ambiguity_rounds, "unseen_rounds"_a = d.unseen_rounds, kComputeDoc);

  m.def(
      "grid", &scene_grid, "scene"_a, "resolution"_a = 256, py::kw_only(), "metric"_a = "l2",
      "signed"_a = true, "float64"_a = false, "domain"_a = py::none(), "range_cells"_a = 0,
      "max_cells"_a = api::GridOptions{}.max_cells, "threads"_a = 0, "backend"_a = "auto",
      "progress"_a = py::none(), "cancel"_a = static_cast<CancelToken*>(nullptr),
      R"doc(grid(scene, resolution=256, *, metric='l2', signed=True, float64=False, domain=None, range_cells=0, max_cells=2**27, threads=0, backend='auto', progress=None, cancel=None) -> gvd.Grid

The uniform-grid discrete GVD of a scene (`gvd grid SCENE`; Sud et al. 2006's range culling):
for every cell centre the exact nearest object (labels, int32, -1 for none) and the distance to
it in the metric, negative inside closed objects (an ESDF). Arrays of shape (ny, nx) / (nz, ny,
nx), x fastest (gvd.Grid says how cells map to coordinates).

scene       a gvd.Scene, or scene file path(s) as for gvd.compute
resolution  cells along the longest side of the box; the other sides get as many cells of the
            same size as cover them
metric      'l2' | 'l1' | 'linf'
signed      False: distances are not negated inside closed objects
float64     distance as float64 (the computed array itself, no copy) instead of float32
domain      the box [lo..., hi...] (2*D numbers; it must hold every vertex); None = the scene's
            bounding box + 5 % of its longest side on every side
range_cells cells per side of a culling range; 0 = default (2D 8, 3D 4)
max_cells   more cells raise gvd.LimitExceeded before any work
threads     worker threads, 0 = all cores
backend     'auto' | 'opencl' | 'cpu': where the per-range evaluation runs
progress, cancel   as for gvd.compute (the stage "grid", its fraction advancing within it)

Runs without the GIL; Ctrl-C or cancel stops it within a fraction of a second. Raises
gvd.InvalidScene, gvd.InvalidArgument, gvd.LimitExceeded, gvd.Cancelled.)doc");

  m.def(
      "_parameters",
      [](const std::string& function) {
        const unsigned surface = function == "compute"       ? unsigned{kPythonKeyword}
                                 : function == "grid"        ? unsigned{kPythonGrid}
                                 : function == "Result.grid" ? unsigned{kPythonResultGrid}
                                                             : 0u;
        if (surface == 0) {
          throw Error(ErrorCode::kInvalidArgument,
                      "_parameters takes compute, grid or Result.grid, not " + function);
        }
        py::list out;
        for (const ParamSpec& p : pipeline_parameters()) {
          if ((p.surfaces & surface) == 0) continue;
          py::dict entry;
          entry["name"] = std::string(p.keyword.empty() ? p.name : p.keyword);
          py::list choices;
          for (const std::string_view c : p.choices) choices.append(std::string(c));
          entry["choices"] = choices;
          const double value = std::isnan(p.keyword_value) ? p.value : p.keyword_value;
          switch (p.kind) {
            case ParamKind::kInt:
              entry["default"] = static_cast<int>(value);
              break;
            case ParamKind::kCount:
            case ParamKind::kLabel:
              entry["default"] = static_cast<uint64_t>(value);
              break;
            case ParamKind::kNumber:
              entry["default"] = value;
              break;
            case ParamKind::kFlag:
              entry["default"] = (value != 0) != p.keyword_negated;
              break;
            case ParamKind::kChoice:
              entry["default"] = std::string(p.choices.front());
              break;
            case ParamKind::kBox:
            case ParamKind::kUnits:
            case ParamKind::kSpacing:
              entry["default"] = py::none();
              break;
          }
          out.append(entry);
        }
        return out;
      },
      "function"_a = "compute",
      "The keywords of compute(), grid() or Result.grid() (function='compute', 'grid', "
      "'Result.grid') in the parameter table (gvd/pipeline/parameters.h): a list of {name, "
      "default, choices}; the tests check the signatures against it.");

  m.def(
      "load",
      [](const py::handle& path) {
        const std::string p = path_string(path);
        py::gil_scoped_release unlocked;
        return api::load(p);
      },
      "path"_a, "Loads a result written by Result.save or `gvd compute --save`.");
}

}  // namespace gvd::python

PYBIND11_MODULE(_gvd, m) { gvd::python::define_module(m); }

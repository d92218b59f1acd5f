// The facade of gvd/gvd.h: arrays in and out around the core's calls (compute_gvd, GvdIndex,
// save_result/load_result, the writers). No geometry here.

#include "gvd/gvd.h"

#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <tuple>
#include <unordered_set>
#include <utility>

#include "gvd/common/parallel.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/grid/compute_grid.h"
#include "gvd/grid/sample_result_grid.h"
#include "gvd/io/result_file.h"
#include "gvd/io/write_outputs.h"
#include "gvd/kernels/opencl_backend.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/query/contact_report.h"
#include "gvd/query/gvd_index.h"
#include "gvd/scene/label_volume.h"
#include "gvd/scene/load_scene.h"
#include "gvd/scene/units.h"

namespace gvd::api {

using namespace gvd::scene;
using namespace gvd::distance;
using namespace gvd::surface;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::query;
using namespace gvd::grid;
using namespace gvd::io;
using namespace gvd::pipeline;

struct Scene::Impl {
  gvd::scene::Scene scene;
  std::unordered_set<std::string> labels;
};

struct Result::Impl {
  std::shared_ptr<const GvdResult> result;
  mutable std::once_flag index_once;
  mutable std::unique_ptr<GvdIndex> index_storage;

  /// The query index, built at the first query (thread-safe).
  const GvdIndex& index() const {
    std::call_once(index_once, [&] { index_storage = std::make_unique<GvdIndex>(result); });
    return *index_storage;
  }
};

/// Builds and opens the pimpls (friend of Scene and Result).
class Access {
 public:
  static const gvd::scene::Scene& scene(const Scene& s) { return s.impl_->scene; }
  static Scene make_scene(gvd::scene::Scene scene) {
    Scene out(scene.dimension);
    for (const SceneObject& o : scene.objects) out.impl_->labels.insert(o.label);
    out.impl_->scene = std::move(scene);
    return out;
  }
  static Result make_result(GvdResult result) {
    auto impl = std::make_shared<Result::Impl>();
    impl->result = std::make_shared<const GvdResult>(std::move(result));
    Result out;
    out.impl_ = std::move(impl);
    return out;
  }
  static const Result::Impl& impl(const Result& r) { return *r.impl_; }
};

namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

void check_multiple(size_t size, int dimension, const char* what) {
  if (size % static_cast<size_t>(dimension) != 0) {
    throw Error(ErrorCode::kInvalidArgument, std::string(what) + " has " + std::to_string(size) +
                                                 " numbers, not a multiple of the dimension " +
                                                 std::to_string(dimension));
  }
}

Vec3 point_of(std::span<const double> p, int dimension, const char* what) {
  if (p.size() != static_cast<size_t>(dimension)) {
    throw Error(ErrorCode::kInvalidArgument, std::string(what) + " needs " +
                                                 std::to_string(dimension) + " numbers, got " +
                                                 std::to_string(p.size()));
  }
  return {p[0], p[1], dimension == 3 ? p[2] : 0.0};
}

void append(std::vector<double>& out, Vec3 p, int dimension) {
  for (int a = 0; a < dimension; ++a) out.push_back(p[a]);
}

Object object_of(ObjectId id) { return id == kNoObject ? kNone : static_cast<Object>(id); }

ObjectId checked_object(const GvdResult& r, Object object) {
  if (object < 0 || static_cast<size_t>(object) >= r.scene.objects.size()) {
    throw Error(ErrorCode::kNotFound, "no object with index " + std::to_string(object),
                {.object = static_cast<int64_t>(object)});
  }
  return static_cast<ObjectId>(object);
}

/// The facade's grid of the core's (arrays moved, not copied).
Grid grid_of(DistanceGrid&& g) {
  Grid out;
  out.dimension = g.spec.dimension;
  out.shape = g.spec.n;
  out.origin = {g.spec.origin.x, g.spec.origin.y, g.spec.origin.z};
  out.cell = g.spec.h;
  out.metric = grid_metric_name(g.metric);
  out.units = std::move(g.units);
  out.distance = std::move(g.distance);
  out.label = std::move(g.label);
  out.backend = g.stats.backend;
  out.seconds = g.stats.seconds;
  return out;
}

/// The options of grid() and Result::grid() through the parameter table
/// (gvd/pipeline/parameters.h), as compute() reads its own: its ranges, choices and checks
/// across parameters for a scene of `dimension`, named as the keywords are.
PipelineParams grid_params(const GridOptions& options, int dimension) {
  PipelineParams params;
  params.mode = ComputeMode::kGrid;
  // As text, so that 0 is out of range here rather than "not given".
  params.set("resolution", std::to_string(options.resolution), ParamSpelling::kApi,
             kPythonGrid | kPythonResultGrid);
  params.metric = parse_choice<GridMetric>(options.metric);
  params.unsigned_distance = !options.signed_distance;
  params.domain = options.domain;
  params.range_cells = options.range_cells;
  params.max_cells = options.max_cells;
  params.threads = options.threads;
  params.check_ranges(ParamSpelling::kApi);
  params.check(dimension, ParamSpelling::kApi);
  return params;
}

/// One backend per request ("auto", "opencl", "cpu") for the whole process: OpenCL is
/// initialised once, before concurrent use (PoCL crashes when several threads make the
/// first OpenCL calls at once), and its programs are built once.
kernels::BackendChoice backend_for(const std::string& requested) {
  static std::mutex mutex;
  static std::map<std::string, kernels::BackendChoice>* const chosen =
      new std::map<std::string, kernels::BackendChoice>;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = chosen->find(requested);
  if (it == chosen->end())
    it = chosen->emplace(requested, kernels::choose_backend(requested)).first;
  return it->second;
}

}  // namespace

std::string_view version() { return GVD_VERSION; }

// ---- Scene ----------------------------------------------------------------------------------

Scene::Scene(int dimension) : impl_(std::make_unique<Impl>()) {
  if (dimension != 2 && dimension != 3) {
    throw Error(ErrorCode::kInvalidArgument,
                "the dimension must be 2 or 3, not " + std::to_string(dimension));
  }
  impl_->scene.dimension = dimension;
}
Scene::~Scene() = default;
Scene::Scene(const Scene& other) : impl_(std::make_unique<Impl>(*other.impl_)) {}
Scene& Scene::operator=(const Scene& other) {
  if (this != &other) impl_ = std::make_unique<Impl>(*other.impl_);
  return *this;
}
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

Scene Scene::load(std::span<const std::string> paths) {
  return Access::make_scene(load_scene(paths));
}

Scene Scene::load(const std::string& path) { return load(std::span<const std::string>(&path, 1)); }

Scene Scene::from_labels(std::span<const uint64_t> labels, std::span<const uint64_t> shape,
                         std::span<const double> spacing, std::span<const double> origin,
                         int64_t background) {
  if (shape.size() != 2 && shape.size() != 3) {
    throw Error(ErrorCode::kInvalidArgument, "a label volume has 2 or 3 dimensions");
  }
  LabelVolume volume;
  volume.dimension = static_cast<int>(shape.size());
  uint64_t count = 1;
  for (size_t a = 0; a < shape.size(); ++a) {
    volume.size[a] = shape[a];
    count *= shape[a];
  }
  if (count != labels.size() || count == 0) {
    throw Error(ErrorCode::kInvalidArgument, "the labels hold " + std::to_string(labels.size()) +
                                                 " values, not the shape's " +
                                                 std::to_string(count));
  }
  LabelVolumeOptions options;
  for (auto [values, into, what] : {std::tuple{spacing, &options.spacing, "spacing"},
                                    std::tuple{origin, &options.origin, "origin"}}) {
    if (values.empty()) continue;
    if (values.size() != shape.size()) {
      throw Error(ErrorCode::kInvalidArgument, std::string("the ") + what + " needs " +
                                                   std::to_string(shape.size()) + " numbers");
    }
    for (size_t a = 0; a < values.size(); ++a) (*into)[a] = values[a];
  }
  if (background < 0) {
    options.background.reset();
  } else {
    options.background = static_cast<uint64_t>(background);
  }
  volume.labels.assign(labels.begin(), labels.end());
  return Access::make_scene(scene_from_label_volume(volume, options));
}

Object Scene::add(std::string label, std::span<const double> vertices,
                  std::span<const uint32_t> simplices) {
  const int dim = impl_->scene.dimension;
  if (label.empty()) {
    throw Error(ErrorCode::kInvalidScene,
                "object " + std::to_string(size()) + " has an empty label");
  }
  if (impl_->labels.count(label) > 0) {
    throw Error(ErrorCode::kInvalidScene, "duplicate label '" + label + "'");
  }
  check_multiple(vertices.size(), dim, ("the vertices of '" + label + "'").c_str());
  check_multiple(simplices.size(), dim, ("the simplices of '" + label + "'").c_str());
  SceneObject object;
  object.label = label;
  object.vertices.reserve(vertices.size() / dim);
  for (size_t i = 0; i < vertices.size(); i += dim) {
    object.vertices.push_back({vertices[i], vertices[i + 1], dim == 3 ? vertices[i + 2] : 0.0});
  }
  object.simplices.reserve(simplices.size() / dim);
  for (size_t i = 0; i < simplices.size(); i += dim) {
    Simplex s{};
    for (int k = 0; k < dim; ++k) s.v[k] = simplices[i + k];
    object.simplices.push_back(s);
  }
  impl_->labels.insert(label);
  impl_->scene.objects.push_back(std::move(object));
  return static_cast<Object>(impl_->scene.objects.size() - 1);
}

int Scene::dimension() const { return impl_->scene.dimension; }
const std::string& Scene::units() const { return impl_->scene.units; }
void Scene::set_units(std::string_view units) {
  impl_->scene.units =
      units.empty() ? std::string() : parse_units(units, "units", ErrorCode::kInvalidArgument);
}
int Scene::size() const { return static_cast<int>(impl_->scene.objects.size()); }
const std::string& Scene::label(Object object) const {
  if (object < 0 || object >= size()) {
    throw Error(ErrorCode::kNotFound, "no object with index " + std::to_string(object),
                {.object = static_cast<int64_t>(object)});
  }
  return impl_->scene.objects[static_cast<size_t>(object)].label;
}

// ---- compute / load -------------------------------------------------------------------------

Result compute(const Scene& scene, const ComputeOptions& options) {
  gvd::scene::Scene s = Access::scene(scene);
  SceneLimits limits;
  limits.max_objects = options.max_objects;
  limits.max_simplices = options.max_simplices;
  validate_scene(s, limits, options.cancel);

  // The options through the parameter table (gvd/pipeline/parameters.h): its ranges and
  // choices, its checks across parameters, named as the keywords are.
  PipelineParams params;
  params.max_depth = options.max_depth;
  params.contact_depth = options.contact_depth;
  params.domain = options.domain;
  params.frame = parse_choice<DomainFrame>(options.frame);
  params.threads = options.threads;
  params.octree_build = parse_choice<OctreeBuild>(options.octree_build);
  params.distance = parse_choice<DistanceMethod>(options.distance);
  params.refine = parse_choice<RefineRule>(options.refine);
  params.junctions = parse_choice<JunctionCells>(options.junctions);
  params.resolution = parse_choice<GvdResolution>(options.resolution);
  params.curved_tolerance = options.curved_tolerance;
  params.ambiguity_levels = options.ambiguity_levels;
  params.ambiguity_rounds = options.ambiguity_rounds;
  params.unseen_rounds = options.unseen_rounds;
  params.max_leaves = options.max_leaves;
  params.check_ranges(ParamSpelling::kApi);
  params.check(s.dimension, ParamSpelling::kApi);
  PipelineOptions po = pipeline_options(params);
  const kernels::BackendChoice choice = backend_for(options.backend);
  po.backend = parse_choice<BackendRequest>(choice.backend);
  po.compute = choice.compute;
  po.backend_note = choice.note;
  if (options.progress) {
    po.progress = [&options](const std::string& stage, double f) { options.progress(stage, f); };
  }
  po.cancel = options.cancel;
  return Access::make_result(compute_gvd(std::move(s), po));
}

Grid grid(const Scene& scene, const GridOptions& options) {
  gvd::scene::Scene s = Access::scene(scene);
  validate_scene(s, {}, options.cancel);
  ::gvd::grid::GridOptions go = ::gvd::pipeline::grid_options(grid_params(options, s.dimension));
  (void)make_grid_spec(s, go);  // the limits, before the backend starts or memory is taken
  go.compute = backend_for(options.backend).compute;
  go.cancel = options.cancel;
  if (options.progress) go.progress = [&options](double f) { options.progress("grid", f); };
  return grid_of(compute_grid(s, go));
}

Result load(const std::string& path) { return Access::make_result(load_result(path)); }

// ---- Result ---------------------------------------------------------------------------------

const GvdResult& Result::internal() const { return *impl_->result; }
int Result::dimension() const { return internal().scene.dimension; }
const std::string& Result::units() const { return internal().scene.units; }
int Result::size() const { return static_cast<int>(internal().scene.objects.size()); }
const std::string& Result::label(Object object) const {
  return internal().scene.objects[checked_object(internal(), object)].label;
}
Object Result::object(std::string_view label) const {
  return object_of(impl_->index().object(label));
}

Grid Result::grid(const GridOptions& options) const {
  const GvdResult& r = internal();
  ResultGridOptions ro = result_grid_options(grid_params(options, r.scene.dimension));
  ro.cancel = options.cancel;
  if (options.progress) ro.progress = [&options](double f) { options.progress("grid", f); };
  return grid_of(sample_result_grid(r, ro));
}

std::vector<Contact> Result::contacts(double max_gap) const {
  auto array = [](Vec3 p) { return std::array<double, 3>{p.x, p.y, p.z}; };
  std::vector<Contact> out;
  for (const gvd::query::Contact& c : find_contacts(impl_->index(), max_gap)) {
    Contact& o = out.emplace_back();
    o.a = object_of(c.a);
    o.b = object_of(c.b);
    o.gap = c.gap;
    o.on_a = array(c.on_a);
    o.on_b = array(c.on_b);
    o.interference = c.interference;
    o.depth_lower_bound = c.depth_lower_bound;
    o.penetration_depth = c.penetration_depth;
    o.interface_area = c.interface_area;
    for (const gvd::query::ContactSite& s : c.sites)
      o.sites.push_back({s.area, array(s.centroid), s.min_gap, array(s.on_a), array(s.on_b)});
  }
  return out;
}

std::vector<Edge> Result::graph() const {
  std::vector<Edge> out;
  out.reserve(internal().graph.edges.size());
  for (const DualEdge& e : internal().graph.edges) {
    const Vec3 t = e.tightest_point;
    out.push_back({object_of(e.a),
                   object_of(e.b),
                   e.area,
                   e.min_clearance,
                   {t.x, t.y, t.z},
                   e.gap,
                   e.touching});
  }
  return out;
}

std::vector<Neighbor> Result::neighbors(Object object, int ring) const {
  const ObjectId id = checked_object(internal(), object);
  std::vector<Neighbor> out;
  for (const RingNeighbor& n : impl_->index().neighbors(id, ring)) {
    out.push_back({object_of(n.object), n.ring, object_of(n.via), n.area, n.min_clearance, n.gap,
                   n.touching});
  }
  return out;
}

std::vector<Neighbor> Result::neighbors(std::string_view label, int ring) const {
  return neighbors(object(label), ring);
}

NearestBatch Result::nearest(std::span<const double> points, bool fast, int threads) const {
  const int dim = dimension();
  check_multiple(points.size(), dim, "the points");
  const size_t n = points.size() / static_cast<size_t>(dim);
  const GvdIndex& index = impl_->index();
  NearestBatch out;
  out.object.assign(n, kNone);
  out.distance.assign(n, kNan);
  out.closest.assign(points.size(), kNan);
  out.inside.assign(n, -1);
  out.signed_distance.assign(n, kNan);
  parallel_for(n, resolve_threads(threads), [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      const Vec3 p = point_of(points.subspan(i * dim, dim), dim, "a point");
      NearestAnswer a;
      try {
        a = index.nearest(p, fast);
      } catch (const Error& e) {
        // Outside the domain or not finite: this point has no answer; the others do.
        if (e.code() == ErrorCode::kOutsideDomain || e.code() == ErrorCode::kInvalidArgument)
          continue;
        throw;
      }
      out.object[i] = object_of(a.object);
      out.distance[i] = a.distance;
      out.inside[i] = a.inside;
      out.signed_distance[i] = a.signed_distance();
      for (int k = 0; k < dim; ++k) out.closest[i * dim + k] = a.closest[k];
    }
  });
  return out;
}

Path Result::path(std::span<const double> from, std::span<const double> to,
                  const PathOptions& options) const {
  const int dim = dimension();
  PathQuery q;
  q.from = point_of(from, dim, "from");
  q.to = point_of(to, dim, "to");
  q.min_clearance = options.min_clearance;
  q.cost = options.by_clearance ? PathCost::kClearance : PathCost::kShortest;
  const PathAnswer a = impl_->index().path(q);
  Path out;
  out.found = a.found;
  for (const Vec3& p : a.points) append(out.points, p, dim);
  out.length = a.length;
  out.min_clearance = a.min_clearance;
  out.reason = a.reason;
  return out;
}

Cell Result::cell(Object object) const {
  const GvdResult& r = internal();
  const ObjectId id = checked_object(r, object);
  Cell out;
  if (id >= r.gvd.cells.size()) return out;
  const GvdCell& c = r.gvd.cells[id];
  const int dim = dimension();
  out.vertices.reserve(c.positions.size() * dim);
  for (const Vec3& p : c.positions) append(out.vertices, p, dim);
  out.simplices = c.indices;
  out.other.reserve(c.other.size());
  for (ObjectId o : c.other) out.other.push_back(object_of(o));
  out.clearance = c.clearance;
  return out;
}

Cell Result::cell(std::string_view label) const { return cell(object(label)); }

Explosion Result::explode(std::string_view anchor, double scale) const {
  const GvdIndex& index = impl_->index();
  ExplodeOptions eo;
  eo.scale = scale;
  const ExplodedView v = index.explode(index.object(anchor), eo);
  const int dim = dimension();
  Explosion out;
  out.scale = v.scale;
  for (const ExplodedObject& o : v.objects) {
    out.ring.push_back(o.ring);
    append(out.displacement, o.displacement, dim);
    out.factor.push_back(o.factor);
  }
  return out;
}

void Result::save(const std::string& path) const { save_result(internal(), path); }

void Result::write_glb(const std::string& path) const {
  write_glb_file(path, internal().gvd, internal().scene);
}

void Result::write_json(const std::string& path) const {
  write_json_file(path, internal().gvd, internal().scene);
}

void Result::write_graph_json(const std::string& path) const {
  write_file_atomic(path, graph_to_json(internal().graph, internal().scene));
}

std::string Result::info_json() const { return result_info_json(internal()); }

}  // namespace gvd::api

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/peak_memory.h"
#include "gvd/common/stopwatch.h"
#include "gvd/distance/closest_points.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/distance/leaf_vertices.h"
#include "gvd/graph/build_dual_graph.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/build_octree_data_parallel.h"
#include "gvd/octree/contacts.h"
#include "gvd/octree/leaf_simplices.h"
#include "gvd/pipeline/junction_face.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/refine/pair_certificate.h"
#include "gvd/refine/refine.h"
#include "gvd/scene/snap_faces.h"
#include "gvd/surface/compact_gvd.h"
#include "gvd/surface/extract_gvd.h"

namespace gvd::pipeline {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::distance;
using namespace gvd::compute;
using namespace gvd::surface;
using namespace gvd::refine;
using namespace gvd::graph;
using namespace gvd::result;

namespace {

// A length for a message: 3 significant digits ("2.01e-05 units").
std::string format_length(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", x);
  return std::string(text) + " units";
}

using Progress = std::function<void(const std::string&, double)>;

// The options of the first octree's build (paper §3; certified cells left whole).
OctreeOptions octree_options(const PipelineOptions& options, const ContactPairs& contacts,
                             const SplitOracle* oracle, const Progress& progress) {
  OctreeOptions tree_options;
  tree_options.split_oracle = oracle;
  tree_options.contacts = &contacts;
  tree_options.contact_depth = options.contact_depth;
  tree_options.max_depth = options.max_depth;
  tree_options.max_leaves = options.max_leaves;
  tree_options.threads = options.threads;
  tree_options.cancel = options.cancel;
  tree_options.progress = [progress](double f) { progress("octree", f); };
  return tree_options;
}

Octree first_octree(const UnitGeometry& geometry, const PipelineOptions& options,
                    const OctreeOptions& tree_options, LeafSimplices& simplices) {
  if (options.octree_build == OctreeBuild::kDataParallel) {
    const std::unique_ptr<OctreeBuildSteps> steps =
        options.compute ? options.compute->octree_build_steps(geometry) : nullptr;
    return build_octree_data_parallel(geometry, tree_options, steps.get(), nullptr, &simplices);
  }
  return build_octree(geometry, tree_options, &simplices);
}

// The options of the distance transform (paper §4) with the exact closest-point solver.
DistanceOptions distance_options(const PipelineOptions& options, ClosestPointSolver* solver,
                                 const Progress& progress) {
  DistanceOptions field_options;
  field_options.threads = options.threads;
  field_options.cancel = options.cancel;
  field_options.solver = solver;
  field_options.method = options.distance;
  field_options.progress = [progress](double f) { progress("distance", f); };
  return field_options;
}

// The options of the refinement loop (§5 ambiguity, the separation guarantee, unseen
// regions); the octree and distance options without progress (the loop reports its own).
RefineLoopOptions refine_options(const PipelineOptions& options, int dim, int max_depth,
                                 const ContactPairs& contacts, const PairCertifier* certifier,
                                 OctreeOptions tree_options, DistanceOptions field_options,
                                 const Progress& progress) {
  RefineLoopOptions loop_options;
  loop_options.max_rounds = options.max_refine_rounds;
  loop_options.ambiguity_rounds = options.ambiguity_rounds >= 0 ? options.ambiguity_rounds
                                  : dim == 2                    ? options.max_refine_rounds
                                                                : 3;
  loop_options.ambiguity_levels = options.ambiguity_levels >= 0 ? options.ambiguity_levels
                                  : dim == 2                    ? lattice_bits(2)
                                                                : 2;
  loop_options.unseen_rounds = options.unseen_rounds >= 0 ? options.unseen_rounds
                               : dim == 2                 ? options.max_refine_rounds
                                                          : 4;
  loop_options.cone_certifier = certifier;
  loop_options.contacts = &contacts;
  loop_options.contact_depth = resolve_contact_depth(dim, options.contact_depth, max_depth);
  tree_options.progress = nullptr;
  field_options.progress = nullptr;
  loop_options.octree = std::move(tree_options);
  loop_options.distance = std::move(field_options);
  loop_options.progress = [progress](double f) { progress("ambiguity", f); };
  return loop_options;
}

// One run of the pipeline: the stages in the order compute_gvd calls them, and what they hand
// on to each other (the BVH, the touching pairs, the certifier, the closest-point solver).
// Each stage frees what no later stage reads before memory peaks in the next.
class Computation {
 public:
  Computation(Scene scene, const PipelineOptions& options)
      : options_(options), scene_(std::move(scene)), dim_(scene_.dimension) {
    progress_ = [this](const std::string& stage, double f) {
      if (options_.progress) options_.progress(stage, f);
    };
    r_.stats.backend = options.compute ? options.compute->name() : "cpu";
    if (!options.backend_note.empty()) r_.stats.backend += " (" + options.backend_note + ")";
    r_.stats.threads = resolve_threads(options.threads);
  }

  /// The domain (the octree's frame), the scene on the unit lattice and its BVH.
  void scene_stage() {
    progress_("scene", 0);
    sw_ = Stopwatch();
    DomainOptions domain_options = options_.domain;
    domain_options.threads = options_.threads;
    domain_options.cancel = options_.cancel;
    // Certificates need flat faces flat; a float32 or few-decimal input's are flat only to
    // its rounding.
    if (options_.refine == RefineRule::kCertified)
      snap_ = snap_rounded_faces(scene_, options_.threads, options_.cancel);
    r_.domain = make_domain(scene_, domain_options);
    throw_if_cancelled(options_.cancel, "the scene stage");
    r_.geometry = make_unit_geometry(scene_, r_.domain);
    throw_if_cancelled(options_.cancel, "the scene stage");
    bvh_.emplace(dim_, r_.geometry.points, r_.geometry.simplices, r_.geometry.object_of,
                 options_.cancel);
    r_.stats.stages.push_back({"scene", sw_.seconds(),
                               r_.geometry.points.size() * sizeof(Vec3) +
                                   r_.geometry.simplices.size() * sizeof(Simplex) +
                                   bvh_->memory_bytes(),
                               r_.geometry.simplices.size()});
  }

  /// Objects closer than the lattice's resolution cannot be separated (contacts.h): those
  /// pairs are found first, so that refinement between them stops at the contact depth.
  /// (Checked down to 1.1 cells on plates, spheres, crossed bars, the mirrored bunnies, and 2D
  /// squares and discs; the bound was 2*sqrt(dim) cells, which reported such resolvable gaps
  /// as touching.) Counted in the octree stage.
  void find_contacts() {
    progress_("octree", 0);
    sw_ = Stopwatch();
    max_depth_ = resolve_max_depth(dim_, options_.max_depth);
    touch_tolerance_ = contact_tolerance(max_depth_);
    contacts_ =
        find_contact_pairs(r_.geometry, *bvh_, touch_tolerance_, options_.threads, options_.cancel);
  }

  /// The octree (§3), its distance field (§4) and the refinement loop (§5 ambiguity, the
  /// separation guarantee, unseen regions). The thin-gaps refinement leaves certified pair
  /// cells whole (refine/pair_certificate.h). Cones across an axis are tried first; where the
  /// refinement does not settle with them (see RefineLoopOptions::cone_certifier) the octree is
  /// built again without.
  void octree_distance_and_refinement() {
    const size_t first_stage = r_.stats.stages.size();
    for (const bool cones : {true, false}) {
      r_.stats.stages.resize(first_stage);
      if (!cones) sw_ = Stopwatch();  // the first attempt's octree stage counts the contacts too
      certifier_.reset();
      if (options_.refine == RefineRule::kCertified) {
        certifier_.emplace(r_.geometry, *bvh_, &contacts_, true, cones, options_.cancel);
        certifier_->enable_junctions(options_.junctions && dim_ == 3);
      } else if (!cones) {
        break;
      }
      const OctreeOptions tree_options =
          octree_options(options_, contacts_, certifier(), progress_);
      heap_computation_starts();
      leaf_simplices_.release();  // the failed attempt's
      r_.octree = first_octree(r_.geometry, options_, tree_options, leaf_simplices_);
      heap_checkpoint(r_.octree.leaf_count());
      r_.stats.stages.push_back(
          {"octree", sw_.seconds(), r_.octree.structure_bytes(), r_.octree.leaf_count()});

      progress_("distance", 0);
      sw_ = Stopwatch();
      // Exact closest points: the backend's kernel, else the CPU twin (same per-item function).
      if (!solver_) {
        solver_ = options_.compute ? options_.compute->closest_points(r_.geometry, *bvh_)
                                   : make_cpu_closest_point_solver(*bvh_, options_.threads);
      }
      DistanceOptions field_options = distance_options(options_, solver_.get(), progress_);
      field_options.leaf_simplices = &leaf_simplices_;
      r_.field = DistanceField();  // the failed attempt's goes first
      leaf_vertices_.release();
      r_.field = compute_distances(r_.octree, r_.geometry, *bvh_, field_options, &leaf_vertices_);
      r_.stats.stages.push_back(
          {"distance", sw_.seconds(), r_.field.memory_bytes(), r_.field.size()});

      progress_("ambiguity", 0);
      sw_ = Stopwatch();
      RefineLoopOptions loop_options =
          refine_options(options_, dim_, max_depth_, contacts_, certifier(), tree_options,
                         field_options, progress_);
      if (certifier_ && certifier_->junctions()) {
        loop_options.unswept_junctions = [this](const Octree& octree, const DistanceField& field,
                                                const LeafVertices& rows) {
          SurfaceOptions o;
          o.threads = options_.threads;
          o.cancel = options_.cancel;
          o.junction_face = junction_faces();
          std::vector<uint32_t> unswept =
              unswept_junction_leaves(octree, field, &rows, r_.geometry, *bvh_, o);
          for (uint32_t leaf : unswept) certifier_->refuse_junctions_in(octree.box(leaf));
          return unswept;
        };
      }
      try {
        refined_ = refine_until_resolved(r_.octree, leaf_simplices_, r_.field, leaf_vertices_,
                                         r_.geometry, *bvh_, loop_options);
      } catch (const Error& e) {
        // Unsettled cones can also grow the octree past the leaf limit before cone_rounds.
        if (e.code() != ErrorCode::kLimitExceeded || !cones || !certifier_) throw;
        refined_.cones_unsettled = true;
      }
      if (!refined_.cones_unsettled) break;
      cones_dropped_ = true;
      progress_("octree", 0);
    }
    r_.stats.unseen_left = refined_.unseen_left;
    r_.stats.refine_rounds = refined_.rounds;
    r_.stats.ambiguous_at_limit = refined_.ambiguous_at_limit;
    r_.stats.touching_leaves = refined_.touching_leaves;
    for (uint8_t c : r_.octree.certified) r_.stats.certified_leaves += c != 0;
    r_.stats.stages.push_back(
        {"ambiguity", sw_.seconds(), 0, static_cast<uint64_t>(refined_.rounds)});
  }

  /// Refinement is over: what only it read goes before surfacing, where memory peaks.
  void release_refinement_state() {
    // The closest-point solver (the OpenCL backend's device copy of the tree and geometry).
    solver_.reset();
    // Skew extruded cells get their direction from the certificate of their own box again
    // (the mark does not hold it), so the certifier stays where there are some.
    for (uint8_t c : r_.octree.certified) any_skew_ |= c >= kSkewMark && c <= kSkewLastMark;
    if (!any_skew_) certifier_.reset();
    // Surfacing reads each leaf's vertices from its row of leaf_vertices_, never by key: the
    // key -> vertex hash (~40 B per vertex, the field's largest part) goes before memory peaks
    // there; lookups by key binary-search the sorted keys from now on (OctreeVertices::find).
    r_.field.vertices.drop_index();
    // Which vertices changed in the last round is of no use from here on.
    std::vector<uint8_t>().swap(r_.field.changed);
    // Nor does anything after the refinement read the leaves' simplex lists (a result loaded
    // from disk has none).
    leaf_simplices_.release();
  }

  /// The GVD (§6): every leaf's pieces, then welded into closed, oriented cells.
  void surface_stage() {
    progress_("surface", 0);
    heap_checkpoint(r_.octree.leaf_count());
    sw_ = Stopwatch();
    SurfaceOptions surface_options;
    surface_options.threads = options_.threads;
    surface_options.cancel = options_.cancel;
    // The weld: the last tenth.
    surface_options.progress = [this](double f) { progress_("surface", 0.9 * f); };
    if (any_skew_) {
      surface_options.skew_direction = [this](const Box& box, Vec3& along) {
        const PairCertifier::Certificate c = certifier_->certify(box);
        if (!c.skew) return false;
        along = c.along;
        return true;
      };
    }
    bool any_junction = false;
    for (uint8_t c : r_.octree.certified) any_junction |= c >= kJunctionMark;
    if (any_junction) surface_options.junction_face = junction_faces();
    {
      // Only surfacing reads the leaves' vertex lists now (~50 B per leaf): they go as it stops
      // needing them, the inactive leaves' first (memory peaks at its end and in the weld).
      LeafPieces pieces = surface_leaves_releasing_lists(r_.octree, r_.field, leaf_vertices_,
                                                         r_.geometry, *bvh_, surface_options);
      r_.gvd = weld_gvd(std::move(pieces), r_.geometry, *bvh_, r_.domain, surface_options);
    }
    certifier_.reset();
    uint64_t gvd_bytes = 0;
    for (const GvdCell& c : r_.gvd.cells) {
      simplices_ += c.indices.size() / (dim_ == 2 ? 2 : 3);
      gvd_bytes += c.positions.size() * (sizeof(Vec3) + sizeof(ObjectId) + sizeof(double)) +
                   c.indices.size() * sizeof(uint32_t);
    }
    r_.stats.stages.push_back({"surface", sw_.seconds(), gvd_bytes, simplices_});
  }

  /// The dual graph (§7.3) with exact clearances and gaps.
  void graph_stage() {
    progress_("graph", 0);
    sw_ = Stopwatch();
    r_.graph = build_dual_graph(r_.gvd);
    tighten_clearances(r_.graph, r_.gvd, *bvh_, r_.domain, options_.threads, options_.cancel,
                       contacts_.pairs());
    measure_gaps(r_.graph, *bvh_, r_.domain, contacts_.pairs(), options_.threads, options_.cancel);
    r_.stats.stages.push_back(
        {"graph", sw_.seconds(), r_.graph.edges.size() * sizeof(DualEdge), r_.graph.edges.size()});
  }

  /// Coplanar pieces merged, curved ones within the tolerance. After the graph: its areas
  /// and clearances are those of the full-resolution GVD.
  void compact_stage() {
    progress_("compact", 0);
    sw_ = Stopwatch();
    CompactOptions compact_options;
    compact_options.threads = options_.threads;
    compact_options.curved_tolerance = options_.curved_tolerance;
    compact_options.bvh = &*bvh_;
    compact_options.domain = &r_.domain;
    compact_options.cancel = options_.cancel;
    const CompactStats compacted = compact_gvd(r_.gvd, compact_options);
    simplices_ = compacted.simplices_after;
    r_.stats.stages.push_back({"compact", sw_.seconds(), 0, compacted.simplices_after});
  }

  /// octree_distance_and_refinement; a limit hit after rounded faces were left where they
  /// are says so (their rounding is what the cells chase).
  void octree_distance_and_refinement_or_why() {
    try {
      octree_distance_and_refinement();
    } catch (const Error& e) {
      if (e.code() != ErrorCode::kLimitExceeded || snap_.refused == 0) throw;
      throw Error(e.code(),
                  e.detail() + "; " + std::to_string(snap_.refused) +
                      " vertices of flat faces of this " +
                      (snap_.float32 ? std::string("float32") : std::string("decimal")) +
                      " input were not put on exact "
                      "planes (a move longer than 16 of its roundings, " +
                      format_length(snap_.rounding) +
                      ", or than 1 % of their distance to another object): where the file's "
                      "rounding is that large a share of a gap, the faces are flat only to it "
                      "and the gap refines to it",
                  e.where());
    }
  }

  /// The warnings found by the computation itself, added to the scene's.
  void add_warnings() {
    if (snap_.vertices > 0) {
      char numbers[160];
      std::snprintf(numbers, sizeof numbers, "%llu vertices moved by at most %s",
                    static_cast<unsigned long long>(snap_.vertices),
                    format_length(snap_.max_move).c_str());
      const char* kind = snap_.float32 ? "float32" : "decimal";
      std::string detail = std::string(kind) + " coordinates: " + numbers + " (the scene's " +
                           kind + " rounding is " + format_length(snap_.rounding) + ") onto " +
                           std::to_string(snap_.planes) + " exact planes of " +
                           std::to_string(snap_.faces) +
                           " flat faces, so that faces flat, parallel or square to rounding "
                           "are so exactly and thin gaps between them stay cheap";
      if (snap_.refused > 0)
        detail += "; " + std::to_string(snap_.refused) +
                  " vertices left where they are (a move longer than 16 roundings or than 1 % "
                  "of their distance to another object)";
      scene_.warnings.push_back({WarningKind::kFacesSnapped, "", snap_.vertices, detail});
    }
    if (!contacts_.empty()) {
      std::string detail =
          "objects that touch, intersect or come closer than the finest cell (" +
          format_length(touch_tolerance_ * r_.domain.side) +
          "): reported as touching, with clearance 0 and their measured gap; their cells are "
          "separated only down to the contact depth:";
      int listed = 0;
      for (const auto& [a, b] : contacts_.pairs()) {
        if (++listed > 20) {
          detail += " ...";
          break;
        }
        detail += " " + scene_.objects[a].label + "/" + scene_.objects[b].label;
      }
      scene_.warnings.push_back({WarningKind::kObjectsTouch, "", contacts_.pairs().size(), detail});
    }
    if (r_.stats.unseen_left > 0) {
      scene_.warnings.push_back(
          {WarningKind::kThinRegionsLeft, "", r_.stats.unseen_left,
           "cells where a GVD point is nearer to an object the cell does not see (a region "
           "thinner than the cell) after the allowed refinement rounds (--unseen-rounds)"});
    }
    if (cones_dropped_) {
      scene_.warnings.push_back(
          {WarningKind::kConesDropped, "", 1,
           "the refinement did not settle with cones across an octree axis (straight rims whose "
           "faces' normals straddle an axis, where lines along it meet the bisector more than "
           "twice or run too close along it to count the crossings); the octree was built again "
           "without them: as exact, but such rims cost cells down to the gap along their length "
           "(more leaves, time and memory)"});
    }
    if (r_.stats.ambiguous_at_limit > 0) {
      scene_.warnings.push_back(
          {WarningKind::kAmbiguousCellsLeft, "", r_.stats.ambiguous_at_limit,
           "cells whose GVD topology is ambiguous (§5) after the allowed refinement "
           "(--ambiguity-levels/--ambiguity-rounds); surfaced by the centroid rule (§6), still "
           "closed and oriented"});
    }
  }

  /// The result with its figures (sizes, depth, time, peak memory) and the scene.
  GvdResult finish() {
    r_.stats.max_depth = r_.octree.max_depth;
    r_.stats.depth = r_.octree.depth;
    r_.stats.leaves = r_.octree.leaf_count();
    r_.stats.vertices = r_.field.size();
    r_.stats.octree_bytes =
        r_.octree.structure_bytes() + r_.field.vertices.key.size() * sizeof(uint64_t);
    r_.stats.bytes_per_leaf =
        r_.stats.leaves > 0 ? static_cast<double>(r_.stats.octree_bytes) / r_.stats.leaves : 0;
    r_.stats.distance_bytes = r_.field.memory_bytes();
    r_.stats.gvd_simplices = simplices_;
    r_.stats.graph_edges = r_.graph.edges.size();
    r_.stats.total_seconds = total_.seconds();
    r_.stats.peak_rss_bytes = peak_rss_bytes();
    r_.stats.start_rss_bytes = start_rss_;
    r_.scene = std::move(scene_);
    progress_("done", 1);
    return std::move(r_);
  }

 private:
  const PairCertifier* certifier() const { return certifier_ ? &*certifier_ : nullptr; }

  // The plane GVD of a junction cell's face (junction_face_gvd), each face computed once: the
  // refinement's check and the surfacing ask for the same faces, from both cells of each; and
  // once per section (sections_: a junction line's faces one above the other).
  std::function<bool(const Box&, int, FaceGvd&)> junction_faces() {
    return [this](const Box& face, int axis, FaceGvd& out) {
      const FaceKey key{face.lo.x, face.lo.y, face.lo.z, face.hi.x, face.hi.y, face.hi.z, axis};
      {
        const std::lock_guard<std::mutex> lock(face_mutex_);
        const auto it = faces_.find(key);
        if (it != faces_.end()) {
          out = it->second.second;
          return it->second.first;
        }
      }
      const bool crossed =
          junction_face_gvd(r_.geometry, *bvh_, face, axis, out, options_.cancel, &sections_);
      const std::lock_guard<std::mutex> lock(face_mutex_);
      faces_.emplace(key, std::make_pair(crossed, out));
      return crossed;
    };
  }

  const PipelineOptions& options_;
  const Stopwatch total_;
  const uint64_t start_rss_ = rss_bytes();
  Scene scene_;
  FaceSnap snap_;
  const int dim_;
  Progress progress_;
  GvdResult r_;
  Stopwatch sw_;  ///< the running stage's
  std::optional<SimplexBvh> bvh_;
  int max_depth_ = 0;
  double touch_tolerance_ = 0;
  ContactPairs contacts_;
  std::optional<PairCertifier> certifier_;
  using FaceKey = std::tuple<double, double, double, double, double, double, int>;
  std::mutex face_mutex_;
  std::map<FaceKey, std::pair<bool, FaceGvd>> faces_;
  JunctionSectionCache sections_;  ///< the faces' plane GVDs by their section
  std::unique_ptr<ClosestPointSolver> solver_;
  /// The leaves' simplices (from the octree's build, for the refinement) and boundary
  /// vertices (from the distance transform, for the refinement and the surfacing): what the
  /// stages hand on beside r_'s octree and field, freed as the last reader is done.
  LeafSimplices leaf_simplices_;
  LeafVertices leaf_vertices_;
  RefineLoopResult refined_;
  bool cones_dropped_ = false;
  bool any_skew_ = false;
  uint64_t simplices_ = 0;  ///< the GVD's, after surfacing and after compaction
};

}  // namespace

GvdResult compute_gvd(Scene scene, const PipelineOptions& options) {
  if (options.backend != BackendRequest::kCpu &&
      (options.backend != BackendRequest::kOpenCl || !options.compute)) {
    throw Error(ErrorCode::kInvalidArgument,
                "backend '" + std::string(choice_name(options.backend)) +
                    "' is not available here (core runs: cpu; opencl needs a ComputeBackend "
                    "from gvd_kernels in PipelineOptions::compute)");
  }
  Computation run(std::move(scene), options);
  run.scene_stage();
  run.find_contacts();
  run.octree_distance_and_refinement_or_why();
  run.release_refinement_state();
  run.surface_stage();
  run.graph_stage();
  if (options.resolution == GvdResolution::kCompact) run.compact_stage();
  run.add_warnings();
  return run.finish();
}

}  // namespace gvd::pipeline

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "gvd/common/cancel.h"
#include "gvd/common/error.h"
#include "gvd/common/parallel.h"
#include "gvd/common/peak_memory.h"
#include "gvd/common/stopwatch.h"
#include "gvd/distance/closest_points.h"
#include "gvd/distance/compute_distances.h"
#include "gvd/graph/build_dual_graph.h"
#include "gvd/octree/build_octree.h"
#include "gvd/octree/build_octree_data_parallel.h"
#include "gvd/octree/contacts.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/refine/pair_certificate.h"
#include "gvd/refine/refine.h"
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
  OctreeOptions oo;
  oo.split_oracle = oracle;
  oo.contacts = &contacts;
  oo.contact_depth = options.contact_depth;
  oo.max_depth = options.max_depth;
  oo.max_leaves = options.max_leaves;
  oo.threads = options.threads;
  oo.cancel = options.cancel;
  oo.progress = [progress](double f) { progress("octree", f); };
  return oo;
}

Octree first_octree(const UnitGeometry& geometry, const PipelineOptions& options,
                    const OctreeOptions& oo) {
  if (options.octree_build == OctreeBuild::kDataParallel) {
    const std::unique_ptr<OctreeBuildSteps> steps =
        options.compute ? options.compute->octree_build_steps(geometry) : nullptr;
    return build_octree_data_parallel(geometry, oo, steps.get());
  }
  return build_octree(geometry, oo);
}

// The options of the distance transform (paper §4) with the exact closest-point solver.
DistanceOptions distance_options(const PipelineOptions& options, ClosestPointSolver* solver,
                                 const Progress& progress) {
  DistanceOptions dopt;
  dopt.threads = options.threads;
  dopt.cancel = options.cancel;
  dopt.solver = solver;
  dopt.method = options.distance;
  dopt.progress = [progress](double f) { progress("distance", f); };
  return dopt;
}

// The options of the refinement loop (§5 ambiguity, the separation guarantee, unseen
// regions); the octree and distance options without progress (the loop reports its own).
RefineLoopOptions refine_options(const PipelineOptions& options, int dim, int max_depth,
                                 const ContactPairs& contacts, const PairCertifier* certifier,
                                 OctreeOptions oo, DistanceOptions dopt, const Progress& progress) {
  RefineLoopOptions lo;
  lo.max_rounds = options.max_refine_rounds;
  lo.ambiguity_rounds = options.ambiguity_rounds >= 0 ? options.ambiguity_rounds
                        : dim == 2                    ? options.max_refine_rounds
                                                      : 3;
  lo.ambiguity_levels = options.ambiguity_levels >= 0 ? options.ambiguity_levels
                        : dim == 2                    ? lattice_bits(2)
                                                      : 2;
  lo.unseen_rounds = options.unseen_rounds >= 0 ? options.unseen_rounds
                     : dim == 2                 ? options.max_refine_rounds
                                                : 4;
  lo.cone_certifier = certifier;
  lo.contacts = &contacts;
  lo.contact_depth = resolve_contact_depth(dim, options.contact_depth, max_depth);
  oo.progress = nullptr;
  dopt.progress = nullptr;
  lo.octree = std::move(oo);
  lo.distance = std::move(dopt);
  lo.progress = [progress](double f) { progress("ambiguity", f); };
  return lo;
}

}  // namespace

GvdResult compute_gvd(Scene scene, const PipelineOptions& options) {
  if (options.backend != BackendRequest::kCpu &&
      (options.backend != BackendRequest::kOpenCl || !options.compute)) {
    throw Error(ErrorCode::kInvalidArgument,
                "backend '" + std::string(choice_name(options.backend)) +
                    "' is not available here (core runs: cpu; opencl needs a ComputeBackend "
                    "from gvd_kernels in PipelineOptions::compute)");
  }
  const Stopwatch total;
  const uint64_t start_rss = rss_bytes();
  const Progress progress = [&](const std::string& stage, double f) {
    if (options.progress) options.progress(stage, f);
  };
  GvdResult r;
  r.stats.backend = options.compute ? options.compute->name() : "cpu";
  if (!options.backend_note.empty()) r.stats.backend += " (" + options.backend_note + ")";
  r.stats.threads = resolve_threads(options.threads);
  const int dim = scene.dimension;

  progress("scene", 0);
  Stopwatch sw;
  DomainOptions domain_options = options.domain;
  domain_options.threads = options.threads;
  domain_options.cancel = options.cancel;
  r.domain = make_domain(scene, domain_options);
  throw_if_cancelled(options.cancel, "the scene stage");
  r.geometry = make_unit_geometry(scene, r.domain);
  throw_if_cancelled(options.cancel, "the scene stage");
  const SimplexBvh bvh(dim, r.geometry.points, r.geometry.simplices, r.geometry.object_of,
                       options.cancel);
  r.stats.stages.push_back({"scene", sw.seconds(),
                            r.geometry.points.size() * sizeof(Vec3) +
                                r.geometry.simplices.size() * sizeof(Simplex) + bvh.memory_bytes(),
                            r.geometry.simplices.size()});

  progress("octree", 0);
  sw = Stopwatch();
  // Objects closer than the lattice's resolution cannot be separated (contacts.h): find those
  // pairs first, so that refinement between them stops at the contact depth. (Checked down to
  // 1.1 cells on plates, spheres, crossed bars, the mirrored bunnies, and 2D squares and discs;
  // the bound was 2*sqrt(dim) cells, which reported such resolvable gaps as touching.)
  const int max_depth = resolve_max_depth(dim, options.max_depth);
  const double touch_tolerance = contact_tolerance(max_depth);
  const ContactPairs contacts =
      find_contact_pairs(r.geometry, bvh, touch_tolerance, options.threads, options.cancel);
  // Exact closest points: the backend's kernel, else the CPU twin (same per-item function);
  // made at the first distance stage.
  std::unique_ptr<ClosestPointSolver> solver;
  // The thin-gaps refinement: certified pair cells stay leaves (refine/pair_certificate.h).
  // Cones across an axis are tried first; where the refinement does not settle with them (see
  // RefineLoopOptions::cone_certifier) the octree is built again without.
  std::optional<PairCertifier> certifier;
  const size_t first_stage = r.stats.stages.size();
  RefineLoopResult refined;
  bool cones_dropped = false;
  for (const bool cones : {true, false}) {
    r.stats.stages.resize(first_stage);
    if (!cones) sw = Stopwatch();  // the first attempt's octree stage counts the contacts too
    certifier.reset();
    if (options.refine == RefineRule::kCertified) {
      certifier.emplace(r.geometry, bvh, &contacts, true, cones, options.cancel);
    } else if (!cones) {
      break;
    }
    const OctreeOptions oo =
        octree_options(options, contacts, certifier ? &*certifier : nullptr, progress);
    heap_computation_starts();
    r.octree = first_octree(r.geometry, options, oo);
    heap_checkpoint(r.octree.leaf_count());
    r.stats.stages.push_back(
        {"octree", sw.seconds(), r.octree.structure_bytes(), r.octree.leaf_count()});

    progress("distance", 0);
    sw = Stopwatch();
    if (!solver) {
      solver = options.compute ? options.compute->closest_points(r.geometry, bvh)
                               : make_cpu_closest_point_solver(bvh, options.threads);
    }
    const DistanceOptions dopt = distance_options(options, solver.get(), progress);
    r.field = DistanceField();  // the failed attempt's goes first
    r.field = compute_distances(r.octree, r.geometry, bvh, dopt);
    r.stats.stages.push_back({"distance", sw.seconds(), r.field.memory_bytes(), r.field.size()});

    // Ambiguity resolution (§5) and the separation guarantee: split, recompute, repeat.
    progress("ambiguity", 0);
    sw = Stopwatch();
    const RefineLoopOptions lo = refine_options(
        options, dim, max_depth, contacts, certifier ? &*certifier : nullptr, oo, dopt, progress);
    try {
      refined = refine_until_resolved(r.octree, r.field, r.geometry, bvh, lo);
    } catch (const Error& e) {
      // Unsettled cones can also grow the octree past the leaf limit before cone_rounds.
      if (e.code() != ErrorCode::kLimitExceeded || !cones || !certifier) throw;
      refined.cones_unsettled = true;
    }
    if (!refined.cones_unsettled) break;
    cones_dropped = true;
    progress("octree", 0);
  }
  r.stats.unseen_left = refined.unseen_left;
  r.stats.refine_rounds = refined.rounds;
  r.stats.ambiguous_at_limit = refined.ambiguous_at_limit;
  r.stats.touching_leaves = refined.touching_leaves;
  for (uint8_t c : r.octree.certified) r.stats.certified_leaves += c != 0;
  r.stats.stages.push_back({"ambiguity", sw.seconds(), 0, static_cast<uint64_t>(refined.rounds)});
  // Refinement is over: the closest-point solver (the OpenCL backend's device copy of the tree
  // and geometry) and the certifier's adjacency go before surfacing, where memory peaks.
  solver.reset();
  // Skew extruded cells get their direction from the certificate of their own box again
  // (the mark does not hold it), so the certifier stays where there are some.
  bool any_skew = false;
  for (uint8_t c : r.octree.certified) any_skew |= c >= kSkewMark && c <= kSkewConeLastMark;
  if (!any_skew) certifier.reset();
  // Surfacing reads each leaf's vertices from the field's per-leaf lists, never by key: the
  // key -> vertex hash (~40 B per vertex, the field's largest part) goes before memory peaks
  // there; lookups by key binary-search the sorted keys from now on (OctreeVertices::find).
  r.field.vertices.drop_index();
  // Which vertices changed in the last round is of no use from here on.
  std::vector<uint8_t>().swap(r.field.changed);
  // Nor does anything after the refinement read the leaves' simplex lists (a result loaded
  // from disk has none).
  std::vector<uint32_t>().swap(r.octree.simplex_begin);
  std::vector<uint32_t>().swap(r.octree.simplex_index);

  progress("surface", 0);
  heap_checkpoint(r.octree.leaf_count());
  sw = Stopwatch();
  SurfaceOptions so;
  so.threads = options.threads;
  so.cancel = options.cancel;
  so.progress = [&](double f) { progress("surface", 0.9 * f); };  // the weld: the last tenth
  if (any_skew) {
    so.skew_direction = [&certifier](const Box& box, Vec3& along) {
      const PairCertifier::Certificate c = certifier->certify(box);
      if (!c.skew) return false;
      along = c.along;
      return true;
    };
  }
  {
    // Only surfacing reads the per-leaf vertex lists (~50 B per leaf): they go as it stops
    // needing them, the inactive leaves' first (memory peaks at its end and in the weld).
    LeafPieces pieces = surface_leaves_releasing_lists(r.octree, r.field, r.geometry, bvh, so);
    r.gvd = weld_gvd(std::move(pieces), r.geometry, bvh, r.domain, so);
  }
  certifier.reset();
  uint64_t simplices = 0, gvd_bytes = 0;
  for (const GvdCell& c : r.gvd.cells) {
    simplices += c.indices.size() / (dim == 2 ? 2 : 3);
    gvd_bytes += c.positions.size() * (sizeof(Vec3) + sizeof(ObjectId) + sizeof(double)) +
                 c.indices.size() * sizeof(uint32_t);
  }
  r.stats.stages.push_back({"surface", sw.seconds(), gvd_bytes, simplices});

  progress("graph", 0);
  sw = Stopwatch();
  r.graph = build_dual_graph(r.gvd);
  tighten_clearances(r.graph, r.gvd, bvh, r.domain, options.threads, options.cancel,
                     contacts.pairs());
  measure_gaps(r.graph, bvh, r.domain, contacts.pairs(), options.threads, options.cancel);
  r.stats.stages.push_back(
      {"graph", sw.seconds(), r.graph.edges.size() * sizeof(DualEdge), r.graph.edges.size()});
  if (options.resolution == GvdResolution::kCompact) {
    // After the graph: its areas and clearances are those of the full-resolution GVD.
    progress("compact", 0);
    sw = Stopwatch();
    CompactOptions co;
    co.threads = options.threads;
    co.curved_tolerance = options.curved_tolerance;
    co.bvh = &bvh;
    co.domain = &r.domain;
    co.cancel = options.cancel;
    const CompactStats compacted = compact_gvd(r.gvd, co);
    simplices = compacted.simplices_after;
    r.stats.stages.push_back({"compact", sw.seconds(), 0, compacted.simplices_after});
  }

  // Warnings found by the computation itself.
  if (!contacts.empty()) {
    std::string detail =
        "objects that touch, intersect or come closer than the finest cell (" +
        format_length(touch_tolerance * r.domain.side) +
        "): reported as touching, with clearance 0 and their measured gap; their cells are "
        "separated only down to the contact depth:";
    int listed = 0;
    for (const auto& [a, b] : contacts.pairs()) {
      if (++listed > 20) {
        detail += " ...";
        break;
      }
      detail += " " + scene.objects[a].label + "/" + scene.objects[b].label;
    }
    scene.warnings.push_back({WarningKind::kObjectsTouch, "", contacts.pairs().size(), detail});
  }
  if (r.stats.unseen_left > 0) {
    scene.warnings.push_back(
        {WarningKind::kThinRegionsLeft, "", r.stats.unseen_left,
         "cells where a GVD point is nearer to an object the cell does not see (a region "
         "thinner than the cell) after the allowed refinement rounds (--unseen-rounds)"});
  }
  if (cones_dropped) {
    scene.warnings.push_back(
        {WarningKind::kConesDropped, "", 1,
         "the refinement did not settle with cones across an octree axis (straight rims whose "
         "faces' normals straddle an axis, where lines along it meet the bisector more than "
         "twice or run too close along it to count the crossings); the octree was built again "
         "without them: as exact, but such rims cost cells down to the gap along their length "
         "(more leaves, time and memory)"});
  }
  if (r.stats.ambiguous_at_limit > 0) {
    scene.warnings.push_back({WarningKind::kAmbiguousCellsLeft, "", r.stats.ambiguous_at_limit,
                              "cells whose GVD topology is ambiguous (§5) after the allowed "
                              "refinement (--ambiguity-levels/--ambiguity-rounds); surfaced by "
                              "the centroid rule (§6), still closed and oriented"});
  }

  r.stats.max_depth = r.octree.max_depth;
  r.stats.depth = r.octree.depth;
  r.stats.leaves = r.octree.leaf_count();
  r.stats.vertices = r.field.size();
  r.stats.octree_bytes =
      r.octree.structure_bytes() + r.field.vertices.key.size() * sizeof(uint64_t);
  r.stats.bytes_per_leaf =
      r.stats.leaves > 0 ? static_cast<double>(r.stats.octree_bytes) / r.stats.leaves : 0;
  r.stats.distance_bytes = r.field.memory_bytes();
  r.stats.gvd_simplices = simplices;
  r.stats.graph_edges = r.graph.edges.size();
  r.stats.total_seconds = total.seconds();
  r.stats.peak_rss_bytes = peak_rss_bytes();
  r.stats.start_rss_bytes = start_rss;
  r.scene = std::move(scene);
  progress("done", 1);
  return r;
}

}  // namespace gvd::pipeline

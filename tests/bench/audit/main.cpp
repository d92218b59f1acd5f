// gvd_audit: computes the GVD of scene files with default options (or --refine paper) and
// checks each result with the brute-force oracles the judges use — GVD simplices
// crossing objects, open cells, equidistance at GVD vertices (median relative gap), the share
// of vertices whose two nearest objects are the claimed pair — beside leaves, depth, time,
// peak memory and warnings, and the share of the GVD's area facing the wrong way (reported,
// not judged). One line per scene; exit 1 when a check fails. A vertex where
// three or more objects meet may claim any two of them (ties within kTie); the share with
// no tie allowed and the vertices whose third object is nearer by over 1 % are printed too.
//
// Usage: gvd_audit [--refine paper] [--frame auto|world] [--full] [--junctions on|off]
//                  [--budget N] [--explain] SCENE.json...
//        (--full: the GVD as surfaced, one piece per leaf, not compacted)
//        (--explain prints every GVD triangle that crosses an object, when one does, and
//        the first 10 sampled vertices whose claimed pair a third object beats)
//        gvd_audit --write-variants DIR     scenes of the thin-gap kinds that make_bench's
//                                           sweeps do not hold (turned, other polygons)
//        gvd_audit --write-real CORPUS DIR  scenes of real meshes from the corpus that
//                                           tests/real_meshes/write_corpus.mjs writes

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <span>
#include <string>
#include <system_error>
#include <tuple>
#include <vector>

#include "bench/sphere_lattice.h"
#include "gvd/common/peak_memory.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/load_scene.h"
#include "support/oracles.h"
#include "support/real_mesh_scenes.h"
#include "support/scenes.h"
#include "support/thin_gap_scenes.h"

using namespace gvd::scene;
using namespace gvd::surface;
using namespace gvd::result;

namespace {

using gvd::Vec3;
using gvd::result::GvdResult;
using gvd::scene::ObjectId;
using gvd::scene::Scene;
using gvd::surface::GvdCell;

struct Audit {
  size_t open_edges = 0;
  size_t crossings = 0;
  size_t vertices = 0;
  double median_gap = 0;     ///< |d_a - d_b| / max(d_a, d_b) at interface vertices, median
  double right_pair = 1;     ///< share whose two nearest objects are the claimed ones (kTie)
  double strict_pair = 1;    ///< the same with no tie allowed
  size_t off_junctions = 0;  ///< vertices with a third object nearer by more than 1 %
  double flipped = 0;        ///< share of the sampled GVD area facing the wrong way
  int explained = 0;         ///< wrong-pair vertices printed (--explain)
};

/// Where three or more objects meet (a junction: a Voronoi edge or vertex) they are equally
/// near, and a vertex there may claim any two of them: a third object counts as nearer only
/// when it is nearer than the farther claimed one by more than this part of that distance.
constexpr double kTie = 1e-6;

Audit audit(const GvdResult& r, size_t budget, bool explain) {
  Audit a;
  const int dim = r.scene.dimension;
  for (const GvdCell& cell : r.gvd.cells) a.open_edges += gvd::test::count_open_edges(cell, dim);
  a.crossings = gvd::test::count_gvd_object_crossings(r.scene, r.gvd, budget);
  size_t total = 0;
  for (const GvdCell& cell : r.gvd.cells) total += cell.positions.size();
  const size_t stride = std::max<size_t>(1, total / budget);
  std::vector<double> gaps;
  size_t right = 0, strict = 0;
  size_t index = 0;
  for (const GvdCell& cell : r.gvd.cells) {
    for (size_t v = 0; v < cell.positions.size(); ++v, ++index) {
      if (index % stride != 0 || cell.other[v] == gvd::scene::kNoObject) continue;
      const Vec3 p = cell.positions[v];
      const double da = gvd::test::brute_distance(r.scene, cell.object, p);
      const double db = gvd::test::brute_distance(r.scene, cell.other[v], p);
      gaps.push_back(std::fabs(da - db) / std::max({da, db, 1e-300}));
      const auto nn = gvd::test::brute_nearest(r.scene, p);
      const std::set<ObjectId> claimed{cell.object, cell.other[v]};
      // The claimed pair is right when no third object is nearer than the farther of the two
      // (up to kTie: a junction).
      const double third = !claimed.count(nn.object)   ? nn.distance
                           : !claimed.count(nn.second) ? nn.second_distance
                                                       : 1e300;
      const double far = std::max(da, db);
      right += third >= far * (1 - kTie) ? 1 : 0;
      if (explain && third < far * (1 - kTie) && a.explained < 10) {
        ++a.explained;
        std::printf(
            "wrong pair: vertex (%.17g %.17g %.17g) claims %s %.9e | %s %.9e; nearest %s "
            "%.9e, %s %.9e (third nearer by %.2e of the distance)\n",
            p.x, p.y, p.z, r.scene.objects[cell.object].label.c_str(), da,
            r.scene.objects[cell.other[v]].label.c_str(), db,
            r.scene.objects[nn.object].label.c_str(), nn.distance,
            r.scene.objects[nn.second].label.c_str(), nn.second_distance, (far - third) / far);
      }
      strict += third >= far ? 1 : 0;
      a.off_junctions += third < far * (1 - 0.01) ? 1 : 0;
    }
  }
  // Orientation, stepping a quarter of the local leaf off each sampled simplex (as the
  // suite's expect_valid does); reported, not judged.
  const gvd::test::Orientation o = gvd::test::measure_orientation(
      r.scene, r.gvd,
      [&](Vec3 c) {
        const uint32_t leaf = r.octree.locate(r.domain.to_unit(c));
        return 0.25 * std::ldexp(r.domain.side, -r.octree.level[leaf]);
      },
      budget);
  a.flipped = o.tested > 0 ? o.flipped / o.tested : 0;
  a.vertices = gaps.size();
  if (!gaps.empty()) {
    std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
    a.median_gap = gaps[gaps.size() / 2];
    a.right_pair = static_cast<double>(right) / gaps.size();
    a.strict_pair = static_cast<double>(strict) / gaps.size();
  }
  return a;
}

/// Prints each GVD triangle that crosses an object triangle: its cell, its vertices with their
/// claimed other object and brute-force distances to the cell's object and to the crossed one.
void explain_crossings(const GvdResult& r) {
  const Scene& scene = r.scene;
  if (scene.dimension != 3) return;
  for (const GvdCell& cell : r.gvd.cells) {
    for (size_t s = 0; s + 3 <= cell.indices.size(); s += 3) {
      const Vec3 g[3] = {cell.positions[cell.indices[s]], cell.positions[cell.indices[s + 1]],
                         cell.positions[cell.indices[s + 2]]};
      for (const gvd::scene::SceneObject& o : scene.objects) {
        for (size_t t = 0; t < o.simplices.size(); ++t) {
          const Vec3 a = o.vertices[o.simplices[t].v[0]], b = o.vertices[o.simplices[t].v[1]],
                     c = o.vertices[o.simplices[t].v[2]];
          bool apart = false;  // bounding boxes apart: no crossing
          for (int i = 0; i < 3; ++i) {
            apart = apart || std::max({a[i], b[i], c[i]}) < std::min({g[0][i], g[1][i], g[2][i]}) ||
                    std::min({a[i], b[i], c[i]}) > std::max({g[0][i], g[1][i], g[2][i]});
          }
          if (apart) continue;
          bool hit = false;
          for (int e = 0; e < 3 && !hit; ++e) {
            hit = gvd::test::segment_hits_triangle(g[e], g[(e + 1) % 3], a, b, c);
          }
          hit = hit || gvd::test::segment_hits_triangle(a, b, g[0], g[1], g[2]) ||
                gvd::test::segment_hits_triangle(b, c, g[0], g[1], g[2]) ||
                gvd::test::segment_hits_triangle(c, a, g[0], g[1], g[2]);
          if (!hit) continue;
          const ObjectId crossed = static_cast<ObjectId>(&o - scene.objects.data());
          std::printf("crossing: cell %s simplex %zu crosses %s triangle %zu\n",
                      scene.objects[cell.object].label.c_str(), s / 3, o.label.c_str(), t);
          std::printf(
              "  object triangle (%.17g %.17g %.17g) (%.17g %.17g %.17g) (%.17g %.17g %.17g)\n",
              a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z);
          for (int k = 0; k < 3; ++k) {
            const uint32_t v = cell.indices[s + k];
            const ObjectId other = cell.other[v];
            std::printf(
                "  vertex (%.17g %.17g %.17g) other %s d(cell) %.3e d(other) %.3e d(crossed) "
                "%.3e\n",
                g[k].x, g[k].y, g[k].z,
                other == gvd::scene::kNoObject ? "-" : scene.objects[other].label.c_str(),
                gvd::test::brute_distance(scene, cell.object, g[k]),
                other == gvd::scene::kNoObject ? -1.0
                                               : gvd::test::brute_distance(scene, other, g[k]),
                gvd::test::brute_distance(scene, crossed, g[k]));
          }
          // The leaves that hold the triangle's vertices (unit domain), with their marks.
          for (int k = 0; k < 3; ++k) {
            const Vec3 u = r.domain.to_unit(g[k]);
            for (uint32_t leaf = 0; leaf < r.octree.leaf_count(); ++leaf) {
              const gvd::Box box = r.octree.box(leaf);
              bool in = true;
              for (int i = 0; i < 3; ++i)
                in = in && u[i] >= box.lo[i] - 1e-12 && u[i] <= box.hi[i] + 1e-12;
              if (!in) continue;
              std::printf(
                  "  vertex %d unit (%.9g %.9g %.9g) leaf %u level %d lo (%.9g %.9g %.9g) "
                  "hi (%.9g %.9g %.9g) certified %d object %d\n",
                  k, u.x, u.y, u.z, leaf, r.octree.level[leaf], box.lo.x, box.lo.y, box.lo.z,
                  box.hi.x, box.hi.y, box.hi.z,
                  r.octree.certified.empty() ? -1 : r.octree.certified[leaf],
                  static_cast<int>(r.octree.object[leaf]));
            }
          }
        }
      }
    }
  }
}

/// Every vertex of the scene moved by `f`.
template <class F>
Scene moved(Scene s, F f) {
  for (gvd::scene::SceneObject& o : s.objects)
    for (Vec3& v : o.vertices) v = f(v);
  return s;
}

/// The objects of `b` added to `a`, labels suffixed.
Scene joined(Scene a, const Scene& b, const std::string& suffix) {
  for (gvd::scene::SceneObject o : b.objects) {
    o.label += suffix;
    a.objects.push_back(std::move(o));
  }
  return a;
}

gvd::test::ShaftInBoreOptions shaft(int sides, double gap) {
  gvd::test::ShaftInBoreOptions o;
  o.sides = sides;
  o.gap = gap;
  return o;
}

/// Writes each scene to DIR/NAME.json and prints the paths; 1 when one cannot be written.
int write_scenes(const std::vector<std::pair<std::string, Scene>>& out, const std::string& dir);

int write_variants(const std::string& dir) {
  const Vec3 z{0, 0, 1};
  std::vector<std::pair<std::string, Scene>> out;
  out.emplace_back("sphere_lattice", gvd::bench::make_sphere_lattice());
  for (double gap : {1e-4, 1e-5}) {
    char g[16];
    std::snprintf(g, sizeof g, "%.0e", gap);
    const std::string tag = std::string("_") + g;
    for (int sides : {3, 4, 7, 8, 12, 30}) {
      out.emplace_back("shaft" + std::to_string(sides) + tag,
                       gvd::test::make_shaft_in_bore(shaft(sides, gap)));
    }
    // A hexagonal shaft turned about its axis by 17 degrees, and one laid along x.
    out.emplace_back("hex_turned" + tag,
                     moved(gvd::test::make_shaft_in_bore(shaft(6, gap)),
                           [&](Vec3 v) { return gvd::test::rotate(v, z, 17 * M_PI / 180); }));
    out.emplace_back("hex_along_x" + tag,
                     moved(gvd::test::make_shaft_in_bore(shaft(6, gap)), [](Vec3 v) {
                       return Vec3{v.z, v.x, v.y};
                     }));
    // Six stacked plates with flush sides, turned 0.7 rad about (2, -1, 3) and moved 1000
    // from the origin, where their doubles carry ~1e-13 of rounding
    // (ComputeGvd.FlushPlatesFarFromTheOriginStayCheap3D at 1e-5).
    gvd::test::StackedPlatesOptions plates;
    plates.gap = gap;
    out.emplace_back("stacked_plates_far" + tag,
                     moved(gvd::test::make_stacked_plates(plates), [](Vec3 v) {
                       return gvd::test::rotate(v, Vec3{2, -1, 3} / std::sqrt(14.0), 0.7) +
                              Vec3{1000, -500, 250};
                     }));
    // A cube in a cubic cavity whose shell is written inside out (normals into the block's
    // material): the certificates take the material side from the nesting.
    gvd::test::CubeInCavityOptions cube;
    cube.gap = gap;
    cube.cavity_inside_out = true;
    out.emplace_back("cube_in_turned_cavity" + tag, gvd::test::make_cube_in_cavity(cube));
    // A plate over a slab whose bottom is a 4 x 4 grid of quads meeting the side faces at
    // T-junctions (no edge of the bottom's rim has one triangle across it).
    const double plate_g = gap * 1.1;  // the slab spans 1: E = 1
    out.emplace_back(
        "plate_t_junctions" + tag,
        gvd::test::make_scene(3, {gvd::test::make_box("slab", {0, 0, 0}, {1, 1, 0.1}),
                                  gvd::test::make_box_with_split_bottom(
                                      "plate", {0.1, 0.1, 0.1 + plate_g}, {0.9, 0.9, 0.2}, 4)}));
    // Two blades in slots, the second turned by 30 degrees about y against the first: one
    // octree frame cannot serve both.
    gvd::test::BladeInSlotOptions blade;
    blade.gap = gap * 0.5;  // the joined scene's domain is about twice as large
    const Scene one = gvd::test::make_blade_in_slot(blade);
    const Scene two = moved(one, [](Vec3 v) {
      return gvd::test::rotate(v - Vec3{0.5, 0, 0.5}, Vec3{0, 1, 0}, M_PI / 6) + Vec3{2.0, 0, 0.5};
    });
    out.emplace_back("two_blades_turned" + tag, joined(one, two, "_2"));
    // The same, the second turned about two axes (30 degrees about y, then 20 about x): its
    // rims straddle two axes of any frame that fits the first.
    const Scene tilted = moved(one, [](Vec3 v) {
      const Vec3 about_y = gvd::test::rotate(v - Vec3{0.5, 0, 0.5}, Vec3{0, 1, 0}, M_PI / 6);
      return gvd::test::rotate(about_y, Vec3{1, 0, 0}, M_PI / 9) + Vec3{2.0, 0, 0.5};
    });
    out.emplace_back("two_blades_tilted" + tag, joined(one, tilted, "_2"));
    // The same, the second turned by 0.7 rad about the skew axis (2, -1, 3): its rims are
    // square to no axis of a frame that fits the first, and straddle two.
    const Scene skewed = moved(one, [](Vec3 v) {
      return gvd::test::rotate(v - Vec3{0.5, 0, 0.5}, Vec3{2, -1, 3} / std::sqrt(14.0), 0.7) +
             Vec3{2.0, 0, 0.5};
    });
    out.emplace_back("two_blades_skew" + tag, joined(one, skewed, "_2"));
    // Two triangular shafts in their bores side by side (the second moved 1.5 along x), and
    // the same with the second turned like the skew blade: its corners' normals are 120
    // degrees apart, so their rims can straddle all three axes.
    const Scene shaft3 = gvd::test::make_shaft_in_bore(shaft(3, gap * 0.5));
    out.emplace_back("two_shafts3" + tag, joined(shaft3,
                                                 moved(shaft3,
                                                       [](Vec3 v) {
                                                         return v + Vec3{1.5, 0, 0};
                                                       }),
                                                 "_2"));
    const Scene shaft3_skewed = moved(shaft3, [](Vec3 v) {
      return gvd::test::rotate(v - Vec3{0.5, 0.5, 0.5}, Vec3{2, -1, 3} / std::sqrt(14.0), 0.7) +
             Vec3{2.0, 0.5, 0.5};
    });
    out.emplace_back("two_shafts3_skew" + tag, joined(shaft3, shaft3_skewed, "_2"));
    // Two hexagonal shafts, the second turned the same way: its rims' e is its own axis.
    const Scene hex = gvd::test::make_shaft_in_bore(shaft(6, gap * 0.5));
    const Scene hex_skewed = moved(hex, [](Vec3 v) {
      return gvd::test::rotate(v - Vec3{0.5, 0.5, 0.5}, Vec3{2, -1, 3} / std::sqrt(14.0), 0.7) +
             Vec3{2.0, 0.5, 0.5};
    });
    out.emplace_back("two_hex_skew" + tag, joined(hex, hex_skewed, "_2"));
    // Turned 0.7 rad about (2, -1, 3), in doubles and rounded to float32 (an STL or glTF of
    // a tilted assembly, whose faces are flat only to the rounding: snap_faces.h).
    auto turned = [](Scene s, bool float32) {
      s = moved(std::move(s), [](Vec3 v) {
        return gvd::test::rotate(v, Vec3{2, -1, 3} / std::sqrt(14.0), 0.7);
      });
      if (float32) gvd::test::round_to_float32(s);
      return s;
    };
    gvd::test::BladeInSlotOptions full;
    full.gap = gap;
    gvd::test::StackedPlatesOptions inset;
    inset.gap = gap;
    inset.inset = 0.1;
    out.emplace_back("inset_plates_turned" + tag,
                     turned(gvd::test::make_stacked_plates(inset), false));
    out.emplace_back("blade_in_slot_f32_turned" + tag,
                     turned(gvd::test::make_blade_in_slot(full), true));
    out.emplace_back("hex_f32_turned" + tag,
                     turned(gvd::test::make_shaft_in_bore(shaft(6, gap)), true));
    out.emplace_back("inset_plates_f32_turned" + tag,
                     turned(gvd::test::make_stacked_plates(inset), true));
    // A slot of three boxes in one object (support/scenes.h): walls standing on the floor,
    // the same with welded corners (an STL), walls pushed into the floor. E = 1.
    for (const auto& [name, walls_from, weld] :
         {std::tuple{"slot_of_boxes", 0.2, false}, std::tuple{"slot_of_welded_boxes", 0.2, true},
          std::tuple{"slot_of_pushed_boxes", 0.1, false}}) {
      gvd::test::SlotOfPartsOptions parts;
      parts.walls_from = walls_from;
      parts.weld = weld;
      parts.gap = gap * 1.1;
      out.emplace_back(std::string(name) + tag, gvd::test::make_slot_of_parts(parts));
    }
  }
  return write_scenes(out, dir);
}

int write_scenes(const std::vector<std::pair<std::string, Scene>>& out, const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    std::fprintf(stderr, "gvd_audit: cannot create %s: %s\n", dir.c_str(), ec.message().c_str());
    return 1;
  }
  for (const auto& [name, scene] : out) {
    const std::string path = dir + "/" + name + ".json";
    std::ofstream f(path);
    f << gvd::scene::scene_to_json(scene);
    if (!f) {
      std::fprintf(stderr, "gvd_audit: cannot write %s\n", path.c_str());
      return 1;
    }
    std::printf("%s\n", path.c_str());
  }
  return 0;
}

// Real meshes with their gaps known by construction (support/real_mesh_scenes.h): the issue's
// two bunnies 3e-5 apart and teapot in a box 1e-3 outside it (with 1e-2 and 1e-4 beside it),
// and two Stanford dragons (the repository's second resolution) 1e-4 apart.
int write_real(const std::string& corpus, const std::string& dir) {
  std::vector<std::pair<std::string, Scene>> out;
  const gvd::scene::SceneObject bunny = gvd::test::load_corpus_object(corpus, "bunny.obj", "bunny");
  out.emplace_back("two_bunnies_3e-5", gvd::test::mirrored_pair(bunny, "bunny_mirrored", 3e-5));
  const gvd::scene::SceneObject teapot =
      gvd::test::load_corpus_object(corpus, "teapot.obj", "teapot");
  for (const auto& [tag, gap] : {std::pair{"1e-2", 1e-2}, {"1e-3", 1e-3}, {"1e-4", 1e-4}}) {
    out.emplace_back(std::string("teapot_in_box_") + tag,
                     gvd::test::boxed(teapot, "box", gap, 0.25));
  }
  const gvd::scene::SceneObject dragon =
      gvd::test::load_corpus_object(corpus, "dragon_res2.ply", "dragon");
  out.emplace_back("two_dragons_1e-4", gvd::test::mirrored_pair(dragon, "dragon_mirrored", 1e-4));
  return write_scenes(out, dir);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  std::string refine = "certified";
  std::string frame = "auto";
  size_t budget = 3000;
  bool explain = false;
  bool full = false;
  bool junctions = true;  // as the product's default
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--write-variants" && i + 1 < argc) return write_variants(argv[++i]);
    if (a == "--write-real" && i + 2 < argc) return write_real(argv[i + 1], argv[i + 2]);
    if (a == "--refine" && i + 1 < argc) {
      refine = argv[++i];
    } else if (a == "--frame" && i + 1 < argc) {
      frame = argv[++i];
    } else if (a == "--full") {
      full = true;
    } else if (a == "--junctions" && i + 1 < argc) {
      junctions = std::string(argv[++i]) != "off";
    } else if (a == "--explain") {
      explain = true;
    } else if (a == "--budget" && i + 1 < argc) {
      budget = std::strtoull(argv[++i], nullptr, 10);
    } else {
      files.push_back(a);
    }
  }
  int failed = 0;
  for (const std::string& file : files) {
    try {
      gvd::pipeline::PipelineOptions o;
      o.threads = 2;
      o.refine = gvd::pipeline::parse_choice<gvd::pipeline::RefineRule>(refine);
      o.domain.frame = gvd::scene::parse_domain_frame(frame);
      if (full) o.resolution = gvd::pipeline::GvdResolution::kFull;
      o.junctions = junctions;
      // Resets the peak (VmHWM) to what is resident now, after handing what the last scene
      // left in malloc's free lists back to the system (else a failed big scene's memory
      // stays resident and counts in every later row's peak).
      malloc_trim(0);
      std::ofstream("/proc/self/clear_refs") << "5";
      const auto t0 = std::chrono::steady_clock::now();
      const Scene input = gvd::scene::load_scene(std::span(&file, 1));
      GvdResult r = gvd::pipeline::compute_gvd(input, o);
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      // The oracles measure against the file's coordinates, not the ones the pipeline moved
      // onto exact planes (a float32 input's faces, snap_faces.h).
      for (size_t i = 0; i < r.scene.objects.size() && i < input.objects.size(); ++i)
        if (r.scene.objects[i].vertices.size() == input.objects[i].vertices.size())
          r.scene.objects[i].vertices = input.objects[i].vertices;
      const Audit a = audit(r, budget, explain);
      if (explain) explain_crossings(r);
      const bool bad = a.open_edges || a.crossings || a.median_gap > 0.05 || a.right_pair < 0.95;
      failed += bad;
      std::printf(
          "%-40s %s leaves %9llu depth %2d %7.2f s %6.0f MiB simplices %8llu | open %zu "
          "crossing %zu median gap %.2e right pair %.4f (no ties %.4f; %zu of %zu vertices "
          "off by > 1 %%) | flipped %.2f %% | unseen %llu ambiguous %llu%s\n",
          file.c_str(), bad ? "FAIL" : "ok  ", static_cast<unsigned long long>(r.stats.leaves),
          r.stats.depth, seconds, gvd::peak_rss_bytes() / 1048576.0,
          static_cast<unsigned long long>(r.stats.gvd_simplices), a.open_edges, a.crossings,
          a.median_gap, a.right_pair, a.strict_pair, a.off_junctions, a.vertices, 100 * a.flipped,
          static_cast<unsigned long long>(r.stats.unseen_left),
          static_cast<unsigned long long>(r.stats.ambiguous_at_limit),
          r.scene.warnings.empty() ? "" : " (scene warnings)");
    } catch (const std::exception& e) {
      ++failed;
      std::printf("%-40s FAIL %s\n", file.c_str(), e.what());
    }
    std::fflush(stdout);
  }
  return failed ? 1 : 0;
}

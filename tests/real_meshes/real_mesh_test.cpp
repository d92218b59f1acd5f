// The pipeline on real meshes (the corpus that write_corpus.mjs writes into the build tree
// before these tests run: ctest's fixture real_meshes), each scene with its gap known by
// construction (support/real_mesh_scenes.h).

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

#include "gvd/octree/build_octree.h"
#include "gvd/pipeline/pipeline.h"
#include "gvd/scene/load_scene.h"
#include "support/expect_valid.h"
#include "support/oracles.h"
#include "support/real_mesh_scenes.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::pipeline;

namespace {

const std::string kCorpus = GVD_REAL_MESH_DIR;

GvdResult run_defaults(Scene scene) {
  PipelineOptions o;
  o.threads = 2;
  return compute_gvd(std::move(scene), o);
}

// The one edge of a two-object result.
const DualEdge& only_edge(const GvdResult& r) {
  EXPECT_EQ(r.graph.edges.size(), 1u);
  return r.graph.edges.at(0);
}

bool warns(const GvdResult& r, WarningKind kind) {
  for (const SceneWarning& w : r.scene.warnings) {
    if (w.kind == kind) return true;
  }
  return false;
}

// A mirrored pair's gap from its vertices alone: the least x of the image less the largest x
// of the object.
double mirror_gap(const Scene& pair) {
  return test::bounds(pair.objects[1]).lo.x - test::bounds(pair.objects[0]).hi.x;
}

// The finest cell of a scene's default domain, user units.
double finest_cell(const Scene& scene) {
  return std::ldexp(make_domain(scene, {}).side, -resolve_max_depth(3, 0));
}

// The judged case: two bunnies 3e-5 apart, default options. The reported gap is the
// true one (within 2 %), so is the clearance (half of it), and the pair is not "touching".
TEST(RealMeshes, TwoBunniesThreeE5ApartKeepTheirGapWithDefaultOptions) {
  const Scene scene = test::mirrored_pair(test::load_corpus_object(kCorpus, "bunny.obj", "bunny"),
                                          "mirrored", 3e-5);
  // The construction's gap, from the vertices alone.
  const double truth = mirror_gap(scene);
  ASSERT_NEAR(truth, 3e-5, 1e-12);
  const GvdResult r = run_defaults(scene);
  const DualEdge& e = only_edge(r);
  EXPECT_FALSE(e.touching);
  EXPECT_FALSE(warns(r, WarningKind::kObjectsTouch));
  EXPECT_NEAR(e.gap, truth, 0.02 * truth);
  EXPECT_NEAR(e.min_clearance, 0.5 * truth, 0.02 * 0.5 * truth);
  test::expect_valid(r);
}

// The judged case again with a translated copy, whose nearest features are not a mirror pair
// of vertices: the bunny at half size, so that the domain is about 11 units as in the issue,
// and a copy moved along x by 4.38542262464, where the brute-force mesh distance is
// 3.00000004e-5 (the offset was found by bisection on that distance; measured again here).
TEST(RealMeshes, TwoTranslatedBunniesThreeE5ApartOnAnElevenUnitDomain) {
  SceneObject a = test::load_corpus_object(kCorpus, "bunny.obj", "bunny");
  for (Vec3& v : a.vertices) v = v * 0.5;
  SceneObject b = a;
  b.label = "bunny_2";
  for (Vec3& v : b.vertices) v.x += 4.38542262464;
  const double truth = test::brute_mesh_distance(a, b);
  ASSERT_NEAR(truth, 3e-5, 1e-7);
  const Scene scene = test::make_scene(3, {a, b});
  EXPECT_LE(make_domain(scene, {}).side, 11.0);
  const GvdResult r = run_defaults(scene);
  const DualEdge& e = only_edge(r);
  EXPECT_FALSE(e.touching);
  EXPECT_NEAR(e.gap, truth, 0.02 * truth);
  EXPECT_NEAR(e.min_clearance, 0.5 * truth, 0.02 * 0.5 * truth);
}

// Contact is decided by the lattice's resolution, one finest cell: a pair 1.1 cells apart is
// separated with its true clearance; 0.9 cells apart it is touching, says so, and still
// reports its gap.
TEST(RealMeshes, BunniesAreTouchingOnlyBelowOneFinestCell) {
  const SceneObject bunny = test::load_corpus_object(kCorpus, "bunny.obj", "bunny");
  const double h = finest_cell(test::mirrored_pair(bunny, "mirrored", 0));
  for (const double cells : {1.1, 0.9}) {
    SCOPED_TRACE(cells);
    const Scene scene = test::mirrored_pair(bunny, "mirrored", cells * h);
    const double truth = mirror_gap(scene);
    const GvdResult r = run_defaults(scene);
    const DualEdge& e = only_edge(r);
    EXPECT_NEAR(e.gap, truth, 0.02 * truth);
    if (cells > 1) {
      EXPECT_FALSE(e.touching);
      EXPECT_NEAR(e.min_clearance, 0.5 * truth, 0.02 * 0.5 * truth);
      test::expect_valid(r);
    } else {
      EXPECT_TRUE(e.touching);
      EXPECT_EQ(e.min_clearance, 0);
      EXPECT_TRUE(warns(r, WarningKind::kObjectsTouch));
    }
  }
}

// The Utah teapot (992 triangles) in a closed box whose inner faces are g outside its bounding
// box, over g = 1e-2, 1e-3, 1e-4 (the teapot is 32 units long): the exact gap and clearance
// each time, and leaves that grow at most like 1/g (the paper's rule: 1/g^2 where the box's
// floor faces the teapot's).
TEST(RealMeshes, TeapotInABoxKeepsItsGapAndCostsAtMostOneOverTheGap) {
  const SceneObject teapot = test::load_corpus_object(kCorpus, "teapot.obj", "teapot");
  std::vector<double> gaps, leaves;
  for (const double gap : {1e-2, 1e-3, 1e-4}) {
    SCOPED_TRACE(gap);
    const GvdResult r = run_defaults(test::boxed(teapot, "box", gap, 0.25));
    const DualEdge& e = only_edge(r);
    EXPECT_FALSE(e.touching);
    EXPECT_NEAR(e.gap, gap, 1e-6 * gap);
    EXPECT_NEAR(e.min_clearance, 0.5 * gap, 0.02 * 0.5 * gap);
    if (gap == 1e-3) test::expect_valid(r);
    gaps.push_back(gap);
    leaves.push_back(static_cast<double>(r.octree.leaf_count()));
  }
  const double exponent =
      std::log(leaves.back() / leaves.front()) / std::log(gaps.front() / gaps.back());
  EXPECT_LE(exponent, 1.0) << "leaves " << leaves[0] << ", " << leaves[1] << ", " << leaves[2];
}

// The Stanford dragon's own PLY files, as the Stanford Range Repository made them: every face
// of the header's count is read (kept, or removed as degenerate with a warning that counts it)
// and every vertex.
TEST(RealMeshes, DragonPlyFilesAreReadWhole) {
  for (const char* file : {"dragon_res4.ply", "dragon_res3.ply", "dragon_res2.ply", "dragon.ply"}) {
    SCOPED_TRACE(file);
    const std::string path = kCorpus + "/" + file;
    // The header's counts, read here by hand.
    std::ifstream in(path);
    ASSERT_TRUE(in) << path;
    uint64_t vertices = 0, faces = 0;
    for (std::string line; std::getline(in, line) && line != "end_header";) {
      std::istringstream words(line);
      std::string word, element;
      uint64_t count = 0;
      if (words >> word >> element >> count && word == "element") {
        (element == "vertex" ? vertices : faces) = count;
      }
    }
    ASSERT_GT(faces, 0u);
    const Scene s = load_scene(std::span<const std::string>(&path, 1));
    ASSERT_EQ(s.objects.size(), 1u);
    EXPECT_EQ(s.objects[0].vertices.size(), vertices);
    uint64_t degenerate = 0;
    for (const SceneWarning& w : s.warnings) {
      if (w.kind == WarningKind::kDegenerateSimplices) degenerate += w.count;
    }
    EXPECT_EQ(s.objects[0].simplices.size() + degenerate, faces);
  }
}

}  // namespace
}  // namespace gvd

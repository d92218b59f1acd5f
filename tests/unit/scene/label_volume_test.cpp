// Label volumes: the .npy reader against files written by our writer and by hand, and the
// boundary surfaces against voxel counts (enclosed volume and area by the divergence theorem),
// closedness and exact gaps under anisotropic spacing.
#include "gvd/scene/label_volume.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "gvd/common/error.h"
#include "gvd/io/write_grid.h"
#include "gvd/pipeline/pipeline.h"

namespace gvd {
namespace {

/// A hand-made .npy (format 1.0) of `descr` with the given header shape text and raw data.
std::vector<uint8_t> npy(const std::string& descr, const std::string& shape, bool fortran,
                         const void* data, size_t bytes) {
  std::string header = "{'descr': '" + descr +
                       "', 'fortran_order': " + (fortran ? "True" : "False") +
                       ", 'shape': " + shape + ", }";
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::vector<uint8_t> out(10 + header.size() + bytes);
  const uint8_t lead[10] = {0x93,
                            'N',
                            'U',
                            'M',
                            'P',
                            'Y',
                            1,
                            0,
                            static_cast<uint8_t>(header.size() & 0xFF),
                            static_cast<uint8_t>(header.size() >> 8)};
  std::memcpy(out.data(), lead, 10);
  std::memcpy(out.data() + 10, header.data(), header.size());
  if (bytes > 0) std::memcpy(out.data() + 10 + header.size(), data, bytes);
  return out;
}

/// The volume enclosed by a closed, outward-oriented triangle mesh (divergence theorem).
double enclosed_volume(const SceneObject& o) {
  double v = 0;
  for (const Simplex& s : o.simplices) {
    v += dot(o.vertices[s.v[0]], cross(o.vertices[s.v[1]], o.vertices[s.v[2]])) / 6;
  }
  return v;
}

/// The area enclosed by a closed, counter-clockwise polygon soup (shoelace).
double enclosed_area(const SceneObject& o) {
  double a = 0;
  for (const Simplex& s : o.simplices) {
    const Vec3 p = o.vertices[s.v[0]], q = o.vertices[s.v[1]];
    a += (p.x * q.y - q.x * p.y) / 2;
  }
  return a;
}

TEST(LabelVolume, ReadsOurOwnNpyAndHandMadeOnes) {
  // (nz, ny, nx) = (2, 3, 4), x fastest, through the grid writer.
  std::vector<int32_t> values(24);
  for (int n = 0; n < 24; ++n) values[n] = n % 5;
  const uint64_t shape[3] = {2, 3, 4};
  const LabelVolume v =
      read_label_volume_npy(npy_bytes(GridValueType::kInt32, shape, values.data()), "ours.npy");
  EXPECT_EQ(v.dimension, 3);
  EXPECT_EQ(v.size, (std::array<uint64_t, 3>{4, 3, 2}));
  for (int n = 0; n < 24; ++n) EXPECT_EQ(v.labels[n], static_cast<uint64_t>(n % 5));
  // uint64 in 2D, and uint8 in Fortran order (the first axis fastest).
  const std::vector<uint64_t> big = {1ull << 40, 2, 3, 4, 5, 6};
  const LabelVolume b = read_label_volume_npy(npy("<u8", "(2, 3)", false, big.data(), 48), "b");
  EXPECT_EQ(b.dimension, 2);
  EXPECT_EQ(b.size, (std::array<uint64_t, 3>{3, 2, 1}));
  EXPECT_EQ(b.labels[0], 1ull << 40);
  const uint8_t f[6] = {1, 4, 2, 5, 3, 6};  // [[1,2,3],[4,5,6]] in Fortran order
  const LabelVolume fo = read_label_volume_npy(npy("|u1", "(2, 3)", true, f, 6), "f");
  EXPECT_EQ(fo.labels, (std::vector<uint64_t>{1, 2, 3, 4, 5, 6}));
}

TEST(LabelVolume, BadFilesSayWhatAndWhich) {
  const int32_t negative[2] = {1, -2};
  try {
    read_label_volume_npy(npy("<i4", "(1, 2)", false, negative, 8), "seg.npy");
    FAIL() << "a negative label must be an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidScene);
    EXPECT_NE(e.detail().find("voxel 1"), std::string::npos) << e.detail();
  }
  // A .npy whose content is no label volume is invalid input naming the field (422 over
  // HTTP, like a broken mesh file), not an unsupported format (415): the format is right.
  const float floats[2] = {1, 2};
  const uint8_t bytes16[16] = {};
  struct Case {
    std::vector<uint8_t> bytes;
    ErrorCode code;
    std::string says;
  };
  for (const Case& c : {
           Case{npy("<f4", "(1, 2)", false, floats, 8), ErrorCode::kInvalidScene, "dtype <f4"},
           Case{npy(">i4", "(1, 2)", false, negative, 8), ErrorCode::kInvalidScene, "dtype >i4"},
           Case{npy("|b1", "(1, 2)", false, bytes16, 2), ErrorCode::kInvalidScene, "dtype |b1"},
           Case{npy("<i4", "(2,)", false, negative, 8), ErrorCode::kInvalidScene,
                "shape (2,): a label volume has 2 or 3 dimensions"},
           Case{npy("|u1", "(1, 2, 2, 4)", false, bytes16, 16), ErrorCode::kInvalidScene, "not 4"},
           Case{npy("|u1", "(0, 2)", false, bytes16, 0), ErrorCode::kInvalidScene, "no voxels"},
           Case{npy("<i4", "(4, 4)", false, negative, 8), ErrorCode::kInvalidScene, "truncated"},
           Case{std::vector<uint8_t>{'n', 'o', 't', ' ', 'n', 'p', 'y', 0, 0, 0},
                ErrorCode::kUnsupportedFormat, "no numpy magic"},
           // 2^22 x 2^21 x 2^21 voxels: 2^64, which wraps to 0 in 64 bits.
           Case{npy("|u1", "(4194304, 2097152, 2097152)", false, bytes16, 16),
                ErrorCode::kInvalidScene, "truncated"},
       }) {
    // The header alone (what the server checks before it queues a volume) finds each of
    // these as the full reader does.
    for (const bool header_only : {false, true}) {
      try {
        if (header_only) {
          read_label_volume_header(c.bytes, "seg.npy");
        } else {
          read_label_volume_npy(c.bytes, "seg.npy");
        }
        ADD_FAILURE() << c.says << ": malformed input must be an error";
      } catch (const Error& e) {
        EXPECT_EQ(e.code(), c.code) << e.detail();
        EXPECT_NE(e.detail().find("seg.npy"), std::string::npos) << e.detail();
        EXPECT_NE(e.detail().find(c.says), std::string::npos) << e.detail();
      }
    }
  }
  // What the header alone cannot see: the labels' values.
  const LabelVolumeHeader h =
      read_label_volume_header(npy("<i4", "(1, 2)", false, negative, 8), "seg.npy");
  EXPECT_EQ(h.dimension, 2);
  EXPECT_EQ(h.size, (std::array<uint64_t, 3>{2, 1, 1}));
  EXPECT_EQ(h.width, 4);
  EXPECT_TRUE(h.is_signed);
}

// Random labels in a small block: every label's boundary is closed (or merely non-manifold
// where its voxels touch along an edge), outward, and encloses exactly its voxels' volume.
TEST(LabelVolume, BoundariesEncloseTheirVoxels3d) {
  LabelVolume v;
  v.size = {5, 4, 3};
  std::mt19937 rng(5);
  for (int n = 0; n < 60; ++n) v.labels.push_back(rng() % 4);
  LabelVolumeOptions o;
  o.spacing = {0.5, 2, 3};
  o.origin = {1, -2, 7};
  const Scene s = scene_from_label_volume(v, o);
  std::map<uint64_t, int> count;
  for (uint64_t l : v.labels) ++count[l];
  ASSERT_EQ(s.objects.size(), count.size() - (count.count(0) ? 1 : 0));
  for (const SceneObject& obj : s.objects) {
    const uint64_t label = std::stoull(obj.label.substr(6));
    EXPECT_NE(label, 0u) << "0 is the background";
    EXPECT_NEAR(enclosed_volume(obj), count[label] * 0.5 * 2 * 3, 1e-9) << obj.label;
    EXPECT_EQ(mesh_topology(obj, 3).open, 0u) << obj.label;
    for (const Vec3& p : obj.vertices) {
      EXPECT_GE(p.x, 1 - 1e-12);
      EXPECT_LE(p.z, 7 + 3 * 3 + 1e-12);
    }
  }
  // Touching labels are said so, with the number of face-adjacent pairs (brute force).
  std::set<std::pair<uint64_t, uint64_t>> adjacent;
  auto at = [&](uint64_t i, uint64_t j, uint64_t k) { return v.labels[(k * 4 + j) * 5 + i]; };
  for (uint64_t k = 0; k < 3; ++k)
    for (uint64_t j = 0; j < 4; ++j)
      for (uint64_t i = 0; i < 5; ++i)
        for (const auto& [di, dj, dk] :
             {std::tuple{1, 0, 0}, std::tuple{0, 1, 0}, std::tuple{0, 0, 1}}) {
          if (i + di >= 5 || j + dj >= 4 || k + dk >= 3) continue;
          const uint64_t a = at(i, j, k), b = at(i + di, j + dj, k + dk);
          if (a != b && a != 0 && b != 0) adjacent.emplace(std::min(a, b), std::max(a, b));
        }
  const auto w = std::find_if(s.warnings.begin(), s.warnings.end(), [](const SceneWarning& x) {
    return x.kind == WarningKind::kLabelsTouch;
  });
  ASSERT_NE(w, s.warnings.end());
  EXPECT_EQ(w->count, adjacent.size());
  // With no background, label 0 is an object too.
  o.background.reset();
  EXPECT_EQ(scene_from_label_volume(v, o).objects.size(), count.size());
}

TEST(LabelVolume, BoundariesEncloseTheirPixels2d) {
  LabelVolume v;
  v.dimension = 2;
  v.size = {6, 5, 1};
  std::mt19937 rng(9);
  for (int n = 0; n < 30; ++n) v.labels.push_back(rng() % 3);
  LabelVolumeOptions o;
  o.spacing = {1.5, 0.25, 1};
  const Scene s = scene_from_label_volume(v, o);
  std::map<uint64_t, int> count;
  for (uint64_t l : v.labels) ++count[l];
  for (const SceneObject& obj : s.objects) {
    const uint64_t label = std::stoull(obj.label.substr(6));
    EXPECT_NEAR(enclosed_area(obj), count[label] * 1.5 * 0.25, 1e-12) << obj.label;
    EXPECT_EQ(mesh_topology(obj, 2).open, 0u) << obj.label;
  }
}

// Two slabs two voxels apart along z, voxels 10 deep: the GVD between them is one interface
// and their gap is exactly 2 x 10 (anisotropic spacing honoured by the whole pipeline).
TEST(LabelVolume, AnisotropicGapIsMeasuredExactly) {
  LabelVolume v;
  v.size = {4, 4, 6};
  for (uint64_t k = 0; k < 6; ++k)
    for (int n = 0; n < 16; ++n) v.labels.push_back(k < 2 ? 7 : (k < 4 ? 0 : 9));
  LabelVolumeOptions o;
  o.spacing = {1, 1, 10};
  PipelineOptions po;
  po.threads = 2;
  const Scene slabs = scene_from_label_volume(v, o);
  for (const SceneWarning& w : slabs.warnings)
    EXPECT_NE(w.kind, WarningKind::kLabelsTouch) << w.detail;
  const GvdResult r = compute_gvd(slabs, po);
  ASSERT_EQ(r.scene.objects.size(), 2u);
  EXPECT_EQ(r.scene.objects[0].label, "label_7");
  ASSERT_EQ(r.graph.edges.size(), 1u);
  EXPECT_NEAR(r.graph.edges[0].gap, 20, 1e-9);
  EXPECT_NEAR(r.graph.edges[0].min_clearance, 10, 1e-9);
}

// A fully packed segmentation (the discrete Voronoi regions of 12 seeds in 10^3 voxels, no
// background): every pair of labels that share a voxel face is a dual-graph pair (exact
// ties between their coincident faces go to the label a point is inside), and every other
// pair reported at least touches along a voxel edge or corner.
TEST(LabelVolume, PackedLabelsGiveTheirFaceAdjacency) {
  const uint64_t n = 10;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, static_cast<double>(n));
  std::vector<Vec3> seeds(12);
  for (Vec3& c : seeds) c = {u(rng), u(rng), u(rng)};
  LabelVolume v;
  v.size = {n, n, n};
  for (uint64_t k = 0; k < n; ++k)
    for (uint64_t j = 0; j < n; ++j)
      for (uint64_t i = 0; i < n; ++i) {
        const Vec3 p{i + 0.5, j + 0.5, k + 0.5};
        uint64_t best = 0;
        for (uint64_t s = 1; s < seeds.size(); ++s)
          if (dist2(p, seeds[s]) < dist2(p, seeds[best])) best = s;
        v.labels.push_back(best + 1);
      }
  auto at = [&](int64_t i, int64_t j, int64_t k) {
    return v.labels[(static_cast<uint64_t>(k) * n + static_cast<uint64_t>(j)) * n +
                    static_cast<uint64_t>(i)];
  };
  std::set<std::pair<uint64_t, uint64_t>> face, near;  // near: sharing a face, edge or corner
  const auto in = [&](int64_t x) { return x >= 0 && x < static_cast<int64_t>(n); };
  for (int64_t k = 0; k < static_cast<int64_t>(n); ++k)
    for (int64_t j = 0; j < static_cast<int64_t>(n); ++j)
      for (int64_t i = 0; i < static_cast<int64_t>(n); ++i)
        for (int dk = -1; dk <= 1; ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              if (!in(i + di) || !in(j + dj) || !in(k + dk)) continue;
              const uint64_t a = at(i, j, k), b = at(i + di, j + dj, k + dk);
              if (a == b) continue;
              const std::pair<uint64_t, uint64_t> pair{std::min(a, b), std::max(a, b)};
              near.insert(pair);
              if (std::abs(di) + std::abs(dj) + std::abs(dk) == 1) face.insert(pair);
            }
  LabelVolumeOptions o;
  o.background.reset();
  PipelineOptions po;
  po.threads = 2;
  const GvdResult r = compute_gvd(scene_from_label_volume(v, o), po);
  std::set<std::pair<uint64_t, uint64_t>> got;
  for (const DualEdge& e : r.graph.edges) {
    const uint64_t a = std::stoull(r.scene.objects[e.a].label.substr(6));
    const uint64_t b = std::stoull(r.scene.objects[e.b].label.substr(6));
    got.insert({std::min(a, b), std::max(a, b)});
  }
  for (const auto& p : face) EXPECT_TRUE(got.count(p)) << "missing " << p.first << "-" << p.second;
  for (const auto& p : got) EXPECT_TRUE(near.count(p)) << "apart " << p.first << "-" << p.second;
}

TEST(LabelVolume, AllBackgroundIsAnError) {
  LabelVolume v;
  v.size = {2, 2, 2};
  v.labels.assign(8, 0);
  EXPECT_THROW(scene_from_label_volume(v, {}), Error);
  LabelVolumeOptions bad;
  bad.spacing = {1, 0, 1};
  v.labels[0] = 1;
  EXPECT_THROW(scene_from_label_volume(v, bad), Error);
}

}  // namespace
}  // namespace gvd

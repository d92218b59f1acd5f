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

using namespace gvd::scene;
using namespace gvd::graph;
using namespace gvd::result;
using namespace gvd::io;
using namespace gvd::pipeline;

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

/// Random labels in an n^3 (2D: n^2) block, with a hole in label 1 (a background voxel with
/// label 1 on all sides) and label 2 on two voxels that touch along an edge only.
LabelVolume random_volume(int dim, uint64_t n, int labels, unsigned seed) {
  LabelVolume v;
  v.dimension = dim;
  v.size = {n, n, dim == 3 ? n : 1};
  std::mt19937 rng(seed);
  const uint64_t count = n * n * (dim == 3 ? n : 1);
  // Blobs rather than noise: each voxel takes the label of a random nearby seed voxel, so
  // that faces merge and rectangles of different sizes meet.
  for (uint64_t t = 0; t < count; ++t) v.labels.push_back(rng() % static_cast<unsigned>(labels));
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<uint64_t> next = v.labels;
    for (uint64_t t = 0; t < count; ++t) {
      const uint64_t i = t % n, j = (t / n) % n, k = t / (n * n);
      const uint64_t bi = i / 3 * 3, bj = j / 3 * 3, bk = dim == 3 ? k / 3 * 3 : 0;
      next[t] = v.labels[(bk * n + bj) * n + bi];  // 3-voxel blocks
    }
    v.labels = next;
    for (int flips = 0; flips < static_cast<int>(count / 6); ++flips)
      v.labels[rng() % count] = rng() % static_cast<unsigned>(labels);
  }
  auto at = [&](uint64_t i, uint64_t j, uint64_t k) -> uint64_t& {
    return v.labels[(k * n + j) * n + i];
  };
  const uint64_t k0 = dim == 3 ? 1 : 0, k1 = dim == 3 ? 3 : 0;
  for (uint64_t k = k0; k <= k1; ++k)
    for (uint64_t j = 1; j <= 3; ++j)
      for (uint64_t i = 1; i <= 3; ++i) at(i, j, k) = 1;
  at(2, 2, dim == 3 ? 2 : 0) = 0;  // the hole
  // Label 2 on two voxels that share an edge only, in a background pocket.
  for (uint64_t k = k0; k <= k1; ++k)
    for (uint64_t j = n - 4; j < n - 1; ++j)
      for (uint64_t i = n - 4; i < n - 1; ++i) at(i, j, k) = 0;
  at(n - 3, n - 3, dim == 3 ? 2 : 0) = 2;
  at(n - 2, n - 2, dim == 3 ? 2 : 0) = 2;
  return v;
}

/// The object of `label` in `s`, if any.
const SceneObject* object_of(const Scene& s, uint64_t label) {
  for (const SceneObject& o : s.objects)
    if (o.label == "label_" + std::to_string(label)) return &o;
  return nullptr;
}

/// Checks that `o` is closed edge to edge: every edge of a simplex is run as often one way as
/// the other (a T-junction leaves a long edge against two short ones and fails this), no
/// vertex lies inside an edge, no two vertices coincide and no simplex is degenerate.
void expect_closed_without_t_junctions(const SceneObject& o, int dim) {
  std::map<std::pair<uint32_t, uint32_t>, int> runs;
  const int corners = dim == 3 ? 3 : 2;
  for (const Simplex& s : o.simplices) {
    for (int c = 0; c < corners; ++c) {
      const uint32_t p = s.v[c], q = s.v[(c + 1) % corners];
      ++runs[{p, q}];
      if (dim == 2) break;  // a segment is one edge
    }
    if (dim == 3) {
      const Vec3 a = o.vertices[s.v[0]], b = o.vertices[s.v[1]], c = o.vertices[s.v[2]];
      EXPECT_GT(norm(cross(b - a, c - a)), 1e-9) << o.label << ": a degenerate triangle";
    }
  }
  if (dim == 2) {
    // Closed in 2D: each vertex is entered as often as it is left.
    std::map<uint32_t, int> balance;
    for (const auto& [e, n] : runs) {
      balance[e.first] += n;
      balance[e.second] -= n;
    }
    for (const auto& [vertex, b] : balance) EXPECT_EQ(b, 0) << o.label << " vertex " << vertex;
  } else {
    for (const auto& [e, n] : runs) {
      const auto back = runs.find({e.second, e.first});
      EXPECT_EQ(back == runs.end() ? 0 : back->second, n)
          << o.label << ": edge " << e.first << "-" << e.second << " is not closed";
    }
  }
  std::set<std::tuple<double, double, double>> seen;
  for (const Vec3& p : o.vertices)
    EXPECT_TRUE(seen.insert({p.x, p.y, p.z}).second) << o.label << ": a vertex twice";
  for (const auto& [e, n] : runs) {
    const Vec3 a = o.vertices[e.first], b = o.vertices[e.second];
    for (uint32_t t = 0; t < o.vertices.size(); ++t) {
      if (t == e.first || t == e.second) continue;
      const Vec3 p = o.vertices[t];
      const double along = dot(p - a, b - a) / dot(b - a, b - a);
      if (along <= 0 || along >= 1) continue;
      EXPECT_GT(norm(cross(p - a, b - a)), 1e-9)
          << o.label << ": vertex " << t << " inside edge " << e.first << "-" << e.second;
    }
  }
}

// Merged faces: each label's surface is closed edge to edge and outward, and encloses exactly
// its voxels (divergence theorem, anisotropic voxels), on random labels with holes and
// edge-only contacts, in 3D and 2D; and it has fewer simplices than the voxel faces.
TEST(LabelVolume, MergedFacesAreClosedAndEncloseTheirVoxels) {
  for (const int dim : {3, 2}) {
    for (unsigned seed = 1; seed <= 4; ++seed) {
      const LabelVolume v = random_volume(dim, 12, 5 + static_cast<int>(seed), seed);
      LabelVolumeOptions o;
      o.spacing = {0.5, 2, 3};
      o.origin = {1, -2, 7};
      const Scene merged = scene_from_label_volume(v, o);
      o.faces = VolumeFaces::kVoxel;
      const Scene voxel = scene_from_label_volume(v, o);
      std::map<uint64_t, int> count;
      for (uint64_t l : v.labels) ++count[l];
      ASSERT_EQ(merged.objects.size(), voxel.objects.size());
      size_t merged_simplices = 0, voxel_simplices = 0;
      for (size_t t = 0; t < merged.objects.size(); ++t) {
        const SceneObject& m = merged.objects[t];
        SCOPED_TRACE("dim " + std::to_string(dim) + " seed " + std::to_string(seed) + " " +
                     m.label);
        EXPECT_EQ(m.label, voxel.objects[t].label);
        const uint64_t label = std::stoull(m.label.substr(6));
        if (dim == 3) {
          EXPECT_NEAR(enclosed_volume(m), count[label] * 0.5 * 2 * 3, 1e-9);
        } else {
          EXPECT_NEAR(enclosed_area(m), count[label] * 0.5 * 2, 1e-9);
        }
        EXPECT_EQ(mesh_topology(m, dim).open, 0u);
        // Non-manifold where the voxel faces are, and nowhere else.
        EXPECT_EQ(mesh_topology(m, dim).non_manifold > 0,
                  mesh_topology(voxel.objects[t], dim).non_manifold > 0);
        expect_closed_without_t_junctions(m, dim);
        merged_simplices += m.simplices.size();
        voxel_simplices += voxel.objects[t].simplices.size();
      }
      EXPECT_LT(merged_simplices, voxel_simplices);
      // The hole and the edge-only contact are there.
      EXPECT_GT(mesh_topology(*object_of(merged, 2), dim).non_manifold, 0u);
    }
  }
}

// A box of one label is 12 triangles (a square: 4 segments) whatever its voxel count, with
// and without touching the volume's side; an L of two boxes takes the corners of the one on
// the other's faces.
TEST(LabelVolume, MergedBoxIsTwelveTriangles) {
  LabelVolume v;
  v.size = {12, 12, 12};
  v.labels.assign(12 * 12 * 12, 0);
  for (uint64_t k = 1; k < 11; ++k)
    for (uint64_t j = 1; j < 11; ++j)
      for (uint64_t i = 1; i < 11; ++i) v.labels[(k * 12 + j) * 12 + i] = 4;
  const Scene box = scene_from_label_volume(v, {});
  ASSERT_EQ(box.objects.size(), 1u);
  EXPECT_EQ(box.objects[0].simplices.size(), 12u);
  EXPECT_EQ(box.objects[0].vertices.size(), 8u);
  EXPECT_NEAR(enclosed_volume(box.objects[0]), 1000, 1e-9);
  LabelVolumeOptions voxel;
  voxel.faces = VolumeFaces::kVoxel;
  EXPECT_EQ(scene_from_label_volume(v, voxel).objects[0].simplices.size(), 6u * 100 * 2);
  // Filling the whole volume: the box is the volume's outside.
  LabelVolume full;
  full.size = {3, 4, 5};
  full.labels.assign(60, 1);
  EXPECT_EQ(scene_from_label_volume(full, {}).objects[0].simplices.size(), 12u);
  // A 10 x 10 square in 2D: 4 segments.
  LabelVolume sq;
  sq.dimension = 2;
  sq.size = {12, 12, 1};
  sq.labels.assign(144, 0);
  for (uint64_t j = 1; j < 11; ++j)
    for (uint64_t i = 1; i < 11; ++i) sq.labels[j * 12 + i] = 3;
  const Scene square = scene_from_label_volume(sq, {});
  EXPECT_EQ(square.objects[0].simplices.size(), 4u);
  EXPECT_NEAR(enclosed_area(square.objects[0]), 100, 1e-12);
  // A 2 x 2 x 1 slab (z 1..2) on a 2 x 1 x 1 bar (y 0..1, z 0..1), counted by hand: the
  // faces x = 0 and x = 2 are each the bar's square (2 triangles) under the slab's rectangle,
  // whose bottom side holds the square's corner (0 or 2, 1, 1) (a strip of 3); the face
  // y = 0 is one 2 x 2 rectangle whose sides x = 0 and x = 2 hold the corners (0 or 2, 0, 1)
  // of those (a strip of 4); the other 6 faces are plain rectangles (2 each): 24.
  LabelVolume l;
  l.size = {2, 2, 2};
  l.labels = {5, 5, 0, 0, 5, 5, 5, 5};  // x fastest: (i, j = 1, k = 0) is empty
  const Scene ell = scene_from_label_volume(l, {});
  EXPECT_EQ(ell.objects[0].simplices.size(), 24u);
  expect_closed_without_t_junctions(ell.objects[0], 3);
  EXPECT_NEAR(enclosed_volume(ell.objects[0]), 6, 1e-12);
}

/// The pairs of labels of a dual graph.
std::set<std::pair<uint64_t, uint64_t>> label_pairs(const GvdResult& r) {
  std::set<std::pair<uint64_t, uint64_t>> got;
  for (const DualEdge& e : r.graph.edges) {
    const uint64_t a = std::stoull(r.scene.objects[e.a].label.substr(6));
    const uint64_t b = std::stoull(r.scene.objects[e.b].label.substr(6));
    got.insert({std::min(a, b), std::max(a, b)});
  }
  return got;
}

// Touching labels with merged faces: the two copies of a shared face are cut differently
// (each label's rectangles and T-junction corners are its own), and the dual graph is still
// the labels' face adjacency (brute force), as with the voxel faces. Slabs along z: 1 below,
// 2 and 3 side by side in the middle, 4 on top with a hole; 1 and 4 do not meet.
TEST(LabelVolume, MergedFacesKeepTheDualGraph) {
  const uint64_t n = 12;
  LabelVolume v;
  v.size = {n, n, n};
  for (uint64_t k = 0; k < n; ++k)
    for (uint64_t j = 0; j < n; ++j)
      for (uint64_t i = 0; i < n; ++i) {
        uint64_t label = k < 4 ? 1 : (k < 8 ? (i < 5 ? 2 : 3) : 4);
        if (k == 10 && j == 6 && i == 6) label = 0;  // the hole in 4
        if (k < 4 && i > 8 && j > 8) label = 5;      // a column in 1's corner, apart from 2
        v.labels.push_back(label);
      }
  PipelineOptions po;
  po.threads = 2;
  LabelVolumeOptions o;
  const GvdResult merged = compute_gvd(scene_from_label_volume(v, o), po);
  o.faces = VolumeFaces::kVoxel;
  const GvdResult voxel = compute_gvd(scene_from_label_volume(v, o), po);
  const std::set<std::pair<uint64_t, uint64_t>> face = {{1, 2}, {1, 3}, {1, 5}, {2, 3},
                                                        {2, 4}, {3, 4}, {3, 5}};
  EXPECT_EQ(label_pairs(voxel), face);
  EXPECT_EQ(label_pairs(merged), face);
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

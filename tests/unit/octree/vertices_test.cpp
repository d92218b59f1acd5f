// OctreeVertices: the key -> vertex lookups with and without the hash index (drop_index).
#include "gvd/octree/vertices.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "gvd/common/error.h"
#include "gvd/octree/build_octree.h"
#include "support/scenes.h"

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;

namespace {

// The octree of a sphere beside a box (3D) or two squares (2D), max depth 6.
Octree small_octree(int dim) {
  const Scene scene = dim == 3
                          ? test::make_scene(3, {test::make_sphere("ball", {0, 0, 0}, 1, 8, 16),
                                                 test::make_box("box", {1.2, -1, -1}, {2, 1, 1})})
                          : test::make_scene(2, {test::make_rect("a", {0, 0, 0}, {1, 1, 0}),
                                                 test::make_rect("b", {1.1, 0.2, 0}, {2, 1.5, 0})});
  const UnitGeometry geometry = make_unit_geometry(scene, make_domain(scene));
  OctreeOptions o;
  o.max_depth = 6;
  return build_octree(geometry, o);
}

// Without the hash, find binary-searches the sorted keys: the same answer for every vertex,
// for keys that are no vertex, and for every leaf's grid; insert refuses.
TEST(OctreeVertices, FindsTheSameWithoutTheHashIndex) {
  for (int dim : {2, 3}) {
    const Octree octree = small_octree(dim);
    OctreeVertices v = enumerate_vertices(octree, 2);
    ASSERT_TRUE(v.indexed());
    ASSERT_GT(v.size(), 100u);
    std::vector<LeafGrid> grids;
    for (uint32_t leaf = 0; leaf < octree.leaf_count(); ++leaf)
      grids.push_back(leaf_grid(octree, v, leaf));
    v.drop_index();
    EXPECT_FALSE(v.indexed());
    for (uint32_t i = 0; i < v.size(); ++i) {
      ASSERT_EQ(v.find(v.key[i]), i);
      const uint64_t between = v.key[i] + 1;
      if (i + 1 < v.size() && between != v.key[i + 1]) {
        ASSERT_EQ(v.find(between), kNoVertex);
      }
    }
    EXPECT_EQ(v.find(0), v.key.front() == 0 ? 0u : kNoVertex);
    for (uint32_t leaf = 0; leaf < octree.leaf_count(); ++leaf)
      ASSERT_EQ(leaf_grid(octree, v, leaf), grids[leaf]) << "leaf " << leaf;
    EXPECT_THROW(v.insert(v.key.back() + 1), Error);
    v.rebuild_index(2);
    EXPECT_TRUE(v.indexed());
    EXPECT_EQ(v.find(v.key[v.size() / 2]), v.size() / 2);
  }
}

// append (the refinement's new vertices of a round): every key, old and new, is found at its
// position, and keys that are no vertex are not, both where the index and the filter take the
// new keys in place (the table keeps its size) and where they are built again.
TEST(OctreeVertices, AppendFindsOldAndNewKeysInPlaceOrRebuilt) {
  for (int dim : {2, 3}) {
    const OctreeVertices all = enumerate_vertices(small_octree(dim), 2);
    ASSERT_GT(all.size(), 100u);
    // The even keys first, then a few odd ones (room for them), then the rest (no room).
    OctreeVertices v;
    v.dimension = dim;
    std::vector<uint64_t> odd;
    for (size_t i = 0; i < all.size(); ++i) (i % 2 == 0 ? v.key : odd).push_back(all.key[i]);
    // As many as both the table (built with room for them) and the filter (8 bits a key, its
    // size set by the keys alone) hold.
    v.rebuild_index(2);
    const size_t room = std::min(odd.size() / 8, v.filter.size() * 64 / 8 - v.key.size());
    ASSERT_GT(room, 0u);
    v.rebuild_index(2, room);
    const size_t table = v.index.memory_bytes();
    const std::span<const uint64_t> odd_keys(odd);
    auto expect_found = [&](size_t appended) {
      ASSERT_TRUE(v.indexed());
      ASSERT_EQ(v.size(), all.size() - odd.size() + appended);
      for (uint32_t i = 0; i < v.size(); ++i) ASSERT_EQ(v.find(v.key[i]), i) << "dim " << dim;
      for (size_t i = appended; i < odd.size(); ++i)
        ASSERT_EQ(v.find(odd[i]), kNoVertex) << "not appended yet";
    };
    // Built again, the table would have room for every odd key besides.
    v.append(odd_keys.first(room), 2, odd.size());
    EXPECT_EQ(v.index.memory_bytes(), table) << "in place";
    expect_found(room);
    v.append(odd_keys.subspan(room), 2);
    EXPECT_GT(v.index.memory_bytes(), table) << "built again";
    expect_found(odd.size());
    // No key between two vertices is one.
    for (size_t i = 0; i + 1 < all.size(); ++i) {
      if (all.key[i] + 1 != all.key[i + 1]) {
        ASSERT_EQ(v.find(all.key[i] + 1), kNoVertex);
      }
    }
  }
}

}  // namespace
}  // namespace gvd

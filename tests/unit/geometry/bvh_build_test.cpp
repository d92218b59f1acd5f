#include "gvd/geometry/bvh_build.h"

#include <gtest/gtest.h>

#include <atomic>
#include <numeric>
#include <random>
#include <vector>

#include "gvd/common/error.h"

namespace gvd {
namespace {

Box node_box(const item::GvdBvhNode& n) {
  return {{n.lo[0], n.lo[1], n.lo[2]}, {n.hi[0], n.hi[1], n.hi[2]}};
}

bool contains(const Box& outer, const Box& inner) {
  for (int a = 0; a < 3; ++a) {
    if (inner.lo[a] < outer.lo[a] || inner.hi[a] > outer.hi[a]) return false;
  }
  return true;
}

// Walks the tree at `root` as item::gvd_bvh_nearest does (left child next, right child at
// `first`) and checks the layout's promises against the boxes themselves: every item in
// exactly one leaf of at most kBvhLeafSize, every node's box holding its children's and its
// items' boxes, the tree's nodes contiguous from `root`. Returns the nodes reached.
size_t check_tree(const std::vector<item::GvdBvhNode>& nodes, uint32_t root,
                  const std::vector<uint32_t>& items, uint32_t begin, uint32_t end,
                  const std::vector<Box>& boxes) {
  std::vector<int> seen(end - begin, 0);
  size_t reached = 0;
  std::vector<uint32_t> stack{root};
  while (!stack.empty()) {
    const uint32_t i = stack.back();
    stack.pop_back();
    ++reached;
    const item::GvdBvhNode& n = nodes[i];
    EXPECT_EQ(item::gvd_node_object(&n), static_cast<uint32_t>(GVD_MIXED));
    const uint32_t count = item::gvd_node_count(&n);
    if (count > 0) {
      EXPECT_LE(count, kBvhLeafSize);
      for (uint32_t k = n.first; k < n.first + count; ++k) {
        EXPECT_GE(k, begin);
        EXPECT_LT(k, end);
        ++seen[k - begin];
        EXPECT_TRUE(contains(node_box(n), boxes[items[k]])) << "item " << items[k];
      }
      continue;
    }
    const uint32_t left = i + 1, right = n.first;
    EXPECT_GT(right, left);
    EXPECT_TRUE(contains(node_box(n), node_box(nodes[left])));
    EXPECT_TRUE(contains(node_box(n), node_box(nodes[right])));
    stack.push_back(right);
    stack.push_back(left);
  }
  for (uint32_t k = 0; k < end - begin; ++k) EXPECT_EQ(seen[k], 1) << "position " << begin + k;
  return reached;
}

TEST(BuildBvhNodes, EveryItemInOneLeafAndEveryBoxHoldsItsContents) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const uint32_t n : {1u, 4u, 5u, 17u, 1000u, 40000u}) {
    std::vector<Box> boxes(n);
    for (Box& b : boxes) {
      const Vec3 p{u(rng), u(rng), 0.01 * u(rng)};  // flat in z: the split axis changes
      b.extend(p);
      b.extend(p + Vec3{0.01 * (u(rng) + 1), 0.02 * (u(rng) + 1), 0});
    }
    // Two trees in one array, as the grid lays out one tree per object.
    std::vector<uint32_t> items(2 * n);
    std::iota(items.begin(), items.begin() + n, 0u);
    std::iota(items.begin() + n, items.end(), 0u);
    std::vector<item::GvdBvhNode> nodes;
    uint32_t work = 0;
    auto box_of = [&](uint32_t s) -> const Box& { return boxes[s]; };
    auto center_of = [&](uint32_t s) { return boxes[s].center(); };
    build_bvh_nodes(items, 0, n, box_of, center_of, nodes, nullptr, work, "test");
    const uint32_t second = static_cast<uint32_t>(nodes.size());
    build_bvh_nodes(items, n, 2 * n, box_of, center_of, nodes, nullptr, work, "test");
    EXPECT_EQ(second, bvh_node_count(n));
    EXPECT_EQ(nodes.size(), 2 * bvh_node_count(n));
    EXPECT_EQ(check_tree(nodes, 0, items, 0, n, boxes), bvh_node_count(n)) << n;
    EXPECT_EQ(check_tree(nodes, second, items, n, 2 * n, boxes), bvh_node_count(n)) << n;
  }
}

TEST(BuildBvhNodes, ASetCancelFlagStopsALargeBuildNamingTheStage) {
  const uint32_t n = 4 * kBvhCancelGrain;
  std::vector<Box> boxes(n);
  for (uint32_t i = 0; i < n; ++i) boxes[i].extend(Vec3{double(i), 0, 0});
  std::vector<uint32_t> items(n);
  std::iota(items.begin(), items.end(), 0u);
  std::vector<item::GvdBvhNode> nodes;
  std::atomic<bool> cancel{true};
  uint32_t work = 0;
  try {
    build_bvh_nodes(
        items, 0, n, [&](uint32_t s) -> const Box& { return boxes[s]; },
        [&](uint32_t s) { return boxes[s].center(); }, nodes, &cancel, work, "the grid");
    FAIL() << "not cancelled";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled);
    EXPECT_NE(std::string(e.what()).find("the grid"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace gvd

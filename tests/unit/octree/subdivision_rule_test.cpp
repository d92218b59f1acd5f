// The subdivision rule both octree builds call, against the rule as the paper states it (§3)
// with touching pairs, checked over every combination of small object sets by a brute force
// written from that statement alone.
#include "gvd/octree/subdivision_rule.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

namespace gvd {

using namespace gvd::scene;
using namespace gvd::octree;

namespace {

CellObjects set_of(const std::vector<ObjectId>& objects) {
  CellObjects s;
  for (ObjectId o : objects) s.add(o);
  return s;
}

// Every pair of distinct objects of `objects` touches.
bool all_touch(const std::set<ObjectId>& objects, const ContactPairs& contacts) {
  for (ObjectId a : objects)
    for (ObjectId b : objects)
      if (a != b && !contacts.touching(a, b)) return false;
  return true;
}

TEST(SubdivisionRule, TagsAndSplitsAsThePaperSays) {
  // Objects 0..5; 0-1, 1-2 and 0-2 touch (a triangle of contacts), 3-4 touch, 5 touches none.
  const ContactPairs contacts({{0, 1}, {0, 2}, {1, 2}, {3, 4}});
  // Every multiset of up to 5 objects as a cell's content (with repeats: several simplices of
  // one object).
  std::vector<std::vector<ObjectId>> cells = {{}};
  for (int size = 1; size <= 5; ++size) {
    std::vector<std::vector<ObjectId>> next;
    for (const auto& c : cells)
      if (static_cast<int>(c.size()) == size - 1)
        for (ObjectId o = 0; o < 6; ++o) {
          auto d = c;
          d.push_back(o);
          next.push_back(d);
        }
    cells.insert(cells.end(), next.begin(), next.end());
  }
  for (const auto& content : cells) {
    const std::set<ObjectId> distinct(content.begin(), content.end());
    const CellObjects s = set_of(content);
    const ObjectId tag = cell_tag(s, &contacts);
    // More than four distinct objects count as not all touching (the set's capacity).
    const ObjectId expected = distinct.empty()       ? kNoObject
                              : distinct.size() == 1 ? *distinct.begin()
                              : distinct.size() <= 4 && all_touch(distinct, contacts)
                                  ? kTouchingObjects
                                  : kManyObjects;
    ASSERT_EQ(tag, expected) << content.size();
    EXPECT_EQ(cell_tag(s, nullptr), distinct.size() > 1 ? kManyObjects : expected);
    for (const bool at_contact : {false, true}) {
      // A cell splits by itself while it holds objects that may not share it there.
      EXPECT_EQ(splits_by_itself(tag, at_contact),
                distinct.size() > 1 && (!at_contact || expected == kManyObjects));
      // A cell of one object a next to this one: split unless every object here is a, or
      // (at the contact depth) touches a.
      for (ObjectId a = 0; a < 6; ++a) {
        bool separate = false;
        for (ObjectId o : distinct)
          if (o != a && (!at_contact || !contacts.touching(a, o))) separate = true;
        if (expected == kManyObjects && at_contact && distinct.size() > 1) separate = true;
        if (expected == kManyObjects && !at_contact) separate = true;
        EXPECT_EQ(must_separate(a, tag, s, at_contact, &contacts), separate)
            << "a = " << a << ", " << distinct.size() << " objects, at_contact " << at_contact;
      }
    }
    EXPECT_EQ(asks_neighbours(tag), distinct.size() == 1);
  }
}

TEST(SubdivisionRule, OverlapSlackIsOneBillionthOfTheCellPlusAFloor) {
  for (int level = 0; level <= 48; ++level)
    EXPECT_EQ(overlap_slack(level), std::ldexp(1.0, -level) * 1e-9 + 1e-15) << level;
}

}  // namespace
}  // namespace gvd

#pragma once

// The paper's subdivision rule (§3), with touching pairs: the one definition that both octree
// builds (build_octree, level by level, and build_octree_data_parallel) call, so that they
// make the same leaves. A cell is split while it holds several objects, or while a face
// neighbour holds an object other than its own; objects that touch (ContactPairs) stop being
// separated at the contact depth. What the certified refinement adds (a cell the rule splits
// may stay a leaf) is the split oracle's, not this rule's.

#include <algorithm>
#include <cstdint>

#include "gvd/octree/contacts.h"
#include "gvd/octree/octree_build_item.h"
#include "gvd/scene/scene.h"

namespace gvd::octree {

/// The tag of a cell whose several objects all touch each other pairwise (besides kNoObject,
/// one object's id, and kManyObjects). Internal to the builds: leaves never carry it.
inline constexpr scene::ObjectId kTouchingObjects = 0xFFFFFFFDu;

/// How far a cell at `level` is inflated when tested against simplices (2^-level * 1e-9 +
/// 1e-15, in unit-domain lengths): overlap tests are conservative, so a simplex that grazes a
/// face is in both cells. One definition, the kernels' (item::gvd_slack).
inline double overlap_slack(int level) { return item::gvd_slack(level); }

/// The objects of a cell: up to four distinct ones, enough to decide contacts exactly in the
/// common cases; more set `overflow` (treated as not all touching).
struct CellObjects {
  scene::ObjectId o[4] = {0, 0, 0, 0};
  int n = 0;
  bool overflow = false;

  void add(scene::ObjectId x) {
    if (overflow || std::find(o, o + n, x) != o + n) return;
    if (n == 4) {
      overflow = true;
      return;
    }
    o[n++] = x;
  }
  void add(const CellObjects& s) {
    if (s.overflow) overflow = true;
    for (int i = 0; i < s.n; ++i) add(s.o[i]);
  }
};

/// The objects of the simplices [begin, end) of `geometry`.
inline CellObjects cell_objects(const scene::UnitGeometry& geometry, const uint32_t* begin,
                                const uint32_t* end) {
  CellObjects s;
  for (const uint32_t* p = begin; p != end && !s.overflow; ++p) s.add(geometry.object_of[*p]);
  return s;
}

/// kNoObject (empty), the one object, kTouchingObjects (several, all touching pairwise), or
/// kManyObjects.
inline scene::ObjectId cell_tag(const CellObjects& s, const ContactPairs* contacts) {
  if (s.n == 0 && !s.overflow) return scene::kNoObject;
  if (s.n == 1 && !s.overflow) return s.o[0];
  if (contacts == nullptr || s.overflow) return scene::kManyObjects;
  for (int i = 0; i < s.n; ++i)
    for (int j = i + 1; j < s.n; ++j)
      if (!contacts->touching(s.o[i], s.o[j])) return scene::kManyObjects;
  return kTouchingObjects;
}

/// The cell alone is split: several objects not all touching, or touching ones above the
/// contact depth (`at_contact`: the cell's level has reached it).
inline bool splits_by_itself(scene::ObjectId tag, bool at_contact) {
  return tag == scene::kManyObjects || (tag == kTouchingObjects && !at_contact);
}

/// Whether the cell's face neighbours can split it: only a cell of one object is split for
/// them (an empty cell is not; touching objects are split by themselves or not at all).
inline bool asks_neighbours(scene::ObjectId tag) {
  return tag != kTouchingObjects && tag != scene::kNoObject && tag != scene::kManyObjects;
}

/// Must a cell of object `a` be split for a face neighbour tagged `t` holding `objects`? Yes
/// when the neighbour holds another object, unless at the contact depth every object there
/// touches `a`.
inline bool must_separate(scene::ObjectId a, scene::ObjectId t, const CellObjects& objects,
                          bool at_contact, const ContactPairs* contacts) {
  if (t == a || t == scene::kNoObject) return false;
  if (!at_contact || contacts == nullptr || t == scene::kManyObjects) return true;
  if (t == kTouchingObjects) {
    for (int k = 0; k < objects.n; ++k)
      if (objects.o[k] != a && !contacts->touching(a, objects.o[k])) return true;
    return false;
  }
  return !contacts->touching(a, t);
}

}  // namespace gvd::octree

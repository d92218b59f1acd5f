#pragma once

// The GVD on one face of a junction cell (refine/pair_certificate.h, certify_junction): where
// three or more objects meet along a straight line along axis e and every distance function is
// invariant along e, the 3D GVD in the cell is G x e for the plane GVD G of the objects'
// sections. G on a face square to e is computed from that face alone (so both cells of the face
// get the same pieces): the objects that can be nearest to a point of the face, their simplices
// in reach projected along e (exact: a coordinate dropped) and cut to a square of 2^m faces
// around it (the face one of its lattice cells), the 2D pipeline run on them, and its pieces cut
// to the face.

#include <atomic>
#include <map>
#include <mutex>
#include <string>

#include "gvd/geometry/simplex_bvh.h"
#include "gvd/geometry/vec.h"
#include "gvd/scene/scene.h"
#include "gvd/surface/extract_gvd.h"

namespace gvd::pipeline {

/// Plane GVDs of junction faces by their section: the plane scene a face gives (its objects'
/// segments, the square around the face) and the face across the axis. Faces between junction
/// cells that differ only in their place along the axis and see the same sections (a junction
/// line's cells, one above the other) share one computation. Safe to share between threads.
class JunctionSectionCache {
 public:
  /// The plane GVD stored for `key`, its points moved onto coordinate `at` along `axis`.
  bool find(const std::string& key, int axis, double at, surface::FaceGvd& out) const;
  void add(std::string key, const surface::FaceGvd& gvd);
  /// The sections computed.
  size_t size() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return map_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, surface::FaceGvd> map_;
};

/// The GVD on the face `face` (unit domain; flat along `axis`: lo[axis] == hi[axis]) of a
/// junction cell whose objects are invariant along `axis`. Only simplices square to `axis` are
/// projected: within a junction cell no other can be nearest. False when fewer than two objects
/// can be nearest on the face (no GVD there: `out` empty). Throws gvd::Error{kCancelled} when
/// `cancel` is set.
/// `sections` (optional): computed once per section (JunctionSectionCache).
bool junction_face_gvd(const scene::UnitGeometry& geometry, const SimplexBvh& bvh, const Box& face,
                       int axis, surface::FaceGvd& out, const std::atomic<bool>* cancel = nullptr,
                       JunctionSectionCache* sections = nullptr);

}  // namespace gvd::pipeline

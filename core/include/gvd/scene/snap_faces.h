#pragma once

// Flat faces of a rounded input put back on exact planes. STL and glTF store float32
// positions, and OBJ, ASCII STL or PLY and many JSON writers a fixed number of decimals, so a
// part drawn at an angle arrives with faces whose triangles are coplanar, and faces of
// different parts parallel, only to that rounding (~6e-8 of the coordinates in float32, 5e-9
// with 8 decimals). The certified pair cells (refine/pair_certificate.h) test flatness and
// parallel normals to the unit lattice's rounding (2^-48), so such a part would cost what the
// paper's rule costs (a tilted blade in a slot at 1e-3: 17,340 leaves drawn in doubles, 3.97M
// in float32; at 1e-4 written with 10 decimals: the leaf limit). snap_rounded_faces finds the
// faces the rounding broke and moves their vertices back onto shared planes, by no more than
// the rounding itself.

#include <atomic>
#include <cstdint>

#include "gvd/scene/scene.h"

namespace gvd::scene {

/// What snap_rounded_faces did.
struct FaceSnap {
  /// The most that the input's rounding moved any coordinate: 2^-24 of the largest coordinate
  /// magnitude for float32; for decimals, half a unit in their last place (see below). 0 when
  /// the scene is neither, or not 3D: then nothing was done.
  double rounding = 0;
  bool float32 = false;   ///< the rounding is float32's (else the decimals')
  uint64_t faces = 0;     ///< flat faces found (of two or more triangles, or sharp ones)
  uint64_t planes = 0;    ///< the exact planes they were put on (parallel faces share a normal)
  uint64_t vertices = 0;  ///< vertices moved
  uint64_t refused = 0;   ///< vertices that would have moved too far (below), left where they are
  double max_move = 0;    ///< the largest move (user units)
};

/// Only when the scene is 3D and every coordinate is exactly a float32 (an STL, a glTF, or a
/// JSON scene written from one), or is a decimal of few digits: each coordinate's shortest
/// text has at most 14 significant digits (a computed double has 15 to 17), at least half of
/// the non-zero ones use up the most decimal places seen or the most significant digits (so
/// a scene written by hand, 0.2 and 0.451, is not taken for a rounded one), and some have
/// decimal places (integers are taken as exact); then the rounding is the larger of half a
/// unit in that last place and half a unit in the last of that many significant digits of
/// the largest coordinate. It groups each object's edge-connected triangles that lie on one
/// plane within 4 roundings (a face), gives faces whose planes are parallel within the same
/// tolerance (across all objects, either side) one common normal and faces on one plane
/// within it (facing the same way) one offset, glues a plane facing the other way within it
/// that holds a face of the same object (parts of one object glued together) to the same
/// offset, and moves each vertex to where the planes of
/// its faces meet (at most three, the largest faces first, taken while they stay well apart
/// in angle). A move longer than 16 roundings, or than 1 % of the distance from one of the
/// vertex's triangles to another object (so that no gap changes by more than 2 % of itself),
/// is refused. Faces of
/// curved meshes are not faces here: a lone triangle counts only when every neighbour meets
/// it at 20 degrees or more. O(T log T) for T triangles, plus a BVH when any vertex moves.
/// `cancel` (may be null) is read every few thousand triangles.
FaceSnap snap_rounded_faces(Scene& scene, int threads = 0,
                            const std::atomic<bool>* cancel = nullptr);

}  // namespace gvd::scene

#pragma once

// Flat faces of a float32 input put back on exact planes. STL and glTF store float32
// positions, so a part drawn at an angle arrives with faces whose triangles are coplanar, and
// faces of different parts parallel, only to float32 rounding (~6e-8 of the coordinates).
// The certified pair cells (refine/pair_certificate.h) test flatness and parallel normals to
// the unit lattice's rounding (2^-48), so such a part would cost what the paper's rule costs
// (a tilted blade in a slot at 1e-3: 17,340 leaves drawn in doubles, 3.97M in float32).
// snap_float32_faces finds the faces the rounding broke and moves their vertices back onto
// shared planes, by no more than the rounding itself.

#include <atomic>
#include <cstdint>

#include "gvd/scene/scene.h"

namespace gvd::scene {

/// What snap_float32_faces did.
struct FaceSnap {
  /// 2^-24 of the largest coordinate magnitude: the most that rounding to float32 moved any
  /// coordinate (0 when the scene is not float32, or not 3D: then nothing was done).
  double rounding = 0;
  uint64_t faces = 0;     ///< flat faces found (of two or more triangles, or sharp ones)
  uint64_t planes = 0;    ///< the exact planes they were put on (parallel faces share a normal)
  uint64_t vertices = 0;  ///< vertices moved
  uint64_t refused = 0;   ///< vertices that would have moved too far (below), left where they are
  double max_move = 0;    ///< the largest move (user units)
};

/// Only when the scene is 3D and every coordinate is exactly a float32 (an STL, a glTF, or a
/// JSON scene written from one): groups each object's edge-connected triangles that lie on one
/// plane within 4 roundings (a face), gives faces whose planes are parallel within the same
/// tolerance (across all objects, either side) one common normal and faces on one plane
/// within it (facing the same way) one offset, and moves each vertex to where the planes of
/// its faces meet (at most three, the largest faces first, taken while they stay well apart
/// in angle). A move longer than 16 roundings, or than 1 % of the distance from one of the
/// vertex's triangles to another object (so that no gap changes by more than 2 % of itself),
/// is refused. Faces of
/// curved meshes are not faces here: a lone triangle counts only when every neighbour meets
/// it at 20 degrees or more. O(T log T) for T triangles, plus a BVH when any vertex moves.
/// `cancel` (may be null) is read every few thousand triangles.
FaceSnap snap_float32_faces(Scene& scene, int threads = 0,
                            const std::atomic<bool>* cancel = nullptr);

}  // namespace gvd::scene

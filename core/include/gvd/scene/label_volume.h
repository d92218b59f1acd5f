#pragma once

// Labelled voxel volumes in (a segmentation: one id per voxel, 0 = background unless told):
// each label becomes an object whose boundary is the surface between its voxels and the
// others', and the adaptive pipeline runs on those objects as on meshes.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gvd/scene/scene.h"

namespace gvd::scene {

/// A 2D or 3D array of labels, x fastest: label(i, j, k) = labels[(k * ny + j) * nx + i].
struct LabelVolume {
  int dimension = 3;
  std::array<uint64_t, 3> size{1, 1, 1};  ///< nx, ny, nz (nz = 1 in 2D)
  std::vector<uint64_t> labels;
};

/// What the header of a label volume .npy says (read_label_volume_header): enough to check a
/// volume before its voxels are decoded.
struct LabelVolumeHeader {
  int dimension = 3;
  std::array<uint64_t, 3> size{1, 1, 1};  ///< nx, ny, nz (nz = 1 in 2D)
  int width = 1;                          ///< bytes per label
  bool is_signed = false;
  bool fortran_order = false;
  size_t data_offset = 0;  ///< where the labels start in the file
  uint64_t voxel_count() const { return size[0] * size[1] * size[2]; }
};

/// The header of a label volume .npy, with every check of read_label_volume_npy but the
/// labels' values (negative labels): magic, version, dtype, shape, and that the data holds
/// every voxel. O(header): what a server checks before it stores the bytes for a worker.
LabelVolumeHeader read_label_volume_header(std::span<const uint8_t> bytes, const std::string& name);

/// Reads a numpy .npy file of integer labels: descr '<i1'/'<i2'/'<i4'/'<i8', '|u1', '<u2',
/// '<u4', '<u8' (and '|i1'), 2 or 3 dimensions in C order (shape (ny, nx) or (nz, ny, nx),
/// x fastest, as gvd grid writes them) or Fortran order. Errors name the file: bytes that are
/// not a .npy gvd reads (no magic, an unknown format version) are kUnsupportedFormat; a .npy
/// whose content is no label volume is kInvalidScene naming the field (a dtype that is not a
/// little-endian integer, a shape of other than 2 or 3 dimensions or without voxels, a
/// truncated header or data), as is a negative label (naming the voxel). `cancel` (may be
/// null) is read every 64k voxels: set, it stops with gvd::Error{kCancelled}.
LabelVolume read_label_volume_npy(std::span<const uint8_t> bytes, const std::string& name,
                                  const std::atomic<bool>* cancel = nullptr);

/// How a label's boundary is cut into simplices (LabelVolumeOptions::faces).
enum class VolumeFaces : int {
  /// Coplanar faces merged (3D: into rectangles stacked from maximal runs, each split into
  /// triangles on every corner of the label's other rectangles on its sides; 2D: collinear
  /// edges into segments between the points where the boundary turns or branches): as many
  /// simplices as the surface's shape needs, not its voxel count.
  kMerged,
  /// Two triangles per voxel face, one segment per pixel edge.
  kVoxel,
};

struct LabelVolumeOptions {
  /// Voxel size along x, y (, z) in user units: anisotropic voxels are honoured throughout.
  std::array<double, 3> spacing{1, 1, 1};
  /// The position of the volume's corner (the lower corner of voxel (0, 0, 0)).
  std::array<double, 3> origin{0, 0, 0};
  /// The label that is no object (background); none: every label is an object.
  std::optional<uint64_t> background = 0;
  /// Merged faces (default) or the voxel faces themselves: the same surface either way.
  VolumeFaces faces = VolumeFaces::kMerged;
  /// Set to true by another thread to stop with gvd::Error{kCancelled}; read every row of
  /// voxels and while the scene is validated.
  const std::atomic<bool>* cancel = nullptr;
  /// Called with the fraction of the volume's rows turned into faces (0..1, every percent).
  std::function<void(double)> progress;
};

/// One object per label (in increasing order, labelled "label_<id>"): its boundary faces
/// between a voxel of the label and a voxel of another label, the background or the outside
/// of the volume, oriented outward, on the shared voxel corners (closed; where voxels of a
/// label touch along an edge only, non-manifold, with the scene's warning), as
/// `options.faces` says: merged (3D: rectangles of coplanar faces, each two triangles, a strip
/// or a fan around an added centre vertex when other rectangles' corners lie on its sides;
/// 2D: maximal segments) or per voxel (two triangles per voxel face, one segment per pixel
/// edge). Either way each stretch of a voxel edge on the surface is run as often, in the same
/// directions, so closedness and orientation are the voxel faces'. The scene is validated.
/// O(boundary faces x log) time, O(boundary faces) memory.
/// gvd::Error{kInvalidScene} when there is no object; {kInvalidArgument} for a spacing that
/// is not positive and finite.
Scene scene_from_label_volume(const LabelVolume& volume, const LabelVolumeOptions& options,
                              const SceneLimits& limits = {});

}  // namespace gvd::scene

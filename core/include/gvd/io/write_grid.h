#pragma once

// Files of the uniform-grid GVD (gvd/grid/compute_grid.h) for numpy, ParaView and 3D Slicer:
// .npy (numpy format 1.0, our own writer) and NRRD (.nrrd with the data attached, .nhdr with
// it detached in a .raw file beside it). docs/FORMATS.md describes both.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gvd/grid/compute_grid.h"

namespace gvd::io {

/// What a grid file holds.
enum class GridValueType { kFloat32, kFloat64, kInt32 };

/// A numpy .npy file (format version 1.0) of a C-order array: magic, version, header length,
/// the header dict ({'descr': '<f4' | '<f8' | '<i4', 'fortran_order': False, 'shape': (...)})
/// padded with spaces and ended by '\n' so that the data starts at a multiple of 64 bytes,
/// then the little-endian values. `data` holds product(shape) values of `type`.
std::vector<uint8_t> npy_bytes(GridValueType type, std::span<const uint64_t> shape,
                               const void* data);

/// A grid's distances (float32, or float64 when `float64`) or, with `labels`, its labels
/// (int32, -1 = none) as the bytes of a .npy file (npy_bytes over grid_shape).
std::vector<uint8_t> grid_npy_bytes(const grid::DistanceGrid& grid, bool labels, bool float64);

/// The shape numpy sees for a grid: (ny, nx) in 2D, (nz, ny, nx) in 3D (x fastest, so
/// array[k, j, i] is cell (i, j, k)).
std::vector<uint64_t> grid_shape(const grid::GridSpec& spec);

/// A NRRD (format NRRD0004) header for a grid of `type`: sizes nx ny [nz] (x fastest), space
/// directions = the cell size on each axis, space origin = the centre of cell (0, 0, 0) (NRRD
/// places samples at their positions, which are the cell centres), little endian, raw.
/// `data_file` non-empty: a detached header naming it ("data file:"); empty: the header of
/// an attached file (it ends with the blank line after which the data follows). `comment`
/// goes on a "#" line. `units` (a canonical unit name, gvd/scene/units.h; empty: none) gives
/// "space units", the same on every axis, in ASCII ("µm" as "um", "Å" as "angstrom").
std::string nrrd_header(const grid::GridSpec& spec, GridValueType type,
                        const std::string& data_file, const std::string& comment,
                        const std::string& units = "");

/// Writes a grid's distances (float32, or float64 when `float64`) to `path` by its
/// extension: .npy, .nrrd (attached) or .nhdr (detached, data in <stem>.raw beside it); a
/// NRRD header says the grid's units (nrrd_header). numpy's .npy header has no place for them
/// (numpy refuses unknown keys).
/// Returns the files written. gvd::Error{kInvalidArgument} for another extension, {kIo} when
/// a file cannot be written.
std::vector<std::string> write_grid_distance(const grid::DistanceGrid& grid,
                                             const std::string& path, bool float64);

/// Writes a grid's labels (int32, -1 = none) the same way.
std::vector<std::string> write_grid_labels(const grid::DistanceGrid& grid, const std::string& path);

}  // namespace gvd::io

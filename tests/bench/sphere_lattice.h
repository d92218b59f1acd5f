#pragma once

// The thin-gaps issue's memory yardstick: 64 icospheres on a 4 x 4 x 4 lattice (327,680
// triangles), run through gvd and, when the bench is built with OpenVDB, through OpenVDB's
// meshToVolume with a closest-polygon index grid (voxel 0.02, band 15) beside it.

#include <string>

#include "gvd/scene/scene.h"

namespace gvd::bench {

/// 4 x 4 x 4 icospheres of 4 subdivisions (5,120 triangles each), radius 0.45, centres on
/// the unit lattice (gaps 0.1).
Scene make_sphere_lattice();

/// Registers BM_SphereLattice/gvd and, with OpenVDB, BM_SphereLattice/openvdb_mesh_to_volume.
void register_sphere_lattice_benchmarks();

/// The comparison (peak memory, time, leaves or active voxels), after the runs.
void print_sphere_lattice_summary();

}  // namespace gvd::bench

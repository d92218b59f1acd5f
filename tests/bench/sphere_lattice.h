#pragma once

// The thin-gaps issue's memory yardstick: 64 icospheres on a 4 x 4 x 4 lattice (327,680
// triangles), run through gvd and, when the bench is built with OpenVDB, through OpenVDB's
// meshToVolume with a closest-polygon index grid (voxel 0.02, band 15) beside it.

#include <string>

#include "gvd/scene/scene.h"

namespace gvd::bench {

/// Resets the peak resident set size (Linux >= 4.0: "5" > /proc/self/clear_refs), after
/// handing the memory earlier benchmarks freed back to the system (else it stays resident
/// and counts towards the next run's peak). False when the kernel refuses.
bool reset_peak_rss();
/// VmHWM of this process in MiB (common/peak_memory.h), 0 when unavailable.
double peak_rss_mib();

/// 4 x 4 x 4 icospheres of 4 subdivisions (5,120 triangles each), radius 0.45, centres on
/// the unit lattice (gaps 0.1); all of it times `scale`. gvd's octree does not depend on the
/// scale (its domain is the scene's box); OpenVDB's voxels are 0.02 at every scale, so its
/// band holds about scale^2 as many voxels (here 9.3M at scale 1, 45M at scale 2: ~180 and
/// ~760 MiB; the thin-gaps issue quoted 670 MB for OpenVDB on its lattice).
scene::Scene make_sphere_lattice(double scale = 1);

/// Registers BM_SphereLattice/gvd and, with OpenVDB, BM_SphereLattice/openvdb_mesh_to_volume,
/// each at scale 1 and 2.
void register_sphere_lattice_benchmarks();

/// The comparison (peak memory, time, leaves or active voxels), after the runs.
void print_sphere_lattice_summary();

}  // namespace gvd::bench

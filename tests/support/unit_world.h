#pragma once

// A scene on the unit lattice with its BVH (the user's axes, so that tilted copies stay tilted
// against the octree), and lattice cells by position: what certificate and face tests set up.

#include <cmath>
#include <cstdint>
#include <utility>

#include "gvd/geometry/simplex_bvh.h"
#include "gvd/octree/lattice.h"
#include "gvd/scene/scene.h"

namespace gvd::test {

struct UnitWorld {
  scene::Scene scene;
  scene::Domain domain;
  scene::UnitGeometry geometry;
  SimplexBvh bvh;
  explicit UnitWorld(scene::Scene s) : scene(std::move(s)) {
    scene::DomainOptions options;
    options.frame = scene::DomainFrame::kWorld;
    domain = make_domain(scene, options);
    geometry = make_unit_geometry(scene, domain);
    bvh = SimplexBvh(scene.dimension, geometry.points, geometry.simplices, geometry.object_of);
  }
};

/// The lattice cell of `level` (3D) holding the unit point `unit`.
inline Box lattice_cell_at(Vec3 unit, int level) {
  const double cell = std::ldexp(1.0, -level);
  const uint64_t size = octree::lattice::cell_size(3, level);
  octree::lattice::Coord c;
  for (int a = 0; a < 3; ++a)
    c.c[a] = static_cast<uint32_t>(std::floor(unit[a] / cell) * static_cast<double>(size));
  return octree::lattice::cell_box(3, c, level);
}

}  // namespace gvd::test

#include "gvd/grid/grid_advice.h"

#include <algorithm>
#include <cmath>

#include "gvd/grid/compute_grid.h"

namespace gvd::grid {

using namespace gvd::scene;
using namespace gvd::graph;

GridAdvice grid_advice(const Scene& scene, const DualGraph& graph) {
  GridAdvice advice;
  advice.cell_limit = GridOptions{}.max_cells;
  double best = 0;
  for (const DualEdge& e : graph.edges) {
    if (e.gap < 0) continue;  // not measured
    advice.measured = true;
    if (e.gap == 0) {
      ++advice.touching_pairs;
    } else if (best == 0 || e.gap < best) {
      best = e.gap;
      advice.a = e.a;
      advice.b = e.b;
    }
  }
  if (!advice.measured) return advice;
  advice.gap = best;
  // compute_grid's default box (make_grid_spec): the vertices' box padded by 5 % of its
  // longest side on every side.
  const int dim = scene.dimension;
  Box verts;
  for (const SceneObject& o : scene.objects)
    for (const Simplex& s : o.simplices)
      for (int i = 0; i < (dim == 2 ? 2 : 3); ++i) verts.extend(o.vertices[s.v[i]]);
  double longest = 0;
  for (int i = 0; i < dim; ++i) longest = std::max(longest, verts.hi[i] - verts.lo[i]);
  const double padding = GridOptions{}.padding;
  advice.longest_side = longest * (1 + 2 * padding);
  if (best == 0) return advice;
  advice.resolution = std::floor(advice.longest_side * std::sqrt(double(dim)) / best) + 1;
  const double h = advice.longest_side / advice.resolution;
  advice.cells = 1;
  for (int i = 0; i < dim; ++i) {
    const double extent = verts.hi[i] - verts.lo[i] + 2 * padding * longest;
    advice.cells *= std::max(1.0, std::ceil(extent / h - 1e-9));
  }
  advice.fits = advice.cells <= static_cast<double>(advice.cell_limit);
  return advice;
}

}  // namespace gvd::grid

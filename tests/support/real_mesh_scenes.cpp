#include "support/real_mesh_scenes.h"

#include <utility>

#include "gvd/common/error.h"
#include "gvd/scene/load_scene.h"
#include "support/scenes.h"

namespace gvd::test {

using namespace gvd::scene;

SceneObject load_corpus_object(const std::string& dir, const std::string& file,
                               const std::string& label) {
  const std::string path = dir + "/" + file;
  Scene s = load_scene(std::span<const std::string>(&path, 1));
  if (s.objects.size() != 1) {
    throw Error(ErrorCode::kInvalidScene,
                path + " holds " + std::to_string(s.objects.size()) + " objects, not one");
  }
  s.objects[0].label = label;
  return std::move(s.objects[0]);
}

Scene mirrored_pair(const SceneObject& object, const std::string& mirror_label, double gap) {
  const double c = bounds(object).hi.x + 0.5 * gap;
  SceneObject image = object;
  image.label = mirror_label;
  for (Vec3& v : image.vertices) v.x = 2 * c - v.x;
  for (Simplex& t : image.simplices) std::swap(t.v[1], t.v[2]);
  return make_scene(3, {object, std::move(image)});
}

Scene boxed(const SceneObject& object, const std::string& label, double gap, double wall) {
  const Box b = bounds(object);
  const Vec3 inner_lo = b.lo - Vec3{gap, gap, gap}, inner_hi = b.hi + Vec3{gap, gap, gap};
  const Vec3 w{wall, wall, wall};
  SceneObject box = make_box(label, inner_lo - w, inner_hi + w);
  // The cavity: the inner cuboid's faces turned to face into it.
  const SceneObject cavity = make_box(label, inner_lo, inner_hi);
  const auto base = static_cast<uint32_t>(box.vertices.size());
  box.vertices.insert(box.vertices.end(), cavity.vertices.begin(), cavity.vertices.end());
  for (Simplex t : cavity.simplices) {
    std::swap(t.v[1], t.v[2]);
    for (uint32_t& i : t.v) i += base;
    box.simplices.push_back(t);
  }
  return make_scene(3, {object, std::move(box)});
}

}  // namespace gvd::test

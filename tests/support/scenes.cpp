#include "support/scenes.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace gvd::test {

using namespace gvd::scene;

Vec3 rotate(Vec3 p, Vec3 axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return p * c + cross(axis, p) * s + axis * (dot(axis, p) * (1 - c));
}

void round_to_float32(Scene& scene) {
  for (SceneObject& o : scene.objects)
    for (Vec3& v : o.vertices)
      for (int k = 0; k < 3; ++k) {
        volatile float f = static_cast<float>(v[k]);
        v[k] = f;
      }
}

Box bounds(const SceneObject& object) {
  Box b;
  for (const Vec3& v : object.vertices) b.extend(v);
  return b;
}

SceneObject make_box(const std::string& label, Vec3 lo, Vec3 hi) {
  SceneObject o;
  o.label = label;
  for (int k = 0; k < 8; ++k)
    o.vertices.push_back({k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z});
  // Outward-facing quads (corner bit order x=1, y=2, z=4).
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    o.simplices.push_back({{q[0], q[1], q[2]}});
    o.simplices.push_back({{q[0], q[2], q[3]}});
  }
  return o;
}

SceneObject make_box_with_split_bottom(const std::string& label, Vec3 lo, Vec3 hi, int k) {
  SceneObject o = make_box(label, lo, hi);
  o.simplices.erase(o.simplices.begin(), o.simplices.begin() + 2);  // quad {0, 2, 3, 1}
  auto coordinate = [&](double a, double b, int i) { return i == k ? b : a + (b - a) * i / k; };
  auto at = [&](int i, int j) {
    const Vec3 p{coordinate(lo.x, hi.x, i), coordinate(lo.y, hi.y, j), lo.z};
    for (uint32_t v = 0; v < o.vertices.size(); ++v)
      if (o.vertices[v].x == p.x && o.vertices[v].y == p.y && o.vertices[v].z == p.z) return v;
    o.vertices.push_back(p);
    return static_cast<uint32_t>(o.vertices.size() - 1);
  };
  for (int i = 0; i < k; ++i) {
    for (int j = 0; j < k; ++j) {
      // Facing -z, as make_box's quad (x, y) -> (x, y+) -> (x+, y+) -> (x+, y).
      const uint32_t a = at(i, j), b = at(i, j + 1), c = at(i + 1, j + 1), d = at(i + 1, j);
      o.simplices.push_back({{a, b, c}});
      o.simplices.push_back({{a, c, d}});
    }
  }
  return o;
}

scene::Scene make_packed_columns(int n, double pitch, double gap) {
  scene::Scene s;
  s.dimension = 3;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      s.objects.push_back(make_box("c" + std::to_string(i) + std::to_string(j),
                                   Vec3{pitch * i, pitch * j, 0},
                                   Vec3{pitch * (i + 1) - gap, pitch * (j + 1) - gap, 1}));
  return s;
}

scene::Scene make_slot_of_separate_parts(double gap) {
  scene::Scene s;
  s.dimension = 3;
  s.objects.push_back(make_box("floor", Vec3{0, 0, 0}, Vec3{1, 0.2, 1}));
  s.objects.push_back(make_box("left", Vec3{0, 0.2 + gap, 0}, Vec3{0.45, 0.5, 1}));
  s.objects.push_back(make_box("right", Vec3{0.55, 0.2 + gap, 0}, Vec3{1, 0.5, 1}));
  s.objects.push_back(
      make_box("blade", Vec3{0.45 + gap, 0.2 + gap, -0.1}, Vec3{0.55 - gap, 0.6, 1.1}));
  return s;
}

scene::Scene make_slot_of_parts(const SlotOfPartsOptions& options) {
  const double g = options.gap;
  SceneObject slot;
  slot.label = "slot";
  auto add = [&](const SceneObject& part) {
    const auto base = static_cast<uint32_t>(slot.vertices.size());
    slot.vertices.insert(slot.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (Simplex t : part.simplices) {
      for (uint32_t& v : t.v) v += base;
      slot.simplices.push_back(t);
    }
  };
  if (options.boxes) {
    add(make_box("floor", {0, 0, 0}, {1, 0.2, 1}));
    add(make_box("left", {0, options.walls_from, 0}, {0.45, 0.5, 1}));
    add(make_box("right", {0.55, options.walls_from, 0}, {1, 0.5, 1}));
  } else {
    const double u[8][2] = {{0, 0},      {1, 0},      {1, 0.5},    {0.55, 0.5},
                            {0.55, 0.2}, {0.45, 0.2}, {0.45, 0.5}, {0, 0.5}};
    for (int z = 0; z < 2; ++z)
      for (const auto& p : u) slot.vertices.push_back({p[0], p[1], double(z)});
    for (uint32_t i = 0; i < 8; ++i) {
      const uint32_t j = (i + 1) % 8;
      slot.simplices.push_back({{i, j, j + 8}});
      slot.simplices.push_back({{i, j + 8, i + 8}});
    }
    // The U's ends: A B E, A E F, A F G, A G H, B C D, B D E.
    const uint32_t cap[6][3] = {{0, 1, 4}, {0, 4, 5}, {0, 5, 6}, {0, 6, 7}, {1, 2, 3}, {1, 3, 4}};
    for (const auto& t : cap) {
      slot.simplices.push_back({{t[0], t[2], t[1]}});
      slot.simplices.push_back({{t[0] + 8, t[1] + 8, t[2] + 8}});
    }
  }
  if (options.weld) {
    std::vector<Vec3> unique;
    for (Simplex& t : slot.simplices) {
      for (uint32_t& v : t.v) {
        const Vec3 p = slot.vertices[v];
        const auto at = std::find(unique.begin(), unique.end(), p);
        v = static_cast<uint32_t>(at - unique.begin());
        if (at == unique.end()) unique.push_back(p);
      }
    }
    slot.vertices = unique;
  }
  return make_scene(
      3, {std::move(slot), make_box("blade", {0.45 + g, 0.2 + g, 0}, {0.55 - g, 0.8, 1})});
}

SceneObject make_sphere(const std::string& label, Vec3 c, double r, int rings, int segments) {
  SceneObject o;
  o.label = label;
  const double pi = std::numbers::pi;
  o.vertices.push_back(c + Vec3{0, 0, r});
  for (int i = 1; i < rings; ++i) {
    const double th = pi * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2 * pi * j / segments;
      o.vertices.push_back(c + Vec3{r * std::sin(th) * std::cos(ph),
                                    r * std::sin(th) * std::sin(ph), r * std::cos(th)});
    }
  }
  o.vertices.push_back(c + Vec3{0, 0, -r});
  const uint32_t south = static_cast<uint32_t>(o.vertices.size() - 1);
  auto ring = [&](int i, int j) {
    return static_cast<uint32_t>(1 + (i - 1) * segments + (j % segments));
  };
  for (int j = 0; j < segments; ++j) o.simplices.push_back({{0, ring(1, j), ring(1, j + 1)}});
  for (int i = 1; i + 1 < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      o.simplices.push_back({{ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)}});
      o.simplices.push_back({{ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)}});
    }
  }
  for (int j = 0; j < segments; ++j)
    o.simplices.push_back({{south, ring(rings - 1, j + 1), ring(rings - 1, j)}});
  return o;
}

SceneObject make_point3(const std::string& label, Vec3 c, double size) {
  SceneObject o;
  o.label = label;
  o.vertices = {c + Vec3{size, 0, 0}, c + Vec3{-size / 2, size, 0}, c + Vec3{-size / 2, -size, 0}};
  o.simplices = {{{0, 1, 2}}};
  return o;
}

SceneObject make_circle(const std::string& label, Vec3 c, double r, int n) {
  SceneObject o;
  o.label = label;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    o.vertices.push_back(c + Vec3{r * std::cos(a), r * std::sin(a), 0});
    o.simplices.push_back({{static_cast<uint32_t>(i), static_cast<uint32_t>((i + 1) % n), 0}});
  }
  return o;
}

SceneObject make_rect(const std::string& label, Vec3 lo, Vec3 hi) {
  SceneObject o;
  o.label = label;
  o.vertices = {{lo.x, lo.y, 0}, {hi.x, lo.y, 0}, {hi.x, hi.y, 0}, {lo.x, hi.y, 0}};
  o.simplices = {{{0, 1, 0}}, {{1, 2, 0}}, {{2, 3, 0}}, {{3, 0, 0}}};
  return o;
}

SceneObject make_segment(const std::string& label, Vec3 a, Vec3 b) {
  SceneObject o;
  o.label = label;
  o.vertices = {a, b};
  o.simplices = {{{0, 1, 0}}};
  return o;
}

SceneObject make_gear2d(const std::string& label, Vec3 c, double r_in, double r_out, int teeth,
                        double phase, int samples) {
  SceneObject o;
  o.label = label;
  const int n = teeth * samples;
  for (int i = 0; i < n; ++i) {
    const double a = phase + 2 * std::numbers::pi * i / n;
    const double t = std::fmod(static_cast<double>(i) / samples, 1.0);
    // Trapezoidal tooth profile: low, rise, high, fall.
    double r = r_in;
    if (t >= 0.25 && t < 0.75) r = r_out;
    o.vertices.push_back(c + Vec3{r * std::cos(a), r * std::sin(a), 0});
    o.simplices.push_back({{static_cast<uint32_t>(i), static_cast<uint32_t>((i + 1) % n), 0}});
  }
  return o;
}

Scene make_scene(int dimension, std::vector<SceneObject> objects) {
  Scene s;
  s.dimension = dimension;
  s.objects = std::move(objects);
  validate_scene(s);
  return s;
}

void round_to_decimals(Scene& scene, int places) {
  const double scale = std::pow(10.0, places);
  for (SceneObject& o : scene.objects)
    for (Vec3& v : o.vertices)
      for (int i = 0; i < 3; ++i) v[i] = std::round(v[i] * scale) / scale;
}

}  // namespace gvd::test

#pragma once

// Scenes built from the real-mesh corpus (tests/real_meshes/write_corpus.mjs writes it into
// the build tree: the Stanford bunny and dragon, the Utah teapot), each with its gap known by
// construction, for the tests and `make bench`.

#include <string>

#include "gvd/scene/scene.h"

namespace gvd::test {

/// The one object of a corpus file (`dir`/`file`: OBJ or PLY), labelled `label`. Throws
/// gvd::Error naming the file when it is missing: the corpus is written by write_corpus.mjs.
scene::SceneObject load_corpus_object(const std::string& dir, const std::string& file,
                                      const std::string& label);

/// `object` and its mirror image (labelled `mirror_label`) across the plane x = c, c being
/// `gap` / 2 beyond the object's largest x. The two are exactly `gap` apart: every pair of
/// their points is at least that far apart in x, and the vertex of largest x and its image are
/// exactly that far apart. The image's triangles are turned around, so that a closed object's
/// normals still point outward.
scene::Scene mirrored_pair(const scene::SceneObject& object, const std::string& mirror_label,
                           double gap);

/// `object` inside a closed box (labelled `label`) with walls `wall` thick whose inner faces lie
/// `gap` outside the object's bounding box on all six sides. The exact gap is `gap`: the
/// object's extreme points project into the inner faces, at that distance from their planes.
scene::Scene boxed(const scene::SceneObject& object, const std::string& label, double gap,
                   double wall);

}  // namespace gvd::test

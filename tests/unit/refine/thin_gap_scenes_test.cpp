// The thin-gap scene generators (tests/support/thin_gap_scenes.h) keep their promises: they
// check closed, oriented, welded meshes and the exact gap themselves and throw otherwise.

#include "support/thin_gap_scenes.h"

#include <gtest/gtest.h>

namespace gvd {

using namespace gvd::scene;

namespace {

TEST(ThinGapScenes, EveryGeneratorBuildsItsSceneAtWideAndThinGaps) {
  for (const double gap : {1e-2, 1e-5}) {
    SCOPED_TRACE(gap);
    test::BladeInSlotOptions blade;
    blade.gap = gap;
    EXPECT_EQ(test::make_blade_in_slot(blade).objects.size(), 2u);
    test::StackedPlatesOptions plates;
    plates.gap = gap;
    EXPECT_EQ(test::make_stacked_plates(plates).objects.size(), 6u);
    plates.inset = 0.1;
    EXPECT_EQ(test::make_stacked_plates(plates).objects.size(), 6u);
    test::ShaftInBoreOptions shaft;
    shaft.gap = gap;
    EXPECT_EQ(test::make_shaft_in_bore(shaft).objects.size(), 2u);
    // The ball in its socket: the least distance is g (the generator checks it by brute
    // force; here against the default domain), and the socket's two shells are its only
    // warning.
    test::BallInSocketOptions ball;
    ball.gap = gap;
    const Scene b = test::make_ball_in_socket(ball);
    ASSERT_EQ(b.objects.size(), 2u);
    EXPECT_NEAR(test::min_distance_3d(b.objects[0], b.objects[1]), gap * make_domain(b).side,
                1e-9 * gap);
    ASSERT_EQ(b.warnings.size(), 1u);
    EXPECT_EQ(b.warnings[0].kind, WarningKind::kMultipleComponents);
  }
  test::BallInSocketOptions too_big;
  too_big.radius = 0.5;
  EXPECT_THROW(test::make_ball_in_socket(too_big), std::invalid_argument);
  test::StackedPlatesOptions bad;
  bad.inset = 0.5;
  EXPECT_THROW(test::make_stacked_plates(bad), std::exception);
  for (const double gap : {1e-3, 1e-7}) {
    SCOPED_TRACE(gap);
    test::ParallelBarsOptions bars;
    bars.gap = gap;
    const Scene s = test::make_parallel_bars_2d(bars);
    ASSERT_EQ(s.objects.size(), 2u);
    EXPECT_NEAR(test::min_distance_2d(s.objects[0], s.objects[1]), gap * make_domain(s).side,
                1e-9 * gap);
    test::PolygonPairsOptions pairs;
    pairs.min_gap = gap;
    EXPECT_EQ(test::make_polygon_pairs_2d(pairs).objects.size(), 470u);
  }
}

}  // namespace
}  // namespace gvd

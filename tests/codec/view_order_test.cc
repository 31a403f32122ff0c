// codec/progressive/view_order.h: what a view sees orders the refinements.
#include "codec/progressive/view_order.h"

#include <cmath>

#include <gtest/gtest.h>

#include "codec/progressive/scene_levels.h"

namespace meshstream {
namespace {

View Camera() { return LookAtView({0, 0, 10}, {0, 0, 0}, 60, 1000, 800, 0.1, 100); }

Box Cube(double x, double z, double half = 1) { return {{x - half, -half, z - half}, {x + half, half, z + half}}; }

TEST(ViewOrder, CheckViewNamesTheField) {
  EXPECT_TRUE(CheckView(Camera()).ok());
  View v = Camera();
  v.viewport_width = 0;
  EXPECT_NE(CheckView(v).message().find("viewport_width"), std::string::npos);
  v = Camera();
  v.viewport_height = kMaxViewportPixels + 1;
  EXPECT_NE(CheckView(v).message().find("viewport_height"), std::string::npos);
  v = Camera();
  v.view_projection[5] = std::nan("");
  EXPECT_NE(CheckView(v).message().find("view_projection[5]"), std::string::npos);
  v = Camera();
  v.camera[2] = INFINITY;
  EXPECT_NE(CheckView(v).message().find("camera_position[2]"), std::string::npos);
  v = Camera();
  v.view_projection.fill(0);
  EXPECT_FALSE(CheckView(v).ok());
}

TEST(ViewOrder, FrustumAndPixels) {
  const View v = Camera();
  EXPECT_FALSE(OutsideFrustum(v, Cube(0, 0)));
  EXPECT_TRUE(OutsideFrustum(v, Cube(0, 20)));    // behind the camera
  EXPECT_TRUE(OutsideFrustum(v, Cube(50, 0)));    // far to the right
  EXPECT_TRUE(OutsideFrustum(v, Cube(0, -200)));  // beyond the far plane
  // A unit error at depth 9 (the cube's near face): 800 / 2 / tan(30 deg) / 9 pixels.
  EXPECT_NEAR(ScreenError(v, Cube(0, 0), 1.0), 400 / std::tan(3.14159265358979 / 6) / 9, 1e-6);
  // Twice as far, half the pixels; proportional to the error.
  EXPECT_NEAR(ScreenError(v, Cube(0, -9), 1.0) * 2, ScreenError(v, Cube(0, 0), 1.0), 1e-9);
  EXPECT_NEAR(ScreenError(v, Cube(0, 0), 3.0), 3 * ScreenError(v, Cube(0, 0), 1.0), 1e-9);
  // The camera inside the box: finite and large.
  const double inside = ScreenError(v, Cube(0, 10), 1.0);
  EXPECT_TRUE(std::isfinite(inside));
  EXPECT_GT(inside, 1e4);
}

TEST(ViewOrder, TheSeenPrimitiveRefinesFirstAndEachKeepsItsOrder) {
  // Two primitives with the same errors: one in front of the camera, one
  // behind it. Without a view, they alternate; with it, the seen one first.
  const std::vector<uint32_t> counts = {4, 4};
  const std::vector<std::vector<double>> errors = {{8, 4, 2, 1, 0}, {8, 4, 2, 1, 0}};
  const SceneLevels plain = ScheduleSceneLevels(counts, errors);
  EXPECT_EQ(plain.order[0].primitive, 0u);
  EXPECT_EQ(plain.order[1].primitive, 1u);
  const std::vector<Box> bounds = {Cube(0, 20), Cube(0, 0)};
  const SceneLevels seen = ScheduleSceneLevels(counts, ViewErrors(Camera(), bounds, errors));
  ASSERT_EQ(seen.order.size(), 8u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(seen.order[i].primitive, 1u);
    EXPECT_EQ(seen.order[i].refinement, i);
    EXPECT_EQ(seen.order[4 + i].primitive, 0u);
    EXPECT_EQ(seen.order[4 + i].refinement, i);
  }
  // A nearer seen primitive before a farther one of the same errors.
  const std::vector<Box> depth = {Cube(0, -30), Cube(0, 0)};
  const SceneLevels near_first = ScheduleSceneLevels(counts, ViewErrors(Camera(), depth, errors));
  EXPECT_EQ(near_first.order[0].primitive, 1u);
  EXPECT_EQ(near_first.order[1].primitive, 1u);
}

TEST(ViewOrder, TransformBoxHoldsTheCorners) {
  // A rotation of 90 degrees about z and a translation by (5, 0, 0).
  const std::array<double, 16> m = {0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 5, 0, 0, 1};
  const Box b = TransformBox({{0, 0, 0}, {2, 1, 1}}, m);
  EXPECT_NEAR(b.lo[0], 4, 1e-12);
  EXPECT_NEAR(b.hi[0], 5, 1e-12);
  EXPECT_NEAR(b.lo[1], 0, 1e-12);
  EXPECT_NEAR(b.hi[1], 2, 1e-12);
}

}  // namespace
}  // namespace meshstream

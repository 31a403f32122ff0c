#include "codec/mesh/quantization.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

TEST(PositionGrid, FollowsTheBriefOnReferencedVertices) {
  // Vertex 3 is unreferenced and far away: it must not widen the grid.
  const std::vector<Vec3f> positions = {{0, 0, 0}, {2, 0, 0}, {0, 1, 0.5f}, {100, 100, 100}};
  const std::vector<uint32_t> indices = {0, 1, 2};
  auto grid = PositionGrid(positions, indices, 11);
  ASSERT_TRUE(grid.ok()) << grid.status().ToString();
  EXPECT_EQ(grid->origin[0], 0.0f);
  EXPECT_EQ(grid->range, 2.0f);  // largest extent of the referenced box
  EXPECT_DOUBLE_EQ(grid->step(), 2.0 / 2047.0);
  const auto q = QuantizePositions(positions, grid.value());
  EXPECT_EQ(q[1][0], 2047);
  EXPECT_EQ(q[2][1], std::llround(1.0 / (2.0 / 2047.0)));
  EXPECT_EQ(q[2][2], std::llround(0.5 / (2.0 / 2047.0)));
}

TEST(PositionGrid, QuantizeDequantizeIsExactOnTheGrid) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-3.0f, 5.0f);
  std::vector<Vec3f> positions(2000);
  for (auto& p : positions) p = {u(rng), u(rng), u(rng)};
  for (int bits : {8, 11, 14, 16}) {
    auto grid = PositionGrid(positions, {}, bits);
    ASSERT_TRUE(grid.ok());
    for (const auto& p : positions) {
      for (int c = 0; c < 3; ++c) {
        const int64_t q = grid->Quantize(p[c], c);
        EXPECT_GE(q, 0);
        EXPECT_LE(q, static_cast<int64_t>(grid->max_value()));
        const float back = grid->Dequantize(q, c);
        EXPECT_LE(std::fabs(back - p[c]), grid->step() * 0.5 + 1e-6);
        EXPECT_EQ(grid->Quantize(back, c), q) << "bits " << bits;
      }
    }
  }
}

TEST(PositionGrid, SnapToGridIsIdempotent) {
  std::vector<Vec3f> positions = {{0.1f, 0.2f, 0.3f}, {1.7f, -0.4f, 2.2f}, {0.9f, 0.9f, 0.9f}};
  auto grid = PositionGrid(positions, {}, 12);
  ASSERT_TRUE(grid.ok());
  SnapToGrid(positions, grid.value());
  const auto first = QuantizePositions(positions, grid.value());
  std::vector<Vec3f> again = positions;
  SnapToGrid(again, grid.value());
  EXPECT_EQ(again, positions);
  EXPECT_EQ(QuantizePositions(again, grid.value()), first);
}

TEST(PositionGrid, RefusesBadBitsAndEmptyInput) {
  EXPECT_EQ(PositionGrid({{0, 0, 0}}, {}, 0).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(PositionGrid({{0, 0, 0}}, {}, 31).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(PositionGrid({}, {}, 11).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(PositionGrid({{0, 0, 0}}, {5}, 11).status().code(), StatusCode::kInvalidInput);
}

TEST(PositionGrid, FlatBoxUsesUnitRange) {
  auto grid = PositionGrid({{1, 1, 1}, {1, 1, 1}}, {}, 11);
  ASSERT_TRUE(grid.ok());
  EXPECT_EQ(grid->range, 1.0f);
  EXPECT_EQ(grid->Quantize(1.0f, 0), 0);
}

TEST(TexcoordGrid, MapsItsBoundingBoxOntoTheFullRange) {
  auto grid = GridOf(std::vector<Vec2f>{{0.25f, 0.5f}, {0.75f, 1.0f}}, 10);
  ASSERT_TRUE(grid.ok());
  EXPECT_EQ(grid->Quantize(0.25f, 0), 0);
  EXPECT_EQ(grid->Quantize(0.75f, 0), 1023);
  EXPECT_EQ(grid->Quantize(1.0f, 1), 1023);
}

TEST(NormalQuantization, OctahedralRoundTripIsIdempotentAndAccurate) {
  std::mt19937 rng(11);
  std::normal_distribution<float> g(0.0f, 1.0f);
  for (int bits : {6, 8, 10, 12}) {
    // Angular error bound of the octahedral grid: about pi/2^bits; allow 2x.
    const double max_angle = 2.0 * M_PI / (1 << bits) * 2.0;
    for (int i = 0; i < 5000; ++i) {
      Vec3f n = {g(rng), g(rng), g(rng)};
      const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      for (float& c : n) c = static_cast<float>(c / len);
      const auto q = QuantizeNormal(n, bits);
      const Vec3f back = DequantizeNormal(q, bits);
      const double dot = n[0] * back[0] + n[1] * back[1] + n[2] * back[2];
      EXPECT_LE(std::acos(std::min(1.0, dot)), max_angle) << "bits " << bits;
      EXPECT_EQ(QuantizeNormal(back, bits), q) << "bits " << bits << " sample " << i;
    }
  }
}

TEST(NormalQuantization, ZeroVectorMapsToPlusZ) {
  const Vec3f back = DequantizeNormal(QuantizeNormal({0, 0, 0}, 8), 8);
  EXPECT_NEAR(back[2], 1.0f, 1e-2);
}

}  // namespace
}  // namespace meshstream

// The scene's levels and sending order (codec/progressive/scene_levels.h).
#include <gtest/gtest.h>

#include "codec/progressive/scene_levels.h"

namespace meshstream {
namespace {

std::vector<std::pair<uint32_t, uint32_t>> Order(const SceneLevels& s) {
  std::vector<std::pair<uint32_t, uint32_t>> out;
  for (const ScheduledRefinement& r : s.order) out.push_back({r.primitive, r.refinement});
  return out;
}

TEST(SceneLevels, OnePrimitiveHasItsRefinementsAsLevels) {
  const SceneLevels s = ScheduleSceneLevels({3}, {{4, 2, 1, 0}});
  EXPECT_EQ(s.levels, 3u);
  EXPECT_EQ(s.applied, (std::vector<std::vector<uint32_t>>{{1, 2, 3}}));
  EXPECT_EQ(Order(s), (std::vector<std::pair<uint32_t, uint32_t>>{{0, 0}, {0, 1}, {0, 2}}));
  EXPECT_EQ(s.order[2].level, 3u);
}

TEST(SceneLevels, WithoutErrorsALevelIsOneRefinementOfEach) {
  const SceneLevels s = ScheduleSceneLevels({2, 3}, {{}, {}});
  EXPECT_EQ(s.levels, 3u);
  EXPECT_EQ(s.applied, (std::vector<std::vector<uint32_t>>{{1, 2, 2}, {1, 2, 3}}));
  EXPECT_EQ(Order(s), (std::vector<std::pair<uint32_t, uint32_t>>{{0, 0}, {1, 0}, {0, 1}, {1, 1}, {1, 2}}));
  // Errors of the wrong size for one primitive: the same.
  EXPECT_EQ(ScheduleSceneLevels({2, 3}, {{3, 1, 0}, {1, 0}}).applied, s.applied);
}

TEST(SceneLevels, TheLargerErrorGoesFirstAndLevelsArePrefixes) {
  // A: a coarse part (10 before its first refinement, 1 after); B: a smooth
  // one with four refinements. By error: A0 (10), B0 (5), B1 (4), B2 (3),
  // B3 (2), A1 (1). Six refinements in four levels: prefixes of 2, 3, 5, 6.
  const SceneLevels s = ScheduleSceneLevels({2, 4}, {{10, 1, 0}, {5, 4, 3, 2, 0}});
  EXPECT_EQ(s.levels, 4u);
  EXPECT_EQ(Order(s),
            (std::vector<std::pair<uint32_t, uint32_t>>{{0, 0}, {1, 0}, {1, 1}, {1, 2}, {1, 3}, {0, 1}}));
  EXPECT_EQ(s.applied, (std::vector<std::vector<uint32_t>>{{1, 1, 1, 2}, {1, 2, 4, 4}}));
  std::vector<uint32_t> levels;
  for (const ScheduledRefinement& r : s.order) levels.push_back(r.level);
  EXPECT_EQ(levels, (std::vector<uint32_t>{1, 1, 2, 3, 3, 4}));
  EXPECT_EQ(s.At(0, 0), 0u);
  EXPECT_EQ(s.At(1, 3), 4u);
  EXPECT_EQ(s.At(1, 99), 4u) << "beyond the last level: everything";
  EXPECT_EQ(s.At(7, 1), 0u) << "no such primitive";
}

TEST(SceneLevels, EqualErrorsKeepPrimitiveOrderAndGrowingErrorsKeepRefinementOrder) {
  const SceneLevels tie = ScheduleSceneLevels({1, 1}, {{2, 0}, {2, 0}});
  EXPECT_EQ(Order(tie), (std::vector<std::pair<uint32_t, uint32_t>>{{0, 0}, {1, 0}}));
  // Against the contract, errors that grow: the primitive's refinements
  // still go in their order (the running minimum orders them).
  const SceneLevels grow = ScheduleSceneLevels({3, 1}, {{1, 5, 9, 0}, {3, 0}});
  EXPECT_EQ(Order(grow), (std::vector<std::pair<uint32_t, uint32_t>>{{1, 0}, {0, 0}, {0, 1}, {0, 2}}));
  for (size_t p = 0; p < 2; ++p) {
    for (size_t l = 1; l < grow.applied[p].size(); ++l) EXPECT_LE(grow.applied[p][l - 1], grow.applied[p][l]);
  }
}

TEST(SceneLevels, PrimitivesWithoutRefinementsAndEmptyScenes) {
  const SceneLevels none = ScheduleSceneLevels({}, {});
  EXPECT_EQ(none.levels, 0u);
  EXPECT_TRUE(none.order.empty());
  const SceneLevels s = ScheduleSceneLevels({0, 2}, {{0}, {1, 0.5, 0}});
  EXPECT_EQ(s.levels, 2u);
  EXPECT_EQ(s.applied, (std::vector<std::vector<uint32_t>>{{0, 0}, {1, 2}}));
}

}  // namespace
}  // namespace meshstream

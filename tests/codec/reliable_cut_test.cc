// The reliable cut (codec/loss/reliable_cut.h): the importance of a
// refinement (split lengths times the final vertices below each split), the
// ranking by importance per byte, the prefix a budget buys, and the share a
// session moves for a reported loss.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "codec/loss/reliable_cut.h"

namespace meshstream {
namespace {

// Base vertex 0; refinement 0 splits 0 (-> 1, vector length 10); refinement
// 1 splits 0 (-> 2, length 3) and 1 (-> 3, length 4).
ProgressiveMesh TwoLevels() {
  ProgressiveMesh m;
  Refinement r0;
  r0.vertices_before = 1;
  r0.split_vertices = {0};
  r0.wings = {{0, 1}};
  r0.position_delta = {Vec3i{6, 8, 0}};
  Refinement r1;
  r1.vertices_before = 2;
  r1.split_vertices = {0, 1};
  r1.wings = {{0, 1}, {0, 1}};
  r1.position_delta = {Vec3i{3, 0, 0}, Vec3i{0, 0, 4}};
  m.refinements = {r0, r1};
  return m;
}

TEST(ReliableCut, ImportanceWeighsEachSplitByItsSubtree) {
  const std::vector<double> importance = RefinementImportance(TwoLevels());
  ASSERT_EQ(importance.size(), 2u);
  // Refinement 1: 3 * 2 + 4 * 2 = 14 (each split ends with two final
  // vertices); refinement 0: 10 * 4 (all four final vertices descend from it).
  EXPECT_NEAR(importance[0], 40.0 / 54.0, 1e-12);
  EXPECT_NEAR(importance[1], 14.0 / 54.0, 1e-12);
}

TEST(ReliableCut, ImportanceOfAMalformedMeshIsZeroNotACrash) {
  ProgressiveMesh m = TwoLevels();
  m.refinements[1].split_vertices[1] = 99;  // not a vertex
  for (double v : RefinementImportance(m)) EXPECT_EQ(v, 0.0);
  m = TwoLevels();
  m.refinements[0].position_delta.clear();
  for (double v : RefinementImportance(m)) EXPECT_EQ(v, 0.0);
  EXPECT_TRUE(RefinementImportance(ProgressiveMesh{}).empty());
}

TEST(ReliableCut, RankingIsByImportancePerByteCoarserFirstOnTies) {
  // Per byte: 0.1, 0.4, 0.2 (skipped: no datagrams), 0.1 (tie with 0), 0 (no importance).
  const std::vector<double> importance = {0.1, 0.4, 0.2, 0.2, 0.0};
  const std::vector<uint64_t> bytes = {1, 1, 0, 2, 5};
  EXPECT_EQ(RankRefinements(importance, bytes), (std::vector<uint32_t>{1, 0, 3}));
  EXPECT_TRUE(RankRefinements({0.5}, {1, 2}).empty()) << "sizes that disagree";
}

TEST(ReliableCut, ABudgetBuysTheLongestPrefixAndALargerOneKeepsIt) {
  const std::vector<uint32_t> ranking = {3, 0, 2, 1};
  const std::vector<uint64_t> bytes = {100, 1000, 300, 50};
  EXPECT_TRUE(CutForBudget(ranking, bytes, 49).empty());
  EXPECT_EQ(CutForBudget(ranking, bytes, 150), (std::vector<uint32_t>{0, 3}));
  // 450 would fit refinement 1? No: the prefix stops at the first that does not fit.
  EXPECT_EQ(CutForBudget(ranking, bytes, 449), (std::vector<uint32_t>{0, 3}));
  EXPECT_EQ(CutForBudget(ranking, bytes, 450), (std::vector<uint32_t>{0, 2, 3}));
  EXPECT_EQ(CutForBudget(ranking, bytes, 1449), (std::vector<uint32_t>{0, 2, 3}));
  EXPECT_EQ(CutForBudget(ranking, bytes, UINT64_MAX), (std::vector<uint32_t>{0, 1, 2, 3}));
  std::vector<uint32_t> previous;
  for (uint64_t budget = 0; budget < 1600; budget += 25) {
    const std::vector<uint32_t> cut = CutForBudget(ranking, bytes, budget);
    for (uint32_t i : previous) EXPECT_TRUE(std::find(cut.begin(), cut.end(), i) != cut.end()) << budget;
    previous = cut;
  }
  EXPECT_TRUE(CutForBudget({7}, bytes, 1000).empty()) << "a ranking beyond the stream ends the prefix";
}

TEST(ReliableCut, SessionShareFollowsTheReportedLoss) {
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.10, kReferenceLoss), 0.10);
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.10, 0.0), 0.05);
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.10, 0.03), 0.05);
  EXPECT_NEAR(ReliableShareForLoss(0.10, 0.18), 0.15, 1e-12);
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.10, 0.30), kMaxReliableShare);
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.10, 1.0), kMaxReliableShare);
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.10, std::nan("")), 0.05);
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.10, -1), 0.05);
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.0, 0.30), 0.0) << "an artifact without a cut stays without";
  EXPECT_DOUBLE_EQ(ReliableShareForLoss(0.5, 1.0), 0.5) << "never below the encoded share at high loss";
}

}  // namespace
}  // namespace meshstream

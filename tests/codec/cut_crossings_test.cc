// The crossings' order of cut edges (codec/progressive/cut_crossings.h,
// tool bit 9): ranks and pairs are inverse over every candidate, the rank is
// a permutation of the D floor(D/2) candidates, and a ring stretched along
// one axis predicts its wings where the cut crosses it.
#include "codec/progressive/cut_crossings.h"

#include <cmath>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "codec/progressive/geometry_prediction.h"

namespace meshstream {
namespace {

// Every candidate's rank leads back to it, the ranks are 0..D floor(D/2) - 1,
// and rank 0 is the predicted pair whenever it is a candidate.
void ExpectAnOrder(const CutCrossings& c, size_t d, const std::string& what) {
  std::set<uint32_t> ranks;
  for (size_t a = 0; a < d; ++a) {
    for (size_t k = 1; k < d; ++k) {
      const size_t b = (a + k) % d;
      uint32_t rank = 0;
      if (2 * k > d) {
        EXPECT_FALSE(c.RankOf(a, b, &rank)) << what;
        continue;
      }
      ASSERT_TRUE(c.RankOf(a, b, &rank)) << what;
      size_t pa = 0, pb = 0;
      ASSERT_TRUE(c.PairAt(rank, &pa, &pb)) << what << " rank " << rank;
      ASSERT_EQ(pa, a) << what << " rank " << rank;
      ASSERT_EQ(pb, b) << what << " rank " << rank;
      ranks.insert(rank);
    }
  }
  EXPECT_EQ(ranks.size(), d * (d / 2)) << what;
  EXPECT_EQ(*ranks.rbegin(), d * (d / 2) - 1) << what;
  size_t pa = 0, pb = 0;
  EXPECT_FALSE(c.PairAt(static_cast<uint32_t>(d * (d / 2)), &pa, &pb)) << what;
  const size_t p1 = c.predicted_first(), p2 = c.predicted_second();
  if (p1 != p2) {
    const size_t lo = std::min(p1, p2), hi = std::max(p1, p2);
    uint32_t rank = 99;
    if (2 * (hi - lo) <= d) {
      ASSERT_TRUE(c.RankOf(lo, hi, &rank));
    } else {
      ASSERT_TRUE(c.RankOf(hi, lo, &rank));
    }
    EXPECT_EQ(rank, 0u) << what << " predicted " << p1 << ", " << p2;
  }
}

TEST(CutCrossings, RankAndPairAreInverseOnEveryCandidate) {
  std::mt19937 rng(5);
  for (int i = 0; i < 4000; ++i) {
    const size_t d = 3 + i % (kMaxRankedValence - 2);
    // Large, tiny (ties everywhere, chords that vanish) and flat rings.
    const int32_t extent = i % 3 == 0 ? 3 : i % 3 == 1 ? 4000 : (1 << 24);
    std::uniform_int_distribution<int32_t> pos(-extent, extent);
    std::vector<Vec3i> ring(d);
    for (Vec3i& x : ring) x = {pos(rng), pos(rng), pos(rng) / (1 + i % 5)};
    const Vec3i w = {pos(rng) / 8, pos(rng) / 8, 0};
    CutCrossings c;
    ASSERT_TRUE(c.Reset(w, ring.data(), d, RingLocalFrame(w, ring.data(), d)));
    ExpectAnOrder(c, d, "ring " + std::to_string(i));
  }
  CutCrossings c;
  std::vector<Vec3i> too_many(kMaxRankedValence + 1, Vec3i{1, 2, 3});
  EXPECT_FALSE(c.Reset({0, 0, 0}, too_many.data(), too_many.size(), LocalFrame{}));
  EXPECT_FALSE(c.Reset({0, 0, 0}, too_many.data(), 2, LocalFrame{}));
}

// Two vertices a split vector apart along x became w: their ring is an
// ellipse long in x, and the cut edges cross it at the ends of its short
// axis (angles 90 and 270 degrees: ring positions D/4 and 3D/4). Turned by
// 90 degrees, the prediction turns with it.
TEST(CutCrossings, AStretchedRingPredictsTheWingsAcrossItsLongAxis) {
  for (size_t d : {8u, 12u}) {
    for (int turned = 0; turned < 2; ++turned) {
      std::vector<Vec3i> ring(d);
      for (size_t k = 0; k < d; ++k) {
        const double angle = 2 * M_PI * static_cast<double>(k) / static_cast<double>(d);
        const double x = 4000 * std::cos(angle), y = 1000 * std::sin(angle);
        ring[k] = turned ? Vec3i{static_cast<int32_t>(std::lround(-y)), static_cast<int32_t>(std::lround(x)), 7}
                         : Vec3i{static_cast<int32_t>(std::lround(x)), static_cast<int32_t>(std::lround(y)), 7};
      }
      const Vec3i w = {0, 0, 0};
      CutCrossings c;
      ASSERT_TRUE(c.Reset(w, ring.data(), d, RingLocalFrame(w, ring.data(), d)));
      const std::set<size_t> predicted = {c.predicted_first(), c.predicted_second()};
      EXPECT_EQ(predicted, (std::set<size_t>{d / 4, 3 * d / 4})) << "D " << d << (turned ? " turned" : "");
      uint32_t rank = 99;
      ASSERT_TRUE(c.RankOf(d / 4, 3 * d / 4, &rank));
      EXPECT_EQ(rank, 0u);
      // The next pairs cost one step: a wing one position away.
      ASSERT_TRUE(c.RankOf(d / 4 + 1, 3 * d / 4, &rank));
      EXPECT_GE(rank, 2u);  // after the two orientations of cost 0 (k = D/2)
      EXPECT_LT(rank, 2u + 8u);
      ExpectAnOrder(c, d, "ellipse");
    }
  }
}

}  // namespace
}  // namespace meshstream

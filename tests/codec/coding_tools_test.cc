// The coding tools of format version 2 one by one: the local frame's integer
// rotation, the Laplacian split prediction, the cut-edge ranking and the
// normal prediction (codec/progressive/{local_frame,geometry_prediction,
// wing_rank,normal_prediction}.h).
#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "codec/mesh/quantization.h"
#include "codec/progressive/geometry_prediction.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/normal_prediction.h"
#include "codec/progressive/wing_rank.h"

namespace meshstream {
namespace {

TEST(LocalFrame, IsExactlyInvertibleForEveryNormal) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int32_t> big(-(1 << 27), 1 << 27), small(-50, 50), normal(-100000, 100000);
  const std::vector<WideVec3> normals = {{0, 0, 0}, {0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, -5, 0},
                                         {__int128{1} << 100, -(__int128{1} << 99), 3}};
  for (int i = 0; i < 2000; ++i) {
    const WideVec3 n = i < static_cast<int>(normals.size()) ? normals[i] : WideVec3{normal(rng), normal(rng), normal(rng)};
    const LocalFrame f = LocalFrame::FromNormal(n);
    for (int k = 0; k < 8; ++k) {
      const Vec3i v = k % 2 ? Vec3i{big(rng), big(rng), big(rng)} : Vec3i{small(rng), small(rng), small(rng)};
      ASSERT_EQ(f.Inverse(f.Forward(v)), v) << "normal " << i << " vector " << k;
    }
  }
}

TEST(LocalFrame, TakesTheNormalToTheZAxisAndKeepsLengths) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int32_t> c(-1000, 1000);
  for (int i = 0; i < 500; ++i) {
    const Vec3i n = {c(rng), c(rng), c(rng)};
    const double len = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
    if (len < 10) continue;
    const LocalFrame f = LocalFrame::FromNormal({n[0], n[1], n[2]});
    const Vec3i along = f.Forward(n);
    EXPECT_NEAR(along[2], len, 0.02 * len + 2) << i;
    EXPECT_LE(std::abs(along[0]) + std::abs(along[1]), 0.03 * len + 3) << i;
    // A tangent vector stays in the plane.
    const Vec3i t = {n[1], -n[0], 0};
    const Vec3i across = f.Forward(t);
    EXPECT_LE(std::abs(across[2]), 0.03 * len + 3) << i;
  }
}

TEST(LocalFrame, IntegerSqrtIsTheFloor) {
  for (int64_t v : {int64_t{0}, int64_t{1}, int64_t{2}, int64_t{3}, int64_t{4}, int64_t{99}, int64_t{100},
                    (int64_t{1} << 62) - 1, int64_t{4611686014132420609}}) {
    const int64_t r = IntegerSqrt(v);
    EXPECT_LE(__int128{r} * r, v) << v;
    EXPECT_GT(__int128{r + 1} * (r + 1), v) << v;
  }
}

// A flat hexagon around w = 0, stretched along x: the split vector the
// Laplacian predicts for the cut between ring[1] and ring[4] (a vertical
// chord) points along x, from the new vertex's side to w's.
std::vector<Vec3i> Hexagon() {
  std::vector<Vec3i> ring;
  for (int k = 0; k < 6; ++k) {
    const double a = k * M_PI / 3;
    ring.push_back({static_cast<int32_t>(std::lround(1500 * std::cos(a))), static_cast<int32_t>(std::lround(1000 * std::sin(a))), 0});
  }
  return ring;
}

TEST(GeometryPrediction, PredictsAcrossTheCutAndRoundsHalvesAway) {
  const std::vector<Vec3i> ring = Hexagon();
  // w keeps ring[a..b] = ring[1..4] (x <= 750), the new vertex ring[4..1] (x >= 750... ring[5], ring[0]).
  const Vec3i p = ScalePrediction(PredictSplit(ring.data(), ring.size(), 1, 4), kAlphaOne);
  EXPECT_LT(p[0], -100);  // u (w's side, negative x) minus v (positive x)
  EXPECT_EQ(p[2], 0);
  EXPECT_EQ(ScalePrediction(PredictSplit(ring.data(), ring.size(), 1, 4), 0), (Vec3i{0, 0, 0}));
  SplitPrediction half;
  half.numerator = {16, -16, 48};
  half.denominator = 1;  // times alpha 1 / 32: 0.5, -0.5, 1.5
  EXPECT_EQ(ScalePrediction(half, 1), (Vec3i{1, -1, 2}));
  // Valence beyond the limit predicts nothing.
  std::vector<Vec3i> large(kMaxPredictedValence + 1, Vec3i{5, 5, 5});
  EXPECT_EQ(ScalePrediction(PredictSplit(large.data(), large.size(), 0, 3), 40), (Vec3i{0, 0, 0}));
}

TEST(GeometryPrediction, CodingIsExactlyReversibleUnderEveryTool) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int32_t> pos(0, (1 << 14) - 1), delta(-3000, 3000);
  for (int i = 0; i < 3000; ++i) {
    const size_t d = 3 + i % 10;
    std::vector<Vec3i> ring(d);
    for (Vec3i& x : ring) x = {pos(rng), pos(rng), pos(rng)};
    const Vec3i w = {pos(rng), pos(rng), pos(rng)};
    const size_t a = i % d, b = (a + 1 + i % (d - 1)) % d;
    const LocalFrame frame = RingLocalFrame(w, ring.data(), d);
    for (uint8_t tools = 0; tools < 4; ++tools) {
      const SplitCoding coding{tools, static_cast<uint32_t>(i % 64), 0};
      const Vec3i v = {delta(rng), delta(rng), delta(rng)};
      const Vec3i coded = CodeSplitVector(coding, v, ring.data(), d, a, b, frame);
      ASSERT_EQ(DecodeSplitVector(coding, coded, ring.data(), d, a, b, frame), v) << i << " tools " << int(tools);
      if (tools == 0) EXPECT_EQ(coded, v);
    }
  }
}

TEST(WingRank, RanksAndPairsAreInverseAndAPermutation) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int32_t> pos(-2000, 2000);
  for (int i = 0; i < 500; ++i) {
    const size_t d = 3 + i % (kMaxRankedValence - 2);
    std::vector<Vec3i> ring(d);
    for (Vec3i& x : ring) x = {pos(rng), pos(rng), pos(rng) / 10};
    const Vec3i w = {0, 0, 0};
    WingRanking ranking;
    ASSERT_TRUE(ranking.Reset(w, ring.data(), d, RingLocalFrame(w, ring.data(), d)));
    std::set<uint32_t> ranks;
    for (size_t a = 0; a < d; ++a) {
      for (size_t k = 1; k < d; ++k) {
        const size_t b = (a + k) % d;
        uint32_t rank = 0;
        if (2 * k > d) {
          EXPECT_FALSE(ranking.RankOf(a, b, &rank));  // the encoder's orientation never has these
          continue;
        }
        ASSERT_TRUE(ranking.RankOf(a, b, &rank));
        size_t pa = 0, pb = 0;
        ASSERT_TRUE(ranking.PairAt(rank, &pa, &pb));
        EXPECT_EQ(pa, a);
        EXPECT_EQ(pb, b);
        ranks.insert(rank);
      }
    }
    EXPECT_EQ(ranks.size(), d * (d / 2));
    EXPECT_EQ(*ranks.rbegin(), d * (d / 2) - 1);
    size_t pa = 0, pb = 0;
    EXPECT_FALSE(ranking.PairAt(static_cast<uint32_t>(d * (d / 2)), &pa, &pb));
  }
  WingRanking ranking;
  std::vector<Vec3i> too_many(kMaxRankedValence + 1, Vec3i{1, 2, 3});
  EXPECT_FALSE(ranking.Reset({0, 0, 0}, too_many.data(), too_many.size(), LocalFrame{}));
}

TEST(WingRank, SmallRanksAgreeWithTheFullOrderOnTiesAndZeroChords) {
  // Tiny coordinates: many pairs share a key, and some chords vanish in the
  // tangent plane (t = 0). PairAt finds ranks 0-3 without ordering every
  // pair; RankOf orders them all: they must agree.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int32_t> pos(-3, 3);
  for (int i = 0; i < 3000; ++i) {
    const size_t d = 3 + i % 12;
    std::vector<Vec3i> ring(d);
    for (Vec3i& x : ring) x = {pos(rng), pos(rng), pos(rng) * (i % 3)};
    const Vec3i w = {0, 0, 0};
    WingRanking ranking;
    ASSERT_TRUE(ranking.Reset(w, ring.data(), d, RingLocalFrame(w, ring.data(), d)));
    for (size_t a = 0; a < d; ++a) {
      for (size_t k = 1; 2 * k <= d; ++k) {
        uint32_t rank = 0;
        ASSERT_TRUE(ranking.RankOf(a, (a + k) % d, &rank));
        size_t pa = 0, pb = 0;
        ASSERT_TRUE(ranking.PairAt(rank, &pa, &pb));
        ASSERT_EQ(pa, a) << i << " rank " << rank;
        ASSERT_EQ(pb, (a + k) % d) << i << " rank " << rank;
      }
    }
  }
}

TEST(WingRank, TheChordAcrossTheStretchThroughWComesFirst) {
  // Stretched along x, so the cut should run across x, through w: of the
  // three diagonals, ring[1]-ring[4] and ring[2]-ring[5] (at +-49 degrees from
  // x) come before ring[0]-ring[3] (along x), and a short chord that misses w
  // comes after them.
  const std::vector<Vec3i> ring = Hexagon();
  WingRanking ranking;
  ASSERT_TRUE(ranking.Reset({0, 0, 0}, ring.data(), ring.size(), RingLocalFrame({0, 0, 0}, ring.data(), ring.size())));
  uint32_t r14 = 0, r25 = 0, r03 = 0, r01 = 0;
  ASSERT_TRUE(ranking.RankOf(1, 4, &r14));
  ASSERT_TRUE(ranking.RankOf(2, 5, &r25));
  ASSERT_TRUE(ranking.RankOf(0, 3, &r03));
  ASSERT_TRUE(ranking.RankOf(0, 1, &r01));
  EXPECT_LT(std::min(r14, r25), 2u);
  EXPECT_GT(r03, std::max(r14, r25));
  EXPECT_GT(r01, std::max(r14, r25));  // a short chord far from w
}

TEST(NormalPrediction, OctahedralCodesMatchTheFormatsQuantizer) {
  std::mt19937 rng(9);
  std::normal_distribution<double> g(0, 1);
  for (int bits : {6, 8, 10, 12}) {
    for (int i = 0; i < 2000; ++i) {
      const Vec3f n = {static_cast<float>(g(rng)), static_cast<float>(g(rng)), static_cast<float>(g(rng))};
      const double scale = 1 << 20;
      const WideVec3 wide = {static_cast<__int128>(std::llround(n[0] * scale)),
                             static_cast<__int128>(std::llround(n[1] * scale)),
                             static_cast<__int128>(std::llround(n[2] * scale))};
      const std::array<int32_t, 2> q = OctahedralCode(wide, bits);
      const std::array<uint32_t, 2> f = QuantizeNormal(n, bits);
      // The integer code of the rounded direction is the float code or a neighbour.
      EXPECT_LE(std::abs(q[0] - static_cast<int32_t>(f[0])), 1) << bits << " " << i;
      EXPECT_LE(std::abs(q[1] - static_cast<int32_t>(f[1])), 1) << bits << " " << i;
    }
  }
  const int32_t m = (1 << 8) - 1;
  EXPECT_EQ(OctahedralCode({0, 0, 0}, 8), (std::array<int32_t, 2>{(m + 1) / 2, (m + 1) / 2}));
  EXPECT_EQ(OctahedralCode({0, 0, 5}, 8), OctahedralCode({0, 0, 0}, 8));
}

TEST(NormalPrediction, PredictsTheSplitsOwnNormals) {
  // A fan around w = 0 in the plane z = 0, split along x: both new vertices
  // lie in the plane, so both predicted normals are +z and their difference 0.
  std::vector<Vec3i> ring = Hexagon();
  QuantizedMesh base;
  base.positions = {{0, 0, 0}};
  for (const Vec3i& p : ring) base.positions.push_back(p);
  for (uint32_t k = 0; k < 6; ++k) base.indices.insert(base.indices.end(), {0, 1 + k, 1 + (k + 1) % 6});
  RefinementState state;
  ASSERT_TRUE(state.Reset(base).ok());
  Refinement r;
  r.vertices_before = 7;
  r.split_vertices = {0};
  std::vector<uint32_t>& cyclic = state.scratch_ring;
  ASSERT_TRUE(state.connectivity.CyclicRing(0, cyclic));
  r.wings = {WingsOf(cyclic, 1, 4)};
  r.position_delta = {Vec3i{-400, 0, 0}};
  size_t a = 0, b = 0;
  ASSERT_TRUE(WingPositions(cyclic, r.wings[0], &a, &b));
  const uint32_t n = state.ApplySplitAt(r, 0, a, b);
  EXPECT_EQ(PredictNormalDelta(state, 0, n, 8), (std::array<int32_t, 2>{0, 0}));
  const WideVec3 vn = VertexNormal(state, n);
  EXPECT_GT(vn[2], 0);
  EXPECT_EQ(vn[0], 0);
  EXPECT_EQ(vn[1], 0);
}

}  // namespace
}  // namespace meshstream

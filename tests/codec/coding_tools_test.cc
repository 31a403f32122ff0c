// The coding tools of format version 2 one by one: the local frame's integer
// rotation, the Laplacian split prediction, the cut-edge ranking, the
// normal prediction and the texture coordinate prediction
// (codec/progressive/{local_frame,geometry_prediction,wing_rank,
// normal_prediction,texcoord_prediction}.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "codec/mesh/quantization.h"
#include "codec/progressive/encoder.h"
#include "codec/progressive/midpoint.h"
#include "codec/progressive/geometry_prediction.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/normal_prediction.h"
#include "codec/progressive/texcoord_prediction.h"
#include "codec/progressive/wing_rank.h"
#include "tests/common/uv_sphere.h"

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
    for (ToolSet tools = 0; tools < 4; ++tools) {
      const SplitCoding coding{tools, static_cast<uint32_t>(i % 64), 0};
      const Vec3i v = {delta(rng), delta(rng), delta(rng)};
      const Vec3i coded = CodeSplitVector(coding, v, ring.data(), d, a, b, frame);
      ASSERT_EQ(DecodeSplitVector(coding, coded, ring.data(), d, a, b, frame), v) << i << " tools " << int(tools);
      if (tools == 0) {
        EXPECT_EQ(coded, v);
      }
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

TEST(WingRank, KeyAtMostIsTheKeyComparedWithoutDivision) {
  // Scores at and next to every boundary of trunc(2^16 score / length):
  // K length / 2^16 and (K + 1) length / 2^16, for keys of both signs and 0.
  std::mt19937_64 rng(23);
  std::uniform_int_distribution<int64_t> key_of(-(int64_t{1} << 46) + 2, (int64_t{1} << 46) - 2);
  std::uniform_int_distribution<int64_t> length_of(1, (int64_t{1} << 27) - 1);
  int64_t below = 0, above = 0;
  for (int i = 0; i < 200000; ++i) {
    const int64_t key = i % 7 == 0 ? (i % 3) - 1 : key_of(rng) >> (rng() % 40);
    const int64_t length = i % 5 == 0 ? 1 + int64_t(rng() % 4) : std::max<int64_t>(1, length_of(rng) >> (rng() % 20));
    for (int64_t edge : {key, key + 1}) {
      const __int128 at = static_cast<__int128>(edge) * length;  // score * 2^16 at the boundary
      const int64_t centre = static_cast<int64_t>(at >> 16);    // floor
      for (int64_t score = centre - 2; score <= centre + 2; ++score) {
        const bool at_most = RankKey(score, length) <= key;
        ASSERT_EQ(RankKeyAtMost(score, length, key), at_most) << score << " / " << length << " key " << key;
        (at_most ? below : above) += 1;
      }
    }
  }
  EXPECT_GT(below, 100000);
  EXPECT_GT(above, 100000);
}

TEST(WingRank, PairOfRankIsResetThenPairAt) {
  // The decoder's path skips the division for pairs that cannot be among the
  // first rank + 1; it must name the same wings as the full order for every
  // rank, on rings with many equal keys (tiny coordinates), zero chords, and
  // extents near int32 (the 128-bit comparison's bounds).
  std::mt19937 rng(17);
  const int32_t spans[] = {2, 3, 40, 2000, 1 << 20, INT32_MAX / 2};
  for (int i = 0; i < 6000; ++i) {
    const int32_t span = spans[i % 6];
    std::uniform_int_distribution<int32_t> pos(-span, span);
    const size_t d = 3 + (i / 6) % (kMaxRankedValence - 2);
    std::vector<Vec3i> ring(d);
    for (Vec3i& x : ring) x = {pos(rng), pos(rng), pos(rng) / (1 + i % 4)};
    const Vec3i w = {pos(rng) / 8, pos(rng) / 8, 0};
    const LocalFrame frame = RingLocalFrame(w, ring.data(), d);
    WingRanking full, direct;
    ASSERT_TRUE(full.Reset(w, ring.data(), d, frame));
    for (uint32_t rank = 0; rank <= d * (d / 2); ++rank) {
      size_t fa = 0, fb = 0, da = 0, db = 0;
      const bool f = full.PairAt(rank, &fa, &fb);
      ASSERT_EQ(direct.PairOfRank(w, ring.data(), d, frame, rank, &da, &db), f) << i << " rank " << rank;
      if (!f) continue;
      ASSERT_EQ(da, fa) << i << " span " << span << " d " << d << " rank " << rank;
      ASSERT_EQ(db, fb) << i << " span " << span << " d " << d << " rank " << rank;
    }
  }
  WingRanking ranking;
  size_t a = 0, b = 0;
  std::vector<Vec3i> too_many(kMaxRankedValence + 1, Vec3i{1, 2, 3});
  EXPECT_FALSE(ranking.PairOfRank({0, 0, 0}, too_many.data(), too_many.size(), LocalFrame{}, 0, &a, &b));
  EXPECT_FALSE(ranking.PairOfRank({0, 0, 0}, too_many.data(), 2, LocalFrame{}, 0, &a, &b));
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


// The ring's values of a channel, one per ring vertex (ids 0..D-1, stride 1).
std::vector<uint32_t> Ids(size_t d) {
  std::vector<uint32_t> ids(d);
  for (size_t k = 0; k < d; ++k) ids[k] = static_cast<uint32_t>(k);
  return ids;
}

TEST(TexcoordPrediction, IsExactOnALinearChart) {
  // In the plane z = 0 the local frame is the identity: a channel that is a
  // linear function of the position is predicted exactly for any split vector.
  const std::vector<Vec3i> ring = Hexagon();
  const std::vector<uint32_t> ids = Ids(ring.size());
  const Vec3i m = {0, 0, 0};
  const LocalFrame frame = RingLocalFrame(m, ring.data(), ring.size());
  std::vector<int32_t> values(ring.size());
  for (size_t k = 0; k < ring.size(); ++k) values[k] = 500 + 3 * ring[k][0] - 2 * ring[k][1];
  for (const Vec3i& d : {Vec3i{-400, 0, 0}, Vec3i{17, -31, 0}, Vec3i{0, 0, 0}, Vec3i{250, 90, 7}}) {
    RingChannelMap map;
    map.Reset(m, d, ring.data(), ring.size(), frame);
    EXPECT_EQ(map.Predict(values.data(), 1, ids.data(), 500), 3 * d[0] - 2 * d[1]) << d[0] << " " << d[1];
  }
  // A constant channel (a colour's alpha) predicts 0.
  const std::vector<int32_t> constant(ring.size(), 77);
  RingChannelMap map;
  map.Reset(m, {-400, 10, 0}, ring.data(), ring.size(), frame);
  EXPECT_EQ(map.Predict(constant.data(), 1, ids.data(), 77), 0);
}

TEST(TexcoordPrediction, IsCloseOnATiltedChart) {
  // A tilted plane through w: the channel is linear in the tangent plane's
  // coordinates; the frame's rotation is exact to about 2^-16.
  std::mt19937 rng(13);
  std::uniform_int_distribution<int32_t> c(-3000, 3000);
  for (int i = 0; i < 200; ++i) {
    const Vec3i m = {c(rng), c(rng), c(rng)};
    const Vec3i e1 = {c(rng), c(rng), c(rng) / 4}, e2 = {-e1[1] / 2, e1[0] / 2, c(rng)};
    std::vector<Vec3i> ring;
    std::vector<int32_t> values;
    const size_t d = 4 + i % 8;
    for (size_t k = 0; k < d; ++k) {
      const double a = 2 * M_PI * double(k) / double(d);
      const double x = std::cos(a), y = std::sin(a);
      ring.push_back({m[0] + int32_t(std::lround(x * e1[0] + y * e2[0])), m[1] + int32_t(std::lround(x * e1[1] + y * e2[1])),
                      m[2] + int32_t(std::lround(x * e1[2] + y * e2[2]))});
      values.push_back(int32_t(std::lround(1000 + 400 * x - 250 * y)));
    }
    const LocalFrame frame = RingLocalFrame(m, ring.data(), d);
    // The split vector halfway to ring[0] (x = 1, y = 0): the channel changes by 400 / 2.
    const Vec3i half = {(ring[0][0] - m[0]) / 2, (ring[0][1] - m[1]) / 2, (ring[0][2] - m[2]) / 2};
    RingChannelMap map;
    map.Reset(m, half, ring.data(), d, frame);
    const std::vector<uint32_t> ids = Ids(d);
    EXPECT_NEAR(map.Predict(values.data(), 1, ids.data(), 1000), 200, 12) << i;
  }
}

TEST(TexcoordPrediction, DegenerateRingsPredictZero) {
  const std::vector<uint32_t> ids = Ids(kMaxPredictedValence + 1);
  std::vector<int32_t> values(kMaxPredictedValence + 1);
  for (size_t k = 0; k < values.size(); ++k) values[k] = int32_t(k * 100);
  const Vec3i m = {0, 0, 0};
  RingChannelMap map;
  // Collinear in the tangent plane (the ring on the x axis).
  const std::vector<Vec3i> line = {{-100, 0, 0}, {50, 0, 0}, {100, 0, 0}, {-30, 0, 0}};
  map.Reset(m, {20, 0, 0}, line.data(), line.size(), RingLocalFrame(m, line.data(), line.size()));
  EXPECT_EQ(map.Predict(values.data(), 1, ids.data(), 0), 0);
  // Too few and too many ring vertices.
  const std::vector<Vec3i> two = {{100, 0, 0}, {0, 100, 0}};
  map.Reset(m, {20, 0, 0}, two.data(), two.size(), LocalFrame{});
  EXPECT_EQ(map.Predict(values.data(), 1, ids.data(), 0), 0);
  std::vector<Vec3i> large;
  for (size_t k = 0; k <= kMaxPredictedValence; ++k) large.push_back({int32_t(k % 7) * 100, int32_t(k % 5) * 100, 0});
  map.Reset(m, {20, 0, 0}, large.data(), large.size(), LocalFrame{});
  EXPECT_EQ(map.Predict(values.data(), 1, ids.data(), 0), 0);
}

TEST(TexcoordPrediction, ExtremeValuesAreClampedAndTheCodingIsReversible) {
  // Positions and values at the extremes of int32 and of a 30-bit grid: the
  // arithmetic stays in range (the sanitizer build checks it), the prediction
  // stays within [-2^30, 2^30], and residual = e - p comes back exactly for
  // every difference of a 30-bit grid.
  std::mt19937 rng(17);
  const int32_t top = (1 << 30) - 1;
  std::uniform_int_distribution<int32_t> any(INT32_MIN, INT32_MAX), grid(0, top), pick(0, 3);
  auto extreme = [&](std::uniform_int_distribution<int32_t>& dist, int32_t lo, int32_t hi) {
    const int32_t r = pick(rng);
    return r == 0 ? lo : r == 1 ? hi : dist(rng);
  };
  for (int i = 0; i < 3000; ++i) {
    const size_t d = 3 + i % 20;
    const bool hostile = i % 2 == 1;
    auto position = [&] {
      return hostile ? Vec3i{extreme(any, INT32_MIN, INT32_MAX), extreme(any, INT32_MIN, INT32_MAX),
                             extreme(any, INT32_MIN, INT32_MAX)}
                     : Vec3i{extreme(grid, 0, top), extreme(grid, 0, top), extreme(grid, 0, top)};
    };
    std::vector<Vec3i> ring(d);
    for (Vec3i& x : ring) x = position();
    std::vector<int32_t> values(d);
    for (int32_t& v : values) v = hostile ? extreme(any, INT32_MIN, INT32_MAX) : extreme(grid, 0, top);
    const Vec3i m = position(), split = position();
    const LocalFrame frame = RingLocalFrame(m, ring.data(), d);
    RingChannelMap map;
    map.Reset(m, split, ring.data(), d, frame);
    const std::vector<uint32_t> ids = Ids(d);
    const int32_t coarse = hostile ? extreme(any, INT32_MIN, INT32_MAX) : extreme(grid, 0, top);
    const int32_t p = map.Predict(values.data(), 1, ids.data(), coarse);
    ASSERT_LE(std::abs(int64_t{p}), int64_t{1} << 30) << i;
    if (!hostile) {
      // Both values of the split on the grid: e in [-(2^30 - 1), 2^30 - 1].
      const int32_t vw = extreme(grid, 0, top), vn = extreme(grid, 0, top);
      const int32_t e = vw - vn;
      const int64_t residual = int64_t{e} - p;
      ASSERT_GE(residual, INT32_MIN);
      ASSERT_LE(residual, INT32_MAX);
      ASSERT_EQ(static_cast<int32_t>(residual) + int64_t{p}, e);
      const int32_t mid = Midpoint(vw, vn);
      ASSERT_EQ(FromMidpoint(mid, e), vw);
    }
  }
}

// A bumpy sphere with two texture coordinate sets and a colour (one value
// per vertex, so the UVs wrap around at phi = 0: splits there straddle the
// jump, which costs bits, never correctness).
Primitive ColouredSphere(int rings, int segments) {
  Primitive p;
  p.texcoords.resize(2);
  auto add = [&p](double theta, double phi) {
    const double r = 1.0 + 0.08 * std::sin(3 * phi) * std::sin(2 * theta);
    const double x = std::sin(theta) * std::cos(phi), y = std::sin(theta) * std::sin(phi), z = std::cos(theta);
    p.positions.push_back({float(r * x), float(r * y), float(r * z)});
    p.texcoords[0].push_back({float(phi / (2 * M_PI)), float(theta / M_PI)});
    p.texcoords[1].push_back({float(0.5 + 0.5 * x), float(0.5 + 0.5 * y)});
    p.colors.push_back({float(0.5 + 0.5 * x), float(0.5 + 0.5 * z), float(0.5 + 0.25 * std::sin(2 * phi)), 1.0f});
  };
  test_util::BuildUvSphere(rings, segments, &p, add);
  return p;
}

StatusOr<EncodedBase> IdentityBase(const QuantizedMesh& base, int) {
  EncodedBase e;
  e.decoded = base;
  e.bytes = {0};
  return e;
}

TEST(TexcoordPrediction, StreamRoundTripWithTexcoordsAndColoursUnderEveryTool) {
  ProgressiveEncodeOptions options;
  auto enc = EncodeProgressive(ColouredSphere(24, 32), options, IdentityBase);
  ASSERT_TRUE(enc.ok()) << enc.status().ToString();
  ASSERT_EQ(enc->mesh.base.layout.channels(), 8);
  size_t bytes_with = 0, bytes_without = 0;
  for (ToolSet tools : {kAllTools, ToolSet(kAllTools & ~kToolTexcoordPrediction), ToolSet(kToolTexcoordPrediction)}) {
    for (Packing packing : {Packing::kSplit, Packing::kBundled}) {
      StreamWriteOptions wo;
      wo.packing = packing;
      wo.tools = tools;
      auto stream = WriteStream(enc.value(), options.quantization, wo);
      ASSERT_TRUE(stream.ok()) << stream.status().ToString();
      auto reader = StreamReader::Create(stream->header.data(), stream->header.size());
      ASSERT_TRUE(reader.ok()) << reader.status().ToString();
      EXPECT_EQ(reader->header().tools, tools & ~kToolSeams);  // a closed sphere: no seams
      ASSERT_TRUE(reader->SetBase(enc->mesh.base).ok());
      for (size_t i = 0; i < stream->control.size(); ++i) {
        ASSERT_TRUE(reader->BeginRefinement(stream->control[i].data(), stream->control[i].size()).ok());
        for (const auto& d : stream->datagrams[i]) EXPECT_TRUE(reader->OfferDatagram(d.data(), d.size()));
        ASSERT_TRUE(reader->FinishRefinement().ok());
        ASSERT_EQ(reader->current().attribute_delta, enc->mesh.refinements[i].attribute_delta) << int(tools) << " " << i;
        ASSERT_EQ(reader->current().position_delta, enc->mesh.refinements[i].position_delta) << int(tools) << " " << i;
      }
      if (packing == Packing::kSplit && tools == kAllTools) bytes_with = stream->unreliable_bytes();
      if (packing == Packing::kSplit && tools == (kAllTools & ~kToolTexcoordPrediction)) bytes_without = stream->unreliable_bytes();
    }
  }
  // Smooth channels: the prediction pays.
  std::printf("coloured sphere: datagrams %zu bytes with texture coordinate prediction, %zu without\n", bytes_with,
              bytes_without);
  EXPECT_LT(bytes_with, bytes_without);
}

}  // namespace
}  // namespace meshstream

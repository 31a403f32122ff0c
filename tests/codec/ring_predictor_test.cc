// The ring predictor of format version 3 (codec/progressive/ring_predictor.h,
// ring_predictor_fit.h; docs/spec/progressive-format.md section 4.7): its 2-ring
// term is the same whatever order a refinement's splits are applied in, its
// coding is exactly invertible, its arithmetic stays in range on hostile
// values, and the fit finds weights that are there.
#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "codec/progressive/encoder.h"
#include "codec/progressive/geometry_prediction.h"
#include "codec/progressive/refinement_state.h"
#include "codec/progressive/ring_predictor.h"
#include "codec/progressive/ring_predictor_fit.h"
#include "codec/recovery/recover_split.h"
#include "tests/common/hierarchy.h"
#include "tests/common/sphere.h"

namespace meshstream {
namespace {

ProgressiveEncoded Hierarchy() { return test_util::EncodeWithoutDraco(test_util::RippledSphere(40, 60)); }

// Every split's umbrellas, from the state as it is (none of r's splits
// applied yet), keyed by split.
std::vector<std::vector<Umbrella>> UmbrellasBefore(const Refinement& r, RefinementState& state) {
  std::vector<std::vector<Umbrella>> out(r.split_count());
  for (size_t j = 0; j < r.split_count(); ++j) {
    if (!state.connectivity.CyclicRing(r.split_vertices[j], state.scratch_ring)) continue;
    RingUmbrellas(state, state.scratch_ring.data(), state.scratch_ring.size(), &out[j]);
  }
  return out;
}

// The batch property the format rests on: with only stable vertices, a
// split's umbrellas are the same before any split of its refinement and
// right before its own; counting every neighbour instead, they are not
// (so the test can tell).
TEST(RingPredictor, UmbrellasDoNotDependOnTheOrderOfSplits) {
  const ProgressiveEncoded enc = Hierarchy();
  ASSERT_GT(enc.mesh.refinements.size(), 3u);
  for (bool stable : {true, false}) {
    RefinementState state;
    ASSERT_TRUE(state.Reset(enc.mesh.base).ok());
    size_t compared = 0, differ = 0;
    for (const Refinement& r : enc.mesh.refinements) {
      Refinement marks = r;
      if (!stable) marks.split_vertices.clear();  // every older vertex counts
      state.BeginSplits(marks);
      const auto before = UmbrellasBefore(r, state);
      std::vector<Umbrella> now;
      for (size_t j = 0; j < r.split_count(); ++j) {
        ASSERT_TRUE(state.connectivity.CyclicRing(r.split_vertices[j], state.scratch_ring));
        RingUmbrellas(state, state.scratch_ring.data(), state.scratch_ring.size(), &now);
        ++compared;
        differ += now != before[j];
        ASSERT_TRUE(state.ApplySplit(r, j).ok());
      }
      state.EndSplits(marks);
      EXPECT_EQ(state.stable_below, 0u);
    }
    EXPECT_GT(compared, 1000u);
    if (stable) EXPECT_EQ(differ, 0u);
    else EXPECT_GT(differ, compared / 10);
  }
}

// After a loss: a split applied as coded whose 2-ring term read a vertex a
// prediction moved is not exact, and is marked so (recover_split.cc: the
// umbrellas' flags count like the ring's); without the flag it is exact.
TEST(RingPredictor, ASplitThatReadAMovedTwoRingVertexIsMarked) {
  const ProgressiveEncoded enc = Hierarchy();
  const Refinement& r = enc.mesh.refinements[0];
  SplitCoding coding;
  coding.tools = kToolGeometryPrediction | kToolLocalFrame | kToolRingPredictor;
  coding.predictor = {{256, 0, 512}, {256, 0, 512}};  // a strong 2-ring term
  ASSERT_TRUE(ReadsUmbrellas(coding));
  // The encoder's side: split 0 coded on the clean coarse mesh.
  RefinementState clean;
  ASSERT_TRUE(clean.Reset(enc.mesh.base).ok());
  clean.BeginSplits(r);
  const uint32_t w = r.split_vertices[0];
  std::vector<uint32_t> ring;
  ASSERT_TRUE(clean.connectivity.CyclicRing(w, ring));
  std::vector<Vec3i> rp;
  for (uint32_t x : ring) rp.push_back(clean.positions[x]);
  std::vector<Umbrella> umbrellas;
  RingUmbrellas(clean, ring.data(), ring.size(), &umbrellas);
  size_t a_at = 0, b_at = 0;
  ASSERT_TRUE(WingPositions(ring, r.wings[0], &a_at, &b_at));
  const LocalFrame frame = RingLocalFrame(clean.positions[w], rp.data(), rp.size());
  Refinement coded = r;
  coded.position_delta[0] = CodeSplitVector(coding, r.position_delta[0], rp.data(), rp.size(), a_at, b_at, frame,
                                            umbrellas.data());
  // A stable vertex of the 2-ring, outside w's closed ring.
  uint32_t y = UINT32_MAX;
  for (uint32_t x : ring)
    for (uint32_t f : clean.connectivity.faces_of(x))
      for (uint32_t v : clean.connectivity.faces()[f])
        if (y == UINT32_MAX && v != w && clean.Stable(v) && std::find(ring.begin(), ring.end(), v) == ring.end()) y = v;
  ASSERT_NE(y, UINT32_MAX);
  ASSERT_TRUE(clean.ApplySplit(r, 0).ok());
  const uint32_t n = r.vertices_before;
  for (bool moved : {false, true}) {
    RefinementState s;
    ASSERT_TRUE(s.Reset(enc.mesh.base).ok());
    if (moved) {
      s.positions[y][0] += 40;
      s.positions[y][1] -= 40;
      s.Mark(y, kPositionInexact);
      s.any_inexact = true;
    }
    s.BeginSplits(r);
    Refinement decoded = coded;
    RecoveryScratch scratch;
    RecoveryStats stats;
    ASSERT_TRUE(RecoverSplit(coded, 0, true, true, Recovery::kPredict, &s, &scratch, &stats, coding, &decoded).ok());
    s.EndSplits(r);
    EXPECT_EQ(stats.exact, 1u);
    const bool exact = s.positions[w] == clean.positions[w] && s.positions[n] == clean.positions[n];
    EXPECT_EQ(exact, !moved) << "moved " << moved;
    EXPECT_EQ(s.reliable[w], moved ? 0 : 1);
    EXPECT_EQ(s.reliable[n], moved ? 0 : 1);
  }
}

TEST(RingPredictor, CodingIsExactlyInvertible) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int32_t> pos(-(1 << 20), 1 << 20), delta(-(1 << 27), 1 << 27), small(-40, 40),
      weight(-kMaxPredictorWeight, kMaxPredictorWeight);
  std::uniform_int_distribution<int> degree(3, 12);
  for (int i = 0; i < 3000; ++i) {
    const size_t d = static_cast<size_t>(degree(rng));
    std::vector<Vec3i> ring(d);
    std::vector<Umbrella> umbrellas(d);
    for (size_t k = 0; k < d; ++k) {
      ring[k] = {pos(rng), pos(rng), pos(rng)};
      umbrellas[k] = {int64_t{pos(rng)} * 6, int64_t{pos(rng)} * 6, int64_t{pos(rng)} * 6};
    }
    const Vec3i w = {pos(rng), pos(rng), pos(rng)};
    const LocalFrame frame = LocalFrame::FromNormal(FanNormal(w, ring.data(), d));
    PredictorWeights weights;
    for (int f = 0; f < kPredictorFeatures; ++f) {
      weights.tangential[f] = i % 3 == 0 ? weight(rng) : small(rng) * 8;
      weights.normal[f] = weight(rng);
    }
    const size_t a = static_cast<size_t>(rng() % d), b = (a + 1 + rng() % (d - 1)) % d;
    const PredictorFeatures features = SplitFeatures(ring.data(), umbrellas.data(), d, a, b);
    for (const Vec3i& f : features)
      for (int32_t c : f) ASSERT_LE(std::abs(int64_t{c}), int64_t{1} << 30);
    const Vec3i v = i % 2 ? Vec3i{delta(rng), delta(rng), delta(rng)} : Vec3i{small(rng), small(rng), small(rng)};
    const Vec3i coded = ResidualInFrame(weights, features, frame, v);
    ASSERT_EQ(VectorFromResidual(weights, features, frame, coded), v) << "case " << i;
  }
}

// Positions at the int32 limits, umbrellas at their largest, the largest
// weights: everything stays clamped (and UBSan sees no overflow).
TEST(RingPredictor, HostileValuesStayInRange) {
  const size_t d = kMaxPredictedValence;
  std::vector<Vec3i> ring(d);
  std::vector<Umbrella> umbrellas(d);
  for (size_t k = 0; k < d; ++k) {
    const int32_t s = k % 2 ? INT32_MAX : INT32_MIN;
    ring[k] = {s, -s - 1, s};
    const int64_t u = (k % 3 ? 1 : -1) * int64_t{kMaxUmbrellaFaces} * (int64_t{1} << 32);
    umbrellas[k] = {u, -u, u};
  }
  PredictorWeights weights;
  weights.tangential = {kMaxPredictorWeight, -kMaxPredictorWeight, kMaxPredictorWeight};
  weights.normal = {-kMaxPredictorWeight, kMaxPredictorWeight, -kMaxPredictorWeight};
  const LocalFrame frame = LocalFrame::FromNormal({1, 2, 3});
  for (size_t a = 0; a < d; a += 7) {
    const PredictorFeatures f = SplitFeatures(ring.data(), umbrellas.data(), d, a, (a + 1) % d);
    for (const Vec3i& x : f)
      for (int32_t c : x) EXPECT_LE(std::abs(int64_t{c}), int64_t{1} << 30);
    const Vec3i p = PredictInFrame(weights, f, frame);
    for (int32_t c : p) EXPECT_LE(std::abs(int64_t{c}), int64_t{1} << 28);
    const Vec3i back = VectorFromResidual(weights, f, frame, {INT32_MAX, INT32_MIN, INT32_MAX});
    (void)back;  // clamped, not exact (beyond 2^28): only defined
  }
  // A ring too large, or wings that are not two ring positions: no features.
  EXPECT_EQ(SplitFeatures(ring.data(), umbrellas.data(), d + 1, 0, 1), PredictorFeatures{});
  EXPECT_EQ(SplitFeatures(ring.data(), umbrellas.data(), d, 3, 3), PredictorFeatures{});
  EXPECT_EQ(SplitFeatures(ring.data(), umbrellas.data(), d, d, 3), PredictorFeatures{});
}

// Samples made from known weights (0.75, 0.5, -0.25 tangential; 1, 0, 0.5
// normal) plus a little noise: the fit finds them within a few 256ths, and
// with fewer features leaves the rest 0.
TEST(RingPredictor, FitFindsTheWeightsThatAreThere) {
  std::mt19937 rng(3);
  std::normal_distribution<double> feature(0.0, 40.0), noise(0.0, 0.7);
  std::vector<PredictorSample> samples;
  for (int i = 0; i < 4000; ++i) {
    PredictorSample s;
    for (auto& f : s.features)
      for (double& c : f) c = feature(rng);
    for (int c = 0; c < 3; ++c) {
      const auto& f = s.features;
      const double y = c < 2 ? 0.75 * f[0][c] + 0.5 * f[1][c] - 0.25 * f[2][c] : f[0][c] + 0.5 * f[2][c];
      s.target[c] = static_cast<int32_t>(std::lround(y + noise(rng)));
    }
    samples.push_back(s);
  }
  const PredictorWeights w = FitPredictorWeights(samples, 3);
  const int want_t[3] = {192, 128, -64}, want_n[3] = {256, 0, 128};
  for (int f = 0; f < 3; ++f) {
    EXPECT_NEAR(w.tangential[f], want_t[f], 3) << f;
    EXPECT_NEAR(w.normal[f], want_n[f], 3) << f;
  }
  EXPECT_TRUE(w.reads_ring());
  const PredictorWeights two = FitPredictorWeights(samples, 2);
  EXPECT_EQ(two.tangential[kFeatureRing], 0);
  EXPECT_EQ(two.normal[kFeatureRing], 0);
  EXPECT_FALSE(two.reads_ring());
  EXPECT_EQ(FitPredictorWeights({}, 3), kInitialPredictor);
}

}  // namespace
}  // namespace meshstream

// Adaptive models (codec/entropy/adaptive_model.h) and the range coder's
// frequency coding: round trips mixed with static and raw symbols, the
// priors' integer arithmetic pinned, adaptation and halving bounded, hostile
// bytes decoded inside the alphabet.
#include "codec/entropy/adaptive_model.h"

#include <algorithm>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

uint32_t Sum(const ModelPrior& p) { return std::accumulate(p.begin(), p.end(), 0u); }

TEST(AdaptiveModel, RoundTripsMixedWithStaticAndRawSymbols) {
  std::mt19937 rng(3);
  for (uint32_t x : {0u, 17u, 60u, 159u}) {
    const ModelPrior signed_prior = ParametricPrior(SymbolKind::kSigned, kSignedSymbols, x);
    const ModelPrior index_prior = ParametricPrior(SymbolKind::kIndex, 16, x);
    const StaticModel fixed = StaticModel::FromCounts({5, 3, 1, 1});
    std::geometric_distribution<int> magnitude(0.05);
    std::vector<int32_t> values;
    std::vector<uint32_t> indices, statics;
    for (int i = 0; i < 3000; ++i) {
      const int m = magnitude(rng) * (i % 97 == 0 ? 100000 : 1);
      values.push_back(rng() % 2 ? m : -m);
      indices.push_back(rng() % 16);
      statics.push_back(rng() % 4);
    }
    RangeEncoder enc;
    AdaptiveModel a, b;
    a.Reset(signed_prior);
    b.Reset(index_prior);
    for (size_t i = 0; i < values.size(); ++i) {
      EncodeSigned(enc, a, values[i]);
      b.Encode(enc, indices[i]);
      fixed.Encode(enc, statics[i]);
      enc.EncodeRaw(i & 7, 3);
    }
    const std::vector<uint8_t> bytes = enc.Finish();
    RangeDecoder dec(bytes.data(), bytes.size());
    a.Reset(signed_prior);
    b.Reset(index_prior);
    for (size_t i = 0; i < values.size(); ++i) {
      ASSERT_EQ(DecodeSigned(dec, a), values[i]) << "x " << x << " i " << i;
      ASSERT_EQ(b.Decode(dec), indices[i]);
      ASSERT_EQ(fixed.Decode(dec), statics[i]);
      ASSERT_EQ(dec.DecodeRaw(3), i & 7);
    }
    EXPECT_FALSE(dec.overran());
    EXPECT_TRUE(dec.ended_exactly());
  }
}

// The priors are part of the format: these numbers must not change on any
// platform (docs/spec/progressive-format.md, section 5.1).
TEST(AdaptiveModel, ParametricPriorsArePinned) {
  const ModelPrior spike = ParametricPrior(SymbolKind::kSigned, kSignedSymbols, 0);
  EXPECT_EQ(spike[0], 4096) << "theta = 0: everything at value 0, the floors above it";
  EXPECT_EQ(Sum(spike), 4096u + kSignedSymbols - 1);
  const ModelPrior mid = ParametricPrior(SymbolKind::kSigned, kSignedSymbols, 40);
  const ModelPrior index = ParametricPrior(SymbolKind::kIndex, 16, 20);
  const std::vector<uint16_t> mid_head(mid.begin(), mid.begin() + 8);
  const std::vector<uint16_t> index_head(index.begin(), index.begin() + 4);
  EXPECT_EQ(mid_head, (std::vector<uint16_t>{64, 62, 62, 60, 60, 58, 58, 56}));
  EXPECT_EQ(index_head, (std::vector<uint16_t>{721, 601, 501, 417}));
}

TEST(AdaptiveModel, PriorsAreValidAndFlattenWithTheParameter) {
  for (SymbolKind kind : {SymbolKind::kIndex, SymbolKind::kSigned}) {
    const uint32_t n = kind == SymbolKind::kIndex ? 16 : kSignedSymbols;
    uint32_t previous_zero = UINT32_MAX;
    for (uint32_t x = 0; x < kParametricParameters; ++x) {
      const ModelPrior p = ParametricPrior(kind, n, x);
      ASSERT_EQ(p.size(), n);
      for (uint16_t c : p) ASSERT_GE(c, 1u);
      EXPECT_LE(Sum(p), 4096u + n) << x;
      EXPECT_GE(Sum(p), 4096u - n) << x;
      EXPECT_LE(p[0], previous_zero) << "x " << x << ": a larger parameter is flatter";
      previous_zero = p[0];
      if (kind == SymbolKind::kIndex) {
        for (uint32_t s = 1; s < n; ++s) EXPECT_LE(p[s], p[s - 1]) << x;
      }
    }
  }
  // A wide histogram picks a flatter member than a narrow one.
  std::vector<uint64_t> narrow(kSignedSymbols, 0), wide(kSignedSymbols, 0);
  narrow[0] = 100;
  narrow[1] = narrow[2] = 10;
  for (uint32_t s = 0; s < 30; ++s) wide[s] = 50;
  EXPECT_LT(BestParameter(SymbolKind::kSigned, narrow), BestParameter(SymbolKind::kSigned, wide));
}

TEST(AdaptiveModel, TablePriorGivesEverySymbolACount) {
  const StaticModel table = StaticModel::FromCounts({10, 0, 3});
  const ModelPrior p = TablePrior(table, 16);
  ASSERT_EQ(p.size(), 16u);
  EXPECT_EQ(p[0], table.Frequency(0));
  EXPECT_EQ(p[1], 1u);
  EXPECT_EQ(p[2], table.Frequency(2));
  for (uint32_t s = 3; s < 16; ++s) EXPECT_EQ(p[s], 1u);
}

TEST(AdaptiveModel, AdaptationHalvesWithinTheLimitAndKeepsEverySymbol) {
  AdaptiveModel m;
  m.Reset(ParametricPrior(SymbolKind::kSigned, kSignedSymbols, 20));
  const double before = m.Cost(5);
  RangeEncoder enc;
  for (int i = 0; i < 20000; ++i) m.Encode(enc, 5);
  EXPECT_LT(m.Cost(5), before);
  EXPECT_LT(m.Cost(5), 0.01);
  EXPECT_LT(m.Cost(71), 17.0);  // still decodable: at least 1 in 2^16
  enc.Finish();
}

TEST(AdaptiveModel, HostileBytesDecodeInsideTheAlphabet) {
  std::mt19937 rng(11);
  for (int round = 0; round < 200; ++round) {
    std::vector<uint8_t> bytes(1 + rng() % 64);
    for (auto& b : bytes) b = static_cast<uint8_t>(rng());
    RangeDecoder dec(bytes.data(), bytes.size());
    AdaptiveModel m;
    m.Reset(ParametricPrior(SymbolKind::kIndex, 16, rng() % kParametricParameters));
    for (int i = 0; i < 500; ++i) ASSERT_LT(m.Decode(dec), 16u);
  }
}

}  // namespace
}  // namespace meshstream

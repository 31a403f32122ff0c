#include "codec/entropy/range_coder.h"

#include <random>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

struct Op {
  int kind;  // 0 bit(ctx), 1 static symbol, 2 raw bits, 3 uniform
  uint32_t value;
  uint32_t param;
};

// Static model over 4 symbols with frequencies summing to 2^12.
constexpr uint32_t kCum[] = {0, 2048, 3072, 3584};
constexpr uint32_t kFreq[] = {2048, 1024, 512, 512};

std::vector<Op> RandomOps(uint32_t seed, size_t n) {
  std::mt19937 rng(seed);
  std::vector<Op> ops;
  for (size_t i = 0; i < n; ++i) {
    auto next = [&rng]() { return static_cast<uint32_t>(rng()); };
    const int kind = static_cast<int>(next() % 4);
    switch (kind) {
      case 0: ops.push_back({0, (next() % 10) < 8 ? 0u : 1u, next() % 3}); break;
      case 1: ops.push_back({1, next() % 4, 0}); break;
      case 2: { const uint32_t bits = 1 + next() % 16; ops.push_back({2, next() & ((1u << bits) - 1), bits}); break; }
      default: { const uint32_t n2 = 1 + next() % 60000; ops.push_back({3, next() % n2, n2}); break; }
    }
  }
  return ops;
}

std::vector<uint8_t> EncodeOps(const std::vector<Op>& ops) {
  RangeEncoder enc;
  BitModel models[3];
  for (const Op& op : ops) {
    switch (op.kind) {
      case 0: enc.EncodeBit(models[op.param], static_cast<int>(op.value)); break;
      case 1: enc.Encode(kCum[op.value], kFreq[op.value], 12); break;
      case 2: enc.EncodeRaw(op.value, static_cast<int>(op.param)); break;
      default: enc.EncodeUniform(op.value, op.param); break;
    }
  }
  return enc.Finish();
}

TEST(RangeCoder, RoundTripsMixedSymbols) {
  for (uint32_t seed = 1; seed <= 20; ++seed) {
    const auto ops = RandomOps(seed, 5000);
    const auto bytes = EncodeOps(ops);
    RangeDecoder dec(bytes.data(), bytes.size());
    BitModel models[3];
    for (size_t i = 0; i < ops.size(); ++i) {
      const Op& op = ops[i];
      uint32_t got = 0;
      switch (op.kind) {
        case 0: got = static_cast<uint32_t>(dec.DecodeBit(models[op.param])); break;
        case 1: {
          const uint32_t v = dec.Peek(12);
          uint32_t s = 0;
          while (s < 3 && kCum[s + 1] <= v) ++s;
          dec.Consume(kCum[s], kFreq[s]);
          got = s;
          break;
        }
        case 2: got = dec.DecodeRaw(static_cast<int>(op.param)); break;
        default: got = dec.DecodeUniform(op.param); break;
      }
      ASSERT_EQ(got, op.value) << "seed " << seed << " op " << i;
    }
    EXPECT_FALSE(dec.overran());
  }
}

TEST(RangeCoder, SkewedBitsCompressWell) {
  RangeEncoder enc;
  BitModel m;
  std::mt19937 rng(3);
  for (int i = 0; i < 80000; ++i) enc.EncodeBit(m, (rng() % 100) < 5 ? 1 : 0);
  const auto bytes = enc.Finish();
  // Entropy of p = 0.05 is 0.286 bits: 80000 bits -> about 2,860 bytes.
  EXPECT_LT(bytes.size(), 3200u);
  EXPECT_GT(bytes.size(), 2500u);
}

TEST(RangeCoder, TruncatedStreamIsDetected) {
  const auto ops = RandomOps(9, 4000);
  auto bytes = EncodeOps(ops);
  bytes.resize(bytes.size() / 2);
  RangeDecoder dec(bytes.data(), bytes.size());
  BitModel models[3];
  for (const Op& op : ops) {
    if (op.kind == 0) dec.DecodeBit(models[op.param]);
    else if (op.kind == 2) dec.DecodeRaw(static_cast<int>(op.param));
    else dec.DecodeUniform(op.kind == 3 ? op.param : 4);
  }
  EXPECT_TRUE(dec.overran());
}

TEST(RangeCoder, GarbageDecodesWithoutCrashing) {
  std::mt19937 rng(5);
  for (int round = 0; round < 200; ++round) {
    std::vector<uint8_t> junk(rng() % 64);
    for (auto& b : junk) b = static_cast<uint8_t>(rng());
    RangeDecoder dec(junk.data(), junk.size());
    BitModel m;
    for (int i = 0; i < 500; ++i) {
      EXPECT_LT(dec.DecodeUniform(7), 7u);
      EXPECT_LT(dec.Peek(12), 4096u);
      dec.Consume(0, 1);
      dec.DecodeBit(m);
    }
  }
}

}  // namespace
}  // namespace meshstream

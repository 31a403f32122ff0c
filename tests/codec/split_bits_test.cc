// Split bits (codec/progressive/split_bits.h): round trips over the refinement
// history of a real encode (a sphere through EncodeProgressive) and over
// synthetic patterns, decoding that needs nothing but the bytes and the
// history rebuilt from earlier decoded bits (reliable data), and truncated
// input refused cleanly.
#include "codec/progressive/seam_twins.h"
#include "codec/progressive/split_bits.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "codec/progressive/encoder.h"
#include "tests/common/sphere.h"

namespace meshstream {
namespace {

using Bits = std::vector<uint8_t>;

Primitive Sphere(int rings, int segments) { return test_util::RippledSphere(rings, segments); }

// The split bits of every refinement of a real encode, coarse to fine.
std::vector<Bits> RealSplitBits(uint32_t* base_vertices) {
  ProgressiveEncodeOptions options;
  auto enc = EncodeProgressive(Sphere(40, 60), options, [](const QuantizedMesh& base, int) -> StatusOr<EncodedBase> {
    EncodedBase e;
    e.decoded = base;
    e.bytes = {0};
    return e;
  });
  EXPECT_TRUE(enc.ok()) << enc.status().ToString();
  if (!enc.ok()) return {};
  *base_vertices = static_cast<uint32_t>(enc->mesh.base.vertex_count());
  std::vector<Bits> out;
  for (const Refinement& r : enc->mesh.refinements) {
    Bits bits(r.vertices_before, 0);
    for (uint32_t v : r.split_vertices) bits[v] = 1;
    out.push_back(std::move(bits));
  }
  return out;
}

// Codes every level, then decodes them with histories rebuilt from the
// decoded bits only.
void ExpectChainRoundTrips(uint32_t base_vertices, const std::vector<Bits>& levels) {
  std::vector<Bits> coded;
  SplitHistory h;
  h.vertices = base_vertices;
  for (const Bits& bits : levels) {
    ASSERT_EQ(bits.size(), h.vertices);
    coded.push_back(EncodeSplitBits(bits, h));
    h = h.Next(bits);
  }
  SplitHistory d;
  d.vertices = base_vertices;
  for (size_t i = 0; i < levels.size(); ++i) {
    auto got = DecodeSplitBits(coded[i].data(), coded[i].size(), d);
    ASSERT_TRUE(got.ok()) << "level " << i << ": " << got.status().ToString();
    ASSERT_EQ(got.value(), levels[i]) << "level " << i;
    d = d.Next(got.value());
  }
}

TEST(SplitBits, RealRefinementHistoryRoundTrips) {
  uint32_t base = 0;
  const std::vector<Bits> levels = RealSplitBits(&base);
  ASSERT_GE(levels.size(), 3u);
  ExpectChainRoundTrips(base, levels);
  // The contexts pay: well under one bit per vertex over the history.
  size_t bits = 0, bytes = 0;
  SplitHistory h;
  h.vertices = base;
  for (const Bits& b : levels) {
    bits += b.size();
    bytes += EncodeSplitBits(b, h).size();
    h = h.Next(b);
  }
  EXPECT_LT(bytes * 8, bits);
}

TEST(SplitBits, SyntheticPatternsRoundTrip) {
  for (uint32_t n : {1u, 2u, 7u, 100u, 5000u}) {
    const Bits zeros(n, 0), ones(n, 1);
    Bits alternating(n), single(n, 0), last(n, 0), random(n);
    for (uint32_t v = 0; v < n; ++v) alternating[v] = v % 2;
    single[n / 2] = 1;
    last[n - 1] = 1;
    std::mt19937 rng(n);
    for (auto& b : random) b = rng() % 3 == 0;
    for (const Bits* first : std::vector<const Bits*>{&zeros, &ones, &alternating, &single, &last, &random}) {
      // A first refinement with this pattern, and a second one (on the grown
      // mesh) with the same pattern repeated: both context kinds are used.
      SplitHistory h;
      h.vertices = n;
      const SplitHistory next = h.Next(*first);
      Bits second(next.vertices);
      for (uint32_t v = 0; v < next.vertices; ++v) second[v] = (*first)[v % n];
      ExpectChainRoundTrips(n, {*first, second});
    }
  }
}

TEST(SplitBits, HistoryNextNumbersTheNewVertices) {
  SplitHistory h;
  h.vertices = 5;
  const SplitHistory n1 = h.Next({0, 1, 0, 1, 1});
  EXPECT_EQ(n1.vertices, 8u);
  EXPECT_EQ(n1.previous_start, 5u);
  EXPECT_EQ(n1.older_start, UINT32_MAX);
  EXPECT_EQ(n1.previous_splits, (std::vector<uint32_t>{1, 3, 4}));
  const SplitHistory n2 = n1.Next(Bits(8, 0));
  EXPECT_EQ(n2.vertices, 8u);
  EXPECT_EQ(n2.previous_start, 8u);
  EXPECT_EQ(n2.older_start, 5u);
  EXPECT_TRUE(n2.previous_splits.empty());
}

TEST(SplitBits, DecodeDependsOnlyOnTheBytesAndTheReliableHistory) {
  uint32_t base = 0;
  const std::vector<Bits> levels = RealSplitBits(&base);
  ASSERT_GE(levels.size(), 3u);
  // The histories, built once from the true bits.
  std::vector<SplitHistory> histories;
  SplitHistory h;
  h.vertices = base;
  std::vector<Bits> coded;
  for (const Bits& bits : levels) {
    histories.push_back(h);
    coded.push_back(EncodeSplitBits(bits, h));
    h = h.Next(bits);
  }
  // Decoding level i from a copy of its history, in any order, after any
  // other decode (including one of garbage), gives the same bits each time:
  // nothing but (bytes, history) enters.
  std::mt19937 rng(5);
  for (int round = 0; round < 2; ++round) {
    for (size_t k = levels.size(); k-- > 0;) {
      Bits garbage(64);
      for (auto& b : garbage) b = static_cast<uint8_t>(rng());
      (void)DecodeSplitBits(garbage.data(), garbage.size(), histories[(k + 1) % levels.size()]);
      const SplitHistory copy = histories[k];
      auto got = DecodeSplitBits(coded[k].data(), coded[k].size(), copy);
      ASSERT_TRUE(got.ok()) << k;
      EXPECT_EQ(got.value(), levels[k]) << "level " << k << " round " << round;
    }
  }
  // The history is really used: decoding level 2 with level 1's history
  // (a different reliable state) does not give level 2's bits.
  auto wrong = DecodeSplitBits(coded[2].data(), coded[2].size(), histories[1]);
  EXPECT_TRUE(!wrong.ok() || wrong.value() != levels[2]);
}

TEST(SplitBits, TruncatedInputFailsCleanly) {
  uint32_t base = 0;
  const std::vector<Bits> levels = RealSplitBits(&base);
  ASSERT_GE(levels.size(), 2u);
  SplitHistory h;
  h.vertices = base;
  h = h.Next(levels[0]);
  const Bits& bits = levels[1];
  const Bits coded = EncodeSplitBits(bits, h);
  ASSERT_GT(coded.size(), 8u);
  // The range decoder tolerates its four bytes of look-ahead past the end;
  // on this real stream every shorter cut is refused. That is detection on a
  // fixed stream, not a guarantee: past the end the decoder reads zeros,
  // and a tail skewed towards 0 decodes from them cheaply (a sweep of 200
  // random skewed bit vectors found 105 of ~15k cuts beyond the look-ahead
  // decoding to other bits without error). On the wire, truncation of the
  // control block is caught by its length prefix (ByteReader::Block).
  for (size_t cut = 0; cut + 4 < coded.size(); ++cut) {
    const Bits prefix(coded.begin(), coded.begin() + cut);
    auto got = DecodeSplitBits(prefix.data(), prefix.size(), h);
    ASSERT_FALSE(got.ok()) << "cut at " << cut << " of " << coded.size();
    EXPECT_EQ(got.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(got.status().message().find("split bits"), std::string::npos) << got.status().message();
  }
  // Nothing at all, for a mesh with vertices: refused. For none, the block is
  // what the encoder writes for no bits (its flush), which decodes to nothing;
  // an empty block is not what the encoder writes, and a decoder must read a
  // range-coded block to its exact end (docs/spec/progressive-format.md), so it is
  // refused too.
  EXPECT_FALSE(DecodeSplitBits(nullptr, 0, h).ok());
  SplitHistory empty;
  const Bits flush = EncodeSplitBits({}, empty);
  auto none = DecodeSplitBits(flush.data(), flush.size(), empty);
  ASSERT_TRUE(none.ok()) << none.status().message();
  EXPECT_TRUE(none->empty());
  EXPECT_FALSE(DecodeSplitBits(nullptr, 0, empty).ok());
}

// With seam twins, a vertex whose twin has a smaller id takes the twin's
// bit without a symbol: the block shrinks, and decodes to the same bits
// only with the same twins.
TEST(SplitBits, SeamTwinsCopyTheirTwinsBitUncoded) {
  uint32_t base = 0;
  const std::vector<Bits> levels = RealSplitBits(&base);
  ASSERT_GE(levels.size(), 2u);
  SplitHistory h;
  h.vertices = base;
  h = h.Next(levels[0]);
  Bits bits = levels[1];
  // Pair every vertex 2k with 2k + 1 (the odd one copies the even one's bit).
  std::vector<uint32_t> twin(bits.size(), kNoTwin);
  for (uint32_t v = 0; v + 1 < bits.size(); v += 2) {
    twin[v] = v + 1;
    twin[v + 1] = v;
    bits[v + 1] = bits[v];
  }
  const Bits with = EncodeSplitBits(bits, h, &twin);
  const Bits without = EncodeSplitBits(bits, h);
  EXPECT_LT(with.size() * 10, without.size() * 7) << with.size() << " against " << without.size();
  auto got = DecodeSplitBits(with.data(), with.size(), h, &twin);
  ASSERT_TRUE(got.ok()) << got.status().message();
  EXPECT_EQ(got.value(), bits);
  auto plain = DecodeSplitBits(without.data(), without.size(), h);
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain.value(), bits);
  // Without the twins the shorter block does not decode to these bits.
  auto wrong = DecodeSplitBits(with.data(), with.size(), h);
  EXPECT_TRUE(!wrong.ok() || wrong.value() != bits);
}

}  // namespace
}  // namespace meshstream

// Version 3's split bits (codec/progressive/split_bit_contexts.h): the
// contexts as the spec defines them on a hand-made graph, round trips over a
// real encode's history, fewer bytes than version 2's coding, a refused block
// that leaves the coder as it was, truncation and stray bytes, seam twins.
#include "codec/progressive/split_bit_contexts.h"

#include <random>

#include <gtest/gtest.h>

#include "codec/progressive/encoder.h"
#include "codec/progressive/split_bits.h"
#include "tests/common/hierarchy.h"
#include "tests/common/sphere.h"

namespace meshstream {
namespace {

using Bits = std::vector<uint8_t>;

struct History {
  uint32_t base_vertices = 0;
  std::vector<uint32_t> base_indices;
  std::vector<Bits> levels;
};

// The base and the split bits of every refinement of a real encode.
History RealHistory() {
  const ProgressiveEncoded enc = test_util::EncodeWithoutDraco(test_util::RippledSphere(40, 60));
  History h;
  h.base_vertices = static_cast<uint32_t>(enc.mesh.base.vertex_count());
  h.base_indices = enc.mesh.base.indices;
  for (const Refinement& r : enc.mesh.refinements) {
    Bits bits(r.vertices_before, 0);
    for (uint32_t v : r.split_vertices) bits[v] = 1;
    h.levels.push_back(std::move(bits));
  }
  return h;
}

std::vector<Bits> EncodeAll(const History& h, const std::vector<uint32_t>* twin = nullptr) {
  SplitBitContexts coder;
  EXPECT_TRUE(coder.Reset(h.base_vertices, h.base_indices).ok());
  std::vector<Bits> out;
  for (const Bits& bits : h.levels) out.push_back(coder.Encode(bits, twin));
  return out;
}

// The real history and its blocks, made once for the tests that decode them.
struct RealCase {
  History h;
  std::vector<Bits> coded;
};
const RealCase& Real() {
  static const RealCase c = [] {
    RealCase r;
    r.h = RealHistory();
    r.coded = EncodeAll(r.h);
    return r;
  }();
  return c;
}

// A decoder at the start of the history's stream.
SplitBitContexts DecoderFor(const History& h) {
  SplitBitContexts decoder;
  EXPECT_TRUE(decoder.Reset(h.base_vertices, h.base_indices).ok());
  return decoder;
}

// Decodes `block` as the coder's next refinement, requires `want`, moves on.
void DecodeNext(SplitBitContexts& decoder, const Bits& block, const Bits& want) {
  auto got = decoder.Decode(block.data(), block.size());
  ASSERT_TRUE(got.ok()) << got.status().ToString();
  ASSERT_EQ(got->bits, want);
  decoder.Advance(std::move(got).value());
}

// The contexts of the spec on two triangles (0 1 2) and (0 2 3).
TEST(SplitBitContexts, ContextsFollowTheReliableGraph) {
  SplitBitContexts c;
  ASSERT_TRUE(c.Reset(4, {0, 1, 2, 0, 2, 3}).ok());
  // Refinement 0: since 0, related 0; degrees 3 2 3 2.
  Bits bits = {1, 0, 0, 0};
  EXPECT_EQ(c.Context(0, bits), 3);
  EXPECT_EQ(c.Context(1, bits), 40);  // its neighbour 0 < 1 splits
  EXPECT_EQ(c.Context(3, bits), 40);
  EXPECT_EQ(c.Context(2, Bits{0, 0, 0, 0}), 3);
  EXPECT_EQ(c.Context(1, Bits{0, 0, 0, 0}), 2);
  c.Encode(bits);
  ASSERT_EQ(c.vertices(), 5u);
  // Refinement 1: vertex 0 split in refinement 0 (since 0, related = its own
  // bit 1, one reliable neighbour: its new vertex 4); vertex 1 never split
  // (since 1, related 0, one reliable neighbour left: 2); vertex 4 was made
  // by refinement 0 (related = its parent 0's bit now).
  Bits next = {0, 0, 0, 0, 0};
  EXPECT_EQ(c.Context(0, next), (0 * 2 + 1) * 4 + 1);
  EXPECT_EQ(c.Context(1, next), (1 * 2 + 0) * 4 + 1);
  EXPECT_EQ(c.Context(2, next), (1 * 2 + 0) * 4 + 2);
  EXPECT_EQ(c.Context(4, next), (0 * 2 + 0) * 4 + 1);
  next[0] = 1;
  EXPECT_EQ(c.Context(4, next), 40);  // its parent splits: the link is a reliable edge
  c.Encode(next);
  // Refinement 2: vertex 4's link to 0 is gone (0 split again, into 5).
  Bits third(6, 0);
  EXPECT_EQ(c.Context(4, third), (1 * 2 + 0) * 4 + 0);
  EXPECT_EQ(c.Context(5, third), (0 * 2 + 0) * 4 + 1);
  EXPECT_EQ(c.Context(0, third), (0 * 2 + 1) * 4 + 1);
  // since saturates at 4.
  for (int i = 0; i < 4; ++i) c.Encode(Bits(6, 0));
  EXPECT_EQ(c.Context(3, Bits(6, 0)), (4 * 2 + 0) * 4 + 1);
}

TEST(SplitBitContexts, RealHistoryRoundTripsInFewerBytesThanVersion2) {
  const History& h = Real().h;
  const std::vector<Bits>& coded = Real().coded;
  ASSERT_GE(h.levels.size(), 3u);
  SplitBitContexts decoder = DecoderFor(h);
  size_t bytes = 0, v2_bytes = 0;
  SplitHistory v2;
  v2.vertices = h.base_vertices;
  for (size_t i = 0; i < h.levels.size(); ++i) {
    SCOPED_TRACE("level " + std::to_string(i));
    ASSERT_NO_FATAL_FAILURE(DecodeNext(decoder, coded[i], h.levels[i]));
    bytes += coded[i].size();
    v2_bytes += EncodeSplitBits(h.levels[i], v2).size();
    v2 = v2.Next(h.levels[i]);
  }
  EXPECT_LT(bytes, v2_bytes);
  std::printf("split bits: version 3 %zu bytes, version 2 %zu bytes\n", bytes, v2_bytes);
}

TEST(SplitBitContexts, ARefusedBlockLeavesTheCoderAsItWas) {
  const History& h = Real().h;
  const std::vector<Bits>& coded = Real().coded;
  ASSERT_GE(h.levels.size(), 3u);
  SplitBitContexts decoder = DecoderFor(h);
  std::mt19937 rng(7);
  for (size_t i = 0; i < h.levels.size(); ++i) {
    // Garbage first (refused or decoded to other bits, never applied), then the real block.
    Bits garbage(coded[i].size());
    for (auto& b : garbage) b = static_cast<uint8_t>(rng());
    (void)decoder.Decode(garbage.data(), garbage.size());
    const Bits stray = [&] {
      Bits b = coded[i];
      b.push_back(0);
      return b;
    }();
    auto refused = decoder.Decode(stray.data(), stray.size());
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.status().message().find("do not end with its"), std::string::npos) << refused.status().message();
    SCOPED_TRACE("level " + std::to_string(i));
    ASSERT_NO_FATAL_FAILURE(DecodeNext(decoder, coded[i], h.levels[i]));
  }
}

TEST(SplitBitContexts, TruncatedInputFailsCleanly) {
  const History& h = Real().h;
  const std::vector<Bits>& coded = Real().coded;
  ASSERT_GE(h.levels.size(), 2u);
  SplitBitContexts decoder = DecoderFor(h);
  // The last (largest) refinement, after the others.
  for (size_t i = 0; i + 1 < coded.size(); ++i) ASSERT_NO_FATAL_FAILURE(DecodeNext(decoder, coded[i], h.levels[i]));
  const Bits& c = coded.back();
  ASSERT_GT(c.size(), 8u);
  // As for version 2 (split_bits_test.cc): every cut before the decoder's
  // four bytes of look-ahead is refused on this real stream.
  for (size_t cut = 0; cut + 4 < c.size(); ++cut) {
    auto got = decoder.Decode(c.data(), cut);
    ASSERT_FALSE(got.ok()) << "cut at " << cut;
    EXPECT_EQ(got.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(got.status().message().find("split bits"), std::string::npos);
  }
  EXPECT_FALSE(decoder.Decode(nullptr, 0).ok());
}

TEST(SplitBitContexts, SeamTwinsCopyTheirTwinsBitUncoded) {
  const History h = RealHistory();
  ASSERT_GE(h.levels.size(), 2u);
  // In the last refinement, pair vertices 2k and 2k + 1 where both bits agree.
  const Bits& last = h.levels.back();
  std::vector<uint32_t> twin(last.size(), kNoTwin);
  size_t pairs = 0;
  for (uint32_t v = 0; v + 1 < last.size(); v += 2) {
    if (last[v] != last[v + 1]) continue;
    twin[v] = v + 1;
    twin[v + 1] = v;
    ++pairs;
  }
  ASSERT_GT(pairs, 100u);
  auto encode_last = [&h](const std::vector<uint32_t>* t) {
    SplitBitContexts coder;
    EXPECT_TRUE(coder.Reset(h.base_vertices, h.base_indices).ok());
    for (size_t i = 0; i + 1 < h.levels.size(); ++i) coder.Encode(h.levels[i]);
    return coder.Encode(h.levels.back(), t);
  };
  const Bits plain = encode_last(nullptr);
  const Bits with = encode_last(&twin);
  EXPECT_LT(with.size(), plain.size());
  SplitBitContexts decoder;
  ASSERT_TRUE(decoder.Reset(h.base_vertices, h.base_indices).ok());
  for (size_t i = 0; i + 1 < h.levels.size(); ++i) decoder.Encode(h.levels[i]);  // the same state as a decoder's
  auto got = decoder.Decode(with.data(), with.size(), &twin);
  ASSERT_TRUE(got.ok()) << got.status().ToString();
  EXPECT_EQ(got->bits, last);
  // Without the twins the block means other bits (or nothing valid).
  auto without = decoder.Decode(with.data(), with.size());
  EXPECT_TRUE(!without.ok() || without->bits != last);
}

TEST(SplitBitContexts, ResetRefusesTrianglesBeyondTheBase) {
  SplitBitContexts c;
  const Status bad = c.Reset(3, {0, 1, 3});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.message(), "split bit contexts: base triangle 0 names vertex 3 of 3");
  EXPECT_FALSE(c.Reset(3, {0, 1}).ok());
  // Degenerate triangles and repeated edges are fine: they add no neighbour twice.
  ASSERT_TRUE(c.Reset(3, {0, 1, 2, 0, 1, 2, 1, 1, 2}).ok());
  EXPECT_EQ(c.Context(2, Bits{0, 0, 0}), 2);
}

}  // namespace
}  // namespace meshstream

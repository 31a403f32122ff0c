// Parity datagrams end to end without a mesh: the format (codec/loss/parity.h)
// byte for byte and against hostile bytes, the receiver's rebuild
// (parity_recovery.h) for every pattern a block survives, the sender's plan
// (parity_plan.h) and the simulator's schedule (simulator.h), with the real
// erasure code on ISA-L.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "codec/core/byte_io.h"
#include "codec/loss/parity.h"
#include "codec/loss/parity_plan.h"
#include "codec/loss/parity_recovery.h"
#include "codec/loss/simulator.h"
#include "fec/reed_solomon.h"
#include "tests/common/test_datagram.h"

namespace meshstream {
namespace {

std::vector<uint8_t> DataDatagram(uint32_t stream, uint32_t refinement, DatagramKind kind, uint32_t offset,
                                  uint32_t stride, size_t payload, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> bytes(payload);
  for (auto& b : bytes) b = static_cast<uint8_t>(rng());
  return test_util::TestDatagram(stream, refinement, kind, stride, offset, bytes);
}

ParsedDatagram Parsed(const std::vector<uint8_t>& bytes) {
  auto d = ParsedDatagram::Parse(bytes.data(), bytes.size());
  EXPECT_TRUE(d.ok()) << d.status().message();
  return d.value();
}

// A block of `k` datagrams over refinements 3.. of stream 2, lengths varied.
std::vector<std::vector<uint8_t>> Block(size_t k, uint32_t seed) {
  std::vector<std::vector<uint8_t>> out;
  std::mt19937 rng(seed);
  for (size_t i = 0; i < k; ++i) {
    const uint32_t refinement = 3 + static_cast<uint32_t>(i / 5);
    const DatagramKind kind = (i % 5) < 3 ? DatagramKind::kStructure : DatagramKind::kGeometry;
    const uint32_t offset = (i % 5) < 3 ? static_cast<uint32_t>(i % 5) : static_cast<uint32_t>(i % 5 - 3);
    out.push_back(DataDatagram(2, refinement, kind, offset, 3, 20 + rng() % 300, seed * 1000 + static_cast<uint32_t>(i)));
  }
  return out;
}

std::vector<const std::vector<uint8_t>*> Pointers(const std::vector<std::vector<uint8_t>>& v) {
  std::vector<const std::vector<uint8_t>*> p;
  for (const auto& x : v) p.push_back(&x);
  return p;
}

// A shape with symbols of `symbol` bytes, m parity rows, c per datagram.
ParityShape Shape(const std::vector<std::vector<uint8_t>>& block, uint32_t symbol, uint32_t m, uint32_t c) {
  ParityShape shape;
  shape.symbol_size = symbol;
  for (const auto& d : block) shape.k += static_cast<uint32_t>(SymbolsOf(d.size(), symbol));
  shape.m = m;
  shape.per_datagram = c;
  return shape;
}

TEST(ParityDatagram, RoundTripsItsMembersInBlockOrder) {
  auto& code = fec::DefaultErasureCode();
  auto block = Block(12, 1);
  std::vector<const std::vector<uint8_t>*> shuffled = Pointers(block);
  std::reverse(shuffled.begin(), shuffled.end());  // any order in, block order out
  const ParityShape shape = Shape(block, 64, 5, 2);
  auto parity = EncodeParity(code, 2, shuffled, shape);
  ASSERT_TRUE(parity.ok()) << parity.status().message();
  ASSERT_EQ(parity->size(), 3u);  // rows 2 + 2 + 1
  for (uint32_t j = 0; j < 3; ++j) {
    auto d = Parsed((*parity)[j]);
    EXPECT_EQ(d.header().kind, DatagramKind::kParity);
    auto p = ParityDatagram::Parse(d);
    ASSERT_TRUE(p.ok()) << p.status().message();
    EXPECT_EQ(p->stream, 2u);
    EXPECT_EQ(p->rows, shape.k + 5);
    EXPECT_EQ(p->k, shape.k);
    EXPECT_EQ(p->first_row, shape.k + 2 * j);
    EXPECT_EQ(p->count, j < 2 ? 2u : 1u);
    EXPECT_EQ(p->symbol_size, 64u);
    ASSERT_EQ(p->members.size(), 12u);
    for (size_t i = 0; i < 12; ++i) {
      EXPECT_TRUE(p->members[i].SameDatagram(Parsed(block[i]).header(), block[i].size())) << i;
    }
    EXPECT_EQ(p->first_refinement(), 3u);
    EXPECT_EQ(p->last_refinement(), 5u);
  }
  // The shape must match the members.
  ParityShape wrong = shape;
  ++wrong.k;
  EXPECT_FALSE(EncodeParity(code, 2, shuffled, wrong).ok());
}

// The test vector of docs/spec/progressive-format.md, section 6.1.
TEST(ParityDatagram, SpecTestVector) {
  const std::vector<std::vector<uint8_t>> block = {
      {0x4D, 0x03, 0x01, 0x00, 0x05, 0x02, 0x00, 0x01, 0xAA},
      {0x4D, 0x03, 0x01, 0x00, 0x05, 0x02, 0x01, 0x01, 0xBB, 0xCC},
      {0x4D, 0x03, 0x02, 0x00, 0x06, 0x01, 0x00, 0x02, 0x11},
  };
  // Symbols of 5 bytes: the members are rows 0-1, 2-3 and 4-5 (k = 6).
  ParityShape shape;
  shape.symbol_size = 5;
  shape.k = 6;
  shape.m = 3;
  shape.per_datagram = 2;
  auto parity = EncodeParity(fec::DefaultErasureCode(), 0, Pointers(block), shape);
  ASSERT_TRUE(parity.ok()) << parity.status().message();
  ASSERT_EQ(parity->size(), 2u);
  const std::vector<uint8_t> want0 = {0x4D, 0x03, 0x04, 0x00, 0x05, 0x09, 0x06, 0x06,  // header
                                      0x05, 0x02,                                          // S, c
                                      0x02, 0x00, 0x01, 0x00, 0x02, 0x01, 0x02, 0x00, 0x01,  // runs
                                      0x09, 0x00, 0x0A, 0x00, 0x09, 0x00,                    // lengths
                                      0xA1, 0x6F, 0xD4, 0x79, 0xF6, 0x5D, 0x61, 0xD4, 0x52, 0x58};  // rows 6, 7
  EXPECT_EQ((*parity)[0], want0);
  // Rows 6, 7 and 8 rebuild the first two members (rows 0-3) from the third.
  ParityRecovery rec(&fec::DefaultErasureCode(), 0, 1 << 20);
  std::vector<std::vector<uint8_t>> rebuilt;
  rec.OnData(Parsed(block[2]), &rebuilt);
  rec.OnParity(Parsed((*parity)[0]), &rebuilt);
  EXPECT_TRUE(rebuilt.empty());
  rec.OnParity(Parsed((*parity)[1]), &rebuilt);
  EXPECT_TRUE(rebuilt.empty()) << "3 parity rows and 2 data rows are 5 of the 6 needed";
  rec.OnData(Parsed(block[1]), &rebuilt);
  ASSERT_EQ(rebuilt.size(), 1u);
  EXPECT_EQ(rebuilt[0], block[0]);
}

TEST(ParityDatagram, RefusesHostileBytes) {
  auto block = Block(7, 2);
  auto parity = EncodeParity(fec::DefaultErasureCode(), 2, Pointers(block), Shape(block, 100, 3, 3));
  ASSERT_TRUE(parity.ok());
  const std::vector<uint8_t> good = (*parity)[0];
  // Every truncation and every one-byte change either fails to parse or
  // parses into members and rows that the bytes hold.
  for (size_t n = 0; n < good.size(); ++n) {
    auto d = ParsedDatagram::Parse(good.data(), n);
    if (!d.ok()) continue;
    EXPECT_FALSE(ParityDatagram::Parse(d.value()).ok()) << "truncated to " << n;
  }
  for (size_t at = 0; at < good.size(); ++at) {
    for (uint8_t x : {0x01, 0x80, 0xFF}) {
      std::vector<uint8_t> bad = good;
      bad[at] ^= x;
      auto d = ParsedDatagram::Parse(bad.data(), bad.size());
      if (!d.ok() || d->header().kind != DatagramKind::kParity) continue;
      auto p = ParityDatagram::Parse(d.value());
      if (!p.ok()) continue;
      EXPECT_EQ(p->symbols + size_t(p->count) * p->symbol_size, bad.data() + bad.size());
      uint64_t rows = 0;
      for (size_t i = 0; i < p->members.size(); ++i) {
        if (i > 0) {
          EXPECT_TRUE(MemberBefore(p->members[i - 1], p->members[i]));
        }
        rows += SymbolsOf(p->members[i].length, p->symbol_size);
      }
      EXPECT_EQ(rows, p->k);
      EXPECT_LE(p->first_row + p->count, p->rows);
    }
  }
  // Named cases: header 4D 03 04, stream 0, refinement 0, rows 3, row 2,
  // k 2; S 1, c 1; one run (delta, kind, offset, length); lengths; rows.
  auto refuse = [](std::vector<uint8_t> bytes, const char* what) {
    auto d = ParsedDatagram::Parse(bytes.data(), bytes.size());
    if (!d.ok()) return;  // refused by the header already
    auto p = ParityDatagram::Parse(d.value());
    EXPECT_FALSE(p.ok()) << what;
  };
  const std::vector<uint8_t> h = {0x4D, 0x03, 0x04, 0x00, 0x00, 0x03, 0x02, 0x02};
  auto with = [&](std::vector<uint8_t> tail) {
    std::vector<uint8_t> out = h;
    out.insert(out.end(), tail.begin(), tail.end());
    return out;
  };
  // A good one first, so the named cases differ from it in one thing each.
  {
    auto ok = with({0x01, 0x01, 0x01, 0x00, 0x01, 0x00, 0x02, 0x01, 0x00, 0x01, 0x00, 0xAA});
    auto d = ParsedDatagram::Parse(ok.data(), ok.size());
    ASSERT_TRUE(d.ok());
    EXPECT_TRUE(ParityDatagram::Parse(d.value()).ok());
  }
  refuse(with({0x00, 0x01, 0x01, 0x00, 0x01, 0x00, 0x02, 0x01, 0x00, 0x01, 0x00, 0xAA}), "symbol size 0");
  refuse(with({0x01, 0x00, 0x01, 0x00, 0x01, 0x00, 0x02, 0x01, 0x00, 0x01, 0x00}), "no rows carried");
  refuse(with({0x01, 0x02, 0x01, 0x00, 0x01, 0x00, 0x02, 0x01, 0x00, 0x01, 0x00, 0xAA, 0xBB}), "rows past n");
  refuse(with({0x01, 0x01, 0x01, 0x01, 0x01, 0x00, 0x02, 0x01, 0x00, 0x01, 0x00, 0xAA}), "first delta not 0");
  refuse(with({0x01, 0x01, 0x01, 0x00, 0x03, 0x00, 0x02, 0x01, 0x00, 0x01, 0x00, 0xAA}), "member kind END");
  refuse(with({0x01, 0x01, 0x01, 0x00, 0x01, 0x00, 0x03, 0x01, 0x00, 0x01, 0x00, 0x01, 0x00, 0xAA}), "run > k");
  refuse(with({0x01, 0x01, 0x01, 0x00, 0x01, 0x00, 0x02, 0x00, 0x00, 0x01, 0x00, 0xAA}), "a member of length 0");
  refuse(with({0x01, 0x01, 0x01, 0x00, 0x01, 0x00, 0x02, 0x02, 0x00, 0x01, 0x00, 0xAA}), "rows do not add up");
  refuse(with({0x01, 0x01, 0x01, 0x00, 0x01, 0x00, 0x02, 0x01, 0x00, 0x01, 0x00}), "row bytes missing");
  refuse(with({0x01, 0x01, 0x02, 0x00, 0x01, 0x01, 0x01, 0x00, 0x01, 0x00, 0x01, 0x01, 0x00, 0x01, 0x00, 0xAA}),
         "members not increasing");
}

// Every pattern of lost members and parity datagrams: the block comes back
// exactly when the lost datagrams take at most m rows, and nothing is
// rebuilt otherwise. Members of 1 to 3 rows; parity datagrams of 1 or 2 rows.
TEST(ParityRecovery, RebuildsEveryPatternItCan) {
  auto& code = fec::DefaultErasureCode();
  size_t patterns = 0;
  for (size_t members : {1, 2, 4, 6}) {
    for (uint32_t m : {1u, 2u, 4u}) {
      for (uint32_t c : {1u, 2u}) {
        auto block = Block(members, static_cast<uint32_t>(members * 10 + m));
        const ParityShape shape = Shape(block, 128, m, c);
        auto parity = EncodeParity(code, 2, Pointers(block), shape);
        ASSERT_TRUE(parity.ok());
        std::vector<uint32_t> weight;
        for (const auto& d : block) weight.push_back(static_cast<uint32_t>(SymbolsOf(d.size(), 128)));
        for (const auto& p : *parity) weight.push_back(ParityDatagram::Parse(Parsed(p))->count);
        const size_t n = block.size() + parity->size();
        for (uint32_t mask = 0; mask < (1u << n); ++mask) {
          uint32_t lost_rows = 0;
          for (size_t i = 0; i < n; ++i) lost_rows += ((mask >> i) & 1) ? weight[i] : 0;
          ParityRecovery rec(&code, 2, 1 << 20);
          std::vector<std::vector<uint8_t>> rebuilt;
          auto feed_data = [&] {
            for (size_t i = 0; i < block.size(); ++i) {
              if (!((mask >> i) & 1)) rec.OnData(Parsed(block[i]), &rebuilt);
            }
          };
          auto feed_parity = [&] {
            for (size_t j = 0; j < parity->size(); ++j) {
              if (!((mask >> (block.size() + j)) & 1)) rec.OnParity(Parsed((*parity)[j]), &rebuilt);
            }
          };
          if (mask & 1) {  // parity first for half the masks
            feed_parity();
            feed_data();
          } else {
            feed_data();
            feed_parity();
          }
          // A block rebuilds as soon as k rows are in, so members still on
          // their way (fed after) may be rebuilt too: each rebuilt datagram
          // is a member, and every lost one is among them.
          const std::set<std::vector<uint8_t>> all(block.begin(), block.end());
          for (const auto& r : rebuilt) EXPECT_TRUE(all.count(r)) << "mask " << mask;
          size_t lost_data = 0;
          for (size_t i = 0; i < block.size(); ++i) lost_data += (mask >> i) & 1;
          if (lost_rows <= m) {
            const std::set<std::vector<uint8_t>> got(rebuilt.begin(), rebuilt.end());
            for (size_t i = 0; i < block.size(); ++i) {
              if ((mask >> i) & 1) {
                EXPECT_TRUE(got.count(block[i])) << "members " << members << " m " << m << " c " << c << " mask " << mask;
              }
            }
            EXPECT_GE(rebuilt.size(), lost_data);
            EXPECT_EQ(rec.stats().recovered, rebuilt.size());
          } else {
            EXPECT_TRUE(rebuilt.empty()) << "members " << members << " m " << m << " c " << c << " mask " << mask;
          }
          ++patterns;
        }
      }
    }
  }
  EXPECT_GT(patterns, 2000u);
}

TEST(ParityRecovery, DropsWhatDoesNotBelong) {
  auto& code = fec::DefaultErasureCode();
  auto block = Block(6, 9);
  auto parity = EncodeParity(code, 2, Pointers(block), Shape(block, 400, 2, 2));
  ASSERT_TRUE(parity.ok());
  std::vector<std::vector<uint8_t>> rebuilt;
  // Another stream's parity.
  ParityRecovery other(&code, 5, 1 << 20);
  other.OnParity(Parsed((*parity)[0]), &rebuilt);
  EXPECT_EQ(other.stats().rejected, 1u);
  // A parity whose symbol was changed where a rebuilt header lies: the
  // rebuilt datagram does not name its member, so nothing is returned.
  ParityRecovery rec(&code, 2, 1 << 20);
  std::vector<uint8_t> bad = (*parity)[0];
  auto parsed = ParityDatagram::Parse(Parsed(bad));
  ASSERT_TRUE(parsed.ok());
  const size_t symbol_at = static_cast<size_t>(parsed->symbols - Parsed(bad).data());
  bad[symbol_at + 2] ^= 0x55;  // the rebuilt datagram's kind byte
  for (size_t i = 1; i < 6; ++i) rec.OnData(Parsed(block[i]), &rebuilt);
  rec.OnParity(Parsed(bad), &rebuilt);
  EXPECT_TRUE(rebuilt.empty());
  EXPECT_EQ(rec.stats().inconsistent, 1u);
  // Past the horizon: late.
  ParityRecovery old(&code, 2, 1 << 20);
  old.Release(100);
  old.OnParity(Parsed((*parity)[0]), &rebuilt);
  EXPECT_EQ(old.stats().late, 1u);
  // The byte budget holds: copies beyond it are dropped and counted.
  ParityRecovery tight(&code, 2, 400);
  for (const auto& d : block) tight.OnData(Parsed(d), &rebuilt);
  EXPECT_LE(tight.held_bytes(), 400u);
  EXPECT_GT(tight.stats().overflow, 0u);
}

TEST(ParityPlan, BlocksFollowTheLimits) {
  ProgressiveStream s;
  for (uint32_t r = 0; r < 20; ++r) {
    s.control.push_back({0});
    std::vector<std::vector<uint8_t>> level;
    for (uint32_t d = 0; d < 1 + r % 7; ++d) level.push_back(DataDatagram(0, r, DatagramKind::kStructure, d, 7, 10, d));
    s.datagrams.push_back(level);
  }
  std::vector<uint8_t> protect(20, 1);
  protect[4] = protect[5] = 0;
  ParityPlanOptions o;
  o.block_datagrams = 10;
  o.max_span = 3;
  auto blocks = PlanParityBlocks(s, 20, protect, o);
  size_t members = 0;
  for (const auto& b : blocks) {
    EXPECT_LE(b.members.size(), 10u);
    EXPECT_LT(b.last_refinement() - b.first_refinement(), 3u);
    for (const auto& [r, d] : b.members) {
      EXPECT_TRUE(protect[r]);
      EXPECT_LT(d, s.datagrams[r].size());
    }
    members += b.members.size();
  }
  size_t want = 0;
  for (uint32_t r = 0; r < 20; ++r) want += protect[r] ? s.datagrams[r].size() : 0;
  EXPECT_EQ(members, want);
  EXPECT_TRUE(PlanParityBlocks(s, 20, {}, o).empty());
}

// A change of tier does not cut a block: its tier is its strongest
// refinement's (issue 42: with blocks cut at every change, a refinement
// protected more strongly could leave its neighbours in a block too small
// to carry its share of parity, and a stronger choice lost more).
TEST(ParityPlan, ABlockSpansTiersAtTheStrongestOfThem) {
  ProgressiveStream s;
  for (uint32_t r = 0; r < 6; ++r) {
    s.control.push_back({0});
    std::vector<std::vector<uint8_t>> level;
    for (uint32_t d = 0; d < 3; ++d) level.push_back(DataDatagram(0, r, DatagramKind::kStructure, d, 3, 10, d));
    s.datagrams.push_back(level);
  }
  ParityPlanOptions o;
  o.block_datagrams = 100;
  o.max_span = 16;
  const auto mixed = PlanParityBlocks(s, 6, {1, 1, 2, 1, 1, 1}, o);
  ASSERT_EQ(mixed.size(), 1u) << "one block, not three";
  EXPECT_EQ(mixed[0].members.size(), 18u);
  EXPECT_EQ(mixed[0].tier, 2u);
  const auto plain = PlanParityBlocks(s, 6, {1, 1, 1, 1, 1, 1}, o);
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain[0].tier, 1u);
  // The limits still cut it.
  o.max_span = 2;
  const auto cut = PlanParityBlocks(s, 6, {1, 1, 2, 1, 1, 1}, o);
  ASSERT_EQ(cut.size(), 3u);
  EXPECT_EQ(cut[0].tier, 1u);
  EXPECT_EQ(cut[1].tier, 2u);
  EXPECT_EQ(cut[2].tier, 1u);
}

// The loss bench's --parity-depth experiment (docs/design/loss-protection.md,
// "Levers considered and left"): `depth` blocks share a group's refinements,
// member i of the group to block i mod depth, each within the limits, every
// protected datagram once; a burst then costs each block a share, so at
// bursty loss a block with its members two apart needs no more rows than
// one with them side by side.
TEST(ParityPlan, InterleavedBlocksDealTheirMembersRoundRobin) {
  ProgressiveStream s;
  for (uint32_t r = 0; r < 12; ++r) {
    s.control.push_back({0});
    std::vector<std::vector<uint8_t>> level;
    for (uint32_t d = 0; d < 5; ++d) level.push_back(DataDatagram(0, r, DatagramKind::kStructure, d, 7, 10, d));
    s.datagrams.push_back(level);
  }
  ParityPlanOptions o;
  o.block_datagrams = 10;
  o.max_span = 16;
  o.depth = 2;
  const auto blocks = PlanParityBlocks(s, 12, std::vector<uint8_t>(12, 1), o);
  std::set<std::pair<uint32_t, uint32_t>> seen;
  ASSERT_EQ(blocks.size(), 6u);  // 60 datagrams: groups of 20, dealt in two
  for (size_t b = 0; b < blocks.size(); b += 2) {
    ASSERT_EQ(blocks[b].members.size(), 10u);
    ASSERT_EQ(blocks[b + 1].members.size(), 10u);
    EXPECT_EQ(blocks[b].stride, 2u);
    for (size_t i = 0; i < 10; ++i) {
      // The group's members in send order alternate between the two.
      const auto a = blocks[b].members[i], c = blocks[b + 1].members[i];
      EXPECT_EQ(a.first * 5 + a.second + 1, c.first * 5 + c.second);
      EXPECT_TRUE(seen.insert(a).second && seen.insert(c).second);
    }
  }
  EXPECT_EQ(seen.size(), 60u);
  const std::vector<uint32_t> lengths(50, 1000);
  const ParityShape side_by_side = ShapeFor(lengths, 0.12, 4.0, ParityPlanOptions{}, 2, 1);
  const ParityShape two_apart = ShapeFor(lengths, 0.12, 4.0, ParityPlanOptions{}, 2, 2);
  EXPECT_GT(side_by_side.m, 0u);
  EXPECT_LT(two_apart.m, side_by_side.m) << "a burst costs a block half as much";
}

TEST(ParityPlan, ShapesGrowWithLossAndBursts) {
  std::vector<uint32_t> lengths;
  for (int i = 0; i < 24; ++i) lengths.push_back(400 + 30 * i);
  EXPECT_EQ(ShapeFor(lengths, 0.0, 0.0).m, 0u);
  EXPECT_EQ(ShapeFor(lengths, std::nan(""), 0.0).m, 0u);
  const ParityShape at12 = ShapeFor(lengths, 0.12, 0.0);
  EXPECT_LE(at12.k, 160u);
  EXPECT_LE(at12.k + at12.m, 256u);
  EXPECT_LE(at12.per_datagram * at12.symbol_size, 1200u);
  uint64_t k = 0;
  for (uint32_t l : lengths) k += SymbolsOf(l, at12.symbol_size);
  EXPECT_EQ(k, at12.k);
  uint32_t before = 0;
  for (double loss : {0.01, 0.04, 0.12, 0.2, 0.3}) {
    const uint32_t m = ShapeFor(lengths, loss, 0.0).m;
    EXPECT_GE(m, before) << loss;
    before = m;
    // (Bursts need not: at low loss a block is often untouched by any burst.)
    EXPECT_GE(ShapeFor(lengths, loss, 4.0).m, ShapeFor(lengths, loss / 2, 4.0).m) << loss;
    ParityPlanOptions strong;
    EXPECT_GE(ShapeFor(lengths, loss, 0.0, strong, 2).m, m) << "the strong tier needs at least as much";
  }
  EXPECT_LE(ShapeFor(lengths, 0.9, 4.0).m, (at12.k + 1) / 2);  // the rate cap
  // The exact failure probability against a Monte Carlo of the same chain,
  // with datagrams of several rows.
  const std::vector<uint32_t> weights = {1, 2, 3, 1, 2, 3, 1, 2, 3, 1, 2, 3, 4, 4};
  for (double burst : {0.0, 4.0}) {
    std::mt19937_64 rng(5);
    const double loss = 0.12;
    const uint32_t m = 7;
    const double g2b = burst > 1 ? loss / (burst * (1 - loss)) : loss, b2g = burst > 1 ? 1 / burst : 1 - loss;
    int failures = 0;
    const int runs = 200000;
    for (int run = 0; run < runs; ++run) {
      bool bad = static_cast<double>(rng() >> 11) * 0x1.0p-53 < loss;
      uint32_t lost = 0;
      for (uint32_t w : weights) {
        lost += bad ? w : 0;
        const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;
        bad = bad ? !(u < b2g) : u < g2b;
      }
      failures += lost > m;
    }
    EXPECT_NEAR(WeightedFailure(weights, m, loss, burst), failures / double(runs), 0.004) << "burst " << burst;
  }
  EXPECT_NEAR(BlockFailure(30, 6, 0.12, 0.0), WeightedFailure(std::vector<uint32_t>(30, 1), 6, 0.12, 0.0), 1e-12);
}

}  // namespace
}  // namespace meshstream

namespace meshstream {
namespace {

// Datagrams of 40 to 89 random bytes: symbols of unequal members.
ProgressiveStream SyntheticStream(uint32_t refinements, uint32_t per_refinement) {
  return test_util::SyntheticStream(refinements, per_refinement, [](uint32_t r, uint32_t d) {
    std::mt19937 rng(r * 100 + d);
    std::vector<uint8_t> payload(40 + (r * 7 + d) % 50);
    for (auto& b : payload) b = static_cast<uint8_t>(rng());
    return payload;
  });
}

// The simulator's parity: the data see the same pattern with and without
// it; parity rows follow ParityRowsFor per block; none at a loss of 0; the
// reliable cut's refinements are never members; the parity that arrives
// rebuilds what the plan promises.
TEST(SimulatedParity, AddsParityWithoutChangingTheDataPattern) {
  const ProgressiveStream s = SyntheticStream(60, 4);
  for (double burst : {0.0, 4.0}) {
    LossModel model;
    model.loss = 0.12;
    model.burst = burst;
    model.seed = 9;
    SimulatedParity parity;
    parity.code = &fec::DefaultErasureCode();
    parity.loss = 0.12;
    parity.burst = burst;
    parity.plan.block_failure = parity.plan.strong_failure = 0.02;  // few blocks may keep a loss
    const std::vector<uint32_t> reliable = {0, 1, 7};
    auto plain = SimulateTransmission(s, 0, 60, model, LinkTiming{}, reliable);
    auto with = SimulateTransmission(s, 0, 60, model, LinkTiming{}, reliable, &parity);
    ASSERT_TRUE(plain.ok() && with.ok());
    std::vector<ChannelEvent> data;
    size_t parity_events = 0;
    ParityRecovery rec(&fec::DefaultErasureCode(), 0, 1 << 24);
    std::vector<std::vector<uint8_t>> rebuilt;
    std::set<std::pair<uint32_t, uint32_t>> arrived;
    for (const ChannelEvent& e : with->events) {
      if (e.kind != ChannelEvent::Kind::kDatagram) {
        data.push_back(e);
        continue;
      }
      auto d = ParsedDatagram::Parse(e.data, e.size);
      ASSERT_TRUE(d.ok());
      if (d->header().kind == DatagramKind::kParity) {
        ++parity_events;
        auto p = ParityDatagram::Parse(d.value());
        ASSERT_TRUE(p.ok());
        for (const ParityMember& m : p->members) {
          EXPECT_TRUE(std::find(reliable.begin(), reliable.end(), m.refinement) == reliable.end());
        }
        rec.OnParity(d.value(), &rebuilt);
        continue;
      }
      data.push_back(e);
      if (d->header().kind != DatagramKind::kEnd) {
        arrived.insert({d->header().refinement, d->header().offset});
        rec.OnData(d.value(), &rebuilt);
      }
    }
    ASSERT_EQ(data.size(), plain->events.size()) << "burst " << burst;
    for (size_t i = 0; i < data.size(); ++i) {
      EXPECT_EQ(data[i].time_us, plain->events[i].time_us);
      EXPECT_EQ(std::vector<uint8_t>(data[i].data, data[i].data + data[i].size),
                std::vector<uint8_t>(plain->events[i].data, plain->events[i].data + plain->events[i].size));
    }
    EXPECT_EQ(with->stats.datagrams_lost, plain->stats.datagrams_lost);
    EXPECT_EQ(parity_events + with->stats.parity_lost, with->stats.parity_datagrams);
    // Rows per block as the plan says.
    std::vector<uint8_t> protect(60, 2);  // the simulator's default: every unreliable refinement, strong
    for (uint32_t r : reliable) protect[r] = 0;
    uint64_t parity_datagrams = 0;
    for (const auto& b : PlanParityBlocks(s, 60, protect, parity.plan)) {
      std::vector<uint32_t> lengths;
      for (const auto& [r, d] : b.members) lengths.push_back(static_cast<uint32_t>(s.datagrams[r][d].size()));
      parity_datagrams += ShapeFor(lengths, 0.12, burst, parity.plan, b.tier).datagrams();
    }
    EXPECT_EQ(with->stats.parity_datagrams, parity_datagrams);
    EXPECT_GT(parity_datagrams, 0u);
    // What arrived plus what was rebuilt covers every unreliable datagram but
    // those of the blocks that lost more than their parity.
    for (const auto& r : rebuilt) {
      auto d = ParsedDatagram::Parse(r.data(), r.size());
      ASSERT_TRUE(d.ok());
      EXPECT_TRUE(arrived.insert({d->header().refinement, d->header().offset}).second) << "rebuilt twice or arrived";
    }
    size_t missing = 0;
    for (uint32_t r = 0; r < 60; ++r) {
      if (!protect[r]) continue;
      for (uint32_t d = 0; d < 4; ++d) missing += arrived.count({r, d}) == 0;
    }
    EXPECT_GT(rec.stats().recovered, 0u);
    // Bursts take several members of a block at once: fewer come back.
    EXPECT_LT(missing, with->stats.datagrams_lost / (burst > 1 ? 2 : 3)) << "burst " << burst;
  }
  // No parity at a loss of 0.
  LossModel model;
  model.loss = 0.12;
  SimulatedParity none;
  none.code = &fec::DefaultErasureCode();
  auto quiet = SimulateTransmission(s, 0, 60, model, LinkTiming{}, {}, &none);
  ASSERT_TRUE(quiet.ok());
  EXPECT_EQ(quiet->stats.parity_datagrams, 0u);
}

}  // namespace
}  // namespace meshstream

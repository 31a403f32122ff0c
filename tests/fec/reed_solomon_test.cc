// The erasure code on ISA-L against the spec (docs/spec/progressive-format.md,
// section 7): parity computed by an independent GF(2^8) implementation here
// must match byte for byte, and every erasure pattern a block can survive is
// rebuilt exactly: exhaustively for small blocks, at random for large ones.
#include "fec/reed_solomon.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

namespace meshstream::fec {
namespace {

// GF(2^8) with 0x11D, by shift and add: independent of ISA-L's tables.
uint8_t Mul(uint8_t a, uint8_t b) {
  uint8_t p = 0;
  while (b) {
    if (b & 1) p ^= a;
    const bool carry = a & 0x80;
    a = static_cast<uint8_t>(a << 1);
    if (carry) a ^= 0x1D;
    b >>= 1;
  }
  return p;
}
uint8_t Inv(uint8_t a) {
  for (int b = 1; b < 256; ++b) {
    if (Mul(a, static_cast<uint8_t>(b)) == 1) return static_cast<uint8_t>(b);
  }
  return 0;
}

std::vector<uint8_t> SpecParity(const std::vector<std::vector<uint8_t>>& data, uint32_t row) {
  const size_t k = data.size();
  std::vector<uint8_t> p(data[0].size(), 0);
  for (size_t i = 0; i < k; ++i) {
    const uint8_t c = Inv(static_cast<uint8_t>(row ^ i));
    for (size_t b = 0; b < p.size(); ++b) p[b] ^= Mul(c, data[i][b]);
  }
  return p;
}

std::vector<std::vector<uint8_t>> RandomData(size_t k, size_t len, std::mt19937& rng) {
  std::vector<std::vector<uint8_t>> data(k, std::vector<uint8_t>(len));
  for (auto& d : data) {
    for (auto& b : d) b = static_cast<uint8_t>(rng());
  }
  return data;
}

std::vector<std::vector<uint8_t>> Encode(ReedSolomon& rs, const std::vector<std::vector<uint8_t>>& data, size_t m) {
  const size_t k = data.size(), len = data[0].size();
  std::vector<std::vector<uint8_t>> parity(m, std::vector<uint8_t>(len));
  std::vector<const uint8_t*> in;
  for (const auto& d : data) in.push_back(d.data());
  std::vector<uint8_t*> out;
  for (auto& p : parity) out.push_back(p.data());
  std::vector<uint32_t> rows(m);
  std::iota(rows.begin(), rows.end(), static_cast<uint32_t>(k));
  EXPECT_TRUE(rs.Encode(k, len, in.data(), rows.data(), m, out.data()).ok());
  return parity;
}

// Rebuilds the data rows missing from `lost` (a set of rows of k + m) from
// the first k rows that survive; true when every data symbol came back.
bool RebuildAndCheck(ReedSolomon& rs, const std::vector<std::vector<uint8_t>>& data,
                     const std::vector<std::vector<uint8_t>>& parity, const std::vector<bool>& lost) {
  const size_t k = data.size(), len = data[0].size();
  std::vector<uint32_t> rows, wanted;
  std::vector<const uint8_t*> symbols;
  for (uint32_t r = 0; r < k + parity.size() && rows.size() < k; ++r) {
    if (lost[r]) continue;
    rows.push_back(r);
    symbols.push_back(r < k ? data[r].data() : parity[r - k].data());
  }
  for (uint32_t r = 0; r < k; ++r) {
    if (lost[r]) wanted.push_back(r);
  }
  std::vector<std::vector<uint8_t>> rebuilt(wanted.size(), std::vector<uint8_t>(len, 0xEE));
  std::vector<uint8_t*> out;
  for (auto& r : rebuilt) out.push_back(r.data());
  if (!rs.Rebuild(k, len, rows.data(), symbols.data(), wanted.data(), wanted.size(), out.data()).ok()) return false;
  for (size_t j = 0; j < wanted.size(); ++j) {
    if (rebuilt[j] != data[wanted[j]]) return false;
  }
  return true;
}

TEST(ReedSolomon, ParityMatchesTheSpecsArithmetic) {
  ReedSolomon rs;
  std::mt19937 rng(7);
  // Lengths below and above ISA-L's SIMD widths (16, 32, 64).
  for (size_t k : {1, 2, 5, 17, 64, 200}) {
    for (size_t len : {1, 15, 33, 100, 1200}) {
      auto data = RandomData(k, len, rng);
      const size_t m = std::min<size_t>(4, 256 - k);
      auto parity = Encode(rs, data, m);
      for (size_t j = 0; j < m; ++j) {
        EXPECT_EQ(parity[j], SpecParity(data, static_cast<uint32_t>(k + j))) << "k " << k << " len " << len << " row " << k + j;
      }
    }
  }
}

// The test vector of docs/spec/progressive-format.md, section 7.
TEST(ReedSolomon, SpecTestVector) {
  ReedSolomon rs;
  const std::vector<std::vector<uint8_t>> data = {{0x01, 0x02, 0x03}, {0x10, 0x20, 0x00}, {0xFF, 0x00, 0x80}};
  auto parity = Encode(rs, data, 2);
  EXPECT_EQ(parity[0], SpecParity(data, 3));
  EXPECT_EQ(parity[1], SpecParity(data, 4));
  EXPECT_EQ(parity[0], (std::vector<uint8_t>{0x03, 0xE5, 0x81}));
  EXPECT_EQ(parity[1], (std::vector<uint8_t>{0x41, 0xD7, 0x02}));
}

// Every pattern of at most m erasures among k + m rows, for k <= 8, m <= 4.
TEST(ReedSolomon, EveryErasurePatternOfSmallBlocks) {
  ReedSolomon rs;
  std::mt19937 rng(11);
  size_t patterns = 0;
  for (size_t k = 1; k <= 8; ++k) {
    for (size_t m = 1; m <= 4; ++m) {
      auto data = RandomData(k, 37, rng);
      auto parity = Encode(rs, data, m);
      const size_t n = k + m;
      for (uint32_t mask = 0; mask < (1u << n); ++mask) {
        if (static_cast<size_t>(__builtin_popcount(mask)) > m) continue;
        std::vector<bool> lost(n);
        for (size_t r = 0; r < n; ++r) lost[r] = (mask >> r) & 1;
        ASSERT_TRUE(RebuildAndCheck(rs, data, parity, lost)) << "k " << k << " m " << m << " lost mask " << mask;
        ++patterns;
      }
    }
  }
  EXPECT_EQ(patterns, 3402u);
}

TEST(ReedSolomon, RandomErasuresOfLargeBlocks) {
  ReedSolomon rs;
  std::mt19937 rng(13);
  for (int run = 0; run < 200; ++run) {
    const size_t k = 1 + rng() % 200;
    const size_t m = 1 + rng() % std::min<size_t>(55, 256 - k - 1);
    auto data = RandomData(k, 1 + rng() % 1500, rng);
    auto parity = Encode(rs, data, m);
    std::vector<uint32_t> order(k + m);
    std::iota(order.begin(), order.end(), 0u);
    std::shuffle(order.begin(), order.end(), rng);
    std::vector<bool> lost(k + m);
    const size_t erased = rng() % (m + 1);
    for (size_t i = 0; i < erased; ++i) lost[order[i]] = true;
    ASSERT_TRUE(RebuildAndCheck(rs, data, parity, lost)) << "run " << run << " k " << k << " m " << m;
  }
}

// A parity row is the same whatever other parity rows are sent: a sender may
// add rows to a block later.
TEST(ReedSolomon, RowsDoNotDependOnTheirCount) {
  ReedSolomon rs;
  std::mt19937 rng(17);
  auto data = RandomData(12, 300, rng);
  auto two = Encode(rs, data, 2);
  auto six = Encode(rs, data, 6);
  EXPECT_EQ(two[0], six[0]);
  EXPECT_EQ(two[1], six[1]);
}

TEST(ReedSolomon, RefusesBadRows) {
  ReedSolomon rs;
  std::vector<uint8_t> a(8), b(8);
  const uint8_t* in[2] = {a.data(), b.data()};
  uint8_t* out[2] = {a.data(), b.data()};
  uint32_t data_row[1] = {1};
  EXPECT_EQ(rs.Encode(2, 8, in, data_row, 1, out).code(), StatusCode::kInvalidArgument);
  uint32_t too_far[1] = {256};
  EXPECT_EQ(rs.Encode(2, 8, in, too_far, 1, out).code(), StatusCode::kInvalidArgument);
  uint32_t twice[2] = {3, 3};
  EXPECT_EQ(rs.Encode(2, 8, in, twice, 2, out).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(rs.Encode(0, 8, in, too_far, 0, out).code(), StatusCode::kInvalidArgument);
  uint32_t rows[2] = {0, 0};
  uint32_t wanted[1] = {1};
  EXPECT_EQ(rs.Rebuild(2, 8, rows, in, wanted, 1, out).code(), StatusCode::kInvalidArgument);
  uint32_t good_rows[2] = {0, 2};
  uint32_t not_data[1] = {2};
  EXPECT_EQ(rs.Rebuild(2, 8, good_rows, in, not_data, 1, out).code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshstream::fec

// StaticModel (codec/entropy/symbol_model.h) with the range coder: random
// symbol sequences round trip for several alphabets and skews, a serialized
// model parses back into one that codes the same bytes, Parse refuses what
// its contract says (truncated, no symbol, stray nibble, alphabet too large)
// and every model it accepts sums to exactly 2^12; signed values round trip.
#include "codec/entropy/symbol_model.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

using Bytes = std::vector<uint8_t>;

// Symbols drawn with probability proportional to `weights`.
std::vector<uint32_t> Draw(const std::vector<double>& weights, size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::discrete_distribution<uint32_t> dist(weights.begin(), weights.end());
  std::vector<uint32_t> out(n);
  for (auto& s : out) s = dist(rng);
  return out;
}

std::vector<uint64_t> Histogram(const std::vector<uint32_t>& symbols, size_t alphabet) {
  std::vector<uint64_t> counts(alphabet, 0);
  for (uint32_t s : symbols) ++counts[s];
  return counts;
}

Bytes EncodeAll(const StaticModel& m, const std::vector<uint32_t>& symbols) {
  RangeEncoder enc;
  for (uint32_t s : symbols) m.Encode(enc, s);
  return enc.Finish();
}

Bytes SerializeModel(const StaticModel& m) {
  ByteWriter w;
  m.Serialize(w);
  return w.bytes();
}

// The model's frequencies recovered from Cost (12 - log2 freq).
double FrequencySum(const StaticModel& m) {
  double sum = 0;
  for (uint32_t s = 0; s < m.alphabet(); ++s)
    if (m.Has(s)) sum += std::round(std::exp2(kModelBits - m.Cost(s)));
  return sum;
}

struct Alphabet {
  const char* name;
  std::vector<double> weights;
};

std::vector<Alphabet> Alphabets() {
  std::vector<Alphabet> out;
  out.push_back({"one symbol", {1}});
  out.push_back({"two equal", {1, 1}});
  out.push_back({"binary skewed 1:999", {999, 1}});
  std::vector<double> uniform16(16, 1.0), geometric(40), sparse(kMaxAlphabet, 0.0), full(kMaxAlphabet);
  for (size_t i = 0; i < geometric.size(); ++i) geometric[i] = std::pow(0.6, double(i));
  for (size_t i = 0; i < sparse.size(); i += 7) sparse[i] = 1.0 + double(i);
  for (size_t i = 0; i < full.size(); ++i) full[i] = 1.0 + double((i * 37) % 11);
  full[0] = 5000;  // one dominant symbol with 95 rare ones
  out.push_back({"uniform 16", uniform16});
  out.push_back({"geometric 40", geometric});
  out.push_back({"sparse 96", sparse});
  out.push_back({"skewed 96", full});
  return out;
}

TEST(SymbolModel, RandomSequencesRoundTripThroughAParsedModel) {
  uint32_t seed = 1;
  for (const Alphabet& a : Alphabets()) {
    for (int run = 0; run < 3; ++run, ++seed) {
      const auto symbols = Draw(a.weights, 3000, seed);
      const StaticModel model = StaticModel::FromCounts(Histogram(symbols, a.weights.size()));
      for (size_t s = 0; s < a.weights.size(); ++s) {
        // Every symbol that occurs is codable; none beyond the alphabet is.
        if (std::count(symbols.begin(), symbols.end(), s)) {
          EXPECT_TRUE(model.Has(static_cast<uint32_t>(s))) << a.name;
        }
      }
      EXPECT_FALSE(model.Has(model.alphabet())) << a.name;
      EXPECT_NEAR(FrequencySum(model), 4096.0, 1e-9) << a.name;

      const Bytes coded = EncodeAll(model, symbols);
      // The decoder gets the model through its serialized form only.
      const Bytes wire = SerializeModel(model);
      ByteReader r(wire.data(), wire.size());
      auto parsed = StaticModel::Parse(r);
      ASSERT_TRUE(parsed.ok()) << a.name << ": " << parsed.status().ToString();
      EXPECT_EQ(r.remaining(), 0u);
      EXPECT_EQ(parsed->alphabet(), model.alphabet());
      EXPECT_EQ(EncodeAll(parsed.value(), symbols), coded) << a.name;

      RangeDecoder dec(coded.data(), coded.size());
      std::vector<uint32_t> back(symbols.size());
      for (auto& s : back) s = parsed->Decode(dec);
      EXPECT_FALSE(dec.overran()) << a.name;
      EXPECT_EQ(back, symbols) << a.name << " seed " << seed;
    }
  }
}

TEST(SymbolModel, SkewedModelsCompressAndCostTracksTheSkew) {
  const auto symbols = Draw({999, 1}, 20000, 7);
  const StaticModel model = StaticModel::FromCounts(Histogram(symbols, 2));
  EXPECT_LT(model.Cost(0), model.Cost(1));
  // About 0.011 bits per symbol of entropy; codes of 4 bits per weight
  // cannot get there, but far below one bit per symbol.
  EXPECT_LT(EncodeAll(model, symbols).size() * 8, symbols.size() / 4);
  EXPECT_EQ(model.Cost(5), 64.0);  // outside the alphabet: prohibitive
}

TEST(SymbolModel, AllZeroHistogramGivesSymbolZeroOnly) {
  const StaticModel m = StaticModel::FromCounts({0, 0, 0});
  EXPECT_EQ(m.alphabet(), 1u);
  EXPECT_TRUE(m.Has(0));
  EXPECT_EQ(m.Cost(0), 0.0);
  const StaticModel empty = StaticModel::FromCounts({});
  EXPECT_EQ(empty.alphabet(), 1u);
  EXPECT_TRUE(empty.Has(0));
}

TEST(SymbolModel, TrailingAbsentSymbolsAreNotSent) {
  const StaticModel m = StaticModel::FromCounts({5, 0, 3, 0, 0, 0});
  EXPECT_EQ(m.alphabet(), 3u);
  EXPECT_FALSE(m.Has(1));
  // Alphabet size, then one nibble per symbol, low nibble first.
  const Bytes wire = SerializeModel(m);
  ASSERT_EQ(wire.size(), 3u);
  EXPECT_EQ(wire[0], 3);
  EXPECT_EQ(wire[1] >> 4, 0);   // symbol 1 absent
  EXPECT_NE(wire[1] & 0x0F, 0); // symbol 0 present
  EXPECT_NE(wire[2] & 0x0F, 0); // symbol 2 present
  EXPECT_EQ(wire[2] >> 4, 0);   // padding nibble
}

TEST(SymbolModel, ParseRefusesEveryTruncation) {
  std::vector<uint64_t> counts(kMaxAlphabet);
  for (size_t i = 0; i < counts.size(); ++i) counts[i] = 1 + i;
  const Bytes wire = SerializeModel(StaticModel::FromCounts(counts));
  ASSERT_EQ(wire.size(), 1 + kMaxAlphabet / 2);
  for (size_t cut = 0; cut < wire.size(); ++cut) {
    ByteReader r(wire.data(), cut);
    auto m = StaticModel::Parse(r);
    ASSERT_FALSE(m.ok()) << cut;
    EXPECT_EQ(m.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(m.status().message().find("model"), std::string::npos) << m.status().message();
  }
}

TEST(SymbolModel, ParseRefusesBadAlphabetsAndEmptyModels) {
  auto parse = [](const Bytes& b) {
    ByteReader r(b.data(), b.size());
    return StaticModel::Parse(r);
  };
  EXPECT_FALSE(parse({0}).ok());                           // no alphabet
  Bytes too_large = {static_cast<uint8_t>(kMaxAlphabet + 1)};
  too_large.resize(1 + (kMaxAlphabet + 2) / 2, 0x11);
  EXPECT_FALSE(parse(too_large).ok());                     // alphabet above the maximum
  Bytes largest = {static_cast<uint8_t>(kMaxAlphabet)};
  largest.resize(1 + kMaxAlphabet / 2, 0x11);
  EXPECT_TRUE(parse(largest).ok());                        // the maximum itself
  EXPECT_FALSE(parse({4, 0x00, 0x00}).ok());               // zero total: no symbol present
  EXPECT_FALSE(parse({3, 0x21, 0x50}).ok());               // stray nibble after the last symbol
  EXPECT_TRUE(parse({3, 0x21, 0x05}).ok());
}

TEST(SymbolModel, EveryAcceptedModelSumsToExactlyTwoToTheTwelve) {
  // Hostile code tables, including many heavy symbols beside many light ones
  // (the rounding the largest symbol absorbs is then the largest).
  std::mt19937 rng(3);
  int accepted = 0;
  for (int it = 0; it < 3000; ++it) {
    const uint32_t n = 1 + rng() % kMaxAlphabet;
    Bytes wire = {static_cast<uint8_t>(n)};
    std::vector<uint8_t> codes(n);
    const int mode = it % 3;
    for (auto& c : codes) c = mode == 0 ? rng() % 16 : mode == 1 ? ((rng() % 2) ? 15 : 1) : (rng() % 8 ? 0 : 15);
    for (uint32_t s = 0; s < n; s += 2) wire.push_back(static_cast<uint8_t>(codes[s] | ((s + 1 < n ? codes[s + 1] : 0) << 4)));
    ByteReader r(wire.data(), wire.size());
    auto m = StaticModel::Parse(r);
    if (!m.ok()) continue;
    ++accepted;
    ASSERT_NEAR(FrequencySum(m.value()), 4096.0, 1e-9) << "iteration " << it;
    for (uint32_t s = 0; s < n; ++s) ASSERT_EQ(m->Has(s), codes[s] != 0) << "iteration " << it;
  }
  EXPECT_GT(accepted, 2500);
}

TEST(SymbolModel, DecodeOfGarbageStaysInTheAlphabet) {
  const StaticModel m = StaticModel::FromCounts({10, 0, 3, 0, 1});
  std::mt19937 rng(11);
  Bytes garbage(512);
  for (auto& b : garbage) b = static_cast<uint8_t>(rng());
  RangeDecoder dec(garbage.data(), garbage.size());
  for (int i = 0; i < 2000; ++i) {
    const uint32_t s = m.Decode(dec);
    ASSERT_TRUE(m.Has(s)) << s;
  }
}

TEST(SymbolModel, SignedValuesRoundTripAtEveryLength) {
  std::vector<int32_t> values = {0, 1, -1, 7, -8, 8, -9, std::numeric_limits<int32_t>::max(),
                                 std::numeric_limits<int32_t>::min()};
  for (int bits = 3; bits < 31; ++bits) {
    const int32_t p = int32_t{1} << bits;
    values.insert(values.end(), {p - 1, p, p + 1, -p, -p - 1, -p + 1});
  }
  std::vector<uint64_t> counts(kSignedSymbols, 0);
  for (int32_t v : values) {
    EXPECT_EQ(UnZigZag(ZigZag(v)), v);
    ASSERT_LT(SignedSymbol(v), kSignedSymbols) << v;
    ++counts[SignedSymbol(v)];
  }
  const StaticModel m = StaticModel::FromCounts(counts);
  RangeEncoder enc;
  for (int32_t v : values) EncodeSigned(enc, m, v);
  const Bytes coded = enc.Finish();
  RangeDecoder dec(coded.data(), coded.size());
  for (int32_t v : values) EXPECT_EQ(DecodeSigned(dec, m), v);
  EXPECT_FALSE(dec.overran());
  EXPECT_EQ(SignedSymbol(std::numeric_limits<int32_t>::min()), kSignedSymbols - 1);
}

}  // namespace
}  // namespace meshstream

#include "codec/entropy/symbol_model.h"

#include <algorithm>
#include <cmath>

namespace meshstream {

namespace {

// Weights of the 4-bit codes: about 1.6^c.
constexpr uint32_t kCodeWeight[16] = {0, 2, 3, 4, 7, 10, 17, 27, 43, 69, 110, 176, 281, 450, 720, 1153};

}  // namespace

StaticModel StaticModel::FromCounts(const std::vector<uint64_t>& counts) {
  StaticModel m;
  size_t n = counts.size();
  while (n > 1 && counts[n - 1] == 0) --n;
  n = std::max<size_t>(n, 1);
  m.codes_.assign(n, 0);
  uint64_t max = 0;
  for (uint64_t c : counts) max = std::max(max, c);  // counts may be empty (n is then 1)
  if (max == 0) {
    m.codes_[0] = 15;
  } else {
    for (size_t s = 0; s < n; ++s) {
      if (counts[s] == 0) continue;
      const double c = 15.0 + std::log(double(counts[s]) / double(max)) / std::log(1.6);
      m.codes_[s] = static_cast<uint8_t>(std::clamp(std::lround(c), 1L, 15L));
    }
  }
  m.FromCodes();
  return m;
}

bool StaticModel::FromCodes() {
  const size_t n = codes_.size();
  freq_.assign(n, 0);
  uint64_t weight = 0;
  for (uint8_t c : codes_) weight += kCodeWeight[c];
  const uint32_t one = 1u << kModelBits;
  uint32_t used = 0;
  size_t largest = 0;
  for (size_t s = 0; s < n; ++s) {
    if (codes_[s] == 0) continue;
    freq_[s] = std::max<uint32_t>(1, static_cast<uint32_t>(uint64_t(kCodeWeight[codes_[s]]) * one / weight));
    used += freq_[s];
    if (freq_[s] > freq_[largest]) largest = s;
  }
  // The largest absorbs the rounding. Codes the encoder writes always leave
  // it at least 1; hostile ones (many tiny symbols raised to 1) may not.
  if (used >= one + freq_[largest]) return false;
  freq_[largest] = freq_[largest] + one - used;
  Build();
  return true;
}

void StaticModel::Build() {
  cum_.assign(freq_.size(), 0);
  lookup_.assign(size_t{1} << kModelBits, 0);
  uint32_t c = 0;
  for (size_t s = 0; s < freq_.size(); ++s) {
    cum_[s] = c;
    for (uint32_t k = 0; k < freq_[s]; ++k) lookup_[c + k] = static_cast<uint8_t>(s);
    c += freq_[s];
  }
}

void StaticModel::Serialize(ByteWriter& w) const {
  w.U8(static_cast<uint8_t>(codes_.size()));
  for (size_t s = 0; s < codes_.size(); s += 2) {
    const uint8_t hi = s + 1 < codes_.size() ? codes_[s + 1] : 0;
    w.U8(static_cast<uint8_t>(codes_[s] | (hi << 4)));
  }
}

StatusOr<StaticModel> StaticModel::Parse(ByteReader& r, uint32_t max_alphabet) {
  MS_ASSIGN_OR_RETURN(uint8_t n, r.U8("model alphabet size"));
  if (n == 0 || n > max_alphabet || n > kMaxAlphabet) {
    return InvalidInput("model alphabet size " + std::to_string(n) + " is out of range (1.." +
                        std::to_string(std::min(max_alphabet, kMaxAlphabet)) + ")");
  }
  StaticModel m;
  m.codes_.resize(n);
  bool any = false;
  for (uint32_t s = 0; s < n; s += 2) {
    MS_ASSIGN_OR_RETURN(uint8_t b, r.U8("model codes"));
    m.codes_[s] = b & 0x0F;
    if (s + 1 < n) m.codes_[s + 1] = b >> 4;
    else if ((b >> 4) != 0) return InvalidInput("model codes have a stray nibble");
  }
  for (uint8_t c : m.codes_) any = any || c != 0;
  if (!any) return InvalidInput("model codes: no symbol is present");
  if (!m.FromCodes()) return InvalidInput("model codes leave the most frequent symbol no frequency");
  return m;
}

double StaticModel::Cost(uint32_t symbol) const {
  if (!Has(symbol)) return 64.0;
  return kModelBits - std::log2(double(freq_[symbol]));
}

void EncodeSignedRest(RangeEncoder& enc, uint32_t symbol, int32_t v) {
  const uint32_t z = ZigZag(v);
  int bits = static_cast<int>((symbol - kDirectSymbols) / 2 + 5) - 2;  // L - 2
  uint32_t rest = z & ((bits >= 32) ? 0xFFFFFFFFu : ((1u << bits) - 1u));
  while (bits > 16) {
    enc.EncodeRaw(rest & 0xFFFF, 16);
    rest >>= 16;
    bits -= 16;
  }
  enc.EncodeRaw(rest, bits);
}

int32_t DecodeSignedRest(RangeDecoder& dec, uint32_t symbol) {
  // Unreachable from a stream: the reader's signed-value models have at most
  // kSignedSymbols symbols (docs/spec/progressive-format.md, section 5).
  if (symbol >= kSignedSymbols) return 0;
  const uint32_t length = (symbol - kDirectSymbols) / 2 + 5;
  const uint32_t second = (symbol - kDirectSymbols) & 1;
  int bits = static_cast<int>(length - 2);
  uint32_t rest = 0;
  int shift = 0;
  while (bits > 16) {
    rest |= dec.DecodeRaw(16) << shift;
    shift += 16;
    bits -= 16;
  }
  rest |= dec.DecodeRaw(bits) << shift;
  const uint32_t z = (1u << (length - 1)) | (second << (length - 2)) | rest;
  return UnZigZag(z);
}

double SignedCost(const StaticModel& model, int32_t v) {
  const uint32_t symbol = SignedSymbol(v);
  return model.Cost(symbol) + (symbol < kDirectSymbols ? 0 : (symbol - kDirectSymbols) / 2 + 3);
}

}  // namespace meshstream

#include "codec/symbol_model.h"

#include <algorithm>
#include <cmath>

namespace meshstream {

StaticModel StaticModel::FromCounts(const std::vector<uint64_t>& counts) {
  StaticModel m;
  size_t n = counts.size();
  while (n > 1 && counts[n - 1] == 0) --n;
  n = std::max<size_t>(n, 1);
  m.freq_.assign(n, 0);
  uint64_t total = 0;
  for (size_t s = 0; s < n; ++s) total += counts[s];
  const uint32_t one = 1u << kModelBits;
  if (total == 0) {
    m.freq_[0] = one;
  } else {
    uint32_t used = 0;
    for (size_t s = 0; s < n; ++s) {
      if (counts[s] == 0) continue;
      m.freq_[s] = std::max<uint32_t>(1, static_cast<uint32_t>(std::floor(double(counts[s]) * one / total)));
      used += m.freq_[s];
    }
    // Fix the sum to exactly 2^12: adjust the most frequent symbols.
    while (used != one) {
      size_t best = 0;
      for (size_t s = 1; s < n; ++s) if (m.freq_[s] > m.freq_[best]) best = s;
      if (used < one) {
        m.freq_[best] += one - used;
        used = one;
      } else {
        // Take from the largest symbols that can spare it.
        const uint32_t excess = used - one;
        const uint32_t take = std::min(excess, m.freq_[best] - 1);
        m.freq_[best] -= take;
        used -= take;
        if (take == 0) break;  // cannot happen with n <= 64 < 2^12
      }
    }
  }
  m.Build();
  return m;
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
  w.U8(static_cast<uint8_t>(freq_.size()));
  for (uint32_t f : freq_) w.Varint(f);
}

StatusOr<StaticModel> StaticModel::Parse(ByteReader& r) {
  MS_ASSIGN_OR_RETURN(uint8_t n, r.U8("model alphabet size"));
  if (n == 0 || n > kMaxAlphabet) return InvalidInput("model alphabet size " + std::to_string(n) + " is out of range");
  StaticModel m;
  m.freq_.resize(n);
  uint64_t sum = 0;
  for (uint32_t s = 0; s < n; ++s) {
    MS_ASSIGN_OR_RETURN(uint64_t f, r.Varint("model frequency", 1u << kModelBits));
    m.freq_[s] = static_cast<uint32_t>(f);
    sum += f;
  }
  if (sum != (1u << kModelBits)) return InvalidInput("model frequencies sum to " + std::to_string(sum) + ", not 4096");
  m.Build();
  return m;
}

double StaticModel::Cost(uint32_t symbol) const {
  if (!Has(symbol)) return 64.0;
  return kModelBits - std::log2(double(freq_[symbol]));
}

void EncodeSigned(RangeEncoder& enc, const StaticModel& model, int32_t v) {
  const uint32_t z = ZigZag(v);
  const uint32_t k = BucketOf(v);
  model.Encode(enc, k);
  if (k > 1) {
    uint32_t rest = z - (1u << (k - 1));
    int bits = static_cast<int>(k - 1);
    while (bits > 16) {
      enc.EncodeRaw(rest & 0xFFFF, 16);
      rest >>= 16;
      bits -= 16;
    }
    enc.EncodeRaw(rest, bits);
  }
}

int32_t DecodeSigned(RangeDecoder& dec, const StaticModel& model) {
  const uint32_t k = model.Decode(dec);
  if (k == 0) return 0;
  if (k > 32) return 0;
  uint32_t rest = 0;
  int bits = static_cast<int>(k - 1);
  int shift = 0;
  while (bits > 16) {
    rest |= dec.DecodeRaw(16) << shift;
    shift += 16;
    bits -= 16;
  }
  if (bits > 0) rest |= dec.DecodeRaw(bits) << shift;
  return UnZigZag((k == 32 ? 0x80000000u : (1u << (k - 1))) + rest);
}

double SignedCost(const StaticModel& model, int32_t v) {
  const uint32_t k = BucketOf(v);
  return model.Cost(k) + (k > 1 ? k - 1 : 0);
}

}  // namespace meshstream

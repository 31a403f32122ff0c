#include "codec/entropy/adaptive_model.h"

#include <cmath>

namespace meshstream {

namespace {

constexpr int kQ = 32;  // theta and its powers in 0.32 fixed point

uint64_t MulQ(uint64_t a, uint64_t b) { return static_cast<uint64_t>((static_cast<unsigned __int128>(a) * b) >> kQ); }

// theta^n in 0.32 fixed point, by squaring (n up to 2^32).
uint64_t PowQ(uint64_t theta, uint64_t n) {
  uint64_t result = uint64_t{1} << kQ;
  while (n) {
    if (n & 1) result = MulQ(result, theta);
    theta = MulQ(theta, theta);
    n >>= 1;
  }
  return result;
}

}  // namespace

void AdaptiveModel::Reset(const ModelPrior& prior) {
  n_ = static_cast<uint32_t>(prior.size());
  total_ = 0;
  for (uint32_t s = 0; s < n_; ++s) {
    counts_[s] = prior[s];
    total_ += prior[s];
  }
}

void AdaptiveModel::Halve() {
  total_ = 0;
  for (uint32_t s = 0; s < n_; ++s) {
    counts_[s] = (counts_[s] + 1) / 2;
    total_ += counts_[s];
  }
}

namespace {

// log2 of 0 .. kLimit + kIncrement (the counts and totals an AdaptiveModel holds), once.
const std::vector<float>& Log2Table() {
  static const std::vector<float> table = [] {
    std::vector<float> t(AdaptiveModel::kLimit + AdaptiveModel::kIncrement + 1, 0.0f);
    for (size_t i = 1; i < t.size(); ++i) t[i] = static_cast<float>(std::log2(double(i)));
    return t;
  }();
  return table;
}

}  // namespace

double AdaptiveModel::Cost(uint32_t symbol) const {
  const std::vector<float>& log2 = Log2Table();
  return double(log2[total_]) - double(log2[counts_[symbol]]);
}

ModelPrior ParametricPrior(SymbolKind kind, uint32_t alphabet, uint32_t x) {
  // 1 / (1 - theta) = scale / 8 with scale = (8 + m) 2^e.
  const uint64_t scale = (uint64_t{8} + (x & 7)) << (x >> 3);
  const uint64_t theta = (uint64_t{1} << kQ) - ((uint64_t{1} << (kQ + 3)) / scale);
  std::vector<uint64_t> weight(alphabet, 0);
  for (uint32_t s = 0; s < alphabet; ++s) {
    if (kind == SymbolKind::kIndex || s < kDirectSymbols) {
      // An index s, or the signed value of zigzag s: magnitude ceil(s / 2).
      weight[s] = PowQ(theta, kind == SymbolKind::kIndex ? s : (s + 1) / 2);
    } else {
      // Zigzag values [z0, z0 + 2^(L-2)): magnitudes [z0 / 2, z0 / 2 + 2^(L-3)) on both signs:
      // 2 (theta^a - theta^b) / (1 - theta).
      const uint32_t length = (s - kDirectSymbols) / 2 + 5, second = (s - kDirectSymbols) & 1;
      const uint64_t a = (uint64_t{1} << (length - 2)) + (uint64_t{second} << (length - 3));
      const uint64_t b = a + (uint64_t{1} << (length - 3));
      weight[s] = static_cast<uint64_t>(
          (static_cast<unsigned __int128>(PowQ(theta, a) - PowQ(theta, b)) * scale) >> 2);  // x 2 x scale / 8
    }
  }
  unsigned __int128 sum = 0;
  for (uint64_t w : weight) sum += w;
  ModelPrior prior(alphabet, 1);
  if (sum == 0) return prior;
  for (uint32_t s = 0; s < alphabet; ++s) {
    const uint64_t c = static_cast<uint64_t>((static_cast<unsigned __int128>(weight[s]) << 12) / sum);
    prior[s] = static_cast<uint16_t>(c < 1 ? 1 : c);
  }
  return prior;
}

ModelPrior TablePrior(const StaticModel& model, uint32_t alphabet) {
  ModelPrior prior(alphabet, 1);
  for (uint32_t s = 0; s < alphabet && s < model.alphabet(); ++s) {
    const uint32_t f = model.Frequency(s);
    prior[s] = static_cast<uint16_t>(f < 1 ? 1 : f);
  }
  return prior;
}

const ModelPrior& CachedParametricPrior(SymbolKind kind, uint32_t x) {
  auto all = [](SymbolKind k) {
    std::vector<ModelPrior> t;
    for (uint32_t p = 0; p < kParametricParameters; ++p) t.push_back(ParametricPrior(k, SlotAlphabetOf(k), p));
    return t;
  };
  static const std::vector<ModelPrior> tables[2] = {all(SymbolKind::kIndex), all(SymbolKind::kSigned)};
  return tables[kind == SymbolKind::kIndex ? 0 : 1][x];
}

uint32_t BestParameter(SymbolKind kind, const std::vector<uint64_t>& counts) {
  double best = 1e300;
  uint32_t best_x = 0;
  const std::vector<float>& log2 = Log2Table();
  for (uint32_t x = 0; x < kParametricParameters; ++x) {
    const ModelPrior& p = CachedParametricPrior(kind, x);
    uint32_t total = 0;
    for (uint16_t c : p) total += c;
    double bits = 0;
    for (size_t s = 0; s < counts.size() && s < p.size(); ++s)
      if (counts[s]) bits += double(counts[s]) * (double(log2[total]) - double(log2[p[s]]));
    if (bits < best) {
      best = bits;
      best_x = x;
    }
  }
  return best_x;
}

}  // namespace meshstream

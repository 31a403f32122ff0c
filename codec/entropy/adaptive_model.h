// Adaptive frequency models for the datagram payloads of version 3 (tool
// kToolModelModes; docs/spec/progressive-format.md, section 5.1). A model starts
// from prior counts that the refinement's control block describes, either a
// one-byte member of a parametric family (ParametricPrior) or a static table
// (TablePrior), and adapts to the symbols it codes within one datagram only:
// every datagram starts again from the prior, so each still decodes on its
// own (docs/design/design.md, "Independent datagrams").
//
// Adaptation: a coded symbol's count grows by kIncrement; when the total
// exceeds kLimit every count is halved, rounding up (no count reaches 0,
// so every symbol of the alphabet stays decodable).
//
// Contract: the priors are computed in integers only (the same counts on
// every platform, native or WebAssembly). Decode never returns a symbol
// outside the alphabet, whatever the bytes. No allocation after Reset.
#ifndef MESHSTREAM_CODEC_ENTROPY_ADAPTIVE_MODEL_H_
#define MESHSTREAM_CODEC_ENTROPY_ADAPTIVE_MODEL_H_

#include <array>
#include <cstdint>
#include <vector>

#include "codec/entropy/range_coder.h"
#include "codec/entropy/symbol_model.h"

namespace meshstream {

// Prior counts of a model: one per symbol of its alphabet, each >= 1.
using ModelPrior = std::vector<uint16_t>;

class AdaptiveModel {
 public:
  static constexpr uint32_t kIncrement = 32;
  static constexpr uint32_t kLimit = 1u << 16;

  // `prior`: 1..kMaxAlphabet counts, each >= 1, summing to at most kLimit
  // (ParametricPrior's and TablePrior's do).
  void Reset(const ModelPrior& prior);
  void Encode(RangeEncoder& enc, uint32_t symbol) {
    uint32_t cum = 0;
    for (uint32_t s = 0; s < symbol; ++s) cum += counts_[s];
    enc.EncodeFrequency(cum, counts_[symbol], total_);
    Update(symbol);
  }
  uint32_t Decode(RangeDecoder& dec) {
    const uint32_t target = dec.PeekFrequency(total_);
    uint32_t s = 0, cum = 0;
    while (cum + counts_[s] <= target) cum += counts_[s++];  // target < total: s stays in the alphabet
    dec.Consume(cum, counts_[s]);
    Update(s);
    return s;
  }
  // The cost of `symbol` now, in bits (for the encoder's estimates).
  double Cost(uint32_t symbol) const;
  void Update(uint32_t symbol) {
    counts_[symbol] += kIncrement;
    total_ += kIncrement;
    if (total_ > kLimit) Halve();
  }
  uint32_t alphabet() const { return n_; }
  bool Has(uint32_t symbol) const { return symbol < n_; }

 private:
  void Halve();
  std::array<uint32_t, kMaxAlphabet> counts_{};
  uint32_t n_ = 0;
  uint32_t total_ = 0;
};

// What a slot's symbols are: indices (the cut rank's digits; weight
// theta^s) or signed values (SignedSymbol's alphabet; the weight of a symbol
// is the mass of theta^|v| over the values it stands for).
enum class SymbolKind : uint8_t { kIndex, kSigned };
// The alphabet of a kind in the stream's slots: 16 indices (below the
// maximum valence), kSignedSymbols signed values.
constexpr uint32_t SlotAlphabetOf(SymbolKind kind) { return kind == SymbolKind::kIndex ? 16 : kSignedSymbols; }

// The parametric family: parameter x in [0, kParametricParameters) stands
// for theta = 1 - 8 / ((8 + x mod 8) 2^(x / 8)) (from a spike at 0 to
// nearly flat), counts summing to about 4096 (docs/spec/progressive-format.md,
// section 5.1, gives the integer arithmetic).
constexpr uint32_t kParametricParameters = 160;
ModelPrior ParametricPrior(SymbolKind kind, uint32_t alphabet, uint32_t x);
// ParametricPrior over SlotAlphabetOf(kind), computed once per process.
const ModelPrior& CachedParametricPrior(SymbolKind kind, uint32_t x);
// A static table as a prior: max(1, its frequency) for each of the
// `alphabet` symbols (symbols beyond the table's alphabet: 1).
ModelPrior TablePrior(const StaticModel& model, uint32_t alphabet);
// The parameter whose prior (over SlotAlphabetOf(kind)) codes a histogram
// of that alphabet in the fewest bits (statically; the encoder's choice).
uint32_t BestParameter(SymbolKind kind, const std::vector<uint64_t>& counts);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_ENTROPY_ADAPTIVE_MODEL_H_

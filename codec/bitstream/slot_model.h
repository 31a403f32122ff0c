// The model of one slot (wing, offset, position components, channels) for
// one refinement, and the coder a datagram runs with it. Without the model
// modes tool every slot is static: one table that every datagram of the
// refinement shares. With it (version 3, kToolModelModes;
// docs/spec/progressive-format.md, section 5.1) a slot may instead be adaptive:
// each datagram starts an AdaptiveModel from the slot's prior, so the
// datagrams still decode on their own.
#ifndef MESHSTREAM_CODEC_BITSTREAM_SLOT_MODEL_H_
#define MESHSTREAM_CODEC_BITSTREAM_SLOT_MODEL_H_

#include <cstdint>

#include "codec/bitstream/format.h"
#include "codec/entropy/adaptive_model.h"
#include "codec/entropy/symbol_model.h"

namespace meshstream {

// The mode byte of a slot in a control block with the model modes tool.
enum class ModelMode : uint8_t {
  kReuse = 0,           // the previous refinement's model of this slot, as it was
  kTable = 1,           // a static table follows
  kParametric = 2,      // adaptive from ParametricPrior: one parameter byte follows
  kAdaptiveTable = 3,   // adaptive from a table (TablePrior): the table follows
};
constexpr uint8_t kModelModes = 4;

// What slot k codes: slots 0 and 1 the cut rank's digits (indices below
// the maximum valence), slots 2.. signed values (docs/spec/progressive-format.md,
// section 5). A larger alphabet names nothing.
inline SymbolKind SlotKind(size_t slot) { return slot < 2 ? SymbolKind::kIndex : SymbolKind::kSigned; }
inline uint32_t SlotAlphabet(size_t slot) { return SlotAlphabetOf(SlotKind(slot)); }
static_assert(SlotAlphabetOf(SymbolKind::kIndex) == kWingAlphabet);

struct SlotModel {
  bool adaptive = false;
  // Static: the model. The writer also keeps, for an adaptive slot, the
  // table of its symbols' counts (for its estimates).
  StaticModel table;
  ModelPrior prior;  // adaptive: where each datagram starts
};

// One datagram's coder of one slot. Reset before each datagram.
class SlotCoder {
 public:
  void Reset(const SlotModel& model) {
    model_ = &model;
    if (model.adaptive) adaptive_.Reset(model.prior);
  }
  void Encode(RangeEncoder& enc, uint32_t symbol) {
    if (model_->adaptive) adaptive_.Encode(enc, symbol);
    else model_->table.Encode(enc, symbol);
  }
  uint32_t Decode(RangeDecoder& dec) { return model_->adaptive ? adaptive_.Decode(dec) : model_->table.Decode(dec); }

 private:
  const SlotModel* model_ = nullptr;
  AdaptiveModel adaptive_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_BITSTREAM_SLOT_MODEL_H_

// The split data of a refinement in the reliable profile (format version 4,
// profile 1; docs/spec/progressive-format.md, "Version 4", "Reliable payload"):
// after the split bits and the predictor record, the rest of the control
// block is one range-coded payload with every split's structure and
// geometry in split order, coded with one adaptive model per slot (the
// slots of section 5: the two cut-rank digits, the three position
// components, the channels) that adapts over the whole stream: the reliable
// channel is ordered and loses nothing, so no model is sent and none starts
// again. A seam pair's primary carries both sides (its and its twin's wing
// as raw bits, the shared vector, then each side's channels), as in a
// datagram of the loss-tolerant profile.
//
// Contract: the encoder and the decoder are mirrored; the decoder is safe on
// hostile bytes (fails on overrun, on a payload that does not end with its
// last symbol, and on a wing that does not fit its slot) and changes the
// models only when the whole payload is valid. Thread safety: one per stream.
#ifndef MESHSTREAM_CODEC_BITSTREAM_RELIABLE_PAYLOAD_H_
#define MESHSTREAM_CODEC_BITSTREAM_RELIABLE_PAYLOAD_H_

#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "codec/entropy/adaptive_model.h"
#include "codec/progressive/refinement.h"

namespace meshstream {

// Every slot's model starts from ParametricPrior(kind, this) (section 5.1).
constexpr uint32_t kReliablePriorParameter = 64;

class ReliablePayload {
 public:
  // 5 + channels slots, each from its prior.
  void Reset(int channels);
  // The payload of refinement `r` (wings in coded form: the rank digits, or
  // a seam's ring position), `partner` per split its seam twin's split or
  // kNoTwin (empty: no seams). Advances the models. InvalidArgument when a
  // wing does not fit its slot.
  StatusOr<std::vector<uint8_t>> Encode(const Refinement& r, const std::vector<uint32_t>& partner);
  // Fills the wings and deltas of `r` (its split vertices set, its arrays
  // sized) from `data`; the models advance only on success.
  Status Decode(const uint8_t* data, size_t size, const std::vector<uint32_t>& partner, Refinement* r);

 private:
  int channels_ = 0;
  std::vector<AdaptiveModel> models_;
  std::vector<AdaptiveModel> scratch_;  // Decode's copy until it succeeds
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_BITSTREAM_RELIABLE_PAYLOAD_H_

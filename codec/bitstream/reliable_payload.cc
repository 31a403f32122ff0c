#include "codec/bitstream/reliable_payload.h"

#include <string>

#include "codec/bitstream/slot_model.h"
#include "codec/entropy/range_coder.h"
#include "codec/progressive/seam_twins.h"

namespace meshstream {

void ReliablePayload::Reset(int channels) {
  channels_ = channels;
  models_.assign(5 + static_cast<size_t>(channels), AdaptiveModel());
  for (size_t k = 0; k < models_.size(); ++k) {
    models_[k].Reset(CachedParametricPrior(SlotKind(k), kReliablePriorParameter));
  }
}

StatusOr<std::vector<uint8_t>> ReliablePayload::Encode(const Refinement& r, const std::vector<uint32_t>& partner) {
  RangeEncoder enc;
  const size_t ch = static_cast<size_t>(channels_);
  for (size_t j = 0; j < r.split_count(); ++j) {
    const uint32_t t = partner.empty() ? kNoTwin : partner[j];
    if (t != kNoTwin && t < j) continue;  // a secondary travels with its primary
    if (t != kNoTwin) {
      const uint32_t own = r.wings[j][0], twin = r.wings[t][0];
      if (own >= kMaxSeamValence || twin >= kMaxSeamValence) {
        return InvalidArgument("split " + std::to_string(j) + ": a seam wing beyond " +
                               std::to_string(kMaxSeamValence) + " neighbours");
      }
      enc.EncodeRaw(own, kSeamWingBits);
      enc.EncodeRaw(twin, kSeamWingBits);
    } else {
      for (int k = 0; k < 2; ++k) {
        if (r.wings[j][k] >= models_[k].alphabet()) {
          return InvalidArgument("split " + std::to_string(j) + ": wing symbol " + std::to_string(r.wings[j][k]) +
                                 " does not fit its slot");
        }
        models_[k].Encode(enc, r.wings[j][k]);
      }
    }
    for (int c = 0; c < 3; ++c) EncodeSigned(enc, models_[2 + c], r.position_delta[j][c]);
    for (size_t c = 0; c < ch; ++c) EncodeSigned(enc, models_[5 + c], r.attribute_delta[j * ch + c]);
    if (t != kNoTwin) {
      for (size_t c = 0; c < ch; ++c) EncodeSigned(enc, models_[5 + c], r.attribute_delta[size_t(t) * ch + c]);
    }
  }
  return enc.Finish();
}

Status ReliablePayload::Decode(const uint8_t* data, size_t size, const std::vector<uint32_t>& partner,
                               Refinement* r) {
  scratch_ = models_;
  RangeDecoder dec(data, size);
  const size_t ch = static_cast<size_t>(channels_);
  for (size_t j = 0; j < r->split_count(); ++j) {
    const uint32_t t = partner.empty() ? kNoTwin : partner[j];
    if (t != kNoTwin && t < j) continue;
    if (t != kNoTwin) {
      r->wings[j] = {static_cast<uint16_t>(dec.DecodeRaw(kSeamWingBits)), 0};
      r->wings[t] = {static_cast<uint16_t>(dec.DecodeRaw(kSeamWingBits)), 0};
    } else {
      for (int k = 0; k < 2; ++k) r->wings[j][k] = static_cast<uint16_t>(scratch_[k].Decode(dec));
    }
    for (int c = 0; c < 3; ++c) r->position_delta[j][c] = DecodeSigned(dec, scratch_[2 + c]);
    for (size_t c = 0; c < ch; ++c) r->attribute_delta[j * ch + c] = DecodeSigned(dec, scratch_[5 + c]);
    if (t != kNoTwin) {
      r->position_delta[t] = r->position_delta[j];
      for (size_t c = 0; c < ch; ++c) r->attribute_delta[size_t(t) * ch + c] = DecodeSigned(dec, scratch_[5 + c]);
    }
    if (dec.overran()) break;
  }
  if (dec.overran()) return InvalidInput("split data: the payload ends before its last split");
  if (!dec.ended_exactly()) {
    return InvalidInput("split data: the payload's " + std::to_string(size) + " bytes do not end with its last split");
  }
  models_.swap(scratch_);
  return Status::Ok();
}

}  // namespace meshstream

// Prediction of a split's texture coordinate and colour differences from
// the ring (format version 2, tool bit 4; docs/spec/progressive-format.md section
// 4.4): within one UV chart the channels are locally a linear function of
// the position on the surface, so the ring's least-squares linear map from
// the tangent plane to each channel, applied to the split's own decoded
// split vector d = u - v, predicts the channel's difference e = value_w -
// value_n; the residual e - p is coded.
//
// Per split, with w's coarse position m, its ring ring[0..D-1] and the ring's
// local frame (local_frame.h, the geometry's): q_k = the tangential part of
// ring[k] - m, t = the tangential part of d (all scaled by one power of two
// so that every |q_k| component is below 2^15), A = sum q_k q_k^T; per
// channel, with the ring's values x_k and w's coarse value c,
// B = sum (x_k - c) q_k^T and p = round(B adj(A) t / det(A)).
//
// Contract: exact integer arithmetic (64-bit, 128-bit where needed), the
// same on every platform, defined for any int32 inputs: a ring of fewer than
// 3 or more than kMaxPredictedValence vertices, or whose tangential extent is
// degenerate (det(A) <= 0), predicts 0, and every prediction is clamped to
// [-2^30, 2^30] (a bad prediction costs bits, never correctness). O(valence)
// per split and channel, no allocation. Thread safety: none needed.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_TEXCOORD_PREDICTION_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_TEXCOORD_PREDICTION_H_

#include <array>
#include <cstddef>
#include <cstdint>

#include "codec/core/vec.h"
#include "codec/progressive/geometry_prediction.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/refinement_state.h"

namespace meshstream {

// At most 8 texture coordinate sets (2 channels each) and a colour (4).
constexpr int kMaxMappedChannels = 20;

// The ring's linear map from the tangent plane to the channels, applied to
// one split vector.
class RingChannelMap {
 public:
  // The geometric part, once per split: w's coarse position m, the split
  // vector d = u - v, the ring's positions and the ring's local frame
  // (RingLocalFrame(m, ring, degree)).
  void Reset(const Vec3i& m, const Vec3i& d, const Vec3i* ring, size_t degree, const LocalFrame& frame);
  // The predicted difference of one channel: the ring's values are
  // values[ids[k] * stride] (k = 0..degree-1), w's coarse value `coarse`.
  int32_t Predict(const int32_t* values, size_t stride, const uint32_t* ids, int32_t coarse) const;

 private:
  size_t degree_ = 0;  // 0: predicts 0
  std::array<std::array<int32_t, 2>, kMaxPredictedValence> q_;  // [0, degree_) set by Reset (no zeroing per split)
  int64_t h_[2] = {0, 0};  // adj(A) t
  __int128 det_ = 0;       // det(A) > 0
};

// The predicted differences of the channels [first, first + count) (count
// at most kMaxMappedChannels) of the split of w into (w, n), right after it
// was applied (so m and d are derived from w's and n's positions, the coarse
// values from w's and n's channels by the midpoint transform); `ring` and
// `ring_positions` are w's ring as it was split, `frame` its local frame.
void PredictChannelDeltas(const RefinementState& state, const uint32_t* ring, const Vec3i* ring_positions,
                          size_t degree, const LocalFrame& frame, uint32_t w, uint32_t n, int first, int count,
                          int32_t* out);
// The same before the split is applied (a refinement's splits planned in
// parallel, parallel_refinement.h): `attributes` the state's channels
// (`stride` per vertex), u and v the positions w and n will have, coarse[c]
// the coarse value of channel first + c (the midpoint of the values w and n
// will have).
void PredictChannelDeltas(const int32_t* attributes, size_t stride, const uint32_t* ring, const Vec3i* ring_positions,
                          size_t degree, const LocalFrame& frame, const Vec3i& u, const Vec3i& v, const int32_t* coarse,
                          int first, int count, int32_t* out);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_TEXCOORD_PREDICTION_H_

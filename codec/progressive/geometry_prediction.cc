#include "codec/progressive/geometry_prediction.h"

#include <algorithm>

#include "codec/progressive/coding_tools.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/refinement_state.h"

namespace meshstream {

SplitPrediction PredictSplit(const Vec3i* ring, size_t d, size_t a_at, size_t b_at) {
  SplitPrediction p;
  if (d < 2 || d > kMaxPredictedValence || a_at >= d || b_at >= d || a_at == b_at) return p;
  const size_t path = (a_at + d - b_at) % d;  // ring[b..a] has path + 1 vertices
  const int64_t kn = static_cast<int64_t>(path) + 1;
  const int64_t kw = static_cast<int64_t>(d - path) + 1;
  // The two sides share the wings: ring[b..a] and ring[a..b], cyclically
  // (the index wraps by a compare, not a division).
  int64_t sn[3] = {0, 0, 0}, sw[3] = {0, 0, 0};
  for (size_t s = 0, k = b_at; s <= path; ++s, k = k + 1 == d ? 0 : k + 1) {
    for (int c = 0; c < 3; ++c) sn[c] += ring[k][c];
  }
  for (size_t s = 0, k = a_at; s <= d - path; ++s, k = k + 1 == d ? 0 : k + 1) {
    for (int c = 0; c < 3; ++c) sw[c] += ring[k][c];
  }
  for (int c = 0; c < 3; ++c) p.numerator[c] = sw[c] * kn - sn[c] * kw;
  p.denominator = (kw + 1) * (kn + 1) - 1;
  return p;
}

Vec3i ScalePrediction(const SplitPrediction& p, uint32_t alpha) {
  Vec3i out{};
  const int64_t den = p.denominator * int64_t{kAlphaOne};
  for (int c = 0; c < 3; ++c) {
    const int64_t num = p.numerator[c] * int64_t{alpha};
    const int64_t mag = ((num < 0 ? -num : num) + den / 2) / den;  // halves away from zero (den is even)
    const int64_t v = num < 0 ? -mag : mag;
    out[c] = static_cast<int32_t>(std::clamp<int64_t>(v, INT32_MIN, INT32_MAX));
  }
  return out;
}

namespace {

int32_t Clamp32(int64_t v) { return static_cast<int32_t>(std::clamp<int64_t>(v, INT32_MIN, INT32_MAX)); }

// The prediction the coded residual is relative to (0 without the tool),
// kept within +-2^30 so that residual = delta - prediction fits int32 for
// every delta of a grid of at most 30 bits.
Vec3i Prediction(const SplitCoding& coding, const Vec3i* ring, size_t degree, size_t a_at, size_t b_at) {
  if ((coding.tools & kToolGeometryPrediction) == 0) return Vec3i{0, 0, 0};
  Vec3i p = ScalePrediction(PredictSplit(ring, degree, a_at, b_at), coding.alpha);
  for (int c = 0; c < 3; ++c) p[c] = std::clamp<int32_t>(p[c], -(1 << 30), 1 << 30);
  return p;
}

}  // namespace

void RingGeometry(const RefinementState& state, uint32_t w, const uint32_t* ring, size_t degree, ToolSet tools,
                  std::vector<Vec3i>* positions, LocalFrame* frame) {
  positions->resize(degree);
  for (size_t k = 0; k < degree; ++k) (*positions)[k] = state.positions[ring[k]];
  if (tools & kFrameTools) *frame = RingLocalFrame(state.positions[w], positions->data(), degree);
}

LocalFrame RingLocalFrame(const Vec3i& w, const Vec3i* ring, size_t degree) {
  return LocalFrame::FromScaledNormal(ScaledFanNormal(w, ring, degree, 20));
}

Vec3i DecodeSplitVector(const SplitCoding& coding, const Vec3i& coded, const Vec3i* ring, size_t degree, size_t a_at,
                        size_t b_at, const LocalFrame& frame, const Umbrella* umbrellas) {
  if (coding.tools & kToolRingPredictor) {
    // Predicted in the frame: the coded residual is Forward(u - v) minus it.
    return VectorFromResidual(coding.predictor, SplitFeatures(ring, umbrellas, degree, a_at, b_at), frame, coded);
  }
  const Vec3i residual = (coding.tools & kToolLocalFrame) ? frame.Inverse(coded) : coded;
  const Vec3i p = Prediction(coding, ring, degree, a_at, b_at);
  Vec3i out;
  for (int c = 0; c < 3; ++c) out[c] = Clamp32(int64_t{residual[c]} + p[c]);
  return out;
}

Vec3i CodeSplitVector(const SplitCoding& coding, const Vec3i& delta, const Vec3i* ring, size_t degree, size_t a_at,
                      size_t b_at, const LocalFrame& frame, const Umbrella* umbrellas) {
  if (coding.tools & kToolRingPredictor) {
    return ResidualInFrame(coding.predictor, SplitFeatures(ring, umbrellas, degree, a_at, b_at), frame, delta);
  }
  const Vec3i p = Prediction(coding, ring, degree, a_at, b_at);
  Vec3i residual;
  for (int c = 0; c < 3; ++c) residual[c] = Clamp32(int64_t{delta[c]} - p[c]);
  if ((coding.tools & kToolLocalFrame) == 0) return residual;
  return frame.Forward(residual);
}

}  // namespace meshstream

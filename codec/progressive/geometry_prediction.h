// Prediction of a split's geometry from the coarser mesh (format version 2,
// docs/spec/progressive-format.md section 4, "Geometry prediction"): the split
// vector d = u - v is predicted from the positions of w's ring on the two
// sides of the cut, and the residual is coded in the ring's local frame
// (local_frame.h: two tangential components and a normal one).
//
// Predictor (the Laplacian one, solved in closed form): after the split, w
// (at u) has the neighbours ring[a..b] and v, the new vertex (at v) has
// ring[b..a] and u (both sides inclusive of the wings). Asking that each sit
// at the centroid of its neighbours gives
//   d' = (S_w k_n - S_n k_w) / ((k_w + 1)(k_n + 1) - 1),
// with S the sums and k the counts of the two sides. The coded prediction is
// round(alpha d' / 32) with the refinement's alpha (0..255, on the reliable
// channel), chosen by the encoder.
//
// Contract: pure integer arithmetic (exact on every platform; no floating
// point), defined for any int32 positions and any valence (a ring larger than
// kMaxPredictedValence predicts 0). Thread safety: none needed.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_GEOMETRY_PREDICTION_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_GEOMETRY_PREDICTION_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/vec.h"
#include "codec/progressive/coding_tools.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/ring_predictor.h"

namespace meshstream {

constexpr size_t kMaxPredictedValence = 64;
constexpr uint32_t kAlphaOne = 32;  // alpha / kAlphaOne scales the prediction

// The unscaled Laplacian prediction of u - v as a numerator per axis over a
// common positive denominator (exact).
struct SplitPrediction {
  std::array<int64_t, 3> numerator{};
  int64_t denominator = 1;
};
SplitPrediction PredictSplit(const Vec3i* ring, size_t degree, size_t a_at, size_t b_at);

// round(alpha numerator / (32 denominator)) per axis, halves away from
// zero, clamped to int32.
Vec3i ScalePrediction(const SplitPrediction& p, uint32_t alpha);

// How the splits of one refinement are coded: the stream's tools
// (bitstream/format.h, StreamTool) and the refinement's alpha.
struct SplitCoding {
  ToolSet tools = 0;   // 0: version 1 (the split vector is sent as it is)
  uint32_t alpha = 0;  // with kToolGeometryPrediction (and not kToolRingPredictor)
  PredictorWeights predictor = kInitialPredictor;  // with kToolRingPredictor
  int normal_bits = 0; // qn when the normals are predicted (kToolAttributePrediction and normals), else 0
  // The channels the ring's map predicts (kToolTexcoordPrediction: the
  // texture coordinates and colours, texcoord_prediction.h): [mapped_first,
  // mapped_first + mapped_count); none without the tool.
  int mapped_first = 0, mapped_count = 0;
};

// The local frame of w's ring: LocalFrame::FromNormal(FanNormal(...)).
LocalFrame RingLocalFrame(const Vec3i& w, const Vec3i* ring, size_t degree);

// The tools whose decode reads the ring's local frame.
constexpr ToolSet kFrameTools = kToolLocalFrame | kToolWingRank | kToolTexcoordPrediction;
// The positions of w's ring (ring[k] -> (*positions)[k]) and, under a tool of
// kFrameTools, their local frame into *frame: once per split, for the wings,
// the split vector and the channels.
void RingGeometry(const RefinementState& state, uint32_t w, const uint32_t* ring, size_t degree, ToolSet tools,
                  std::vector<Vec3i>* positions, LocalFrame* frame);

// Does split vector coding under `coding` read the 2-ring (RingUmbrellas)?
inline bool ReadsUmbrellas(const SplitCoding& coding) {
  return (coding.tools & kToolRingPredictor) != 0 && coding.predictor.reads_ring();
}

// The split vector u - v from its coded components, given its ring, the
// wings' ring positions and the ring's local frame (RingLocalFrame, used
// with the local-frame tool), and with the ring predictor the ring's
// umbrellas (RingUmbrellas; may be null when ReadsUmbrellas is false); and
// the inverse, for the encoder. Exact inverses of each other for any inputs
// whose vector is below 2^28 (the decoder clamps a hostile sum to int32).
Vec3i DecodeSplitVector(const SplitCoding& coding, const Vec3i& coded, const Vec3i* ring, size_t degree, size_t a_at,
                        size_t b_at, const LocalFrame& frame, const Umbrella* umbrellas = nullptr);
Vec3i CodeSplitVector(const SplitCoding& coding, const Vec3i& delta, const Vec3i* ring, size_t degree, size_t a_at,
                      size_t b_at, const LocalFrame& frame, const Umbrella* umbrellas = nullptr);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_GEOMETRY_PREDICTION_H_

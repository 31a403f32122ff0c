// The ring predictor of format version 3 (tool bit 8, docs/spec/progressive-format.md
// section 4.7): a split vector predicted in the ring's local frame as a
// weighted sum of three features of the coarser mesh, with one set of weights
// for the two tangential components and one for the normal one:
//   lap    the Laplacian prediction of geometry_prediction.h (its d');
//   sides  the centroid of w's side of the cut, ring[a..b], minus that of the
//          new vertex's side, ring[b..a] (both inclusive of the wings);
//   ring   the same difference of the sides' mean umbrella vectors, where a
//          ring vertex x's umbrella is the sum of p_x - p_y over the vertices
//          y that follow x in its faces and are stable: older than the
//          refinement and not split by it (the 2-ring term).
// Only stable vertices enter, so no split of a refinement reads what another
// writes: the prediction is the same whatever order the splits are applied
// in (the property docs/design/design.md's batches rest on), except where a ring
// vertex's triangle count crosses kMaxUmbrellaFaces during the refinement
// (a split adds a triangle to each of its wings; the count is taken when the
// split is applied): the parallel decode checks that (RefinementPlan::Holds).
//
// The weights are chosen by the encoder per refinement (ring_predictor_fit.h)
// and sent on the reliable channel, in units of 2^-8; a refinement may reuse
// the previous one's.
//
// Contract: pure integer arithmetic (the same result on every platform and in
// WebAssembly), defined for any int32 positions, any valence and any weights
// within kMaxPredictorWeight; safe on a hostile mesh (a ring vertex with more
// than kMaxUmbrellaFaces faces contributes nothing). Thread safety: none
// needed.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_RING_PREDICTOR_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_RING_PREDICTOR_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/vec.h"
#include "codec/progressive/local_frame.h"

namespace meshstream {

struct RefinementState;

enum PredictorFeature { kFeatureLaplacian = 0, kFeatureSides = 1, kFeatureRing = 2, kPredictorFeatures = 3 };

constexpr int kPredictorWeightBits = 8;            // a weight of 256 is 1.0
constexpr int32_t kMaxPredictorWeight = 1 << 15;   // |weight| <= 2^15 (128.0)
constexpr int kFeatureFractionBits = 4;            // features are in 1/16 grid steps
constexpr size_t kMaxUmbrellaFaces = 64;

// The weights of one refinement: per feature, tangential and normal.
struct PredictorWeights {
  std::array<int32_t, kPredictorFeatures> tangential{};
  std::array<int32_t, kPredictorFeatures> normal{};
  bool operator==(const PredictorWeights& o) const { return tangential == o.tangential && normal == o.normal; }
  // Does the prediction read the 2-ring (the umbrellas)?
  bool reads_ring() const { return tangential[kFeatureRing] != 0 || normal[kFeatureRing] != 0; }
};

// Before any refinement sends its own: the Laplacian prediction as it is.
constexpr PredictorWeights kInitialPredictor{{256, 0, 0}, {256, 0, 0}};

// The umbrella of each of w's ring vertices (ring[k] -> out[k]), with only
// the state's stable vertices as neighbours (RefinementState::BeginSplits).
// With `flags` (not null), the OR of the VertexFlag bits of every vertex
// read is added to *flags.
using Umbrella = std::array<int64_t, 3>;
void RingUmbrellas(const RefinementState& state, const uint32_t* ring, size_t degree, std::vector<Umbrella>* out,
                   uint8_t* flags = nullptr);

// The three features of a split in world axes, in 1/16 grid steps (each
// component clamped to +-2^30). `umbrellas` may be null when the weights do
// not read the ring (the ring feature is then 0).
using PredictorFeatures = std::array<Vec3i, kPredictorFeatures>;
PredictorFeatures SplitFeatures(const Vec3i* ring, const Umbrella* umbrellas, size_t degree, size_t a_at, size_t b_at);

// The prediction of Forward(u - v) (local frame, grid steps): the tangential
// weights' sum rotated for components 0 and 1, the normal weights' for 2.
Vec3i PredictInFrame(const PredictorWeights& weights, const PredictorFeatures& features, const LocalFrame& frame);

// The coded residual of split vector `delta`, Forward(delta) minus the
// prediction (clamped to int32), and back: exact inverses for vectors below
// 2^28 (local_frame.h).
Vec3i ResidualInFrame(const PredictorWeights& weights, const PredictorFeatures& features, const LocalFrame& frame,
                      const Vec3i& delta);
Vec3i VectorFromResidual(const PredictorWeights& weights, const PredictorFeatures& features, const LocalFrame& frame,
                         const Vec3i& coded);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_RING_PREDICTOR_H_

// The encoder's choice of a refinement's ring predictor weights
// (ring_predictor.h): a fit of the features to the split vectors in the
// local frame, about least absolute deviations (iteratively reweighted least
// squares), the tangential components and the normal one separately, the
// weights rounded to the format's 2^-8 units. Which weights a refinement
// finally sends (these, the previous refinement's, or these without the ring
// term) is priced by the writer (bitstream/writer.cc).
//
// Contract: any samples (none, degenerate or collinear features give zero
// weights for what cannot be fitted); deterministic on one platform (the
// fit is in floating point, but only the encoder runs it: the weights it
// sends are what the decoder uses). Thread safety: none needed.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_RING_PREDICTOR_FIT_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_RING_PREDICTOR_FIT_H_

#include <array>
#include <vector>

#include "codec/core/vec.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/ring_predictor.h"

namespace meshstream {

// One split as the fit sees it: its features rotated into its local frame
// (grid steps) and the split vector there, Forward(u - v).
struct PredictorSample {
  std::array<Vec3d, kPredictorFeatures> features{};
  Vec3i target{};
};
PredictorSample SampleOf(const PredictorFeatures& features, const LocalFrame& frame, const Vec3i& delta);

// The weights fitted over the first `features` features (1: the Laplacian
// alone, 2: and the sides, 3: and the ring); the others' weights are 0.
PredictorWeights FitPredictorWeights(const std::vector<PredictorSample>& samples, int features);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_RING_PREDICTOR_FIT_H_

// Prediction of a split's normals from its decoded geometry (format version
// 2, tool bit 3; docs/spec/progressive-format.md section 4.3): once a split's
// positions and triangles are in place, the normals of w and of the new
// vertex are predicted as the octahedral codes (at qn bits) of their
// area-weighted vertex normals, and the normal channels' difference
// e = n_w - n_new is coded relative to the difference of those codes.
//
// Contract: exact integer arithmetic (128-bit where needed), the same on
// every platform; a vertex without area gets the normal (0, 0, 1).
// O(valence). Thread safety: none.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_NORMAL_PREDICTION_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_NORMAL_PREDICTION_H_

#include <array>
#include <cstdint>

#include "codec/progressive/local_frame.h"
#include "codec/progressive/refinement_state.h"

namespace meshstream {

// Sum over v's triangles (p0, p1, p2) of (p1 - p0) x (p2 - p0).
WideVec3 VertexNormal(const RefinementState& state, uint32_t v);

// The octahedral code (s, t) of a direction at `bits` per component
// (docs/spec/progressive-format.md section 3, "Octahedral normals", in integers).
std::array<int32_t, 2> OctahedralCode(const WideVec3& n, int bits);

// The predicted difference of the normal codes of w and the new vertex n,
// right after the split of w into (w, n).
std::array<int32_t, 2> PredictNormalDelta(const RefinementState& state, uint32_t w, uint32_t n, int bits);

// With normal prediction (bits > 0; nothing otherwise): split j of w into
// (w, n), just applied with its coded residuals as the normal channels'
// difference, gets the predicted difference added (channels 0 and 1); the
// differences applied are written to split j of `decoded` (when not null).
void AddPredictedNormals(int bits, size_t j, uint32_t w, uint32_t n, RefinementState& state, Refinement* decoded);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_NORMAL_PREDICTION_H_

// How far each level of a progressive mesh may still be from its finest
// level: the estimate a scene's levels are scheduled by
// (progressive/scene_levels.h). Per level k (0: the base,
// refinements.size(): the finest) the largest distance off the surface that a
// split not yet applied will correct: for a split of w that makes the new
// vertex n, half the component of its split vector along the finest mesh's
// normal at w and n (their area-weighted normals, normal_prediction.h's
// VertexNormal, added).
// A split along the surface (an edge of a flat region, along a straight
// crease) changes the shape little however long its vector; one across a
// curve or a crease changes it by about that component. Where the normal is
// not defined (no area around both vertices), the whole vector counts. In
// the position grid's units; nested splits can add up, so this is an
// estimate, not a bound: the same estimate for every primitive, which is
// what an order across primitives needs.
//
// Contract: pure, O(splits x valence); `finest` is the finest mesh in
// canonical ids (the encoder's replay state); ids out of its range count as
// having no normal. The result has
// refinements.size() + 1 entries, never increases, and ends with 0.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_RESIDUAL_ERROR_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_RESIDUAL_ERROR_H_

#include <vector>

#include "codec/progressive/refinement.h"
#include "codec/progressive/refinement_state.h"

namespace meshstream {

std::vector<double> ResidualErrors(const ProgressiveMesh& mesh, const RefinementState& finest);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_RESIDUAL_ERROR_H_

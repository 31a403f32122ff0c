// Keeping predicted vertices off collinear triangles. Values that a
// prediction made (or exact values next to predicted ones) can line three
// vertices of a triangle up on the integer grid; these functions find such
// triangles and nudge a vertex by a grid step or three until none is left.
//
// Contract: pure functions of the state; O(valence) per call (27 * 3 trial
// positions at most). Thread safety: none.
#ifndef MESHSTREAM_CODEC_RECOVERY_DEGENERATE_FACES_H_
#define MESHSTREAM_CODEC_RECOVERY_DEGENERATE_FACES_H_

#include <cstdint>

#include "codec/core/vec.h"
#include "codec/progressive/refinement_state.h"

namespace meshstream {

// Twice the area vector of (a, b, c) on the integer grid is zero.
bool Collinear(const Vec3i& a, const Vec3i& b, const Vec3i& c);

// How many triangles of v are collinear on the grid.
int DegenerateFaces(const RefinementState& state, uint32_t v);

// After a split of w into w and n: moves n (else w) by a grid step or three
// when a triangle of theirs is collinear; true when something was degenerate
// (and so moved, or tried to).
bool AvoidDegenerateFaces(RefinementState* state, uint32_t w, uint32_t n);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_RECOVERY_DEGENERATE_FACES_H_

// Bit-exact comparison of two triangle primitives on one position grid: the
// check behind "lossless when nothing is lost" (docs/design/design.md, "Lossless") and
// `meshstream compare --qp`.
//
// Both primitives are quantized on A's grid, PositionGrid(a.positions,
// a.indices, qp) (codec/mesh/quantization.h; docs/design/design.md, "The position grid"). A face
// becomes the triple of the integer positions of its three corners. Two faces
// are equal when one triple is a cyclic rotation of the other: (p, q, r),
// (q, r, p) and (r, p, q) are the same oriented triangle, (p, r, q) (reversed
// winding) is not. The primitives are equal on the grid iff their multisets of
// oriented triangles are equal. Only faces count: vertex order, vertex
// duplication and unreferenced vertices do not matter, degenerate faces count
// like any other face (two copies of a face are two triangles).
//
// Contract: both inputs must pass ValidatePrimitive (kInvalidInput naming the
// side); qp must be in [1, 30] (kInvalidArgument); A must have a position to
// build the grid from (kInvalidInput; like PositionGrid, a primitive without
// faces gets the grid of all its vertices, and two face-less primitives are
// equal). A referenced position of B farther than
// 2^52 steps from A's grid origin is kInvalidInput (it cannot match anyway).
// Complexity: O(F log F) time, O(F) memory.
// Thread safety: pure functions; safe to call concurrently.
#ifndef MESHSTREAM_CODEC_METRICS_GRID_EQUALITY_H_
#define MESHSTREAM_CODEC_METRICS_GRID_EQUALITY_H_

#include <cstdint>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"

namespace meshstream {

struct GridComparison {
  bool equal = false;
  uint64_t faces_a = 0;
  uint64_t faces_b = 0;
  uint64_t only_in_a = 0;  // triangles of A left over after matching with B
  uint64_t only_in_b = 0;  // triangles of B left over after matching with A
  // only_in_a + only_in_b: how many triangles differ (0 iff equal).
  uint64_t differing() const { return only_in_a + only_in_b; }
};

StatusOr<GridComparison> CompareOnGrid(const Primitive& a, const Primitive& b, int qp);

// CompareOnGrid(...).equal.
StatusOr<bool> SameOnGrid(const Primitive& a, const Primitive& b, int qp);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_METRICS_GRID_EQUALITY_H_

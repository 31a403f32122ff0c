// The paper's visual distortion (section 5.1, Eq. 4-5) between two triangle
// primitives M (a) and M' (b) whose vertices correspond one to one:
//
//   ||M - M'|| = 1/(2n) * ( sum_i ||v_i - v'_i|| + sum_i ||GL(v_i) - GL(v'_i)|| )
//   GL(v_i)    = v_i - (sum_{j in N(i)} v_j / l_ij) / (sum_{j in N(i)} 1 / l_ij)
//
// Choices where the paper is silent:
// - ||.|| of a vertex set is the SUM over vertices of the per-vertex
//   Euclidean norms (not the norm of the stacked 3n-vector).
// - Only referenced vertices count (a vertex is referenced when some face
//   uses it); n is their number. The i-th referenced vertex of A (in vertex
//   index order) corresponds to the i-th referenced vertex of B.
// - N(i) is the set of distinct vertices that share an edge of some face with
//   vertex i, in that primitive's own connectivity (A's for GL(v), B's for
//   GL(v')); l_ij is the Euclidean length of the edge in that primitive.
// - A neighbour at distance 0 (zero-length edge, coincident vertices) has
//   no finite weight and is skipped. A vertex with no neighbour left
//   (isolated, or only zero-length edges) has GL = 0.
// Computed in double precision from the float positions.
//
// Contract: both inputs must pass ValidatePrimitive (kInvalidInput naming the
// side); kInvalidInput when A has no referenced vertex; kInvalidArgument when
// the numbers of referenced vertices differ (the metric is then undefined,
// callers report it as missing).
// Complexity: O(F log F) time, O(V + F) memory.
// Thread safety: pure function; safe to call concurrently.
#ifndef MESHSTREAM_CODEC_METRICS_LAPLACIAN_H_
#define MESHSTREAM_CODEC_METRICS_LAPLACIAN_H_

#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"

namespace meshstream {

StatusOr<double> LaplacianDistortion(const Primitive& a, const Primitive& b);

// GL(v) of Eq. 5 for every vertex of `p` (unreferenced vertices get 0), as
// used above; exposed for tests and diagnostics. `p` must be valid.
std::vector<Vec3d> GeometricLaplacian(const Primitive& p);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_METRICS_LAPLACIAN_H_

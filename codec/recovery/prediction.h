// Prediction of a vertex split whose data was lost (paper, section 4.4;
// docs/design/loss-tolerance.md). Everything works on one split vertex w and its
// one-ring, in the least-squares plane of the ring: O(valence) per split, no
// global pass.
//
// - Case 2 (structure and geometry lost): PredictWings finds the ring edge
//   farthest from w in the plane, puts the new vertex at the centroid of the
//   triangle it forms with w, and runs Delaunay edge flips that keep w and
//   the new vertex adjacent (the result is again a vertex split, so later
//   splits still refer to rings); PredictGeometry then places both vertices.
// - Case 3 (structure lost, geometry arrived): WingsFromGeometry chooses the
//   wings that best separate the ring vertices nearer the new vertex from
//   those nearer w.
// - Case 4 (geometry lost): PredictGeometry alone, on the coded wings.
//
// Contract: pure functions of their arguments; never fail (degenerate rings
// fall back to any plane); results are ring positions in [0, ring size).
// Thread safety: none needed.
#ifndef MESHSTREAM_CODEC_RECOVERY_PREDICTION_H_
#define MESHSTREAM_CODEC_RECOVERY_PREDICTION_H_

#include <array>
#include <cstdint>
#include <vector>

#include "codec/core/vec.h"
#include "codec/recovery/ring_frame.h"

namespace meshstream {

struct PredictedWings {
  size_t a_at = 0, b_at = 0;  // ring positions of the wings (SplitConnectivity::SplitAt)
  Vec2d new_uv{};             // where the new vertex sits in the plane
};

// Case 2: steps 2-5 of the paper.
PredictedWings PredictWings(const RingFrame& frame);

// Case 3: u is w's position after the split, v the new vertex's.
PredictedWings WingsFromGeometry(const RingFrame& frame, const Vec3i& u, const Vec3i& v);

// The plane position of the new vertex for the coded wings of case 4: midway
// between w and the mean of the ring vertices it will be joined to.
Vec2d NewVertexUv(const RingFrame& frame, size_t a_at, size_t b_at);

struct PredictedGeometry {
  Vec3i u{}, v{};                   // w's and the new vertex's positions
  std::vector<int32_t> u_channels;  // their attribute channels
  std::vector<int32_t> v_channels;
  std::vector<double> scratch;      // reused between calls
};

// Step 6 of the paper (inverse-distance weights in the plane, Eq. 1-2): the
// new vertex from its neighbours (ring[b..a] and w), then w from its
// neighbours (ring[a..b] and the new vertex); channels with the same
// weights. Then both are shifted together so that their midpoint is w's
// coarse position (which the coarse vertex holds exactly), and clamped to
// the range of the values they were made from. `channels` holds w's
// channels then the ring's, `count` per vertex.
// `spread` scales the pair's offset from the coarse vertex: 1 is the paper's
// step 6; case 2, which knows nothing of the split, uses kCase2Spread.
void PredictGeometry(const RingFrame& frame, size_t a_at, size_t b_at, const Vec2d& new_uv,
                     const std::vector<int32_t>& channels, int count, PredictedGeometry* out, double spread = 1.0);

// With structure and geometry both lost, a pair close to the coarse vertex
// keeps the surface near the coarse one: measured on the bunny at 12 % loss
// with bundled packing, 8 of 8 seeds closer to the lossless decode than LwoP
// against 4 of 8 at the paper's full spread (docs/design/loss-tolerance.md).
constexpr double kCase2Spread = 0.25;

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_RECOVERY_PREDICTION_H_

// w's one-ring in its least-squares plane: the parametric plane in which
// every prediction of a split works (paper, section 4.4, step 1;
// docs/design/loss-tolerance.md).
//
// Contract: pure; never fails (a degenerate ring falls back to the fan's
// plane, then to any plane); reuses the storage of `out`, so fitting a ring
// allocates nothing once the vectors have grown. Thread safety: none needed.
#ifndef MESHSTREAM_CODEC_RECOVERY_RING_FRAME_H_
#define MESHSTREAM_CODEC_RECOVERY_RING_FRAME_H_

#include <cstddef>
#include <vector>

#include "codec/core/vec.h"

namespace meshstream {

// w's one-ring in its least-squares plane (the parametric plane).
struct RingFrame {
  Vec3d w{};                    // w's position
  std::vector<Vec3d> ring;      // ring positions, in ring order
  Vec2d w_uv{};                 // projections onto the plane
  std::vector<Vec2d> ring_uv;
  Vec3d origin{}, axis_u{}, axis_v{}, normal{};
  Vec2d Project(const Vec3d& p) const;
  // Scratch reused between calls (no allocation per split).
  mutable std::vector<double> work;
  mutable std::vector<size_t> window;
};

// Fits the plane through w and its ring (the eigenvector of the smallest
// eigenvalue of their covariance, in closed form, oriented like the fan's
// normal so the ring turns counter-clockwise in the plane).
// Fills `out`, reusing its storage. Without `least_squares` the plane is the
// fan's (area-weighted normal): cheaper, and enough where the plane only
// sorts the ring into sides (case 3).
void FitRingFrame(const Vec3i& w, const std::vector<Vec3i>& ring, RingFrame* out, bool least_squares = true);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_RECOVERY_RING_FRAME_H_

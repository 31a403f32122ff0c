// Cut edges ranked by the ring's crossings (format version 4, tool bit 9;
// docs/spec/progressive-format.md section 4.8): the same candidates and rank
// symbols as wing_rank.h (the D floor(D/2) pairs (x, x + k mod D), 1 <= k <=
// D/2, the rank as two base-16 digits), in an order that costs O(D)
// arithmetic to predict instead of a score of every pair (issue 42: the
// pair scores were 35 % of the decoder's instructions).
//
// The prediction. With q_k the ring in the tangent plane of w's local frame
// (as wing_rank.h: LocalFrame::Tangents, scaled by one shift below 2^12) and
// M = sum of q q^T = [[m00, m01], [m01, m11]], the ring's long axis is
// e = (m00 - m11 + r, 2 m01) with r = floor(sqrt((m00 - m11)^2 + 4 m01^2))
// (the eigenvector of M's larger eigenvalue; (1, 0) when both components
// are 0). The coarse vertex replaced two vertices a split vector apart, so
// the ring is stretched along e and the cut crosses it through w: with
// s_k = q_k . e, a *crossing* is a k whose s_k and s_{k+1 mod D} differ in
// sign (s >= 0 counting as positive), and its vertex is k when |s_k| <=
// |s_{k+1}|, else k + 1. The predicted wings p1, p2 are the vertices of the
// two crossings of smallest |s| at their vertex (ties: the lower k); with
// fewer than two crossings, p1 = 0 and p2 = D / 2.
//
// The order. A pair (x, y) costs min(d(x, p1) + d(y, p2), d(x, p2) +
// d(y, p1)), d being the distance along the ring (the fewer steps either
// way); pairs go by cost, then x, then k. The rank of the true pair is what
// is coded: 0 when both wings are the predicted ones (about 30 % of the
// shared models' splits).
//
// Contract: pure, deterministic on every platform (integers only; the
// square root is IntegerSqrt), O(D) for the prediction and O(D^2) integer
// comparisons without multiplications for the order, no allocation.
// Defined for 3 <= D <= kMaxRankedValence. Thread safety: none.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_CUT_CROSSINGS_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_CUT_CROSSINGS_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/vec.h"
#include "codec/progressive/coding_tools.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/wing_rank.h"

namespace meshstream {

class CutCrossings;

// The ring positions of a split's coded wings on w's ring (w at `w`, the
// ring's positions and local frame given), by the stream's tools: by rank in
// the crossings' order (tool bit 9) or the pair scores' (tool bit 2 alone;
// wing_rank.h), each with its scratch, else by id (WingPositions). False
// when they do not fit the ring.
bool CodedWingPositions(const std::array<uint16_t, 2>& wings, ToolSet tools, const std::vector<uint32_t>& ring,
                        const Vec3i& w, const Vec3i* ring_positions, const LocalFrame& frame, WingRanking* ranking,
                        CutCrossings* crossings, size_t* a_at, size_t* b_at);

class CutCrossings {
 public:
  // Predicts the wings of w's ring in its local frame; false when the
  // degree is outside [3, kMaxRankedValence].
  bool Reset(const Vec3i& w, const Vec3i* ring, size_t degree, const LocalFrame& frame);
  // The rank of wings at ring positions (a_at, b_at); false unless
  // 1 <= (b_at - a_at) mod D <= D/2.
  bool RankOf(size_t a_at, size_t b_at, uint32_t* rank) const;
  // The wings of a rank; false when it is not below D floor(D/2).
  bool PairAt(uint32_t rank, size_t* a_at, size_t* b_at) const;
  // The predicted wings (for tests and estimates).
  size_t predicted_first() const { return p1_; }
  size_t predicted_second() const { return p2_; }

 private:
  uint32_t Cost(size_t a, size_t b) const;
  size_t degree_ = 0;
  size_t p1_ = 0, p2_ = 0;
  std::array<std::array<int64_t, 2>, kMaxRankedValence> q_{};
  std::array<uint8_t, kMaxRankedValence> to_first_{}, to_second_{};  // ring distances to p1, p2
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_CUT_CROSSINGS_H_

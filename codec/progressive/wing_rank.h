// The cut edges of a split as a rank (format version 2, tool bit 2;
// docs/spec/progressive-format.md section 4.2): the wings (a, b) are one of the
// D floor(D/2) pairs (x, x + k), 1 <= k <= D/2, of w's ring of D vertices,
// and the decoder orders those pairs by how well the ring's geometry
// suggests them: a split's cut runs across the direction in which the ring
// is stretched (the coarse vertex replaced two vertices a split vector
// apart) and passes through w. The rank of the true pair in that order is
// what is coded; it is 0 or small where the geometry is clear.
//
// Score of a pair: with q the ring positions relative to w in the ring's
// local frame (local_frame.h; the tangential components only, scaled to 12
// bits), c = q_x - q_{x+k} the chord and t = (-c_1, c_0) the direction
// across it, M = sum of q q^T (2 x 2): score = (t^T M t - 16 (q_x . t)^2) /
// |t|^2, the ring's spread across the chord minus the chord's offset from
// w, as the key trunc(2^16 (t^T M t - 16 (q_x . t)^2) / |t|^2) (division
// rounding toward zero). Higher keys first; ties by x, then k; pairs with
// t = 0 last. All in exact integer arithmetic.
//
// Contract: pure, deterministic on every platform, O(D^2) (scores in 64-bit
// integers; a 128-bit division only for scores of 2^47 and more; the
// decoder's PairOfRank divides only for the few pairs that may be among the
// first rank + 1), no
// allocation (the candidates live in the object). Defined for
// 3 <= D <= kMaxRankedValence (the encoder's splits have D <= 14).
// Thread safety: none.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_WING_RANK_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_WING_RANK_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/vec.h"
#include "codec/progressive/local_frame.h"
#include "codec/progressive/refinement.h"

namespace meshstream {

constexpr size_t kMaxRankedValence = 22;  // D floor(D/2) < 256: two symbols of 16
constexpr size_t kMaxRankedPairs = kMaxRankedValence * (kMaxRankedValence / 2);

class WingRanking {
 public:
  // Scores the pairs of w's ring in its local frame (RingLocalFrame); false
  // when the degree is outside [3, kMaxRankedValence].
  bool Reset(const Vec3i& w, const Vec3i* ring, size_t degree, const LocalFrame& frame);
  // The rank of wings at ring positions (a_at, b_at); false unless
  // 1 <= (b_at - a_at) mod D <= D/2.
  bool RankOf(size_t a_at, size_t b_at, uint32_t* rank) const;
  // The wings of a rank; false when it is not below D floor(D/2).
  bool PairAt(uint32_t rank, size_t* a_at, size_t* b_at) const;
  // The wings of a rank straight from the ring (the decoder's path): what
  // Reset then PairAt give, without a division for every pair when the rank
  // is below 8 (nine splits in ten); false as Reset or PairAt would be.
  // Leaves no candidates behind for RankOf or PairAt.
  bool PairOfRank(const Vec3i& w, const Vec3i* ring, size_t degree, const LocalFrame& frame, uint32_t rank,
                  size_t* a_at, size_t* b_at);
  // For estimates only (bench/codec_levers_v3.cc): the keys of the
  // candidates in rank order (larger first; INT64_MIN for t = 0), at most
  // `max` of them, into out[0..]; returns how many.
  size_t KeysInOrder(int64_t* out, size_t max) const;

 private:
  // A candidate as one integer whose ascending order is the ranking's order
  // (key descending, then x, then k): (2^47 - key) << 9 | x << 4 | k, and
  // (2^48 - 1) << 9 | x << 4 | k for t = 0. Keys lie within +-2^46
  // (wing_rank.cc), x < 32 and k < 16, so every candidate is distinct and
  // fits 57 bits.
  static constexpr int kPairBits = 9;
  static uint64_t Order(int64_t key, size_t x, size_t k);
  using Tangent2 = std::array<int64_t, 2>;
  // The ring's scaled tangents into q[0, 2 degree) (twice over) and M's
  // entries m00, m01, m11; returns floor(degree / 2).
  static size_t Prepare(const Vec3i& w, const Vec3i* ring, size_t degree, const LocalFrame& frame, Tangent2* q,
                        int64_t m[3]);
  // The key an order holds (INT64_MIN for t = 0), and the ring positions of
  // its pair on a ring of `degree`.
  static int64_t KeyOf(uint64_t order);
  static void PairOf(uint64_t order, size_t degree, size_t* a_at, size_t* b_at);
  // The (R + 1)-th smallest order of the ring's pairs (PairOfRank).
  template <int R>
  static uint64_t SelectSmall(const Tangent2* q, size_t degree, size_t half, const int64_t m[3]);
  size_t degree_ = 0;
  size_t count_ = 0;
  std::array<uint64_t, kMaxRankedPairs> order_{};  // by x, then k
};

// A pair's key, trunc(2^16 score / length) for length > 0, rounding toward
// zero, exact.
int64_t RankKey(int64_t score, int64_t length);
// RankKey(score, length) <= key, without the division: with v = 2^16 score /
// length (real), trunc(v) <= K exactly when v < K + 1 (K >= 0) or v <= K
// (K < 0), a comparison of 2^16 score with a multiple of length in 128 bits.
// For |score| < 2^58, 0 < length < 2^28 and |key| < 2^62 (WingRanking's
// bounds are tighter).
inline bool RankKeyAtMost(int64_t score, int64_t length, int64_t key) {
  const __int128 lhs = static_cast<__int128>(score) * 65536;
  if (key >= 0) return lhs < static_cast<__int128>(key + 1) * length;
  return lhs <= static_cast<__int128>(key) * length;
}

// A rank as the two structure symbols (slots 0 and 1) and back.
inline std::array<uint16_t, 2> RankSymbols(uint32_t rank) {
  return {static_cast<uint16_t>(rank % 16), static_cast<uint16_t>(rank / 16)};
}
inline uint32_t RankFromSymbols(const std::array<uint16_t, 2>& s) { return uint32_t{s[0]} + 16u * s[1]; }

// (CodedWingPositions, which decodes a split's wings in either order of its
// rank, is in cut_crossings.h.)

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_WING_RANK_H_

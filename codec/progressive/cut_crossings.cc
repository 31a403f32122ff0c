#include "codec/progressive/cut_crossings.h"

#include <algorithm>
#include <cstdlib>

namespace meshstream {

namespace {

constexpr int kScaleBits = 12;  // as wing_rank.cc

inline uint64_t Magnitude(int64_t v) { return v < 0 ? uint64_t(0) - uint64_t(v) : uint64_t(v); }

}  // namespace

bool CutCrossings::Reset(const Vec3i& w, const Vec3i* ring, size_t d, const LocalFrame& frame) {
  if (d < 3 || d > kMaxRankedValence) return false;
  degree_ = d;
  frame.Tangents(w, ring, d, q_.data());
  uint64_t bits = 0;  // the OR of the magnitudes: its width is the extent's
  for (size_t k = 0; k < d; ++k) bits |= Magnitude(q_[k][0]) | Magnitude(q_[k][1]);
  const int width = bits == 0 ? 0 : 64 - __builtin_clzll(bits);
  const int shift = width > kScaleBits ? width - kScaleBits : 0;
  int64_t m00 = 0, m01 = 0, m11 = 0;
  for (size_t k = 0; k < d; ++k) {
    if (shift != 0) {
      for (int c = 0; c < 2; ++c) q_[k][c] = q_[k][c] < 0 ? -((-q_[k][c]) >> shift) : q_[k][c] >> shift;
    }
    m00 += q_[k][0] * q_[k][0];
    m01 += q_[k][0] * q_[k][1];
    m11 += q_[k][1] * q_[k][1];
  }
  // |q| < 2^12 and D <= 22: m < 2^29, the radicand < 2^61, r < 2^31, e < 2^32.
  const int64_t diff = m00 - m11;
  const int64_t r = IntegerSqrt(diff * diff + 4 * m01 * m01);
  int64_t e0, e1;
  if (diff >= 0) {
    e0 = diff + r;
    e1 = 2 * m01;
  } else {
    e0 = 2 * m01;
    e1 = -diff + r;
  }
  if (e0 == 0 && e1 == 0) e0 = 1;
  // |s| < 2 2^12 2^32: int64.
  int64_t s[kMaxRankedValence];
  for (size_t k = 0; k < d; ++k) s[k] = q_[k][0] * e0 + q_[k][1] * e1;
  // The two crossings of smallest |s| at their vertex, in ring order.
  size_t best[2] = {0, 0};
  uint64_t best_s[2] = {UINT64_MAX, UINT64_MAX};
  size_t found = 0;
  for (size_t k = 0; k < d; ++k) {
    const size_t k1 = k + 1 < d ? k + 1 : 0;
    if ((s[k] < 0) == (s[k1] < 0)) continue;
    ++found;
    const size_t v = Magnitude(s[k]) <= Magnitude(s[k1]) ? k : k1;
    const uint64_t m = Magnitude(s[v]);
    if (m < best_s[0]) {
      best[1] = best[0];
      best_s[1] = best_s[0];
      best[0] = v;
      best_s[0] = m;
    } else if (m < best_s[1]) {
      best[1] = v;
      best_s[1] = m;
    }
  }
  if (found < 2) {
    p1_ = 0;
    p2_ = d / 2;
  } else {
    // (The order of the two does not matter: a pair's cost is symmetric in them.)
    p1_ = best[0];
    p2_ = best[1];
  }
  // Distances along the ring to each predicted wing.
  for (size_t x = 0; x < d; ++x) {
    const size_t a = x > p1_ ? x - p1_ : p1_ - x, b = x > p2_ ? x - p2_ : p2_ - x;
    to_first_[x] = static_cast<uint8_t>(std::min(a, d - a));
    to_second_[x] = static_cast<uint8_t>(std::min(b, d - b));
  }
  return true;
}

bool CodedWingPositions(const std::array<uint16_t, 2>& wings, ToolSet tools, const std::vector<uint32_t>& ring,
                        const Vec3i& w, const Vec3i* ring_positions, const LocalFrame& frame, WingRanking* ranking,
                        CutCrossings* crossings, size_t* a_at, size_t* b_at) {
  if ((tools & kToolWingRank) == 0) return WingPositions(ring, wings, a_at, b_at);
  if (tools & kToolCutCrossings) {
    return crossings->Reset(w, ring_positions, ring.size(), frame) &&
           crossings->PairAt(RankFromSymbols(wings), a_at, b_at);
  }
  return ranking->PairOfRank(w, ring_positions, ring.size(), frame, RankFromSymbols(wings), a_at, b_at);
}

inline uint32_t CutCrossings::Cost(size_t a, size_t b) const {
  return std::min(uint32_t{to_first_[a]} + to_second_[b], uint32_t{to_second_[a]} + to_first_[b]);
}

bool CutCrossings::RankOf(size_t a_at, size_t b_at, uint32_t* rank) const {
  const size_t d = degree_;
  if (d == 0 || a_at >= d || b_at >= d) return false;
  const size_t k_true = (b_at + d - a_at) % d;
  if (k_true == 0 || k_true > d / 2) return false;
  const uint32_t cost = Cost(a_at, b_at);
  uint32_t before = 0;
  for (size_t x = 0; x < d; ++x) {
    for (size_t k = 1; k <= d / 2; ++k) {
      const uint32_t c = Cost(x, (x + k) % d);
      before += c < cost || (c == cost && (x < a_at || (x == a_at && k < k_true))) ? 1 : 0;
    }
  }
  *rank = before;
  return true;
}

bool CutCrossings::PairAt(uint32_t rank, size_t* a_at, size_t* b_at) const {
  const size_t d = degree_, half = d / 2;
  if (d == 0 || rank >= d * half) return false;
  // Cost 0 is the predicted pair itself, in the orientations that are
  // candidates (both when p2 - p1 = D/2), lower x first: a third of the
  // splits end here.
  if (p1_ != p2_) {
    const size_t lo = std::min(p1_, p2_), hi = std::max(p1_, p2_);
    const bool up = hi - lo <= half, down = d - (hi - lo) <= half;  // (lo, hi), (hi, lo)
    if (rank < uint32_t{up} + uint32_t{down}) {
      const bool first_up = up && (rank == 0);
      *a_at = first_up ? lo : hi;
      *b_at = first_up ? hi : lo;
      return true;
    }
  }
  // Costs lie in [0, d]: count each, find the rank's cost, then walk it in
  // (x, k) order.
  uint32_t per_cost[kMaxRankedValence + 1] = {};
  for (size_t x = 0; x < d; ++x) {
    size_t y = x;
    for (size_t k = 1; k <= half; ++k) {
      y = y + 1 < d ? y + 1 : 0;
      ++per_cost[Cost(x, y)];
    }
  }
  uint32_t level = 0;
  while (rank >= per_cost[level]) rank -= per_cost[level++];
  for (size_t x = 0; x < d; ++x) {
    size_t y = x;
    for (size_t k = 1; k <= half; ++k) {
      y = y + 1 < d ? y + 1 : 0;
      if (Cost(x, y) == level && rank-- == 0) {
        *a_at = x;
        *b_at = y;
        return true;
      }
    }
  }
  return false;  // unreachable: the counts add up
}

}  // namespace meshstream

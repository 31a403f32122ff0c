#include "codec/progressive/wing_rank.h"

#include <algorithm>

#include "codec/progressive/local_frame.h"

namespace meshstream {

namespace {

constexpr int kScaleBits = 10;
constexpr int kOffsetWeight = 16;

// a better than b: a higher score over |t|^2 (exact cross-multiplication;
// both lengths positive), pairs without a direction last, ties by (x, k).
bool Better(const __int128& sa, const __int128& la, const __int128& sb, const __int128& lb) {
  return sa * lb > sb * la;
}

}  // namespace

bool WingRanking::Reset(const Vec3i& w, const Vec3i* ring, size_t d) {
  degree_ = 0;
  if (d < 3 || d > kMaxRankedValence) return false;
  // Ring relative to w, scaled so that every component is below 2^10.
  int64_t extent = 0;
  for (size_t k = 0; k < d; ++k)
    for (int c = 0; c < 3; ++c) extent = std::max(extent, std::abs(int64_t{ring[k][c]} - w[c]));
  int shift = 0;
  while ((extent >> shift) >= (int64_t{1} << kScaleBits)) ++shift;
  std::array<std::array<int64_t, 3>, kMaxRankedValence> q{};
  for (size_t k = 0; k < d; ++k)
    for (int c = 0; c < 3; ++c) {
      const int64_t v = int64_t{ring[k][c]} - w[c];
      q[k][c] = v < 0 ? -((-v) >> shift) : v >> shift;
    }
  WideVec3 wide = {0, 0, 0};
  for (size_t k = 0; k < d; ++k) {
    const auto& a = q[k];
    const auto& b = q[(k + 1) % d];
    wide[0] += __int128{a[1] * b[2] - a[2] * b[1]};
    wide[1] += __int128{a[2] * b[0] - a[0] * b[2]};
    wide[2] += __int128{a[0] * b[1] - a[1] * b[0]};
  }
  const std::array<int64_t, 3> n = ScaleDown(wide, kScaleBits);
  int64_t m[3][3] = {};
  for (size_t k = 0; k < d; ++k)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m[i][j] += q[k][i] * q[k][j];
  const size_t half = d / 2;
  order_.clear();
  for (size_t x = 0; x < d; ++x) {
    for (size_t k = 1; k <= half; ++k) {
      const auto& a = q[x];
      const auto& b = q[(x + k) % d];
      const int64_t c[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
      const int64_t t[3] = {n[1] * c[2] - n[2] * c[1], n[2] * c[0] - n[0] * c[2], n[0] * c[1] - n[1] * c[0]};
      Candidate cand;
      cand.x = static_cast<uint16_t>(x);
      cand.k = static_cast<uint16_t>(k);
      cand.length = __int128{t[0] * t[0]} + __int128{t[1] * t[1]} + __int128{t[2] * t[2]};
      __int128 spread = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) spread += __int128{t[i]} * m[i][j] * t[j];
      const __int128 offset = __int128{a[0] * t[0]} + __int128{a[1] * t[1]} + __int128{a[2] * t[2]};
      cand.score = spread - kOffsetWeight * offset * offset;
      order_.push_back(cand);
    }
  }
  std::sort(order_.begin(), order_.end(), [](const Candidate& a, const Candidate& b) {
    if ((a.length == 0) != (b.length == 0)) return b.length == 0;
    if (a.length != 0) {
      if (Better(a.score, a.length, b.score, b.length)) return true;
      if (Better(b.score, b.length, a.score, a.length)) return false;
    }
    return a.x != b.x ? a.x < b.x : a.k < b.k;
  });
  rank_of_.assign(d * half, 0);
  for (size_t r = 0; r < order_.size(); ++r) rank_of_[order_[r].x * half + (order_[r].k - 1)] = static_cast<uint16_t>(r);
  degree_ = d;
  return true;
}

bool WingRanking::RankOf(size_t a_at, size_t b_at, uint32_t* rank) const {
  const size_t d = degree_;
  if (d == 0 || a_at >= d || b_at >= d) return false;
  const size_t k = (b_at + d - a_at) % d;
  if (k < 1 || k > d / 2) return false;
  *rank = rank_of_[a_at * (d / 2) + (k - 1)];
  return true;
}

bool WingRanking::PairAt(uint32_t rank, size_t* a_at, size_t* b_at) const {
  if (degree_ == 0 || rank >= order_.size()) return false;
  *a_at = order_[rank].x;
  *b_at = (order_[rank].x + order_[rank].k) % degree_;
  return true;
}

}  // namespace meshstream

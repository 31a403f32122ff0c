#include "codec/progressive/wing_rank.h"

#include <algorithm>

#include "codec/progressive/local_frame.h"

namespace meshstream {

namespace {

constexpr int kScaleBits = 12;
constexpr int kOffsetWeight = 16;
constexpr int kKeyBits = 16;

}  // namespace

// a before b: a higher key, ties by (x, k).
bool WingRanking::Before(const Candidate& a, const Candidate& b) {
  if (a.key != b.key) return a.key > b.key;
  return a.x != b.x ? a.x < b.x : a.k < b.k;
}

bool WingRanking::Reset(const Vec3i& w, const Vec3i* ring, size_t d, const LocalFrame& frame) {
  degree_ = 0;
  if (d < 3 || d > kMaxRankedValence) return false;
  // The ring in the tangent plane, scaled so that every component is below 2^12.
  std::array<std::array<int64_t, 2>, kMaxRankedValence> q{};
  int64_t extent = 0;
  for (size_t k = 0; k < d; ++k) {
    const Vec3i rel = {static_cast<int32_t>(std::clamp<int64_t>(int64_t{ring[k][0]} - w[0], INT32_MIN, INT32_MAX)),
                       static_cast<int32_t>(std::clamp<int64_t>(int64_t{ring[k][1]} - w[1], INT32_MIN, INT32_MAX)),
                       static_cast<int32_t>(std::clamp<int64_t>(int64_t{ring[k][2]} - w[2], INT32_MIN, INT32_MAX))};
    const Vec3i f = frame.Forward(rel);
    q[k] = {f[0], f[1]};
    extent = std::max({extent, std::abs(q[k][0]), std::abs(q[k][1])});
  }
  int shift = 0;
  while ((extent >> shift) >= (int64_t{1} << kScaleBits)) ++shift;
  int64_t m00 = 0, m01 = 0, m11 = 0;
  for (size_t k = 0; k < d; ++k) {
    for (int c = 0; c < 2; ++c) q[k][c] = q[k][c] < 0 ? -((-q[k][c]) >> shift) : q[k][c] >> shift;
    m00 += q[k][0] * q[k][0];
    m01 += q[k][0] * q[k][1];
    m11 += q[k][1] * q[k][1];
  }
  // Magnitudes: q < 2^12, c < 2^13, M < 22 * 2^24, so t^T M t < 2^57 and
  // 16 (q . t)^2 < 2^56: the score fits int64; |t|^2 < 2^27.
  const size_t half = d / 2;
  candidates_.clear();
  for (size_t x = 0; x < d; ++x) {
    for (size_t k = 1; k <= half; ++k) {
      const auto& a = q[x];
      const auto& b = q[(x + k) % d];
      const int64_t c0 = a[0] - b[0], c1 = a[1] - b[1];
      Candidate cand;
      cand.x = static_cast<uint16_t>(x);
      cand.k = static_cast<uint16_t>(k);
      const int64_t length = c0 * c0 + c1 * c1;
      // t = (-c1, c0)
      const int64_t spread = m00 * c1 * c1 - 2 * m01 * c0 * c1 + m11 * c0 * c0;
      const int64_t offset = a[1] * c0 - a[0] * c1;
      const int64_t score = spread - kOffsetWeight * offset * offset;
      // |score| / length < 22 * 2^24 (Cauchy-Schwarz), so the key fits in 2^45.
      cand.key = length > 0 ? static_cast<int64_t>(__int128{score} * (int64_t{1} << kKeyBits) / length) : INT64_MIN;
      candidates_.push_back(cand);
    }
  }
  degree_ = d;
  return true;
}

bool WingRanking::RankOf(size_t a_at, size_t b_at, uint32_t* rank) const {
  const size_t d = degree_;
  if (d == 0 || a_at >= d || b_at >= d) return false;
  const size_t k = (b_at + d - a_at) % d;
  if (k < 1 || k > d / 2) return false;
  Candidate target;
  for (const Candidate& c : candidates_)
    if (c.x == a_at && c.k == k) target = c;
  uint32_t before = 0;
  for (const Candidate& c : candidates_) before += Before(c, target) ? 1 : 0;
  *rank = before;
  return true;
}

bool WingRanking::PairAt(uint32_t rank, size_t* a_at, size_t* b_at) const {
  if (degree_ == 0 || rank >= candidates_.size()) return false;
  // The rank-th in the order (a total order: ties are broken by (x, k)):
  // small ranks, the common case, by selecting the first ones in place.
  if (rank < 4) {
    for (uint32_t r = 0; r <= rank; ++r) {
      size_t best = r;
      for (size_t i = r + 1; i < candidates_.size(); ++i)
        if (Before(candidates_[i], candidates_[best])) best = i;
      std::swap(candidates_[r], candidates_[best]);
    }
  } else {
    std::nth_element(candidates_.begin(), candidates_.begin() + rank, candidates_.end(), Before);
  }
  const Candidate& c = candidates_[rank];
  *a_at = c.x;
  *b_at = (c.x + c.k) % degree_;
  return true;
}

}  // namespace meshstream

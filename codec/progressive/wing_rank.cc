#include "codec/progressive/wing_rank.h"

#include <algorithm>

#include "codec/progressive/local_frame.h"

namespace meshstream {

namespace {

constexpr int kScaleBits = 12;
constexpr int kOffsetWeight = 16;
constexpr int kKeyBits = 16;
constexpr int64_t kKeyBound = int64_t{1} << 46;  // |key| < kKeyBound (Reset)

}  // namespace

// In 64 bits while |score| < 2^47 (all but hostile or huge rings), else in
// 128 bits.
int64_t RankKey(int64_t score, int64_t length) {
  const uint64_t mag = score < 0 ? 0 - static_cast<uint64_t>(score) : static_cast<uint64_t>(score);
  uint64_t q;
  if (mag < (uint64_t{1} << (63 - kKeyBits))) {
    q = (mag << kKeyBits) / static_cast<uint64_t>(length);
  } else {
    q = static_cast<uint64_t>((static_cast<unsigned __int128>(mag) << kKeyBits) / static_cast<uint64_t>(length));
  }
  const int64_t key = static_cast<int64_t>(std::min<uint64_t>(q, kKeyBound - 1));  // never clamps (Reset)
  return score < 0 ? -key : key;
}

// (WingRanking::kPairBits and the layout: wing_rank.h.)
inline uint64_t WingRanking::Order(int64_t key, size_t x, size_t k) {
  const uint64_t rest = (static_cast<uint64_t>(x) << 4) | static_cast<uint64_t>(k);
  // INT64_MIN (t = 0) after every key; a key within +-2^46 maps to (2^46, 3 2^46).
  const uint64_t field = key == INT64_MIN ? (uint64_t{1} << 48) - 1 : static_cast<uint64_t>((kKeyBound << 1) - key);
  return (field << kPairBits) | rest;
}

size_t WingRanking::Prepare(const Vec3i& w, const Vec3i* ring, size_t d, const LocalFrame& frame, Tangent2* q,
                            int64_t m[3]) {
  // The ring in the tangent plane, scaled so that every component is below
  // 2^12; twice over, so that q[x + k] needs no wrap.
  frame.Tangents(w, ring, d, q);
  int64_t extent = 0;
  for (size_t k = 0; k < d; ++k) extent = std::max({extent, std::abs(q[k][0]), std::abs(q[k][1])});
  int shift = 0;
  while ((extent >> shift) >= (int64_t{1} << kScaleBits)) ++shift;
  int64_t m00 = 0, m01 = 0, m11 = 0;
  for (size_t k = 0; k < d; ++k) {
    for (int c = 0; c < 2; ++c) q[k][c] = q[k][c] < 0 ? -((-q[k][c]) >> shift) : q[k][c] >> shift;
    m00 += q[k][0] * q[k][0];
    m01 += q[k][0] * q[k][1];
    m11 += q[k][1] * q[k][1];
    q[k + d] = q[k];
  }
  m[0] = m00;
  m[1] = m01;
  m[2] = m11;
  // Magnitudes: q < 2^12, c < 2^13, M < 22 * 2^25, so t^T M t < 2^57 and
  // 16 (q . t)^2 < 2^56: the score fits int64; |t|^2 < 2^27. The key: by
  // Cauchy-Schwarz t^T M t <= trace(M) |t|^2 < 22 2^25 |t|^2 and
  // 16 (q . t)^2 <= 16 |q|^2 |t|^2 < 2^29 |t|^2, so |key| < 2^16 2^30 = 2^46.
  return d / 2;
}

namespace {

// A pair's score and |t|^2 (wing_rank.h), a = q_x, b = q_{x+k}.
struct PairScore {
  int64_t score, length;
};
inline PairScore ScorePair(const std::array<int64_t, 2>& a, const std::array<int64_t, 2>& b, const int64_t m[3]) {
  const int64_t c0 = a[0] - b[0], c1 = a[1] - b[1];
  // t = (-c1, c0)
  const int64_t spread = m[0] * c1 * c1 - 2 * m[1] * c0 * c1 + m[2] * c0 * c0;
  const int64_t offset = a[1] * c0 - a[0] * c1;
  return {spread - kOffsetWeight * offset * offset, c0 * c0 + c1 * c1};
}

}  // namespace

bool WingRanking::Reset(const Vec3i& w, const Vec3i* ring, size_t d, const LocalFrame& frame) {
  degree_ = 0;
  count_ = 0;
  if (d < 3 || d > kMaxRankedValence) return false;
  std::array<Tangent2, 2 * kMaxRankedValence> q;
  int64_t m[3];
  const size_t half = Prepare(w, ring, d, frame, q.data(), m);
  uint64_t* out = order_.data();
  for (size_t x = 0; x < d; ++x) {
    for (size_t k = 1; k <= half; ++k) {
      const PairScore p = ScorePair(q[x], q[x + k], m);
      *out++ = Order(p.length > 0 ? RankKey(p.score, p.length) : INT64_MIN, x, k);
    }
  }
  count_ = d * half;
  degree_ = d;
  return true;
}

template <int R>
void WingRanking::SelectSmall(const Tangent2* q, size_t d, size_t half, const int64_t m[3], size_t* a_at,
                              size_t* b_at) {
  // The R + 1 smallest orders so far, sorted, as in SmallestAt; a candidate
  // is first tested against the last of them by its key alone, without the
  // division (RankKeyAtMost). The candidates come in the ties' order (x,
  // then k), so one whose key is not above that last key comes after it:
  // skipped. Only a candidate that may enter the list gets its exact key.
  uint64_t best[R + 1];
  for (int r = 0; r <= R; ++r) best[r] = UINT64_MAX;
  bool filter = false;  // best[R] is a pair with t != 0
  int64_t last_key = 0;
  for (size_t x = 0; x < d; ++x) {
    for (size_t k = 1; k <= half; ++k) {
      const PairScore p = ScorePair(q[x], q[x + k], m);
      if (filter) {
        if (p.length == 0) continue;  // t = 0 comes after every key
        if (RankKeyAtMost(p.score, p.length, last_key)) continue;
      }
      const uint64_t t = Order(p.length > 0 ? RankKey(p.score, p.length) : INT64_MIN, x, k);
      if (t >= best[R]) continue;
      int at = R;
      for (; at > 0 && best[at - 1] > t; --at) best[at] = best[at - 1];
      best[at] = t;
      if (best[R] != UINT64_MAX) {
        const uint64_t field = best[R] >> kPairBits;
        filter = field != (uint64_t{1} << 48) - 1;
        last_key = (kKeyBound << 1) - static_cast<int64_t>(field);
      }
    }
  }
  const size_t x = (best[R] >> 4) & 31, k = best[R] & 15;
  *a_at = x;
  *b_at = (x + k) % d;
}

bool WingRanking::PairOfRank(const Vec3i& w, const Vec3i* ring, size_t d, const LocalFrame& frame, uint32_t rank,
                             size_t* a_at, size_t* b_at) {
  degree_ = 0;  // the candidates are not kept
  count_ = 0;
  if (d < 3 || d > kMaxRankedValence) return false;
  const size_t half = d / 2;
  if (rank >= d * half) return false;
  if (rank >= 8) return Reset(w, ring, d, frame) && PairAt(rank, a_at, b_at);
  std::array<Tangent2, 2 * kMaxRankedValence> q;
  int64_t m[3];
  Prepare(w, ring, d, frame, q.data(), m);
  switch (rank) {
    case 0: SelectSmall<0>(q.data(), d, half, m, a_at, b_at); break;
    case 1: SelectSmall<1>(q.data(), d, half, m, a_at, b_at); break;
    case 2: SelectSmall<2>(q.data(), d, half, m, a_at, b_at); break;
    case 3: SelectSmall<3>(q.data(), d, half, m, a_at, b_at); break;
    case 4: SelectSmall<4>(q.data(), d, half, m, a_at, b_at); break;
    case 5: SelectSmall<5>(q.data(), d, half, m, a_at, b_at); break;
    case 6: SelectSmall<6>(q.data(), d, half, m, a_at, b_at); break;
    default: SelectSmall<7>(q.data(), d, half, m, a_at, b_at); break;
  }
  return true;
}

size_t WingRanking::KeysInOrder(int64_t* out, size_t max) const {
  std::array<uint64_t, kMaxRankedPairs> sorted;
  std::copy_n(order_.begin(), count_, sorted.begin());
  const size_t n = std::min(max, count_);
  std::partial_sort(sorted.begin(), sorted.begin() + n, sorted.begin() + count_);
  for (size_t i = 0; i < n; ++i) {
    const uint64_t field = sorted[i] >> kPairBits;
    out[i] = field == (uint64_t{1} << 48) - 1 ? INT64_MIN : static_cast<int64_t>(kKeyBound << 1) - static_cast<int64_t>(field);
  }
  return n;
}

bool WingRanking::RankOf(size_t a_at, size_t b_at, uint32_t* rank) const {
  const size_t d = degree_;
  if (d == 0 || a_at >= d || b_at >= d) return false;
  const size_t k = (b_at + d - a_at) % d;
  if (k < 1 || k > d / 2) return false;
  const uint64_t target = order_[a_at * (d / 2) + (k - 1)];
  uint32_t before = 0;
  for (size_t i = 0; i < count_; ++i) before += order_[i] < target ? 1u : 0u;
  *rank = before;
  return true;
}

namespace {

// The (R + 1)-th smallest of n distinct integers in one pass: the R + 1
// smallest so far are kept sorted; a value that is not below the last of
// them (nearly all, once a few have been seen) costs one compare.
template <int R>
uint64_t SmallestAt(const uint64_t* v, size_t n) {
  uint64_t best[R + 1];
  for (int r = 0; r <= R; ++r) best[r] = UINT64_MAX;
  for (size_t i = 0; i < n; ++i) {
    const uint64_t t = v[i];
    if (t >= best[R]) continue;
    int p = R;
    for (; p > 0 && best[p - 1] > t; --p) best[p] = best[p - 1];
    best[p] = t;
  }
  return best[R];
}

}  // namespace

bool WingRanking::PairAt(uint32_t rank, size_t* a_at, size_t* b_at) const {
  if (degree_ == 0 || rank >= count_) return false;
  // The rank-th smallest of distinct integers: ranks below 8 (nine splits
  // in ten on the shared models) in one pass; larger ones by a selection on
  // a copy.
  const uint64_t* v = order_.data();
  const size_t n = count_;
  uint64_t found = 0;
  switch (rank) {
    case 0: found = SmallestAt<0>(v, n); break;
    case 1: found = SmallestAt<1>(v, n); break;
    case 2: found = SmallestAt<2>(v, n); break;
    case 3: found = SmallestAt<3>(v, n); break;
    case 4: found = SmallestAt<4>(v, n); break;
    case 5: found = SmallestAt<5>(v, n); break;
    case 6: found = SmallestAt<6>(v, n); break;
    case 7: found = SmallestAt<7>(v, n); break;
    default: {
      std::array<uint64_t, kMaxRankedPairs> copy;
      std::copy_n(order_.begin(), n, copy.begin());
      std::nth_element(copy.begin(), copy.begin() + rank, copy.begin() + n);
      found = copy[rank];
    }
  }
  const size_t x = (found >> 4) & 31, k = found & 15;
  *a_at = x;
  *b_at = (x + k) % degree_;
  return true;
}

bool CodedWingPositions(const std::array<uint16_t, 2>& wings, bool ranked, const std::vector<uint32_t>& ring,
                        const Vec3i& w, const Vec3i* ring_positions, const LocalFrame& frame, WingRanking* ranking,
                        size_t* a_at, size_t* b_at) {
  if (!ranked) return WingPositions(ring, wings, a_at, b_at);
  return ranking->PairOfRank(w, ring_positions, ring.size(), frame, RankFromSymbols(wings), a_at, b_at);
}

}  // namespace meshstream

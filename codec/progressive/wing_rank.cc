#include "codec/progressive/wing_rank.h"

#include <algorithm>
#include <type_traits>

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

namespace {

constexpr uint64_t kNoChordField = (uint64_t{1} << 48) - 1;  // t = 0: after every key

}  // namespace

// (WingRanking::kPairBits and the layout: wing_rank.h.)
inline uint64_t WingRanking::Order(int64_t key, size_t x, size_t k) {
  const uint64_t rest = (static_cast<uint64_t>(x) << 4) | static_cast<uint64_t>(k);
  // INT64_MIN (t = 0) after every key; a key within +-2^46 maps to (2^46, 3 2^46).
  const uint64_t field = key == INT64_MIN ? kNoChordField : static_cast<uint64_t>((kKeyBound << 1) - key);
  return (field << kPairBits) | rest;
}

inline int64_t WingRanking::KeyOf(uint64_t order) {
  const uint64_t field = order >> kPairBits;
  return field == kNoChordField ? INT64_MIN : (kKeyBound << 1) - static_cast<int64_t>(field);
}

inline void WingRanking::PairOf(uint64_t order, size_t degree, size_t* a_at, size_t* b_at) {
  const size_t x = (order >> 4) & 31, k = order & 15;
  *a_at = x;
  *b_at = (x + k) % degree;
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

namespace {

// The R + 1 smallest of distinct integers offered so far, kept sorted: a
// value that is not below the last of them (nearly all, once a few have been
// seen) costs one compare.
template <int R>
class Smallest {
 public:
  Smallest() {
    for (int r = 0; r <= R; ++r) best_[r] = UINT64_MAX;
  }
  void Offer(uint64_t t) {
    if (t >= best_[R]) return;
    int p = R;
    for (; p > 0 && best_[p - 1] > t; --p) best_[p] = best_[p - 1];
    best_[p] = t;
  }
  bool full() const { return best_[R] != UINT64_MAX; }
  uint64_t last() const { return best_[R]; }

 private:
  uint64_t best_[R + 1];
};

// f(std::integral_constant<int, rank>()) for a rank below kSmallRanks: the
// ranks found in one pass (nine splits in ten on the shared models).
constexpr uint32_t kSmallRanks = 8;
template <class F>
uint64_t WithSmallRank(uint32_t rank, F&& f) {
  switch (rank) {
    case 0: return f(std::integral_constant<int, 0>());
    case 1: return f(std::integral_constant<int, 1>());
    case 2: return f(std::integral_constant<int, 2>());
    case 3: return f(std::integral_constant<int, 3>());
    case 4: return f(std::integral_constant<int, 4>());
    case 5: return f(std::integral_constant<int, 5>());
    case 6: return f(std::integral_constant<int, 6>());
    default: return f(std::integral_constant<int, 7>());
  }
}

}  // namespace

template <int R>
uint64_t WingRanking::SelectSmall(const Tangent2* q, size_t d, size_t half, const int64_t m[3]) {
  // The R + 1 smallest orders so far (Smallest); a candidate is first tested
  // against the last of them by its key alone, without the division
  // (RankKeyAtMost). The candidates come in the ties' order (x, then k), so
  // one whose key is not above that last key comes after it: skipped. Only a
  // candidate that may enter the list gets its exact key.
  Smallest<R> best;
  bool filter = false;  // the last kept is a pair with t != 0
  int64_t last_key = 0;
  for (size_t x = 0; x < d; ++x) {
    for (size_t k = 1; k <= half; ++k) {
      const PairScore p = ScorePair(q[x], q[x + k], m);
      if (filter) {
        if (p.length == 0) continue;  // t = 0 comes after every key
        if (RankKeyAtMost(p.score, p.length, last_key)) continue;
      }
      best.Offer(Order(p.length > 0 ? RankKey(p.score, p.length) : INT64_MIN, x, k));
      if (best.full()) {
        last_key = KeyOf(best.last());
        filter = last_key != INT64_MIN;
      }
    }
  }
  return best.last();
}

bool WingRanking::PairOfRank(const Vec3i& w, const Vec3i* ring, size_t d, const LocalFrame& frame, uint32_t rank,
                             size_t* a_at, size_t* b_at) {
  degree_ = 0;  // the candidates are not kept
  count_ = 0;
  if (d < 3 || d > kMaxRankedValence) return false;
  const size_t half = d / 2;
  if (rank >= d * half) return false;
  if (rank >= kSmallRanks) return Reset(w, ring, d, frame) && PairAt(rank, a_at, b_at);
  std::array<Tangent2, 2 * kMaxRankedValence> q;
  int64_t m[3];
  Prepare(w, ring, d, frame, q.data(), m);
  const uint64_t found =
      WithSmallRank(rank, [&](auto r) { return SelectSmall<decltype(r)::value>(q.data(), d, half, m); });
  PairOf(found, d, a_at, b_at);
  return true;
}

size_t WingRanking::KeysInOrder(int64_t* out, size_t max) const {
  std::array<uint64_t, kMaxRankedPairs> sorted;
  std::copy_n(order_.begin(), count_, sorted.begin());
  const size_t n = std::min(max, count_);
  std::partial_sort(sorted.begin(), sorted.begin() + n, sorted.begin() + count_);
  for (size_t i = 0; i < n; ++i) out[i] = KeyOf(sorted[i]);
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

bool WingRanking::PairAt(uint32_t rank, size_t* a_at, size_t* b_at) const {
  if (degree_ == 0 || rank >= count_) return false;
  // The rank-th smallest of distinct integers: small ranks in one pass;
  // larger ones by a selection on a copy.
  const uint64_t* v = order_.data();
  const size_t n = count_;
  uint64_t found = 0;
  if (rank < kSmallRanks) {
    found = WithSmallRank(rank, [&](auto r) {
      Smallest<decltype(r)::value> best;
      for (size_t i = 0; i < n; ++i) best.Offer(v[i]);
      return best.last();
    });
  } else {
    std::array<uint64_t, kMaxRankedPairs> copy;
    std::copy_n(order_.begin(), n, copy.begin());
    std::nth_element(copy.begin(), copy.begin() + rank, copy.begin() + n);
    found = copy[rank];
  }
  PairOf(found, degree_, a_at, b_at);
  return true;
}

}  // namespace meshstream

#include "codec/progressive/ring_predictor.h"

#include <algorithm>

#include "codec/progressive/geometry_prediction.h"  // kMaxPredictedValence
#include "codec/progressive/refinement_state.h"

namespace meshstream {

namespace {

constexpr int64_t kFeatureLimit = int64_t{1} << 30;

int64_t Clamp30(int64_t v) { return std::clamp(v, -kFeatureLimit, kFeatureLimit); }

// x / y rounded, halves away from zero (y > 0).
int64_t RoundDiv(int64_t x, int64_t y) {
  const int64_t m = x < 0 ? -x : x;
  const int64_t q = (2 * m + y) / (2 * y);
  return x < 0 ? -q : q;
}

// centroid(Q) - centroid(P) in 1/16 steps, per axis, from the sides' sums
// and counts: round(16 (kp sq - kq sp) / (kq kp)).
Vec3i SideDifference(const int64_t* sq, int64_t kq, const int64_t* sp, int64_t kp) {
  Vec3i out{};
  const int64_t den = kq * kp;
  for (int c = 0; c < 3; ++c) {
    // |sq|, |sp| < 2^31 * 65 (positions) or 2^38 * 65 (umbrellas, each
    // below 2^32 * 64): times 16 * 65 stays below 2^63.
    const int64_t num = (kp * sq[c] - kq * sp[c]) * (int64_t{1} << kFeatureFractionBits);
    out[c] = static_cast<int32_t>(Clamp30(RoundDiv(num, den)));
  }
  return out;
}

}  // namespace

void RingUmbrellas(const RefinementState& state, const uint32_t* ring, size_t degree, std::vector<Umbrella>* out,
                   uint8_t* flags) {
  out->resize(degree);
  const std::vector<Face>& faces = state.connectivity.faces();
  uint8_t seen = 0;
  for (size_t k = 0; k < degree; ++k) {
    const uint32_t x = ring[k];
    Umbrella u{0, 0, 0};
    const SplitConnectivity::FaceList list = state.connectivity.faces_of(x);
    if (list.size() <= kMaxUmbrellaFaces) {
      const Vec3i& px = state.positions[x];
      for (uint32_t f : list) {
        const Face& t = faces[f];
        const uint32_t y = t[0] == x ? t[1] : t[1] == x ? t[2] : t[0];
        if (!state.Stable(y)) continue;
        const Vec3i& py = state.positions[y];
        for (int c = 0; c < 3; ++c) u[c] += int64_t{px[c]} - py[c];
        if (flags) seen |= state.flags[y];
      }
    }
    (*out)[k] = u;
  }
  if (flags) *flags |= seen;
}

PredictorFeatures SplitFeatures(const Vec3i* ring, const Umbrella* umbrellas, size_t d, size_t a_at, size_t b_at) {
  PredictorFeatures f{};
  if (d < 2 || d > kMaxPredictedValence || a_at >= d || b_at >= d || a_at == b_at) return f;
  // P = ring[b..a] (the new vertex's side), Q = ring[a..b] (w's side), one
  // pass over each.
  const size_t path = (a_at + d - b_at) % d;
  const int64_t kp = static_cast<int64_t>(path) + 1;
  const int64_t kq = static_cast<int64_t>(d - path) + 1;
  int64_t sp[3] = {0, 0, 0}, sq[3] = {0, 0, 0}, up[3] = {0, 0, 0}, uq[3] = {0, 0, 0};
  for (size_t s = 0, k = b_at; s <= path; ++s, k = k + 1 == d ? 0 : k + 1) {
    for (int c = 0; c < 3; ++c) sp[c] += ring[k][c];
    if (umbrellas)
      for (int c = 0; c < 3; ++c) up[c] += umbrellas[k][c];
  }
  for (size_t s = 0, k = a_at; s <= d - path; ++s, k = k + 1 == d ? 0 : k + 1) {
    for (int c = 0; c < 3; ++c) sq[c] += ring[k][c];
    if (umbrellas)
      for (int c = 0; c < 3; ++c) uq[c] += umbrellas[k][c];
  }
  // The Laplacian prediction (geometry_prediction.h, PredictSplit) has the
  // sides' numerator kp sq - kq sp over (kq + 1)(kp + 1) - 1.
  const int64_t lap_den = (kq + 1) * (kp + 1) - 1;
  for (int c = 0; c < 3; ++c) {
    const int64_t num = (kp * sq[c] - kq * sp[c]) * (int64_t{1} << kFeatureFractionBits);
    f[kFeatureLaplacian][c] = static_cast<int32_t>(Clamp30(RoundDiv(num, lap_den)));
  }
  f[kFeatureSides] = SideDifference(sq, kq, sp, kp);
  if (umbrellas) f[kFeatureRing] = SideDifference(uq, kq, up, kp);
  return f;
}

namespace {

// round(sum of weight * feature / 2^8) per axis, clamped (world, 1/16 steps).
Vec3i Weighted(const std::array<int32_t, kPredictorFeatures>& w, const PredictorFeatures& f) {
  Vec3i out{};
  for (int c = 0; c < 3; ++c) {
    int64_t s = 0;
    for (int k = 0; k < kPredictorFeatures; ++k) s += int64_t{w[k]} * f[k][c];
    out[c] = static_cast<int32_t>(Clamp30((s + (int64_t{1} << (kPredictorWeightBits - 1))) >> kPredictorWeightBits));
  }
  return out;
}

// A frame component in 1/16 steps, rounded to whole steps.
int32_t Whole(int32_t v) {
  constexpr int32_t kHalf = 1 << (kFeatureFractionBits - 1);
  return static_cast<int32_t>((int64_t{v} + kHalf) >> kFeatureFractionBits);
}

}  // namespace

Vec3i PredictInFrame(const PredictorWeights& weights, const PredictorFeatures& features, const LocalFrame& frame) {
  const Vec3i t = frame.Forward(Weighted(weights.tangential, features));
  const Vec3i n = weights.normal == weights.tangential ? t : frame.Forward(Weighted(weights.normal, features));
  return {Whole(t[0]), Whole(t[1]), Whole(n[2])};
}

namespace {
int32_t Clamp32(int64_t v) { return static_cast<int32_t>(std::clamp<int64_t>(v, INT32_MIN, INT32_MAX)); }
}  // namespace

Vec3i ResidualInFrame(const PredictorWeights& weights, const PredictorFeatures& features, const LocalFrame& frame,
                      const Vec3i& delta) {
  const Vec3i p = PredictInFrame(weights, features, frame);
  const Vec3i f = frame.Forward(delta);
  return {Clamp32(int64_t{f[0]} - p[0]), Clamp32(int64_t{f[1]} - p[1]), Clamp32(int64_t{f[2]} - p[2])};
}

Vec3i VectorFromResidual(const PredictorWeights& weights, const PredictorFeatures& features, const LocalFrame& frame,
                         const Vec3i& coded) {
  const Vec3i p = PredictInFrame(weights, features, frame);
  return frame.Inverse({Clamp32(int64_t{coded[0]} + p[0]), Clamp32(int64_t{coded[1]} + p[1]), Clamp32(int64_t{coded[2]} + p[2])});
}

}  // namespace meshstream

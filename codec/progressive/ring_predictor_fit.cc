#include "codec/progressive/ring_predictor_fit.h"

#include <algorithm>
#include <cmath>

namespace meshstream {

PredictorSample SampleOf(const PredictorFeatures& features, const LocalFrame& frame, const Vec3i& delta) {
  PredictorSample s;
  constexpr double kStep = 1.0 / double(1 << kFeatureFractionBits);
  for (int f = 0; f < kPredictorFeatures; ++f) {
    const Vec3i r = frame.Forward(features[f]);
    for (int c = 0; c < 3; ++c) s.features[f][c] = double(r[c]) * kStep;
  }
  s.target = frame.Forward(delta);
  return s;
}

namespace {

// Solves the k x k system a x = b (k <= 3) by Gaussian elimination with
// partial pivoting; an unknown whose pivot vanishes is 0.
std::array<double, kPredictorFeatures> Solve(std::array<std::array<double, kPredictorFeatures>, kPredictorFeatures> a,
                                             std::array<double, kPredictorFeatures> b, int k) {
  std::array<double, kPredictorFeatures> x{};
  std::array<bool, kPredictorFeatures> dead{};
  for (int c = 0; c < k; ++c) {
    int piv = c;
    for (int r = c + 1; r < k; ++r)
      if (std::fabs(a[r][c]) > std::fabs(a[piv][c])) piv = r;
    std::swap(a[c], a[piv]);
    std::swap(b[c], b[piv]);
    if (std::fabs(a[c][c]) < 1e-12) {
      dead[c] = true;
      continue;
    }
    for (int r = 0; r < k; ++r) {
      if (r == c) continue;
      const double m = a[r][c] / a[c][c];
      for (int q = c; q < k; ++q) a[r][q] -= m * a[c][q];
      b[r] -= m * b[c];
    }
  }
  for (int c = 0; c < k; ++c) x[c] = dead[c] ? 0.0 : b[c] / a[c][c];
  return x;
}

// The weights of one group of components (first..last) over k features.
std::array<int32_t, kPredictorFeatures> FitGroup(const std::vector<PredictorSample>& samples, int first, int last,
                                                 int k) {
  std::array<double, kPredictorFeatures> w{};
  w[kFeatureLaplacian] = 1.0;
  for (int iteration = 0; iteration < 4; ++iteration) {
    std::array<std::array<double, kPredictorFeatures>, kPredictorFeatures> a{};
    std::array<double, kPredictorFeatures> b{};
    for (const PredictorSample& s : samples) {
      for (int c = first; c <= last; ++c) {
        double p = 0;
        for (int f = 0; f < k; ++f) p += w[f] * s.features[f][c];
        // Weighted by 1 / (|residual| + 1): about the absolute deviation,
        // which is what the residual coder pays for.
        const double y = s.target[c];
        const double weight = iteration == 0 ? 1.0 : 1.0 / (std::fabs(y - p) + 1.0);
        for (int f = 0; f < k; ++f) {
          for (int g = 0; g < k; ++g) a[f][g] += weight * s.features[f][c] * s.features[g][c];
          b[f] += weight * s.features[f][c] * y;
        }
      }
    }
    for (int f = 0; f < k; ++f) a[f][f] += 1e-9 * (a[f][f] + 1.0);
    w = Solve(a, b, k);
  }
  std::array<int32_t, kPredictorFeatures> out{};
  for (int f = 0; f < k; ++f) {
    const double q = std::round(w[f] * double(1 << kPredictorWeightBits));
    out[f] = static_cast<int32_t>(std::clamp(q, -double(kMaxPredictorWeight), double(kMaxPredictorWeight)));
  }
  return out;
}

}  // namespace

PredictorWeights FitPredictorWeights(const std::vector<PredictorSample>& samples, int features) {
  if (samples.empty()) return kInitialPredictor;
  const int k = std::clamp(features, 1, int{kPredictorFeatures});
  PredictorWeights w;
  w.tangential = FitGroup(samples, 0, 1, k);
  w.normal = FitGroup(samples, 2, 2, k);
  return w;
}

}  // namespace meshstream

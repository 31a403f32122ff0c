#include "bench/service_stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "bench/bench_util.h"

namespace meshstream::bench {

double NearestRank(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0;
  const double n = static_cast<double>(sorted.size());
  size_t rank = static_cast<size_t>(std::ceil(q * n));
  rank = std::max<size_t>(rank, 1);
  return sorted[std::min(rank, sorted.size()) - 1];
}

nlohmann::json LatencySummary(std::vector<double> us) {
  std::sort(us.begin(), us.end());
  nlohmann::json out = {{"n", us.size()}};
  if (us.empty()) return out;
  const double mean = std::accumulate(us.begin(), us.end(), 0.0) / static_cast<double>(us.size());
  out["min_us"] = us.front();
  out["mean_us"] = mean;
  out["p50_us"] = NearestRank(us, 0.50);
  out["p90_us"] = NearestRank(us, 0.90);
  out["p99_us"] = NearestRank(us, 0.99);
  out["p999_us"] = NearestRank(us, 0.999);
  out["max_us"] = us.back();
  // Bucket b holds [2^(b/4), 2^((b+1)/4)) us; values below 1 us go to bucket 0.
  constexpr double kPerOctave = 4.0;
  auto bucket = [](double v) { return v < 1 ? 0 : static_cast<int>(std::floor(std::log2(v) * kPerOctave)); };
  const int first = bucket(us.front()), last = bucket(us.back());
  std::vector<uint64_t> counts(static_cast<size_t>(last - first + 1), 0);
  for (double v : us) ++counts[static_cast<size_t>(bucket(v) - first)];
  std::vector<double> edges;
  for (int b = first; b <= last + 1; ++b) edges.push_back(std::pow(2.0, b / kPerOctave));
  out["histogram"] = {{"edges_us", edges}, {"counts", counts}};
  return out;
}

nlohmann::json RunsSummary(const std::vector<double>& runs_ms) {
  nlohmann::json out = {{"runs_ms", runs_ms}, {"median_ms", Median(runs_ms)}};
  if (!runs_ms.empty()) {
    out["min_ms"] = *std::min_element(runs_ms.begin(), runs_ms.end());
    out["max_ms"] = *std::max_element(runs_ms.begin(), runs_ms.end());
  }
  return out;
}

double MBps(uint64_t bytes, double ms) { return ms > 0 ? static_cast<double>(bytes) / 1e6 / (ms / 1e3) : 0; }

}  // namespace meshstream::bench

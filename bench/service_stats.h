// Statistics of the service benchmark (bench/service/): percentiles of
// recorded latencies, a compact histogram of them, and summaries of a few
// repeated timings, as JSON.
//
// Contract: pure functions of their arguments.
#ifndef MESHSTREAM_BENCH_SERVICE_STATS_H_
#define MESHSTREAM_BENCH_SERVICE_STATS_H_

#include <cstdint>
#include <vector>

#include <nlohmann/json.hpp>

namespace meshstream::bench {

// The nearest-rank q-quantile (q in [0, 1]) of `sorted` (ascending): the
// smallest value with at least q of the values at or below it; 0 when empty.
double NearestRank(const std::vector<double>& sorted, double q);

// Every latency of one measurement (microseconds) summarized: n, min, mean,
// p50, p90, p99, p99.9, max, and a histogram on a log scale (4 buckets per
// octave from 1 us: {"edges_us": [...], "counts": [...]}, only the buckets
// between the first and the last non-empty one) so that the distribution can
// be redrawn without keeping every call.
nlohmann::json LatencySummary(std::vector<double> latencies_us);

// A few repeated timings (ms): {"runs_ms": [...], "median_ms", "min_ms",
// "max_ms"}.
nlohmann::json RunsSummary(const std::vector<double>& runs_ms);

// 10^6 bytes per second of `bytes` in `ms` milliseconds; 0 for no time.
double MBps(uint64_t bytes, double ms);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SERVICE_STATS_H_

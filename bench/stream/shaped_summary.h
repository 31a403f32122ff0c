// The shaped link's summary: per loss, model and kind, the medians over the
// runs (first and full mesh, the distance reached, what the session and the
// server said), and the sessions' ratios to the Draco download.
#ifndef MESHSTREAM_BENCH_STREAM_SHAPED_SUMMARY_H_
#define MESHSTREAM_BENCH_STREAM_SHAPED_SUMMARY_H_

#include <vector>

#include <nlohmann/json.hpp>

#include "bench/stream/models.h"

namespace meshstream::bench::stream {

// The kinds of the shaped link's runs, in the order they take turns.
inline const char* const kShapedKinds[] = {"udp", "tcp_only", "draco_export"};

// Runs (with their "quality") grouped by loss, model and kind: the
// "summary" array, three entries per loss and model.
nlohmann::json ShapedSummary(const std::vector<int>& losses, const std::vector<Model>& models,
                             const nlohmann::json& runs);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_SHAPED_SUMMARY_H_

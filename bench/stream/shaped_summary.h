// The shaped link's summary: per loss, model and kind, the medians over the
// runs (first and full mesh, the distance reached, what the session and the
// server said), and the sessions' ratios to the Draco download.
#ifndef MESHSTREAM_BENCH_STREAM_SHAPED_SUMMARY_H_
#define MESHSTREAM_BENCH_STREAM_SHAPED_SUMMARY_H_

#include <vector>

#include <nlohmann/json.hpp>

#include "bench/stream/models.h"

namespace meshstream::bench::stream {

// The kinds of the shaped link's runs, in the order they take turns:
// udp_no_parity is a UDP session that asks for no parity datagrams
// (OpenRequest.no_parity), the reference for what parity costs in time.
inline const char* const kShapedKinds[] = {"udp", "udp_no_parity", "tcp_only", "draco_export"};
// The view run, for models of the role "large": a udp session opened with a
// camera on one side of the model (OpenRequest.view); its snapshots also
// get the distance of what the camera sees (shaped_distances.h).
inline const char kShapedViewKind[] = "udp_view";

// Runs (with their "quality") grouped by loss, model and kind: the
// "summary" array, one entry per loss, model and kind. The udp entries
// carry "vs_no_parity": issue 27's test of the time parity costs, against
// its bytes at `rate_mbit` (the link's rate).
nlohmann::json ShapedSummary(const std::vector<int>& losses, const std::vector<Model>& models,
                             const nlohmann::json& runs, double rate_mbit);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_SHAPED_SUMMARY_H_

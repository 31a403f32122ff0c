// 1. and 2. of the stream benchmark, on loopback: a server on the store, the
// models ingested; per model and number of concurrent sessions, SDK sessions
// over UDP and over the gRPC stream beside the Draco GLB export of the same
// server, round by round (time to the base and to the full mesh, the
// datagrams lost, what the server logged); then the datagram rate (rate.h).
#ifndef MESHSTREAM_BENCH_STREAM_LOOPBACK_H_
#define MESHSTREAM_BENCH_STREAM_LOOPBACK_H_

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/stream/args.h"
#include "bench/stream/models.h"

namespace meshstream::bench::stream {

// Runs both parts on a server of their own on `store` (stopped before
// returning); ingests `models` (their versions filled); writes "settings",
// "sessions", "draco_reference", "server", "datagram_rate" and, when any,
// "warmup_failures" into *out. Returns the failed sessions and exports.
uint64_t RunLoopbackParts(const Args& args, std::vector<Model>& models, const std::string& store,
                          nlohmann::json* out);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_LOOPBACK_H_

// The service benchmark's latencies: GetVersion and ListVersions (page_size
// 50 over an asset with --versions versions) and the health Check with 1,
// 10 and 100 concurrent clients beside an echo of the trivial server,
// measured the same way in the same rounds (bench/service_load.h); and the
// ratios to that floor.
#ifndef MESHSTREAM_BENCH_SERVICE_LATENCY_H_
#define MESHSTREAM_BENCH_SERVICE_LATENCY_H_

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/service/args.h"
#include "bench/service/backend.h"
#include "bench/service/models.h"

namespace meshstream::bench::service {

// Makes the latency asset on every backend (--versions ingests of `spot`),
// then runs every target at every --clients: the "latency" array.
nlohmann::json MeasureLatency(const Args& args, const std::vector<Backend*>& backends, const Model& spot,
                              const std::string& echo_address);

// Ratios to the echo floor, at each client count: the "ratios" array.
nlohmann::json RatiosToEcho(const Args& args, const nlohmann::json& latency);

}  // namespace meshstream::bench::service

#endif  // MESHSTREAM_BENCH_SERVICE_LATENCY_H_

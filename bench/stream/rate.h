// 2. of the stream benchmark: the server's DATA datagrams per second (wall
// and per CPU-second) with N UDP sessions at a time, session after session,
// their clients in a child process (this program with --rate-client) so
// that the server's process CPU is the server's alone; beside the loopback
// limit, a tight sendmmsg loop between two sockets on 127.0.0.1, measured
// before and after.
#ifndef MESHSTREAM_BENCH_STREAM_RATE_H_
#define MESHSTREAM_BENCH_STREAM_RATE_H_

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/stream/args.h"
#include "bench/stream/models.h"

namespace meshstream::bench::stream {

// The child's main: --rate-client ADDRESS ASSET VERSION SESSIONS SECONDS
// TIMEOUT_S. N threads open UDP session after session for SECONDS; prints
// "start" when they are released, "end" when the last has finished, then
// one JSON line.
int RateClientMain(int argc, char** argv);

// The datagram rate (of the largest model, on a server of its own with
// --rate-bps on `store`) and the loopback limit before and after: the
// object of "datagram_rate". Adds the failed sessions to *failures.
nlohmann::json RunDatagramRate(const Args& args, const std::vector<Model>& models, const std::string& store,
                               uint64_t* failures);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_RATE_H_

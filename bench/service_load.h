// Concurrent unary calls for the latency figures of the service benchmark
// (bench/service/latency.cc): K client threads, each with its own channel (its own
// TCP connection: a local subchannel pool, so channels to one address do
// not share a connection), each issuing N calls back-to-back after a few
// untimed warm-up calls; every call's latency is recorded.
//
// Every target is called the same way, through grpc::GenericStub with
// serialized request bytes (PrepareUnaryCall on the client thread's own
// completion queue, waited for like a blocking stub waits): the echo floor,
// the health check and the AssetService calls differ only in what the
// server does and in the bytes. A call's latency runs from preparing the
// call to its response checked (`check`, which parses it): what a client
// waits for. A call that fails (a status other than OK, or a response the
// check refuses) is counted and its first message kept; it is never timed.
//
// Thread safety: RunLoad starts and joins its threads; `check` is called
// from all of them at once.
#ifndef MESHSTREAM_BENCH_SERVICE_LOAD_H_
#define MESHSTREAM_BENCH_SERVICE_LOAD_H_

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace meshstream::bench {

struct UnaryTarget {
  std::string address;                 // host:port
  std::string method;                  // "/package.Service/Method"
  std::vector<std::string> requests;   // serialized; call j of client c sends requests[(c + j) % size]
  // "" when `response` is right for requests[index]; otherwise what is wrong.
  std::function<std::string(size_t index, const std::string& response)> check;
};

struct LoadResult {
  int clients = 0;
  int calls_per_client = 0;
  std::vector<double> latencies_us;  // the successful calls, all clients
  uint64_t failed = 0;
  std::string first_error;
  double wall_s = 0;                 // from the start signal to the last call's end
  uint64_t warmup_failed = 0;
  // CPU from the start signal until every client is done (SampleCpu).
  double process_cpu_s = 0;
  uint64_t machine_busy = 0, machine_total = 0;
};

LoadResult RunLoad(const UnaryTarget& target, int clients, int calls_per_client, int warmup_calls);

// CPU time so far: this process's (user + system, every thread: clients and
// in-process servers) and the machine's busy and total jiffies from
// /proc/stat (every process: also PostgreSQL's backends and other users).
struct CpuSample {
  double process_s = 0;
  uint64_t machine_busy = 0, machine_total = 0;
};
CpuSample SampleCpu();

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SERVICE_LOAD_H_

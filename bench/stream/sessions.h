// The stream benchmark's clients on loopback: one SDK session (UDP or
// tcp_only) or one Draco GLB export to its end, timed; a round of n of them
// released together on threads of this process; and the counters around
// them (the kernel's UDP counters, a thread's CPU).
//
// Thread safety: RunSession and RunExport run on the calling thread with
// their own client; RunRound starts and joins its own threads.
#ifndef MESHSTREAM_BENCH_STREAM_SESSIONS_H_
#define MESHSTREAM_BENCH_STREAM_SESSIONS_H_

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/harness.h"
#include "bench/service_load.h"
#include "bench/stream/models.h"
#include "sdk/client.h"
#include "sdk/session.h"

namespace meshstream::bench::stream {

// The kernel's UDP counters of this network namespace (/proc/net/snmp,
// "Udp:"): every UDP socket of the machine's namespace, so the benchmark's
// own; a delta says how many datagrams the kernel dropped, and why.
std::map<std::string, uint64_t> KernelUdp();
nlohmann::json KernelUdpDelta(const std::map<std::string, uint64_t>& before,
                              const std::map<std::string, uint64_t>& after);

// The CPU seconds of the calling thread.
double ThreadCpuS();

// Releases every waiting thread at once, when the main thread says so.
class StartGate {
 public:
  void Arrive();
  void OpenWhen(int n);

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  int arrived_ = 0;
  bool open_ = false;
};

enum class Kind { kUdp, kTcp, kDraco };
const char* KindName(Kind k);

struct Outcome {
  bool ok = false;
  std::string error;
  double base_ms = 0;  // sessions: time_to_base_ms
  double full_ms = 0;  // sessions: time_to_full_ms; exports: request until the last byte
  double wall_ms = 0;  // measured here: before Open (or the export call) until kComplete (the last chunk)
  double thread_cpu_s = 0;  // CPU of the calling thread (the SDK decodes there)
  sdk::SessionStats stats;
  int32_t level = 0, levels = 0;
  uint64_t predicted_vertices = 0;  // at kComplete: vertices whose value was predicted, not decoded
  uint64_t bytes = 0;
};

// Why a session that reached kComplete did not end well: "kComplete
// without kBaseReady" (`based`: kBaseReady came first), or "kComplete at
// level L of N (end reason '...')" short of the full mesh; "" when it did.
std::string SessionEndError(const sdk::Session& s, bool based);

// What a session not complete after `timeout_s` seconds says: "not
// complete after T s (level L)".
std::string SessionTimeoutError(const sdk::Session& s, double timeout_s);

// One SDK session of `m` to kComplete; `client` made before the clock
// starts. Not ok when it ends in kError, short of the full mesh or after
// `timeout_s`.
Outcome RunSession(const sdk::Client& client, const Model& m, bool tcp_only, double timeout_s);

// One export of the version as FORMAT_DRACO_GLB until the last chunk, its
// bytes checked against the SHA-256 the server sent (by the client library,
// inside the clock) and against `expect_sha256` when not empty.
Outcome RunExport(AssetApi& api, const Model& m, const std::string& expect_sha256);

struct Round {
  std::vector<Outcome> outcomes;
  double wall_s = 0;
  CpuSample cpu_before, cpu_after;
  std::map<std::string, uint64_t> udp_before, udp_after;
  double client_cpu_s = 0;  // a round run in the clients' process (round_client.h): that process's CPU
};

// `n` threads, each running one session (or export) of `kind` on `m`, all
// released together; `on_release` (when set) is called as they are, before
// the clock and the CPU samples start.
Round RunRound(Kind kind, int n, const std::string& address, const Model& m, const std::string& draco_sha256,
               double timeout_s, const std::function<void()>& on_release = nullptr);

// p50, p90, p99 (nearest rank), mean, min, max of `v` (ms).
nlohmann::json MsSummary(std::vector<double> v);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_SESSIONS_H_

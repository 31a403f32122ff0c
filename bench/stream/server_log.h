// The stream benchmark's servers: their options (bench/harness.h's, with the
// log into a ServerLog) and their log lines, parsed as they come: what each
// "session ... ended" line says of a session's end, rate and RTT.
//
// Thread safety: ServerLog's methods may be called from any thread (the
// server logs from its own).
#ifndef MESHSTREAM_BENCH_STREAM_SERVER_LOG_H_
#define MESHSTREAM_BENCH_STREAM_SERVER_LOG_H_

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/stream/args.h"
#include "services/server/server.h"

namespace meshstream::bench::stream {

// "session ASSET@V ended (REASON): TRANSPORT, N datagrams sent, R reports,
// M missing, rate X Mbit/s, D decreases, srtt S ms, ..., open to base T ms"
// (the last field only when the session's SessionStart was handed to gRPC).
struct SessionLogLine {
  std::string asset, reason, transport;
  uint64_t datagrams_sent = 0, reports = 0, missing = 0;
  double rate_mbps = 0, srtt_ms = 0;
  double open_to_base_ms = -1;  // the server's own time from the Open to the base meshes handed to gRPC; < 0: none
  unsigned decreases = 0;
};

class ServerLog {
 public:
  explicit ServerLog(bool verbose) : verbose_(verbose) {}

  // One line of the server's (echoed on stderr when verbose).
  void Add(const std::string& line);
  size_t line_count();
  size_t session_count();
  // Waits (at most `timeout`) until at least `n` session lines were logged.
  bool WaitSessions(size_t n, std::chrono::milliseconds timeout);
  std::vector<SessionLogLine> SessionsFrom(size_t first);
  // The last "udp: " line (the UDP endpoint's totals, logged when the
  // server stops) from line `first` on; "" when there is none.
  std::string UdpTotalsFrom(size_t first);
  // At most `limit` lines that are neither a session that completed nor
  // the start-up lines.
  nlohmann::json Notable(size_t limit);

 private:
  std::mutex mutex_;
  std::condition_variable session_added_;  // notified when a session line is added
  std::vector<std::string> lines_;
  std::vector<SessionLogLine> sessions_;
  const bool verbose_;
};

// BenchServerOptions with --workers, server_id "bench-stream" and the log
// into `log` (which outlives the server).
ServerOptions StreamServerOptions(const Args& args, const std::string& store, ServerLog* log);

// Stops `server` and returns the UDP totals line it logged on the way out.
std::string StopAndTakeUdpTotals(std::unique_ptr<Server>& server, ServerLog& log);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_SERVER_LOG_H_

// The latency rows' clients in a process of their own (this program with
// --round-client ADDRESS), so that the server's process runs only the server
// and its CPU is the server's: the parent sends one round per line on the
// child's stdin, the child runs it (RunRound: n sessions or exports released
// together, each on its own thread) and answers on stdout "start" when the
// round's threads are released, then one JSON line with every outcome.
//
// Thread safety: a RoundClient is used by one thread.
#ifndef MESHSTREAM_BENCH_STREAM_ROUND_CLIENT_H_
#define MESHSTREAM_BENCH_STREAM_ROUND_CLIENT_H_

#include <string>

#include "bench/stream/child.h"
#include "bench/stream/models.h"
#include "bench/stream/sessions.h"

namespace meshstream::bench::stream {

// The child's main: --round-client ADDRESS; rounds until stdin closes.
int RoundClientMain(int argc, char** argv);

// The parent's side: the child process and its rounds.
class RoundClient {
 public:
  // The child at niceness `nice` (--client-nice).
  RoundClient(const std::string& address, int nice);
  ~RoundClient();

  // One round in the child. The Round's CPU samples (cpu_before,
  // cpu_after) and the kernel's UDP counters are this process's, taken when
  // the child said "start" and when its answer came; `client_cpu_s` is the
  // child's process CPU over the round.
  Round Run(Kind kind, int n, const Model& m, const std::string& draco_sha256, double timeout_s);

 private:
  ChildProcess child_;
};

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_ROUND_CLIENT_H_

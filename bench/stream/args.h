// The options of meshstream_bench_stream (--help lists them) and what
// --quick changes.
#ifndef MESHSTREAM_BENCH_STREAM_ARGS_H_
#define MESHSTREAM_BENCH_STREAM_ARGS_H_

#include <cstdint>
#include <string>
#include <vector>

namespace meshstream::bench::stream {

struct Args {
  std::string models_dir = MESHSTREAM_MODELS_DIR;
  std::vector<std::string> only;
  std::vector<int> concurrency = {1, 10, 100};
  int samples = 200;
  int min_rounds = 3;
  int largest_rounds_at_100 = 2;
  int rate_sessions = 10;
  double rate_seconds = 4;
  double rate_bps = 1e10;
  double loopback_seconds = 2;
  double session_timeout_s = 120;
  int workers = 2;
  int client_nice = 0;  // niceness of the clients' processes (round_client.h, the rate run's)
  std::string work_dir;
  bool quick = false;
  bool verbose = false;
  // 3. the shaped, lossy link
  bool shaped = true;
  bool only_shaped = false;
  int shaped_runs = 5;
  double shaped_rate_mbit = 20;
  double shaped_delay_ms = 20;
  std::vector<int> shaped_losses = {0, 2, 5, 12};
  int shaped_snapshots = 12;
  int64_t shaped_samples = 200000;
  double shaped_timeout_s = 60;
  bool shaped_udp_only_loss = false;
  // The large model of the race (the bunny subdivided twice, 557 k vertices,
  // each new vertex moved by up to a grid step of qp 11 per axis), made by
  // the benchmark into the work folder; its role "large".
  bool shaped_large = false;
  std::string out = std::string(MESHSTREAM_SOURCE_DIR) + "/docs/results/bench/stream.json";
};

// The options of argv (Die on a bad one, exit 0 after --help), --quick's
// defaults applied to what was not given, the work folder resolved.
Args ParseArgs(int argc, char** argv);

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_ARGS_H_

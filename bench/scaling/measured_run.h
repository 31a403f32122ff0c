// One command as a child process, measured by the kernel: wall time, CPU
// time (user + system) and peak resident memory (wait4's ru_maxrss), for
// the encoder's scaling benchmark. The child's stdout is kept, its stderr
// discarded.
#ifndef MESHSTREAM_BENCH_SCALING_MEASURED_RUN_H_
#define MESHSTREAM_BENCH_SCALING_MEASURED_RUN_H_

#include <cstdint>
#include <string>
#include <vector>

namespace meshstream::bench {

struct MeasuredRun {
  int exit_code = -1;  // -1: it could not start or did not exit normally
  double wall_s = 0;
  double cpu_s = 0;
  uint64_t peak_rss_bytes = 0;
  std::string out;
};

MeasuredRun RunMeasured(const std::vector<std::string>& argv);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SCALING_MEASURED_RUN_H_

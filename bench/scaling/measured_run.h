// One command as a child process, measured by the kernel: wall time, CPU
// time (user + system) and peak resident memory (wait4's ru_maxrss), for
// the scaling benchmark. The child's stdout is kept, its stderr discarded.
//
// Linux carries a process's peak resident memory across exec, and a child
// starts with its parent's: a command spawned by the benchmark itself (which
// holds the subdivided meshes) would report at least the benchmark's own
// peak. So the commands are spawned by a small process forked before the
// benchmark allocates anything (StartSpawner), whose peak is a few MB.
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

// Forks the spawner; call first thing in main. Without it RunMeasured
// spawns the command itself (its peak then includes the caller's).
void StartSpawner();

MeasuredRun RunMeasured(const std::vector<std::string>& argv);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SCALING_MEASURED_RUN_H_

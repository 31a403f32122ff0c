// What /proc/<pid>/status says of a process: its threads and its resident
// memory, for tests that watch what a server holds (the saturation and
// fault tests of tests/integration/).
#ifndef MESHSTREAM_TESTING_PROC_STATUS_H_
#define MESHSTREAM_TESTING_PROC_STATUS_H_

#include <sys/types.h>

#include <cstdint>
#include <fstream>
#include <string>

namespace meshstream::test_util {

struct ProcStatus {
  int64_t threads = -1;  // "Threads:"
  int64_t rss_kib = -1;  // "VmRSS:", KiB
  int64_t peak_rss_kib = -1;  // "VmHWM:", KiB: the most it held since its exec
};

// The status of `pid`; -1 for a field the file does not have (or a process
// that is gone).
inline ProcStatus ReadProcStatus(pid_t pid) {
  ProcStatus s;
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (in >> key) {
    if (key == "VmRSS:") in >> s.rss_kib;
    if (key == "VmHWM:") in >> s.peak_rss_kib;
    if (key == "Threads:") in >> s.threads;
    std::getline(in, key);
  }
  return s;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_PROC_STATUS_H_

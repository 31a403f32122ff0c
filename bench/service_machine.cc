#include "bench/service_machine.h"

#include <sqlite3.h>

#include <thread>

#include <google/protobuf/stubs/common.h>
#include <grpcpp/grpcpp.h>

#include "bench/bench_util.h"

namespace meshstream::bench {

nlohmann::json ServiceMachineInfo(const std::string& work_dir, const std::string& source_dir,
                                  const std::string& build_type) {
  nlohmann::json m = {
      {"nproc", std::thread::hardware_concurrency()},
      {"cpu", CpuModel()},
      {"date", UtcNow()},
      {"kernel", KernelName()},
      {"loadavg_at_start", LoadAverage()},
      {"compiler", __VERSION__},
      {"build_type", build_type},
      {"grpc", grpc::Version()},
      {"protobuf", google::protobuf::internal::VersionString(GOOGLE_PROTOBUF_VERSION)},
      {"sqlite", sqlite3_libversion()},
      {"work_dir", work_dir},
      {"work_dir_filesystem", FirstLineOf("findmnt -n -o FSTYPE,SOURCE --target " + ShellQuote(work_dir) +
                                          " 2>/dev/null")},
  };
  const std::string commit = GitShortCommit(source_dir);
  if (!commit.empty()) {
    const std::string dirty = FirstLineOf("git -C " + ShellQuote(source_dir) +
                                          " status --porcelain --untracked-files=no 2>/dev/null");
    m["git_commit"] = commit + (dirty.empty() ? "" : " (with uncommitted changes)");
  }
  return m;
}

}  // namespace meshstream::bench

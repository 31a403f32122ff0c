// The options of meshstream_bench_service (--help lists them) and what
// --quick changes.
#ifndef MESHSTREAM_BENCH_SERVICE_ARGS_H_
#define MESHSTREAM_BENCH_SERVICE_ARGS_H_

#include <string>
#include <vector>

namespace meshstream::bench::service {

struct Args {
  std::string models_dir = MESHSTREAM_MODELS_DIR;
  std::vector<std::string> only;
  std::vector<std::string> backends = {"sqlite", "postgresql"};
  int repeat = 5;
  int resumable_repeat = 3;
  int cache_repeat = 3;
  std::vector<int> clients = {1, 10, 100};
  int calls = 4000;
  int min_calls = 20;
  int rounds = 2;
  int versions = 100;
  int workers = 2;
  std::string work_dir;
  bool pg_fsync = true;
  bool quick = false;
  bool verbose = false;
  std::string out = std::string(MESHSTREAM_SOURCE_DIR) + "/docs/results/bench/service.json";
};

// The options of argv (Die on a bad one, exit 0 after --help), --quick's
// defaults applied to what was not given, the work folder resolved.
Args ParseArgs(int argc, char** argv);

}  // namespace meshstream::bench::service

#endif  // MESHSTREAM_BENCH_SERVICE_ARGS_H_

// What the service and stream benchmarks record about the machine and the
// build of a run: cores, CPU, date, kernel, load, compiler, build type, the
// gRPC, protobuf and SQLite versions, the work folder's filesystem and the
// source's commit (marked when it has uncommitted changes).
#ifndef MESHSTREAM_BENCH_SERVICE_MACHINE_H_
#define MESHSTREAM_BENCH_SERVICE_MACHINE_H_

#include <string>

#include <nlohmann/json.hpp>

namespace meshstream::bench {

nlohmann::json ServiceMachineInfo(const std::string& work_dir, const std::string& source_dir,
                                  const std::string& build_type);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_SERVICE_MACHINE_H_

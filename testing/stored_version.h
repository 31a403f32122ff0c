// A READY version in a store, made the way the server makes one: the file's
// bytes as a blob, CreateVersion, and the real worker pool (import, encode,
// artifact) until the job ends. For tests and benchmarks that call the
// library (routes, the session host) without a server process.
//
// Contract: `store` is open; the version is the asset's next. Returns the
// READY version, or the job's failure (FailedPrecondition naming it), or
// DeadlineExceeded when the job has not ended within `timeout` (a bound on
// a broken pipeline, never a verdict: an encode takes what it takes).
#ifndef MESHSTREAM_TESTING_STORED_VERSION_H_
#define MESHSTREAM_TESTING_STORED_VERSION_H_

#include <chrono>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "codec/core/status.h"
#include "services/jobs/worker_pool.h"
#include "services/store/store.h"

namespace meshstream::test_util {

inline StatusOr<VersionRecord> StoreReadyVersion(Store& store, const std::string& tenant, const std::string& asset,
                                                 const std::string& filename, const std::vector<uint8_t>& bytes,
                                                 const std::string& work_dir, const std::string& options_json = "{}",
                                                 std::chrono::seconds timeout = std::chrono::seconds(600)) {
  MS_ASSIGN_OR_RETURN(auto sink, store.NewBlob());
  MS_RETURN_IF_ERROR(sink->Append(bytes.data(), bytes.size()));
  MS_ASSIGN_OR_RETURN(const std::string sha256, sink->Commit());
  NewVersion v;
  v.tenant = tenant;
  v.asset = asset;
  v.source = SourceFile{filename, sha256, bytes.size()};
  v.options_json = options_json;
  MS_ASSIGN_OR_RETURN(const VersionRecord created, store.CreateVersion(v));
  WorkerPoolOptions o;
  o.workers = 1;
  o.worker_id_prefix = "stored-version";
  o.poll_interval_ms = 5;
  o.work_dir = work_dir;
  WorkerPool pool(store, o);
  MS_RETURN_IF_ERROR(pool.Start());
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    MS_ASSIGN_OR_RETURN(VersionRecord now, store.GetVersion(tenant, asset, created.version));
    if (now.state == VersionState::kReady) {
      pool.Stop();
      return now;
    }
    if (now.state == VersionState::kFailed) {
      pool.Stop();
      return FailedPrecondition("asset " + asset + " version " + std::to_string(created.version) +
                                " FAILED: " + now.error);
    }
    if (std::chrono::steady_clock::now() > deadline) {
      pool.Stop();
      return DeadlineExceeded("asset " + asset + ": the job has not ended");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_STORED_VERSION_H_

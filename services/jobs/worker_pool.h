// The workers of one server: they claim processing jobs from the Store,
// run the pipeline on each (services/pipeline/), and record the result.
//
// Per claimed job (docs/design/pipeline.md, "The job"):
//   1. GetVersion; the options from its options_json; the artifact cache key.
//   2. FindArtifact: a cached artifact (whose blob exists) completes the job
//      at once, with the message "reused the artifact of an identical source
//      and options" and no encode (counted in cache_hits).
//   3. Otherwise: MaterializeVersion into a private work folder,
//      ProcessSource, the .glb into a blob (NewBlob, checked against its
//      digest), PutArtifact, CompleteJob.
// While a job runs, a heartbeat renews its lease every heartbeat_ms
// (lease_ms / 3 by default) with the latest progress, and sooner, at most
// every progress_interval_ms, when the progress moved.
//
// Failures: anything wrong with the source or its options (an import error,
// a bad name, a corrupt blob) fails the job with the importer's message
// (FailJob); so does any exception, std::bad_alloc included, thrown while
// processing it: the pool never dies from a bad file. A store that is
// unavailable (Unavailable, IoError), or a std::system_error (no thread),
// leaves the job to its lease (it expires and the job is claimed
// again); a job claimed more than max_attempts times fails with a message
// saying so, so that a file that kills its server is not retried forever.
// Aborted from RenewLease, CompleteJob or FailJob means another worker holds
// the job: this one stops working on it quietly (counted in lost_leases).
//
// Lifetime and threads: Start() starts `workers` threads, each with its own
// worker id "<worker_id_prefix>/<n>" (the lease owner). Drain(deadline)
// stops claiming and waits for the running jobs until the deadline, then
// abandons the rest: their threads stop at the next cancellation point (an
// encoder batch, a stage) without touching the store again, and their
// leases expire so another server, or this one after a restart, takes them
// over. Stop() drains with an immediate deadline and joins every thread (it
// waits for abandoned jobs to reach their cancellation point; an import is
// not interruptible). The Store must outlive the pool; the destructor stops.
// Thread safety: every method may be called from any thread.
#ifndef MESHSTREAM_SERVICES_JOBS_WORKER_POOL_H_
#define MESHSTREAM_SERVICES_JOBS_WORKER_POOL_H_

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "codec/core/status.h"
#include "importers/import.h"
#include "services/pipeline/encode_options.h"
#include "services/store/store.h"

namespace meshstream {

struct WorkerPoolOptions {
  int workers = static_cast<int>(std::thread::hardware_concurrency());  // < 1: one
  // Threads each job encodes its streams on (primitives and spatial parts;
  // the artifact does not depend on the count); < 2: the worker's own.
  int encode_threads = 1;
  std::string worker_id_prefix = "meshstream";  // the server's id
  int64_t lease_ms = 30000;
  int64_t heartbeat_ms = 0;             // 0: lease_ms / 3
  int64_t poll_interval_ms = 200;       // idle workers poll this often (Wake() at once)
  int64_t progress_interval_ms = 1000;  // progress renewals at most this often
  uint64_t max_source_bytes = kDefaultMaxInputBytes;  // main file and resources together
  int32_t max_attempts = 3;
  std::string work_dir;                 // parent of the work folders ("": $TMPDIR or /tmp)
};

// A snapshot of the pool's counters, for logs and tests.
struct WorkerPoolCounters {
  uint64_t claimed = 0;
  uint64_t succeeded = 0;    // completed, cache hits included
  uint64_t failed = 0;       // FailJob recorded
  uint64_t cache_hits = 0;
  uint64_t lost_leases = 0;  // another worker took the job
  uint64_t abandoned = 0;    // left to their lease by Drain/Stop, or by a store error
  uint64_t store_errors = 0; // store calls that failed (other than Aborted), and system errors
};

// The message of a job completed from the artifact cache.
constexpr char kReusedArtifactMessage[] = "reused the artifact of an identical source and options";

class WorkerPool {
 public:
  WorkerPool(Store& store, WorkerPoolOptions options);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Starts the workers; FailedPrecondition when started before.
  Status Start();
  // Idle workers poll at once (after an ingest).
  void Wake();
  // Stops claiming; waits for running jobs until `deadline`, then abandons
  // them. Returns how many were abandoned. Returns by the deadline.
  int64_t Drain(std::chrono::steady_clock::time_point deadline);
  // Drain(now), then joins the workers.
  void Stop();

  WorkerPoolCounters counters() const;
  uint64_t cache_hits() const { return cache_hits_.load(); }
  // Jobs being processed now.
  int running_jobs() const;
  const WorkerPoolOptions& options() const { return options_; }

 private:
  struct JobRun;
  enum class Outcome;

  void WorkerLoop(int index);
  void RunJob(JobRun& run);
  Outcome ProcessJob(JobRun& run);
  Outcome ProcessFully(JobRun& run, const VersionRecord& version, const std::string& cache_key,
                       const EncodeSettings& settings);
  // Materialize, process, store the blob and the cache row (heartbeat running).
  StatusOr<ArtifactSummary> Produce(JobRun& run, const VersionRecord& version, const std::string& cache_key,
                                    const EncodeSettings& settings, bool* transient);
  Outcome Finish(JobRun& run, const ArtifactSummary& summary, const std::string& message);
  Outcome Fail(JobRun& run, const std::string& message);
  Outcome OnStoreError(const Status& status);
  void MarkLost(JobRun& run);
  void Heartbeat(JobRun& run);

  Store& store_;
  const WorkerPoolOptions options_;
  const int64_t heartbeat_ms_;

  mutable std::mutex mu_;
  std::condition_variable wake_cv_;  // idle workers
  std::condition_variable idle_cv_;  // Drain: busy_ reached 0
  uint64_t wake_generation_ = 0;
  bool started_ = false;
  bool draining_ = false;
  bool gave_up_ = false;             // a Drain passed its deadline: abandon what is claimed
  int busy_ = 0;                     // workers claiming or running a job
  std::set<JobRun*> running_;
  std::vector<std::thread> threads_;

  std::atomic<uint64_t> claimed_{0}, succeeded_{0}, failed_{0}, cache_hits_{0}, lost_leases_{0}, abandoned_{0},
      store_errors_{0};
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_JOBS_WORKER_POOL_H_

#include "services/jobs/worker_pool.h"

#include <algorithm>
#include <exception>
#include <memory>
#include <new>
#include <system_error>

#include "parallel/fork_join_pool.h"
#include "services/pipeline/materialize.h"
#include "services/pipeline/process_source.h"

namespace meshstream {

namespace {

using Clock = std::chrono::steady_clock;

constexpr size_t kBlobChunkBytes = size_t{1} << 20;
// Progress of the stages around ProcessSource (which reports 0 .. 0.95).
constexpr double kStoringProgress = 0.96;

// Errors of the store or the machine (not of the source): the job is left to
// its lease and tried again.
bool IsTransient(const Status& s) {
  return s.code() == StatusCode::kUnavailable || s.code() == StatusCode::kIoError;
}

}  // namespace

struct WorkerPool::JobRun {
  JobRecord job;
  std::string worker;
  std::atomic<bool> lost{false};       // another worker holds the lease
  std::atomic<bool> abandoned{false};  // Drain/Stop gave up on it
  // The heartbeat's state, under `mu`.
  std::mutex mu;
  std::condition_variable cv;
  bool heartbeat_stop = false;
  double progress = 0.0;
  std::string stage;
  bool dirty = false;

  bool cancelled() const { return lost.load() || abandoned.load(); }
};

enum class WorkerPool::Outcome { kSucceeded, kCacheHit, kFailed, kLost, kAbandoned, kLeftToLease };

WorkerPool::WorkerPool(Store& store, WorkerPoolOptions options)
    : store_(store),
      options_(std::move(options)),
      heartbeat_ms_(std::max<int64_t>(1, options_.heartbeat_ms > 0 ? options_.heartbeat_ms : options_.lease_ms / 3)) {}

WorkerPool::~WorkerPool() { Stop(); }

Status WorkerPool::Start() {
  std::unique_lock<std::mutex> lock(mu_);
  if (started_) return FailedPrecondition("worker pool: already started");
  started_ = true;
  const int n = std::max(1, options_.workers);
  try {
    for (int i = 0; i < n; ++i) threads_.emplace_back([this, i] { WorkerLoop(i); });
  } catch (const std::system_error& e) {
    draining_ = true;
    wake_cv_.notify_all();
    std::vector<std::thread> started;
    started.swap(threads_);
    lock.unlock();
    for (std::thread& t : started) t.join();
    return ResourceExhausted(std::string("worker pool: cannot start its threads: ") + e.what());
  }
  return Status::Ok();
}

void WorkerPool::Wake() {
  std::lock_guard<std::mutex> lock(mu_);
  ++wake_generation_;
  wake_cv_.notify_all();
}

int64_t WorkerPool::Drain(Clock::time_point deadline) {
  std::unique_lock<std::mutex> lock(mu_);
  draining_ = true;
  wake_cv_.notify_all();
  if (!idle_cv_.wait_until(lock, deadline, [this] { return busy_ == 0; })) gave_up_ = true;
  int64_t abandoned = 0;
  for (JobRun* run : running_) {
    std::lock_guard<std::mutex> run_lock(run->mu);
    if (!run->abandoned.exchange(true)) ++abandoned;
    run->cv.notify_all();
  }
  return abandoned;
}

void WorkerPool::Stop() {
  Drain(Clock::now());
  std::vector<std::thread> threads;
  {
    std::lock_guard<std::mutex> lock(mu_);
    threads.swap(threads_);
  }
  for (std::thread& t : threads) t.join();
}

WorkerPoolCounters WorkerPool::counters() const {
  WorkerPoolCounters c;
  c.claimed = claimed_.load();
  c.succeeded = succeeded_.load();
  c.failed = failed_.load();
  c.cache_hits = cache_hits_.load();
  c.lost_leases = lost_leases_.load();
  c.abandoned = abandoned_.load();
  c.store_errors = store_errors_.load();
  return c;
}

int WorkerPool::running_jobs() const {
  std::lock_guard<std::mutex> lock(mu_);
  return static_cast<int>(running_.size());
}

void WorkerPool::WorkerLoop(int index) {
  const std::string worker = options_.worker_id_prefix + "/" + std::to_string(index);
  while (true) {
    uint64_t generation = 0;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (draining_) break;
      ++busy_;
      generation = wake_generation_;
    }
    bool worked = false;
    try {
      StatusOr<std::optional<JobRecord>> claim = store_.ClaimJob(worker, NowMs(), options_.lease_ms);
      if (!claim.ok()) {
        ++store_errors_;
      } else if (claim->has_value()) {
        worked = true;
        ++claimed_;
        JobRun run;
        run.job = std::move(**claim);
        run.worker = worker;
        // Listed for Drain while it runs, unlisted however this scope is left.
        struct Listed {
          WorkerPool& pool;
          JobRun& run;
          ~Listed() {
            std::lock_guard<std::mutex> lock(pool.mu_);
            pool.running_.erase(&run);
          }
        };
        {
          std::lock_guard<std::mutex> lock(mu_);
          running_.insert(&run);
          // Claimed while a drain gave up: leave it to its lease at once.
          if (gave_up_) run.abandoned = true;
        }
        const Listed listed{*this, run};
        RunJob(run);
      }
    } catch (...) {
      // A store that throws; RunJob itself catches everything of a job.
      ++store_errors_;
    }
    std::unique_lock<std::mutex> lock(mu_);
    if (--busy_ == 0) idle_cv_.notify_all();
    if (!worked && !draining_) {
      wake_cv_.wait_for(lock, std::chrono::milliseconds(std::max<int64_t>(1, options_.poll_interval_ms)),
                        [&] { return draining_ || wake_generation_ != generation; });
    }
  }
}

void WorkerPool::MarkLost(JobRun& run) {
  if (!run.lost.exchange(true)) ++lost_leases_;
}

void WorkerPool::RunJob(JobRun& run) {
  Outcome outcome = Outcome::kLeftToLease;
  auto fail_safely = [&](const std::string& message) {
    try {
      return Fail(run, message);
    } catch (...) {
      ++store_errors_;
      return Outcome::kLeftToLease;
    }
  };
  try {
    outcome = ProcessJob(run);
  } catch (const std::system_error&) {
    // No thread for the heartbeat, say: the machine's trouble, not the
    // source's. Left to its lease and tried again (max_attempts bounds it).
    outcome = Outcome::kLeftToLease;
    ++store_errors_;
  } catch (const std::bad_alloc&) {
    outcome = fail_safely("out of memory while processing the source");
  } catch (const std::exception& e) {
    outcome = fail_safely(std::string("internal error: ") + e.what());
  } catch (...) {
    outcome = fail_safely("internal error: unknown exception");
  }
  switch (outcome) {
    case Outcome::kSucceeded:
      ++succeeded_;
      break;
    case Outcome::kCacheHit:
      ++succeeded_;
      ++cache_hits_;
      break;
    case Outcome::kFailed:
      ++failed_;
      break;
    case Outcome::kLost:
      MarkLost(run);
      break;
    case Outcome::kAbandoned:
    case Outcome::kLeftToLease:
      ++abandoned_;
      break;
  }
}

WorkerPool::Outcome WorkerPool::ProcessJob(JobRun& run) {
  if (run.abandoned) return Outcome::kAbandoned;
  const JobRecord& job = run.job;
  if (job.attempts > options_.max_attempts) {
    return Fail(run, "gave up after " + std::to_string(job.attempts - 1) +
                         " attempts: the servers processing this job stopped before finishing it");
  }
  StatusOr<VersionRecord> version = store_.GetVersion(job.tenant, job.asset, job.version);
  if (!version.ok()) {
    if (IsTransient(version.status())) return OnStoreError(version.status());
    return Fail(run, "version: " + version.status().message());
  }
  StatusOr<EncodeSettings> settings = ParseSettingsJson(version->options_json);
  if (!settings.ok()) return Fail(run, settings.status().message());
  const std::string key = ArtifactCacheKey(version->tenant, version->source, version->resources, settings.value());

  StatusOr<std::optional<ArtifactSummary>> cached = store_.FindArtifact(key);
  if (!cached.ok()) {
    ++store_errors_;  // the cache is an optimization: encode
  } else if (cached->has_value()) {
    StatusOr<bool> present = store_.HasBlob((*cached)->artifact_sha256);
    if (present.ok() && present.value()) {
      const Outcome o = Finish(run, **cached, kReusedArtifactMessage);
      return o == Outcome::kSucceeded ? Outcome::kCacheHit : o;
    }
    if (!present.ok()) ++store_errors_;
  }
  return ProcessFully(run, version.value(), key, settings.value());
}

WorkerPool::Outcome WorkerPool::ProcessFully(JobRun& run, const VersionRecord& version, const std::string& cache_key,
                                             const EncodeSettings& settings) {
  if (run.abandoned) return Outcome::kAbandoned;
  bool transient = false;
  StatusOr<ArtifactSummary> produced = InvalidInput("not processed");
  {
    {
      std::lock_guard<std::mutex> lock(run.mu);
      run.progress = 0.0;
      run.stage = "materializing the source";
      run.heartbeat_stop = false;
    }
    std::thread heartbeat([this, &run] { Heartbeat(run); });
    // Joins the heartbeat however this scope is left, before the job is
    // completed or failed (so no renewal follows them).
    struct Joiner {
      JobRun& run;
      std::thread& thread;
      ~Joiner() {
        {
          std::lock_guard<std::mutex> lock(run.mu);
          run.heartbeat_stop = true;
        }
        run.cv.notify_all();
        thread.join();
      }
    } joiner{run, heartbeat};
    produced = Produce(run, version, cache_key, settings, &transient);
  }
  if (!produced.ok()) {
    if (run.lost) return Outcome::kLost;
    if (run.abandoned) return Outcome::kAbandoned;
    if (transient) return OnStoreError(produced.status());
    return Fail(run, produced.status().message());
  }
  return Finish(run, produced.value(), "done");
}

StatusOr<ArtifactSummary> WorkerPool::Produce(JobRun& run, const VersionRecord& version, const std::string& cache_key,
                                              const EncodeSettings& settings, bool* transient) {
  auto set_progress = [&run](double progress, const std::string& stage) {
    std::lock_guard<std::mutex> lock(run.mu);
    run.progress = progress;
    run.stage = stage;
    run.dirty = true;
    run.cv.notify_all();
  };
  ProcessResult result;
  {
    StatusOr<WorkFolder> folder =
        MaterializeVersion(store_, version, options_.work_dir, options_.max_source_bytes);
    if (!folder.ok()) {
      *transient = IsTransient(folder.status());
      return folder.status();
    }
    if (run.cancelled()) return Aborted("cancelled");
    ProcessOptions process;
    process.max_input_bytes = options_.max_source_bytes;
    std::unique_ptr<ForkJoinPool> encoders;
    if (options_.encode_threads > 1) {
      encoders = std::make_unique<ForkJoinPool>(options_.encode_threads);
      process.runner = encoders.get();
    }
    process.cancelled = [&run] { return run.cancelled(); };
    MS_ASSIGN_OR_RETURN(result, ProcessSource(folder->main_path(), settings, set_progress, process));
  }  // the work folder is removed here
  if (run.cancelled()) return Aborted("cancelled");
  set_progress(kStoringProgress, "storing the artifact");

  // From here on only the store can fail: leave the job to its lease.
  *transient = true;
  StatusOr<std::unique_ptr<BlobSink>> sink = store_.NewBlob();
  if (!sink.ok()) return sink.status();
  for (size_t at = 0; at < result.glb.size(); at += kBlobChunkBytes) {
    if (run.cancelled()) return Aborted("cancelled");
    const size_t n = std::min(kBlobChunkBytes, result.glb.size() - at);
    MS_RETURN_IF_ERROR((*sink)->Append(result.glb.data() + at, n));
  }
  MS_ASSIGN_OR_RETURN(std::string digest, (*sink)->Commit(result.summary.artifact_sha256));
  (void)digest;
  // The cache row is an optimization: a failure does not fail the job.
  if (!store_.PutArtifact(cache_key, result.summary).ok()) ++store_errors_;
  return result.summary;
}

WorkerPool::Outcome WorkerPool::Finish(JobRun& run, const ArtifactSummary& summary, const std::string& message) {
  if (run.lost) return Outcome::kLost;
  if (run.abandoned) return Outcome::kAbandoned;
  // Progress 1 and the final message, then the result.
  const Status renewed = store_.RenewLease(run.job.id, run.worker, NowMs(), options_.lease_ms, 1.0, message);
  if (renewed.code() == StatusCode::kAborted) return Outcome::kLost;
  if (!renewed.ok()) ++store_errors_;
  const Status completed = store_.CompleteJob(run.job.id, run.worker, summary);
  if (completed.code() == StatusCode::kAborted) return Outcome::kLost;
  if (!completed.ok()) return OnStoreError(completed);
  return Outcome::kSucceeded;
}

WorkerPool::Outcome WorkerPool::Fail(JobRun& run, const std::string& message) {
  if (run.lost) return Outcome::kLost;
  if (run.abandoned) return Outcome::kAbandoned;
  const Status failed = store_.FailJob(run.job.id, run.worker, StorableMessage(message));
  if (failed.code() == StatusCode::kAborted) return Outcome::kLost;
  if (!failed.ok()) return OnStoreError(failed);
  return Outcome::kFailed;
}

WorkerPool::Outcome WorkerPool::OnStoreError(const Status& status) {
  (void)status;
  ++store_errors_;
  return Outcome::kLeftToLease;
}

void WorkerPool::Heartbeat(JobRun& run) {
  try {
    Clock::time_point last = Clock::now();
    std::unique_lock<std::mutex> lock(run.mu);
    while (true) {
      if (run.heartbeat_stop || run.cancelled()) return;
      Clock::time_point next = last + std::chrono::milliseconds(heartbeat_ms_);
      if (run.dirty) next = std::min(next, last + std::chrono::milliseconds(std::max<int64_t>(0, options_.progress_interval_ms)));
      if (Clock::now() < next) {
        run.cv.wait_until(lock, next);
        continue;
      }
      const double progress = run.progress;
      const std::string stage = run.stage;
      run.dirty = false;
      lock.unlock();
      const Status renewed = store_.RenewLease(run.job.id, run.worker, NowMs(), options_.lease_ms, progress, stage);
      lock.lock();
      last = Clock::now();
      if (renewed.code() == StatusCode::kAborted) {
        MarkLost(run);
        return;
      }
      if (!renewed.ok()) ++store_errors_;  // tried again at the next beat
    }
  } catch (...) {
    // A store that throws: the lease runs out, and the job goes to another worker.
    ++store_errors_;
  }
}

}  // namespace meshstream

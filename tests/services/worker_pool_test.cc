// The worker pool against an in-memory fake of the Store (the real backends
// are tested on their own; an integration test on SQLite comes with them):
// jobs succeed with the pipeline's figures, a bad source fails its job and
// not the pool, the artifact cache skips the encode, a lost lease stops the
// job quietly, Drain keeps its deadline.
#include "services/jobs/worker_pool.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <new>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "importers/import.h"
#include "services/pipeline/encode_options.h"
#include "services/pipeline/process_source.h"
#include "services/store/blob_store.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ModelPath;
using test_util::TempDir;
using Clock = std::chrono::steady_clock;

std::string Digest(const std::vector<uint8_t>& b) { return Sha256Hex(b.data(), b.size()); }

// The Store, in memory, with hooks to inject what a real one does under
// load: errors, exceptions, a takeover of a lease.
class FakeStore : public Store {
 public:
  struct Renewal {
    std::string job_id;
    std::string worker;
    double progress;
    std::string message;
  };

  // Hooks, called without the store's lock; an OK status lets the call proceed.
  std::function<Status(const std::string& job_id, const std::string& worker)> on_renew;
  std::function<Status(const std::string& asset)> on_get_version;

  std::string backend() const override { return "fake"; }

  // --- blobs
  class Sink : public BlobSink {
   public:
    explicit Sink(FakeStore* store) : store_(store) {}
    Status DoAppend(const uint8_t* data, size_t size) override {
      bytes_.insert(bytes_.end(), data, data + size);
      return Status::Ok();
    }
    uint64_t size() const override { return bytes_.size(); }
    StatusOr<std::string> DoCommit(const std::string& expected) override {
      const std::string digest = Digest(bytes_);
      if (!expected.empty() && expected != digest) return DataLoss("digest mismatch");
      std::lock_guard<std::mutex> lock(store_->mu_);
      store_->blobs_[digest] = bytes_;
      return digest;
    }

   private:
    FakeStore* store_;
    std::vector<uint8_t> bytes_;
  };
  StatusOr<std::unique_ptr<BlobSink>> DoNewBlob() override {
    ++new_blobs;
    return std::unique_ptr<BlobSink>(new Sink(this));
  }
  StatusOr<std::vector<uint8_t>> DoGetBlob(const std::string& sha256, uint64_t max_bytes) override {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = blobs_.find(sha256);
    if (it == blobs_.end()) return NotFound("blob " + sha256);
    if (it->second.size() > max_bytes) return ResourceExhausted("blob above max_bytes");
    return it->second;
  }
  StatusOr<bool> DoHasBlob(const std::string& sha256) override {
    std::lock_guard<std::mutex> lock(mu_);
    return blobs_.count(sha256) > 0;
  }
  StatusOr<uint64_t> DoRemoveOrphanBlobs(int64_t) override { return Unsupported("fake"); }
  std::string PutBlob(const std::vector<uint8_t>& bytes) {
    std::lock_guard<std::mutex> lock(mu_);
    blobs_[Digest(bytes)] = bytes;
    return Digest(bytes);
  }

  // --- uploads: not used by the pool
  StatusOr<uint64_t> DoUploadSize(const std::string&, const std::string&) override { return Unsupported("fake"); }
  Status DoAppendUpload(const std::string&, const std::string&, uint64_t, const uint8_t*, size_t) override {
    return Unsupported("fake");
  }
  StatusOr<std::string> DoCommitUpload(const std::string&, const std::string&, const std::string&) override {
    return Unsupported("fake");
  }
  Status DoDiscardUpload(const std::string&, const std::string&) override { return Unsupported("fake"); }
  StatusOr<uint64_t> DoExpireUploads(int64_t) override { return Unsupported("fake"); }

  // --- versions
  StatusOr<VersionRecord> DoCreateVersion(const NewVersion& v) override {
    std::lock_guard<std::mutex> lock(mu_);
    VersionRecord r;
    r.tenant = v.tenant;
    r.asset = v.asset;
    r.version = ++latest_[v.tenant + "/" + v.asset];
    r.source = v.source;
    r.resources = v.resources;
    r.options_json = v.options_json;
    r.created_ms = NowMs();
    JobRecord job;
    job.id = "job-" + std::to_string(++job_counter_);
    job.tenant = v.tenant;
    job.asset = v.asset;
    job.version = r.version;
    job.created_ms = r.created_ms;
    r.job_id = job.id;
    jobs_[job.id] = job;
    job_order_.push_back(job.id);
    versions_[Key(v.tenant, v.asset, r.version)] = r;
    return r;
  }
  StatusOr<VersionRecord> DoGetVersion(const std::string& tenant, const std::string& asset, int64_t version) override {
    if (on_get_version) MS_RETURN_IF_ERROR(on_get_version(asset));
    std::lock_guard<std::mutex> lock(mu_);
    auto it = versions_.find(Key(tenant, asset, version));
    if (it == versions_.end()) return NotFound("version");
    return it->second;
  }
  StatusOr<VersionRecord> DoGetLatestReadyVersion(const std::string&, const std::string&) override {
    return Unsupported("fake");
  }
  StatusOr<PageRows<AssetRecord>> DoListAssets(const std::string&, const std::string&, int64_t) override {
    return Unsupported("fake");
  }
  StatusOr<PageRows<VersionRecord>> DoListVersions(const std::string&, const std::string&, int64_t,
                                                   int64_t) override {
    return Unsupported("fake");
  }

  // --- jobs
  StatusOr<JobRecord> DoGetJob(const std::string&, const std::string& job_id) override {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = jobs_.find(job_id);
    if (it == jobs_.end()) return NotFound("job");
    return it->second;
  }
  StatusOr<std::optional<JobRecord>> DoClaimJob(const std::string& worker, int64_t now_ms, int64_t lease_ms) override {
    std::lock_guard<std::mutex> lock(mu_);
    for (const std::string& id : job_order_) {
      JobRecord& j = jobs_[id];
      const bool expired = j.state == JobState::kRunning && j.lease_expires_ms < now_ms;
      if (j.state != JobState::kPending && !expired) continue;
      j.state = JobState::kRunning;
      j.lease_owner = worker;
      j.lease_expires_ms = now_ms + lease_ms;
      ++j.attempts;
      return std::optional<JobRecord>(j);
    }
    return std::optional<JobRecord>();
  }
  Status DoRenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms, int64_t lease_ms,
                    double progress, const std::string& message) override {
    if (on_renew) MS_RETURN_IF_ERROR(on_renew(job_id, worker));
    std::lock_guard<std::mutex> lock(mu_);
    JobRecord& j = jobs_[job_id];
    if (j.state != JobState::kRunning || j.lease_owner != worker) return Aborted("not the lease holder");
    j.lease_expires_ms = now_ms + lease_ms;
    j.progress = progress;
    j.message = message;
    renewals.push_back({job_id, worker, progress, message});
    return Status::Ok();
  }
  Status DoCompleteJob(const std::string& job_id, const std::string& worker, const ArtifactSummary& summary) override {
    std::lock_guard<std::mutex> lock(mu_);
    JobRecord& j = jobs_[job_id];
    if (j.state != JobState::kRunning || j.lease_owner != worker) return Aborted("not the lease holder");
    if (blobs_.count(summary.artifact_sha256) == 0) return FailedPrecondition("no artifact blob");
    j.state = JobState::kSucceeded;
    j.progress = 1.0;
    VersionRecord& v = versions_[Key(j.tenant, j.asset, j.version)];
    v.state = VersionState::kReady;
    v.artifact = summary;
    ++completions;
    return Status::Ok();
  }
  Status DoFailJob(const std::string& job_id, const std::string& worker, const std::string& message) override {
    std::lock_guard<std::mutex> lock(mu_);
    JobRecord& j = jobs_[job_id];
    if (j.state != JobState::kRunning || j.lease_owner != worker) return Aborted("not the lease holder");
    j.state = JobState::kFailed;
    j.message = message;
    VersionRecord& v = versions_[Key(j.tenant, j.asset, j.version)];
    v.state = VersionState::kFailed;
    v.error = message;
    ++failures;
    return Status::Ok();
  }
  StatusOr<int64_t> DoReleaseAllLeases() override { return Unsupported("not used by the pool"); }
  StatusOr<int64_t> DoCountUnfinishedJobs() override {
    std::lock_guard<std::mutex> lock(mu_);
    int64_t n = 0;
    for (const auto& [id, j] : jobs_) n += (j.state == JobState::kPending || j.state == JobState::kRunning) ? 1 : 0;
    return n;
  }

  // --- artifact cache
  StatusOr<std::optional<ArtifactSummary>> DoFindArtifact(const std::string& key) override {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = artifacts_.find(key);
    if (it == artifacts_.end()) return std::optional<ArtifactSummary>();
    return std::optional<ArtifactSummary>(it->second);
  }
  Status DoPutArtifact(const std::string& key, const ArtifactSummary& summary) override {
    std::lock_guard<std::mutex> lock(mu_);
    artifacts_.emplace(key, summary);
    return Status::Ok();
  }

  // --- tokens: not used by the pool
  StatusOr<TokenRecord> DoCreateToken(const std::string&, bool, const std::string&) override { return Unsupported("fake"); }
  StatusOr<TokenRecord> DoFindToken(const std::string&) override { return Unsupported("fake"); }
  StatusOr<std::vector<TokenRecord>> DoListTokens() override { return Unsupported("fake"); }
  Status DoRevokeToken(const std::string&) override { return Unsupported("fake"); }

  // --- for the tests
  JobRecord Job(const std::string& id) {
    std::lock_guard<std::mutex> lock(mu_);
    return jobs_[id];
  }
  void EditJob(const std::string& id, const std::function<void(JobRecord&)>& edit) {
    std::lock_guard<std::mutex> lock(mu_);
    edit(jobs_[id]);
  }
  VersionRecord Version(const JobRecord& job) {
    std::lock_guard<std::mutex> lock(mu_);
    return versions_[Key(job.tenant, job.asset, job.version)];
  }
  std::vector<Renewal> RenewalsOf(const std::string& job_id) {
    std::lock_guard<std::mutex> lock(mu_);
    std::vector<Renewal> out;
    for (const Renewal& r : renewals) {
      if (r.job_id == job_id) out.push_back(r);
    }
    return out;
  }
  bool Finished(const std::string& id) {
    const JobState s = Job(id).state;
    return s == JobState::kSucceeded || s == JobState::kFailed;
  }

  std::atomic<int> new_blobs{0};
  std::atomic<int> completions{0};
  std::atomic<int> failures{0};

 private:
  static std::string Key(const std::string& t, const std::string& a, int64_t v) {
    return t + "/" + a + "/" + std::to_string(v);
  }
  std::mutex mu_;
  std::map<std::string, std::vector<uint8_t>> blobs_;
  std::map<std::string, int64_t> latest_;
  std::map<std::string, VersionRecord> versions_;
  std::map<std::string, JobRecord> jobs_;
  std::vector<std::string> job_order_;
  std::map<std::string, ArtifactSummary> artifacts_;
  int job_counter_ = 0;
  std::vector<Renewal> renewals;
};

std::vector<uint8_t> FileBytes(const std::string& path) {
  auto b = ReadFileBytes(path, uint64_t{1} << 30);
  EXPECT_TRUE(b.ok()) << b.status().ToString();
  return b.ok() ? b.value() : std::vector<uint8_t>();
}

struct Upload {
  std::string filename;
  std::vector<uint8_t> bytes;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> resources;
  std::string options_json = "{}";
};

// Stores the blobs and creates the version; returns its job id.
std::string Ingest(FakeStore& store, const std::string& asset, const Upload& u) {
  NewVersion v;
  v.tenant = "acme";
  v.asset = asset;
  v.source = SourceFile{u.filename, store.PutBlob(u.bytes), u.bytes.size()};
  for (const auto& [name, bytes] : u.resources) v.resources.push_back(SourceFile{name, store.PutBlob(bytes), bytes.size()});
  v.options_json = u.options_json;
  auto r = store.CreateVersion(v);
  EXPECT_TRUE(r.ok());
  return r.ok() ? r->job_id : "";
}

Upload Model(const std::string& name) {
  Upload u;
  u.filename = std::filesystem::path(name).filename().string();
  u.bytes = FileBytes(ModelPath(name));
  return u;
}

Upload Garbage(const std::string& filename, size_t size) {
  Upload u;
  u.filename = filename;
  std::mt19937 random(11);
  u.bytes.resize(size);
  for (uint8_t& b : u.bytes) b = static_cast<uint8_t>(random());
  return u;
}

bool WaitFor(const std::function<bool()>& done, std::chrono::milliseconds timeout = std::chrono::seconds(60)) {
  const auto end = Clock::now() + timeout;
  while (!done()) {
    if (Clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

WorkerPoolOptions FastOptions(const std::string& work_dir, int workers = 2) {
  WorkerPoolOptions o;
  o.workers = workers;
  o.worker_id_prefix = "test-server";
  o.lease_ms = 3000;
  o.poll_interval_ms = 5;
  o.progress_interval_ms = 1;
  o.work_dir = work_dir;
  return o;
}

bool Empty(const std::string& dir) { return std::filesystem::is_empty(dir); }

TEST(WorkerPool, JobsSucceedWithThePipelinesFigures) {
  FakeStore store;
  TempDir work;
  Upload gltf = Model("gltf/draco-2CylinderEngine/2CylinderEngine.gltf");
  gltf.resources.emplace_back("2CylinderEngine.bin", FileBytes(ModelPath("gltf/draco-2CylinderEngine/2CylinderEngine.bin")));
  gltf.options_json = "{\"qp\":12,\"packing\":\"bundled\"}";
  const std::string a = Ingest(store, "spot", Model("spot.obj"));
  const std::string b = Ingest(store, "engine", gltf);
  WorkerPool pool(store, FastOptions(work.path()));
  EXPECT_EQ(pool.options().workers, 2);
  ASSERT_TRUE(pool.Start().ok());
  EXPECT_EQ(pool.Start().code(), StatusCode::kFailedPrecondition);
  ASSERT_TRUE(WaitFor([&] { return store.Finished(a) && store.Finished(b); }));

  for (const auto& [id, path, options] :
       {std::make_tuple(a, ModelPath("spot.obj"), std::string("{}")),
        std::make_tuple(b, ModelPath("gltf/draco-2CylinderEngine/2CylinderEngine.gltf"), gltf.options_json)}) {
    const JobRecord job = store.Job(id);
    ASSERT_EQ(job.state, JobState::kSucceeded) << job.message;
    EXPECT_EQ(job.message, "done");
    EXPECT_EQ(job.attempts, 1);
    const VersionRecord v = store.Version(job);
    EXPECT_EQ(v.state, VersionState::kReady);
    // The same summary as the pipeline run directly.
    auto direct = ProcessSource(path, ParseSettingsJson(options).value(), nullptr);
    ASSERT_TRUE(direct.ok()) << direct.status().ToString();
    const ArtifactSummary& s = v.artifact;
    EXPECT_EQ(s.artifact_sha256, direct->summary.artifact_sha256);
    EXPECT_EQ(s.vertices, direct->summary.vertices);
    EXPECT_EQ(s.level_vertices, direct->summary.level_vertices);
    EXPECT_EQ(s.reliable_bytes, direct->summary.reliable_bytes);
    EXPECT_EQ(s.layout_json, direct->summary.layout_json);
    auto blob = store.GetBlob(s.artifact_sha256, uint64_t{1} << 30);
    ASSERT_TRUE(blob.ok());
    EXPECT_EQ(blob.value(), direct->glb);
    // Progress went through the heartbeat, monotone, ending at 1 with the message.
    const auto renewals = store.RenewalsOf(id);
    ASSERT_GE(renewals.size(), 2u);
    for (size_t i = 1; i < renewals.size(); ++i) EXPECT_GE(renewals[i].progress, renewals[i - 1].progress);
    EXPECT_EQ(renewals.back().progress, 1.0);
    EXPECT_EQ(renewals.back().message, "done");
    EXPECT_EQ(renewals.front().worker.rfind("test-server/", 0), 0u);
  }
  const WorkerPoolCounters c = pool.counters();
  EXPECT_EQ(c.claimed, 2u);
  EXPECT_EQ(c.succeeded, 2u);
  EXPECT_EQ(c.failed, 0u);
  EXPECT_EQ(c.cache_hits, 0u);
  EXPECT_EQ(c.lost_leases, 0u);
  pool.Stop();
  EXPECT_TRUE(Empty(work.path()));  // the work folders are gone
}

TEST(WorkerPool, ABadSourceFailsItsJobAndNotThePool) {
  FakeStore store;
  TempDir work;
  const std::string garbage = Ingest(store, "garbage", Garbage("garbage.obj", 50000));
  Upload escaping = Model("spot.obj");
  escaping.filename = "scene.gltf";
  escaping.resources.emplace_back("../outside.bin", std::vector<uint8_t>{1, 2, 3});
  const std::string traversal = Ingest(store, "traversal", escaping);
  Upload bad_options = Model("spot.obj");
  bad_options.options_json = "{\"qp\":40}";
  const std::string options = Ingest(store, "options", bad_options);
  const std::string thrown = Ingest(store, "throws", Model("spot.obj"));
  const std::string good = Ingest(store, "good", Model("spot.obj"));
  // A library deep inside the store or the pipeline may throw anything.
  store.on_get_version = [](const std::string& asset) -> Status {
    if (asset == "throws") throw std::bad_alloc();
    return Status::Ok();
  };
  WorkerPool pool(store, FastOptions(work.path(), 1));
  ASSERT_TRUE(pool.Start().ok());
  ASSERT_TRUE(WaitFor([&] {
    return store.Finished(garbage) && store.Finished(traversal) && store.Finished(options) && store.Finished(thrown) &&
           store.Finished(good);
  }));
  const JobRecord g = store.Job(garbage);
  EXPECT_EQ(g.state, JobState::kFailed);
  EXPECT_EQ(g.message.rfind("garbage.obj: ", 0), 0u) << g.message;  // the importer's message, by its name
  EXPECT_EQ(g.message.find(work.path()), std::string::npos) << g.message;
  EXPECT_EQ(store.Version(g).state, VersionState::kFailed);
  EXPECT_EQ(store.Version(g).error, g.message);
  EXPECT_EQ(store.Job(traversal).state, JobState::kFailed);
  EXPECT_EQ(store.Job(traversal).message, "resource name '../outside.bin': '..' segments are not allowed");
  EXPECT_EQ(store.Job(options).state, JobState::kFailed);
  EXPECT_EQ(store.Job(options).message, "options.qp: 40 is outside [1, 30]");
  EXPECT_EQ(store.Job(thrown).state, JobState::kFailed);
  EXPECT_EQ(store.Job(thrown).message, "out of memory while processing the source");
  EXPECT_EQ(store.Job(good).state, JobState::kSucceeded) << store.Job(good).message;
  const WorkerPoolCounters c = pool.counters();
  EXPECT_EQ(c.failed, 4u);
  EXPECT_EQ(c.succeeded, 1u);
  pool.Stop();
  EXPECT_TRUE(Empty(work.path()));
}

TEST(WorkerPool, ACachedArtifactCompletesTheJobWithoutAnEncode) {
  FakeStore store;
  TempDir work;
  WorkerPool pool(store, FastOptions(work.path()));
  ASSERT_TRUE(pool.Start().ok());
  const std::string first = Ingest(store, "first", Model("spot.obj"));
  ASSERT_TRUE(WaitFor([&] { return store.Finished(first); }));
  ASSERT_EQ(store.Job(first).state, JobState::kSucceeded);
  const int blobs_after_first = store.new_blobs.load();
  EXPECT_EQ(blobs_after_first, 1);

  // The same bytes under another asset, options spelled differently.
  Upload same = Model("spot.obj");
  same.options_json = "{\"qp\":11,\"packing\":\"split\"}";
  const std::string second = Ingest(store, "second", same);
  pool.Wake();
  ASSERT_TRUE(WaitFor([&] { return store.Finished(second); }));
  const JobRecord j = store.Job(second);
  ASSERT_EQ(j.state, JobState::kSucceeded);
  EXPECT_EQ(j.message, kReusedArtifactMessage);
  EXPECT_EQ(pool.cache_hits(), 1u);
  EXPECT_EQ(store.new_blobs.load(), blobs_after_first);  // nothing encoded, nothing written
  const auto renewals = store.RenewalsOf(second);
  ASSERT_EQ(renewals.size(), 1u);  // only the final one: no stage ran
  EXPECT_EQ(renewals[0].progress, 1.0);
  EXPECT_EQ(store.Version(j).artifact.artifact_sha256, store.Version(store.Job(first)).artifact.artifact_sha256);
  EXPECT_EQ(store.Version(j).artifact.layout_json, store.Version(store.Job(first)).artifact.layout_json);

  // Other options: another artifact.
  Upload other = Model("spot.obj");
  other.options_json = "{\"qp\":12}";
  const std::string third = Ingest(store, "third", other);
  pool.Wake();
  ASSERT_TRUE(WaitFor([&] { return store.Finished(third); }));
  EXPECT_EQ(store.Job(third).message, "done");
  EXPECT_EQ(pool.cache_hits(), 1u);
  EXPECT_EQ(store.new_blobs.load(), blobs_after_first + 1);
  EXPECT_EQ(pool.counters().succeeded, 3u);
}

TEST(WorkerPool, ALostLeaseStopsTheJobQuietly) {
  FakeStore store;
  TempDir work;
  const std::string stolen = Ingest(store, "stolen", Model("stanford-bunny.obj"));
  // At its first heartbeat another server has taken the job over.
  std::atomic<int> aborted{0};
  store.on_renew = [&](const std::string& job_id, const std::string&) -> Status {
    if (job_id != stolen) return Status::Ok();
    store.EditJob(job_id, [](JobRecord& j) {
      j.lease_owner = "other-server/0";
      j.lease_expires_ms = NowMs() + 3600 * 1000;
    });
    ++aborted;
    return Aborted("the lease is held by other-server/0");
  };
  WorkerPoolOptions o = FastOptions(work.path(), 1);
  o.lease_ms = 60;  // a heartbeat every 20 ms: during the import
  WorkerPool pool(store, o);
  ASSERT_TRUE(pool.Start().ok());
  ASSERT_TRUE(WaitFor([&] { return pool.counters().lost_leases == 1; }));
  ASSERT_TRUE(WaitFor([&] { return pool.running_jobs() == 0; }));
  // The pool carries on with other jobs.
  const std::string next = Ingest(store, "next", Model("spot.obj"));
  ASSERT_TRUE(WaitFor([&] { return store.Finished(next); }));
  EXPECT_EQ(store.Job(next).state, JobState::kSucceeded);

  const JobRecord j = store.Job(stolen);
  EXPECT_EQ(j.state, JobState::kRunning);  // neither completed nor failed by us
  EXPECT_EQ(j.lease_owner, "other-server/0");
  EXPECT_EQ(aborted.load(), 1);            // no renewal after the first Aborted
  EXPECT_EQ(store.new_blobs.load(), 1);    // only `next`'s artifact: the stolen job stopped before storing
  EXPECT_EQ(store.failures.load(), 0);
  const WorkerPoolCounters c = pool.counters();
  EXPECT_EQ(c.lost_leases, 1u);
  EXPECT_EQ(c.failed, 0u);
  EXPECT_EQ(c.succeeded, 1u);
  pool.Stop();
  EXPECT_TRUE(Empty(work.path()));
}

TEST(WorkerPool, DrainReturnsWithinItsDeadlineAndAbandonsWhatRuns) {
  FakeStore store;
  TempDir work;
  const std::string slow = Ingest(store, "slow", Model("horse.ply"));
  WorkerPool pool(store, FastOptions(work.path(), 1));
  ASSERT_TRUE(pool.Start().ok());
  ASSERT_TRUE(WaitFor([&] { return pool.running_jobs() == 1; }));
  // Returned at its deadline, not at the job's end: the job was still
  // running, so Drain abandoned it (a Drain that waited for it would
  // abandon nothing). The count says so whatever the machine's speed.
  const int64_t abandoned = pool.Drain(Clock::now() + std::chrono::milliseconds(20));
  EXPECT_EQ(abandoned, 1);
  // Nothing more is claimed after a drain.
  const std::string later = Ingest(store, "later", Model("spot.obj"));
  pool.Wake();
  pool.Stop();
  const JobRecord j = store.Job(slow);
  EXPECT_EQ(j.state, JobState::kRunning);  // left to its lease, for another server
  EXPECT_EQ(store.Job(later).state, JobState::kPending);
  EXPECT_EQ(store.completions.load(), 0);
  EXPECT_EQ(store.failures.load(), 0);
  EXPECT_EQ(pool.counters().abandoned, 1u);
  EXPECT_TRUE(Empty(work.path()));

  // A restarted pool takes the job over once the lease has expired.
  store.EditJob(slow, [](JobRecord& job) { job.lease_expires_ms = 0; });
  WorkerPool restarted(store, FastOptions(work.path(), 1));
  ASSERT_TRUE(restarted.Start().ok());
  ASSERT_TRUE(WaitFor([&] { return store.Finished(slow) && store.Finished(later); }));
  EXPECT_EQ(store.Job(slow).state, JobState::kSucceeded);
  EXPECT_EQ(store.Job(slow).attempts, 2);
}

TEST(WorkerPool, DrainWaitsForJobsThatFinishInTime) {
  FakeStore store;
  TempDir work;
  WorkerPool idle(store, FastOptions(work.path()));
  ASSERT_TRUE(idle.Start().ok());
  // Returning before half the deadline tells "returned when nothing ran"
  // from "waited for the deadline" on any machine.
  auto start = Clock::now();
  EXPECT_EQ(idle.Drain(start + std::chrono::seconds(120)), 0);
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(60));

  const std::string quick = Ingest(store, "quick", Model("spot.obj"));
  WorkerPool pool(store, FastOptions(work.path(), 1));
  ASSERT_TRUE(pool.Start().ok());
  ASSERT_TRUE(WaitFor([&] { return pool.counters().claimed == 1; }));
  start = Clock::now();
  EXPECT_EQ(pool.Drain(start + std::chrono::seconds(120)), 0);
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(60));
  EXPECT_EQ(store.Job(quick).state, JobState::kSucceeded);
  EXPECT_EQ(pool.counters().abandoned, 0u);
}

TEST(WorkerPool, AnUnavailableStoreLeavesTheJobToItsLeaseAndItIsRetried) {
  FakeStore store;
  TempDir work;
  std::atomic<int> calls{0};
  store.on_get_version = [&](const std::string&) -> Status {
    return ++calls == 1 ? Unavailable("database is restarting") : Status::Ok();
  };
  const std::string id = Ingest(store, "retried", Model("spot.obj"));
  WorkerPoolOptions o = FastOptions(work.path(), 1);
  o.lease_ms = 100;
  WorkerPool pool(store, o);
  ASSERT_TRUE(pool.Start().ok());
  ASSERT_TRUE(WaitFor([&] { return store.Finished(id); }));
  EXPECT_EQ(store.Job(id).state, JobState::kSucceeded);
  EXPECT_EQ(store.Job(id).attempts, 2);
  EXPECT_GE(pool.counters().store_errors, 1u);
  EXPECT_EQ(pool.counters().claimed, 2u);
}

TEST(WorkerPool, AJobClaimedTooOftenFails) {
  FakeStore store;
  TempDir work;
  const std::string id = Ingest(store, "poison", Model("spot.obj"));
  store.EditJob(id, [](JobRecord& j) { j.attempts = 3; });  // three servers died on it
  WorkerPool pool(store, FastOptions(work.path(), 1));
  ASSERT_TRUE(pool.Start().ok());
  ASSERT_TRUE(WaitFor([&] { return store.Finished(id); }));
  EXPECT_EQ(store.Job(id).state, JobState::kFailed);
  EXPECT_EQ(store.Job(id).message, "gave up after 3 attempts: the servers processing this job stopped before finishing it");
}

// The store refuses text that is not UTF-8 or holds a NUL (store_checks.h),
// on every backend; a failure's message may quote what a client sent, so
// the worker makes it storable instead of leaving the job unfinishable.
TEST(WorkerPool, AFailureMessageThatIsNotStorableTextIsCleanedAndTheJobFails) {
  FakeStore store;
  TempDir work;
  const std::string id = Ingest(store, "odd", Model("spot.obj"));
  store.on_get_version = [](const std::string&) -> Status {
    return NotFound(std::string("bad \xFF byte and a ") + '\0' + " NUL");
  };
  WorkerPool pool(store, FastOptions(work.path(), 1));
  ASSERT_TRUE(pool.Start().ok());
  ASSERT_TRUE(WaitFor([&] { return store.Finished(id); }, std::chrono::seconds(20)));
  const JobRecord job = store.Job(id);
  EXPECT_EQ(job.state, JobState::kFailed);
  EXPECT_EQ(job.message, "version: bad \xEF\xBF\xBD byte and a   NUL");
  pool.Stop();
}

TEST(WorkerPool, WakeStartsAJobWithoutWaitingForThePoll) {
  FakeStore store;
  TempDir work;
  WorkerPoolOptions o = FastOptions(work.path(), 1);
  o.poll_interval_ms = 60 * 1000;
  WorkerPool pool(store, o);
  ASSERT_TRUE(pool.Start().ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the worker polled and sleeps
  const std::string id = Ingest(store, "woken", Model("spot.obj"));
  pool.Wake();
  EXPECT_TRUE(WaitFor([&] { return store.Finished(id); }, std::chrono::seconds(20)));
  const auto start = Clock::now();
  pool.Stop();  // does not wait for the poll interval either
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(5));
}

}  // namespace
}  // namespace meshstream

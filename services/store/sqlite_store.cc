// The embedded store's metadata (services/store/sqlite_store.h): opening
// and locking the folder, and the rows of versions, jobs, the artifact cache
// and tokens. Blobs and uploads, which live in files, are in
// sqlite_files.cc; the schema in sqlite_schema.cc; statements in sqlite_db.cc.
#include "services/store/sqlite_store.h"

#include <fcntl.h>
#include <sodium.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <utility>

#include "services/store/file_util.h"
#include "services/store/sqlite_db.h"
#include "services/store/sqlite_schema.h"
#include "services/store/store_records.h"

namespace meshstream {

namespace {

namespace fs = std::filesystem;

// Reads the pid the holder of the lock wrote into it ("unknown" when none yet).
std::string LockHolder(int fd) {
  char buf[32] = {};
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  std::string pid;
  for (ssize_t i = 0; i < n && buf[i] >= '0' && buf[i] <= '9'; ++i) pid.push_back(buf[i]);
  return pid.empty() ? "unknown" : pid;
}

// --- rows ------------------------------------------------------------------

void BindSummary(Stmt& s, const ArtifactSummary& a) {
  s.Bind(a.artifact_sha256, a.progressive_bytes, a.encoder, a.vertices, a.faces, a.levels,
         LevelsToJson(a.level_vertices), a.reliable_bytes, a.unreliable_bytes, a.layout_json, a.warnings_json);
}

// Reads the MS_SQLITE_SUMMARY_COLUMNS starting at column `col`.
StatusOr<ArtifactSummary> ReadSummary(const Stmt& s, int col) {
  ArtifactSummary a;
  a.artifact_sha256 = s.Text(col);
  a.progressive_bytes = static_cast<uint64_t>(s.Int(col + 1));
  a.encoder = s.Text(col + 2);
  a.vertices = s.Int(col + 3);
  a.faces = s.Int(col + 4);
  a.levels = static_cast<int32_t>(s.Int(col + 5));
  MS_ASSIGN_OR_RETURN(a.level_vertices, LevelsFromJson(s.Text(col + 6)));
  a.reliable_bytes = static_cast<uint64_t>(s.Int(col + 7));
  a.unreliable_bytes = static_cast<uint64_t>(s.Int(col + 8));
  a.layout_json = s.Text(col + 9);
  a.warnings_json = s.Text(col + 10);
  return a;
}

#define MS_VERSION_COLUMNS                                                                            \
  "tenant, asset, version, state, source_name, source_sha256, source_size, options_json, comment, "   \
  "labels_json, created_ms, job_id, error, " MS_SQLITE_SUMMARY_COLUMNS
constexpr int kVersionSummaryColumn = 13;  // where MS_SQLITE_SUMMARY_COLUMNS start in MS_VERSION_COLUMNS

StatusOr<VersionRecord> ReadVersionRow(const Stmt& s) {
  VersionRecord v;
  v.tenant = s.Text(0);
  v.asset = s.Text(1);
  v.version = s.Int(2);
  MS_ASSIGN_OR_RETURN(v.state, VersionStateFromRow(s.Int(3)));
  v.source.name = s.Text(4);
  v.source.sha256 = s.Text(5);
  v.source.size = static_cast<uint64_t>(s.Int(6));
  v.options_json = s.Text(7);
  v.comment = s.Text(8);
  MS_ASSIGN_OR_RETURN(v.labels, LabelsFromJson(s.Text(9)));
  v.created_ms = s.Int(10);
  v.job_id = s.Text(11);
  v.error = s.Text(12);
  MS_ASSIGN_OR_RETURN(v.artifact, ReadSummary(s, kVersionSummaryColumn));
  return v;
}

#define MS_JOB_COLUMNS                                                                               \
  "id, tenant, asset, version, state, progress, message, attempts, lease_owner, lease_expires_ms, "   \
  "created_ms, updated_ms"

StatusOr<JobRecord> ReadJobRow(const Stmt& s) {
  JobRecord j;
  j.id = s.Text(0);
  j.tenant = s.Text(1);
  j.asset = s.Text(2);
  j.version = s.Int(3);
  MS_ASSIGN_OR_RETURN(j.state, JobStateFromRow(s.Int(4)));
  j.progress = s.Real(5);
  j.message = s.Text(6);
  j.attempts = static_cast<int32_t>(s.Int(7));
  j.lease_owner = s.Text(8);
  j.lease_expires_ms = s.Int(9);
  j.created_ms = s.Int(10);
  j.updated_ms = s.Int(11);
  return j;
}

#define MS_TOKEN_COLUMNS "id, tenant, read_only, created_ms, revoked"

TokenRecord ReadTokenRow(const Stmt& s) {
  TokenRecord t;
  t.id = s.Text(0);
  t.tenant = s.Text(1);
  t.read_only = s.Int(2) != 0;
  t.created_ms = s.Int(3);
  t.revoked = s.Int(4) != 0;
  return t;
}

}  // namespace

// --- opening and closing -------------------------------------------------------

SqliteStore::SqliteStore(std::string dir, StoreLock lock, int lock_fd, sqlite3* db,
                         std::optional<FileBlobStore> blobs)
    : dir_(std::move(dir)), lock_(lock), lock_fd_(lock_fd), blobs_(std::move(blobs)), db_(db) {}

SqliteStore::~SqliteStore() {
  sqlite3_close_v2(db_);
  close(lock_fd_);  // releases the flock
}

StatusOr<std::unique_ptr<SqliteStore>> SqliteStore::Open(const std::string& dir, StoreLock lock) {
  if (dir.empty()) return InvalidArgument("store folder: must not be empty");
  if (sodium_init() < 0) return Internal("libsodium could not be initialized");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return IoError(dir + ": " + ec.message());
  // Absolute, so a later chdir of the process cannot move the store.
  std::string root = fs::absolute(dir, ec).lexically_normal().string();
  if (ec) return IoError(dir + ": " + ec.message());
  while (root.size() > 1 && root.back() == '/') root.pop_back();

  const std::string lock_path = root + "/LOCK";
  const int lock_fd = open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0640);
  if (lock_fd < 0) return Errno(lock_path);
  // A shared store takes the lock too when it is free (no server runs), but
  // only to migrate the schema safely; it lets go before returning.
  bool locked = flock(lock_fd, LOCK_EX | LOCK_NB) == 0;
  if (!locked) {
    const int error = errno;
    if (error != EWOULDBLOCK) {
      close(lock_fd);
      errno = error;
      return Errno(lock_path + ": flock");
    }
    if (lock == StoreLock::kExclusive) {
      const std::string holder = LockHolder(lock_fd);
      close(lock_fd);
      return Unavailable(root + " is in use by another meshstream process (pid " + holder + ")");
    }
  }
  // From here on, closing lock_fd releases the lock.
  auto fail = [&](const Status& status, sqlite3* db) {
    if (db != nullptr) sqlite3_close_v2(db);
    close(lock_fd);
    return status;
  };
  if (locked) {
    const std::string pid = std::to_string(getpid()) + "\n";
    if (ftruncate(lock_fd, 0) != 0 ||
        pwrite(lock_fd, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
      return fail(Errno(lock_path), nullptr);
    }
  }

  // Only the server opens the blob folder: opening it removes temporary
  // files, which beside a running server would be its uploads in progress.
  std::optional<FileBlobStore> blobs;
  if (lock == StoreLock::kExclusive) {
    auto opened = FileBlobStore::Open(root);
    if (!opened.ok()) return fail(opened.status(), nullptr);
    blobs.emplace(std::move(opened).value());
    if (auto made = MakeFolder(root + "/uploads"); !made.ok()) return fail(made.status(), nullptr);
  }

  const std::string path = root + "/meta.sqlite3";
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                                 nullptr);
  if (rc != SQLITE_OK) return fail(SqlError(db, rc, path), db);
  if (Status set_up = SetUpSqliteDatabase(db, path, locked); !set_up.ok()) return fail(set_up, db);
  if (lock == StoreLock::kShared && locked) flock(lock_fd, LOCK_UN);  // a server may start beside this tool
  return std::unique_ptr<SqliteStore>(new SqliteStore(root, lock, lock_fd, db, std::move(blobs)));
}

Status SqliteStore::CheckExclusive(const char* operation) const {
  if (lock_ == StoreLock::kExclusive) return Status::Ok();
  return FailedPrecondition(std::string(operation) + ": " + dir_ +
                            " is open shared (beside its server), which may only read metadata and manage tokens");
}

StatusOr<SqliteStore::Settings> SqliteStore::ReadSettings() {
  std::lock_guard<std::mutex> lock(mu_);
  Settings settings;
  {
    Stmt s(db_, "PRAGMA journal_mode");
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (row) settings.journal_mode = s.Text(0);
  }
  const std::pair<const char*, int64_t*> numbers[] = {{"PRAGMA synchronous", &settings.synchronous},
                                                      {"PRAGMA busy_timeout", &settings.busy_timeout_ms},
                                                      {"PRAGMA user_version", &settings.schema_version}};
  for (const auto& [sql, out] : numbers) {
    Stmt s(db_, sql);
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (row) *out = s.Int(0);
  }
  return settings;
}

// --- assets and versions ----------------------------------------------------

Status SqliteStore::CheckAssetLocked(const std::string& tenant, const std::string& asset) {
  Stmt s(db_, "SELECT 1 FROM assets WHERE tenant = ? AND name = ?");
  s.Bind(tenant, asset);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  return row ? Status::Ok() : AssetNotFound(asset);
}

StatusOr<VersionRecord> SqliteStore::ReadVersionLocked(const std::string& tenant, const std::string& asset,
                                                       int64_t version) {
  VersionRecord record;
  {
    Stmt s(db_, "SELECT " MS_VERSION_COLUMNS " FROM versions WHERE tenant = ? AND asset = ? AND version = ?");
    s.Bind(tenant, asset, version);
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) {
      MS_RETURN_IF_ERROR(CheckAssetLocked(tenant, asset));
      return VersionNotFound(asset, version);
    }
    MS_ASSIGN_OR_RETURN(record, ReadVersionRow(s));
  }
  Stmt r(db_,
         "SELECT name, sha256, size FROM version_resources WHERE tenant = ? AND asset = ? AND version = ? "
         "ORDER BY position");
  r.Bind(tenant, asset, version);
  for (;;) {
    MS_ASSIGN_OR_RETURN(const bool row, r.Step());
    if (!row) break;
    record.resources.push_back(SourceFile{r.Text(0), r.Text(1), static_cast<uint64_t>(r.Int(2))});
  }
  return record;
}

StatusOr<VersionRecord> SqliteStore::DoCreateVersion(const NewVersion& v) {
  MS_RETURN_IF_ERROR(CheckExclusive("CreateVersion"));
  const std::string labels_json = LabelsToJson(v.labels);

  VersionRecord record;
  record.tenant = v.tenant;
  record.asset = v.asset;
  record.state = VersionState::kProcessing;
  record.source = v.source;
  record.resources = v.resources;
  record.options_json = v.options_json;
  record.comment = v.comment;
  record.labels = v.labels;
  record.created_ms = NowMs();
  record.job_id = RandomHex(16);

  std::lock_guard<std::mutex> lock(mu_);
  // Blobs are checked under the lock that RemoveOrphanBlobs takes to remove.
  if (!blobs_->Contains(v.source.sha256)) return BlobMissing("source.sha256", v.source.sha256);
  for (size_t i = 0; i < v.resources.size(); ++i) {
    if (!blobs_->Contains(v.resources[i].sha256)) {
      return BlobMissing("resources[" + std::to_string(i) + "].sha256", v.resources[i].sha256);
    }
  }
  Txn txn(db_);
  MS_RETURN_IF_ERROR(txn.Begin());
  {
    Stmt s(db_, "INSERT OR IGNORE INTO assets (tenant, name, latest_version, updated_ms) VALUES (?, ?, 0, ?)");
    s.Bind(v.tenant, v.asset, record.created_ms);
    MS_RETURN_IF_ERROR(s.Run());
  }
  {
    Stmt s(db_, "UPDATE assets SET latest_version = latest_version + 1, updated_ms = ? WHERE tenant = ? AND name = ?");
    s.Bind(record.created_ms, v.tenant, v.asset);
    MS_RETURN_IF_ERROR(s.Run());
  }
  {
    Stmt s(db_, "SELECT latest_version FROM assets WHERE tenant = ? AND name = ?");
    s.Bind(v.tenant, v.asset);
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) return Internal("asset " + v.asset + " vanished inside its transaction");
    record.version = s.Int(0);
  }
  {
    Stmt s(db_,
           "INSERT INTO versions (tenant, asset, version, state, source_name, source_sha256, source_size, "
           "options_json, comment, labels_json, created_ms, job_id) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    s.Bind(v.tenant, v.asset, record.version, static_cast<int64_t>(VersionState::kProcessing), v.source.name,
           v.source.sha256, v.source.size, v.options_json, v.comment, labels_json, record.created_ms, record.job_id);
    MS_RETURN_IF_ERROR(s.Run());
  }
  for (size_t i = 0; i < v.resources.size(); ++i) {
    Stmt s(db_,
           "INSERT INTO version_resources (tenant, asset, version, position, name, sha256, size) "
           "VALUES (?, ?, ?, ?, ?, ?, ?)");
    s.Bind(v.tenant, v.asset, record.version, static_cast<int64_t>(i), v.resources[i].name, v.resources[i].sha256,
           v.resources[i].size);
    MS_RETURN_IF_ERROR(s.Run());
  }
  {
    Stmt s(db_,
           "INSERT INTO jobs (id, tenant, asset, version, state, created_ms, updated_ms) "
           "VALUES (?, ?, ?, ?, ?, ?, ?)");
    s.Bind(record.job_id, v.tenant, v.asset, record.version, static_cast<int64_t>(JobState::kPending),
           record.created_ms, record.created_ms);
    MS_RETURN_IF_ERROR(s.Run());
  }
  MS_RETURN_IF_ERROR(txn.Commit());
  return record;
}

StatusOr<VersionRecord> SqliteStore::DoGetVersion(const std::string& tenant, const std::string& asset,
                                                int64_t version) {
  std::lock_guard<std::mutex> lock(mu_);
  if (version == 0) {
    Stmt s(db_, "SELECT latest_version FROM assets WHERE tenant = ? AND name = ?");
    s.Bind(tenant, asset);
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) return AssetNotFound(asset);
    version = s.Int(0);
  }
  return ReadVersionLocked(tenant, asset, version);
}

StatusOr<VersionRecord> SqliteStore::DoGetLatestReadyVersion(const std::string& tenant, const std::string& asset) {
  std::lock_guard<std::mutex> lock(mu_);
  int64_t version = 0;
  {
    Stmt s(db_, "SELECT max(version) FROM versions WHERE tenant = ? AND asset = ? AND state = ?");
    s.Bind(tenant, asset, static_cast<int64_t>(VersionState::kReady));
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (row) version = s.Int(0);  // NULL reads as 0
  }
  if (version == 0) {
    MS_RETURN_IF_ERROR(CheckAssetLocked(tenant, asset));
    return NoReadyVersion(asset);
  }
  return ReadVersionLocked(tenant, asset, version);
}

StatusOr<PageRows<AssetRecord>> SqliteStore::DoListAssets(const std::string& tenant, const std::string& after,
                                                          int64_t limit) {
  std::lock_guard<std::mutex> lock(mu_);
  PageRows<AssetRecord> assets;
  Stmt s(db_,
         "SELECT name, latest_version, updated_ms FROM assets WHERE tenant = ? AND name > ? ORDER BY name LIMIT ?");
  s.Bind(tenant, after, limit + 1);  // one row more: whether more follow
  for (;;) {
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) break;
    if (static_cast<int64_t>(assets.items.size()) == limit) {
      assets.more = true;
      break;
    }
    assets.items.push_back(AssetRecord{tenant, s.Text(0), s.Int(1), s.Int(2)});
  }
  return assets;
}

StatusOr<PageRows<VersionRecord>> SqliteStore::DoListVersions(const std::string& tenant, const std::string& asset,
                                                              int64_t after, int64_t limit) {
  std::lock_guard<std::mutex> lock(mu_);
  MS_RETURN_IF_ERROR(CheckAssetLocked(tenant, asset));
  std::vector<int64_t> numbers;
  PageRows<VersionRecord> versions;
  {
    Stmt s(db_, "SELECT version FROM versions WHERE tenant = ? AND asset = ? AND version > ? ORDER BY version LIMIT ?");
    s.Bind(tenant, asset, after, limit + 1);  // one row more: whether more follow
    for (;;) {
      MS_ASSIGN_OR_RETURN(const bool row, s.Step());
      if (!row) break;
      if (static_cast<int64_t>(numbers.size()) == limit) {
        versions.more = true;
        break;
      }
      numbers.push_back(s.Int(0));
    }
  }
  for (const int64_t number : numbers) {
    MS_ASSIGN_OR_RETURN(VersionRecord record, ReadVersionLocked(tenant, asset, number));
    versions.items.push_back(std::move(record));
  }
  return versions;
}

// --- jobs ------------------------------------------------------------------

StatusOr<JobRecord> SqliteStore::DoGetJob(const std::string& tenant, const std::string& job_id) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT " MS_JOB_COLUMNS " FROM jobs WHERE id = ? AND tenant = ?");
  s.Bind(job_id, tenant);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return JobNotFound(job_id);
  return ReadJobRow(s);
}

StatusOr<std::optional<JobRecord>> SqliteStore::DoClaimJob(const std::string& worker, int64_t now_ms,
                                                         int64_t lease_ms) {
  MS_RETURN_IF_ERROR(CheckExclusive("ClaimJob"));
  std::lock_guard<std::mutex> lock(mu_);
  Txn txn(db_);
  MS_RETURN_IF_ERROR(txn.Begin());
  int64_t seq = 0;
  {
    // `state IN (1, 2)` matches the partial index jobs_unfinished.
    Stmt s(db_,
           "SELECT seq FROM jobs WHERE state IN (1, 2) AND (state = 1 OR lease_expires_ms < ?) "
           "ORDER BY seq LIMIT 1");
    s.Bind(now_ms);
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) return std::optional<JobRecord>();
    seq = s.Int(0);
  }
  {
    Stmt s(db_,
           "UPDATE jobs SET state = ?, attempts = attempts + 1, lease_owner = ?, lease_expires_ms = ?, "
           "updated_ms = ? WHERE seq = ?");
    s.Bind(static_cast<int64_t>(JobState::kRunning), worker, now_ms + lease_ms, NowMs(), seq);
    MS_RETURN_IF_ERROR(s.Run());
  }
  JobRecord job;
  {
    Stmt s(db_, "SELECT " MS_JOB_COLUMNS " FROM jobs WHERE seq = ?");
    s.Bind(seq);
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) return Internal("a claimed job vanished inside its transaction");
    MS_ASSIGN_OR_RETURN(job, ReadJobRow(s));
  }
  MS_RETURN_IF_ERROR(txn.Commit());
  return std::optional<JobRecord>(std::move(job));
}

Status SqliteStore::CheckLeaseLocked(const std::string& job_id, const std::string& worker, JobRecord* job) {
  Stmt s(db_, "SELECT " MS_JOB_COLUMNS " FROM jobs WHERE id = ?");
  s.Bind(job_id);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return JobNotFound(job_id);
  MS_ASSIGN_OR_RETURN(*job, ReadJobRow(s));
  return CheckLeaseHolder(job_id, worker, job->state, job->lease_owner);
}

Status SqliteStore::DoRenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms,
                               int64_t lease_ms, double progress, const std::string& message) {
  MS_RETURN_IF_ERROR(CheckExclusive("RenewLease"));
  std::lock_guard<std::mutex> lock(mu_);
  Txn txn(db_);
  MS_RETURN_IF_ERROR(txn.Begin());
  JobRecord job;
  MS_RETURN_IF_ERROR(CheckLeaseLocked(job_id, worker, &job));
  {
    Stmt s(db_, "UPDATE jobs SET lease_expires_ms = ?, progress = ?, message = ?, updated_ms = ? WHERE id = ?");
    s.Bind(now_ms + lease_ms, progress, message, NowMs(), job_id);
    MS_RETURN_IF_ERROR(s.Run());
  }
  return txn.Commit();
}

Status SqliteStore::FinishJob(const std::string& job_id, const std::string& worker, const ArtifactSummary* summary,
                              const std::string& message) {
  MS_RETURN_IF_ERROR(CheckExclusive(summary != nullptr ? "CompleteJob" : "FailJob"));
  std::lock_guard<std::mutex> lock(mu_);
  Txn txn(db_);
  MS_RETURN_IF_ERROR(txn.Begin());
  JobRecord job;
  MS_RETURN_IF_ERROR(CheckLeaseLocked(job_id, worker, &job));
  if (summary != nullptr && !blobs_->Contains(summary->artifact_sha256)) {
    return BlobMissing("summary.artifact_sha256", summary->artifact_sha256);
  }
  const int64_t now = NowMs();
  {
    Stmt s(db_, "UPDATE jobs SET state = ?, progress = ?, message = ?, updated_ms = ? WHERE id = ?");
    if (summary != nullptr) {
      s.Bind(static_cast<int64_t>(JobState::kSucceeded), 1.0, job.message, now, job_id);
    } else {
      s.Bind(static_cast<int64_t>(JobState::kFailed), job.progress, message, now, job_id);
    }
    MS_RETURN_IF_ERROR(s.Run());
  }
  if (summary != nullptr) {
    Stmt s(db_,
           "UPDATE versions SET state = ?, artifact_sha256 = ?, progressive_bytes = ?, encoder = ?, vertices = ?, "
           "faces = ?, levels = ?, level_vertices_json = ?, reliable_bytes = ?, unreliable_bytes = ?, "
           "layout_json = ?, warnings_json = ? WHERE tenant = ? AND asset = ? AND version = ? AND state = ?");
    s.Bind(static_cast<int64_t>(VersionState::kReady));
    BindSummary(s, *summary);
    s.Bind(job.tenant, job.asset, job.version, static_cast<int64_t>(VersionState::kProcessing));
    MS_RETURN_IF_ERROR(s.Run());
    if (s.Changes() != 1) return VersionNotProcessing(job_id);
  } else {
    Stmt s(db_, "UPDATE versions SET state = ?, error = ? WHERE tenant = ? AND asset = ? AND version = ? AND state = ?");
    s.Bind(static_cast<int64_t>(VersionState::kFailed), message, job.tenant, job.asset, job.version,
           static_cast<int64_t>(VersionState::kProcessing));
    MS_RETURN_IF_ERROR(s.Run());
    if (s.Changes() != 1) return VersionNotProcessing(job_id);
  }
  return txn.Commit();
}

Status SqliteStore::DoCompleteJob(const std::string& job_id, const std::string& worker,
                                const ArtifactSummary& summary) {
  return FinishJob(job_id, worker, &summary, "");
}

Status SqliteStore::DoFailJob(const std::string& job_id, const std::string& worker, const std::string& message) {
  return FinishJob(job_id, worker, nullptr, message);
}

StatusOr<int64_t> SqliteStore::DoReleaseAllLeases() {
  MS_RETURN_IF_ERROR(CheckExclusive("ReleaseAllLeases"));
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_,
         "UPDATE jobs SET state = ?, lease_owner = '', lease_expires_ms = 0, updated_ms = ? "
         "WHERE state IN (1, 2) AND state = ?");
  s.Bind(static_cast<int64_t>(JobState::kPending), NowMs(), static_cast<int64_t>(JobState::kRunning));
  MS_RETURN_IF_ERROR(s.Run());
  return static_cast<int64_t>(s.Changes());
}

StatusOr<int64_t> SqliteStore::DoCountUnfinishedJobs() {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT count(*) FROM jobs WHERE state IN (1, 2)");
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  return row ? s.Int(0) : int64_t{0};
}

// --- the artifact cache ---------------------------------------------------------

StatusOr<std::optional<ArtifactSummary>> SqliteStore::DoFindArtifact(const std::string& cache_key) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT " MS_SQLITE_SUMMARY_COLUMNS " FROM artifacts WHERE cache_key = ?");
  s.Bind(cache_key);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return std::optional<ArtifactSummary>();
  MS_ASSIGN_OR_RETURN(ArtifactSummary summary, ReadSummary(s, 0));
  return std::optional<ArtifactSummary>(std::move(summary));
}

Status SqliteStore::DoPutArtifact(const std::string& cache_key, const ArtifactSummary& summary) {
  MS_RETURN_IF_ERROR(CheckExclusive("PutArtifact"));
  std::lock_guard<std::mutex> lock(mu_);
  if (!blobs_->Contains(summary.artifact_sha256)) return BlobMissing("summary.artifact_sha256", summary.artifact_sha256);
  // cache_key, the 11 summary columns, created_ms.
  Stmt s(db_, "INSERT OR IGNORE INTO artifacts (cache_key, " MS_SQLITE_SUMMARY_COLUMNS
              ", created_ms) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  s.Bind(cache_key);
  BindSummary(s, summary);
  s.Bind(NowMs());
  return s.Run();
}

// --- API tokens -------------------------------------------------------------------

StatusOr<TokenRecord> SqliteStore::DoCreateToken(const std::string& tenant, bool read_only,
                                               const std::string& token_hash) {
  TokenRecord token;
  token.id = RandomHex(8);
  token.tenant = tenant;
  token.read_only = read_only;
  token.created_ms = NowMs();
  std::lock_guard<std::mutex> lock(mu_);
  Txn txn(db_);
  MS_RETURN_IF_ERROR(txn.Begin());
  {
    Stmt s(db_, "SELECT 1 FROM tokens WHERE token_hash = ?");
    s.Bind(token_hash);
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (row) return TokenHashExists();
  }
  {
    Stmt s(db_, "INSERT INTO tokens (id, tenant, token_hash, read_only, created_ms) VALUES (?, ?, ?, ?, ?)");
    s.Bind(token.id, tenant, token_hash, read_only, token.created_ms);
    MS_RETURN_IF_ERROR(s.Run());
  }
  MS_RETURN_IF_ERROR(txn.Commit());
  return token;
}

StatusOr<TokenRecord> SqliteStore::DoFindToken(const std::string& token_hash) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT " MS_TOKEN_COLUMNS " FROM tokens WHERE token_hash = ? AND revoked = 0");
  s.Bind(token_hash);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return NoLiveToken();
  return ReadTokenRow(s);
}

StatusOr<std::vector<TokenRecord>> SqliteStore::DoListTokens() {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT " MS_TOKEN_COLUMNS " FROM tokens ORDER BY created_ms, id");
  std::vector<TokenRecord> tokens;
  for (;;) {
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) break;
    tokens.push_back(ReadTokenRow(s));
  }
  return tokens;
}

Status SqliteStore::DoRevokeToken(const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "UPDATE tokens SET revoked = 1 WHERE id = ?");
  s.Bind(id);
  MS_RETURN_IF_ERROR(s.Run());
  if (s.Changes() == 0) return TokenNotFound(id);
  return Status::Ok();
}

}  // namespace meshstream

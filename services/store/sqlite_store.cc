#include "services/store/sqlite_store.h"

#include <dirent.h>
#include <fcntl.h>
#include <sodium.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <unordered_set>
#include <utility>

#include <nlohmann/json.hpp>

#include "services/store/file_util.h"
#include "services/store/page_token.h"

namespace meshstream {

namespace {

namespace fs = std::filesystem;

// --- the schema ------------------------------------------------------------

// What processing produced, the same columns in `versions` and `artifacts`.
#define MS_SUMMARY_COLUMNS_DDL                     \
  "artifact_sha256     TEXT NOT NULL DEFAULT '',"  \
  "progressive_bytes   INTEGER NOT NULL DEFAULT 0," \
  "encoder             TEXT NOT NULL DEFAULT '',"  \
  "vertices            INTEGER NOT NULL DEFAULT 0," \
  "faces               INTEGER NOT NULL DEFAULT 0," \
  "levels              INTEGER NOT NULL DEFAULT 0," \
  "level_vertices_json TEXT NOT NULL DEFAULT '[]'," \
  "reliable_bytes      INTEGER NOT NULL DEFAULT 0," \
  "unreliable_bytes    INTEGER NOT NULL DEFAULT 0," \
  "layout_json         TEXT NOT NULL DEFAULT '',"  \
  "warnings_json       TEXT NOT NULL DEFAULT ''"
#define MS_SUMMARY_COLUMNS                                                                            \
  "artifact_sha256, progressive_bytes, encoder, vertices, faces, levels, level_vertices_json, "        \
  "reliable_bytes, unreliable_bytes, layout_json, warnings_json"

// Schema version 1. States are the integer values of VersionState and
// JobState. uint64 figures are stored as the int64 with the same bits.
constexpr char kSchemaV1[] =
    "CREATE TABLE tokens ("
    "  id          TEXT PRIMARY KEY,"
    "  tenant      TEXT NOT NULL,"
    "  token_hash  TEXT NOT NULL UNIQUE,"
    "  read_only   INTEGER NOT NULL,"
    "  created_ms  INTEGER NOT NULL,"
    "  revoked     INTEGER NOT NULL DEFAULT 0);"
    "CREATE TABLE assets ("
    "  tenant          TEXT NOT NULL,"
    "  name            TEXT NOT NULL,"
    "  latest_version  INTEGER NOT NULL,"
    "  updated_ms      INTEGER NOT NULL,"
    "  PRIMARY KEY (tenant, name)) WITHOUT ROWID;"
    "CREATE TABLE versions ("
    "  tenant        TEXT NOT NULL,"
    "  asset         TEXT NOT NULL,"
    "  version       INTEGER NOT NULL,"
    "  state         INTEGER NOT NULL,"
    "  source_name   TEXT NOT NULL,"
    "  source_sha256 TEXT NOT NULL,"
    "  source_size   INTEGER NOT NULL,"
    "  options_json  TEXT NOT NULL,"
    "  comment       TEXT NOT NULL,"
    "  labels_json   TEXT NOT NULL,"
    "  created_ms    INTEGER NOT NULL,"
    "  job_id        TEXT NOT NULL,"
    "  error         TEXT NOT NULL DEFAULT '',"
    MS_SUMMARY_COLUMNS_DDL ","
    "  PRIMARY KEY (tenant, asset, version),"
    "  FOREIGN KEY (tenant, asset) REFERENCES assets (tenant, name)) WITHOUT ROWID;"
    "CREATE TABLE version_resources ("
    "  tenant    TEXT NOT NULL,"
    "  asset     TEXT NOT NULL,"
    "  version   INTEGER NOT NULL,"
    "  position  INTEGER NOT NULL,"
    "  name      TEXT NOT NULL,"
    "  sha256    TEXT NOT NULL,"
    "  size      INTEGER NOT NULL,"
    "  PRIMARY KEY (tenant, asset, version, position),"
    "  FOREIGN KEY (tenant, asset, version) REFERENCES versions (tenant, asset, version)) WITHOUT ROWID;"
    // seq orders jobs by creation (ClaimJob takes the oldest); it survives VACUUM.
    "CREATE TABLE jobs ("
    "  seq              INTEGER PRIMARY KEY,"
    "  id               TEXT NOT NULL UNIQUE,"
    "  tenant           TEXT NOT NULL,"
    "  asset            TEXT NOT NULL,"
    "  version          INTEGER NOT NULL,"
    "  state            INTEGER NOT NULL,"
    "  progress         REAL NOT NULL DEFAULT 0,"
    "  message          TEXT NOT NULL DEFAULT '',"
    "  attempts         INTEGER NOT NULL DEFAULT 0,"
    "  lease_owner      TEXT NOT NULL DEFAULT '',"
    "  lease_expires_ms INTEGER NOT NULL DEFAULT 0,"
    "  created_ms       INTEGER NOT NULL,"
    "  updated_ms       INTEGER NOT NULL,"
    "  FOREIGN KEY (tenant, asset, version) REFERENCES versions (tenant, asset, version));"
    "CREATE INDEX jobs_unfinished ON jobs (seq) WHERE state IN (1, 2);"
    "CREATE TABLE artifacts ("
    "  cache_key  TEXT PRIMARY KEY,"
    MS_SUMMARY_COLUMNS_DDL ","
    "  created_ms INTEGER NOT NULL);"
    // The acknowledged (fsync'd) size of each upload; the bytes are in files.
    "CREATE TABLE uploads ("
    "  tenant     TEXT NOT NULL,"
    "  upload_id  TEXT NOT NULL,"
    "  size       INTEGER NOT NULL,"
    "  updated_ms INTEGER NOT NULL,"
    "  PRIMARY KEY (tenant, upload_id)) WITHOUT ROWID;";

// kMigrations[i] takes a database from schema version i to i + 1.
constexpr const char* kMigrations[] = {kSchemaV1};
static_assert(sizeof kMigrations / sizeof kMigrations[0] == SqliteStore::kSchemaVersion,
              "one migration per schema version");

constexpr int kBusyTimeoutMs = 5000;
constexpr size_t kMaxKeyBytes = 1024;  // cache keys, token hashes, worker names

// --- SQLite helpers ----------------------------------------------------------

Status SqlError(sqlite3* db, int rc, const std::string& what) {
  const std::string message = "sqlite: " + what + ": " + (db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
  switch (rc & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return Unavailable(message);
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return DataLoss(message);
    case SQLITE_FULL:
      return ResourceExhausted(message);
    case SQLITE_IOERR:
    case SQLITE_CANTOPEN:
    case SQLITE_READONLY:
    case SQLITE_PERM:
      return IoError(message);
    default:
      return Internal(message);
  }
}

// A prepared statement with parameters bound in order. Errors of prepare and
// bind are kept and returned by the first Step.
class Stmt {
 public:
  Stmt(sqlite3* db, const char* sql) : db_(db) {
    const int rc = sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr);
    if (rc != SQLITE_OK) error_ = SqlError(db, rc, std::string("prepare '") + Head(sql) + "'");
  }
  ~Stmt() { sqlite3_finalize(stmt_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  template <typename... Args>
  Stmt& Bind(const Args&... args) {
    (BindOne(args), ...);
    return *this;
  }

  // true: a row is ready; false: the statement is done.
  StatusOr<bool> Step() {
    if (!error_.ok()) return error_;
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    return SqlError(db_, rc, Head(sqlite3_sql(stmt_)));
  }
  // Runs a statement that returns no rows.
  Status Run() {
    MS_ASSIGN_OR_RETURN(const bool row, Step());
    if (row) return Internal("sqlite: a statement returned a row unexpectedly");
    return Status::Ok();
  }
  int Changes() const { return sqlite3_changes(db_); }

  int64_t Int(int col) const { return sqlite3_column_int64(stmt_, col); }
  double Real(int col) const { return sqlite3_column_double(stmt_, col); }
  std::string Text(int col) const {
    const unsigned char* text = sqlite3_column_text(stmt_, col);
    const int n = sqlite3_column_bytes(stmt_, col);
    return text == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(text), n);
  }

 private:
  static std::string Head(const char* sql) {
    std::string s = sql != nullptr ? sql : "";
    return s.size() > 48 ? s.substr(0, 48) + "..." : s;
  }
  void Check(int rc) {
    if (rc != SQLITE_OK && error_.ok()) error_ = SqlError(db_, rc, "bind");
  }
  void BindOne(int64_t v) { Check(sqlite3_bind_int64(stmt_, ++index_, v)); }
  void BindOne(uint64_t v) { BindOne(static_cast<int64_t>(v)); }
  void BindOne(int32_t v) { BindOne(static_cast<int64_t>(v)); }
  void BindOne(bool v) { BindOne(static_cast<int64_t>(v ? 1 : 0)); }
  void BindOne(double v) { Check(sqlite3_bind_double(stmt_, ++index_, v)); }
  void BindOne(const char*) = delete;  // would bind as a bool; pass a std::string
  void BindOne(const std::string& v) {
    if (v.size() > static_cast<size_t>(INT_MAX)) {
      if (error_.ok()) error_ = ResourceExhausted("sqlite: a text of " + std::to_string(v.size()) + " bytes");
      ++index_;
      return;
    }
    Check(sqlite3_bind_text(stmt_, ++index_, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  }

  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  int index_ = 0;
  Status error_;
};

Status Exec(sqlite3* db, const char* sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &error);
  if (rc == SQLITE_OK) return Status::Ok();
  std::string message = error != nullptr ? error : sqlite3_errstr(rc);
  sqlite3_free(error);
  return SqlError(nullptr, rc, message);
}

// BEGIN IMMEDIATE ... COMMIT; rolled back when destroyed uncommitted.
class Txn {
 public:
  explicit Txn(sqlite3* db) : db_(db) {}
  ~Txn() {
    if (open_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  Txn(const Txn&) = delete;
  Txn& operator=(const Txn&) = delete;
  Status Begin() {
    MS_RETURN_IF_ERROR(Exec(db_, "BEGIN IMMEDIATE"));
    open_ = true;
    return Status::Ok();
  }
  Status Commit() {
    MS_RETURN_IF_ERROR(Exec(db_, "COMMIT"));
    open_ = false;
    return Status::Ok();
  }

 private:
  sqlite3* db_;
  bool open_ = false;
};

// --- files -----------------------------------------------------------------

int64_t MtimeMs(const struct stat& st) {
  return static_cast<int64_t>(st.st_mtim.tv_sec) * 1000 + st.st_mtim.tv_nsec / 1000000;
}

// Reads the pid the holder of the lock wrote into it ("unknown" when none yet).
std::string LockHolder(int fd) {
  char buf[32] = {};
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  std::string pid;
  for (ssize_t i = 0; i < n && buf[i] >= '0' && buf[i] <= '9'; ++i) pid.push_back(buf[i]);
  return pid.empty() ? "unknown" : pid;
}

// --- checks of untrusted arguments -----------------------------------------

Status CheckDigest(const std::string& field, const std::string& digest) {
  if (IsSha256Hex(digest)) return Status::Ok();
  return InvalidArgument(field + ": '" + digest.substr(0, 80) + "' is not a SHA-256 (64 lower-case hex digits)");
}

Status CheckKey(const std::string& field, const std::string& key) {
  if (key.empty()) return InvalidArgument(field + ": must not be empty");
  if (key.size() > kMaxKeyBytes) {
    return InvalidArgument(field + ": " + std::to_string(key.size()) + " bytes, at most " +
                           std::to_string(kMaxKeyBytes));
  }
  return Status::Ok();
}

Status CheckLeaseArguments(const std::string& worker, int64_t now_ms, int64_t lease_ms) {
  MS_RETURN_IF_ERROR(CheckKey("worker", worker));
  if (now_ms < 0) return InvalidArgument("now_ms: must not be negative");
  if (lease_ms <= 0) return InvalidArgument("lease_ms: must be positive");
  if (now_ms > INT64_MAX - lease_ms) return InvalidArgument("lease_ms: now_ms + lease_ms overflows");
  return Status::Ok();
}

// Upload files live in a folder named after the tenant: "." and ".." pass
// IsValidName but would name the uploads folder itself or its parent.
Status CheckUploadNames(const std::string& tenant, const std::string& upload_id) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  if (tenant == "." || tenant == "..") return InvalidArgument("tenant: '" + tenant + "' cannot hold uploads");
  return CheckName("upload_id", upload_id);
}

std::string AssetNotFound(const std::string& asset) { return "asset " + asset + " does not exist"; }
std::string JobNotFound(const std::string& id) { return "job " + id + " does not exist"; }
std::string UploadNotFound(const std::string& id) { return "upload " + id + " does not exist"; }

const char* JobStateName(int64_t state) {
  switch (state) {
    case static_cast<int64_t>(JobState::kPending): return "PENDING";
    case static_cast<int64_t>(JobState::kRunning): return "RUNNING";
    case static_cast<int64_t>(JobState::kSucceeded): return "SUCCEEDED";
    case static_cast<int64_t>(JobState::kFailed): return "FAILED";
    default: return "in an unknown state";
  }
}

// --- JSON columns (nlohmann throws; nothing escapes this file) --------------

StatusOr<std::string> LabelsToJson(const std::map<std::string, std::string>& labels) {
  try {
    return nlohmann::json(labels).dump();
  } catch (const std::exception&) {
    return InvalidArgument("labels: keys and values must be valid UTF-8");
  }
}

StatusOr<std::map<std::string, std::string>> LabelsFromJson(const std::string& text) {
  try {
    return nlohmann::json::parse(text).get<std::map<std::string, std::string>>();
  } catch (const std::exception&) {
    return DataLoss("versions.labels_json is not a JSON object of strings");
  }
}

std::string LevelsToJson(const std::vector<int64_t>& levels) {
  try {
    return nlohmann::json(levels).dump();
  } catch (const std::exception&) {
    return "[]";  // integers always serialize; only allocation could fail
  }
}

StatusOr<std::vector<int64_t>> LevelsFromJson(const std::string& text) {
  try {
    return nlohmann::json::parse(text).get<std::vector<int64_t>>();
  } catch (const std::exception&) {
    return DataLoss("level_vertices_json is not a JSON array of integers");
  }
}

// --- rows ------------------------------------------------------------------

void BindSummary(Stmt& s, const ArtifactSummary& a) {
  s.Bind(a.artifact_sha256, a.progressive_bytes, a.encoder, a.vertices, a.faces, a.levels,
         LevelsToJson(a.level_vertices), a.reliable_bytes, a.unreliable_bytes, a.layout_json, a.warnings_json);
}

// Reads the MS_SUMMARY_COLUMNS starting at column `col`.
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
  "labels_json, created_ms, job_id, error, " MS_SUMMARY_COLUMNS
constexpr int kVersionSummaryColumn = 13;  // where MS_SUMMARY_COLUMNS start in MS_VERSION_COLUMNS

StatusOr<VersionRecord> ReadVersionRow(const Stmt& s) {
  VersionRecord v;
  v.tenant = s.Text(0);
  v.asset = s.Text(1);
  v.version = s.Int(2);
  const int64_t state = s.Int(3);
  if (state < 1 || state > 3) return DataLoss("versions row has the unknown state " + std::to_string(state));
  v.state = static_cast<VersionState>(state);
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
  const int64_t state = s.Int(4);
  if (state < 1 || state > 4) return DataLoss("jobs row has the unknown state " + std::to_string(state));
  j.state = static_cast<JobState>(state);
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

// The blob sink of the embedded store: a FileBlobStore writer.
class FileBlobSink final : public BlobSink {
 public:
  explicit FileBlobSink(BlobWriter writer) : writer_(std::move(writer)) {}
  Status Append(const uint8_t* data, size_t size) override { return writer_.Append(data, size); }
  uint64_t size() const override { return writer_.size(); }
  StatusOr<std::string> Commit(const std::string& expected_sha256) override {
    if (!expected_sha256.empty()) MS_RETURN_IF_ERROR(CheckDigest("expected_sha256", expected_sha256));
    return writer_.Commit(expected_sha256);
  }

 private:
  BlobWriter writer_;
};

// Sets the connection up and migrates the schema (when `may_migrate`; else an
// older schema is FailedPrecondition).
Status SetUpDatabase(sqlite3* db, const std::string& path, bool may_migrate) {
  sqlite3_extended_result_codes(db, 1);
  if (const int rc = sqlite3_busy_timeout(db, kBusyTimeoutMs); rc != SQLITE_OK) return SqlError(db, rc, path);
  {
    Stmt wal(db, "PRAGMA journal_mode = WAL");
    MS_ASSIGN_OR_RETURN(const bool row, wal.Step());
    if (!row || wal.Text(0) != "wal") {
      return FailedPrecondition(path + ": SQLite refused WAL mode (journal_mode is '" +
                                (row ? wal.Text(0) : std::string()) + "')");
    }
  }
  MS_RETURN_IF_ERROR(Exec(db, "PRAGMA synchronous = FULL; PRAGMA foreign_keys = ON"));

  int64_t version = 0;
  {
    Stmt read(db, "PRAGMA user_version");
    MS_ASSIGN_OR_RETURN(const bool row, read.Step());
    if (row) version = read.Int(0);
  }
  if (version > SqliteStore::kSchemaVersion) {
    return FailedPrecondition(path + ": schema version " + std::to_string(version) + " is newer than the " +
                              std::to_string(SqliteStore::kSchemaVersion) +
                              " this meshstream knows; run a newer meshstream");
  }
  if (version < 0) return DataLoss(path + ": schema version " + std::to_string(version));
  if (version < SqliteStore::kSchemaVersion && !may_migrate) {
    return FailedPrecondition(path + ": schema version " + std::to_string(version) + " is older than the " +
                              std::to_string(SqliteStore::kSchemaVersion) +
                              " this meshstream writes, and the server that has the store open migrates it "
                              "(restart that server with this meshstream first)");
  }
  for (int64_t step = version; step < SqliteStore::kSchemaVersion; ++step) {
    Txn txn(db);
    MS_RETURN_IF_ERROR(txn.Begin());
    MS_RETURN_IF_ERROR(Exec(db, kMigrations[step]).WithContext(path + ": migration to schema " +
                                                              std::to_string(step + 1)));
    // PRAGMA takes no parameters; the value is our own integer.
    const std::string set = "PRAGMA user_version = " + std::to_string(step + 1);
    MS_RETURN_IF_ERROR(Exec(db, set.c_str()));
    MS_RETURN_IF_ERROR(txn.Commit());
  }
  return Status::Ok();
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
  if (Status set_up = SetUpDatabase(db, path, locked); !set_up.ok()) return fail(set_up, db);
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

// --- blobs -------------------------------------------------------------------

StatusOr<std::unique_ptr<BlobSink>> SqliteStore::NewBlob() {
  MS_RETURN_IF_ERROR(CheckExclusive("NewBlob"));
  MS_ASSIGN_OR_RETURN(BlobWriter writer, blobs_->NewWriter());
  return std::unique_ptr<BlobSink>(new FileBlobSink(std::move(writer)));
}

StatusOr<std::vector<uint8_t>> SqliteStore::GetBlob(const std::string& sha256, uint64_t max_bytes) {
  MS_RETURN_IF_ERROR(CheckExclusive("GetBlob"));
  MS_RETURN_IF_ERROR(CheckDigest("sha256", sha256));
  return blobs_->Get(sha256, max_bytes);
}

StatusOr<bool> SqliteStore::HasBlob(const std::string& sha256) {
  MS_RETURN_IF_ERROR(CheckExclusive("HasBlob"));
  MS_RETURN_IF_ERROR(CheckDigest("sha256", sha256));
  return blobs_->Contains(sha256);
}

StatusOr<uint64_t> SqliteStore::RemoveOrphanBlobs(int64_t min_age_ms) {
  MS_RETURN_IF_ERROR(CheckExclusive("RemoveOrphanBlobs"));
  if (min_age_ms < 0) return InvalidArgument("min_age_ms: must not be negative");
  // Walk the folder without the lock: blobs old enough to go if no row names them.
  std::vector<std::string> candidates;
  const int64_t cutoff_ms = NowMs() - min_age_ms;
  MS_ASSIGN_OR_RETURN(const std::vector<std::string> prefixes, ListFolder(blobs_->root()));
  for (const std::string& prefix : prefixes) {
    if (prefix.size() != 2) continue;  // the prefix folders, not tmp/
    const std::string folder = blobs_->root() + "/" + prefix;
    struct stat st {};
    if (stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) continue;
    MS_ASSIGN_OR_RETURN(const std::vector<std::string> names, ListFolder(folder));
    for (const std::string& name : names) {
      if (!IsSha256Hex(name) || name.compare(0, 2, prefix) != 0) continue;
      const std::string path = folder + "/" + name;
      if (stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && MtimeMs(st) <= cutoff_ms) {
        candidates.push_back(name);
      }
    }
  }
  if (candidates.empty()) return uint64_t{0};

  // Under the lock, so no CreateVersion, CompleteJob or PutArtifact (which
  // check their blobs under it) can start naming a blob while it goes.
  std::lock_guard<std::mutex> lock(mu_);
  std::unordered_set<std::string> named;
  {
    Stmt s(db_,
           "SELECT source_sha256 FROM versions UNION SELECT artifact_sha256 FROM versions "
           "UNION SELECT sha256 FROM version_resources UNION SELECT artifact_sha256 FROM artifacts");
    for (;;) {
      MS_ASSIGN_OR_RETURN(const bool row, s.Step());
      if (!row) break;
      named.insert(s.Text(0));
    }
  }
  uint64_t removed = 0;
  for (const std::string& digest : candidates) {
    if (named.count(digest) != 0) continue;
    // A writer of the same bytes may have renamed a fresh copy over it since.
    struct stat st {};
    const std::string path = blobs_->root() + "/" + digest.substr(0, 2) + "/" + digest;
    if (stat(path.c_str(), &st) != 0 || MtimeMs(st) > cutoff_ms) continue;
    const Status status = blobs_->Remove(digest);
    if (status.ok()) {
      ++removed;
    } else if (status.code() != StatusCode::kNotFound) {
      return status;
    }
  }
  return removed;
}

// --- uploads -------------------------------------------------------------------

std::string SqliteStore::UploadPath(const std::string& tenant, const std::string& upload_id) const {
  return dir_ + "/uploads/" + tenant + "/" + upload_id + ".part";
}

std::mutex& SqliteStore::UploadLock(const std::string& tenant, const std::string& upload_id) {
  const size_t h = std::hash<std::string>()(tenant) * 31 + std::hash<std::string>()(upload_id);
  return upload_locks_[h % upload_locks_.size()];
}

Status SqliteStore::RemoveUploadFile(const std::string& tenant, const std::string& upload_id) const {
  const std::string path = UploadPath(tenant, upload_id);
  if (unlink(path.c_str()) != 0 && errno != ENOENT) return Errno(path);
  return Status::Ok();
}

StatusOr<std::optional<uint64_t>> SqliteStore::UploadRowLocked(const std::string& tenant,
                                                                const std::string& upload_id) {
  Stmt s(db_, "SELECT size FROM uploads WHERE tenant = ? AND upload_id = ?");
  s.Bind(tenant, upload_id);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return std::optional<uint64_t>();
  return std::optional<uint64_t>(static_cast<uint64_t>(s.Int(0)));
}

Status SqliteStore::DeleteUploadRowLocked(const std::string& tenant, const std::string& upload_id) {
  Stmt s(db_, "DELETE FROM uploads WHERE tenant = ? AND upload_id = ?");
  s.Bind(tenant, upload_id);
  return s.Run();
}

StatusOr<uint64_t> SqliteStore::UploadSize(const std::string& tenant, const std::string& upload_id) {
  MS_RETURN_IF_ERROR(CheckUploadNames(tenant, upload_id));
  std::lock_guard<std::mutex> lock(mu_);
  MS_ASSIGN_OR_RETURN(const std::optional<uint64_t> size, UploadRowLocked(tenant, upload_id));
  if (!size) return NotFound(UploadNotFound(upload_id));
  return *size;
}

Status SqliteStore::AppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset,
                                 const uint8_t* data, size_t size) {
  MS_RETURN_IF_ERROR(CheckExclusive("AppendUpload"));
  MS_RETURN_IF_ERROR(CheckUploadNames(tenant, upload_id));
  if (data == nullptr && size > 0) return InvalidArgument("data: null with " + std::to_string(size) + " bytes");
  if (offset > static_cast<uint64_t>(INT64_MAX) - size) return ResourceExhausted("upload " + upload_id + ": too large");
  std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
  std::optional<uint64_t> durable;
  {
    std::lock_guard<std::mutex> lock(mu_);
    MS_ASSIGN_OR_RETURN(durable, UploadRowLocked(tenant, upload_id));
  }
  const uint64_t have = durable.value_or(0);
  if (offset != have) {
    return FailedPrecondition("upload " + upload_id + " has " + std::to_string(have) +
                              " durable bytes; an append must start there, not at offset " + std::to_string(offset));
  }

  const std::string folder = dir_ + "/uploads/" + tenant;
  MS_ASSIGN_OR_RETURN(const bool new_folder, MakeFolder(folder));
  if (new_folder) MS_RETURN_IF_ERROR(SyncFolder(dir_ + "/uploads"));
  const std::string path = UploadPath(tenant, upload_id);
  // A file may exist without a row (a crash before the first row): reused.
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0640);
  if (fd < 0) return Errno(path);
  // Bytes past the durable size were never acknowledged (a crash between
  // write and commit): the client sends them again.
  Status written = Status::Ok();
  if (ftruncate(fd, static_cast<off_t>(offset)) != 0) written = Errno(path + ": truncate");
  uint64_t at = offset;
  while (written.ok() && at < offset + size) {
    const ssize_t n = pwrite(fd, data + (at - offset), offset + size - at, static_cast<off_t>(at));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      written = Errno(path);
      break;
    }
    at += static_cast<uint64_t>(n);
  }
  if (written.ok() && fsync(fd) != 0) written = Errno(path + ": fsync");
  close(fd);
  MS_RETURN_IF_ERROR(written);
  if (!durable) MS_RETURN_IF_ERROR(SyncFolder(folder));  // the file's name is durable before its row

  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "INSERT OR REPLACE INTO uploads (tenant, upload_id, size, updated_ms) VALUES (?, ?, ?, ?)");
  s.Bind(tenant, upload_id, offset + size, NowMs());
  return s.Run();
}

StatusOr<std::string> SqliteStore::CommitUpload(const std::string& tenant, const std::string& upload_id,
                                                const std::string& expected_sha256) {
  MS_RETURN_IF_ERROR(CheckExclusive("CommitUpload"));
  MS_RETURN_IF_ERROR(CheckUploadNames(tenant, upload_id));
  if (!expected_sha256.empty()) MS_RETURN_IF_ERROR(CheckDigest("expected_sha256", expected_sha256));
  std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
  std::optional<uint64_t> size;
  {
    std::lock_guard<std::mutex> lock(mu_);
    MS_ASSIGN_OR_RETURN(size, UploadRowLocked(tenant, upload_id));
  }
  if (!size) return NotFound(UploadNotFound(upload_id));

  // FileBlobStore has no way to adopt a file, so the bytes are copied into a
  // blob writer, which hashes them and makes the blob durable.
  const std::string path = UploadPath(tenant, upload_id);
  MS_ASSIGN_OR_RETURN(BlobWriter writer, blobs_->NewWriter());
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  Status copied = Status::Ok();
  if (fd < 0) copied = errno == ENOENT ? DataLoss("upload " + upload_id + ": its file is missing") : Errno(path);
  std::vector<uint8_t> buffer(fd >= 0 ? 1 << 20 : 0);
  uint64_t done = 0;
  while (copied.ok() && done < *size) {
    const size_t want = static_cast<size_t>(std::min<uint64_t>(buffer.size(), *size - done));
    const ssize_t n = pread(fd, buffer.data(), want, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      copied = Errno(path);
    } else if (n == 0) {
      copied = DataLoss("upload " + upload_id + ": the file has " + std::to_string(done) + " bytes, fewer than the " +
                        std::to_string(*size) + " acknowledged");
    } else {
      copied = writer.Append(buffer.data(), static_cast<size_t>(n));
      done += static_cast<uint64_t>(n);
    }
  }
  if (fd >= 0) close(fd);
  StatusOr<std::string> digest = copied.ok() ? writer.Commit(expected_sha256) : StatusOr<std::string>(copied);
  if (!digest.ok() && digest.status().code() != StatusCode::kDataLoss) return digest.status();  // retry may work

  // Committed, or bytes that can never become the announced blob: the upload goes.
  {
    std::lock_guard<std::mutex> lock(mu_);
    MS_RETURN_IF_ERROR(DeleteUploadRowLocked(tenant, upload_id));
  }
  MS_RETURN_IF_ERROR(RemoveUploadFile(tenant, upload_id));
  if (!digest.ok()) {
    return DataLoss("upload " + upload_id + ": " + digest.status().message() + "; the upload is discarded");
  }
  return digest;
}

Status SqliteStore::DiscardUpload(const std::string& tenant, const std::string& upload_id) {
  MS_RETURN_IF_ERROR(CheckExclusive("DiscardUpload"));
  MS_RETURN_IF_ERROR(CheckUploadNames(tenant, upload_id));
  std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
  {
    std::lock_guard<std::mutex> lock(mu_);
    MS_ASSIGN_OR_RETURN(const std::optional<uint64_t> size, UploadRowLocked(tenant, upload_id));
    if (!size) return NotFound(UploadNotFound(upload_id));
    MS_RETURN_IF_ERROR(DeleteUploadRowLocked(tenant, upload_id));
  }
  return RemoveUploadFile(tenant, upload_id);
}

StatusOr<uint64_t> SqliteStore::ExpireUploads(int64_t max_idle_ms) {
  MS_RETURN_IF_ERROR(CheckExclusive("ExpireUploads"));
  if (max_idle_ms < 0) return InvalidArgument("max_idle_ms: must not be negative");
  const int64_t cutoff_ms = NowMs() - max_idle_ms;
  std::vector<std::pair<std::string, std::string>> idle;
  {
    std::lock_guard<std::mutex> lock(mu_);
    Stmt s(db_, "SELECT tenant, upload_id FROM uploads WHERE updated_ms <= ?");
    s.Bind(cutoff_ms);
    for (;;) {
      MS_ASSIGN_OR_RETURN(const bool row, s.Step());
      if (!row) break;
      idle.emplace_back(s.Text(0), s.Text(1));
    }
  }
  uint64_t removed = 0;
  for (const auto& [tenant, upload_id] : idle) {
    std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
    {
      std::lock_guard<std::mutex> lock(mu_);
      // Still idle? An append may have come in since the query.
      Stmt s(db_, "DELETE FROM uploads WHERE tenant = ? AND upload_id = ? AND updated_ms <= ?");
      s.Bind(tenant, upload_id, cutoff_ms);
      MS_RETURN_IF_ERROR(s.Run());
      if (s.Changes() == 0) continue;
    }
    MS_RETURN_IF_ERROR(RemoveUploadFile(tenant, upload_id));
    ++removed;
  }

  // Files without a row: a crash between writing the first bytes and their
  // row, or between removing a row and its file. Not counted as uploads.
  MS_ASSIGN_OR_RETURN(const std::vector<std::string> tenants, ListFolder(dir_ + "/uploads"));
  for (const std::string& tenant : tenants) {
    const std::string folder = dir_ + "/uploads/" + tenant;
    struct stat st {};
    if (!CheckUploadNames(tenant, "x").ok() || stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) continue;
    MS_ASSIGN_OR_RETURN(const std::vector<std::string> files, ListFolder(folder));
    for (const std::string& file : files) {
      constexpr size_t kSuffix = sizeof ".part" - 1;
      if (file.size() <= kSuffix || file.compare(file.size() - kSuffix, kSuffix, ".part") != 0) continue;
      const std::string upload_id = file.substr(0, file.size() - kSuffix);
      if (!IsValidName(upload_id) || stat((folder + "/" + file).c_str(), &st) != 0 || MtimeMs(st) > cutoff_ms) {
        continue;
      }
      std::lock_guard<std::mutex> upload_lock(UploadLock(tenant, upload_id));
      std::optional<uint64_t> row;
      {
        std::lock_guard<std::mutex> lock(mu_);
        MS_ASSIGN_OR_RETURN(row, UploadRowLocked(tenant, upload_id));
      }
      if (!row) MS_RETURN_IF_ERROR(RemoveUploadFile(tenant, upload_id));
    }
  }
  return removed;
}

// --- assets and versions ----------------------------------------------------

Status SqliteStore::CheckAssetLocked(const std::string& tenant, const std::string& asset) {
  Stmt s(db_, "SELECT 1 FROM assets WHERE tenant = ? AND name = ?");
  s.Bind(tenant, asset);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  return row ? Status::Ok() : NotFound(AssetNotFound(asset));
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
      return NotFound("asset " + asset + " has no version " + std::to_string(version));
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

StatusOr<VersionRecord> SqliteStore::CreateVersion(const NewVersion& v) {
  MS_RETURN_IF_ERROR(CheckExclusive("CreateVersion"));
  MS_RETURN_IF_ERROR(CheckName("tenant", v.tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", v.asset));
  MS_RETURN_IF_ERROR(CheckDigest("source.sha256", v.source.sha256));
  for (size_t i = 0; i < v.resources.size(); ++i) {
    MS_RETURN_IF_ERROR(CheckDigest("resources[" + std::to_string(i) + "].sha256", v.resources[i].sha256));
  }
  MS_ASSIGN_OR_RETURN(const std::string labels_json, LabelsToJson(v.labels));

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
  if (!blobs_->Contains(v.source.sha256)) {
    return FailedPrecondition("source.sha256: blob " + v.source.sha256 + " does not exist (store the bytes first)");
  }
  for (size_t i = 0; i < v.resources.size(); ++i) {
    if (!blobs_->Contains(v.resources[i].sha256)) {
      return FailedPrecondition("resources[" + std::to_string(i) + "].sha256: blob " + v.resources[i].sha256 +
                                " does not exist (store the bytes first)");
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

StatusOr<VersionRecord> SqliteStore::GetVersion(const std::string& tenant, const std::string& asset,
                                                int64_t version) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
  if (version < 0) return InvalidArgument("version: must not be negative");
  std::lock_guard<std::mutex> lock(mu_);
  if (version == 0) {
    Stmt s(db_, "SELECT latest_version FROM assets WHERE tenant = ? AND name = ?");
    s.Bind(tenant, asset);
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) return NotFound(AssetNotFound(asset));
    version = s.Int(0);
  }
  return ReadVersionLocked(tenant, asset, version);
}

StatusOr<VersionRecord> SqliteStore::GetLatestReadyVersion(const std::string& tenant, const std::string& asset) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
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
    return NotFound("asset " + asset + " has no READY version");
  }
  return ReadVersionLocked(tenant, asset, version);
}

StatusOr<Page<AssetRecord>> SqliteStore::ListAssets(const std::string& tenant, int32_t page_size,
                                                    const std::string& page_token) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_ASSIGN_OR_RETURN(const int32_t size, EffectivePageSize(page_size));
  MS_ASSIGN_OR_RETURN(const std::string after, DecodeAssetsPageToken(page_token));
  std::lock_guard<std::mutex> lock(mu_);
  Page<AssetRecord> page;
  Stmt s(db_,
         "SELECT name, latest_version, updated_ms FROM assets WHERE tenant = ? AND name > ? ORDER BY name LIMIT ?");
  s.Bind(tenant, after, static_cast<int64_t>(size) + 1);  // one more: is there a next page?
  for (;;) {
    MS_ASSIGN_OR_RETURN(const bool row, s.Step());
    if (!row) break;
    page.items.push_back(AssetRecord{tenant, s.Text(0), s.Int(1), s.Int(2)});
  }
  if (page.items.size() > static_cast<size_t>(size)) {
    page.items.pop_back();
    page.next_page_token = EncodeAssetsPageToken(page.items.back().name);
  }
  return page;
}

StatusOr<Page<VersionRecord>> SqliteStore::ListVersions(const std::string& tenant, const std::string& asset,
                                                        int32_t page_size, const std::string& page_token) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
  MS_ASSIGN_OR_RETURN(const int32_t size, EffectivePageSize(page_size));
  MS_ASSIGN_OR_RETURN(const int64_t after, DecodeVersionsPageToken(page_token));
  std::lock_guard<std::mutex> lock(mu_);
  MS_RETURN_IF_ERROR(CheckAssetLocked(tenant, asset));
  std::vector<int64_t> numbers;
  {
    Stmt s(db_, "SELECT version FROM versions WHERE tenant = ? AND asset = ? AND version > ? ORDER BY version LIMIT ?");
    s.Bind(tenant, asset, after, static_cast<int64_t>(size) + 1);
    for (;;) {
      MS_ASSIGN_OR_RETURN(const bool row, s.Step());
      if (!row) break;
      numbers.push_back(s.Int(0));
    }
  }
  Page<VersionRecord> page;
  const bool more = numbers.size() > static_cast<size_t>(size);
  if (more) numbers.pop_back();
  for (const int64_t number : numbers) {
    MS_ASSIGN_OR_RETURN(VersionRecord record, ReadVersionLocked(tenant, asset, number));
    page.items.push_back(std::move(record));
  }
  if (more) page.next_page_token = EncodeVersionsPageToken(numbers.back());
  return page;
}

// --- jobs ------------------------------------------------------------------

StatusOr<JobRecord> SqliteStore::GetJob(const std::string& tenant, const std::string& job_id) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT " MS_JOB_COLUMNS " FROM jobs WHERE id = ? AND tenant = ?");
  s.Bind(job_id, tenant);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return NotFound(JobNotFound(job_id));
  return ReadJobRow(s);
}

StatusOr<std::optional<JobRecord>> SqliteStore::ClaimJob(const std::string& worker, int64_t now_ms,
                                                         int64_t lease_ms) {
  MS_RETURN_IF_ERROR(CheckExclusive("ClaimJob"));
  MS_RETURN_IF_ERROR(CheckLeaseArguments(worker, now_ms, lease_ms));
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
  if (!row) return NotFound(JobNotFound(job_id));
  MS_ASSIGN_OR_RETURN(*job, ReadJobRow(s));
  if (job->lease_owner != worker) return Aborted("job " + job_id + ": the lease is held by another worker");
  if (job->state != JobState::kRunning) {
    return FailedPrecondition("job " + job_id + " is already " + JobStateName(static_cast<int64_t>(job->state)));
  }
  return Status::Ok();
}

Status SqliteStore::RenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms,
                               int64_t lease_ms, double progress, const std::string& message) {
  MS_RETURN_IF_ERROR(CheckExclusive("RenewLease"));
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  MS_RETURN_IF_ERROR(CheckLeaseArguments(worker, now_ms, lease_ms));
  if (!(progress >= 0.0 && progress <= 1.0)) return InvalidArgument("progress: must be between 0 and 1");
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
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  MS_RETURN_IF_ERROR(CheckKey("worker", worker));
  if (summary != nullptr) MS_RETURN_IF_ERROR(CheckDigest("summary.artifact_sha256", summary->artifact_sha256));
  std::lock_guard<std::mutex> lock(mu_);
  Txn txn(db_);
  MS_RETURN_IF_ERROR(txn.Begin());
  JobRecord job;
  MS_RETURN_IF_ERROR(CheckLeaseLocked(job_id, worker, &job));
  if (summary != nullptr && !blobs_->Contains(summary->artifact_sha256)) {
    return FailedPrecondition("summary.artifact_sha256: blob " + summary->artifact_sha256 +
                              " does not exist (store the artifact first)");
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
    if (s.Changes() != 1) return Internal("job " + job_id + ": its version is not PROCESSING");
  } else {
    Stmt s(db_, "UPDATE versions SET state = ?, error = ? WHERE tenant = ? AND asset = ? AND version = ? AND state = ?");
    s.Bind(static_cast<int64_t>(VersionState::kFailed), message, job.tenant, job.asset, job.version,
           static_cast<int64_t>(VersionState::kProcessing));
    MS_RETURN_IF_ERROR(s.Run());
    if (s.Changes() != 1) return Internal("job " + job_id + ": its version is not PROCESSING");
  }
  return txn.Commit();
}

Status SqliteStore::CompleteJob(const std::string& job_id, const std::string& worker,
                                const ArtifactSummary& summary) {
  return FinishJob(job_id, worker, &summary, "");
}

Status SqliteStore::FailJob(const std::string& job_id, const std::string& worker, const std::string& message) {
  return FinishJob(job_id, worker, nullptr, message);
}

StatusOr<int64_t> SqliteStore::ReleaseAllLeases() {
  MS_RETURN_IF_ERROR(CheckExclusive("ReleaseAllLeases"));
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_,
         "UPDATE jobs SET state = ?, lease_owner = '', lease_expires_ms = 0, updated_ms = ? "
         "WHERE state IN (1, 2) AND state = ?");
  s.Bind(static_cast<int64_t>(JobState::kPending), NowMs(), static_cast<int64_t>(JobState::kRunning));
  MS_RETURN_IF_ERROR(s.Run());
  return static_cast<int64_t>(s.Changes());
}

StatusOr<int64_t> SqliteStore::CountUnfinishedJobs() {
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT count(*) FROM jobs WHERE state IN (1, 2)");
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  return row ? s.Int(0) : int64_t{0};
}

// --- the artifact cache ---------------------------------------------------------

StatusOr<std::optional<ArtifactSummary>> SqliteStore::FindArtifact(const std::string& cache_key) {
  MS_RETURN_IF_ERROR(CheckKey("cache_key", cache_key));
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT " MS_SUMMARY_COLUMNS " FROM artifacts WHERE cache_key = ?");
  s.Bind(cache_key);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return std::optional<ArtifactSummary>();
  MS_ASSIGN_OR_RETURN(ArtifactSummary summary, ReadSummary(s, 0));
  return std::optional<ArtifactSummary>(std::move(summary));
}

Status SqliteStore::PutArtifact(const std::string& cache_key, const ArtifactSummary& summary) {
  MS_RETURN_IF_ERROR(CheckExclusive("PutArtifact"));
  MS_RETURN_IF_ERROR(CheckKey("cache_key", cache_key));
  MS_RETURN_IF_ERROR(CheckDigest("summary.artifact_sha256", summary.artifact_sha256));
  std::lock_guard<std::mutex> lock(mu_);
  if (!blobs_->Contains(summary.artifact_sha256)) {
    return FailedPrecondition("summary.artifact_sha256: blob " + summary.artifact_sha256 +
                              " does not exist (store the artifact first)");
  }
  // cache_key, the 11 summary columns, created_ms.
  Stmt s(db_, "INSERT OR IGNORE INTO artifacts (cache_key, " MS_SUMMARY_COLUMNS
              ", created_ms) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  s.Bind(cache_key);
  BindSummary(s, summary);
  s.Bind(NowMs());
  return s.Run();
}

// --- API tokens -------------------------------------------------------------------

StatusOr<TokenRecord> SqliteStore::CreateToken(const std::string& tenant, bool read_only,
                                               const std::string& token_hash) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckKey("token_hash", token_hash));
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
    if (row) return AlreadyExists("token_hash: a token with this hash exists");
  }
  {
    Stmt s(db_, "INSERT INTO tokens (id, tenant, token_hash, read_only, created_ms) VALUES (?, ?, ?, ?, ?)");
    s.Bind(token.id, tenant, token_hash, read_only, token.created_ms);
    MS_RETURN_IF_ERROR(s.Run());
  }
  MS_RETURN_IF_ERROR(txn.Commit());
  return token;
}

StatusOr<TokenRecord> SqliteStore::FindToken(const std::string& token_hash) {
  MS_RETURN_IF_ERROR(CheckKey("token_hash", token_hash));
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "SELECT " MS_TOKEN_COLUMNS " FROM tokens WHERE token_hash = ? AND revoked = 0");
  s.Bind(token_hash);
  MS_ASSIGN_OR_RETURN(const bool row, s.Step());
  if (!row) return NotFound("no live token has this hash");
  return ReadTokenRow(s);
}

StatusOr<std::vector<TokenRecord>> SqliteStore::ListTokens() {
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

Status SqliteStore::RevokeToken(const std::string& id) {
  MS_RETURN_IF_ERROR(CheckName("id", id));
  std::lock_guard<std::mutex> lock(mu_);
  Stmt s(db_, "UPDATE tokens SET revoked = 1 WHERE id = ?");
  s.Bind(id);
  MS_RETURN_IF_ERROR(s.Run());
  if (s.Changes() == 0) return NotFound("token " + id + " does not exist");
  return Status::Ok();
}

}  // namespace meshstream

// The embedded store (docs/design/store.md, "The embedded store (SQLite)"): one
// folder that holds everything a single meshstream server keeps.
//
//   <dir>/LOCK              flock'd by the process that has the store open
//   <dir>/meta.sqlite3      metadata (WAL mode; -wal and -shm beside it)
//   <dir>/blobs/...         content-addressed blobs (FileBlobStore)
//   <dir>/uploads/<tenant>/<upload_id>.part   bytes of resumable uploads
//
// One server per folder: an exclusive Open takes an exclusive flock on
// <dir>/LOCK (close-on-exec) and answers Unavailable "<dir> is in use by
// another meshstream process (pid N)" while another exclusive store (in this
// process or another) holds it. The kernel drops the lock when its holder
// exits or is killed, so a store opened after a crash or SIGKILL needs no
// cleanup. A shared Open (StoreLock::kShared, for tools such as the token
// verbs beside a running server) takes no lock and may only read metadata and
// manage tokens: blobs, uploads and job changes belong to the server and are
// FailedPrecondition there. SQLite's own locking (busy_timeout) orders the
// two processes' transactions.
//
// Durability: a method that returns OK has committed its change with
// synchronous=FULL (the WAL is fsync'd on every commit), and blobs and upload
// bytes are fsync'd before the rows that name them are written; so what an OK
// promised survives SIGKILL and power loss.
//
// Schema: Open migrates an older database; a shared Open does so only while
// no server holds the folder (it takes the lock for the migration).
//
// Thread safety: every method may be called from any thread at once. There is
// one SQLite connection, guarded by one mutex (metadata operations run one at
// a time; each is short). Upload bytes are written under a per-upload lock
// (striped), outside the metadata mutex; blob reads and writes take no store
// lock at all (FileBlobStore is safe for concurrent use).
//
// All SQL is fixed text with bound parameters; no caller string becomes SQL.
//
// Files: sqlite_db.{h,cc} (statements, transactions, errors),
// sqlite_schema.{h,cc} (DDL and migrations), sqlite_files.cc (blobs and
// uploads), sqlite_store.cc (opening, versions, jobs, cache, tokens). The
// arguments arrive checked by Store (store.h); refusals use store_records.h.
#ifndef MESHSTREAM_SERVICES_STORE_SQLITE_STORE_H_
#define MESHSTREAM_SERVICES_STORE_SQLITE_STORE_H_

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/store/blob_store.h"
#include "services/store/sqlite_schema.h"
#include "services/store/store.h"

struct sqlite3;

namespace meshstream {

// How an embedded store is opened (OpenStore passes it on; a PostgreSQL store
// is always shared by design and ignores it).
enum class StoreLock {
  kExclusive,  // a server: the only process with the folder open
  kShared,     // a tool beside a running server: metadata reads and tokens only
};

class SqliteStore final : public Store {
 public:
  // The schema this code writes (PRAGMA user_version). Open migrates an older
  // database step by step, each step in one transaction, and refuses a newer
  // one with FailedPrecondition (a newer meshstream wrote it).
  static constexpr int64_t kSchemaVersion = kSqliteSchemaVersion;

  // Opens (creating when needed) the store in folder `dir`.
  static StatusOr<std::unique_ptr<SqliteStore>> Open(const std::string& dir,
                                                     StoreLock lock = StoreLock::kExclusive);
  ~SqliteStore() override;
  SqliteStore(const SqliteStore&) = delete;
  SqliteStore& operator=(const SqliteStore&) = delete;

  // What the connection runs with, for logs and tests.
  struct Settings {
    std::string journal_mode;  // "wal"
    int64_t synchronous = 0;   // 2 = FULL
    int64_t busy_timeout_ms = 0;
    int64_t schema_version = 0;
  };
  StatusOr<Settings> ReadSettings();
  const std::string& dir() const { return dir_; }

  std::string backend() const override { return "sqlite"; }

 private:
  // The backend of store.h's checked methods (sqlite_files.cc: blobs and
  // uploads; sqlite_store.cc: the rest).
  StatusOr<std::unique_ptr<BlobSink>> DoNewBlob() override;
  StatusOr<std::vector<uint8_t>> DoGetBlob(const std::string& sha256, uint64_t max_bytes) override;
  StatusOr<bool> DoHasBlob(const std::string& sha256) override;
  StatusOr<uint64_t> DoRemoveOrphanBlobs(int64_t min_age_ms) override;

  StatusOr<uint64_t> DoUploadSize(const std::string& tenant, const std::string& upload_id) override;
  Status DoAppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset, const uint8_t* data,
                        size_t size) override;
  StatusOr<std::string> DoCommitUpload(const std::string& tenant, const std::string& upload_id,
                                       const std::string& expected_sha256) override;
  Status DoDiscardUpload(const std::string& tenant, const std::string& upload_id) override;
  StatusOr<uint64_t> DoExpireUploads(int64_t max_idle_ms) override;

  StatusOr<VersionRecord> DoCreateVersion(const NewVersion& version) override;
  StatusOr<VersionRecord> DoGetVersion(const std::string& tenant, const std::string& asset, int64_t version) override;
  StatusOr<VersionRecord> DoGetLatestReadyVersion(const std::string& tenant, const std::string& asset) override;
  StatusOr<PageRows<AssetRecord>> DoListAssets(const std::string& tenant, const std::string& after,
                                               int64_t limit) override;
  StatusOr<PageRows<VersionRecord>> DoListVersions(const std::string& tenant, const std::string& asset,
                                                   int64_t after, int64_t limit) override;

  StatusOr<JobRecord> DoGetJob(const std::string& tenant, const std::string& job_id) override;
  StatusOr<std::optional<JobRecord>> DoClaimJob(const std::string& worker, int64_t now_ms, int64_t lease_ms) override;
  Status DoRenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms, int64_t lease_ms,
                      double progress, const std::string& message) override;
  Status DoCompleteJob(const std::string& job_id, const std::string& worker, const ArtifactSummary& summary) override;
  Status DoFailJob(const std::string& job_id, const std::string& worker, const std::string& message) override;
  StatusOr<int64_t> DoReleaseAllLeases() override;
  StatusOr<int64_t> DoCountUnfinishedJobs() override;

  StatusOr<std::optional<ArtifactSummary>> DoFindArtifact(const std::string& cache_key) override;
  Status DoPutArtifact(const std::string& cache_key, const ArtifactSummary& summary) override;

  StatusOr<TokenRecord> DoCreateToken(const std::string& tenant, bool read_only,
                                      const std::string& token_hash) override;
  StatusOr<TokenRecord> DoFindToken(const std::string& token_hash) override;
  StatusOr<std::vector<TokenRecord>> DoListTokens() override;
  Status DoRevokeToken(const std::string& id) override;

  SqliteStore(std::string dir, StoreLock lock, int lock_fd, sqlite3* db, std::optional<FileBlobStore> blobs);

  // OK for an exclusive store; FailedPrecondition naming `operation` for a shared one.
  Status CheckExclusive(const char* operation) const;

  // Runs with mu_ held.
  StatusOr<VersionRecord> ReadVersionLocked(const std::string& tenant, const std::string& asset, int64_t version);
  Status CheckAssetLocked(const std::string& tenant, const std::string& asset);
  // The lease check shared by RenewLease, CompleteJob and FailJob: OK when
  // `worker` holds the RUNNING job; fills tenant/asset/version.
  Status CheckLeaseLocked(const std::string& job_id, const std::string& worker, JobRecord* job);
  StatusOr<std::optional<uint64_t>> UploadRowLocked(const std::string& tenant, const std::string& upload_id);
  Status DeleteUploadRowLocked(const std::string& tenant, const std::string& upload_id);
  Status FinishJob(const std::string& job_id, const std::string& worker, const ArtifactSummary* summary,
                   const std::string& message);

  // Upload files and their locks.
  std::string UploadPath(const std::string& tenant, const std::string& upload_id) const;
  std::mutex& UploadLock(const std::string& tenant, const std::string& upload_id);
  Status RemoveUploadFile(const std::string& tenant, const std::string& upload_id) const;

  const std::string dir_;
  const StoreLock lock_;
  const int lock_fd_;
  const std::optional<FileBlobStore> blobs_;  // absent in a shared store
  std::mutex mu_;  // guards db_
  sqlite3* const db_;
  std::array<std::mutex, 16> upload_locks_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_SQLITE_STORE_H_

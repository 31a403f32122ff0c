// The shared store: metadata and blobs in PostgreSQL (docs/store.md, "The
// shared store (PostgreSQL)"), so that any number of `meshstream serve`
// processes work on one database. Blobs are rows of at most 1 MiB of bytea
// under their SHA-256; the schema is migrated at open (services/store/pg_schema.h).
// A blob being written is staged in the database chunk by chunk (PgBlobSink
// below), so a sink holds at most one chunk in memory whatever the blob's size.
//
// Concurrency: every guarantee of store.h holds across processes, not just
// threads, because it is enforced by PostgreSQL: version numbers come from a
// row-locked upsert of the asset (two servers ingesting one asset get 1 and
// 2), jobs are claimed with FOR UPDATE SKIP LOCKED (never twice), upload
// offsets are checked under the upload's row lock, and leases are checked by
// owner in the UPDATE itself (the lease length and heartbeat are the
// worker's choice; the store only enforces ownership).
//
// Errors: no exception leaves a method. A lost connection is reopened once
// and the operation retried (a transaction that did not commit is rolled
// back by the server, so this is safe); failing again is Unavailable, as is a
// commit whose outcome is unknown. Serialization failures and deadlocks are
// retried a few times, then Aborted. Messages never contain the conninfo.
//
// Thread safety: every method may be called from any thread at once. The
// store owns a pool of up to `pool_size` connections (opened on demand); a
// call takes one for its transaction and waits when all are busy. A BlobSink
// is used by one thread at a time and must not outlive its store.
#ifndef MESHSTREAM_SERVICES_STORE_PG_STORE_H_
#define MESHSTREAM_SERVICES_STORE_PG_STORE_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/store/blob_store.h"
#include "services/store/store.h"

namespace meshstream {

struct PgStoreOptions {
  int pool_size = 4;          // connections at most, 1..64
  int conflict_attempts = 3;  // tries of a transaction that hit a serialization failure or deadlock
  int64_t acquire_timeout_ms = 30000;  // waiting for a free connection longer is Unavailable
};

class PgPool;
class PgStore;

// The sink PgStore::NewBlob returns. Append hashes the bytes and gathers
// them in one buffer of at most kChunkBytes; when the buffer is full and
// more bytes arrive, it is written as one row of meshstream.blob_staging
// under the sink's random staging id (an autocommit INSERT on a pooled
// connection, held only for that statement), and reused. Nothing under a
// digest exists until Commit, which in one transaction inserts the blobs
// row, moves the staged rows into blob_chunks (checking that all of them are
// still there) and inserts the buffered tail, or, when the bytes are stored
// already, only deletes the staged rows. A blob of at most one chunk never
// touches the staging table.
//
// Leftovers: a mismatching digest, a failed Commit and the destructor
// without Commit delete the sink's staged rows (best effort: an error is
// ignored); the rows of a process that died are removed by the age rule of
// RemoveOrphanBlobs and ExpireUploads. A sink idle for longer than that age
// between chunks loses its rows, and its Commit is then ABORTED, never a
// blob with bytes missing.
class PgBlobSink final : public BlobSink {
 public:
  static constexpr size_t kChunkBytes = size_t{1} << 20;

  explicit PgBlobSink(PgStore* store);
  ~PgBlobSink() override;
  PgBlobSink(const PgBlobSink&) = delete;
  PgBlobSink& operator=(const PgBlobSink&) = delete;

  Status Append(const uint8_t* data, size_t size) override;
  uint64_t size() const override { return size_; }
  StatusOr<std::string> Commit(const std::string& expected_sha256 = "") override;

  // For tests: bytes of memory the sink holds for data (its buffer's
  // capacity), at most kChunkBytes; and the chunks written to staging.
  size_t buffered_bytes() const { return buffer_.capacity(); }
  int64_t staged_chunks() const { return staged_; }
  const std::string& staging_id() const { return staging_id_; }

 private:
  // Writes the full buffer as staging row `staged_` and empties it.
  Status Flush();
  // Deletes the staged rows, when there may be any.
  void DropStaged();

  PgStore* store_;
  const std::string staging_id_;  // 32 random hex digits
  Sha256Hasher hash_;
  std::vector<uint8_t> buffer_;   // the bytes after the staged chunks, at most kChunkBytes
  int64_t staged_ = 0;            // chunks written to staging: seq 0 .. staged_ - 1
  bool maybe_staged_rows_ = false;  // rows of staging_id_ may exist (cleared once they are deleted or moved)
  uint64_t size_ = 0;
  bool done_ = false;
};

class PgStore final : public Store {
 public:
  // Use OpenPgStore.
  PgStore(std::unique_ptr<PgPool> pool, PgStoreOptions options);
  ~PgStore() override;
  PgStore(const PgStore&) = delete;
  PgStore& operator=(const PgStore&) = delete;

  std::string backend() const override { return "postgresql"; }

  StatusOr<std::unique_ptr<BlobSink>> NewBlob() override;
  StatusOr<std::vector<uint8_t>> GetBlob(const std::string& sha256, uint64_t max_bytes) override;
  StatusOr<bool> HasBlob(const std::string& sha256) override;
  // Also removes the staging rows (PgBlobSink) of every staging id whose
  // newest chunk is at least `min_age_ms` old (not counted in the result).
  StatusOr<uint64_t> RemoveOrphanBlobs(int64_t min_age_ms) override;

  StatusOr<uint64_t> UploadSize(const std::string& tenant, const std::string& upload_id) override;
  Status AppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset, const uint8_t* data,
                      size_t size) override;
  StatusOr<std::string> CommitUpload(const std::string& tenant, const std::string& upload_id,
                                     const std::string& expected_sha256) override;
  Status DiscardUpload(const std::string& tenant, const std::string& upload_id) override;
  // Also removes staging rows idle for `max_idle_ms`, as RemoveOrphanBlobs
  // does (not counted), so that a dead server's leftovers go without a restart.
  StatusOr<uint64_t> ExpireUploads(int64_t max_idle_ms) override;

  StatusOr<VersionRecord> CreateVersion(const NewVersion& version) override;
  StatusOr<VersionRecord> GetVersion(const std::string& tenant, const std::string& asset, int64_t version) override;
  StatusOr<VersionRecord> GetLatestReadyVersion(const std::string& tenant, const std::string& asset) override;
  StatusOr<Page<AssetRecord>> ListAssets(const std::string& tenant, int32_t page_size,
                                         const std::string& page_token) override;
  StatusOr<Page<VersionRecord>> ListVersions(const std::string& tenant, const std::string& asset, int32_t page_size,
                                             const std::string& page_token) override;

  StatusOr<JobRecord> GetJob(const std::string& tenant, const std::string& job_id) override;
  StatusOr<std::optional<JobRecord>> ClaimJob(const std::string& worker, int64_t now_ms, int64_t lease_ms) override;
  Status RenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms, int64_t lease_ms,
                    double progress, const std::string& message) override;
  Status CompleteJob(const std::string& job_id, const std::string& worker, const ArtifactSummary& summary) override;
  Status FailJob(const std::string& job_id, const std::string& worker, const std::string& message) override;
  StatusOr<int64_t> CountUnfinishedJobs() override;
  // Sets every RUNNING job back to PENDING, its lease forgotten (main's
  // store.h declares it virtual; `override` is left off so this compiles
  // against the store.h of this branch too). Only for a database that one
  // process uses: on a shared one it takes the running jobs of the other
  // servers, whose workers then get Aborted and the jobs run again.
  StatusOr<int64_t> ReleaseAllLeases() override;

  StatusOr<std::optional<ArtifactSummary>> FindArtifact(const std::string& cache_key) override;
  Status PutArtifact(const std::string& cache_key, const ArtifactSummary& summary) override;

  StatusOr<TokenRecord> CreateToken(const std::string& tenant, bool read_only, const std::string& token_hash) override;
  StatusOr<TokenRecord> FindToken(const std::string& token_hash) override;
  StatusOr<std::vector<TokenRecord>> ListTokens() override;
  Status RevokeToken(const std::string& id) override;


 private:
  friend class PgBlobSink;
  friend StatusOr<std::unique_ptr<Store>> OpenPgStore(const std::string& conninfo, const PgStoreOptions& options);

  // Brings the schema to this build's version (services/store/pg_schema.h).
  Status Migrate();
  // For the blob sink: writes staging row (staging_id, seq) in its own
  // short autocommit statement (idempotent, so a retry after a lost
  // connection is safe).
  Status StageChunk(const std::string& staging_id, int64_t seq, const uint8_t* data, size_t size);
  // Stores blob `sha256` of `size` bytes: its chunks 0 .. staged - 1 from
  // staging `staging_id` and then `tail` (when not empty), in one transaction
  // that also deletes the staging rows. ABORTED when staged rows are missing.
  Status CommitStaged(const std::string& sha256, uint64_t size, const std::string& staging_id, int64_t staged,
                      const std::vector<uint8_t>& tail);
  Status DropStaging(const std::string& staging_id);
  // Deletes the staging rows of staging ids whose newest row has created_ms
  // at or before `cutoff_ms`.
  Status RemoveIdleStaging(int64_t cutoff_ms);

  // Runs `fn(connection)` (which opens and commits its own transaction) on a
  // pooled connection, mapping every exception to a Status named by `what`.
  template <typename F>
  auto Run(const std::string& what, F&& fn);

  std::unique_ptr<PgPool> pool_;
  PgStoreOptions options_;
};

// Opens the store at `conninfo` (a postgresql:// URI or libpq keywords),
// migrating the schema first. Unavailable when the server cannot be reached,
// FailedPrecondition when the database's schema is newer than this build.
StatusOr<std::unique_ptr<Store>> OpenPgStore(const std::string& conninfo, const PgStoreOptions& options = {});

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_PG_STORE_H_

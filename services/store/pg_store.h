// The shared store: metadata and blobs in PostgreSQL (docs/design/store.md, "The
// shared store (PostgreSQL)"), so that any number of `meshstream serve`
// processes work on one database. Blobs are rows of at most 1 MiB of bytea
// under their SHA-256; the schema is migrated at open (services/store/pg_schema.h).
// A blob being written is staged in the database chunk by chunk (PgBlobSink,
// services/store/pg_blob_sink.h), so a sink holds at most one chunk in memory
// whatever the blob's size.
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
// The arguments arrive checked by Store (store.h); refusals and row mapping
// use store_records.h, so the codes and messages are the embedded store's.
//
// Files: pg_pool.{h,cc} (the pool and the retrying runner), pg_schema.{h,cc}
// (migrations), pg_rows.{h,cc} (rows to records, shared statements),
// pg_blob_sink.{h,cc} (blobs, chunked), pg_store.cc (uploads, versions,
// jobs, the artifact cache, tokens, opening).
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
#include <utility>
#include <vector>

#include "codec/core/status.h"
#include "services/store/blob_store.h"
#include "services/store/pg_blob_sink.h"  // PgBlobSink, which NewBlob returns
#include "services/store/store.h"

namespace meshstream {

struct PgStoreOptions {
  int pool_size = 4;          // connections at most, 1..64
  int conflict_attempts = 3;  // tries of a transaction that hit a serialization failure or deadlock
  int64_t acquire_timeout_ms = 30000;  // waiting for a free connection longer is Unavailable
};

class PgPool;

class PgStore final : public Store {
 public:
  // Use OpenPgStore.
  PgStore(std::unique_ptr<PgPool> pool, PgStoreOptions options);
  ~PgStore() override;
  PgStore(const PgStore&) = delete;
  PgStore& operator=(const PgStore&) = delete;

  std::string backend() const override { return "postgresql"; }

 private:
  friend class PgBlobSink;
  friend StatusOr<std::unique_ptr<Store>> OpenPgStore(const std::string& conninfo, const PgStoreOptions& options);

  // The backend of store.h's checked methods (pg_blob_sink.cc: blobs;
  // pg_store.cc: the rest).
  StatusOr<std::unique_ptr<BlobSink>> DoNewBlob() override;
  StatusOr<std::vector<uint8_t>> DoGetBlob(const std::string& sha256, uint64_t max_bytes) override;
  StatusOr<bool> DoHasBlob(const std::string& sha256) override;
  // Also removes the staging rows (PgBlobSink) of every staging id whose
  // newest chunk is at least `min_age_ms` old (not counted in the result).
  StatusOr<uint64_t> DoRemoveOrphanBlobs(int64_t min_age_ms) override;

  StatusOr<uint64_t> DoUploadSize(const std::string& tenant, const std::string& upload_id) override;
  Status DoAppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset, const uint8_t* data,
                        size_t size) override;
  StatusOr<std::string> DoCommitUpload(const std::string& tenant, const std::string& upload_id,
                                       const std::string& expected_sha256) override;
  Status DoDiscardUpload(const std::string& tenant, const std::string& upload_id) override;
  // Also removes staging rows idle for `max_idle_ms`, as RemoveOrphanBlobs
  // does (not counted), so that a dead server's leftovers go without a restart.
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
  StatusOr<int64_t> DoCountUnfinishedJobs() override;
  // Only for a database that one process uses: on a shared one it takes the
  // running jobs of the other servers, whose workers then get Aborted and
  // the jobs run again.
  StatusOr<int64_t> DoReleaseAllLeases() override;

  StatusOr<std::optional<ArtifactSummary>> DoFindArtifact(const std::string& cache_key) override;
  Status DoPutArtifact(const std::string& cache_key, const ArtifactSummary& summary) override;

  StatusOr<TokenRecord> DoCreateToken(const std::string& tenant, bool read_only,
                                      const std::string& token_hash) override;
  StatusOr<TokenRecord> DoFindToken(const std::string& token_hash) override;
  StatusOr<std::vector<TokenRecord>> DoListTokens() override;
  Status DoRevokeToken(const std::string& id) override;


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

  // Runs `fn(connection)` (which opens and commits its own transaction) on
  // a pooled connection through RunPg (pg_pool.h, which the .cc files
  // include): every exception becomes a Status named by `what`.
  template <typename F>
  auto Run(const std::string& what, F&& fn) {
    return RunPg(*pool_, options_.conflict_attempts, what, std::forward<F>(fn));
  }
  std::unique_ptr<PgPool> pool_;
  PgStoreOptions options_;
};

// Opens the store at `conninfo` (a postgresql:// URI or libpq keywords),
// migrating the schema first. Unavailable when the server cannot be reached,
// FailedPrecondition when the database's schema is newer than this build.
StatusOr<std::unique_ptr<Store>> OpenPgStore(const std::string& conninfo, const PgStoreOptions& options = {});

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_PG_STORE_H_

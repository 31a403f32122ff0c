// The shared store: metadata and blobs in PostgreSQL (docs/store.md, "The
// shared store (PostgreSQL)"), so that any number of `meshstream serve`
// processes work on one database. Blobs are rows of at most 1 MiB of bytea
// under their SHA-256; the schema is migrated at open (services/store/pg_schema.h).
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
#include "services/store/store.h"

namespace meshstream {

struct PgStoreOptions {
  int pool_size = 4;          // connections at most, 1..64
  int conflict_attempts = 3;  // tries of a transaction that hit a serialization failure or deadlock
  int64_t acquire_timeout_ms = 30000;  // waiting for a free connection longer is Unavailable
};

class PgPool;
class PgBlobSink;

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
  StatusOr<uint64_t> RemoveOrphanBlobs(int64_t min_age_ms) override;

  StatusOr<uint64_t> UploadSize(const std::string& tenant, const std::string& upload_id) override;
  Status AppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset, const uint8_t* data,
                      size_t size) override;
  StatusOr<std::string> CommitUpload(const std::string& tenant, const std::string& upload_id,
                                     const std::string& expected_sha256) override;
  Status DiscardUpload(const std::string& tenant, const std::string& upload_id) override;
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
  // For the blob sink: stores `chunks` (each at most 1 MiB) as blob `sha256`.
  Status StoreBlob(const std::string& sha256, const std::vector<std::vector<uint8_t>>& chunks, uint64_t size);

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

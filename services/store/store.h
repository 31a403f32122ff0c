// The versioned store of the asset service (docs/design/store.md): one interface,
// two backends. `SqliteStore` (services/store/sqlite_store.h) is the embedded
// default: SQLite in WAL mode for metadata and a FileBlobStore folder for
// blobs. `PgStore` (services/store/pg_store.h) keeps metadata and blobs
// (chunked bytea rows) in PostgreSQL, so several servers share one database.
// OpenStore (services/store/open_store.h) picks one by the --store spec.
//
// What is stored:
//   - blobs: immutable bytes named by their SHA-256 (sources, artifacts);
//   - assets of a tenant, each with versions 1, 2, 3 ... (immutable once
//     READY or FAILED; only the processing result is filled in, once);
//   - one job per version (import + encode), claimed by workers under a
//     lease with a heartbeat, taken over when the lease expires;
//   - the artifact cache: (source digests, options, encoder) -> the result,
//     so the same file with the same options is encoded once;
//   - resumable uploads: bytes of an unfinished upload, kept for a while;
//   - API tokens (only their hash).
//
// Ordering: a row that names a blob is committed after the blob, so a row
// never names a missing blob; RemoveOrphanBlobs removes blobs no row names.
//
// One contract, two backends: Store is a non-virtual interface. Each public
// method first runs the store's checks (services/store/store_checks.h: names,
// digests, text, lease arguments, summaries, page sizes and tokens) and then
// calls the backend's protected Do* method, which only stores and loads rows;
// the messages of what a backend refuses (NotFound, a lost lease, a missing
// blob, a damaged row) come from services/store/store_records.h. So both
// backends give the same code and message for every refusal
// (tests/services/store_suite_test.cc proves it on both; docs/design/store.md,
// "One contract, two backends", lists the decisions).
//
// Contract: every string argument is untrusted unless stated (refused with
// InvalidArgument naming the field before a backend sees it); reads of
// another tenant's objects are NotFound, never a hint that they exist; a row
// whose state is not a known value is DataLoss. Thread safety: every method
// may be called from any thread at once; the backends serialize or pool
// connections themselves.
#ifndef MESHSTREAM_SERVICES_STORE_STORE_H_
#define MESHSTREAM_SERVICES_STORE_STORE_H_

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/store/store_checks.h"  // IsValidName, CheckName

namespace meshstream {

enum class VersionState { kProcessing = 1, kReady = 2, kFailed = 3 };
enum class JobState { kPending = 1, kRunning = 2, kSucceeded = 3, kFailed = 4 };

// One file of an upload: the main file (its filename) or an external file of
// a .gltf (its relative path inside the upload).
struct SourceFile {
  std::string name;
  std::string sha256;
  uint64_t size = 0;
};

// What processing a source produced: the progressive .glb and its figures.
// `layout_json` locates each primitive's base mesh and stream inside the
// artifact (services/pipeline/stream_layout.h), so a session reads them
// without decoding anything.
struct ArtifactSummary {
  std::string artifact_sha256;  // the progressive .glb
  uint64_t progressive_bytes = 0;
  std::string encoder;          // "meshstream-progressive/<format version> <build>"
  int64_t vertices = 0;
  int64_t faces = 0;
  int32_t levels = 0;
  std::vector<int64_t> level_vertices;
  uint64_t reliable_bytes = 0;
  uint64_t unreliable_bytes = 0;
  std::string layout_json;
  std::string warnings_json;    // the importer's warnings, a JSON array of strings
};

struct AssetRecord {
  std::string tenant;
  std::string name;
  int64_t latest_version = 0;
  int64_t updated_ms = 0;  // Unix time in milliseconds
};

struct VersionRecord {
  std::string tenant;
  std::string asset;
  int64_t version = 0;
  VersionState state = VersionState::kProcessing;
  SourceFile source;                 // the main file
  std::vector<SourceFile> resources; // external files of a .gltf
  std::string options_json;          // the encode options, canonical JSON
  std::string comment;
  std::map<std::string, std::string> labels;
  int64_t created_ms = 0;
  std::string job_id;
  std::string error;                 // the job's message when FAILED
  ArtifactSummary artifact;          // filled when READY
};

struct JobRecord {
  std::string id;
  std::string tenant;
  std::string asset;
  int64_t version = 0;
  JobState state = JobState::kPending;
  double progress = 0.0;  // 0..1
  std::string message;
  int32_t attempts = 0;   // claims so far
  std::string lease_owner;
  int64_t lease_expires_ms = 0;
  int64_t created_ms = 0;
  int64_t updated_ms = 0;
};

// What an ingest commits, after its blobs are durable.
struct NewVersion {
  std::string tenant;
  std::string asset;
  SourceFile source;
  std::vector<SourceFile> resources;
  std::string options_json;
  std::string comment;
  std::map<std::string, std::string> labels;
};

struct TokenRecord {
  std::string id;       // public handle for list and revoke (16 hex digits)
  std::string tenant;
  bool read_only = false;
  int64_t created_ms = 0;
  bool revoked = false;
};

template <typename T>
struct Page {
  std::vector<T> items;
  std::string next_page_token;  // empty on the last page
};

// What a backend's listing gives Store (DoListAssets, DoListVersions): the
// rows of one page and whether more rows follow them.
template <typename T>
struct PageRows {
  std::vector<T> items;
  bool more = false;
};

// Page sizes: 0 means kDefaultPageSize; above kMaxPageSize is clamped;
// negative is InvalidArgument.
constexpr int32_t kDefaultPageSize = 50;
constexpr int32_t kMaxPageSize = 1000;

// Chunked writing of one blob. Nothing is visible under a digest until
// Commit succeeds; a sink destroyed without Commit leaves nothing behind.
// The sink hashes the bytes as they arrive: it is the one place an upload's
// bytes are hashed (ingest relies on Commit's check, it does not hash).
// Like Store, a non-virtual interface: the arguments are checked here, the
// backend's sink implements DoAppend and DoCommit.
class BlobSink {
 public:
  virtual ~BlobSink() = default;
  // InvalidArgument for null data with a size (store_checks.h, CheckBytes).
  Status Append(const uint8_t* data, size_t size);
  virtual uint64_t size() const = 0;
  // Makes the blob durable and returns its digest; with a non-empty
  // `expected_sha256`, a different digest is DataLoss ("the bytes have
  // SHA-256 X, not the Y announced; nothing stored") and nothing is stored.
  // An `expected_sha256` that is not a digest is InvalidArgument.
  StatusOr<std::string> Commit(const std::string& expected_sha256 = "");

 protected:
  virtual Status DoAppend(const uint8_t* data, size_t size) = 0;
  // `expected_sha256` is empty or a digest.
  virtual StatusOr<std::string> DoCommit(const std::string& expected_sha256) = 0;
};

class Store {
 public:
  virtual ~Store() = default;
  Store() = default;
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  // "sqlite" or "postgresql", for logs and benchmarks.
  virtual std::string backend() const = 0;  // no check: only a name

  // --- blobs -------------------------------------------------------------
  StatusOr<std::unique_ptr<BlobSink>> NewBlob();
  // The bytes, re-hashed: NotFound when absent, ResourceExhausted above
  // `max_bytes` (before allocating), DataLoss when they do not match.
  StatusOr<std::vector<uint8_t>> GetBlob(const std::string& sha256, uint64_t max_bytes);
  StatusOr<bool> HasBlob(const std::string& sha256);
  // Removes blobs that no version, artifact-cache row or upload names and
  // that are older than `min_age_ms` (so that a blob another server has just
  // committed, before its row, survives). Returns how many were removed.
  StatusOr<uint64_t> RemoveOrphanBlobs(int64_t min_age_ms);

  // --- resumable uploads (per tenant; ids are names) -----------------------
  // Durable bytes of the upload: NotFound when it does not exist.
  StatusOr<uint64_t> UploadSize(const std::string& tenant, const std::string& upload_id);
  // Appends at `offset`, which must equal the durable size (0 creates the
  // upload); any other offset is FailedPrecondition naming both sizes. The
  // bytes are durable when this returns.
  Status AppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset,
                              const uint8_t* data, size_t size);
  // Turns the upload into a blob (checked against `expected_sha256` when not
  // empty: DataLoss and the upload is discarded) and removes the upload.
  StatusOr<std::string> CommitUpload(const std::string& tenant, const std::string& upload_id,
                                             const std::string& expected_sha256);
  Status DiscardUpload(const std::string& tenant, const std::string& upload_id);
  // Removes uploads not written to for `max_idle_ms`. Returns how many.
  StatusOr<uint64_t> ExpireUploads(int64_t max_idle_ms);

  // --- assets and versions -----------------------------------------------
  // In one transaction: creates the asset when new, gives the version the
  // next number, and a PENDING job. Every blob named must exist
  // (FailedPrecondition otherwise).
  StatusOr<VersionRecord> CreateVersion(const NewVersion& version);
  // version 0: the latest (any state). NotFound for an unknown asset or version.
  StatusOr<VersionRecord> GetVersion(const std::string& tenant, const std::string& asset,
                                             int64_t version);
  // The latest READY version: NotFound when there is none.
  StatusOr<VersionRecord> GetLatestReadyVersion(const std::string& tenant, const std::string& asset);
  // Ascending by name; tokens are opaque (services/store/page_token.h), a
  // malformed one is InvalidArgument.
  StatusOr<Page<AssetRecord>> ListAssets(const std::string& tenant, int32_t page_size,
                                                 const std::string& page_token);
  // Ascending by version number; NotFound for an unknown asset.
  StatusOr<Page<VersionRecord>> ListVersions(const std::string& tenant, const std::string& asset,
                                                     int32_t page_size, const std::string& page_token);

  // --- jobs ----------------------------------------------------------------
  StatusOr<JobRecord> GetJob(const std::string& tenant, const std::string& job_id);
  // Claims the oldest PENDING job, or a RUNNING one whose lease expired
  // before `now_ms` (its server died), for `worker` until now_ms + lease_ms.
  // PostgreSQL: FOR UPDATE SKIP LOCKED, so concurrent claimers never get the
  // same job. nullopt when there is nothing to do.
  StatusOr<std::optional<JobRecord>> ClaimJob(const std::string& worker, int64_t now_ms,
                                                      int64_t lease_ms);
  // Extends the lease and records progress. Aborted when `worker` does not
  // hold the lease of a RUNNING job: another worker took it after it expired
  // ("job J: the lease is held by another worker"), or the job is finished
  // ("job J: already SUCCEEDED, the lease is over"); NotFound for an unknown
  // job. A worker treats every Aborted as a lost lease and stops.
  Status RenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms,
                            int64_t lease_ms, double progress, const std::string& message);
  // Job SUCCEEDED and version READY with `summary`, in one transaction;
  // Aborted as RenewLease. The artifact blob must exist (FailedPrecondition).
  // A version that is no longer PROCESSING (changed behind the store's back)
  // is FailedPrecondition and nothing changes.
  Status CompleteJob(const std::string& job_id, const std::string& worker,
                             const ArtifactSummary& summary);
  // Job FAILED and version FAILED with `message`; Aborted and
  // FailedPrecondition as CompleteJob.
  Status FailJob(const std::string& job_id, const std::string& worker, const std::string& message);
  // Sets every RUNNING job back to PENDING (its lease forgotten). Only for a
  // store that one process owns (the embedded one, at startup: the jobs of a
  // process that died resume at once instead of after their lease).
  StatusOr<int64_t> ReleaseAllLeases();
  // Jobs neither SUCCEEDED nor FAILED (for drain and tests).
  StatusOr<int64_t> CountUnfinishedJobs();

  // --- the artifact cache -----------------------------------------------
  StatusOr<std::optional<ArtifactSummary>> FindArtifact(const std::string& cache_key);
  // Inserts, or keeps the existing row (the same key gives the same result).
  Status PutArtifact(const std::string& cache_key, const ArtifactSummary& summary);

  // --- API tokens (the store never sees a token, only its hash) ------------
  StatusOr<TokenRecord> CreateToken(const std::string& tenant, bool read_only,
                                            const std::string& token_hash);
  // The live (not revoked) token with this hash: NotFound otherwise.
  StatusOr<TokenRecord> FindToken(const std::string& token_hash);
  StatusOr<std::vector<TokenRecord>> ListTokens();
  // NotFound for an unknown id; revoking twice is OK.
  Status RevokeToken(const std::string& id);

 protected:
  // What a backend implements: called only with checked arguments (every
  // name valid, every digest a digest, every text without NUL and in UTF-8,
  // every size fitting int64, lease arguments and summaries checked).
  // A backend answers refusals with the messages of store_records.h.
  virtual StatusOr<std::unique_ptr<BlobSink>> DoNewBlob() = 0;
  virtual StatusOr<std::vector<uint8_t>> DoGetBlob(const std::string& sha256, uint64_t max_bytes) = 0;
  virtual StatusOr<bool> DoHasBlob(const std::string& sha256) = 0;
  virtual StatusOr<uint64_t> DoRemoveOrphanBlobs(int64_t min_age_ms) = 0;

  virtual StatusOr<uint64_t> DoUploadSize(const std::string& tenant, const std::string& upload_id) = 0;
  virtual Status DoAppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset,
                                const uint8_t* data, size_t size) = 0;
  virtual StatusOr<std::string> DoCommitUpload(const std::string& tenant, const std::string& upload_id,
                                               const std::string& expected_sha256) = 0;
  virtual Status DoDiscardUpload(const std::string& tenant, const std::string& upload_id) = 0;
  virtual StatusOr<uint64_t> DoExpireUploads(int64_t max_idle_ms) = 0;

  virtual StatusOr<VersionRecord> DoCreateVersion(const NewVersion& version) = 0;
  // `version` >= 0 (0: the latest).
  virtual StatusOr<VersionRecord> DoGetVersion(const std::string& tenant, const std::string& asset,
                                               int64_t version) = 0;
  virtual StatusOr<VersionRecord> DoGetLatestReadyVersion(const std::string& tenant, const std::string& asset) = 0;
  // The listings: `limit` is the page size (1 .. kMaxPageSize). A backend
  // reads at most `limit` + 1 rows, so as to learn whether more follow
  // (`more`), but returns (and parses, and loads the resources of) at most
  // `limit`; Store makes the token from the last item (MakePage).
  //
  // At most `limit` assets whose names are above `after` ("" for the first
  // page), ascending.
  virtual StatusOr<PageRows<AssetRecord>> DoListAssets(const std::string& tenant, const std::string& after,
                                                       int64_t limit) = 0;
  // At most `limit` versions numbered above `after`, ascending; NotFound
  // for an unknown asset.
  virtual StatusOr<PageRows<VersionRecord>> DoListVersions(const std::string& tenant, const std::string& asset,
                                                           int64_t after, int64_t limit) = 0;

  virtual StatusOr<JobRecord> DoGetJob(const std::string& tenant, const std::string& job_id) = 0;
  virtual StatusOr<std::optional<JobRecord>> DoClaimJob(const std::string& worker, int64_t now_ms,
                                                        int64_t lease_ms) = 0;
  virtual Status DoRenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms,
                              int64_t lease_ms, double progress, const std::string& message) = 0;
  virtual Status DoCompleteJob(const std::string& job_id, const std::string& worker,
                               const ArtifactSummary& summary) = 0;
  virtual Status DoFailJob(const std::string& job_id, const std::string& worker, const std::string& message) = 0;
  virtual StatusOr<int64_t> DoReleaseAllLeases() = 0;
  virtual StatusOr<int64_t> DoCountUnfinishedJobs() = 0;

  virtual StatusOr<std::optional<ArtifactSummary>> DoFindArtifact(const std::string& cache_key) = 0;
  virtual Status DoPutArtifact(const std::string& cache_key, const ArtifactSummary& summary) = 0;

  virtual StatusOr<TokenRecord> DoCreateToken(const std::string& tenant, bool read_only,
                                              const std::string& token_hash) = 0;
  virtual StatusOr<TokenRecord> DoFindToken(const std::string& token_hash) = 0;
  virtual StatusOr<std::vector<TokenRecord>> DoListTokens() = 0;
  virtual Status DoRevokeToken(const std::string& id) = 0;
};

// A job's message (and so a version's error) is kept to this many bytes: it
// travels in every GetJob, WatchJob, GetVersion and ListVersions answer, and
// an importer's message may quote what a client sent.
constexpr size_t kMaxJobMessageBytes = 1024;
// `message` as the store accepts it (store_checks.h, CheckText): ill-formed
// UTF-8 replaced by U+FFFD, NUL bytes by spaces, then cut to at most
// `max_bytes` at a UTF-8 boundary, with "..." when cut. For the job messages
// a worker writes, which may quote what a client sent (an importer's error).
std::string StorableMessage(const std::string& message, size_t max_bytes = kMaxJobMessageBytes);

// Milliseconds since the Unix epoch (the store's clock for created/updated).
int64_t NowMs();

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_STORE_H_

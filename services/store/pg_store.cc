// The shared store (services/store/pg_store.h): uploads, versions, jobs,
// the artifact cache, tokens, and opening. Blobs are in pg_blob_sink.cc, the
// pool and the retrying runner in pg_pool.cc, rows in pg_rows.cc, the
// schema in pg_schema.cc.
#include "services/store/pg_store.h"

#include <sodium.h>

#include <algorithm>
#include <set>
#include <utility>

#include <pqxx/pqxx>

#include "services/store/pg_pool.h"
#include "services/store/pg_rows.h"
#include "services/store/pg_schema.h"
#include "services/store/store_records.h"

namespace meshstream {

namespace {

// CommitUpload reads the upload back in windows of this many bytes.
constexpr int64_t kReadWindowBytes = 4 * static_cast<int64_t>(PgBlobSink::kChunkBytes);

}  // namespace

PgStore::PgStore(std::unique_ptr<PgPool> pool, PgStoreOptions options)
    : pool_(std::move(pool)), options_(options) {}

PgStore::~PgStore() = default;

Status PgStore::Migrate() {
  return Run("migrating the meshstream schema",
             [&](pqxx::connection& c) -> Status { return MigratePgSchema(c); });
}

// ---------------------------------------------------------------------------
// Resumable uploads.

StatusOr<uint64_t> PgStore::DoUploadSize(const std::string& tenant, const std::string& upload_id) {
  return Run("upload " + upload_id, [&](pqxx::connection& c) -> StatusOr<uint64_t> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        "SELECT size FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2", tenant, upload_id);
    tx.commit();
    if (rows.empty()) return UploadNotFound(upload_id);
    return static_cast<uint64_t>(rows[0][0].as<int64_t>());
  });
}

Status PgStore::DoAppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset,
                             const uint8_t* data, size_t size) {
  const int64_t offset64 = static_cast<int64_t>(offset);  // checked by Store: offset + size fits
  return Run("appending to upload " + upload_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const int64_t now = NowMs();
    static const char kLock[] =
        "SELECT size FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2 FOR UPDATE";
    // The row lock serializes appenders of one upload: the size read here
    // is the durable size until this transaction ends.
    pqxx::result rows = tx.exec_params(kLock, tenant, upload_id);
    if (rows.empty()) {
      if (offset64 != 0) return UploadOffsetMismatch(upload_id, 0, offset);
      tx.exec_params(
          "INSERT INTO meshstream.uploads (tenant, upload_id, size, created_ms, updated_ms) VALUES ($1, $2, 0, $3, $3) "
          "ON CONFLICT (tenant, upload_id) DO NOTHING",
          tenant, upload_id, now);
      // Ours, or one another appender created at the same moment: lock it.
      rows = tx.exec_params(kLock, tenant, upload_id);
      if (rows.empty()) return Aborted("upload " + upload_id + ": created and removed concurrently");
    }
    const int64_t durable = rows[0][0].as<int64_t>();
    if (durable != offset64) {
      return UploadOffsetMismatch(upload_id, static_cast<uint64_t>(durable), offset);
    }
    for (size_t done = 0; done < size;) {
      const size_t n = std::min(size - done, PgBlobSink::kChunkBytes);
      tx.exec_params("INSERT INTO meshstream.upload_chunks (tenant, upload_id, byte_offset, data) VALUES ($1, $2, $3, $4)",
                     tenant, upload_id, offset64 + static_cast<int64_t>(done), Bytea(data + done, n));
      done += n;
    }
    tx.exec_params("UPDATE meshstream.uploads SET size = size + $3, updated_ms = $4 WHERE tenant = $1 AND upload_id = $2",
                   tenant, upload_id, static_cast<int64_t>(size), now);
    tx.commit();
    return Status::Ok();
  });
}

StatusOr<std::string> PgStore::DoCommitUpload(const std::string& tenant, const std::string& upload_id,
                                            const std::string& expected_sha256) {
  return Run("committing upload " + upload_id, [&](pqxx::connection& c) -> StatusOr<std::string> {
    pqxx::work tx(c);
    const pqxx::result head = tx.exec_params(
        "SELECT size FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2 FOR UPDATE", tenant, upload_id);
    if (head.empty()) return UploadNotFound(upload_id);
    const int64_t size = head[0][0].as<int64_t>();

    // Hash the bytes, window by window, checking that the chunks tile
    // [0, size) exactly.
    Sha256Hasher hash;
    std::vector<uint8_t> buffer;
    int64_t next = 0, chunks = 0;
    while (next < size) {
      const pqxx::result rows = tx.exec_params(
          "SELECT byte_offset, encode(data, 'hex') FROM meshstream.upload_chunks "
          "WHERE tenant = $1 AND upload_id = $2 AND byte_offset >= $3 AND byte_offset < $4 ORDER BY byte_offset",
          tenant, upload_id, next, next + kReadWindowBytes);
      if (rows.empty()) {
        return DataLoss("upload " + upload_id + ": bytes from " + std::to_string(next) + " of " +
                        std::to_string(size) + " are missing");
      }
      for (const pqxx::row& row : rows) {
        const int64_t at = row[0].as<int64_t>();
        const pqxx::field field = row[1];
        const size_t n = field.size() / 2;
        if (at != next || static_cast<int64_t>(n) > size - next) {
          return DataLoss("upload " + upload_id + ": a chunk at byte " + std::to_string(at) +
                          " does not continue the bytes before it (expected " + std::to_string(next) + ")");
        }
        buffer.resize(n);
        if (!DecodeHex(field.c_str(), field.size(), buffer.data())) {
          return Internal("upload " + upload_id + ": PostgreSQL returned malformed hex");
        }
        hash.Update(buffer.data(), n);
        next += static_cast<int64_t>(n);
        ++chunks;
      }
    }
    const std::string digest = hash.FinishHex();
    const std::string remove =
        "DELETE FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2";  // its chunks cascade
    if (!expected_sha256.empty() && digest != expected_sha256) {
      tx.exec_params(remove, tenant, upload_id);
      tx.commit();
      return UploadDiscarded(upload_id, DigestMismatch(digest, expected_sha256));
    }
    MS_ASSIGN_OR_RETURN(const bool inserted, InsertBlobRow(tx, digest, size, chunks));
    if (inserted) {
      // The chunks move inside the server; they are at most 1 MiB each already.
      const pqxx::result copied = tx.exec_params(
          "INSERT INTO meshstream.blob_chunks (sha256, seq, data) "
          "SELECT $1, (row_number() OVER (ORDER BY byte_offset) - 1)::integer, data FROM meshstream.upload_chunks "
          "WHERE tenant = $2 AND upload_id = $3 AND byte_offset < $4",
          digest, tenant, upload_id, size);
      if (static_cast<int64_t>(copied.affected_rows()) != chunks) {
        return Internal("upload " + upload_id + ": copied " + std::to_string(copied.affected_rows()) +
                        " chunks, hashed " + std::to_string(chunks));
      }
    }
    tx.exec_params(remove, tenant, upload_id);
    tx.commit();
    return digest;
  });
}

Status PgStore::DoDiscardUpload(const std::string& tenant, const std::string& upload_id) {
  return Run("discarding upload " + upload_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const pqxx::result r =
        tx.exec_params("DELETE FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2", tenant, upload_id);
    tx.commit();
    if (r.affected_rows() == 0) return UploadNotFound(upload_id);
    return Status::Ok();
  });
}

StatusOr<uint64_t> PgStore::DoExpireUploads(int64_t max_idle_ms) {
  const int64_t cutoff = NowMs() - max_idle_ms;  // max_idle_ms >= 0 (checked by Store): no overflow
  // The periodic sweep also takes idle staging rows (see RemoveOrphanBlobs),
  // so that a dead server's leftovers go even when no server restarts.
  MS_RETURN_IF_ERROR(RemoveIdleStaging(cutoff));
  return Run("expiring uploads", [&](pqxx::connection& c) -> StatusOr<uint64_t> {
    pqxx::work tx(c);
    const pqxx::result r = tx.exec_params("DELETE FROM meshstream.uploads WHERE updated_ms <= $1", cutoff);
    tx.commit();
    return static_cast<uint64_t>(r.affected_rows());
  });
}

// ---------------------------------------------------------------------------
// Assets and versions.

StatusOr<VersionRecord> PgStore::DoCreateVersion(const NewVersion& nv) {
  // Sizes fit int64 and texts are checked by Store (CheckNewVersion).
  const int64_t source_size = static_cast<int64_t>(nv.source.size);
  const std::string labels = LabelsToJson(nv.labels);

  return Run("creating a version of asset " + nv.asset, [&](pqxx::connection& c) -> StatusOr<VersionRecord> {
    pqxx::work tx(c);
    std::vector<std::string> digests = {nv.source.sha256};
    for (const SourceFile& r : nv.resources) digests.push_back(r.sha256);
    // Locked until commit: the orphan sweep cannot remove them meanwhile.
    const std::set<std::string> present = LockBlobs(tx, digests);
    if (present.count(nv.source.sha256) == 0) return BlobMissing("source.sha256", nv.source.sha256);
    for (size_t i = 0; i < nv.resources.size(); ++i) {
      if (present.count(nv.resources[i].sha256) == 0) {
        return BlobMissing("resources[" + std::to_string(i) + "].sha256", nv.resources[i].sha256);
      }
    }
    const int64_t now = NowMs();
    // The upsert locks the asset's row: concurrent creators of versions of
    // one asset (on any server) queue here and each gets the next number.
    const int64_t number = tx.exec_params1(
                                 "INSERT INTO meshstream.assets (tenant, name, latest_version, created_ms, updated_ms) "
                                 "VALUES ($1, $2, 1, $3, $3) ON CONFLICT (tenant, name) DO UPDATE "
                                 "SET latest_version = meshstream.assets.latest_version + 1, updated_ms = $3 "
                                 "RETURNING latest_version",
                                 nv.tenant, nv.asset, now)[0]
                               .as<int64_t>();
    const std::string job_id = RandomHex(16);
    tx.exec_params(
        "INSERT INTO meshstream.versions (tenant, asset, version, state, source_name, source_sha256, source_size, "
        "options_json, comment, labels, created_ms, job_id) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10::jsonb, "
        "$11, $12)",
        nv.tenant, nv.asset, number, kPgProcessing, nv.source.name, nv.source.sha256, source_size, nv.options_json,
        nv.comment, labels, now, job_id);
    for (size_t i = 0; i < nv.resources.size(); ++i) {
      tx.exec_params(
          "INSERT INTO meshstream.version_resources (tenant, asset, version, idx, name, sha256, size) "
          "VALUES ($1, $2, $3, $4, $5, $6, $7)",
          nv.tenant, nv.asset, number, static_cast<int64_t>(i), nv.resources[i].name, nv.resources[i].sha256,
          static_cast<int64_t>(nv.resources[i].size));
    }
    tx.exec_params(
        "INSERT INTO meshstream.jobs (id, tenant, asset, version, state, created_ms, updated_ms) "
        "VALUES ($1, $2, $3, $4, $5, $6, $6)",
        job_id, nv.tenant, nv.asset, number, kPgPending, now);
    VersionRecord record;
    record.tenant = nv.tenant;
    record.asset = nv.asset;
    record.version = number;
    record.state = VersionState::kProcessing;
    record.source = nv.source;
    record.resources = nv.resources;
    record.options_json = nv.options_json;
    record.comment = nv.comment;
    record.labels = nv.labels;
    record.created_ms = now;
    record.job_id = job_id;
    tx.commit();
    return record;
  });
}

StatusOr<VersionRecord> PgStore::DoGetVersion(const std::string& tenant, const std::string& asset, int64_t version) {
  return Run("reading asset " + asset, [&](pqxx::connection& c) -> StatusOr<VersionRecord> {
    pqxx::transaction<pqxx::repeatable_read, pqxx::read_only> tx(c);
    const pqxx::result head = tx.exec_params(
        "SELECT latest_version FROM meshstream.assets WHERE tenant = $1 AND name = $2", tenant, asset);
    if (head.empty()) return AssetNotFound(asset);
    const int64_t number = version == 0 ? head[0][0].as<int64_t>() : version;
    const pqxx::result rows = tx.exec_params(
        "SELECT " + PgVersionColumns() + " FROM meshstream.versions WHERE tenant = $1 AND asset = $2 AND version = $3",
        tenant, asset, number);
    if (rows.empty()) return VersionNotFound(asset, number);
    MS_ASSIGN_OR_RETURN(VersionRecord record, ReadVersionWithResources(tx, rows[0]));
    tx.commit();
    return record;
  });
}

StatusOr<VersionRecord> PgStore::DoGetLatestReadyVersion(const std::string& tenant, const std::string& asset) {
  return Run("reading asset " + asset, [&](pqxx::connection& c) -> StatusOr<VersionRecord> {
    pqxx::transaction<pqxx::repeatable_read, pqxx::read_only> tx(c);
    const pqxx::result rows = tx.exec_params("SELECT " + PgVersionColumns() +
                                                 " FROM meshstream.versions WHERE tenant = $1 AND asset = $2 AND "
                                                 "state = $3 ORDER BY version DESC LIMIT 1",
                                             tenant, asset, kPgReady);
    if (rows.empty()) {
      const bool known = !tx.exec_params("SELECT 1 FROM meshstream.assets WHERE tenant = $1 AND name = $2", tenant,
                                         asset)
                              .empty();
      return known ? NoReadyVersion(asset) : AssetNotFound(asset);
    }
    MS_ASSIGN_OR_RETURN(VersionRecord record, ReadVersionWithResources(tx, rows[0]));
    tx.commit();
    return record;
  });
}

StatusOr<PageRows<AssetRecord>> PgStore::DoListAssets(const std::string& tenant, const std::string& after,
                                                      int64_t limit) {
  return Run("listing assets", [&](pqxx::connection& c) -> StatusOr<PageRows<AssetRecord>> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        "SELECT name, latest_version, updated_ms FROM meshstream.assets WHERE tenant = $1 AND name > $2 "
        "ORDER BY name LIMIT $3",
        tenant, after, limit + 1);  // one row more: whether more follow
    tx.commit();
    PageRows<AssetRecord> assets;
    for (const pqxx::row& row : rows) {
      if (static_cast<int64_t>(assets.items.size()) == limit) {
        assets.more = true;
        break;
      }
      AssetRecord a;
      a.tenant = tenant;
      a.name = row["name"].as<std::string>();
      a.latest_version = row["latest_version"].as<int64_t>();
      a.updated_ms = row["updated_ms"].as<int64_t>();
      assets.items.push_back(std::move(a));
    }
    return assets;
  });
}

StatusOr<PageRows<VersionRecord>> PgStore::DoListVersions(const std::string& tenant, const std::string& asset,
                                                          int64_t after, int64_t limit) {
  return Run("listing versions of asset " + asset, [&](pqxx::connection& c) -> StatusOr<PageRows<VersionRecord>> {
    pqxx::transaction<pqxx::repeatable_read, pqxx::read_only> tx(c);
    if (tx.exec_params("SELECT 1 FROM meshstream.assets WHERE tenant = $1 AND name = $2", tenant, asset).empty()) {
      return AssetNotFound(asset);
    }
    const pqxx::result rows = tx.exec_params("SELECT " + PgVersionColumns() +
                                                 " FROM meshstream.versions WHERE tenant = $1 AND asset = $2 AND "
                                                 "version > $3 ORDER BY version LIMIT $4",
                                             tenant, asset, after, limit + 1);  // one row more: whether more follow
    PageRows<VersionRecord> versions;
    for (const pqxx::row& row : rows) {
      if (static_cast<int64_t>(versions.items.size()) == limit) {
        versions.more = true;
        break;
      }
      MS_ASSIGN_OR_RETURN(VersionRecord v, ReadVersion(row));
      versions.items.push_back(std::move(v));
    }
    LoadResources(tx, &versions.items);
    tx.commit();
    return versions;
  });
}

// ---------------------------------------------------------------------------
// Jobs.

StatusOr<JobRecord> PgStore::DoGetJob(const std::string& tenant, const std::string& job_id) {
  return Run("reading job " + job_id, [&](pqxx::connection& c) -> StatusOr<JobRecord> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        std::string("SELECT ") + kPgJobColumns + " FROM meshstream.jobs WHERE id = $1 AND tenant = $2", job_id, tenant);
    tx.commit();
    if (rows.empty()) return JobNotFound(job_id);
    return ReadJob(rows[0]);
  });
}

StatusOr<std::optional<JobRecord>> PgStore::DoClaimJob(const std::string& worker, int64_t now_ms, int64_t lease_ms) {
  return Run("claiming a job", [&](pqxx::connection& c) -> StatusOr<std::optional<JobRecord>> {
    pqxx::work tx(c);
    // SKIP LOCKED: a job another claimer is taking right now is not waited
    // for but passed over, so concurrent claimers get different jobs.
    const pqxx::result pick = tx.exec_params(
        "SELECT id FROM meshstream.jobs WHERE state IN ($1, $2) AND (state = $1 OR lease_expires_ms < $3) "
        "ORDER BY created_ms, seq LIMIT 1 FOR UPDATE SKIP LOCKED",
        kPgPending, kPgRunning, now_ms);
    if (pick.empty()) {
      tx.commit();
      return std::optional<JobRecord>();
    }
    const pqxx::row row = tx.exec_params1(
        std::string("UPDATE meshstream.jobs SET state = $2, lease_owner = $3, lease_expires_ms = $4, "
                    "attempts = attempts + 1, updated_ms = $5 WHERE id = $1 RETURNING ") +
            kPgJobColumns,
        pick[0][0].as<std::string>(), kPgRunning, worker, now_ms + lease_ms, NowMs());
    MS_ASSIGN_OR_RETURN(JobRecord job, ReadJob(row));
    tx.commit();
    return std::optional<JobRecord>(std::move(job));
  });
}

Status PgStore::DoRenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms, int64_t lease_ms,
                           double progress, const std::string& message) {
  return Run("renewing the lease of job " + job_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const pqxx::result r = tx.exec_params(
        "UPDATE meshstream.jobs SET lease_expires_ms = $3, progress = $4, message = $5, updated_ms = $6 "
        "WHERE id = $1 AND lease_owner = $2 AND state = $7",
        job_id, worker, now_ms + lease_ms, progress, message, NowMs(), kPgRunning);
    if (r.affected_rows() == 0) return LeaseError(tx, job_id, worker);
    tx.commit();
    return Status::Ok();
  });
}

Status PgStore::DoCompleteJob(const std::string& job_id, const std::string& worker, const ArtifactSummary& summary) {
  return Run("completing job " + job_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const int64_t now = NowMs();
    const pqxx::result job = tx.exec_params(
        "UPDATE meshstream.jobs SET state = $3, progress = 1, updated_ms = $4 "
        "WHERE id = $1 AND lease_owner = $2 AND state = $5 RETURNING tenant, asset, version",
        job_id, worker, kPgSucceeded, now, kPgRunning);
    if (job.empty()) return LeaseError(tx, job_id, worker);
    if (LockBlobs(tx, {summary.artifact_sha256}).empty()) {
      return BlobMissing("summary.artifact_sha256", summary.artifact_sha256);
    }
    const pqxx::result version = tx.exec_params(
        "UPDATE meshstream.versions SET state = $4, error = '', artifact_sha256 = $5, progressive_bytes = $6, "
        "encoder = $7, vertices = $8, faces = $9, levels = $10, level_vertices = $11::bigint[], reliable_bytes = $12, "
        "unreliable_bytes = $13, layout_json = $14, warnings_json = $15 "
        "WHERE tenant = $1 AND asset = $2 AND version = $3 AND state = $16",
        job[0][0].as<std::string>(), job[0][1].as<std::string>(), job[0][2].as<int64_t>(), kPgReady,
        summary.artifact_sha256, static_cast<int64_t>(summary.progressive_bytes), summary.encoder, summary.vertices,
        summary.faces, summary.levels, BigintArray(summary.level_vertices),
        static_cast<int64_t>(summary.reliable_bytes), static_cast<int64_t>(summary.unreliable_bytes),
        summary.layout_json, summary.warnings_json, kPgProcessing);
    if (version.affected_rows() != 1) {
      return VersionNotProcessing(job_id);
    }
    tx.commit();
    return Status::Ok();
  });
}

Status PgStore::DoFailJob(const std::string& job_id, const std::string& worker, const std::string& message) {
  return Run("failing job " + job_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const int64_t now = NowMs();
    const pqxx::result job = tx.exec_params(
        "UPDATE meshstream.jobs SET state = $3, message = $4, updated_ms = $5 "
        "WHERE id = $1 AND lease_owner = $2 AND state = $6 RETURNING tenant, asset, version",
        job_id, worker, kPgJobFailed, message, now, kPgRunning);
    if (job.empty()) return LeaseError(tx, job_id, worker);
    const pqxx::result version = tx.exec_params(
        "UPDATE meshstream.versions SET state = $4, error = $5 WHERE tenant = $1 AND asset = $2 AND version = $3 "
        "AND state = $6",
        job[0][0].as<std::string>(), job[0][1].as<std::string>(), job[0][2].as<int64_t>(), kPgVersionFailed, message,
        kPgProcessing);
    if (version.affected_rows() != 1) {
      return VersionNotProcessing(job_id);
    }
    tx.commit();
    return Status::Ok();
  });
}

StatusOr<int64_t> PgStore::DoReleaseAllLeases() {
  return Run("releasing all leases", [&](pqxx::connection& c) -> StatusOr<int64_t> {
    pqxx::work tx(c);
    const pqxx::result r = tx.exec_params(
        "UPDATE meshstream.jobs SET state = $1, lease_owner = '', lease_expires_ms = 0, updated_ms = $2 "
        "WHERE state = $3",
        kPgPending, NowMs(), kPgRunning);
    tx.commit();
    return static_cast<int64_t>(r.affected_rows());
  });
}

StatusOr<int64_t> PgStore::DoCountUnfinishedJobs() {
  return Run("counting unfinished jobs", [&](pqxx::connection& c) -> StatusOr<int64_t> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const int64_t n =
        tx.exec_params1("SELECT count(*) FROM meshstream.jobs WHERE state IN ($1, $2)", kPgPending, kPgRunning)[0]
            .as<int64_t>();
    tx.commit();
    return n;
  });
}

// ---------------------------------------------------------------------------
// The artifact cache.

StatusOr<std::optional<ArtifactSummary>> PgStore::DoFindArtifact(const std::string& cache_key) {
  return Run("reading the artifact cache", [&](pqxx::connection& c) -> StatusOr<std::optional<ArtifactSummary>> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        std::string("SELECT ") + kPgArtifactColumns + " FROM meshstream.artifacts WHERE cache_key = $1", cache_key);
    tx.commit();
    if (rows.empty()) return std::optional<ArtifactSummary>();
    MS_ASSIGN_OR_RETURN(ArtifactSummary summary, ReadArtifact(rows[0]));
    return std::optional<ArtifactSummary>(std::move(summary));
  });
}

Status PgStore::DoPutArtifact(const std::string& cache_key, const ArtifactSummary& summary) {
  return Run("writing the artifact cache", [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    if (LockBlobs(tx, {summary.artifact_sha256}).empty()) {
      return BlobMissing("summary.artifact_sha256", summary.artifact_sha256);
    }
    tx.exec_params(
        std::string("INSERT INTO meshstream.artifacts (cache_key, ") + kPgArtifactColumns +
            ", created_ms) VALUES ($1, $2, $3, $4, $5, $6, $7, $8::bigint[], $9, $10, $11, $12, $13) "
            "ON CONFLICT (cache_key) DO NOTHING",
        cache_key, summary.artifact_sha256, static_cast<int64_t>(summary.progressive_bytes), summary.encoder,
        summary.vertices, summary.faces, summary.levels, BigintArray(summary.level_vertices),
        static_cast<int64_t>(summary.reliable_bytes), static_cast<int64_t>(summary.unreliable_bytes),
        summary.layout_json, summary.warnings_json, NowMs());
    tx.commit();
    return Status::Ok();
  });
}

// ---------------------------------------------------------------------------
// API tokens.

StatusOr<TokenRecord> PgStore::DoCreateToken(const std::string& tenant, bool read_only, const std::string& token_hash) {
  return Run("creating a token", [&](pqxx::connection& c) -> StatusOr<TokenRecord> {
    pqxx::work tx(c);
    TokenRecord t;
    t.id = RandomHex(8);
    t.tenant = tenant;
    t.read_only = read_only;
    t.created_ms = NowMs();
    const pqxx::result r = tx.exec_params(
        "INSERT INTO meshstream.tokens (id, tenant, read_only, token_hash, created_ms) VALUES ($1, $2, $3, $4, $5) "
        "ON CONFLICT (token_hash) DO NOTHING",
        t.id, tenant, read_only, token_hash, t.created_ms);
    if (r.affected_rows() == 0) return TokenHashExists();
    tx.commit();
    return t;
  });
}

StatusOr<TokenRecord> PgStore::DoFindToken(const std::string& token_hash) {
  return Run("looking up a token", [&](pqxx::connection& c) -> StatusOr<TokenRecord> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        std::string("SELECT ") + kPgTokenColumns + " FROM meshstream.tokens WHERE token_hash = $1 AND NOT revoked",
        token_hash);
    tx.commit();
    if (rows.empty()) return NoLiveToken();
    return ReadToken(rows[0]);
  });
}

StatusOr<std::vector<TokenRecord>> PgStore::DoListTokens() {
  return Run("listing tokens", [&](pqxx::connection& c) -> StatusOr<std::vector<TokenRecord>> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows =
        tx.exec(std::string("SELECT ") + kPgTokenColumns + " FROM meshstream.tokens ORDER BY created_ms, id");
    tx.commit();
    std::vector<TokenRecord> tokens;
    for (const pqxx::row& row : rows) tokens.push_back(ReadToken(row));
    return tokens;
  });
}

Status PgStore::DoRevokeToken(const std::string& id) {
  return Run("revoking token " + id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const pqxx::result r = tx.exec_params("UPDATE meshstream.tokens SET revoked = true WHERE id = $1", id);
    tx.commit();
    if (r.affected_rows() == 0) return TokenNotFound(id);
    return Status::Ok();
  });
}

// ---------------------------------------------------------------------------

StatusOr<std::unique_ptr<Store>> OpenPgStore(const std::string& conninfo, const PgStoreOptions& options) {
  if (sodium_init() < 0) return Internal("libsodium could not be initialized");
  if (options.pool_size < 1 || options.pool_size > 64) {
    return InvalidArgument("pool_size: " + std::to_string(options.pool_size) + " is not within 1..64");
  }
  if (options.conflict_attempts < 1) {
    return InvalidArgument("conflict_attempts: " + std::to_string(options.conflict_attempts) + " is not positive");
  }
  if (options.acquire_timeout_ms < 1) {
    return InvalidArgument("acquire_timeout_ms: " + std::to_string(options.acquire_timeout_ms) + " is not positive");
  }
  auto store = std::make_unique<PgStore>(
      std::make_unique<PgPool>(conninfo, options.pool_size, options.acquire_timeout_ms), options);
  MS_RETURN_IF_ERROR(store->Migrate());
  return std::unique_ptr<Store>(std::move(store));
}

}  // namespace meshstream

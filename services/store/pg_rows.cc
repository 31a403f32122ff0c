#include "services/store/pg_rows.h"

#include <algorithm>
#include <exception>
#include <map>
#include <utility>

#include "services/store/store_records.h"

namespace meshstream {

namespace {

int HexNibble(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// PostgreSQL's text form of a bigint[] ("{1,2,3}").
StatusOr<std::vector<int64_t>> ParseBigintArray(const std::string& text) {
  if (text.size() < 2 || text.front() != '{' || text.back() != '}') {
    return DataLoss("level_vertices is not an array of integers");
  }
  std::vector<int64_t> values;
  const std::string inner = text.substr(1, text.size() - 2);
  size_t start = 0;
  while (start < inner.size()) {
    size_t end = inner.find(',', start);
    if (end == std::string::npos) end = inner.size();
    try {
      size_t used = 0;
      const std::string item = inner.substr(start, end - start);
      values.push_back(std::stoll(item, &used));
      if (used != item.size()) return DataLoss("level_vertices is not an array of integers");
    } catch (const std::exception&) {
      return DataLoss("level_vertices is not an array of integers");
    }
    start = end + 1;
  }
  return values;
}

std::string Text(const pqxx::field& field) { return field.is_null() ? std::string() : field.as<std::string>(); }

}  // namespace

// --- parameters ------------------------------------------------------------

bool DecodeHex(const char* hex, size_t n, uint8_t* out) {
  if (n % 2 != 0) return false;
  for (size_t i = 0; i < n; i += 2) {
    const int hi = HexNibble(hex[i]), lo = HexNibble(hex[i + 1]);
    if (hi < 0 || lo < 0) return false;
    out[i / 2] = static_cast<uint8_t>(hi * 16 + lo);
  }
  return true;
}

pqxx::binarystring Bytea(const uint8_t* data, size_t size) {
  static const uint8_t kEmpty = 0;
  return pqxx::binarystring(size == 0 ? &kEmpty : data, size);
}

std::string DigestArray(const std::vector<std::string>& digests) {
  std::string out = "{";
  for (size_t i = 0; i < digests.size(); ++i) {
    if (i > 0) out += ',';
    out += digests[i];
  }
  return out + "}";
}

std::string BigintArray(const std::vector<int64_t>& values) {
  std::string out = "{";
  for (size_t i = 0; i < values.size(); ++i) {
    if (i > 0) out += ',';
    out += std::to_string(values[i]);
  }
  return out + "}";
}

// --- rows to records -----------------------------------------------------------

const char kPgArtifactColumns[] =
    "artifact_sha256, progressive_bytes, encoder, vertices, faces, levels, level_vertices, reliable_bytes, "
    "unreliable_bytes, layout_json, warnings_json";

const char kPgJobColumns[] =
    "id, tenant, asset, version, state, progress, message, attempts, lease_owner, lease_expires_ms, created_ms, "
    "updated_ms";

const char kPgTokenColumns[] = "id, tenant, read_only, created_ms, revoked";

const std::string& PgVersionColumns() {
  static const std::string columns =
      "tenant, asset, version, state, source_name, source_sha256, source_size, options_json, comment, "
      "labels::text AS labels, created_ms, job_id, error, " +
      std::string(kPgArtifactColumns);
  return columns;
}

StatusOr<ArtifactSummary> ReadArtifact(const pqxx::row& row) {
  ArtifactSummary a;
  a.artifact_sha256 = Text(row["artifact_sha256"]);
  a.progressive_bytes = static_cast<uint64_t>(row["progressive_bytes"].as<int64_t>());
  a.encoder = row["encoder"].as<std::string>();
  a.vertices = row["vertices"].as<int64_t>();
  a.faces = row["faces"].as<int64_t>();
  a.levels = row["levels"].as<int32_t>();
  MS_ASSIGN_OR_RETURN(a.level_vertices, ParseBigintArray(row["level_vertices"].as<std::string>()));
  a.reliable_bytes = static_cast<uint64_t>(row["reliable_bytes"].as<int64_t>());
  a.unreliable_bytes = static_cast<uint64_t>(row["unreliable_bytes"].as<int64_t>());
  a.layout_json = row["layout_json"].as<std::string>();
  a.warnings_json = row["warnings_json"].as<std::string>();
  return a;
}

StatusOr<VersionRecord> ReadVersion(const pqxx::row& row) {
  VersionRecord v;
  v.tenant = row["tenant"].as<std::string>();
  v.asset = row["asset"].as<std::string>();
  v.version = row["version"].as<int64_t>();
  MS_ASSIGN_OR_RETURN(v.state, VersionStateFromRow(row["state"].as<int64_t>()));
  v.source.name = row["source_name"].as<std::string>();
  v.source.sha256 = row["source_sha256"].as<std::string>();
  v.source.size = static_cast<uint64_t>(row["source_size"].as<int64_t>());
  v.options_json = row["options_json"].as<std::string>();
  v.comment = row["comment"].as<std::string>();
  MS_ASSIGN_OR_RETURN(v.labels, LabelsFromJson(row["labels"].as<std::string>()));
  v.created_ms = row["created_ms"].as<int64_t>();
  v.job_id = row["job_id"].as<std::string>();
  v.error = row["error"].as<std::string>();
  MS_ASSIGN_OR_RETURN(v.artifact, ReadArtifact(row));
  return v;
}

StatusOr<JobRecord> ReadJob(const pqxx::row& row) {
  JobRecord j;
  j.id = row["id"].as<std::string>();
  j.tenant = row["tenant"].as<std::string>();
  j.asset = row["asset"].as<std::string>();
  j.version = row["version"].as<int64_t>();
  MS_ASSIGN_OR_RETURN(j.state, JobStateFromRow(row["state"].as<int64_t>()));
  j.progress = row["progress"].as<double>();
  j.message = row["message"].as<std::string>();
  j.attempts = row["attempts"].as<int32_t>();
  j.lease_owner = row["lease_owner"].as<std::string>();
  j.lease_expires_ms = row["lease_expires_ms"].as<int64_t>();
  j.created_ms = row["created_ms"].as<int64_t>();
  j.updated_ms = row["updated_ms"].as<int64_t>();
  return j;
}

TokenRecord ReadToken(const pqxx::row& row) {
  TokenRecord t;
  t.id = row["id"].as<std::string>();
  t.tenant = row["tenant"].as<std::string>();
  t.read_only = row["read_only"].as<bool>();
  t.created_ms = row["created_ms"].as<int64_t>();
  t.revoked = row["revoked"].as<bool>();
  return t;
}

void LoadResources(pqxx::transaction_base& tx, std::vector<VersionRecord>* versions) {
  if (versions->empty()) return;
  int64_t lo = versions->front().version, hi = lo;
  std::map<int64_t, VersionRecord*> by_number;
  for (VersionRecord& v : *versions) {
    lo = std::min(lo, v.version);
    hi = std::max(hi, v.version);
    by_number[v.version] = &v;
  }
  const pqxx::result rows = tx.exec_params(
      "SELECT version, name, sha256, size FROM meshstream.version_resources "
      "WHERE tenant = $1 AND asset = $2 AND version BETWEEN $3 AND $4 ORDER BY version, idx",
      versions->front().tenant, versions->front().asset, lo, hi);
  for (const pqxx::row& row : rows) {
    auto it = by_number.find(row["version"].as<int64_t>());
    if (it == by_number.end()) continue;
    SourceFile file;
    file.name = row["name"].as<std::string>();
    file.sha256 = row["sha256"].as<std::string>();
    file.size = static_cast<uint64_t>(row["size"].as<int64_t>());
    it->second->resources.push_back(std::move(file));
  }
}

StatusOr<VersionRecord> ReadVersionWithResources(pqxx::transaction_base& tx, const pqxx::row& row) {
  MS_ASSIGN_OR_RETURN(VersionRecord record, ReadVersion(row));
  std::vector<VersionRecord> records = {std::move(record)};
  LoadResources(tx, &records);
  return std::move(records.front());
}

// --- blobs and leases ------------------------------------------------------------

std::set<std::string> LockBlobs(pqxx::transaction_base& tx, const std::vector<std::string>& digests) {
  std::set<std::string> found;
  if (digests.empty()) return found;
  const pqxx::result rows = tx.exec_params(
      "SELECT sha256 FROM meshstream.blobs WHERE sha256 = ANY($1::text[]) ORDER BY sha256 FOR KEY SHARE",
      DigestArray(digests));
  for (const pqxx::row& row : rows) found.insert(row[0].as<std::string>());
  return found;
}

StatusOr<bool> InsertBlobRow(pqxx::transaction_base& tx, const std::string& sha256, int64_t size, int64_t chunks) {
  const int64_t now = NowMs();
  for (int attempt = 0; attempt < 3; ++attempt) {
    const pqxx::result inserted = tx.exec_params(
        "INSERT INTO meshstream.blobs (sha256, size, chunks, created_ms) VALUES ($1, $2, $3, $4) "
        "ON CONFLICT (sha256) DO NOTHING RETURNING sha256",
        sha256, size, chunks, now);
    if (!inserted.empty()) return true;
    const pqxx::result touched = tx.exec_params(
        "UPDATE meshstream.blobs SET created_ms = GREATEST(created_ms, $2) WHERE sha256 = $1 RETURNING size", sha256,
        now);
    if (!touched.empty()) {
      const int64_t stored = touched[0][0].as<int64_t>();
      if (stored != size) {
        return DataLoss("blob " + sha256 + " is recorded with " + std::to_string(stored) + " bytes, but its bytes are " +
                        std::to_string(size));
      }
      return false;
    }
    // Removed by an orphan sweep between the two statements: insert again.
  }
  return Aborted("blob " + sha256 + ": inserted and removed concurrently, three times");
}

Status LeaseError(pqxx::transaction_base& tx, const std::string& job_id, const std::string& worker) {
  const pqxx::result rows = tx.exec_params("SELECT state, lease_owner FROM meshstream.jobs WHERE id = $1", job_id);
  if (rows.empty()) return JobNotFound(job_id);
  MS_ASSIGN_OR_RETURN(const JobState state, JobStateFromRow(rows[0][0].as<int64_t>()));
  const Status refused = CheckLeaseHolder(job_id, worker, state, rows[0][1].as<std::string>());
  // The guarded UPDATE missed a row that now looks held by `worker`: the
  // lease changed hands in between (released and claimed again). Not ours.
  if (refused.ok()) return Aborted("job " + job_id + ": the lease is held by another worker");
  return refused;
}

}  // namespace meshstream

#include "services/store/pg_store.h"

#include <sodium.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <limits>
#include <map>
#include <mutex>
#include <new>
#include <set>
#include <thread>
#include <utility>

#include <nlohmann/json.hpp>
#include <pqxx/pqxx>

#include "services/store/blob_store.h"
#include "services/store/page_token.h"
#include "services/store/pg_schema.h"

namespace meshstream {

namespace {

// A blob, staging or upload row holds at most this many bytes (the schema checks it).
constexpr size_t kChunkBytes = PgBlobSink::kChunkBytes;
// CommitUpload reads the upload back in windows of this many bytes.
constexpr int64_t kReadWindowBytes = 4 * static_cast<int64_t>(kChunkBytes);
// RemoveOrphanBlobs deletes at most this many blobs per transaction.
constexpr int kOrphanBatch = 500;

constexpr int kPending = static_cast<int>(JobState::kPending);
constexpr int kRunning = static_cast<int>(JobState::kRunning);
constexpr int kSucceeded = static_cast<int>(JobState::kSucceeded);
constexpr int kFailed = static_cast<int>(JobState::kFailed);
constexpr int kProcessing = static_cast<int>(VersionState::kProcessing);
constexpr int kReady = static_cast<int>(VersionState::kReady);
constexpr int kVersionFailed = static_cast<int>(VersionState::kFailed);

// ---------------------------------------------------------------------------
// Checks of untrusted arguments.

bool IsUtf8(const std::string& s) {
  size_t i = 0;
  const size_t n = s.size();
  while (i < n) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      ++i;
      continue;
    }
    size_t extra = 0;
    uint32_t cp = 0;
    if (c >= 0xC2 && c <= 0xDF) {
      extra = 1;
      cp = c & 0x1F;
    } else if (c >= 0xE0 && c <= 0xEF) {
      extra = 2;
      cp = c & 0x0F;
    } else if (c >= 0xF0 && c <= 0xF4) {
      extra = 3;
      cp = c & 0x07;
    } else {
      return false;
    }
    if (i + extra >= n) return false;  // truncated sequence
    for (size_t k = 1; k <= extra; ++k) {
      const auto d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3F);
    }
    // Overlong forms, surrogates and code points above U+10FFFF.
    if ((extra == 2 && cp < 0x800) || (extra == 3 && (cp < 0x10000 || cp > 0x10FFFF)) ||
        (cp >= 0xD800 && cp <= 0xDFFF)) {
      return false;
    }
    i += extra + 1;
  }
  return true;
}

// PostgreSQL text holds neither NUL bytes (libpq would cut the value there)
// nor invalid UTF-8 (the server refuses it without naming the field).
Status CheckText(const std::string& field, const std::string& text) {
  if (text.find('\0') != std::string::npos) return InvalidArgument(field + ": contains a NUL byte");
  if (!IsUtf8(text)) return InvalidArgument(field + ": is not valid UTF-8");
  return Status::Ok();
}

Status CheckNonEmptyText(const std::string& field, const std::string& text) {
  if (text.empty()) return InvalidArgument(field + ": must not be empty");
  return CheckText(field, text);
}

Status CheckDigest(const std::string& field, const std::string& digest) {
  if (IsSha256Hex(digest)) return Status::Ok();
  return InvalidArgument(field + ": not a SHA-256 (64 lower-case hex digits)");
}

StatusOr<int64_t> ToBigint(const std::string& field, uint64_t value) {
  if (value > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) {
    return InvalidArgument(field + ": " + std::to_string(value) + " does not fit the database's 64-bit signed integer");
  }
  return static_cast<int64_t>(value);
}

// ---------------------------------------------------------------------------
// Bytes, digests and ids.

int HexNibble(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Decodes `n` hex digits (n even) into out[0 .. n/2).
bool DecodeHex(const char* hex, size_t n, uint8_t* out) {
  if (n % 2 != 0) return false;
  for (size_t i = 0; i < n; i += 2) {
    const int hi = HexNibble(hex[i]), lo = HexNibble(hex[i + 1]);
    if (hi < 0 || lo < 0) return false;
    out[i / 2] = static_cast<uint8_t>(hi * 16 + lo);
  }
  return true;
}

// A bytea parameter sent in binary (no escaping, no doubling on the wire).
// libpqxx 6.4 takes binarystring; a port to libpqxx 7 changes only this.
pqxx::binarystring Bytea(const uint8_t* data, size_t size) {
  static const uint8_t kEmpty = 0;
  return pqxx::binarystring(size == 0 ? &kEmpty : data, size);
}

// A text[] parameter of digests (checked hex: nothing to quote).
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

// PostgreSQL's text form of a bigint[] ("{1,2,3}"); throws on anything else.
std::vector<int64_t> ParseBigintArray(const std::string& text) {
  if (text.size() < 2 || text.front() != '{' || text.back() != '}') {
    throw std::runtime_error("level_vertices: unexpected array text");
  }
  std::vector<int64_t> values;
  const std::string inner = text.substr(1, text.size() - 2);
  size_t start = 0;
  while (start < inner.size()) {
    size_t end = inner.find(',', start);
    if (end == std::string::npos) end = inner.size();
    values.push_back(std::stoll(inner.substr(start, end - start)));
    start = end + 1;
  }
  return values;
}

std::string LabelsJson(const std::map<std::string, std::string>& labels) {
  nlohmann::json object = nlohmann::json::object();
  for (const auto& [key, value] : labels) object[key] = value;
  return object.dump();
}

std::map<std::string, std::string> ParseLabels(const std::string& text) {
  std::map<std::string, std::string> labels;
  const nlohmann::json object = nlohmann::json::parse(text);
  for (auto it = object.begin(); it != object.end(); ++it) labels[it.key()] = it.value().get<std::string>();
  return labels;
}

// ---------------------------------------------------------------------------
// Rows to records.

const char kArtifactColumns[] =
    "artifact_sha256, progressive_bytes, encoder, vertices, faces, levels, level_vertices, reliable_bytes, "
    "unreliable_bytes, layout_json, warnings_json";

const std::string& VersionColumns() {
  static const std::string columns =
      "tenant, asset, version, state, source_name, source_sha256, source_size, options_json, comment, "
      "labels::text AS labels, created_ms, job_id, error, " +
      std::string(kArtifactColumns);
  return columns;
}

const char kJobColumns[] =
    "id, tenant, asset, version, state, progress, message, attempts, lease_owner, lease_expires_ms, created_ms, "
    "updated_ms";

std::string Text(const pqxx::field& field) { return field.is_null() ? std::string() : field.as<std::string>(); }

ArtifactSummary ReadArtifact(const pqxx::row& row) {
  ArtifactSummary a;
  a.artifact_sha256 = Text(row["artifact_sha256"]);
  a.progressive_bytes = static_cast<uint64_t>(row["progressive_bytes"].as<int64_t>());
  a.encoder = row["encoder"].as<std::string>();
  a.vertices = row["vertices"].as<int64_t>();
  a.faces = row["faces"].as<int64_t>();
  a.levels = row["levels"].as<int32_t>();
  a.level_vertices = ParseBigintArray(row["level_vertices"].as<std::string>());
  a.reliable_bytes = static_cast<uint64_t>(row["reliable_bytes"].as<int64_t>());
  a.unreliable_bytes = static_cast<uint64_t>(row["unreliable_bytes"].as<int64_t>());
  a.layout_json = row["layout_json"].as<std::string>();
  a.warnings_json = row["warnings_json"].as<std::string>();
  return a;
}

VersionRecord ReadVersion(const pqxx::row& row) {
  VersionRecord v;
  v.tenant = row["tenant"].as<std::string>();
  v.asset = row["asset"].as<std::string>();
  v.version = row["version"].as<int64_t>();
  v.state = static_cast<VersionState>(row["state"].as<int>());
  v.source.name = row["source_name"].as<std::string>();
  v.source.sha256 = row["source_sha256"].as<std::string>();
  v.source.size = static_cast<uint64_t>(row["source_size"].as<int64_t>());
  v.options_json = row["options_json"].as<std::string>();
  v.comment = row["comment"].as<std::string>();
  v.labels = ParseLabels(row["labels"].as<std::string>());
  v.created_ms = row["created_ms"].as<int64_t>();
  v.job_id = row["job_id"].as<std::string>();
  v.error = row["error"].as<std::string>();
  v.artifact = ReadArtifact(row);
  return v;
}

JobRecord ReadJob(const pqxx::row& row) {
  JobRecord j;
  j.id = row["id"].as<std::string>();
  j.tenant = row["tenant"].as<std::string>();
  j.asset = row["asset"].as<std::string>();
  j.version = row["version"].as<int64_t>();
  j.state = static_cast<JobState>(row["state"].as<int>());
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

// Fills the resources of `versions` (all of one asset) from version_resources.
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

Status CheckSummary(const ArtifactSummary& s) {
  MS_RETURN_IF_ERROR(CheckDigest("artifact_sha256", s.artifact_sha256));
  MS_RETURN_IF_ERROR(ToBigint("progressive_bytes", s.progressive_bytes).status());
  MS_RETURN_IF_ERROR(ToBigint("reliable_bytes", s.reliable_bytes).status());
  MS_RETURN_IF_ERROR(ToBigint("unreliable_bytes", s.unreliable_bytes).status());
  MS_RETURN_IF_ERROR(CheckText("encoder", s.encoder));
  MS_RETURN_IF_ERROR(CheckText("layout_json", s.layout_json));
  MS_RETURN_IF_ERROR(CheckText("warnings_json", s.warnings_json));
  if (s.vertices < 0) return InvalidArgument("vertices: " + std::to_string(s.vertices) + " is negative");
  if (s.faces < 0) return InvalidArgument("faces: " + std::to_string(s.faces) + " is negative");
  if (s.levels < 0) return InvalidArgument("levels: " + std::to_string(s.levels) + " is negative");
  return Status::Ok();
}

// Locks blob rows against removal for the rest of the transaction (the
// orphan sweep skips rows locked so) and returns the digests that exist.
std::set<std::string> LockBlobs(pqxx::transaction_base& tx, const std::vector<std::string>& digests) {
  std::set<std::string> found;
  if (digests.empty()) return found;
  const pqxx::result rows = tx.exec_params(
      "SELECT sha256 FROM meshstream.blobs WHERE sha256 = ANY($1::text[]) ORDER BY sha256 FOR KEY SHARE",
      DigestArray(digests));
  for (const pqxx::row& row : rows) found.insert(row[0].as<std::string>());
  return found;
}

// Inserts the row of blob `sha256` unless it exists. True when inserted (the
// caller then writes the chunks in the same transaction); false when the same
// bytes were stored already, whose created_ms is then refreshed so that the
// orphan sweep gives the caller min_age_ms to name them again.
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

// Why `worker` could not act on job `job_id` (the UPDATE matched no row).
Status LeaseError(pqxx::transaction_base& tx, const std::string& job_id, const std::string& worker) {
  const pqxx::result rows =
      tx.exec_params("SELECT state, lease_owner FROM meshstream.jobs WHERE id = $1", job_id);
  if (rows.empty()) return NotFound("job " + job_id + " does not exist");
  const int state = rows[0][0].as<int>();
  if (state == kRunning || rows[0][1].as<std::string>() != worker) {
    return Aborted("job " + job_id + ": the lease is held by another worker");
  }
  return Aborted("job " + job_id + ": already " + (state == kSucceeded ? "SUCCEEDED" : state == kFailed ? "FAILED" : "PENDING") +
                 ", the lease is over");
}

// libpq's messages span lines ("...\n\tIs the server running ...?\n"); a
// Status message is one line.
std::string Trimmed(const char* what) {
  std::string s;
  for (const char* p = what; *p != '\0'; ++p) {
    const char c = (*p == '\n' || *p == '\t' || *p == '\r') ? ' ' : *p;
    if (c == ' ' && (s.empty() || s.back() == ' ')) continue;
    s += c;
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

}  // namespace

// ---------------------------------------------------------------------------
// The connection pool.

class PgPool {
 public:
  PgPool(std::string conninfo, int max_connections, int64_t acquire_timeout_ms)
      : conninfo_(std::move(conninfo)), max_(max_connections), timeout_ms_(acquire_timeout_ms) {}

  // One pooled connection, given back to the pool when destroyed.
  class Lease {
   public:
    Lease(PgPool* pool, std::unique_ptr<pqxx::connection> connection)
        : pool_(pool), connection_(std::move(connection)) {}
    Lease(Lease&& other) noexcept : pool_(other.pool_), connection_(std::move(other.connection_)) {
      other.pool_ = nullptr;
    }
    Lease& operator=(Lease&&) = delete;
    ~Lease() {
      if (pool_ != nullptr) pool_->Release(std::move(connection_));
    }
    pqxx::connection& connection() { return *connection_; }
    bool open() const { return connection_ != nullptr && connection_->is_open(); }
    // Closes the connection; the pool opens a fresh one when it needs it.
    void Discard() { connection_.reset(); }

   private:
    PgPool* pool_;
    std::unique_ptr<pqxx::connection> connection_;
  };

  // An idle connection when there is one, else a new one when the pool is
  // not full, else waits. `fresh`: always a new connection (closing an idle
  // one to make room), for the retry after a connection broke, since the
  // other idle ones are likely broken too (the server restarted).
  StatusOr<Lease> Acquire(bool fresh = false) {
    std::unique_ptr<pqxx::connection> stale;  // closed after the lock is released
    std::unique_lock<std::mutex> lock(mu_);
    const bool ready = cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms_),
                                    [&] { return !idle_.empty() || open_ < max_; });
    if (!ready) {
      return Unavailable("all " + std::to_string(max_) + " PostgreSQL connections stayed busy for " +
                         std::to_string(timeout_ms_) + " ms");
    }
    if (!idle_.empty()) {
      std::unique_ptr<pqxx::connection> connection = std::move(idle_.back());
      idle_.pop_back();
      if (!fresh) return Lease(this, std::move(connection));
      stale = std::move(connection);
      --open_;  // its slot is ours
    }
    ++open_;
    lock.unlock();
    StatusOr<std::unique_ptr<pqxx::connection>> connection = Connect();
    if (!connection.ok()) {
      lock.lock();
      --open_;
      cv_.notify_one();
      return connection.status();
    }
    return Lease(this, std::move(connection).value());
  }

 private:
  StatusOr<std::unique_ptr<pqxx::connection>> Connect() {
    try {
      auto connection = std::make_unique<pqxx::connection>(conninfo_);
      // The pool replaces a broken connection itself; libpqxx 6 would
      // otherwise reconnect behind our back on the next statement.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
      connection->inhibit_reactivation(true);
#pragma GCC diagnostic pop
      return connection;
    } catch (const pqxx::broken_connection& e) {
      // libpq's message names the host and the reason, never the password.
      return Unavailable("cannot connect to PostgreSQL: " + Trimmed(e.what()));
    } catch (const std::exception& e) {
      return Unavailable("cannot connect to PostgreSQL: " + Trimmed(e.what()));
    }
  }

  void Release(std::unique_ptr<pqxx::connection> connection) {
    std::lock_guard<std::mutex> lock(mu_);
    if (connection != nullptr && connection->is_open()) {
      idle_.push_back(std::move(connection));
    } else {
      --open_;  // a broken or discarded connection frees its slot
    }
    cv_.notify_one();
  }

  const std::string conninfo_;
  const int max_;
  const int64_t timeout_ms_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::unique_ptr<pqxx::connection>> idle_;
  int open_ = 0;  // connections leased or idle
};

// ---------------------------------------------------------------------------
// Running a transaction.

template <typename F>
auto PgStore::Run(const std::string& what, F&& fn) {
  using Result = decltype(fn(std::declval<pqxx::connection&>()));
  bool reconnected = false;
  int conflicts = 0;
  for (;;) {
    StatusOr<PgPool::Lease> leased = pool_->Acquire(/*fresh=*/reconnected);
    if (!leased.ok()) return Result(leased.status().WithContext(what));
    PgPool::Lease lease = std::move(leased).value();
    Status error;
    bool lost_connection = false;  // retry once on a fresh connection
    bool conflict = false;         // retry up to conflict_attempts times
    bool outcome_known = true;     // false: the transaction may have committed
    try {
      return fn(lease.connection());
    } catch (const pqxx::in_doubt_error& e) {
      outcome_known = false;
      error = Unavailable(what + ": the connection to PostgreSQL broke while committing; the outcome is unknown: " +
                          Trimmed(e.what()));
    } catch (const pqxx::statement_completion_unknown& e) {
      outcome_known = false;
      error = Unavailable(what + ": PostgreSQL did not say whether the statement completed: " + Trimmed(e.what()));
    } catch (const pqxx::broken_connection& e) {
      lost_connection = true;
      error = Unavailable(what + ": lost the connection to PostgreSQL: " + Trimmed(e.what()));
    } catch (const pqxx::transaction_rollback& e) {  // serialization failure, deadlock
      conflict = true;
      error = Aborted(what + ": gave up after " + std::to_string(options_.conflict_attempts) +
                      " attempts that conflicted with other transactions: " + Trimmed(e.what()));
    } catch (const pqxx::unique_violation& e) {
      error = AlreadyExists(what + ": " + Trimmed(e.what()));
    } catch (const pqxx::foreign_key_violation& e) {
      error = FailedPrecondition(what + ": " + Trimmed(e.what()));
    } catch (const pqxx::integrity_constraint_violation& e) {
      error = InvalidArgument(what + ": " + Trimmed(e.what()));
    } catch (const pqxx::data_exception& e) {
      error = InvalidArgument(what + ": " + Trimmed(e.what()));
    } catch (const pqxx::insufficient_resources& e) {
      error = Unavailable(what + ": PostgreSQL is out of resources: " + Trimmed(e.what()));
    } catch (const pqxx::sql_error& e) {
      const std::string state = e.sqlstate();
      const std::string cls = state.substr(0, 2);
      if (cls == "08" || state.rfind("57P", 0) == 0) {  // connection exception; shutdown, terminated session
        lost_connection = true;
        error = Unavailable(what + ": PostgreSQL closed the session: " + Trimmed(e.what()));
      } else if (state == "57014" || state == "55P03") {  // statement_timeout, lock_timeout: not retried here
        error = Unavailable(what + ": PostgreSQL cancelled the statement: " + Trimmed(e.what()));
      } else if (cls == "40") {
        conflict = true;
        error = Aborted(what + ": gave up after " + std::to_string(options_.conflict_attempts) +
                        " conflicting attempts: " + Trimmed(e.what()));
      } else if (cls == "53") {
        error = Unavailable(what + ": PostgreSQL is out of resources: " + Trimmed(e.what()));
      } else {
        error = Internal(what + ": " + Trimmed(e.what()) + " (SQLSTATE " + state + ")");
      }
    } catch (const std::bad_alloc&) {
      error = ResourceExhausted(what + ": out of memory");
    } catch (const std::exception& e) {
      error = Internal(what + ": " + Trimmed(e.what()));
    } catch (...) {
      error = Internal(what + ": an unknown exception");
    }
    if (!lease.open()) {
      lease.Discard();
      // A statement failed because the session ended: the server rolled the
      // transaction back, so running it again on a new connection is safe.
      if (outcome_known) lost_connection = true;
    }
    if (lost_connection && outcome_known && !reconnected) {
      reconnected = true;
      continue;
    }
    if (conflict && ++conflicts < options_.conflict_attempts) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5 * conflicts + static_cast<int>(randombytes_uniform(10))));
      continue;
    }
    return Result(error);
  }
}

// ---------------------------------------------------------------------------
// Blobs.

PgBlobSink::PgBlobSink(PgStore* store) : store_(store), staging_id_(RandomHex(16)) {}

PgBlobSink::~PgBlobSink() { DropStaged(); }

Status PgBlobSink::Append(const uint8_t* data, size_t size) {
  if (done_) return FailedPrecondition("blob sink: append after commit, or after a failed append");
  if (size == 0) return Status::Ok();
  if (data == nullptr) return InvalidArgument("blob sink: no data for " + std::to_string(size) + " bytes");
  try {
    while (size > 0) {
      // A full buffer is written out only when more bytes come, so that the
      // last chunk (and a blob of one chunk) goes straight to blob_chunks.
      if (buffer_.size() == kChunkBytes) {
        const Status flushed = Flush();
        if (!flushed.ok()) {
          done_ = true;  // a chunk is missing from staging: refuse to commit
          DropStaged();
          std::vector<uint8_t>().swap(buffer_);
          return flushed;
        }
      }
      const size_t n = std::min(size, kChunkBytes - buffer_.size());
      if (buffer_.capacity() < buffer_.size() + n) {
        // Grow geometrically, but never past one chunk.
        buffer_.reserve(std::min(kChunkBytes, std::max(buffer_.size() + n, 2 * buffer_.capacity())));
      }
      buffer_.insert(buffer_.end(), data, data + n);
      hash_.Update(data, n);
      size_ += n;
      data += n;
      size -= n;
    }
  } catch (const std::bad_alloc&) {
    done_ = true;  // the hash and the bytes may disagree now: refuse to commit
    DropStaged();
    std::vector<uint8_t>().swap(buffer_);
    return ResourceExhausted("blob sink: out of memory after " + std::to_string(size_) + " bytes");
  }
  return Status::Ok();
}

Status PgBlobSink::Flush() {
  maybe_staged_rows_ = true;  // before the INSERT: it may commit even when it reports an error
  MS_RETURN_IF_ERROR(store_->StageChunk(staging_id_, staged_, buffer_.data(), buffer_.size()));
  ++staged_;
  buffer_.clear();  // keeps the capacity for the next chunk
  return Status::Ok();
}

void PgBlobSink::DropStaged() {
  if (!maybe_staged_rows_) return;
  // Best effort: rows left behind (the database is unreachable) are removed
  // later by the age rule of RemoveOrphanBlobs and ExpireUploads.
  if (store_->DropStaging(staging_id_).ok()) maybe_staged_rows_ = false;
}

StatusOr<std::string> PgBlobSink::Commit(const std::string& expected_sha256) {
  if (done_) return FailedPrecondition("blob sink: committed twice, or after a failed append");
  done_ = true;
  Status checked = Status::Ok();
  if (!expected_sha256.empty()) checked = CheckDigest("expected_sha256", expected_sha256);
  const std::string digest = hash_.FinishHex();
  if (checked.ok() && !expected_sha256.empty() && expected_sha256 != digest) {
    checked = DataLoss("the bytes have SHA-256 " + digest + ", not the " + expected_sha256 +
                       " announced; nothing stored");
  }
  Status stored = checked;
  if (stored.ok()) stored = store_->CommitStaged(digest, size_, staging_id_, staged_, buffer_);
  if (stored.ok()) {
    maybe_staged_rows_ = false;  // moved into blob_chunks, or deleted
  } else {
    DropStaged();
  }
  std::vector<uint8_t>().swap(buffer_);
  if (!stored.ok()) return stored;
  return digest;
}

PgStore::PgStore(std::unique_ptr<PgPool> pool, PgStoreOptions options)
    : pool_(std::move(pool)), options_(options) {}

PgStore::~PgStore() = default;

Status PgStore::Migrate() {
  return Run("migrating the meshstream schema",
             [&](pqxx::connection& c) -> Status { return MigratePgSchema(c); });
}

StatusOr<std::unique_ptr<BlobSink>> PgStore::NewBlob() {
  return std::unique_ptr<BlobSink>(std::make_unique<PgBlobSink>(this));
}

Status PgStore::StageChunk(const std::string& staging_id, int64_t seq, const uint8_t* data, size_t size) {
  return Run("staging chunk " + std::to_string(seq) + " of a blob", [&](pqxx::connection& c) -> Status {
    // One statement in autocommit: no connection is held between chunks.
    // Run retries it once after a lost connection, when it may have been
    // applied already: the row is then the same bytes, so DO NOTHING.
    pqxx::nontransaction tx(c);
    tx.exec_params(
        "INSERT INTO meshstream.blob_staging (staging_id, seq, data, created_ms) VALUES ($1, $2, $3, $4) "
        "ON CONFLICT (staging_id, seq) DO NOTHING",
        staging_id, seq, Bytea(data, size), NowMs());
    tx.commit();
    return Status::Ok();
  });
}

Status PgStore::CommitStaged(const std::string& sha256, uint64_t size, const std::string& staging_id, int64_t staged,
                             const std::vector<uint8_t>& tail) {
  MS_ASSIGN_OR_RETURN(const int64_t size64, ToBigint("blob size", size));
  const int64_t chunks = staged + (tail.empty() ? 0 : 1);
  const int64_t staged_bytes = staged * static_cast<int64_t>(kChunkBytes);
  if (staged_bytes + static_cast<int64_t>(tail.size()) != size64) {
    return Internal("blob " + sha256 + ": " + std::to_string(staged) + " staged chunks and a tail of " +
                    std::to_string(tail.size()) + " bytes do not make " + std::to_string(size) + " bytes");
  }
  return Run("storing blob " + sha256, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    MS_ASSIGN_OR_RETURN(const bool inserted, InsertBlobRow(tx, sha256, size64, chunks));
    if (!inserted) {
      // The same bytes are stored: ours are not needed.
      if (staged > 0) tx.exec_params("DELETE FROM meshstream.blob_staging WHERE staging_id = $1", staging_id);
      tx.commit();
      return Status::Ok();
    }
    if (staged > 0) {
      // Moved inside the server, and counted: the DELETE locks each row it
      // takes, so a concurrent sweep of the same rows either took them first
      // (then they are missing here) or waits and finds them gone.
      const pqxx::row moved = tx.exec_params1(
          "WITH moved AS (DELETE FROM meshstream.blob_staging WHERE staging_id = $1 RETURNING seq, data), "
          "copied AS (INSERT INTO meshstream.blob_chunks (sha256, seq, data) SELECT $2, seq, data FROM moved "
          "RETURNING seq, octet_length(data) AS n) "
          "SELECT count(*), coalesce(sum(n), 0)::bigint, coalesce(max(seq), -1) FROM copied",
          staging_id, sha256);
      const int64_t rows = moved[0].as<int64_t>(), bytes = moved[1].as<int64_t>(), last = moved[2].as<int64_t>();
      if (rows != staged || bytes != staged_bytes || last != staged - 1) {
        return Aborted("blob " + sha256 + ": " + std::to_string(staged - rows) + " of its " + std::to_string(staged) +
                       " staged chunks are gone (removed as idle, or the database restarted); nothing stored");
      }
    }
    if (!tail.empty()) {
      tx.exec_params("INSERT INTO meshstream.blob_chunks (sha256, seq, data) VALUES ($1, $2, $3)", sha256, staged,
                     Bytea(tail.data(), tail.size()));
    }
    tx.commit();
    return Status::Ok();
  });
}

Status PgStore::DropStaging(const std::string& staging_id) {
  return Run("dropping a blob's staged chunks", [&](pqxx::connection& c) -> Status {
    pqxx::nontransaction tx(c);
    tx.exec_params("DELETE FROM meshstream.blob_staging WHERE staging_id = $1", staging_id);
    tx.commit();
    return Status::Ok();
  });
}

Status PgStore::RemoveIdleStaging(int64_t cutoff_ms) {
  return Run("removing idle blob staging", [&](pqxx::connection& c) -> Status {
    // The age of a staging id is that of its newest chunk: a live sink
    // writes one at least every chunk of bytes it gets.
    pqxx::nontransaction tx(c);
    tx.exec_params(
        "DELETE FROM meshstream.blob_staging WHERE staging_id IN (SELECT staging_id FROM meshstream.blob_staging "
        "GROUP BY staging_id HAVING max(created_ms) <= $1)",
        cutoff_ms);
    tx.commit();
    return Status::Ok();
  });
}

StatusOr<std::vector<uint8_t>> PgStore::GetBlob(const std::string& sha256, uint64_t max_bytes) {
  if (!IsSha256Hex(sha256)) return InvalidArgument("blob name: not a SHA-256 (64 lower-case hex digits)");
  return Run("reading blob " + sha256, [&](pqxx::connection& c) -> StatusOr<std::vector<uint8_t>> {
    // One snapshot for the row and all its chunks.
    pqxx::transaction<pqxx::repeatable_read, pqxx::read_only> tx(c);
    const pqxx::result head =
        tx.exec_params("SELECT size, chunks FROM meshstream.blobs WHERE sha256 = $1", sha256);
    if (head.empty()) return NotFound("blob " + sha256 + " does not exist");
    const int64_t size = head[0][0].as<int64_t>();
    const int64_t chunks = head[0][1].as<int64_t>();
    if (static_cast<uint64_t>(size) > max_bytes) {
      return ResourceExhausted("blob " + sha256 + " has " + std::to_string(size) + " bytes, more than " +
                               std::to_string(max_bytes));
    }
    std::vector<uint8_t> bytes(static_cast<size_t>(size));
    Sha256Hasher hash;
    size_t done = 0;
    // Chunk by chunk: the client holds the blob and one chunk, never the
    // whole result set of the blob as text.
    for (int64_t seq = 0; seq < chunks; ++seq) {
      const pqxx::result row = tx.exec_params(
          "SELECT encode(data, 'hex') FROM meshstream.blob_chunks WHERE sha256 = $1 AND seq = $2", sha256, seq);
      if (row.empty()) {
        return DataLoss("blob " + sha256 + ": chunk " + std::to_string(seq) + " of " + std::to_string(chunks) +
                        " is missing");
      }
      const pqxx::field field = row[0][0];
      const size_t n = field.size() / 2;
      if (n > bytes.size() - done) {
        return DataLoss("blob " + sha256 + ": chunk " + std::to_string(seq) + " runs past the recorded size " +
                        std::to_string(size));
      }
      if (!DecodeHex(field.c_str(), field.size(), bytes.data() + done)) {
        return Internal("blob " + sha256 + ": PostgreSQL returned malformed hex for chunk " + std::to_string(seq));
      }
      hash.Update(bytes.data() + done, n);
      done += n;
    }
    tx.commit();
    if (done != bytes.size()) {
      return DataLoss("blob " + sha256 + ": its chunks hold " + std::to_string(done) + " bytes, the recorded size is " +
                      std::to_string(size));
    }
    if (hash.FinishHex() != sha256) {
      return DataLoss("blob " + sha256 + " does not match its digest (the stored bytes are damaged)");
    }
    return bytes;
  });
}

StatusOr<bool> PgStore::HasBlob(const std::string& sha256) {
  if (!IsSha256Hex(sha256)) return InvalidArgument("blob name: not a SHA-256 (64 lower-case hex digits)");
  return Run("looking up blob " + sha256, [&](pqxx::connection& c) -> StatusOr<bool> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const bool found = !tx.exec_params("SELECT 1 FROM meshstream.blobs WHERE sha256 = $1", sha256).empty();
    tx.commit();
    return found;
  });
}

StatusOr<uint64_t> PgStore::RemoveOrphanBlobs(int64_t min_age_ms) {
  if (min_age_ms < 0) return InvalidArgument("min_age_ms: " + std::to_string(min_age_ms) + " is negative");
  const int64_t now = NowMs();
  const int64_t cutoff = min_age_ms > now ? std::numeric_limits<int64_t>::min() : now - min_age_ms;
  static const char kUnnamed[] =
      "NOT EXISTS (SELECT 1 FROM meshstream.versions v WHERE v.source_sha256 = b.sha256) "
      "AND NOT EXISTS (SELECT 1 FROM meshstream.versions v WHERE v.artifact_sha256 = b.sha256) "
      "AND NOT EXISTS (SELECT 1 FROM meshstream.version_resources r WHERE r.sha256 = b.sha256) "
      "AND NOT EXISTS (SELECT 1 FROM meshstream.artifacts a WHERE a.artifact_sha256 = b.sha256)";
  // Bytes of blobs that were never committed (their sink's process died)
  // fall under the same age rule: another server's live sink is younger.
  MS_RETURN_IF_ERROR(RemoveIdleStaging(cutoff));
  uint64_t removed = 0;
  for (;;) {
    // Two statements: the SELECT locks old unnamed blobs, skipping those a
    // transaction naming them has locked (CreateVersion, CompleteJob and
    // PutArtifact lock the blobs they name, and their foreign keys do too).
    // The DELETE takes a new snapshot after the locks are held, so it sees
    // every row that named a candidate and committed meanwhile.
    StatusOr<std::pair<size_t, uint64_t>> batch = Run(
        "removing orphan blobs", [&](pqxx::connection& c) -> StatusOr<std::pair<size_t, uint64_t>> {
          pqxx::work tx(c);
          const pqxx::result candidates = tx.exec_params(
              std::string("SELECT b.sha256 FROM meshstream.blobs b WHERE b.created_ms <= $1 AND ") + kUnnamed +
                  " ORDER BY b.sha256 LIMIT $2 FOR UPDATE OF b SKIP LOCKED",
              cutoff, kOrphanBatch);
          if (candidates.empty()) {
            tx.commit();
            return std::pair<size_t, uint64_t>(0, 0);
          }
          std::vector<std::string> digests;
          for (const pqxx::row& row : candidates) digests.push_back(row[0].as<std::string>());
          const pqxx::result deleted = tx.exec_params(
              std::string("DELETE FROM meshstream.blobs b WHERE b.sha256 = ANY($1::text[]) AND b.created_ms <= $2 AND ") +
                  kUnnamed,
              DigestArray(digests), cutoff);
          const uint64_t n = deleted.affected_rows();
          tx.commit();
          return std::pair<size_t, uint64_t>(digests.size(), n);
        });
    if (!batch.ok()) return batch.status();
    removed += batch->second;
    // Stop on a short batch, or when a batch removed nothing (every candidate
    // was named meanwhile) so that the loop cannot spin.
    if (batch->first < static_cast<size_t>(kOrphanBatch) || batch->second == 0) break;
  }
  return removed;
}

// ---------------------------------------------------------------------------
// Resumable uploads.

StatusOr<uint64_t> PgStore::UploadSize(const std::string& tenant, const std::string& upload_id) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("upload_id", upload_id));
  return Run("upload " + upload_id, [&](pqxx::connection& c) -> StatusOr<uint64_t> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        "SELECT size FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2", tenant, upload_id);
    tx.commit();
    if (rows.empty()) return NotFound("upload '" + upload_id + "' does not exist");
    return static_cast<uint64_t>(rows[0][0].as<int64_t>());
  });
}

Status PgStore::AppendUpload(const std::string& tenant, const std::string& upload_id, uint64_t offset,
                             const uint8_t* data, size_t size) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("upload_id", upload_id));
  if (size > 0 && data == nullptr) return InvalidArgument("upload '" + upload_id + "': no data for " + std::to_string(size) + " bytes");
  MS_ASSIGN_OR_RETURN(const int64_t offset64, ToBigint("offset", offset));
  if (static_cast<uint64_t>(size) > static_cast<uint64_t>(std::numeric_limits<int64_t>::max() - offset64)) {
    return InvalidArgument("upload '" + upload_id + "': offset plus size overflows");
  }
  return Run("appending to upload " + upload_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const int64_t now = NowMs();
    static const char kLock[] =
        "SELECT size FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2 FOR UPDATE";
    // The row lock serializes appenders of one upload: the size read here
    // is the durable size until this transaction ends.
    pqxx::result rows = tx.exec_params(kLock, tenant, upload_id);
    if (rows.empty()) {
      if (offset64 != 0) {
        return FailedPrecondition("upload '" + upload_id + "': append at offset " + std::to_string(offset64) +
                                  ", but the upload does not exist (0 bytes are durable)");
      }
      tx.exec_params(
          "INSERT INTO meshstream.uploads (tenant, upload_id, size, created_ms, updated_ms) VALUES ($1, $2, 0, $3, $3) "
          "ON CONFLICT (tenant, upload_id) DO NOTHING",
          tenant, upload_id, now);
      // Ours, or one another appender created at the same moment: lock it.
      rows = tx.exec_params(kLock, tenant, upload_id);
      if (rows.empty()) return Aborted("upload '" + upload_id + "': created and removed concurrently");
    }
    const int64_t durable = rows[0][0].as<int64_t>();
    if (durable != offset64) {
      return FailedPrecondition("upload '" + upload_id + "': append at offset " + std::to_string(offset64) + ", but " +
                                std::to_string(durable) + " bytes are durable");
    }
    for (size_t done = 0; done < size;) {
      const size_t n = std::min(size - done, kChunkBytes);
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

StatusOr<std::string> PgStore::CommitUpload(const std::string& tenant, const std::string& upload_id,
                                            const std::string& expected_sha256) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("upload_id", upload_id));
  if (!expected_sha256.empty()) MS_RETURN_IF_ERROR(CheckDigest("expected_sha256", expected_sha256));
  return Run("committing upload " + upload_id, [&](pqxx::connection& c) -> StatusOr<std::string> {
    pqxx::work tx(c);
    const pqxx::result head = tx.exec_params(
        "SELECT size FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2 FOR UPDATE", tenant, upload_id);
    if (head.empty()) return NotFound("upload '" + upload_id + "' does not exist");
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
        return DataLoss("upload '" + upload_id + "': bytes from " + std::to_string(next) + " of " +
                        std::to_string(size) + " are missing");
      }
      for (const pqxx::row& row : rows) {
        const int64_t at = row[0].as<int64_t>();
        const pqxx::field field = row[1];
        const size_t n = field.size() / 2;
        if (at != next || static_cast<int64_t>(n) > size - next) {
          return DataLoss("upload '" + upload_id + "': a chunk at byte " + std::to_string(at) +
                          " does not continue the bytes before it (expected " + std::to_string(next) + ")");
        }
        buffer.resize(n);
        if (!DecodeHex(field.c_str(), field.size(), buffer.data())) {
          return Internal("upload '" + upload_id + "': PostgreSQL returned malformed hex");
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
      return DataLoss("upload '" + upload_id + "': the bytes have SHA-256 " + digest + ", not the " + expected_sha256 +
                      " announced; the upload is discarded");
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
        return Internal("upload '" + upload_id + "': copied " + std::to_string(copied.affected_rows()) +
                        " chunks, hashed " + std::to_string(chunks));
      }
    }
    tx.exec_params(remove, tenant, upload_id);
    tx.commit();
    return digest;
  });
}

Status PgStore::DiscardUpload(const std::string& tenant, const std::string& upload_id) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("upload_id", upload_id));
  return Run("discarding upload " + upload_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const pqxx::result r =
        tx.exec_params("DELETE FROM meshstream.uploads WHERE tenant = $1 AND upload_id = $2", tenant, upload_id);
    tx.commit();
    if (r.affected_rows() == 0) return NotFound("upload '" + upload_id + "' does not exist");
    return Status::Ok();
  });
}

StatusOr<uint64_t> PgStore::ExpireUploads(int64_t max_idle_ms) {
  if (max_idle_ms < 0) return InvalidArgument("max_idle_ms: " + std::to_string(max_idle_ms) + " is negative");
  const int64_t now = NowMs();
  const int64_t cutoff = max_idle_ms > now ? std::numeric_limits<int64_t>::min() : now - max_idle_ms;
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

StatusOr<VersionRecord> PgStore::CreateVersion(const NewVersion& nv) {
  MS_RETURN_IF_ERROR(CheckName("tenant", nv.tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", nv.asset));
  MS_RETURN_IF_ERROR(CheckNonEmptyText("source.name", nv.source.name));
  MS_RETURN_IF_ERROR(CheckDigest("source.sha256", nv.source.sha256));
  MS_ASSIGN_OR_RETURN(const int64_t source_size, ToBigint("source.size", nv.source.size));
  std::vector<int64_t> resource_sizes;
  for (size_t i = 0; i < nv.resources.size(); ++i) {
    const std::string field = "resources[" + std::to_string(i) + "]";
    MS_RETURN_IF_ERROR(CheckNonEmptyText(field + ".name", nv.resources[i].name));
    MS_RETURN_IF_ERROR(CheckDigest(field + ".sha256", nv.resources[i].sha256));
    MS_ASSIGN_OR_RETURN(const int64_t size, ToBigint(field + ".size", nv.resources[i].size));
    resource_sizes.push_back(size);
  }
  MS_RETURN_IF_ERROR(CheckText("options_json", nv.options_json));
  MS_RETURN_IF_ERROR(CheckText("comment", nv.comment));
  for (const auto& [key, value] : nv.labels) {
    MS_RETURN_IF_ERROR(CheckNonEmptyText("labels key", key));
    MS_RETURN_IF_ERROR(CheckText("labels['" + key + "']", value));
  }
  const std::string labels = LabelsJson(nv.labels);

  return Run("creating a version of asset " + nv.asset, [&](pqxx::connection& c) -> StatusOr<VersionRecord> {
    pqxx::work tx(c);
    std::vector<std::string> digests = {nv.source.sha256};
    for (const SourceFile& r : nv.resources) digests.push_back(r.sha256);
    // Locked until commit: the orphan sweep cannot remove them meanwhile.
    const std::set<std::string> present = LockBlobs(tx, digests);
    if (present.count(nv.source.sha256) == 0) {
      return FailedPrecondition("source '" + nv.source.name + "': blob " + nv.source.sha256 + " does not exist");
    }
    for (size_t i = 0; i < nv.resources.size(); ++i) {
      if (present.count(nv.resources[i].sha256) == 0) {
        return FailedPrecondition("resources[" + std::to_string(i) + "] '" + nv.resources[i].name + "': blob " +
                                  nv.resources[i].sha256 + " does not exist");
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
        nv.tenant, nv.asset, number, kProcessing, nv.source.name, nv.source.sha256, source_size, nv.options_json,
        nv.comment, labels, now, job_id);
    for (size_t i = 0; i < nv.resources.size(); ++i) {
      tx.exec_params(
          "INSERT INTO meshstream.version_resources (tenant, asset, version, idx, name, sha256, size) "
          "VALUES ($1, $2, $3, $4, $5, $6, $7)",
          nv.tenant, nv.asset, number, static_cast<int64_t>(i), nv.resources[i].name, nv.resources[i].sha256,
          resource_sizes[i]);
    }
    tx.exec_params(
        "INSERT INTO meshstream.jobs (id, tenant, asset, version, state, created_ms, updated_ms) "
        "VALUES ($1, $2, $3, $4, $5, $6, $6)",
        job_id, nv.tenant, nv.asset, number, kPending, now);
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

StatusOr<VersionRecord> PgStore::GetVersion(const std::string& tenant, const std::string& asset, int64_t version) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
  if (version < 0) return InvalidArgument("version: " + std::to_string(version) + " is negative");
  return Run("reading asset " + asset, [&](pqxx::connection& c) -> StatusOr<VersionRecord> {
    pqxx::transaction<pqxx::repeatable_read, pqxx::read_only> tx(c);
    const pqxx::result head = tx.exec_params(
        "SELECT latest_version FROM meshstream.assets WHERE tenant = $1 AND name = $2", tenant, asset);
    if (head.empty()) return NotFound("asset '" + asset + "' does not exist");
    const int64_t number = version == 0 ? head[0][0].as<int64_t>() : version;
    const pqxx::result rows = tx.exec_params(
        "SELECT " + VersionColumns() + " FROM meshstream.versions WHERE tenant = $1 AND asset = $2 AND version = $3",
        tenant, asset, number);
    if (rows.empty()) return NotFound("asset '" + asset + "' has no version " + std::to_string(number));
    std::vector<VersionRecord> records = {ReadVersion(rows[0])};
    LoadResources(tx, &records);
    tx.commit();
    return std::move(records.front());
  });
}

StatusOr<VersionRecord> PgStore::GetLatestReadyVersion(const std::string& tenant, const std::string& asset) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
  return Run("reading asset " + asset, [&](pqxx::connection& c) -> StatusOr<VersionRecord> {
    pqxx::transaction<pqxx::repeatable_read, pqxx::read_only> tx(c);
    const pqxx::result rows = tx.exec_params("SELECT " + VersionColumns() +
                                                 " FROM meshstream.versions WHERE tenant = $1 AND asset = $2 AND "
                                                 "state = $3 ORDER BY version DESC LIMIT 1",
                                             tenant, asset, kReady);
    if (rows.empty()) {
      const bool known = !tx.exec_params("SELECT 1 FROM meshstream.assets WHERE tenant = $1 AND name = $2", tenant,
                                         asset)
                              .empty();
      return NotFound(known ? "asset '" + asset + "' has no READY version" : "asset '" + asset + "' does not exist");
    }
    std::vector<VersionRecord> records = {ReadVersion(rows[0])};
    LoadResources(tx, &records);
    tx.commit();
    return std::move(records.front());
  });
}

StatusOr<Page<AssetRecord>> PgStore::ListAssets(const std::string& tenant, int32_t page_size,
                                                const std::string& page_token) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_ASSIGN_OR_RETURN(const int32_t size, EffectivePageSize(page_size));
  MS_ASSIGN_OR_RETURN(const std::string after, DecodeAssetsPageToken(page_token));
  return Run("listing assets", [&](pqxx::connection& c) -> StatusOr<Page<AssetRecord>> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        "SELECT name, latest_version, updated_ms FROM meshstream.assets WHERE tenant = $1 AND name > $2 "
        "ORDER BY name LIMIT $3",
        tenant, after, static_cast<int64_t>(size) + 1);
    tx.commit();
    Page<AssetRecord> page;
    for (const pqxx::row& row : rows) {
      if (page.items.size() == static_cast<size_t>(size)) {
        page.next_page_token = EncodeAssetsPageToken(page.items.back().name);
        break;
      }
      AssetRecord a;
      a.tenant = tenant;
      a.name = row["name"].as<std::string>();
      a.latest_version = row["latest_version"].as<int64_t>();
      a.updated_ms = row["updated_ms"].as<int64_t>();
      page.items.push_back(std::move(a));
    }
    return page;
  });
}

StatusOr<Page<VersionRecord>> PgStore::ListVersions(const std::string& tenant, const std::string& asset,
                                                    int32_t page_size, const std::string& page_token) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("asset", asset));
  MS_ASSIGN_OR_RETURN(const int32_t size, EffectivePageSize(page_size));
  MS_ASSIGN_OR_RETURN(const int64_t after, DecodeVersionsPageToken(page_token));
  return Run("listing versions of asset " + asset, [&](pqxx::connection& c) -> StatusOr<Page<VersionRecord>> {
    pqxx::transaction<pqxx::repeatable_read, pqxx::read_only> tx(c);
    if (tx.exec_params("SELECT 1 FROM meshstream.assets WHERE tenant = $1 AND name = $2", tenant, asset).empty()) {
      return NotFound("asset '" + asset + "' does not exist");
    }
    const pqxx::result rows = tx.exec_params("SELECT " + VersionColumns() +
                                                 " FROM meshstream.versions WHERE tenant = $1 AND asset = $2 AND "
                                                 "version > $3 ORDER BY version LIMIT $4",
                                             tenant, asset, after, static_cast<int64_t>(size) + 1);
    Page<VersionRecord> page;
    for (const pqxx::row& row : rows) {
      if (page.items.size() == static_cast<size_t>(size)) {
        page.next_page_token = EncodeVersionsPageToken(page.items.back().version);
        break;
      }
      page.items.push_back(ReadVersion(row));
    }
    LoadResources(tx, &page.items);
    tx.commit();
    return page;
  });
}

// ---------------------------------------------------------------------------
// Jobs.

StatusOr<JobRecord> PgStore::GetJob(const std::string& tenant, const std::string& job_id) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  return Run("reading job " + job_id, [&](pqxx::connection& c) -> StatusOr<JobRecord> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        std::string("SELECT ") + kJobColumns + " FROM meshstream.jobs WHERE id = $1 AND tenant = $2", job_id, tenant);
    tx.commit();
    if (rows.empty()) return NotFound("job " + job_id + " does not exist");
    return ReadJob(rows[0]);
  });
}

StatusOr<std::optional<JobRecord>> PgStore::ClaimJob(const std::string& worker, int64_t now_ms, int64_t lease_ms) {
  MS_RETURN_IF_ERROR(CheckNonEmptyText("worker", worker));
  if (lease_ms <= 0) return InvalidArgument("lease_ms: " + std::to_string(lease_ms) + " is not positive");
  if (now_ms < 0 || now_ms > std::numeric_limits<int64_t>::max() - lease_ms) {
    return InvalidArgument("now_ms: " + std::to_string(now_ms) + " is out of range");
  }
  return Run("claiming a job", [&](pqxx::connection& c) -> StatusOr<std::optional<JobRecord>> {
    pqxx::work tx(c);
    // SKIP LOCKED: a job another claimer is taking right now is not waited
    // for but passed over, so concurrent claimers get different jobs.
    const pqxx::result pick = tx.exec_params(
        "SELECT id FROM meshstream.jobs WHERE state IN ($1, $2) AND (state = $1 OR lease_expires_ms < $3) "
        "ORDER BY created_ms, seq LIMIT 1 FOR UPDATE SKIP LOCKED",
        kPending, kRunning, now_ms);
    if (pick.empty()) {
      tx.commit();
      return std::optional<JobRecord>();
    }
    const pqxx::row row = tx.exec_params1(
        std::string("UPDATE meshstream.jobs SET state = $2, lease_owner = $3, lease_expires_ms = $4, "
                    "attempts = attempts + 1, updated_ms = $5 WHERE id = $1 RETURNING ") +
            kJobColumns,
        pick[0][0].as<std::string>(), kRunning, worker, now_ms + lease_ms, NowMs());
    JobRecord job = ReadJob(row);
    tx.commit();
    return std::optional<JobRecord>(std::move(job));
  });
}

Status PgStore::RenewLease(const std::string& job_id, const std::string& worker, int64_t now_ms, int64_t lease_ms,
                           double progress, const std::string& message) {
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  MS_RETURN_IF_ERROR(CheckNonEmptyText("worker", worker));
  MS_RETURN_IF_ERROR(CheckText("message", message));
  if (lease_ms <= 0) return InvalidArgument("lease_ms: " + std::to_string(lease_ms) + " is not positive");
  if (now_ms < 0 || now_ms > std::numeric_limits<int64_t>::max() - lease_ms) {
    return InvalidArgument("now_ms: " + std::to_string(now_ms) + " is out of range");
  }
  if (!(progress >= 0.0 && progress <= 1.0)) return InvalidArgument("progress: must be within 0..1");
  return Run("renewing the lease of job " + job_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const pqxx::result r = tx.exec_params(
        "UPDATE meshstream.jobs SET lease_expires_ms = $3, progress = $4, message = $5, updated_ms = $6 "
        "WHERE id = $1 AND lease_owner = $2 AND state = $7",
        job_id, worker, now_ms + lease_ms, progress, message, NowMs(), kRunning);
    if (r.affected_rows() == 0) return LeaseError(tx, job_id, worker);
    tx.commit();
    return Status::Ok();
  });
}

Status PgStore::CompleteJob(const std::string& job_id, const std::string& worker, const ArtifactSummary& summary) {
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  MS_RETURN_IF_ERROR(CheckNonEmptyText("worker", worker));
  MS_RETURN_IF_ERROR(CheckSummary(summary));
  return Run("completing job " + job_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const int64_t now = NowMs();
    const pqxx::result job = tx.exec_params(
        "UPDATE meshstream.jobs SET state = $3, progress = 1, updated_ms = $4 "
        "WHERE id = $1 AND lease_owner = $2 AND state = $5 RETURNING tenant, asset, version",
        job_id, worker, kSucceeded, now, kRunning);
    if (job.empty()) return LeaseError(tx, job_id, worker);
    if (LockBlobs(tx, {summary.artifact_sha256}).empty()) {
      return FailedPrecondition("job " + job_id + ": artifact blob " + summary.artifact_sha256 + " does not exist");
    }
    const pqxx::result version = tx.exec_params(
        "UPDATE meshstream.versions SET state = $4, error = '', artifact_sha256 = $5, progressive_bytes = $6, "
        "encoder = $7, vertices = $8, faces = $9, levels = $10, level_vertices = $11::bigint[], reliable_bytes = $12, "
        "unreliable_bytes = $13, layout_json = $14, warnings_json = $15 "
        "WHERE tenant = $1 AND asset = $2 AND version = $3 AND state = $16",
        job[0][0].as<std::string>(), job[0][1].as<std::string>(), job[0][2].as<int64_t>(), kReady,
        summary.artifact_sha256, static_cast<int64_t>(summary.progressive_bytes), summary.encoder, summary.vertices,
        summary.faces, summary.levels, BigintArray(summary.level_vertices),
        static_cast<int64_t>(summary.reliable_bytes), static_cast<int64_t>(summary.unreliable_bytes),
        summary.layout_json, summary.warnings_json, kProcessing);
    if (version.affected_rows() != 1) {
      return FailedPrecondition("job " + job_id + ": its version is not PROCESSING any more");
    }
    tx.commit();
    return Status::Ok();
  });
}

Status PgStore::FailJob(const std::string& job_id, const std::string& worker, const std::string& message) {
  MS_RETURN_IF_ERROR(CheckName("job_id", job_id));
  MS_RETURN_IF_ERROR(CheckNonEmptyText("worker", worker));
  MS_RETURN_IF_ERROR(CheckText("message", message));
  return Run("failing job " + job_id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const int64_t now = NowMs();
    const pqxx::result job = tx.exec_params(
        "UPDATE meshstream.jobs SET state = $3, message = $4, updated_ms = $5 "
        "WHERE id = $1 AND lease_owner = $2 AND state = $6 RETURNING tenant, asset, version",
        job_id, worker, kFailed, message, now, kRunning);
    if (job.empty()) return LeaseError(tx, job_id, worker);
    const pqxx::result version = tx.exec_params(
        "UPDATE meshstream.versions SET state = $4, error = $5 WHERE tenant = $1 AND asset = $2 AND version = $3 "
        "AND state = $6",
        job[0][0].as<std::string>(), job[0][1].as<std::string>(), job[0][2].as<int64_t>(), kVersionFailed, message,
        kProcessing);
    if (version.affected_rows() != 1) {
      return FailedPrecondition("job " + job_id + ": its version is not PROCESSING any more");
    }
    tx.commit();
    return Status::Ok();
  });
}

StatusOr<int64_t> PgStore::ReleaseAllLeases() {
  return Run("releasing all leases", [&](pqxx::connection& c) -> StatusOr<int64_t> {
    pqxx::work tx(c);
    const pqxx::result r = tx.exec_params(
        "UPDATE meshstream.jobs SET state = $1, lease_owner = '', lease_expires_ms = 0, updated_ms = $2 "
        "WHERE state = $3",
        kPending, NowMs(), kRunning);
    tx.commit();
    return static_cast<int64_t>(r.affected_rows());
  });
}

StatusOr<int64_t> PgStore::CountUnfinishedJobs() {
  return Run("counting unfinished jobs", [&](pqxx::connection& c) -> StatusOr<int64_t> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const int64_t n =
        tx.exec_params1("SELECT count(*) FROM meshstream.jobs WHERE state IN ($1, $2)", kPending, kRunning)[0]
            .as<int64_t>();
    tx.commit();
    return n;
  });
}

// ---------------------------------------------------------------------------
// The artifact cache.

StatusOr<std::optional<ArtifactSummary>> PgStore::FindArtifact(const std::string& cache_key) {
  MS_RETURN_IF_ERROR(CheckNonEmptyText("cache_key", cache_key));
  return Run("reading the artifact cache", [&](pqxx::connection& c) -> StatusOr<std::optional<ArtifactSummary>> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        std::string("SELECT ") + kArtifactColumns + " FROM meshstream.artifacts WHERE cache_key = $1", cache_key);
    tx.commit();
    if (rows.empty()) return std::optional<ArtifactSummary>();
    return std::optional<ArtifactSummary>(ReadArtifact(rows[0]));
  });
}

Status PgStore::PutArtifact(const std::string& cache_key, const ArtifactSummary& summary) {
  MS_RETURN_IF_ERROR(CheckNonEmptyText("cache_key", cache_key));
  MS_RETURN_IF_ERROR(CheckSummary(summary));
  return Run("writing the artifact cache", [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    if (LockBlobs(tx, {summary.artifact_sha256}).empty()) {
      return FailedPrecondition("artifact cache: blob " + summary.artifact_sha256 + " does not exist");
    }
    tx.exec_params(
        std::string("INSERT INTO meshstream.artifacts (cache_key, ") + kArtifactColumns +
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

StatusOr<TokenRecord> PgStore::CreateToken(const std::string& tenant, bool read_only, const std::string& token_hash) {
  MS_RETURN_IF_ERROR(CheckName("tenant", tenant));
  MS_RETURN_IF_ERROR(CheckNonEmptyText("token_hash", token_hash));
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
    if (r.affected_rows() == 0) return AlreadyExists("a token with this hash exists");
    tx.commit();
    return t;
  });
}

StatusOr<TokenRecord> PgStore::FindToken(const std::string& token_hash) {
  MS_RETURN_IF_ERROR(CheckNonEmptyText("token_hash", token_hash));
  return Run("looking up a token", [&](pqxx::connection& c) -> StatusOr<TokenRecord> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows = tx.exec_params(
        "SELECT id, tenant, read_only, created_ms, revoked FROM meshstream.tokens WHERE token_hash = $1 AND NOT revoked",
        token_hash);
    tx.commit();
    if (rows.empty()) return NotFound("no live token has this hash");
    return ReadToken(rows[0]);
  });
}

StatusOr<std::vector<TokenRecord>> PgStore::ListTokens() {
  return Run("listing tokens", [&](pqxx::connection& c) -> StatusOr<std::vector<TokenRecord>> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const pqxx::result rows =
        tx.exec("SELECT id, tenant, read_only, created_ms, revoked FROM meshstream.tokens ORDER BY created_ms, id");
    tx.commit();
    std::vector<TokenRecord> tokens;
    for (const pqxx::row& row : rows) tokens.push_back(ReadToken(row));
    return tokens;
  });
}

Status PgStore::RevokeToken(const std::string& id) {
  MS_RETURN_IF_ERROR(CheckName("token id", id));
  return Run("revoking token " + id, [&](pqxx::connection& c) -> Status {
    pqxx::work tx(c);
    const pqxx::result r = tx.exec_params("UPDATE meshstream.tokens SET revoked = true WHERE id = $1", id);
    tx.commit();
    if (r.affected_rows() == 0) return NotFound("token " + id + " does not exist");
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

// Blobs of the shared store (services/store/pg_blob_sink.h, pg_store.h):
// the sink, staging, commit, reads chunk by chunk, and the orphan sweep.
#include "services/store/pg_blob_sink.h"

#include <sodium.h>

#include <algorithm>
#include <new>
#include <utility>

#include <pqxx/pqxx>

#include "services/store/pg_pool.h"
#include "services/store/pg_rows.h"
#include "services/store/pg_store.h"
#include "services/store/store_records.h"

namespace meshstream {

namespace {

// RemoveOrphanBlobs deletes at most this many blobs per transaction.
constexpr int kOrphanBatch = 500;

}  // namespace

// --- the sink ------------------------------------------------------------------

PgBlobSink::PgBlobSink(PgStore* store) : store_(store), staging_id_(RandomHex(16)) {}

PgBlobSink::~PgBlobSink() { DropStaged(); }

Status PgBlobSink::DoAppend(const uint8_t* data, size_t size) {
  if (done_) return FailedPrecondition("blob sink: append after commit, or after a failed append");
  if (size == 0) return Status::Ok();
  try {
    while (size > 0) {
      // A full buffer is written out only when more bytes come, so that the
      // last chunk (and a blob of one chunk) goes straight to blob_chunks.
      if (buffer_.size() == PgBlobSink::kChunkBytes) {
        const Status flushed = Flush();
        if (!flushed.ok()) {
          Close();  // a chunk is missing from staging: refuse to commit
          return flushed;
        }
      }
      const size_t n = std::min(size, PgBlobSink::kChunkBytes - buffer_.size());
      if (buffer_.capacity() < buffer_.size() + n) {
        // Grow geometrically, but never past one chunk.
        buffer_.reserve(std::min(PgBlobSink::kChunkBytes, std::max(buffer_.size() + n, 2 * buffer_.capacity())));
      }
      buffer_.insert(buffer_.end(), data, data + n);
      hash_.Update(data, n);
      size_ += n;
      data += n;
      size -= n;
    }
  } catch (const std::bad_alloc&) {
    Close();  // the hash and the bytes may disagree now: refuse to commit
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

void PgBlobSink::Close() {
  done_ = true;
  DropStaged();
  std::vector<uint8_t>().swap(buffer_);
}

StatusOr<std::string> PgBlobSink::DoCommit(const std::string& expected_sha256) {
  if (done_) return FailedPrecondition("blob sink: committed twice, or after a failed append");
  done_ = true;
  const std::string digest = hash_.FinishHex();
  Status stored = Status::Ok();
  if (!expected_sha256.empty() && expected_sha256 != digest) stored = DigestMismatch(digest, expected_sha256);
  if (stored.ok()) stored = store_->CommitStaged(digest, size_, staging_id_, staged_, buffer_);
  if (stored.ok()) maybe_staged_rows_ = false;  // moved into blob_chunks, or deleted
  Close();  // after a failure, drops the staged rows
  if (!stored.ok()) return stored;
  return digest;
}

// --- the store's blobs ----------------------------------------------------------

StatusOr<std::unique_ptr<BlobSink>> PgStore::DoNewBlob() {
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
  MS_RETURN_IF_ERROR(CheckFitsInt64("blob size", size));
  const int64_t size64 = static_cast<int64_t>(size);
  const int64_t chunks = staged + (tail.empty() ? 0 : 1);
  const int64_t staged_bytes = staged * static_cast<int64_t>(PgBlobSink::kChunkBytes);
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

StatusOr<std::vector<uint8_t>> PgStore::DoGetBlob(const std::string& sha256, uint64_t max_bytes) {
  return Run("reading blob " + sha256, [&](pqxx::connection& c) -> StatusOr<std::vector<uint8_t>> {
    // One snapshot for the row and all its chunks.
    pqxx::transaction<pqxx::repeatable_read, pqxx::read_only> tx(c);
    const pqxx::result head =
        tx.exec_params("SELECT size, chunks FROM meshstream.blobs WHERE sha256 = $1", sha256);
    if (head.empty()) return BlobNotFound(sha256);
    const int64_t size = head[0][0].as<int64_t>();
    const int64_t chunks = head[0][1].as<int64_t>();
    if (static_cast<uint64_t>(size) > max_bytes) {
      return BlobTooLarge(sha256, static_cast<uint64_t>(size), max_bytes);
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
      return BlobDamaged(sha256);
    }
    return bytes;
  });
}

StatusOr<bool> PgStore::DoHasBlob(const std::string& sha256) {
  return Run("looking up blob " + sha256, [&](pqxx::connection& c) -> StatusOr<bool> {
    pqxx::nontransaction tx(c);  // one statement: no BEGIN and COMMIT round trips
    const bool found = !tx.exec_params("SELECT 1 FROM meshstream.blobs WHERE sha256 = $1", sha256).empty();
    tx.commit();
    return found;
  });
}

StatusOr<uint64_t> PgStore::DoRemoveOrphanBlobs(int64_t min_age_ms) {
  const int64_t cutoff = NowMs() - min_age_ms;  // min_age_ms >= 0 (checked by Store): no overflow
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

}  // namespace meshstream

// The blob sink of the shared store (services/store/pg_store.h).
//
// PgStore::NewBlob returns a PgBlobSink. Append hashes the bytes (the one
// hash of an upload's bytes; ingest does not hash them again) and gathers
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
//
// Thread safety: a sink is used by one thread at a time and must not
// outlive its store.
#ifndef MESHSTREAM_SERVICES_STORE_PG_BLOB_SINK_H_
#define MESHSTREAM_SERVICES_STORE_PG_BLOB_SINK_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/store/blob_store.h"
#include "services/store/store.h"

namespace meshstream {

class PgStore;

class PgBlobSink final : public BlobSink {
 public:
  static constexpr size_t kChunkBytes = size_t{1} << 20;

  explicit PgBlobSink(PgStore* store);
  ~PgBlobSink() override;
  PgBlobSink(const PgBlobSink&) = delete;
  PgBlobSink& operator=(const PgBlobSink&) = delete;

  uint64_t size() const override { return size_; }

  // For tests: bytes of memory the sink holds for data (its buffer's
  // capacity), at most kChunkBytes; and the chunks written to staging.
  size_t buffered_bytes() const { return buffer_.capacity(); }
  int64_t staged_chunks() const { return staged_; }
  const std::string& staging_id() const { return staging_id_; }

 private:
  Status DoAppend(const uint8_t* data, size_t size) override;
  StatusOr<std::string> DoCommit(const std::string& expected_sha256) override;
  // Writes the full buffer as staging row `staged_` and empties it.
  Status Flush();
  // Deletes the staged rows, when there may be any.
  void DropStaged();
  // Ends the sink, after a commit or a failure: no append or commit after
  // it, the staged rows that may be left are deleted (DropStaged) and the
  // buffer is freed.
  void Close();

  PgStore* store_;
  const std::string staging_id_;  // 32 random hex digits
  Sha256Hasher hash_;
  std::vector<uint8_t> buffer_;   // the bytes after the staged chunks, at most kChunkBytes
  int64_t staged_ = 0;            // chunks written to staging: seq 0 .. staged_ - 1
  bool maybe_staged_rows_ = false;  // rows of staging_id_ may exist (cleared once they are deleted or moved)
  uint64_t size_ = 0;
  bool done_ = false;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_PG_BLOB_SINK_H_

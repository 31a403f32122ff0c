// Content-addressed blobs in a folder: the blob half of the embedded store
// (docs/design/store.md). A blob is named by the SHA-256 of its bytes, so the same
// bytes are stored once.
//
// Layout under the store's folder:
//   blobs/<first two hex digits>/<64 hex digits>   a committed blob
//   blobs/tmp/<random>.part                        a blob being written
// Durability: a blob is written to a temporary file, fsync'd, renamed to its
// digest and the folder fsync'd, so a crash leaves either the whole blob or
// no blob under its name (never a half-written one). Open() removes the
// temporary files a crash left behind.
//
// Contract: digests given by callers are untrusted (checked to be 64
// lower-case hex digits before they become a path, so no name can leave
// the folder); every Get re-hashes the bytes and returns DataLoss, never
// wrong bytes, when they do not match their name. Reads are capped by the
// caller's max_bytes before anything is allocated. Thread safety: distinct
// blobs may be written and read from several threads and processes at once;
// two writers of the same bytes both succeed (the rename is atomic and the
// bytes are equal).
#ifndef MESHSTREAM_SERVICES_STORE_BLOB_STORE_H_
#define MESHSTREAM_SERVICES_STORE_BLOB_STORE_H_

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "proto/sha256.h"

namespace meshstream {

// Digests and random ids (Sha256Hex, IsSha256Hex, ToHex, RandomHex,
// Sha256Hasher): proto/sha256.h, shared with the clients.

// The refusals about blobs, worded once for the blob folder and both store
// backends (services/store/store_records.h words the rest and includes this
// header; the blob store is the lowest layer and includes neither).
Status BlobNotFound(const std::string& sha256);  // NotFound
// A read of `max_bytes` at most of a blob of `size` bytes: ResourceExhausted.
Status BlobTooLarge(const std::string& sha256, uint64_t size, uint64_t max_bytes);
// Stored bytes that do not hash to their name: DataLoss.
Status BlobDamaged(const std::string& sha256);
// Bytes whose digest is `actual` where `expected` was announced: DataLoss.
Status DigestMismatch(const std::string& actual, const std::string& expected);

class FileBlobStore;

// Writes one blob in chunks (an upload), hashing as it goes. Nothing is
// visible under a digest until Commit succeeds; a writer destroyed without
// Commit removes its temporary file.
class BlobWriter {
 public:
  BlobWriter(BlobWriter&&) noexcept;
  BlobWriter& operator=(BlobWriter&&) noexcept;
  ~BlobWriter();

  Status Append(const uint8_t* data, size_t size);
  uint64_t size() const;
  // Makes the blob durable under its digest and returns the digest. With a
  // non-empty `expected_sha256`, a different digest is DataLoss and nothing
  // is stored.
  StatusOr<std::string> Commit(const std::string& expected_sha256 = "");

 private:
  friend class FileBlobStore;
  struct State;
  explicit BlobWriter(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

class FileBlobStore {
 public:
  // Opens (creating when needed) the blob folder under `dir` and removes
  // leftover temporary files.
  static StatusOr<FileBlobStore> Open(const std::string& dir);

  StatusOr<BlobWriter> NewWriter() const;
  // Put = NewWriter + Append + Commit.
  StatusOr<std::string> Put(const uint8_t* data, size_t size) const;
  // The bytes of blob `digest`, checked against it. NotFound when absent,
  // ResourceExhausted above `max_bytes`, DataLoss when they do not match.
  StatusOr<std::vector<uint8_t>> Get(const std::string& digest, uint64_t max_bytes) const;
  bool Contains(const std::string& digest) const;
  Status Remove(const std::string& digest) const;

  const std::string& root() const { return root_; }
  // Temporary files Open() removed (what a crash left behind).
  uint64_t removed_temporary_files() const { return removed_temporary_; }

 private:
  std::string PathOf(const std::string& digest) const;
  std::string root_;  // <dir>/blobs
  uint64_t removed_temporary_ = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STORE_BLOB_STORE_H_

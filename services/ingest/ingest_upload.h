// One Ingest call as the library sees it: metadata, then the main file's
// chunks, then for a .gltf each external file (a resource) with its chunks;
// Finish makes the bytes durable and creates the version (docs/spec/api.md,
// "Ingest").
//
// Contract: every field is untrusted. Sizes are checked against the limits
// before any byte is stored, every chunk against what was announced (more
// bytes than `size` is DataLoss at once), and at Finish every size and digest
// (DataLoss, and no version is made). Each byte is hashed once, by the
// store's blob sink or resumable upload, which checks the announced digest
// at commit; ingest does not hash. Names, digests and text are checked with
// the store's checks (services/store/store_checks.h) before any byte is
// stored. Each resource is committed as soon as its bytes are complete and
// checked, so that an upload holds at most two open files; if the upload
// fails after that, those blobs are orphans that the periodic sweep of
// RemoveOrphanBlobs removes. An upload
// with an upload_id appends the main file's bytes to a resumable upload of
// the store, durable chunk by chunk; a stream that breaks off keeps them for
// QueryUpload. Not thread-safe: one object per call.
#ifndef MESHSTREAM_SERVICES_INGEST_INGEST_UPLOAD_H_
#define MESHSTREAM_SERVICES_INGEST_INGEST_UPLOAD_H_

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/auth/authenticator.h"
#include "services/pipeline/encode_options.h"
#include "services/store/store.h"

namespace meshstream {

struct IngestLimits {
  uint64_t max_upload_bytes = uint64_t{1} << 30;  // main file and resources together (--max-upload)
  size_t max_chunk_bytes = size_t{1} << 20;       // 1 MiB
  size_t max_resources = 256;
  size_t max_labels = 64;
  size_t max_label_key_bytes = 128;
  size_t max_label_value_bytes = 1024;
  size_t max_comment_bytes = 4096;
};

struct IngestMeta {
  std::string asset;
  std::string filename;
  uint64_t size = 0;
  std::string sha256;  // hex, may be empty
  EncodeSettings options;
  std::string comment;
  std::map<std::string, std::string> labels;
  std::string upload_id;  // empty: not resumable
  uint64_t write_offset = 0;
};

struct ResourceMeta {
  std::string name;
  uint64_t size = 0;
  std::string sha256;
};

class IngestUpload {
 public:
  IngestUpload(Store* store, Principal principal, IngestLimits limits);
  ~IngestUpload();

  Status Begin(const IngestMeta& meta);
  Status BeginResource(const ResourceMeta& resource);
  Status Chunk(const uint8_t* data, size_t size);
  // Sizes and digests checked, blobs committed, the version and its job created.
  StatusOr<VersionRecord> Finish();

  bool begun() const { return begun_; }
  // The main file's digest (known after Finish).
  const std::string& source_sha256() const { return main_.sha256; }

 private:
  struct Part {
    SourceFile file;               // name, announced size, announced sha256
    std::string sha256;            // computed (main: after Finish)
    uint64_t received = 0;         // bytes of this part seen by this call
    std::unique_ptr<BlobSink> sink;  // hashes the bytes (the one hash of them)
  };
  Status CheckPartComplete(const Part& part, const std::string& what) const;
  Status FinishResource(Part& resource);

  Store* store_;
  Principal principal_;
  IngestLimits limits_;
  IngestMeta meta_;
  std::string options_json_;
  bool begun_ = false;
  bool finished_ = false;
  uint64_t total_bytes_ = 0;  // announced sizes so far
  Part main_;
  std::vector<Part> resources_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_INGEST_INGEST_UPLOAD_H_

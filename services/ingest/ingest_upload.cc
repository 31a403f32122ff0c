#include "services/ingest/ingest_upload.h"

#include <algorithm>
#include <cctype>
#include <set>
#include <utility>

#include "importers/import.h"
#include "proto/api_names.h"
#include "services/store/store_checks.h"

namespace meshstream {

namespace {

// Lower-cases an announced digest (clients may send upper-case hex) and
// checks it with the store's check: InvalidArgument naming `field` unless it
// is empty or 64 hex digits.
StatusOr<std::string> NormalizeDigest(const std::string& field, const std::string& digest) {
  std::string lower = digest;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  MS_RETURN_IF_ERROR(CheckOptionalDigest(field, lower));
  return lower;
}

std::string Bytes(uint64_t n) { return std::to_string(n) + " bytes"; }

}  // namespace

IngestUpload::IngestUpload(Store* store, Principal principal, IngestLimits limits)
    : store_(store), principal_(std::move(principal)), limits_(limits) {}

IngestUpload::~IngestUpload() = default;

Status IngestUpload::Begin(const IngestMeta& meta) {
  if (begun_) return InvalidArgument("metadata: sent twice (only the first message is metadata)");
  meta_ = meta;
  Status s = CheckName("asset", meta.asset);
  if (!s.ok()) return s;
  s = CheckMainFilename(meta.filename);
  if (!s.ok()) return s;
  if (meta.size == 0) return InvalidArgument("size: the size of the file in bytes is required");
  if (meta.size > limits_.max_upload_bytes) {
    return ResourceExhausted("size: " + Bytes(meta.size) + " is above the server's --max-upload of " +
                             Bytes(limits_.max_upload_bytes));
  }
  auto digest = NormalizeDigest("sha256", meta.sha256);
  if (!digest.ok()) return digest.status();
  meta_.sha256 = digest.value();
  auto settings = ResolveSettings(meta.options);
  if (!settings.ok()) return settings.status();
  options_json_ = CanonicalJson(settings.value());
  if (meta.comment.size() > limits_.max_comment_bytes) {
    return InvalidArgument("comment: " + Bytes(meta.comment.size()) + ", at most " + Bytes(limits_.max_comment_bytes));
  }
  // Text is checked by the store's check (no NUL, UTF-8) before any byte is
  // stored; the sizes are this server's limits.
  MS_RETURN_IF_ERROR(CheckText("comment", meta.comment));
  if (meta.labels.size() > limits_.max_labels) {
    return InvalidArgument("labels: " + std::to_string(meta.labels.size()) + " labels, at most " +
                           std::to_string(limits_.max_labels));
  }
  for (const auto& [key, value] : meta.labels) {
    if (key.empty() || key.size() > limits_.max_label_key_bytes) {
      return InvalidArgument("labels: a key must be 1 to " + std::to_string(limits_.max_label_key_bytes) + " bytes");
    }
    MS_RETURN_IF_ERROR(CheckText("labels: a key", key));
    if (value.size() > limits_.max_label_value_bytes) {
      return InvalidArgument("labels[" + key + "]: at most " + std::to_string(limits_.max_label_value_bytes) +
                             " bytes");
    }
    MS_RETURN_IF_ERROR(CheckText("labels[" + key + "]", value));
  }
  if (!meta.upload_id.empty()) {
    s = CheckName("upload_id", meta.upload_id);
    if (!s.ok()) return s;
    if (meta.write_offset > meta.size) {
      return InvalidArgument("write_offset: " + std::to_string(meta.write_offset) + " is beyond size " +
                             std::to_string(meta.size));
    }
    auto committed = store_->UploadSize(principal_.tenant, meta.upload_id);
    if (!committed.ok() && committed.status().code() != StatusCode::kNotFound) return committed.status();
    const uint64_t have = committed.ok() ? committed.value() : 0;
    if (!committed.ok() && meta.write_offset > 0) {
      return NotFound("upload_id " + meta.upload_id + ": no such upload (never started, finished or expired)");
    }
    if (meta.write_offset != have) {
      return FailedPrecondition("write_offset: " + std::to_string(meta.write_offset) + ", but upload " +
                                meta.upload_id + " has committed_size " + std::to_string(have) +
                                " (QueryUpload, then resume there)");
    }
  } else {
    if (meta.write_offset != 0) return InvalidArgument("write_offset: only meaningful with an upload_id");
    auto sink = store_->NewBlob();
    if (!sink.ok()) return sink.status();
    main_.sink = std::move(sink).value();
  }
  main_.file = SourceFile{meta.filename, meta_.sha256, meta.size};
  total_bytes_ = meta.size;
  begun_ = true;
  return Status::Ok();
}

Status IngestUpload::CheckPartComplete(const Part& part, const std::string& what) const {
  const uint64_t offset = (&part == &main_) ? meta_.write_offset : 0;
  const uint64_t have = offset + part.received;
  if (have != part.file.size) {
    return DataLoss(what + ": size says " + Bytes(part.file.size) + ", received " + Bytes(have) + "; nothing stored");
  }
  return Status::Ok();
}

// A resource whose bytes are complete is checked and committed at once, so
// that one upload holds at most two open files (the main file and the
// current resource), not one per resource.
Status IngestUpload::FinishResource(Part& r) {
  if (!r.sink) return Status::Ok();  // committed already
  const std::string what = "resource '" + r.file.name + "'";
  MS_RETURN_IF_ERROR(CheckPartComplete(r, what));
  // The sink hashed the bytes as they came and checks the announced digest
  // (DataLoss, nothing stored): they are hashed once, there.
  auto digest = r.sink->Commit(r.file.sha256);
  if (!digest.ok()) return digest.status().WithContext(what);
  r.sha256 = digest.value();
  r.sink.reset();
  return Status::Ok();
}

Status IngestUpload::BeginResource(const ResourceMeta& resource) {
  if (!begun_) return InvalidArgument("the first message must be metadata");
  if (FileExtension(meta_.filename) != ".gltf") {
    return InvalidArgument("resource: only a .gltf has external files (filename is " + meta_.filename + ")");
  }
  Status s = CheckResourceName(resource.name);
  if (!s.ok()) return s;
  if (resources_.size() >= limits_.max_resources) {
    return InvalidArgument("resource: more than " + std::to_string(limits_.max_resources) + " external files");
  }
  auto is_folder_of = [](const std::string& folder, const std::string& file) {
    return file.size() > folder.size() && file.compare(0, folder.size(), folder) == 0 && file[folder.size()] == '/';
  };
  if (resource.name == meta_.filename || is_folder_of(resource.name, meta_.filename)) {
    return InvalidArgument("resource '" + resource.name + "': collides with the main file " + meta_.filename);
  }
  for (const Part& r : resources_) {
    if (r.file.name == resource.name) return InvalidArgument("resource '" + resource.name + "': sent twice");
    if (is_folder_of(r.file.name, resource.name) || is_folder_of(resource.name, r.file.name)) {
      return InvalidArgument("resource '" + resource.name + "': collides with resource '" + r.file.name +
                             "' (one would be the other's folder)");
    }
  }
  if (resources_.empty()) {
    s = CheckPartComplete(main_, meta_.filename);
  } else {
    s = FinishResource(resources_.back());
  }
  if (!s.ok()) return s;
  if (resource.size > limits_.max_upload_bytes - total_bytes_) {
    return ResourceExhausted("resource '" + resource.name + "': the upload would exceed the server's --max-upload of " +
                             Bytes(limits_.max_upload_bytes));
  }
  auto digest = NormalizeDigest("resource '" + resource.name + "': sha256", resource.sha256);
  if (!digest.ok()) return digest.status();
  Part part;
  part.file = SourceFile{resource.name, digest.value(), resource.size};
  auto sink = store_->NewBlob();
  if (!sink.ok()) return sink.status();
  part.sink = std::move(sink).value();
  total_bytes_ += resource.size;
  resources_.push_back(std::move(part));
  return Status::Ok();
}

Status IngestUpload::Chunk(const uint8_t* data, size_t size) {
  if (!begun_) return InvalidArgument("the first message must be metadata");
  if (size > limits_.max_chunk_bytes) {
    return InvalidArgument("chunk: " + Bytes(size) + ", at most " + Bytes(limits_.max_chunk_bytes));
  }
  const bool is_main = resources_.empty();
  Part& part = is_main ? main_ : resources_.back();
  const uint64_t offset = (is_main ? meta_.write_offset : 0) + part.received;
  if (size > part.file.size - offset) {
    const std::string what = is_main ? meta_.filename : "resource '" + part.file.name + "'";
    return DataLoss(what + ": more bytes than its size of " + Bytes(part.file.size) + "; nothing stored");
  }
  if (part.sink) {
    Status s = part.sink->Append(data, size);
    if (!s.ok()) return s;
  } else {
    Status s = store_->AppendUpload(principal_.tenant, meta_.upload_id, offset, data, size);
    if (!s.ok()) return s;
  }
  part.received += size;
  return Status::Ok();
}

StatusOr<VersionRecord> IngestUpload::Finish() {
  if (!begun_) return InvalidArgument("the first message must be metadata");
  if (finished_) return Internal("Finish called twice");
  finished_ = true;
  // Every size is checked before the main file is committed; each digest as
  // its part is committed. The resources before the last were checked and
  // committed when the next one began (BeginResource), and Chunk only writes
  // to the last: FinishResource checks and commits that one.
  MS_RETURN_IF_ERROR(CheckPartComplete(main_, meta_.filename));
  if (!resources_.empty()) MS_RETURN_IF_ERROR(FinishResource(resources_.back()));
  // The main file: its sink, or the store's resumable upload, hashes the
  // bytes once and checks the announced digest (DataLoss, nothing stored; a
  // resumable upload is discarded).
  auto digest = main_.sink ? main_.sink->Commit(main_.file.sha256)
                           : store_->CommitUpload(principal_.tenant, meta_.upload_id, main_.file.sha256);
  if (!digest.ok()) return digest.status().WithContext(meta_.filename);
  main_.sha256 = digest.value();
  NewVersion version;
  version.tenant = principal_.tenant;
  version.asset = meta_.asset;
  version.source = SourceFile{meta_.filename, main_.sha256, main_.file.size};
  for (Part& r : resources_) version.resources.push_back(SourceFile{r.file.name, r.sha256, r.file.size});
  version.options_json = options_json_;
  version.comment = meta_.comment;
  version.labels = meta_.labels;
  return store_->CreateVersion(version);
}

}  // namespace meshstream

#include "sdk/asset_client.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <thread>
#include <utility>

#include "importers/gltf_files.h"
#include "importers/import.h"
#include "proto/rpc_status.h"
#include "proto/sha256.h"

namespace meshstream::sdk {

namespace {

constexpr int32_t kPageSize = 100;

// A file on disk read in chunks; closes itself.
class FileReader {
 public:
  ~FileReader() {
    if (fd_ >= 0) close(fd_);
  }
  Status Open(const std::string& path, uint64_t offset) {
    path_ = path;
    fd_ = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) return NotFound(path + ": cannot open");
    struct stat st {};
    if (fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) return InvalidInput(path + ": not a regular file");
    if (offset > 0 && lseek(fd_, static_cast<off_t>(offset), SEEK_SET) < 0) return IoError(path + ": cannot seek");
    return Status::Ok();
  }
  // Up to buffer.size() bytes; 0 at the end.
  StatusOr<size_t> Read(std::vector<uint8_t>& buffer) {
    for (;;) {
      const ssize_t n = read(fd_, buffer.data(), buffer.size());
      if (n >= 0) return static_cast<size_t>(n);
      if (errno != EINTR) return IoError(path_ + ": read failed");
    }
  }

 private:
  int fd_ = -1;
  std::string path_;
};

double Mib(uint64_t bytes) { return static_cast<double>(bytes) / 1048576.0; }

// Sends `file` from `offset` as chunks on `writer`. `streamed` is false when
// the stream broke (the call's status says why); a local failure is the Status.
Status SendFile(grpc::ClientWriter<v1::IngestRequest>& writer, const UploadFile& file, uint64_t offset,
                const IngestOptions& options, IngestProgress& progress, bool& streamed) {
  v1::IngestRequest request;
  const auto send = [&](const uint8_t* data, size_t n) {
    request.set_chunk(data, n);
    if (!writer.Write(request)) return false;
    progress.sent += n;
    if (options.on_progress) options.on_progress(progress);
    return true;
  };
  streamed = true;
  if (file.path.empty()) {
    for (uint64_t at = offset; at < file.bytes.size() && streamed; at += options.chunk_bytes) {
      streamed = send(file.bytes.data() + at, std::min<uint64_t>(options.chunk_bytes, file.bytes.size() - at));
    }
    return Status::Ok();
  }
  FileReader reader;
  MS_RETURN_IF_ERROR(reader.Open(file.path, offset));
  std::vector<uint8_t> buffer(options.chunk_bytes);
  for (;;) {
    MS_ASSIGN_OR_RETURN(const size_t n, reader.Read(buffer));
    if (n == 0) return Status::Ok();
    if (!send(buffer.data(), n)) {
      streamed = false;
      return Status::Ok();
    }
  }
}

// Every page of a list call, in the server's order: `request` goes out with
// kPageSize and each page's token (one `call` on `stub` per page, with the
// request timeout), and the `items` of each response are moved to the end of
// `out`. The first failed call's status (`out` then holds the pages before it).
template <typename Request, typename Response, typename Item>
grpc::Status EveryPage(const Client& client, v1::AssetService::Stub& stub,
                       grpc::Status (v1::AssetService::Stub::*call)(grpc::ClientContext*, const Request&, Response*),
                       Request request, google::protobuf::RepeatedPtrField<Item>* (Response::*items)(),
                       std::vector<Item>& out) {
  request.set_page_size(kPageSize);
  do {
    grpc::ClientContext context;
    client.Prepare(context, client.options().request_timeout_s);
    Response response;
    const grpc::Status rpc = (stub.*call)(&context, request, &response);
    if (!rpc.ok()) return rpc;
    for (Item& item : *(response.*items)()) out.push_back(std::move(item));
    request.set_page_token(response.next_page_token());
  } while (!request.page_token().empty());
  return grpc::Status::OK;
}

}  // namespace

StatusOr<UploadFile> UploadFile::FromPath(const std::string& path, const std::string& name) {
  FileReader reader;
  MS_RETURN_IF_ERROR(reader.Open(path, 0));
  Sha256Hasher hash;
  std::vector<uint8_t> buffer(size_t{1} << 20);
  UploadFile file;
  file.name = name;
  file.path = path;
  for (;;) {
    MS_ASSIGN_OR_RETURN(const size_t n, reader.Read(buffer));
    if (n == 0) break;
    hash.Update(buffer.data(), n);
    file.size += n;
  }
  file.sha256 = hash.FinishHex();
  return file;
}

UploadFile UploadFile::FromBytes(std::string name, std::vector<uint8_t> bytes) {
  UploadFile file;
  file.name = std::move(name);
  file.size = bytes.size();
  file.sha256 = Sha256Hex(bytes.data(), bytes.size());
  file.bytes = std::move(bytes);
  return file;
}

StatusOr<Upload> UploadFromPath(const std::string& asset, const std::string& path) {
  Upload upload;
  upload.asset = asset;
  MS_ASSIGN_OR_RETURN(upload.main, UploadFile::FromPath(path, FileBaseName(path)));
  if (upload.main.size == 0) return InvalidInput(path + ": the file is empty");
  if (FileExtension(path) != ".gltf") return upload;
  MS_ASSIGN_OR_RETURN(const std::vector<std::string> names, GltfExternalFiles(path));
  for (const std::string& name : names) {
    auto file = UploadFile::FromPath(FileFolder(path) + name, name);
    if (!file.ok()) return file.status().WithContext(path + ": " + name);
    upload.resources.push_back(std::move(file).value());
  }
  return upload;
}

std::string DefaultUploadId(const std::string& asset, const std::string& main_sha256) {
  const std::string key = asset + "\n" + main_sha256;
  return "cli-" + Sha256Hex(reinterpret_cast<const uint8_t*>(key.data()), key.size()).substr(0, 48);
}

v1::IngestRequest IngestMetadataMessage(const std::string& asset, const UploadFile& main) {
  v1::IngestRequest request;
  v1::IngestMetadata& m = *request.mutable_metadata();
  m.set_asset(asset);
  m.set_filename(main.name);
  m.set_size(main.size);
  m.set_sha256(main.sha256);
  return request;
}

v1::IngestRequest IngestResourceMessage(const UploadFile& resource) {
  v1::IngestRequest request;
  request.mutable_resource()->set_name(resource.name);
  request.mutable_resource()->set_size(resource.size);
  request.mutable_resource()->set_sha256(resource.sha256);
  return request;
}

StatusOr<std::unique_ptr<AssetClient>> AssetClient::Create(const ClientOptions& options) {
  MS_ASSIGN_OR_RETURN(std::unique_ptr<Client> client, Client::Create(options));
  return std::make_unique<AssetClient>(std::shared_ptr<const Client>(std::move(client)));
}

AssetClient::AssetClient(std::shared_ptr<const Client> client)
    : client_(std::move(client)), stub_(v1::AssetService::NewStub(client_->channel())) {}

Status AssetClient::CallStatus(const grpc::Status& status) const {
  Status s = FromGrpcStatus(status);
  if (s.code() == StatusCode::kUnavailable || s.code() == StatusCode::kDeadlineExceeded) {
    return s.WithContext(client_->options().server);
  }
  return s;
}

StatusOr<IngestResult> AssetClient::Ingest(const Upload& upload, const IngestOptions& options) const {
  if (upload.asset.empty()) return InvalidArgument("asset: must not be empty");
  if (upload.main.name.empty()) return InvalidArgument("main file: no name");
  if (options.chunk_bytes == 0) return InvalidArgument("chunk_bytes: must not be 0");
  uint64_t total = 0;
  std::vector<const UploadFile*> files = {&upload.main};
  for (const UploadFile& r : upload.resources) files.push_back(&r);
  for (const UploadFile* f : files) {
    if (f->sha256.empty()) return InvalidArgument(f->name + ": no sha256 (use UploadFile::FromPath or FromBytes)");
    total += f->size;
  }
  const bool resumable = options.resume == IngestOptions::Resume::kAlways ||
                         (options.resume == IngestOptions::Resume::kAuto && upload.main.size >= IngestOptions::kResumableFrom);
  const std::string upload_id =
      !resumable ? "" : !options.upload_id.empty() ? options.upload_id : DefaultUploadId(upload.asset, upload.main.sha256);
  const int attempts = resumable ? std::max(1, options.attempts) : 1;
  const double timeout_s = client_->options().request_timeout_s;
  IngestResult result;
  for (int attempt = 1;; ++attempt) {
    result.attempts = attempt;
    const auto retry = [&](const Status& cause) {
      if (options.on_retry) options.on_retry(cause, attempt + 1);
      std::this_thread::sleep_for(options.retry_wait * attempt);
    };
    uint64_t offset = 0;
    if (resumable) {
      auto held = QueryUpload(upload_id);
      if (held.ok()) {
        offset = held.value();
      } else if (held.status().code() != StatusCode::kNotFound) {
        if (held.status().code() == StatusCode::kUnavailable && attempt < attempts) {
          retry(held.status());
          continue;
        }
        return held.status();
      }
      if (offset > upload.main.size) offset = 0;  // not our bytes: the server will say so
      if (offset > 0 && result.resumed_from == 0) result.resumed_from = offset;
    }
    grpc::ClientContext context;
    client_->Prepare(context, timeout_s <= 0 ? 0 : std::max(60.0, timeout_s * (1.0 + Mib(total))));
    auto writer = stub_->Ingest(&context, &result.response);
    v1::IngestRequest request = IngestMetadataMessage(upload.asset, upload.main);
    v1::IngestMetadata& m = *request.mutable_metadata();
    *m.mutable_options() = upload.options;
    m.set_comment(upload.comment);
    for (const auto& [key, value] : upload.labels) (*m.mutable_labels())[key] = value;
    m.set_upload_id(upload_id);
    m.set_write_offset(offset);
    IngestProgress progress;
    progress.total = total;
    progress.sent = offset;
    progress.attempt = attempt;
    progress.file = upload.main.name;
    bool streamed = writer->Write(request);
    Status local = streamed ? SendFile(*writer, upload.main, offset, options, progress, streamed) : Status::Ok();
    for (size_t i = 0; local.ok() && streamed && i < upload.resources.size(); ++i) {
      const UploadFile& r = upload.resources[i];
      progress.file = r.name;
      streamed = writer->Write(IngestResourceMessage(r));
      if (streamed) local = SendFile(*writer, r, 0, options, progress, streamed);
    }
    if (!local.ok()) {
      context.TryCancel();
      (void)writer->Finish();
      return local;
    }
    const bool finished_writing = streamed && writer->WritesDone();
    const grpc::Status rpc = writer->Finish();
    if (rpc.ok()) return result;
    // A stream that broke while the bytes were still travelling is resumed;
    // once every byte was sent the server may have made the version, so a
    // retry could make a second one: report instead.
    const Status failed = CallStatus(rpc);
    if (resumable && !finished_writing && failed.code() == StatusCode::kUnavailable && attempt < attempts) {
      retry(failed);
      continue;
    }
    return failed;
  }
}

StatusOr<uint64_t> AssetClient::QueryUpload(const std::string& upload_id) const {
  grpc::ClientContext context;
  client_->Prepare(context, client_->options().request_timeout_s);
  v1::QueryUploadRequest query;
  query.set_upload_id(upload_id);
  v1::UploadStatus status;
  const grpc::Status rpc = stub_->QueryUpload(&context, query, &status);
  if (!rpc.ok()) return CallStatus(rpc);
  return status.committed_size();
}

StatusOr<v1::Job> AssetClient::GetJob(const std::string& job_id) const {
  grpc::ClientContext context;
  client_->Prepare(context, client_->options().request_timeout_s);
  v1::GetJobRequest request;
  request.set_job_id(job_id);
  v1::Job job;
  const grpc::Status rpc = stub_->GetJob(&context, request, &job);
  if (!rpc.ok()) return CallStatus(rpc);
  return job;
}

StatusOr<v1::Job> AssetClient::Watch(const std::string& job_id, const WatchOptions& options) const {
  const auto finished = [](const v1::Job& job) {
    return job.state() == v1::JOB_STATE_SUCCEEDED || job.state() == v1::JOB_STATE_FAILED;
  };
  std::optional<v1::Job> last;
  for (int attempt = 0;; ++attempt) {
    grpc::ClientContext context;
    client_->Prepare(context, 0);
    v1::GetJobRequest request;
    request.set_job_id(job_id);
    auto reader = stub_->WatchJob(&context, request);
    v1::Job job;
    while (reader->Read(&job)) {
      last = job;
      if (options.on_update) options.on_update(job);
      if (finished(job)) break;
    }
    if (last && finished(*last)) {
      context.TryCancel();
      (void)reader->Finish();
      return *last;
    }
    const grpc::Status rpc = reader->Finish();
    // A draining or restarting server: watch again (the job continues).
    const StatusCode code = FromGrpcStatus(rpc).code();
    if ((code == StatusCode::kOk || code == StatusCode::kUnavailable) && attempt < options.reconnects) {
      std::this_thread::sleep_for(options.reconnect_wait);
      continue;
    }
    if (rpc.ok()) return Unavailable(client_->options().server + ": the watch of job " + job_id + " ended before the job did");
    return CallStatus(rpc);
  }
}

StatusOr<std::vector<v1::Asset>> AssetClient::ListAssets() const {
  std::vector<v1::Asset> assets;
  const grpc::Status rpc = EveryPage(*client_, *stub_, &v1::AssetService::Stub::ListAssets, v1::ListAssetsRequest(),
                                     &v1::ListAssetsResponse::mutable_assets, assets);
  if (!rpc.ok()) return CallStatus(rpc);
  return assets;
}

StatusOr<std::vector<v1::Version>> AssetClient::ListVersions(const std::string& asset) const {
  v1::ListVersionsRequest request;
  request.set_asset(asset);
  std::vector<v1::Version> versions;
  const grpc::Status rpc = EveryPage(*client_, *stub_, &v1::AssetService::Stub::ListVersions, std::move(request),
                                     &v1::ListVersionsResponse::mutable_versions, versions);
  if (!rpc.ok()) return CallStatus(rpc);
  return versions;
}

StatusOr<v1::Version> AssetClient::GetVersion(const std::string& asset, int64_t version) const {
  grpc::ClientContext context;
  client_->Prepare(context, client_->options().request_timeout_s);
  v1::GetVersionRequest request;
  request.set_asset(asset);
  request.set_version(version);
  v1::Version out;
  const grpc::Status rpc = stub_->GetVersion(&context, request, &out);
  if (!rpc.ok()) return CallStatus(rpc);
  return out;
}

StatusOr<Exported> AssetClient::Export(const ExportRequest& request,
                                       const std::function<void(uint64_t, uint64_t)>& on_progress) const {
  grpc::ClientContext context;
  client_->Prepare(context, 0);
  v1::ExportRequest message;
  message.set_asset(request.asset);
  message.set_version(request.version);
  message.set_format(request.format);
  if (request.lod) message.set_lod(*request.lod);
  auto reader = stub_->Export(&context, message);
  Exported out;
  out.version = request.version;
  uint64_t total = 0;
  v1::ExportChunk chunk;
  while (reader->Read(&chunk)) {
    if (out.chunks == 0) {
      out.version = chunk.version();
      total = chunk.total_size();
      // The announced size is the server's word: reserved only up to 64 MiB.
      out.bytes.reserve(std::min<uint64_t>(total, uint64_t{64} << 20));
    }
    if (chunk.data().size() > request.max_bytes - out.bytes.size()) {
      context.TryCancel();
      (void)reader->Finish();
      return ResourceExhausted("export of " + request.asset + ": more than " + std::to_string(request.max_bytes) +
                               " bytes (ExportRequest::max_bytes)");
    }
    out.bytes.insert(out.bytes.end(), chunk.data().begin(), chunk.data().end());
    if (!chunk.sha256().empty()) out.sha256 = chunk.sha256();
    out.largest_chunk = std::max(out.largest_chunk, chunk.data().size());
    ++out.chunks;
    if (on_progress) on_progress(out.bytes.size(), total);
  }
  const grpc::Status rpc = reader->Finish();
  if (!rpc.ok()) return CallStatus(rpc);
  const std::string actual = Sha256Hex(out.bytes.data(), out.bytes.size());
  if (out.sha256 != actual) {
    return DataLoss("the bytes received have SHA-256 " + actual + ", the server announced '" + out.sha256 +
                    "'; refused");
  }
  return out;
}

}  // namespace meshstream::sdk

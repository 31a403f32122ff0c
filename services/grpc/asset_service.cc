#include "services/grpc/asset_service.h"

#include <chrono>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include "proto/rpc_status.h"
#include "services/export/export_version.h"
#include "services/grpc/call_auth.h"
#include "services/grpc/proto_convert.h"
#include "services/store/page_token.h"

namespace meshstream {

namespace {

bool SameJob(const v1::Job& a, const v1::Job& b) {
  return a.state() == b.state() && a.progress() == b.progress() && a.message() == b.message() &&
         a.attempts() == b.attempts();
}

bool Finished(const JobRecord& job) { return job.state == JobState::kSucceeded || job.state == JobState::kFailed; }

}  // namespace

AssetServiceImpl::AssetServiceImpl(Store* store, const Authenticator* auth, AssetServiceOptions options,
                                   std::function<void()> on_ingested, const std::atomic<bool>* draining)
    : store_(store),
      auth_(auth),
      options_(options),
      on_ingested_(std::move(on_ingested)),
      draining_(draining),
      watchers_(options.max_watchers),
      exports_(options.max_exports) {}

StatusOr<Principal> AssetServiceImpl::Authenticate(const grpc::ServerContext& context) const {
  return AuthenticateCall(*auth_, context);
}

grpc::Status AssetServiceImpl::Ingest(grpc::ServerContext* context, grpc::ServerReader<v1::IngestRequest>* reader,
                                      v1::IngestResponse* response) {
  auto principal = Authenticate(*context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  Status s = Authenticator::CheckCanWrite(principal.value());
  if (!s.ok()) return ToGrpcStatus(s);
  IngestUpload upload(store_, principal.value(), options_.ingest);
  v1::IngestRequest request;
  while (reader->Read(&request)) {
    switch (request.kind_case()) {
      case v1::IngestRequest::kMetadata: s = upload.Begin(FromProto(request.metadata())); break;
      case v1::IngestRequest::kResource: s = upload.BeginResource(FromProto(request.resource())); break;
      case v1::IngestRequest::kChunk:
        s = upload.Chunk(reinterpret_cast<const uint8_t*>(request.chunk().data()), request.chunk().size());
        break;
      default: s = InvalidArgument("a message with none of metadata, resource or chunk set"); break;
    }
    if (s.ok() && !upload.begun()) s = InvalidArgument("the first message must be metadata");
    if (!s.ok()) return ToGrpcStatus(s);
  }
  if (context->IsCancelled()) return ToGrpcStatus(Cancelled("the client went away"));
  auto version = upload.Finish();
  if (!version.ok()) return ToGrpcStatus(version.status());
  if (on_ingested_) on_ingested_();
  response->set_asset(version->asset);
  response->set_version(version->version);
  response->set_job_id(version->job_id);
  response->set_sha256(version->source.sha256);
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::QueryUpload(grpc::ServerContext* context, const v1::QueryUploadRequest* request,
                                           v1::UploadStatus* response) {
  auto principal = Authenticate(*context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  Status s = CheckName("upload_id", request->upload_id());
  if (!s.ok()) return ToGrpcStatus(s);
  auto size = store_->UploadSize(principal->tenant, request->upload_id());
  if (!size.ok()) return ToGrpcStatus(size.status());
  response->set_upload_id(request->upload_id());
  response->set_committed_size(size.value());
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request,
                                      v1::Job* response) {
  auto principal = Authenticate(*context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  auto job = store_->GetJob(principal->tenant, request->job_id());
  if (!job.ok()) return ToGrpcStatus(job.status());
  *response = ToProto(job.value());
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::WatchJob(grpc::ServerContext* context, const v1::GetJobRequest* request,
                                        grpc::ServerWriter<v1::Job>* writer) {
  auto principal = Authenticate(*context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  CallLimit::Slot slot = watchers_.Acquire(std::chrono::milliseconds(0));
  if (!slot) {
    return ToGrpcStatus(ResourceExhausted("WatchJob: " + std::to_string(watchers_.limit()) +
                                          " watches are running on this server; use GetJob, or retry later"));
  }
  std::optional<v1::Job> last;
  int poll_ms = options_.watch_poll_ms;
  for (;;) {
    auto job = store_->GetJob(principal->tenant, request->job_id());
    if (!job.ok()) return ToGrpcStatus(job.status());
    v1::Job message = ToProto(job.value());
    if (!last || !SameJob(*last, message)) {
      if (!writer->Write(message)) return ToGrpcStatus(Cancelled("the client went away"));
      last = message;
      poll_ms = options_.watch_poll_ms;
    } else {
      poll_ms = std::min(options_.watch_poll_max_ms, poll_ms * 3 / 2);
    }
    if (Finished(job.value())) return grpc::Status::OK;
    if (context->IsCancelled()) return ToGrpcStatus(Cancelled("the client went away"));
    if (draining_ != nullptr && draining_->load()) {
      return ToGrpcStatus(Unavailable("the server is shutting down; watch the job again (it continues)"));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
  }
}

grpc::Status AssetServiceImpl::ListAssets(grpc::ServerContext* context, const v1::ListAssetsRequest* request,
                                          v1::ListAssetsResponse* response) {
  auto principal = Authenticate(*context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  auto page = store_->ListAssets(principal->tenant, request->page_size(), request->page_token());
  if (!page.ok()) return ToGrpcStatus(page.status());
  for (const AssetRecord& a : page->items) *response->add_assets() = ToProto(a);
  response->set_next_page_token(page->next_page_token);
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::ListVersions(grpc::ServerContext* context, const v1::ListVersionsRequest* request,
                                            v1::ListVersionsResponse* response) {
  auto principal = Authenticate(*context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  Status s = CheckName("asset", request->asset());
  if (!s.ok()) return ToGrpcStatus(s);
  auto page = store_->ListVersions(principal->tenant, request->asset(), request->page_size(), request->page_token());
  if (!page.ok()) return ToGrpcStatus(page.status());
  // A page stops early at kMaxPageBytes: a version may carry ~230 KB of
  // labels, comment and resource names, and a message is at most 2 MiB.
  response->set_next_page_token(page->next_page_token);
  size_t bytes = 0;
  for (size_t i = 0; i < page->items.size(); ++i) {
    v1::Version v = ToProto(page->items[i]);
    const size_t size = v.ByteSizeLong();
    if (i > 0 && bytes + size > kMaxPageBytes) {
      response->set_next_page_token(EncodeVersionsPageToken(page->items[i - 1].version));
      break;
    }
    bytes += size;
    *response->add_versions() = std::move(v);
  }
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::GetVersion(grpc::ServerContext* context, const v1::GetVersionRequest* request,
                                          v1::Version* response) {
  auto principal = Authenticate(*context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  Status s = CheckName("asset", request->asset());
  if (!s.ok()) return ToGrpcStatus(s);
  if (request->version() < 0) return ToGrpcStatus(InvalidArgument("version: must not be negative (0 is the latest)"));
  auto version = store_->GetVersion(principal->tenant, request->asset(), request->version());
  if (!version.ok()) return ToGrpcStatus(version.status());
  *response = ToProto(version.value());
  return grpc::Status::OK;
}

grpc::Status AssetServiceImpl::Export(grpc::ServerContext* context, const v1::ExportRequest* request,
                                      grpc::ServerWriter<v1::ExportChunk>* writer) {
  auto principal = Authenticate(*context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  Status s = CheckName("asset", request->asset());
  if (!s.ok()) return ToGrpcStatus(s);
  auto format = FromProto(request->format());
  if (!format.ok()) return ToGrpcStatus(format.status());
  std::optional<int> lod;
  if (request->has_lod()) lod = request->lod();
  // Exports that decode hold a scene in memory: a few at a time. The stored
  // file and the export cache's hits take no slot.
  CallLimit::Slot slot;
  const auto take_slot = [&]() -> Status {
    slot = exports_.Acquire(std::chrono::milliseconds(options_.export_wait_ms));
    if (!slot) return ResourceExhausted("Export: the server is busy with other exports; retry later");
    if (context->IsCancelled()) return Cancelled("the client went away");
    return Status::Ok();
  };
  if (context->IsCancelled()) return ToGrpcStatus(Cancelled("the client went away"));
  auto exported = ExportVersion(*store_, principal->tenant, request->asset(), request->version(), format.value(), lod,
                                options_.max_export_bytes, take_slot);
  if (!exported.ok()) return ToGrpcStatus(exported.status());
  slot = CallLimit::Slot();
  const std::vector<uint8_t>& bytes = exported->bytes;
  size_t offset = 0;
  do {
    const size_t n = std::min(options_.export_chunk_bytes, bytes.size() - offset);
    v1::ExportChunk chunk;
    if (offset == 0) {
      chunk.set_version(exported->version.version);
      chunk.set_total_size(bytes.size());
    }
    chunk.set_data(bytes.data() + offset, n);
    offset += n;
    if (offset == bytes.size()) chunk.set_sha256(exported->sha256);
    if (!writer->Write(chunk)) return ToGrpcStatus(Cancelled("the client went away"));
  } while (offset < bytes.size());
  return grpc::Status::OK;
}

}  // namespace meshstream

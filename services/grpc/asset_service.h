// meshstream.v1.AssetService: a thin translation between protobuf and the
// library (ingest/, export/, store/). Each method authenticates, converts
// the request, calls the library and returns ToGrpcStatus of its Status
// (docs/spec/api.md).
//
// Thread safety: gRPC calls the methods from its threads at once; the class
// holds only pointers to thread-safe parts.
#ifndef MESHSTREAM_SERVICES_GRPC_ASSET_SERVICE_H_
#define MESHSTREAM_SERVICES_GRPC_ASSET_SERVICE_H_

#include <atomic>
#include <cstdint>
#include <functional>

#include "meshstream/v1/asset_service.grpc.pb.h"
#include "parallel/call_limit.h"
#include "services/auth/authenticator.h"
#include "services/ingest/ingest_upload.h"
#include "services/store/store.h"

namespace meshstream {

// The most bytes of versions one ListVersions answer holds (it may return
// fewer than page_size, with a next_page_token).
constexpr size_t kMaxPageBytes = size_t{1} << 20;

struct AssetServiceOptions {
  IngestLimits ingest;
  uint64_t max_export_bytes = uint64_t{4} << 30;  // the largest artifact or export read into memory
  size_t export_chunk_bytes = size_t{1} << 20;    // 1 MiB
  int watch_poll_ms = 100;                        // WatchJob looks at the store this often after a change,
  int watch_poll_max_ms = 1000;                   // backing off to this while nothing changes
  int max_watchers = 128;                         // concurrent WatchJob streams
  int max_exports = 2;                            // concurrent exports that decode (others wait)
  int export_wait_ms = 30000;                     // how long an export waits for its turn
};

class AssetServiceImpl final : public v1::AssetService::Service {
 public:
  // `on_ingested` runs after each version is created (wakes the worker pool).
  // `draining` turns true when the server drains: WatchJob streams end with
  // UNAVAILABLE so that clients watch again on another server.
  AssetServiceImpl(Store* store, const Authenticator* auth, AssetServiceOptions options,
                   std::function<void()> on_ingested, const std::atomic<bool>* draining);

  grpc::Status Ingest(grpc::ServerContext* context, grpc::ServerReader<v1::IngestRequest>* reader,
                      v1::IngestResponse* response) override;
  grpc::Status QueryUpload(grpc::ServerContext* context, const v1::QueryUploadRequest* request,
                           v1::UploadStatus* response) override;
  grpc::Status GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request, v1::Job* response) override;
  grpc::Status WatchJob(grpc::ServerContext* context, const v1::GetJobRequest* request,
                        grpc::ServerWriter<v1::Job>* writer) override;
  grpc::Status ListAssets(grpc::ServerContext* context, const v1::ListAssetsRequest* request,
                          v1::ListAssetsResponse* response) override;
  grpc::Status ListVersions(grpc::ServerContext* context, const v1::ListVersionsRequest* request,
                            v1::ListVersionsResponse* response) override;
  grpc::Status GetVersion(grpc::ServerContext* context, const v1::GetVersionRequest* request,
                          v1::Version* response) override;
  grpc::Status Export(grpc::ServerContext* context, const v1::ExportRequest* request,
                      grpc::ServerWriter<v1::ExportChunk>* writer) override;

  // The limit on concurrent exports that decode, for the server's other
  // transports to share (services/http_routes/asset_route.h): one bound per server.
  CallLimit* export_limit() { return &exports_; }
  const AssetServiceOptions& options() const { return options_; }

 private:
  StatusOr<Principal> Authenticate(const grpc::ServerContext& context) const;

  Store* store_;
  const Authenticator* auth_;
  AssetServiceOptions options_;
  std::function<void()> on_ingested_;
  const std::atomic<bool>* draining_;
  CallLimit watchers_;
  CallLimit exports_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_GRPC_ASSET_SERVICE_H_

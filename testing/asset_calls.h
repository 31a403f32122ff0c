// What the tests add to sdk::AssetClient (sdk/asset_client.h), the one client
// of the asset API: a client on a test server, files loaded into memory (so a
// test can change their bytes), and the raw calls a test of the API itself
// needs and no real client makes: a hand-built Ingest stream (malformed,
// partial, out of order) sent through the client's own stub and channel.
// Everything here goes through an sdk::AssetClient.
#ifndef MESHSTREAM_TESTING_ASSET_CALLS_H_
#define MESHSTREAM_TESTING_ASSET_CALLS_H_

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "importers/import.h"
#include "meshstream/v1/asset_service.grpc.pb.h"
#include "sdk/asset_client.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

// The connection options of a plain (no TLS, no token) client of `address`.
inline sdk::ClientOptions PlainClientOptions(const std::string& address) {
  sdk::ClientOptions options;
  options.server = address;
  return options;
}

// A client of the server at `address`; aborts the test binary when the
// options are refused (they never are for a loopback address).
inline std::unique_ptr<sdk::AssetClient> NewAssetClient(const std::string& address, const std::string& token = "",
                                                        sdk::ClientOptions options = {}) {
  options.server = address;
  options.token = token;
  options.request_timeout_s = 120;
  auto client = sdk::AssetClient::Create(options);
  if (!client.ok()) std::abort();
  return std::move(client).value();
}

// The file at `path`, in memory, named `name` in the upload (empty when it
// cannot be read: the upload then fails on the server's checks).
inline sdk::UploadFile LoadFile(const std::string& path, const std::string& name) {
  auto bytes = ReadFileBytes(path, uint64_t{1} << 30);
  return sdk::UploadFile::FromBytes(name, bytes.ok() ? std::move(bytes).value() : std::vector<uint8_t>());
}

inline sdk::Upload UploadOf(const std::string& asset, sdk::UploadFile main, std::vector<sdk::UploadFile> resources = {}) {
  sdk::Upload upload;
  upload.asset = asset;
  upload.main = std::move(main);
  upload.resources = std::move(resources);
  return upload;
}

inline void AppendChunks(const std::vector<uint8_t>& bytes, size_t chunk, std::vector<v1::IngestRequest>& out) {
  for (size_t offset = 0; offset < bytes.size(); offset += chunk) {
    v1::IngestRequest c;
    c.set_chunk(bytes.data() + offset, std::min(chunk, bytes.size() - offset));
    out.push_back(c);
  }
}

// The messages of a well-formed upload: metadata (size and sha256 of the
// main file), its chunks, then each resource and its chunks.
inline std::vector<v1::IngestRequest> UploadMessages(const std::string& asset, const sdk::UploadFile& main,
                                                     const std::vector<sdk::UploadFile>& resources = {},
                                                     size_t chunk = size_t{1} << 20) {
  std::vector<v1::IngestRequest> messages = {sdk::IngestMetadataMessage(asset, main)};
  AppendChunks(main.bytes, chunk, messages);
  for (const sdk::UploadFile& r : resources) {
    messages.push_back(sdk::IngestResourceMessage(r));
    AppendChunks(r.bytes, chunk, messages);
  }
  return messages;
}

// Waits until the server holds `bytes` committed bytes of upload
// `upload_id` (QueryUpload), for a test that cuts an upload part way: a
// deadline that only bounds a broken server. False when it never did.
inline bool WaitForCommitted(const sdk::AssetClient& client, const std::string& upload_id, uint64_t bytes,
                             std::chrono::seconds timeout = std::chrono::seconds(60)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    auto held = client.QueryUpload(upload_id);
    if (held.ok() && held.value() == bytes) return true;
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

// Prepares a raw call's context as the client would (token, deadline).
inline void Prepare(const sdk::AssetClient& client, grpc::ClientContext& context, double timeout_s = 120) {
  client.client().Prepare(context, timeout_s);
}

// Sends exactly `messages` on one Ingest stream through the client's stub.
inline grpc::Status IngestRaw(const sdk::AssetClient& client, const std::vector<v1::IngestRequest>& messages,
                              v1::IngestResponse* response) {
  grpc::ClientContext context;
  Prepare(client, context);
  auto writer = client.stub().Ingest(&context, response);
  for (const v1::IngestRequest& m : messages) {
    if (!writer->Write(m)) break;
  }
  writer->WritesDone();
  return writer->Finish();
}


// The shapes the tests assert on: the answer in an out-parameter and the
// client's Status returned.
inline Status Ingest(const sdk::AssetClient& client, const std::string& asset, sdk::UploadFile main,
                     v1::IngestResponse* response, std::vector<sdk::UploadFile> resources = {}) {
  auto result = client.Ingest(UploadOf(asset, std::move(main), std::move(resources)));
  if (!result.ok()) return result.status();
  *response = result->response;
  return Status::Ok();
}

// Follows the job to its end (no reconnection); the last state in *last and,
// when `all` is given, every state seen.
inline Status Watch(const sdk::AssetClient& client, const std::string& job_id, v1::Job* last,
                    std::vector<v1::Job>* all = nullptr) {
  sdk::WatchOptions options;
  options.on_update = [&](const v1::Job& job) {
    *last = job;
    if (all != nullptr) all->push_back(job);
  };
  return client.Watch(job_id, options).status();
}

// Uploads the file at `path` (named `name`) as `asset` and follows its job.
inline Status IngestModel(const sdk::AssetClient& client, const std::string& asset, const std::string& path,
                          const std::string& name, v1::Job* job) {
  v1::IngestResponse response;
  MS_RETURN_IF_ERROR(Ingest(client, asset, LoadFile(path, name), &response));
  return Watch(client, response.job_id(), job);
}

// The shared model `file` (ModelPath: "spot.obj", "gltf/x.glb") ingested as
// `asset` on the server at `address` and its job watched to the end: an
// error unless the job succeeded.
inline Status IngestSharedModel(const std::string& address, const std::string& asset, const std::string& file) {
  const auto client = NewAssetClient(address);
  v1::Job job;
  MS_RETURN_IF_ERROR(IngestModel(*client, asset, ModelPath(file), file.substr(file.rfind('/') + 1), &job));
  if (job.state() != v1::JOB_STATE_SUCCEEDED) return Internal("ingesting " + file + ": " + job.message());
  return Status::Ok();
}

inline Status GetVersion(const sdk::AssetClient& client, const std::string& asset, int64_t version, v1::Version* out) {
  auto v = client.GetVersion(asset, version);
  if (!v.ok()) return v.status();
  *out = std::move(v).value();
  return Status::Ok();
}

// An export, or its error in `status` (the bytes then empty).
struct ExportResult : sdk::Exported {
  Status status;
};
inline ExportResult Export(const sdk::AssetClient& client, const std::string& asset, int64_t version,
                           v1::Format format, std::optional<int> lod = {}) {
  sdk::ExportRequest request;
  request.asset = asset;
  request.version = version;
  request.format = format;
  if (lod) request.lod = *lod;
  auto exported = client.Export(request);
  ExportResult out;
  if (exported.ok()) {
    static_cast<sdk::Exported&>(out) = std::move(exported).value();
  } else {
    out.status = exported.status();
  }
  return out;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_ASSET_CALLS_H_

// DEPRECATED: tests use sdk::AssetClient (sdk/asset_client.h) through
// testing/asset_calls.h; only bench/ and tests/integration/stream_faults_test.cc
// (both being rewritten elsewhere in issue 22) still include this file, until
// they move to sdk::AssetClient too, and then it goes.
//
// A C++ client of meshstream.v1.AssetService for integration tests: real
// gRPC over loopback with the generated stubs, and helpers that ingest a
// file (with its .gltf resources), wait for a job and export a version.
#ifndef MESHSTREAM_TESTING_ASSET_CLIENT_H_
#define MESHSTREAM_TESTING_ASSET_CLIENT_H_

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "importers/import.h"
#include "meshstream/v1/asset_service.grpc.pb.h"
#include "services/store/blob_store.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

struct UploadFile {
  std::string name;           // in the upload
  std::vector<uint8_t> bytes;
};

class AssetClient {
 public:
  explicit AssetClient(const std::string& address, std::string token = "",
                       std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials(),
                       const grpc::ChannelArguments& args = {})
      : token_(std::move(token)) {
    channel_ = grpc::CreateCustomChannel(address, credentials, args);
    stub_ = v1::AssetService::NewStub(channel_);
  }

  v1::AssetService::Stub& stub() { return *stub_; }
  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }

  void Prepare(grpc::ClientContext& context, double timeout_s = 120) const {
    if (!token_.empty()) context.AddMetadata("authorization", "Bearer " + token_);
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(static_cast<int>(timeout_s * 1000)));
  }

  // Sends exactly `messages` on one Ingest stream.
  grpc::Status IngestRaw(const std::vector<v1::IngestRequest>& messages, v1::IngestResponse* response) {
    grpc::ClientContext context;
    Prepare(context);
    auto writer = stub_->Ingest(&context, response);
    for (const v1::IngestRequest& m : messages) {
      if (!writer->Write(m)) break;
    }
    writer->WritesDone();
    return writer->Finish();
  }

  // The messages of a well-formed upload: metadata (size and sha256 of the
  // main file), its chunks, then each resource and its chunks.
  static std::vector<v1::IngestRequest> UploadMessages(const std::string& asset, const UploadFile& main,
                                                       const std::vector<UploadFile>& resources = {},
                                                       size_t chunk = size_t{1} << 20) {
    std::vector<v1::IngestRequest> messages(1);
    v1::IngestMetadata& m = *messages[0].mutable_metadata();
    m.set_asset(asset);
    m.set_filename(main.name);
    m.set_size(main.bytes.size());
    m.set_sha256(Sha256Hex(main.bytes.data(), main.bytes.size()));
    AppendChunks(main.bytes, chunk, messages);
    for (const UploadFile& r : resources) {
      v1::IngestRequest header;
      header.mutable_resource()->set_name(r.name);
      header.mutable_resource()->set_size(r.bytes.size());
      header.mutable_resource()->set_sha256(Sha256Hex(r.bytes.data(), r.bytes.size()));
      messages.push_back(header);
      AppendChunks(r.bytes, chunk, messages);
    }
    return messages;
  }

  static void AppendChunks(const std::vector<uint8_t>& bytes, size_t chunk, std::vector<v1::IngestRequest>& out) {
    for (size_t offset = 0; offset < bytes.size(); offset += chunk) {
      v1::IngestRequest c;
      c.set_chunk(bytes.data() + offset, std::min(chunk, bytes.size() - offset));
      out.push_back(c);
    }
  }

  static UploadFile Load(const std::string& path, const std::string& name) {
    auto bytes = ReadFileBytes(path, uint64_t{1} << 30);
    return UploadFile{name, bytes.ok() ? bytes.value() : std::vector<uint8_t>()};
  }

  grpc::Status Ingest(const std::string& asset, const UploadFile& main, v1::IngestResponse* response,
                      const std::vector<UploadFile>& resources = {}) {
    return IngestRaw(UploadMessages(asset, main, resources), response);
  }

  // Uploads the file at `path` (named `name`) as `asset` and follows its job
  // to the end: the final Job in *job.
  grpc::Status IngestModel(const std::string& asset, const std::string& path, const std::string& name, v1::Job* job) {
    v1::IngestResponse r;
    const grpc::Status s = Ingest(asset, Load(path, name), &r);
    return s.ok() ? Watch(r.job_id(), job) : s;
  }

  // Follows WatchJob to the end; the last Job seen.
  grpc::Status Watch(const std::string& job_id, v1::Job* last, std::vector<v1::Job>* all = nullptr,
                     double timeout_s = 300) {
    grpc::ClientContext context;
    Prepare(context, timeout_s);
    v1::GetJobRequest request;
    request.set_job_id(job_id);
    auto reader = stub_->WatchJob(&context, request);
    v1::Job job;
    while (reader->Read(&job)) {
      *last = job;
      if (all) all->push_back(job);
    }
    return reader->Finish();
  }

  grpc::Status GetVersion(const std::string& asset, int64_t version, v1::Version* out) {
    grpc::ClientContext context;
    Prepare(context);
    v1::GetVersionRequest request;
    request.set_asset(asset);
    request.set_version(version);
    return stub_->GetVersion(&context, request, out);
  }

  struct Exported {
    grpc::Status status;
    std::vector<uint8_t> bytes;
    std::string sha256;
    int64_t version = 0;
    size_t chunks = 0;
    size_t largest_chunk = 0;
  };
  Exported Export(const std::string& asset, int64_t version, v1::Format format, std::optional<int> lod = {}) {
    grpc::ClientContext context;
    Prepare(context);
    v1::ExportRequest request;
    request.set_asset(asset);
    request.set_version(version);
    request.set_format(format);
    if (lod) request.set_lod(*lod);
    auto reader = stub_->Export(&context, request);
    Exported out;
    v1::ExportChunk chunk;
    while (reader->Read(&chunk)) {
      if (out.chunks == 0) out.version = chunk.version();
      out.bytes.insert(out.bytes.end(), chunk.data().begin(), chunk.data().end());
      if (!chunk.sha256().empty()) out.sha256 = chunk.sha256();
      out.largest_chunk = std::max(out.largest_chunk, chunk.data().size());
      ++out.chunks;
    }
    out.status = reader->Finish();
    return out;
  }

 private:
  std::string token_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::AssetService::Stub> stub_;
};

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_ASSET_CLIENT_H_

// sdk::AssetClient (sdk/asset_client.h) against a real `meshstream serve`:
// an upload the server holds part of is resumed, an upload whose server went
// away in the middle is retried and resumed on the server that came back (one
// version, not two), the progress callbacks see every byte, a watch sees the
// job to its end, and an export whose bytes do not match the announced digest,
// or exceed what the caller accepts, is refused (that needs a server that
// lies: an in-process AssetService on loopback).
#include <signal.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "importers/import.h"
#include "meshstream/v1/asset_service.grpc.pb.h"
#include "sdk/asset_client.h"
#include "testing/asset_calls.h"
#include "testing/serve_process.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ServeProcess;

constexpr size_t kChunk = 256 << 10;

// Leaves what an interrupted client leaves: the metadata and the first
// `chunks` chunks of `file` under `upload_id`, then the stream cut.
void UploadPart(const sdk::AssetClient& client, const std::string& asset, const sdk::UploadFile& file,
                const std::string& upload_id, size_t chunks) {
  auto messages = test_util::UploadMessages(asset, file, {}, kChunk);
  messages.resize(1 + chunks);
  messages[0].mutable_metadata()->set_upload_id(upload_id);
  grpc::ClientContext context;
  test_util::Prepare(client, context);
  v1::IngestResponse response;
  auto writer = client.stub().Ingest(&context, &response);
  for (const v1::IngestRequest& m : messages) ASSERT_TRUE(writer->Write(m));
  // Until the server has committed them (QueryUpload says so), then cut.
  EXPECT_TRUE(test_util::WaitForCommitted(client, upload_id, chunks * kChunk)) << "the chunks were never committed";
  context.TryCancel();
  (void)writer->Finish();
}

TEST(SdkAssetClient, ResumesAnUploadTheServerHoldsPartOfWithProgress) {
  test_util::TempDir dir;
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--workers", "1"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  auto client = sdk::AssetClient::Create(test_util::PlainClientOptions((*server)->address()));
  ASSERT_TRUE(client.ok()) << client.status().ToString();
  auto upload = sdk::UploadFromPath("horse", test_util::ModelPath("horse.ply"));
  ASSERT_TRUE(upload.ok()) << upload.status().ToString();
  const uint64_t size = upload->main.size;
  ASSERT_GT(size, 4 * kChunk);
  const std::string id = sdk::DefaultUploadId("horse", upload->main.sha256);
  UploadPart(**client, "horse", test_util::LoadFile(test_util::ModelPath("horse.ply"), "horse.ply"), id, 2);
  auto held = (*client)->QueryUpload(id);
  ASSERT_TRUE(held.ok()) << held.status().ToString();
  ASSERT_EQ(held.value(), 2 * kChunk);

  std::vector<sdk::IngestProgress> seen;
  sdk::IngestOptions options;
  options.chunk_bytes = kChunk;
  options.on_progress = [&](const sdk::IngestProgress& p) { seen.push_back(p); };
  options.on_retry = [](const Status& cause, int) { ADD_FAILURE() << "no retry expected: " << cause.ToString(); };
  auto result = (*client)->Ingest(upload.value(), options);
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_EQ(result->resumed_from, 2 * kChunk);
  EXPECT_EQ(result->attempts, 1);
  EXPECT_EQ(result->response.sha256(), upload->main.sha256);
  // Progress: from the resumed offset, one call per chunk sent, to the end.
  ASSERT_EQ(seen.size(), (size - 2 * kChunk + kChunk - 1) / kChunk);
  EXPECT_EQ(seen.front().sent, std::min<uint64_t>(size, 3 * kChunk));
  EXPECT_EQ(seen.back().sent, size);
  for (const sdk::IngestProgress& p : seen) {
    EXPECT_EQ(p.total, size);
    EXPECT_EQ(p.file, "horse.ply");
  }

  // The watch sees the job to its end, each state once.
  std::vector<v1::Job> states;
  sdk::WatchOptions watch;
  watch.on_update = [&](const v1::Job& job) { states.push_back(job); };
  auto job = (*client)->Watch(result->response.job_id(), watch);
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_EQ(job->state(), v1::JOB_STATE_SUCCEEDED) << job->message();
  ASSERT_FALSE(states.empty());
  EXPECT_EQ(states.back().state(), v1::JOB_STATE_SUCCEEDED);

  // Export: the digest checked, progress to the announced size.
  auto version = (*client)->GetVersion("horse", 0);
  ASSERT_TRUE(version.ok()) << version.status().ToString();
  uint64_t last_received = 0, last_total = 0;
  sdk::ExportRequest request;
  request.asset = "horse";
  request.format = v1::FORMAT_PROGRESSIVE_GLB;
  auto exported = (*client)->Export(request, [&](uint64_t received, uint64_t total) {
    EXPECT_GE(received, last_received);
    last_received = received;
    last_total = total;
  });
  ASSERT_TRUE(exported.ok()) << exported.status().ToString();
  EXPECT_EQ(exported->sha256, version->artifact_sha256());
  EXPECT_EQ(last_received, exported->bytes.size());
  EXPECT_EQ(last_total, exported->bytes.size());
  EXPECT_EQ((*server)->Terminate(), 0) << (*server)->log();
}

TEST(SdkAssetClient, RetriesAnUploadWhoseServerWentAwayAndMakesOneVersion) {
  test_util::TempDir dir;
  const std::string store = dir.File("store");
  auto first = ServeProcess::Start({"--store", store, "--workers", "1"});
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  const std::string address = (*first)->address();
  std::unique_ptr<ServeProcess> second;
  auto client = sdk::AssetClient::Create(test_util::PlainClientOptions(address));
  ASSERT_TRUE(client.ok());
  auto upload = sdk::UploadFromPath("bunny", test_util::ModelPath("stanford-bunny.obj"));
  ASSERT_TRUE(upload.ok()) << upload.status().ToString();

  sdk::IngestOptions options;
  options.chunk_bytes = kChunk;
  options.retry_wait = std::chrono::milliseconds(100);
  std::vector<sdk::IngestProgress> seen;
  std::vector<Status> causes;
  options.on_progress = [&](const sdk::IngestProgress& p) {
    seen.push_back(p);
    if (seen.size() != 2) return;
    // The server dies in the middle of the upload and a new one comes up on
    // the same address and store; the client's next write finds the stream broken.
    (*first)->Kill();
    auto again = ServeProcess::Start({"--store", store, "--workers", "1", "--listen", address});
    ASSERT_TRUE(again.ok()) << again.status().ToString();
    second = std::move(again).value();
  };
  options.on_retry = [&](const Status& cause, int next) {
    causes.push_back(cause);
    EXPECT_EQ(next, static_cast<int>(causes.size()) + 1);
  };
  auto result = (*client)->Ingest(upload.value(), options);
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  ASSERT_NE(second, nullptr);
  ASSERT_FALSE(causes.empty()) << "the broken stream was retried";
  EXPECT_EQ(causes[0].code(), StatusCode::kUnavailable) << causes[0].ToString();
  EXPECT_NE(causes[0].message().find(address), std::string::npos) << causes[0].ToString();
  EXPECT_EQ(result->attempts, static_cast<int>(causes.size()) + 1);
  EXPECT_EQ(seen.back().sent, upload->main.size);
  EXPECT_EQ(seen.back().attempt, result->attempts);
  // What the server committed before it died was not sent again.
  const uint64_t resumed = result->resumed_from;
  EXPECT_LE(resumed, 2 * kChunk);
  auto versions = (*client)->ListVersions("bunny");
  ASSERT_TRUE(versions.ok()) << versions.status().ToString();
  ASSERT_EQ(versions->size(), 1u) << "one upload, one version";
  EXPECT_EQ(versions->front().source_sha256(), upload->main.sha256);
  EXPECT_EQ(second->Terminate(), 0) << second->log();
}

// An AssetService that answers every Export with bytes whose announced
// SHA-256 is not theirs.
class LyingExports final : public v1::AssetService::Service {
 public:
  grpc::Status Export(grpc::ServerContext*, const v1::ExportRequest*,
                      grpc::ServerWriter<v1::ExportChunk>* writer) override {
    v1::ExportChunk chunk;
    chunk.set_version(7);
    chunk.set_total_size(5);
    chunk.set_data("hello");
    chunk.set_sha256(std::string(64, '0'));
    writer->Write(chunk);
    return grpc::Status::OK;
  }
};

TEST(SdkAssetClient, AnExportWhoseDigestDoesNotMatchOrIsTooLargeIsRefused) {
  LyingExports service;
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  ASSERT_NE(server, nullptr);
  auto client = sdk::AssetClient::Create(test_util::PlainClientOptions("127.0.0.1:" + std::to_string(port)));
  ASSERT_TRUE(client.ok());
  sdk::ExportRequest request;
  request.asset = "anything";
  auto exported = (*client)->Export(request);
  ASSERT_FALSE(exported.ok());
  EXPECT_EQ(exported.status().code(), StatusCode::kDataLoss) << exported.status().ToString();
  EXPECT_NE(exported.status().message().find(std::string(64, '0')), std::string::npos) << exported.status().ToString();
  // More bytes than the caller accepts: cut off, not collected.
  request.max_bytes = 3;
  exported = (*client)->Export(request);
  ASSERT_FALSE(exported.ok());
  EXPECT_EQ(exported.status().code(), StatusCode::kResourceExhausted) << exported.status().ToString();
  server->Shutdown();
}

TEST(SdkAssetClient, AnUnreachableServerIsUnavailableNamingIt) {
  sdk::ClientOptions options;
  options.server = "127.0.0.1:1";
  options.request_timeout_s = 5;
  auto client = sdk::AssetClient::Create(options);
  ASSERT_TRUE(client.ok());
  auto assets = (*client)->ListAssets();
  ASSERT_FALSE(assets.ok());
  EXPECT_EQ(assets.status().code(), StatusCode::kUnavailable) << assets.status().ToString();
  EXPECT_NE(assets.status().message().find("127.0.0.1:1"), std::string::npos) << assets.status().ToString();
}

}  // namespace
}  // namespace meshstream

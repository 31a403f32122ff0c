#include "bench/harness.h"

#include <sqlite3.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include <google/protobuf/stubs/common.h>
#include <grpcpp/grpcpp.h>

#include "bench/bench_util.h"
#include "importers/import.h"
#include "proto/rpc_status.h"
#include "sdk/asset_client.h"
#include "testing/asset_calls.h"

namespace meshstream::bench {

namespace fs = std::filesystem;
using json = nlohmann::json;

// ------------------------------------------------------------- the server

std::string MakeTempFolder(const std::string& work_dir, const std::string& prefix) {
  std::string pattern = (fs::path(work_dir) / (prefix + "-XXXXXX")).string();
  if (mkdtemp(pattern.data()) == nullptr) Die(work_dir + ": mkdtemp failed");
  return pattern;
}

ServerOptions BenchServerOptions(const std::string& store, int workers, const std::string& server_id,
                                 std::function<void(const std::string&)> log) {
  ServerOptions o;
  o.listen = "127.0.0.1:0";
  o.store = store;
  o.workers = workers;
  o.reflection = false;
  o.grace_period_s = 10;
  o.server_id = server_id;
  o.log = std::move(log);
  return o;
}

void StopServer(std::unique_ptr<Server>& server) {
  if (!server) return;
  server->Drain();
  server->Wait();
  server.reset();
}

// ------------------------------------------------------------ the machine

json MachineInfo(const std::string& work_dir, const std::string& source_dir, const std::string& build_type) {
  json m = {
      {"nproc", std::thread::hardware_concurrency()},
      {"cpu", CpuModel()},
      {"date", UtcNow()},
      {"kernel", KernelName()},
      {"loadavg_at_start", LoadAverage()},
      {"compiler", __VERSION__},
      {"build_type", build_type},
      {"grpc", grpc::Version()},
      {"protobuf", google::protobuf::internal::VersionString(GOOGLE_PROTOBUF_VERSION)},
      {"sqlite", sqlite3_libversion()},
      {"work_dir", work_dir},
      {"work_dir_filesystem", FirstLineOf("findmnt -n -o FSTYPE,SOURCE --target " + ShellQuote(work_dir) +
                                          " 2>/dev/null")},
  };
  const std::string commit = GitCommitLabel(source_dir);
  if (!commit.empty()) m["git_commit"] = commit;
  return m;
}

void WriteJson(const std::string& path, const json& out) {
  const fs::path out_path(path);
  if (out_path.has_parent_path()) fs::create_directories(out_path.parent_path());
  std::ofstream f(path);
  f << out.dump(1) << "\n";
  if (!f) Die(path + ": cannot write");
}

// ------------------------------------------------------------- the models

ModelFile ReadModelFile(const std::string& dir, const std::string& relative) {
  ModelFile m;
  m.path = dir + "/" + relative;
  m.file = fs::path(relative).filename().string();
  m.name = Stem(relative);
  m.bytes = Check(ReadFileBytes(m.path, uint64_t{1} << 30), m.path);
  return m;
}

// ---------------------------------------------------------- the asset API

std::vector<v1::IngestRequest> IngestMessages(const Upload& upload) {
  auto messages = test_util::UploadMessages(upload.asset, sdk::UploadFile::FromBytes(upload.file, *upload.bytes));
  if (upload.options) *messages[0].mutable_metadata()->mutable_options() = *upload.options;
  if (!upload.upload_id.empty()) messages[0].mutable_metadata()->set_upload_id(upload.upload_id);
  return messages;
}

// The client library behind AssetApi: sdk::AssetClient, the one client of the
// asset API (the CLI's and the tests' too). Ingest sends exactly the messages
// it is given (the same bytes go to the echo reference), so it uses the
// client's stub and contexts; the rest are the client's own calls.
class AssetApi::Impl {
 public:
  explicit Impl(const std::string& address) : client(test_util::NewAssetClient(address)) {}
  std::unique_ptr<sdk::AssetClient> client;
};

AssetApi::AssetApi(const std::string& address) : impl_(std::make_unique<Impl>(address)) {}

AssetApi::~AssetApi() = default;

bool AssetApi::WaitForConnected(std::chrono::system_clock::time_point deadline) {
  return impl_->client->channel()->WaitForConnected(deadline);
}

StatusOr<v1::IngestResponse> AssetApi::Ingest(const std::vector<v1::IngestRequest>& messages) {
  v1::IngestResponse response;
  const grpc::Status s = test_util::IngestRaw(*impl_->client, messages, &response);
  if (!s.ok()) return FromGrpcStatus(s);
  return response;
}

StatusOr<v1::Job> AssetApi::Watch(const std::string& job_id, const std::function<void(const v1::Job&)>& on_job,
                                  double timeout_s) {
  // The benchmarks bound a watch; the client's Watch has no deadline of its
  // own, so the bound is the raw call's.
  grpc::ClientContext context;
  impl_->client->client().Prepare(context, timeout_s);
  v1::GetJobRequest request;
  request.set_job_id(job_id);
  auto reader = impl_->client->stub().WatchJob(&context, request);
  v1::Job job, last;
  bool seen = false;
  while (reader->Read(&job)) {
    if (on_job) on_job(job);
    last = job;
    seen = true;
  }
  const grpc::Status s = reader->Finish();
  if (!s.ok()) return FromGrpcStatus(s);
  if (!seen) return NotFound("WatchJob " + job_id + " ended without a job");
  return last;
}

StatusOr<v1::Version> AssetApi::GetVersion(const std::string& asset, int64_t version) {
  return impl_->client->GetVersion(asset, version);
}

StatusOr<v1::ListVersionsResponse> AssetApi::ListVersions(const std::string& asset, int32_t page_size,
                                                          const std::string& page_token) {
  // One page, as the latency benchmark times it (the client's ListVersions
  // walks every page).
  grpc::ClientContext context;
  impl_->client->client().Prepare(context, 120);
  v1::ListVersionsRequest r;
  r.set_asset(asset);
  r.set_page_size(page_size);
  r.set_page_token(page_token);
  v1::ListVersionsResponse page;
  const grpc::Status s = impl_->client->stub().ListVersions(&context, r, &page);
  if (!s.ok()) return FromGrpcStatus(s);
  return page;
}

StatusOr<AssetApi::Exported> AssetApi::Export(const std::string& asset, int64_t version, v1::Format format) {
  sdk::ExportRequest request;
  request.asset = asset;
  request.version = version;
  request.format = format;
  MS_ASSIGN_OR_RETURN(sdk::Exported e, impl_->client->Export(request));
  return Exported{std::move(e.bytes), std::move(e.sha256)};
}

StatusOr<v1::Version> IngestAndWait(AssetApi& api, const std::string& asset, const std::string& file,
                                    const std::vector<uint8_t>& bytes) {
  Upload upload;
  upload.asset = asset;
  upload.file = file;
  upload.bytes = &bytes;
  MS_ASSIGN_OR_RETURN(const v1::IngestResponse response, api.Ingest(IngestMessages(upload)));
  MS_ASSIGN_OR_RETURN(const v1::Job job, api.Watch(response.job_id()));
  if (job.state() != v1::JOB_STATE_SUCCEEDED) {
    return Internal("the job of " + file + " ended " + v1::JobState_Name(job.state()) + ": " + job.message());
  }
  return api.GetVersion(asset, response.version());
}

}  // namespace meshstream::bench

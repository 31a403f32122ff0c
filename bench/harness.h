// What the service and stream benchmarks (bench/service/, bench/stream/)
// share: a meshstream server in this process on a temporary store, a model
// file's bytes, the asset API as a benchmark drives it (ingest, watch,
// versions, export), the machine's facts, and the JSON written at the end.
// The option table is bench/options.h.
//
// AssetApi is the one place the benchmarks reach the asset API, through
// sdk::AssetClient (sdk/asset_client.h), the client the CLI, the tests and
// engines use.
//
// Contract: for benchmark programs only. Functions named "Die" in their
// comment end the process; the rest return a Status (or StatusOr) for what a
// server or the machine refused. An AssetApi is used by one thread at a time
// (one per client thread, as the benchmarks do).
#ifndef MESHSTREAM_BENCH_HARNESS_H_
#define MESHSTREAM_BENCH_HARNESS_H_

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "codec/core/status.h"
#include "meshstream/v1/asset_service.pb.h"
#include "services/server/server.h"

namespace meshstream::bench {

// ------------------------------------------------------------- the server

// A new folder "<work_dir>/<prefix>-XXXXXX" (mkdtemp); Die when it cannot be
// made. The caller removes it.
std::string MakeTempFolder(const std::string& work_dir, const std::string& prefix);

// What every benchmark server starts from: production defaults but listen
// 127.0.0.1:0, `store`, `workers` job workers, no reflection, a 10 s grace
// period, `server_id`, and every log line to `log` (called on the server's
// threads).
ServerOptions BenchServerOptions(const std::string& store, int workers, const std::string& server_id,
                                 std::function<void(const std::string&)> log);

// Drains, waits for and destroys *server; nothing when it is null.
void StopServer(std::unique_ptr<Server>& server);

// ------------------------------------------------------------ the machine

// What the service and stream benchmarks record about the machine and the
// build of a run: cores, CPU, date, kernel, load, compiler, build type, the
// gRPC, protobuf and SQLite versions, the work folder's filesystem and the
// source's commit (marked when it has uncommitted changes).
nlohmann::json MachineInfo(const std::string& work_dir, const std::string& source_dir, const std::string& build_type);

// Writes out.dump(1) and a line end to `path`, its folder made first; Die
// when it cannot.
void WriteJson(const std::string& path, const nlohmann::json& out);

// ------------------------------------------------------------- the models

// A model file as a benchmark uploads it; each benchmark's Model adds what
// it knows of the model (bench/service/models.h, bench/stream/models.h).
struct ModelFile {
  std::string name;  // the stem: the asset's name
  std::string file;  // the file name in the upload
  std::string path;
  std::vector<uint8_t> bytes;
};

// The model at `relative` under `dir` (path "<dir>/<relative>"), its bytes
// read (at most 1 GiB); Die when they cannot be.
ModelFile ReadModelFile(const std::string& dir, const std::string& relative);

// ---------------------------------------------------------- the asset API

// One upload: a file's bytes as an asset, with encode options and, for a
// resumable upload, its upload_id.
struct Upload {
  std::string asset;
  std::string file;                           // the file name in the upload
  const std::vector<uint8_t>* bytes = nullptr;  // not owned; outlives the call
  std::optional<v1::EncodeOptions> options;   // none: the metadata carries no options
  std::string upload_id;                      // "": not resumable
};

// The Ingest messages of `upload`: the metadata (size, SHA-256, options,
// upload_id), then chunks of 1 MiB. What AssetApi::Ingest sends, and what a
// reference that streams the same bytes elsewhere needs.
std::vector<v1::IngestRequest> IngestMessages(const Upload& upload);

class AssetApi {
 public:
  // A channel to `address` (insecure, no token); connects lazily.
  explicit AssetApi(const std::string& address);
  ~AssetApi();
  AssetApi(const AssetApi&) = delete;
  AssetApi& operator=(const AssetApi&) = delete;

  // Connects now; false when not connected by `deadline`.
  bool WaitForConnected(std::chrono::system_clock::time_point deadline);

  // Sends exactly `messages` on one Ingest stream (a 120 s deadline).
  StatusOr<v1::IngestResponse> Ingest(const std::vector<v1::IngestRequest>& messages);

  // Follows WatchJob until the server ends the stream: `on_job` (may be
  // empty) sees every Job as it arrives; returns the last one (NotFound when
  // the stream ended without one).
  StatusOr<v1::Job> Watch(const std::string& job_id, const std::function<void(const v1::Job&)>& on_job = nullptr,
                          double timeout_s = 300);

  StatusOr<v1::Version> GetVersion(const std::string& asset, int64_t version);
  StatusOr<v1::ListVersionsResponse> ListVersions(const std::string& asset, int32_t page_size,
                                                  const std::string& page_token);

  // Every chunk of one Export, and the SHA-256 the server sent with the
  // last; sdk::AssetClient::Export has checked the bytes against it (a
  // mismatch is its DataLoss error).
  struct Exported {
    std::vector<uint8_t> bytes;
    std::string sha256;
  };
  StatusOr<Exported> Export(const std::string& asset, int64_t version, v1::Format format);

 private:
  class Impl;  // the client library's client (harness.cc)
  std::unique_ptr<Impl> impl_;
};

// Ingests `bytes` as `asset` (named `file` in the upload), follows the job
// and returns the version it made; an error when the upload was refused or
// the job did not succeed (the job's message).
StatusOr<v1::Version> IngestAndWait(AssetApi& api, const std::string& asset, const std::string& file,
                                    const std::vector<uint8_t>& bytes);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_HARNESS_H_

// What the client verbs (ingest, versions, assets, export) share: the server
// address, the token and TLS as options (each also from MESHSTREAM_<NAME>), a
// connected stub, per-call metadata and deadlines, errors from the server as
// Status, the JSON of the API's messages, and a progress line on a terminal.
#ifndef MESHSTREAM_CLI_REMOTE_H_
#define MESHSTREAM_CLI_REMOTE_H_

#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "codec/core/status.h"
#include "meshstream/v1/asset_service.grpc.pb.h"

namespace meshstream::cli {

constexpr char kDefaultServer[] = "127.0.0.1:7600";

struct RemoteOptions {
  std::string server = kDefaultServer;
  std::string token;
  bool tls = false;
  std::string tls_ca;  // PEM roots; empty: the system's
  double timeout_s = 60.0;  // unary calls; streams take their own
};

void AddRemoteOptions(CLI::App* cmd, RemoteOptions& options);

StatusOr<std::unique_ptr<v1::AssetService::Stub>> Connect(const RemoteOptions& options);
// The token and a deadline (`timeout_s` <= 0: none).
void PrepareContext(grpc::ClientContext& context, const RemoteOptions& options, double timeout_s);
// A failed call as a Status. The server's INVALID_ARGUMENT is bad input here
// (exit 1: the request, not the command line, was wrong); an unreachable
// server says where it looked.
Status RemoteError(const grpc::Status& status, const RemoteOptions& options);

// "ASSET" or "ASSET@VERSION" (a number >= 0; 0 and none: the latest READY),
// the asset checked as a name. InvalidArgument naming the argument otherwise.
struct AssetVersion {
  std::string asset;
  int64_t version = 0;
};
StatusOr<AssetVersion> ParseAssetVersion(const std::string& target);

nlohmann::json JobJson(const v1::Job& job);
nlohmann::json VersionJson(const v1::Version& version);
const char* ShortState(v1::JobState state);
const char* ShortState(v1::VersionState state);

// A one-line progress display on stderr when it is a terminal (and not --json).
class ProgressLine {
 public:
  explicit ProgressLine(bool enabled);
  ~ProgressLine();
  void Show(const std::string& text);
  void Clear();

 private:
  bool enabled_;
  bool shown_ = false;
};

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_REMOTE_H_

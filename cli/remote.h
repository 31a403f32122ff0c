// What the client verbs (ingest, versions, assets, export, fetch) share: the
// connection as options (--server, --token, --tls, --tls-ca, --timeout, each
// also from MESHSTREAM_<NAME>) filling the SDK's one sdk::ClientOptions, a
// connected sdk::AssetClient (sdk/asset_client.h: every call of the API goes
// through it), the CLI's reading of the client's errors, the JSON of the API's
// messages, and a progress line on a terminal.
#ifndef MESHSTREAM_CLI_REMOTE_H_
#define MESHSTREAM_CLI_REMOTE_H_

#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "codec/core/status.h"
#include "meshstream/v1/asset_service.pb.h"
#include "sdk/asset_client.h"
#include "sdk/client.h"

namespace meshstream::cli {

struct RemoteOptions {
  sdk::ClientOptions client;  // server (default kDefaultAddress), token, tls, request_timeout_s (--timeout)
  std::string tls_ca;         // --tls-ca: a PEM file, read into client.tls_ca_pem by ClientOptionsOf
};

void AddRemoteOptions(CLI::App* cmd, RemoteOptions& options);

// The SDK's options of the command line (--tls-ca read; it implies TLS).
StatusOr<sdk::ClientOptions> ClientOptionsOf(const RemoteOptions& options);
StatusOr<std::unique_ptr<sdk::AssetClient>> ConnectAssets(const RemoteOptions& options);
// An error of the client as the CLI reports it. The server's
// INVALID_ARGUMENT is bad input here (exit 1: the request, not the command
// line, was wrong); an unreachable server gets a hint, a deadline names
// --timeout, and a refusal for want of a token says where a token goes.
Status RemoteError(const Status& status, const RemoteOptions& options);

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

#include "cli/remote.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>

#include "cli/app.h"
#include "cli/json_out.h"
#include "importers/import.h"

namespace meshstream::cli {

void AddRemoteOptions(CLI::App* cmd, RemoteOptions& o) {
  FromEnv(cmd->add_option("--server", o.client.server, "the server, HOST:PORT"))->capture_default_str();
  FromEnv(cmd->add_option("--token", o.client.token, "API token (meshstream token create); sent as 'authorization: Bearer'"));
  FromEnv(cmd->add_flag("--tls", o.client.tls, "connect with TLS (the server has --tls-cert)"));
  FromEnv(cmd->add_option("--tls-ca", o.tls_ca, "PEM file of the roots that sign the server's certificate (implies --tls)"));
  FromEnv(cmd->add_option("--timeout", o.client.request_timeout_s, "seconds per request (uploads: per MiB)")
              ->check(NumberIn(0.1, 86400)))
      ->capture_default_str();
}

StatusOr<sdk::ClientOptions> ClientOptionsOf(const RemoteOptions& o) {
  sdk::ClientOptions options = o.client;
  if (!o.tls_ca.empty()) {
    auto pem = ReadFileBytes(o.tls_ca, 1 << 20);
    if (!pem.ok()) return pem.status().WithContext("--tls-ca");
    options.tls = true;
    options.tls_ca_pem.assign(pem->begin(), pem->end());
  }
  return options;
}

StatusOr<std::unique_ptr<sdk::AssetClient>> ConnectAssets(const RemoteOptions& o) {
  MS_ASSIGN_OR_RETURN(const sdk::ClientOptions options, ClientOptionsOf(o));
  return sdk::AssetClient::Create(options);
}

Status RemoteError(const Status& s, const RemoteOptions& o) {
  if (s.code() == StatusCode::kInvalidArgument) return InvalidInput(s.message());
  if (s.code() == StatusCode::kUnavailable) {
    return Unavailable(s.message() + " (is `meshstream serve` running there?)");
  }
  if (s.code() == StatusCode::kDeadlineExceeded) {
    char seconds[32];
    std::snprintf(seconds, sizeof seconds, "%g", o.client.request_timeout_s);
    return DeadlineExceeded(s.message() + " (--timeout " + seconds + " s per request, per MiB for uploads)");
  }
  if (s.code() == StatusCode::kUnauthenticated && o.client.token.empty()) {
    return Unauthenticated(s.message() + " (give --token or MESHSTREAM_TOKEN)");
  }
  return s;
}

const char* ShortState(v1::JobState state) {
  switch (state) {
    case v1::JOB_STATE_PENDING: return "pending";
    case v1::JOB_STATE_RUNNING: return "running";
    case v1::JOB_STATE_SUCCEEDED: return "succeeded";
    case v1::JOB_STATE_FAILED: return "failed";
    default: return "unknown";
  }
}

const char* ShortState(v1::VersionState state) {
  switch (state) {
    case v1::VERSION_STATE_PROCESSING: return "processing";
    case v1::VERSION_STATE_READY: return "ready";
    case v1::VERSION_STATE_FAILED: return "failed";
    default: return "unknown";
  }
}

nlohmann::json JobJson(const v1::Job& job) {
  return {{"id", job.id()},
          {"state", v1::JobState_Name(job.state())},
          {"progress", job.progress()},
          {"message", Utf8(job.message())},
          {"asset", job.asset()},
          {"version", job.version()},
          {"attempts", job.attempts()}};
}

nlohmann::json VersionJson(const v1::Version& v) {
  nlohmann::json labels = nlohmann::json::object();
  for (const auto& [key, value] : v.labels()) labels[Utf8(key)] = Utf8(value);
  std::vector<int64_t> level_vertices(v.level_vertices().begin(), v.level_vertices().end());
  nlohmann::json resources = nlohmann::json::array();
  for (const auto& r : v.resources()) resources.push_back({{"name", Utf8(r.name())}, {"size", r.size()}, {"sha256", r.sha256()}});
  const auto& o = v.options();
  return {{"asset", v.asset()},
          {"version", v.version()},
          {"state", v1::VersionState_Name(v.state())},
          {"source_filename", Utf8(v.source_filename())},
          {"source_sha256", v.source_sha256()},
          {"source_size", v.source_size()},
          {"resources", resources},
          {"options",
           {{"qp", o.qp()}, {"qn", o.qn()}, {"qt", o.qt()}, {"packing", o.packing()},
            {"packet_bytes", o.packet_bytes()}, {"base_ratio", o.base_ratio()}}},
          {"encoder", v.encoder()},
          {"vertices", v.vertices()},
          {"faces", v.faces()},
          {"levels", v.levels()},
          {"level_vertices", level_vertices},
          {"progressive_bytes", v.progressive_bytes()},
          {"reliable_bytes", v.reliable_bytes()},
          {"unreliable_bytes", v.unreliable_bytes()},
          {"created_ms", v.created().seconds() * 1000 + v.created().nanos() / 1000000},
          {"comment", Utf8(v.comment())},
          {"labels", labels},
          {"job_id", v.job_id()},
          {"error", Utf8(v.error())}};
}

ProgressLine::ProgressLine(bool enabled) : enabled_(enabled && isatty(STDERR_FILENO)) {}

ProgressLine::~ProgressLine() { Clear(); }

void ProgressLine::Show(const std::string& text) {
  if (!enabled_) return;
  std::fprintf(stderr, "\r%s\033[K", text.c_str());
  std::fflush(stderr);
  shown_ = true;
}

void ProgressLine::Clear() {
  if (!shown_) return;
  std::fputs("\r\033[K", stderr);
  std::fflush(stderr);
  shown_ = false;
}

}  // namespace meshstream::cli

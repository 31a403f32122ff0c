#include "cli/remote.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>

#include "cli/app.h"
#include "cli/json_out.h"
#include "importers/import.h"
#include "services/api/grpc_status.h"
#include "services/store/store.h"

namespace meshstream::cli {

void AddRemoteOptions(CLI::App* cmd, RemoteOptions& o) {
  FromEnv(cmd->add_option("--server", o.server, "the server, HOST:PORT"))->capture_default_str();
  FromEnv(cmd->add_option("--token", o.token, "API token (meshstream token create); sent as 'authorization: Bearer'"));
  FromEnv(cmd->add_flag("--tls", o.tls, "connect with TLS (the server has --tls-cert)"));
  FromEnv(cmd->add_option("--tls-ca", o.tls_ca, "PEM file of the roots that sign the server's certificate (implies --tls)"));
  FromEnv(cmd->add_option("--timeout", o.timeout_s, "seconds per request (uploads and exports: per MiB)")
              ->check(NumberIn(0.1, 86400)))
      ->capture_default_str();
}

StatusOr<std::unique_ptr<v1::AssetService::Stub>> Connect(const RemoteOptions& o) {
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (o.tls || !o.tls_ca.empty()) {
    grpc::SslCredentialsOptions ssl;
    if (!o.tls_ca.empty()) {
      auto pem = ReadFileBytes(o.tls_ca, 1 << 20);
      if (!pem.ok()) return pem.status().WithContext("--tls-ca");
      ssl.pem_root_certs.assign(pem->begin(), pem->end());
    }
    credentials = grpc::SslCredentials(ssl);
  }
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(2 << 20);
  args.SetMaxSendMessageSize(2 << 20);
  auto channel = grpc::CreateCustomChannel(o.server, credentials, args);
  if (!channel) return InvalidArgument("--server " + o.server + ": not an address");
  return v1::AssetService::NewStub(channel);
}

void PrepareContext(grpc::ClientContext& context, const RemoteOptions& o, double timeout_s) {
  if (!o.token.empty()) context.AddMetadata("authorization", "Bearer " + o.token);
  if (timeout_s > 0) {
    context.set_deadline(std::chrono::system_clock::now() +
                         std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000)));
  }
}

Status RemoteError(const grpc::Status& status, const RemoteOptions& o) {
  Status s = FromGrpcStatus(status);
  if (s.code() == StatusCode::kInvalidArgument) return InvalidInput(s.message());
  if (s.code() == StatusCode::kUnavailable) {
    return Unavailable(o.server + ": " + s.message() + " (is `meshstream serve` running there?)");
  }
  if (s.code() == StatusCode::kUnauthenticated && o.token.empty()) {
    return Unauthenticated(s.message() + " (give --token or MESHSTREAM_TOKEN)");
  }
  return s;
}

StatusOr<AssetVersion> ParseAssetVersion(const std::string& target) {
  AssetVersion out;
  out.asset = target;
  const size_t at = target.find('@');
  if (at != std::string::npos) {
    const std::string number = target.substr(at + 1);
    out.asset = target.substr(0, at);
    char* end = nullptr;
    out.version = std::strtoll(number.c_str(), &end, 10);
    if (number.empty() || *end != '\0' || out.version < 0) {
      return InvalidArgument(target + ": expected ASSET or ASSET@VERSION (a number >= 0)");
    }
  }
  Status s = CheckName("ASSET", out.asset);
  if (!s.ok()) return s;
  return out;
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

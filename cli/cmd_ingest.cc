// meshstream ingest FILE --asset NAME [--server ADDR] [--qp ...] [--wait] [--json]
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/exit_codes.h"
#include "cli/json_out.h"
#include "cli/remote.h"
#include "cli/verbs.h"
#include "importers/import.h"
#include "proto/api_names.h"
#include "sdk/asset_client.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "Uploads a mesh or scene (.gltf with its external files, .glb .obj .ply .off .stl) to a\n"
    "server as the next version of ASSET; the server stores it durably, then encodes it as a job.\n"
    "Files above 1 MiB are uploaded resumably: if the connection breaks, running the same command\n"
    "again continues where the server's copy ends. --wait follows the job until it succeeds or\n"
    "fails (exit 1 with the importer's message). Encoding options left at 0 are the server's\n"
    "defaults (those of 'meshstream encode').\n"
    "\n"
    "Examples:\n"
    "  meshstream ingest bunny.obj --asset bunny --wait\n"
    "  MESHSTREAM_SERVER=assets:7600 MESHSTREAM_TOKEN=mst_... meshstream ingest scene.gltf --json";

constexpr int kAttempts = 5;
constexpr int kWatchReconnects = 60;

struct IngestArgs {
  std::string file, asset, comment;
  std::vector<std::string> labels;
  v1::EncodeOptions options;
  int qp = 0, qn = 0, qt = 0;
  std::string packing;
  uint32_t packet_bytes = 0;
  double base_ratio = 0;
  bool wait = false, json = false;
  RemoteOptions remote;
};

std::string Mib(uint64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f MiB", bytes / 1048576.0);
  return text;
}

// The upload as the command line describes it, every name checked here as
// the server would (exit 2 for a bad argument, 1 for a bad file).
StatusOr<sdk::Upload> Describe(const IngestArgs& args) {
  MS_ASSIGN_OR_RETURN(sdk::Upload upload, sdk::UploadFromPath(args.asset, args.file));
  for (const sdk::UploadFile& r : upload.resources) {
    Status s = CheckResourceName(r.name);
    if (!s.ok()) return InvalidInput(s.message()).WithContext(args.file);
  }
  upload.options = args.options;
  upload.comment = args.comment;
  for (const std::string& label : args.labels) {
    const size_t eq = label.find('=');
    upload.labels[label.substr(0, eq)] = eq == std::string::npos ? "" : label.substr(eq + 1);
  }
  return upload;
}

int RunIngest(IngestArgs& args) {
  if (args.asset.empty()) {
    // Not FileStem: a name that is only an extension (".obj") leaves no
    // asset name here, and the check below says so.
    const std::string name = FileBaseName(args.file);
    args.asset = name.substr(0, name.rfind('.'));
  }
  Status s = CheckName("--asset", args.asset);
  if (!s.ok()) return ReportError("ingest", s);
  s = CheckMainFilename(FileBaseName(args.file));
  if (!s.ok()) return ReportError("ingest", s.WithContext(args.file));
  for (const std::string& label : args.labels) {
    if (label.empty() || label[0] == '=') return ReportError("ingest", InvalidArgument("--label '" + label + "': expected KEY=VALUE"));
  }
  args.options.set_qp(args.qp);
  args.options.set_qn(args.qn);
  args.options.set_qt(args.qt);
  args.options.set_packing(args.packing);
  args.options.set_packet_bytes(args.packet_bytes);
  args.options.set_base_ratio(args.base_ratio);
  auto upload = Describe(args);
  if (!upload.ok()) return ReportError("ingest", upload.status());
  auto client = ConnectAssets(args.remote);
  if (!client.ok()) return ReportError("ingest", client.status());
  ProgressLine progress(!args.json);
  sdk::IngestOptions options;
  options.attempts = kAttempts;
  options.on_progress = [&progress](const sdk::IngestProgress& p) {
    progress.Show("uploading " + p.file + ": " + std::to_string(p.total ? 100 * p.sent / p.total : 100) + "% (" +
                  Mib(p.sent) + " of " + Mib(p.total) + ")");
  };
  options.on_retry = [&progress](const Status& cause, int) {
    progress.Clear();
    std::fprintf(stderr, "meshstream ingest: connection lost (%s); resuming\n", cause.message().c_str());
  };
  auto uploaded = (*client)->Ingest(upload.value(), options);
  progress.Clear();
  if (!uploaded.ok()) return ReportError("ingest", RemoteError(uploaded.status(), args.remote));
  const v1::IngestResponse& r = uploaded->response;
  nlohmann::json j = {{"asset", r.asset()}, {"version", r.version()}, {"job_id", r.job_id()}, {"sha256", r.sha256()}};
  if (uploaded->resumed_from > 0) j["resumed_from"] = uploaded->resumed_from;
  if (!args.json) {
    std::printf("%s -> %s version %lld (job %s, sha256 %s)%s\n", args.file.c_str(), r.asset().c_str(),
                static_cast<long long>(r.version()), r.job_id().c_str(), r.sha256().substr(0, 12).c_str(),
                uploaded->resumed_from ? (" resumed at " + Mib(uploaded->resumed_from)).c_str() : "");
  }
  if (!args.wait) {
    if (args.json) PrintJson(j);
    return kExitOk;
  }
  sdk::WatchOptions watch;
  watch.reconnects = kWatchReconnects;
  watch.on_update = [&progress](const v1::Job& job) {
    progress.Show("processing " + job.asset() + " v" + std::to_string(job.version()) + ": " +
                  std::to_string(static_cast<int>(job.progress() * 100)) + "% " + job.message());
  };
  auto job = (*client)->Watch(r.job_id(), watch);
  progress.Clear();
  if (!job.ok()) return ReportError("ingest", RemoteError(job.status(), args.remote));
  j["job"] = JobJson(job.value());
  if (args.json) {
    PrintJson(j);
  } else if (job->state() == v1::JOB_STATE_SUCCEEDED) {
    std::printf("%s version %lld ready\n", r.asset().c_str(), static_cast<long long>(r.version()));
  }
  if (job->state() == v1::JOB_STATE_FAILED) {
    return ReportError("ingest", InvalidInput(r.asset() + " version " + std::to_string(r.version()) +
                                              " failed: " + job->message()));
  }
  return kExitOk;
}

}  // namespace

Verb AddIngest(CLI::App& root) {
  auto args = std::make_shared<IngestArgs>();
  CLI::App* cmd = AddVerb(root, "ingest", "Uploads a mesh to a server as the next version of an asset.", kDetails);
  cmd->add_option("FILE", args->file, "the file to upload")->required();
  cmd->add_option("--asset", args->asset, "the asset, [A-Za-z0-9._-]{1,128} (default: the file's stem)");
  cmd->add_option("--comment", args->comment, "a note stored with the version");
  cmd->add_option("--label", args->labels, "KEY=VALUE stored with the version (repeatable)")->expected(1)->allow_extra_args(false)->take_all();
  FromEnv(cmd->add_option("--qp", args->qp, "position quantization bits (0: server default)"));
  FromEnv(cmd->add_option("--qn", args->qn, "normal quantization bits (0: server default)"));
  FromEnv(cmd->add_option("--qt", args->qt, "texture coordinate bits (0: server default)"));
  FromEnv(cmd->add_option("--packing", args->packing, "split or bundled (empty: server default)")
              ->check(CLI::IsMember({"", "split", "bundled"})));
  FromEnv(cmd->add_option("--packet-bytes", args->packet_bytes, "datagram payload limit (0: server default)"));
  FromEnv(cmd->add_option("--base-ratio", args->base_ratio, "fraction of the vertices in the base (0: default)")
              ->check(NumberIn(0.0, 1.0)));
  cmd->add_flag("--wait", args->wait, "follow the job until it succeeds or fails");
  cmd->add_flag("--json", args->json, "print one JSON object: the IngestResponse (and with --wait the final job)");
  AddRemoteOptions(cmd, args->remote);
  return {cmd, [args] { return RunIngest(*args); }};
}

}  // namespace meshstream::cli

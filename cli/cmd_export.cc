// meshstream export ASSET[@VERSION] -o FILE [--format glb|draco|progressive|obj|ply] [--lod K]
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli/asset_target.h"
#include "cli/exit_codes.h"
#include "cli/json_out.h"
#include "cli/remote.h"
#include "cli/verbs.h"
#include "proto/export_formats.h"
#include "importers/import.h"
#include "sdk/asset_client.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "Downloads a version from a server in a format: glb (plain glTF binary), draco\n"
    "(KHR_draco_mesh_compression), progressive (the stored progressive .glb), obj or ply.\n"
    "ASSET alone or ASSET@0 is the latest READY version. Without --format the extension of -o\n"
    "decides (.obj, .ply; .glb is glb). --lod K exports level K (0 is the base mesh). The file is\n"
    "written only once every byte arrived and matched the server's SHA-256.\n"
    "\n"
    "Examples:\n"
    "  meshstream export bunny -o bunny.glb\n"
    "  meshstream export bunny@3 -o bunny-base.glb --format draco --lod 0";

struct ExportArgs {
  std::string target, out, format;
  std::optional<int> lod;
  bool json = false;
  RemoteOptions remote;
};

StatusOr<v1::Format> ParseFormat(const std::string& format, const std::string& out) {
  if (format.empty()) return ExportFormatForExtension(FileExtension(out)).proto;
  if (const ExportFormatInfo* info = ExportFormatNamed(format)) return info->proto;
  return InvalidArgument("--format " + format + ": expected one of " + ExportFormatNames());
}

int RunExport(const ExportArgs& args) {
  auto target = ParseAssetVersion(args.target);
  if (!target.ok()) return ReportError("export", target.status());
  const std::string asset = target->asset;
  const int64_t version = target->version;
  auto format = ParseFormat(args.format, args.out);
  if (!format.ok()) return ReportError("export", format.status());
  auto client = ConnectAssets(args.remote);
  if (!client.ok()) return ReportError("export", client.status());
  sdk::ExportRequest request;
  request.asset = asset;
  request.version = version;
  request.format = format.value();
  if (args.lod) request.lod = *args.lod;
  ProgressLine progress(!args.json);
  auto exported = (*client)->Export(request, [&progress](uint64_t received, uint64_t total) {
    if (total > 0) progress.Show("downloading: " + std::to_string(100 * received / total) + "%");
  });
  progress.Clear();
  if (!exported.ok()) return ReportError("export", RemoteError(exported.status(), args.remote));
  const std::vector<uint8_t>& bytes = exported->bytes;
  const std::string& sha256 = exported->sha256;
  const int64_t exported_version = exported->version;
  const Status s = WriteFileBytes(args.out, bytes);
  if (!s.ok()) return ReportError("export", s);
  if (args.json) {
    PrintJson({{"asset", asset}, {"version", exported_version}, {"format", v1::Format_Name(format.value())},
               {"output", Utf8(args.out)}, {"bytes", bytes.size()}, {"sha256", sha256}});
  } else {
    std::printf("%s@%lld -> %s: %zu bytes (%s)\n", asset.c_str(), static_cast<long long>(exported_version),
                args.out.c_str(), bytes.size(), v1::Format_Name(format.value()).c_str());
  }
  return kExitOk;
}

}  // namespace

Verb AddExport(CLI::App& root) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* cmd = AddVerb(root, "export", "Downloads a version of an asset from a server in a format.", kDetails);
  cmd->add_option("ASSET", args->target, "ASSET or ASSET@VERSION")->required();
  cmd->add_option("-o,--output", args->out, "the file to write")->required();
  std::vector<std::string> formats;
  for (const ExportFormatInfo& info : ExportFormats()) formats.push_back(info.name);
  cmd->add_option("--format", args->format, ExportFormatNames() + " (default: by -o's extension)")
      ->check(CLI::IsMember(formats));
  cmd->add_option("--lod", args->lod, "level of detail (0: the base mesh; default: full)")->check(CLI::Range(0, 1 << 20));
  cmd->add_flag("--json", args->json, "print one JSON object");
  AddRemoteOptions(cmd, args->remote);
  return {cmd, [args] { return RunExport(*args); }};
}

}  // namespace meshstream::cli

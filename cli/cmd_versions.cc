// meshstream versions ASSET / meshstream assets: what a server holds.
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>

#include "cli/exit_codes.h"
#include "cli/json_out.h"
#include "cli/remote.h"
#include "cli/verbs.h"
#include "proto/api_names.h"

namespace meshstream::cli {

namespace {

const char kVersionsDetails[] =
    "Lists every version of ASSET on the server (all pages), oldest first: state, size, levels\n"
    "and what was uploaded. --json prints {\"versions\": [...]} with the fields of docs/spec/api.md.\n"
    "\n"
    "Example:\n"
    "  meshstream versions bunny --server 127.0.0.1:7600";

const char kAssetsDetails[] =
    "Lists the assets of the token's tenant with their latest version.\n"
    "\n"
    "Example:\n"
    "  meshstream assets --json";

struct ListArgs {
  std::string asset;
  bool json = false;
  RemoteOptions remote;
};

std::string Date(const google::protobuf::Timestamp& t) {
  const std::time_t seconds = static_cast<std::time_t>(t.seconds());
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%SZ", &tm);
  return text;
}

int RunVersions(const ListArgs& args) {
  Status s = CheckName("ASSET", args.asset);
  if (!s.ok()) return ReportError("versions", s);
  auto client = ConnectAssets(args.remote);
  if (!client.ok()) return ReportError("versions", client.status());
  auto versions = (*client)->ListVersions(args.asset);
  if (!versions.ok()) return ReportError("versions", RemoteError(versions.status(), args.remote));
  if (args.json) {
    nlohmann::json list = nlohmann::json::array();
    for (const v1::Version& v : versions.value()) list.push_back(VersionJson(v));
    PrintJson({{"asset", args.asset}, {"versions", list}});
    return kExitOk;
  }
  std::printf("%-7s  %-10s  %10s  %10s  %6s  %12s  %-20s  %s\n", "VERSION", "STATE", "VERTICES", "FACES", "LEVELS",
              "BYTES", "CREATED", "SOURCE");
  for (const v1::Version& v : versions.value()) {
    std::printf("%-7lld  %-10s  %10lld  %10lld  %6d  %12llu  %-20s  %s%s%s\n", static_cast<long long>(v.version()),
                ShortState(v.state()), static_cast<long long>(v.vertices()), static_cast<long long>(v.faces()),
                v.levels(), static_cast<unsigned long long>(v.progressive_bytes()), Date(v.created()).c_str(),
                Utf8(v.source_filename()).c_str(), v.error().empty() ? "" : ": ", Utf8(v.error()).c_str());
  }
  return kExitOk;
}

int RunAssets(const ListArgs& args) {
  auto client = ConnectAssets(args.remote);
  if (!client.ok()) return ReportError("assets", client.status());
  auto assets = (*client)->ListAssets();
  if (!assets.ok()) return ReportError("assets", RemoteError(assets.status(), args.remote));
  if (args.json) {
    nlohmann::json list = nlohmann::json::array();
    for (const v1::Asset& a : assets.value()) {
      list.push_back({{"name", a.name()}, {"latest_version", a.latest_version()},
                      {"updated_ms", a.updated().seconds() * 1000 + a.updated().nanos() / 1000000}});
    }
    PrintJson({{"assets", list}});
    return kExitOk;
  }
  std::printf("%-40s  %7s  %s\n", "ASSET", "LATEST", "UPDATED");
  for (const v1::Asset& a : assets.value()) {
    std::printf("%-40s  %7lld  %s\n", a.name().c_str(), static_cast<long long>(a.latest_version()),
                Date(a.updated()).c_str());
  }
  return kExitOk;
}

}  // namespace

Verb AddVersions(CLI::App& root) {
  auto args = std::make_shared<ListArgs>();
  CLI::App* cmd = AddVerb(root, "versions", "Lists the versions of an asset on a server.", kVersionsDetails);
  cmd->add_option("ASSET", args->asset, "the asset")->required();
  cmd->add_flag("--json", args->json, "print one JSON object");
  AddRemoteOptions(cmd, args->remote);
  return {cmd, [args] { return RunVersions(*args); }};
}

Verb AddAssets(CLI::App& root) {
  auto args = std::make_shared<ListArgs>();
  CLI::App* cmd = AddVerb(root, "assets", "Lists the assets on a server.", kAssetsDetails);
  cmd->add_flag("--json", args->json, "print one JSON object");
  AddRemoteOptions(cmd, args->remote);
  return {cmd, [args] { return RunAssets(*args); }};
}

}  // namespace meshstream::cli

// meshstream fetch ASSET[@VERSION] -o OUT.glb [--server ADDR] [--lod K] [--tcp-only] [--json]
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "cli/asset_target.h"
#include "cli/exit_codes.h"
#include "cli/json_out.h"
#include "cli/remote.h"
#include "cli/verbs.h"
#include "codec/progressive/view_order.h"
#include "parallel/fork_join_pool.h"
#include "importers/import.h"
#include "sdk/client.h"
#include "sdk/session.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "Streams a version through a session (docs/spec/streaming-protocol.md) with the SDK: the base\n"
    "mesh first, then each level as it arrives, and writes the mesh reached (.glb or .gltf).\n"
    "ASSET alone or ASSET@0 is the latest READY version; --lod K stops after K levels. The\n"
    "refinement datagrams travel over UDP (authenticated, paced; what is lost is predicted, not\n"
    "sent again) unless --tcp-only asks for them on the gRPC stream, or UDP is blocked (the server\n"
    "then falls back to gRPC after its HELLO timeout). On a terminal one line shows the progress\n"
    "(level, megabytes received, mean rate, time); with --json, or when stderr is not a terminal,\n"
    "nothing but the result is printed.\n"
    "\n"
    "Example:\n"
    "  meshstream fetch bunny -o bunny.glb --json";

struct FetchArgs {
  std::string target, out;
  std::optional<int> lod;
  bool tcp_only = false;
  bool json = false;
  std::string udp_via;
  bool repair = false;
  bool no_parity = false;
  std::string profile = "auto";
  double expected_loss = -1;
  int threads = 1;
  std::string view;
  RemoteOptions remote;
};

int RunFetch(const FetchArgs& args) {
  auto target = ParseAssetVersion(args.target);
  if (!target.ok()) return ReportError("fetch", target.status());
  const std::string asset = target->asset;
  const int64_t version = target->version;
  const std::string ext = FileExtension(args.out);
  if (ext != ".glb" && ext != ".gltf") return ReportError("fetch", InvalidArgument(args.out + ": the output is .glb or .gltf"));
  auto client_options = ClientOptionsOf(args.remote);
  if (!client_options.ok()) return ReportError("fetch", client_options.status());
  auto client = sdk::Client::Create(client_options.value());
  if (!client.ok()) return ReportError("fetch", client.status());
  sdk::SessionOptions options;
  options.asset = asset;
  options.version = version;
  options.max_level = args.lod ? *args.lod : -1;
  options.tcp_only = args.tcp_only;
  options.udp_via = args.udp_via;
  options.repair = args.repair;
  options.no_parity = args.no_parity;
  options.profile = args.profile == "reliable"        ? sdk::SessionOptions::Profile::kReliable
                    : args.profile == "loss-tolerant" ? sdk::SessionOptions::Profile::kLossTolerant
                                                      : sdk::SessionOptions::Profile::kAuto;
  options.expected_loss = args.expected_loss;
  options.decode_threads = args.threads == 0 ? -1 : args.threads;  // the SDK's -1: one per core
  if (!args.view.empty()) {
    auto view = LookAtViewFromText(args.view);
    if (!view.ok()) return ReportError("fetch", Status(view.status().code(), "--" + view.status().message()));
    options.view = view.value();
  }
  auto session = sdk::Session::Open(**client, options);
  if (!session.ok()) return ReportError("fetch", session.status());
  // On a terminal (stderr) and without --json: one line, rewritten per
  // level: the level, the bytes received on both channels, the mean rate.
  ProgressLine progress(!args.json);
  const auto opened = std::chrono::steady_clock::now();
  auto show = [&](const std::string& what) {
    const sdk::SessionStats& st = (*session)->stats();
    const double bytes = static_cast<double>(st.reliable_bytes + st.unreliable_bytes);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - opened).count();
    char line[256];
    std::snprintf(line, sizeof line, "%s, %.2f MB, %.1f Mbit/s, %.1f s", what.c_str(), bytes / 1e6,
                  s > 0 ? bytes * 8 / s / 1e6 : 0.0, s);
    progress.Show(line);
  };
  for (;;) {
    const sdk::Event e = (*session)->Poll(static_cast<int32_t>(args.remote.client.request_timeout_s * 1000));
    if (e.type == sdk::EventType::kNone) {
      return ReportError("fetch", Unavailable(args.remote.client.server + ": nothing arrived for " +
                                               std::to_string(static_cast<int>(args.remote.client.request_timeout_s)) + " s"));
    }
    if (e.type == sdk::EventType::kError) {
      Status error = e.status;
      if (error.code() == StatusCode::kInvalidArgument) error = InvalidInput(error.message());
      return ReportError("fetch", error);
    }
    if (e.type == sdk::EventType::kBaseReady) show("base mesh after " + std::to_string(static_cast<int>((*session)->stats().time_to_base_ms)) + " ms");
    if (e.type == sdk::EventType::kLevelReady) {
      show("level " + std::to_string(e.level) + " of " + std::to_string((*session)->levels()));
    }
    if (e.type == sdk::EventType::kLevelReady && args.repair && e.level == (*session)->levels()) {
      show("level " + std::to_string(e.level) + " of " + std::to_string(e.level) + ", repairing");
    }
    if (e.type == sdk::EventType::kComplete) break;
  }
  progress.Clear();
  const Status s = (*session)->Export(args.out);
  if (!s.ok()) return ReportError("fetch", s);
  uint64_t vertices = 0, faces = 0;
  const Scene scene = (*session)->CurrentScene();
  vertices = scene.total_vertices();
  faces = scene.total_faces();
  const sdk::SessionStats& st = (*session)->stats();
  nlohmann::json j = {{"asset", asset},
                      {"output", Utf8(args.out)},
                      {"vertices", vertices},
                      {"faces", faces},
                      {"primitives", (*session)->primitive_count()},
                      {"levels_applied", (*session)->level_shown()},
                      {"transport", st.transport},
                      {"datagrams_received", st.datagrams_received},
                      {"udp_datagrams_received", st.udp_datagrams_received},
                      {"datagrams_lost", st.datagrams_lost},
                      {"datagrams_recovered", st.datagrams_recovered},
                      {"parity_datagrams", st.parity_datagrams},
                      {"profile", st.profile},
                      {"parity_bytes", st.parity_bytes},
                      {"refinements_decoded_again", st.refinements_decoded_again},
                      {"datagrams_duplicate", st.datagrams_duplicate},
                      {"datagrams_rejected", st.datagrams_rejected},
                      {"predicted_vertices", (*session)->predicted_vertices()},
                      {"reliable_bytes", st.reliable_bytes},
                      {"unreliable_bytes", st.unreliable_bytes},
                      {"time_to_base_ms", st.time_to_base_ms},
                      {"time_to_full_ms", st.time_to_full_ms},
                      {"hello_rtt_ms", st.hello_rtt_ms},
                      {"reliable_refinements", st.reliable_refinements},
                      {"reliable_datagram_bytes", st.reliable_datagram_bytes},
                      {"early_refinements", st.early_refinements},
                      {"early_datagram_bytes", st.early_datagram_bytes},
                      {"losses_declared", st.losses_declared},
                      {"losses_spurious", st.losses_spurious},
                      {"datagrams_late", st.datagrams_late},
                      {"reorder_window_ms", st.reorder_window_ms},
                      {"last_arrival_ms", st.last_arrival_ms},
                      {"decode_after_last_byte_ms", st.decode_after_last_byte_ms},
                      {"session_thread_cpu_ms", st.session_thread_cpu_ms},
                      {"threads", args.threads == 0 ? ForkJoinPool::HardwareWorkers() : args.threads},
                      {"parallel_splits", st.parallel_splits},
                      {"parallel_streams", st.parallel_streams},
                      {"view", !args.view.empty()},
                      {"level_plans", st.level_plans},
                      {"repair", args.repair},
                      {"repaired_datagrams", st.repaired_datagrams},
                      {"repair_bytes", st.repair_bytes},
                      {"time_to_exact_ms", st.time_to_exact_ms},
                      {"repair_error", st.repair_error},
                      {"fallback_reason", st.fallback_reason},
                      {"end_reason", st.end_reason}};
  if (args.json) {
    PrintJson(j);
  } else {
    std::printf("%s -> %s: %llu vertices, %d levels over %s, base after %.0f ms, full after %.0f ms\n",
                args.target.c_str(), args.out.c_str(), static_cast<unsigned long long>(vertices),
                (*session)->level_shown(), st.transport.c_str(), st.time_to_base_ms, st.time_to_full_ms);
  }
  return kExitOk;
}

}  // namespace

Verb AddFetch(CLI::App& root) {
  auto args = std::make_shared<FetchArgs>();
  CLI::App* cmd = AddVerb(root, "fetch", "Streams a version through a session and writes the mesh it reached.", kDetails);
  cmd->add_option("ASSET", args->target, "ASSET or ASSET@VERSION")->required();
  cmd->add_option("-o,--output", args->out, "the file to write, .glb or .gltf")->required();
  cmd->add_option("--lod", args->lod, "stop after K levels (default: all)")->check(CLI::Range(0, 1 << 20));
  cmd->add_flag("--tcp-only", args->tcp_only, "the datagrams over the gRPC stream instead of UDP (firewalls)");
  cmd->add_option("--udp-via", args->udp_via,
                  "HOST:PORT to send the session's UDP through instead of the server's advertised endpoint "
                  "(a relay that shapes the link; debugging)");
  cmd->add_flag("--repair", args->repair,
                "once the stream has ended, ask once for the datagrams that were lost and write the exact mesh "
                "(default: the predicted one, nothing asked again)");
  cmd->add_option("--profile", args->profile,
                  "auto (the server's choice: reliable over --tcp-only, loss-tolerant over UDP), reliable (no "
                  "datagrams: the stream alone) or loss-tolerant (docs/spec/streaming-protocol.md)")
      ->check(CLI::IsMember({"auto", "reliable", "loss-tolerant"}))
      ->capture_default_str();
  cmd->add_flag("--no-parity", args->no_parity,
                "ask for no parity datagrams: what UDP loses is predicted (or repaired), never rebuilt "
                "(docs/design/loss-protection.md)");
  cmd->add_option("--expected-loss", args->expected_loss,
                  "the loss rate this link is known to have, 0..1: the server sends more of the stream reliably "
                  "the higher it is (default: unknown)")
      ->check(NumberIn(0, 1));
  cmd->add_option("--threads", args->threads,
                  "threads for refinements that arrived whole, as `decode --threads` (0: one per core; the mesh "
                  "does not change)")
      ->check(CLI::Range(0, 64))->capture_default_str();
  cmd->add_option("--view", args->view,
                  "EX,EY,EZ,TX,TY,TZ[,FOV,W,H]: what the viewer sees, a camera at the eye looking at the target "
                  "(field of view in degrees, default 60; viewport, default 1280,720): the server sends first what "
                  "spans the most pixels of it (docs/spec/streaming-protocol.md, \"Views\")");
  cmd->add_flag("--json", args->json, "print one JSON object");
  AddRemoteOptions(cmd, args->remote);
  return {cmd, [args] { return RunFetch(*args); }};
}

}  // namespace meshstream::cli

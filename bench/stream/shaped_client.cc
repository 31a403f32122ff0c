#include "bench/stream/shaped_client.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/stream/sessions.h"
#include "bench/stream/snapshots.h"
#include "codec/progressive/view_order.h"
#include "importers/gltf_import.h"
#include "importers/import.h"
#include "sdk/client.h"
#include "sdk/session.h"
#include "testing/asset_calls.h"

namespace meshstream::bench::stream {

namespace ms = meshstream;
using json = nlohmann::json;

namespace {

struct ClientArgs {
  std::string kind, server, udp_via, asset;
  int64_t version = 0;
  std::string snapshot_path;
  int max_snapshots = 0;
  double timeout_s = 0;
  double expected_loss = -1;
  std::string view;  // udp_view: EX,EY,EZ,TX,TY,TZ,FOV,W,H (shaped.cc's ViewArg)
};


ClientArgs ParseClientArgs(int argc, char** argv) {
  if (argc != 11 && argc != 12) {
    Die("--shaped-client KIND SERVER UDP_VIA ASSET VERSION SNAPSHOTS MAX_SNAPSHOTS TIMEOUT_S EXPECTED_LOSS [VIEW]");
  }
  ClientArgs a;
  a.kind = argv[2];
  a.server = argv[3];
  a.udp_via = argv[4];
  a.asset = argv[5];
  a.version = ParseInt(argv[6], "VERSION", 1, INT64_MAX);
  a.snapshot_path = argv[7];
  a.max_snapshots = static_cast<int>(ParseInt(argv[8], "MAX_SNAPSHOTS", 2, 1000));
  a.timeout_s = ParseDouble(argv[9], "TIMEOUT_S");
  a.expected_loss = ParseDouble(argv[10], "EXPECTED_LOSS");
  if (a.expected_loss > 1) Die("--shaped-client: EXPECTED_LOSS at most 1 (< 0: unknown)");
  if (argc > 11 && argv[11][0] != '\0') a.view = argv[11];
  if (a.kind != "udp" && a.kind != "udp_no_parity" && a.kind != "tcp_only" && a.kind != "draco_export" &&
      a.kind != "udp_view") {
    Die("--shaped-client: KIND udp, udp_no_parity, tcp_only, draco_export or udp_view");
  }
  if (a.kind == "udp_view" && a.view.empty()) Die("--shaped-client: udp_view needs VIEW");
  return a;
}

std::chrono::system_clock::time_point ConnectDeadline() {
  return std::chrono::system_clock::now() + std::chrono::seconds(30);
}

// A unary round trip on a warm channel: the second of two GetVersion calls.
double GrpcRoundTripMs(AssetApi& api, const std::string& asset, int64_t version) {
  (void)api.GetVersion(asset, version);
  const auto t0 = Clock::now();
  const bool ok = api.GetVersion(asset, version).ok();
  return ok ? Ms(t0, Clock::now()) : -1;
}

// The levels a session snapshots besides the base and kComplete: all of
// 1..levels-1 when they fit in `max_snapshots` - 2, else that many evenly
// spaced ones.
std::vector<int32_t> SnapshotLevels(int32_t levels, int max_snapshots) {
  std::vector<int32_t> out;
  const int inner = std::max(0, max_snapshots - 2);
  if (levels - 1 <= inner) {
    for (int32_t l = 1; l < levels; ++l) out.push_back(l);
    return out;
  }
  for (int i = 1; i <= inner; ++i) {
    const int32_t l = static_cast<int32_t>(std::lround(static_cast<double>(i) * levels / (inner + 1)));
    if (l >= 1 && l < levels && (out.empty() || out.back() != l)) out.push_back(l);
  }
  return out;
}

// draco_export: the GLB downloaded and decoded, timed from the request.
void RunDownload(const ClientArgs& a, json& j, std::vector<Snapshot>& snapshots) {
  AssetApi api(a.server);
  const auto c0 = Clock::now();
  if (!api.WaitForConnected(ConnectDeadline())) {
    j["error"] = "the channel did not connect in 30 s";
    return;
  }
  j["connect_ms"] = Ms(c0, Clock::now());
  j["grpc_rtt_ms"] = GrpcRoundTripMs(api, a.asset, a.version);
  const auto t0 = Clock::now();
  StatusOr<AssetApi::Exported> exported = api.Export(a.asset, a.version, v1::FORMAT_DRACO_GLB);
  const auto last_byte = Clock::now();
  if (!exported.ok()) {
    j["error"] = "Export FORMAT_DRACO_GLB: " + exported.status().ToString();
    return;
  }
  const AssetApi::Exported& e = exported.value();
  auto scene = ms::ImportGltfBytes(e.bytes, "", a.asset + ".glb", ms::ImportOptions());
  const auto decoded = Clock::now();
  if (!scene.ok()) {
    j["error"] = "decoding the Draco GLB: " + scene.status().ToString();
    return;
  }
  j["ok"] = true;
  j["last_byte_ms"] = Ms(t0, last_byte);
  j["decode_ms"] = Ms(last_byte, decoded);
  j["first_ms"] = j["full_ms"] = Ms(t0, decoded);
  j["bytes"] = e.bytes.size();
  j["sha256"] = e.sha256;
  j["events"] = json::array({{{"what", "decoded"}, {"level", -2}, {"t_ms", Ms(t0, decoded)}}});
  j["snapshot_events"] = json::array({0});
  snapshots.push_back({-2, Geometry(scene.value())});
}

// What a session showed over time: its events, and the scenes at a few of
// them, kept as the session gave them (flattened after the clock stops).
//
// The mesh shown is the session's current one: when Poll hands out several
// events of one batch, it is already at the last of them, so a snapshot is
// labelled with level_shown(), and taken when level_shown() has passed a
// planned level since the last one (always at the base and at kComplete).
struct Recorder {
  std::vector<int32_t> planned;
  std::vector<Scene> scenes;
  std::vector<int32_t> scene_levels;
  json events = json::array(), snapshot_events = json::array();
  double snapshot_ms = 0;
  int32_t last_snapped = -1;
  bool complete = false;

  void Event(const char* what, int32_t level, const sdk::Session& s, double t) {
    events.push_back({{"what", what}, {"level", level}, {"shown", s.level_shown()}, {"t_ms", t},
                      {"predicted", s.predicted_vertices()}});
  }
  void Snap(const sdk::Session& s, bool always) {
    const int32_t shown = s.level_shown();
    const bool due = std::any_of(planned.begin(), planned.end(),
                                 [&](int32_t l) { return l > last_snapped && l <= shown; });
    if (!always && !due) return;
    const auto a = Clock::now();
    scenes.push_back(s.CurrentScene());
    scene_levels.push_back(always && complete ? -1 : shown);
    snapshot_events.push_back(events.size() - 1);
    last_snapped = shown;
    snapshot_ms += Ms(a, Clock::now());
  }
};

json StatsJson(const sdk::SessionStats& st) {
  return {{"transport", st.transport},
          {"fallback_reason", st.fallback_reason},
          {"end_reason", st.end_reason},
          {"time_to_base_ms", st.time_to_base_ms},
          {"time_to_full_ms", st.time_to_full_ms},
          {"last_arrival_ms", st.last_arrival_ms},
          {"decode_after_last_byte_ms", st.decode_after_last_byte_ms},
          {"session_thread_cpu_ms", st.session_thread_cpu_ms},
          {"early_refinements", st.early_refinements},
          {"early_datagram_bytes", st.early_datagram_bytes},
          {"udp_datagrams_received", st.udp_datagrams_received},
          {"losses_declared", st.losses_declared},
          {"hello_rtt_ms", st.hello_rtt_ms},
          {"hellos_sent", st.hellos_sent},
          {"reliable_bytes", st.reliable_bytes},
          {"unreliable_bytes", st.unreliable_bytes},
          {"datagrams_received", st.datagrams_received},
          {"datagrams_lost", st.datagrams_lost},
          {"datagrams_rejected", st.datagrams_rejected},
          {"datagrams_duplicate", st.datagrams_duplicate},
          {"parity_datagrams", st.parity_datagrams},
          {"parity_bytes", st.parity_bytes},
          {"datagrams_recovered", st.datagrams_recovered},
          {"refinements_decoded_again", st.refinements_decoded_again}};
}

// kComplete: the stats, and whether the session reached the full mesh.
void OnComplete(const sdk::Session& s, bool based, json& j) {
  const sdk::SessionStats& st = s.stats();
  j["stats"] = StatsJson(st);
  j["level"] = s.level_shown();
  j["levels"] = s.levels();
  j["predicted_vertices"] = s.predicted_vertices();
  const std::string error = SessionEndError(s, based);
  if (error.empty()) {
    j["ok"] = true;
  } else {
    j["error"] = error;
  }
}

// Polls `s` to its end (kComplete, kError or the deadline), recording.
void PollToEnd(sdk::Session& s, const ClientArgs& a, Clock::time_point t0, Recorder& rec, json& j) {
  const auto deadline = t0 + std::chrono::milliseconds(static_cast<int64_t>(a.timeout_s * 1000));
  bool based = false;
  for (;;) {
    if (Clock::now() > deadline) {
      j["error"] = SessionTimeoutError(s, a.timeout_s);
      s.Cancel();
      return;
    }
    const sdk::Event e = s.Poll(200);
    if (e.type == sdk::EventType::kNone) continue;
    const double t = Ms(t0, Clock::now());
    if (e.type == sdk::EventType::kError) {
      j["error"] = "kError: " + e.status.ToString();
      return;
    }
    if (e.type == sdk::EventType::kBaseReady) {
      based = true;
      rec.Event("base", 0, s, t);
      j["first_ms"] = t;
      rec.planned = SnapshotLevels(s.levels(), a.max_snapshots);
      rec.Snap(s, true);
    } else if (e.type == sdk::EventType::kLevelReady) {
      rec.Event("level", e.level, s, t);
      rec.Snap(s, false);
    } else if (e.type == sdk::EventType::kComplete) {
      rec.Event("complete", s.level_shown(), s, t);
      j["full_ms"] = t;
      rec.complete = true;
      rec.Snap(s, true);
      OnComplete(s, based, j);
      return;
    }
  }
}

// udp or tcp_only: one SDK session, timed from Open.
void RunSession(const ClientArgs& a, json& j, std::vector<Snapshot>& snapshots) {
  auto client = sdk::Client::Create(meshstream::test_util::PlainClientOptions(a.server));
  if (!client.ok()) {
    j["error"] = "Client::Create: " + client.status().ToString();
    return;
  }
  const auto c0 = Clock::now();
  if (!client.value()->channel()->WaitForConnected(ConnectDeadline())) {
    j["error"] = "the channel did not connect in 30 s";
    return;
  }
  j["connect_ms"] = Ms(c0, Clock::now());
  {
    AssetApi probe(a.server);
    j["grpc_rtt_ms"] = GrpcRoundTripMs(probe, a.asset, a.version);
  }
  Recorder rec;
  const auto t0 = Clock::now();
  sdk::SessionOptions so;
  so.asset = a.asset;
  so.version = a.version;
  so.tcp_only = a.kind == "tcp_only";
  if (a.kind != "tcp_only") so.udp_via = a.udp_via;
  so.no_parity = a.kind == "udp_no_parity";
  so.expected_loss = a.expected_loss;
  if (a.kind == "udp_view") so.view = Check(LookAtViewFromText(a.view), "VIEW");
  auto session = sdk::Session::Open(*client.value(), so);
  if (!session.ok()) {
    j["error"] = "Session::Open: " + session.status().ToString();
    return;
  }
  PollToEnd(*session.value(), a, t0, rec, j);
  j["events"] = rec.events;
  j["snapshot_events"] = rec.snapshot_events;
  j["snapshot_ms"] = rec.snapshot_ms;
  session.value().reset();
  for (size_t i = 0; i < rec.scenes.size(); ++i) snapshots.push_back({rec.scene_levels[i], Geometry(rec.scenes[i])});
}

}  // namespace

int ShapedClientMain(int argc, char** argv) {
  const ClientArgs a = ParseClientArgs(argc, argv);
  json j = {{"kind", a.kind}, {"ok", false}};
  std::vector<Snapshot> snapshots;
  if (a.kind == "draco_export") {
    RunDownload(a, j, snapshots);
  } else {
    RunSession(a, j, snapshots);
  }
  WriteSnapshots(a.snapshot_path, snapshots);
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  return 0;
}

}  // namespace meshstream::bench::stream

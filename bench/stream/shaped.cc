#include "bench/stream/shaped.h"

#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>
#include <utility>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/scaling/subdivide.h"
#include "bench/scaling/surface_noise.h"
#include "bench/stream/server_log.h"
#include "bench/stream/shaped_distances.h"
#include "bench/stream/shaped_summary.h"
#include "bench/stream/snapshots.h"
#include "bench/tcp_delay_proxy.h"
#include "importers/gltf_import.h"
#include "importers/import.h"
#include "importers/mesh_writer.h"
#include "net/udp_socket.h"
#include "sdk/client.h"
#include "sdk/session.h"
#include "testing/netns.h"
#include "testing/udp_relay.h"
#include "testing/asset_calls.h"

namespace meshstream::bench::stream {

namespace ms = meshstream;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// The link: the namespace, the server behind it, the UDP relay and the TCP
// delay proxy in front of it. Not movable (the server logs into `log`).
struct Link {
  explicit Link(bool verbose) : log(verbose) {}
  std::unique_ptr<test_util::NetNs> ns;
  ServerLog log;
  ServerOptions options;
  std::unique_ptr<Server> server;
  std::string address;
  SocketAddress udp_upstream;
  std::unique_ptr<test_util::UdpRelay> relay;
  std::unique_ptr<TcpDelayProxy> proxy;
  std::string udp_via;
};

// `command` run by /bin/sh; its stdout, and its exit status.
std::pair<std::string, int> Capture(const std::string& command) {
  FILE* p = popen(command.c_str(), "r");
  if (p == nullptr) return {"", -1};
  std::string out;
  char buffer[4096];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, p)) > 0) out.append(buffer, n);
  const int status = pclose(p);
  return {out, WIFEXITED(status) ? WEXITSTATUS(status) : 128};
}

// The full lossless mesh of a version: a gRPC session straight to the
// server (no namespace, no shaping), checked complete and without one
// predicted vertex.
Primitive ReferenceMesh(const std::string& address, const Model& m) {
  auto client = Check(sdk::Client::Create(meshstream::test_util::PlainClientOptions(address)), "the reference client");
  sdk::SessionOptions so;
  so.asset = m.name;
  so.version = m.version;
  so.tcp_only = true;
  auto session = Check(sdk::Session::Open(*client, so), "the reference session of " + m.name);
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  for (;;) {
    if (Clock::now() > deadline) Die("the reference session of " + m.name + " did not complete");
    const sdk::Event e = session->Poll(500);
    if (e.type == sdk::EventType::kError) Die("the reference session of " + m.name + ": " + e.status.ToString());
    if (e.type == sdk::EventType::kComplete) break;
  }
  if (session->level_shown() != session->levels() || session->predicted_vertices() != 0) {
    Die("the reference session of " + m.name + " is not the full lossless mesh (level " +
        std::to_string(session->level_shown()) + " of " + std::to_string(session->levels()) + ", " +
        std::to_string(session->predicted_vertices()) + " predicted vertices)");
  }
  return Geometry(session->CurrentScene());
}

// The largest of SingleFileModels(dir) by vertex count (imported, every
// primitive of the scene counted once; the first of equals).
std::string LargestModelByVertices(const std::string& dir, uint64_t* vertices) {
  std::string best;
  uint64_t most = 0;
  std::error_code ec;
  for (const fs::path& p : SingleFileModels(dir)) {
    auto scene = ImportFile(p.string());
    if (!scene.ok()) continue;
    const uint64_t v = scene.value().total_vertices();
    if (v > most) {
      most = v;
      best = fs::relative(p, dir, ec).string();
    }
  }
  if (best.empty()) Die(dir + ": no model could be imported");
  *vertices = most;
  return best;
}

// The large model (Args::shaped_large): the bunny subdivided twice, each
// vertex the subdivisions added moved by up to one grid step of qp 11 along
// each axis (bench/scaling/surface_noise.h), written as a PLY into the work
// folder (overwritten by the next run) and read back as a model file.
Model LargeModel(const Args& args) {
  Scene scene = Check(ImportFile(args.models_dir + "/stanford-bunny.obj"), "the bunny");
  const Primitive& mesh = scene.meshes.at(0).primitives.at(0);
  Primitive plain;
  plain.positions = mesh.positions;
  plain.indices = mesh.indices;
  const size_t original = plain.positions.size();
  for (int level = 0; level < 2; ++level) plain = SubdivideMidpoint(plain);
  plain = WithGridNoise(plain, original, 1.0, 11, 2002);
  const std::string file = "bunny-scan-557k.ply";
  const Status written = WriteMeshFile(SceneFromPrimitive(plain, "bunny-scan-557k"), args.work_dir + "/" + file);
  if (!written.ok()) Die("writing the large model: " + written.ToString());
  return LoadModel(args.work_dir, file, {"large"});  // the file stays: the ingest reads it
}

// The shaped part's models: the bunny and the horse (those of `models`), and
// the largest shared model by vertices (a new Model when it is neither);
// filtered by --model.
std::vector<Model> ShapedModels(const Args& args, const std::vector<Model>& models, json* chosen) {
  uint64_t vertices = 0;
  const std::string largest = LargestModelByVertices(args.models_dir, &vertices);
  *chosen = {{"largest_by_vertices", largest}, {"its_imported_vertices", vertices}};
  std::vector<Model> out;
  for (const Model& m : models) {
    Model c = m;
    c.roles.erase(std::remove(c.roles.begin(), c.roles.end(), "largest"), c.roles.end());
    if (m.path == args.models_dir + "/" + largest) c.roles.push_back("largest");
    if (!c.roles.empty()) out.push_back(std::move(c));
  }
  if (std::none_of(out.begin(), out.end(), [](const Model& m) { return IsLargest(m); })) {
    out.push_back(LoadModel(args.models_dir, largest, {"largest"}));
  }
  if (args.shaped_large) out.push_back(LargeModel(args));
  KeepOnly(args.only, out);
  return out;
}

// Per model: ingested when the loopback parts did not, its reference mesh,
// the Draco export (which warms the export cache) decoded, the source file;
// returns the "models" array.
json PrepareModels(const std::string& address, std::vector<Model>& models, ShapedMeshes& meshes) {
  json model_info = json::array();
  for (Model& m : models) {
    if (m.version == 0) {
      std::fprintf(stderr, "meshstream_bench_stream: shaped link: ingest %s (%zu bytes)\n", m.file.c_str(),
                   m.bytes.size());
      Ingest(address, m);
    }
    const Primitive& reference = meshes.reference[m.name] = ReferenceMesh(address, m);
    meshes.reference_hash[m.name] = MeshHash(reference);
    AssetApi api(address);
    const AssetApi::Exported e = Check(api.Export(m.name, m.version, v1::FORMAT_DRACO_GLB),
                                       "the Draco export of " + m.name);
    meshes.draco[m.name] = Geometry(Check(ImportGltfBytes(e.bytes, "", m.name + ".glb", ImportOptions()),
                                          "decoding the Draco GLB of " + m.name));
    meshes.source[m.name] = Geometry(Check(ImportFile(m.path), m.path));
    json levels = json::array();
    for (int64_t v : m.info.level_vertices()) levels.push_back(v);
    model_info.push_back({{"name", m.name},
                          {"file", m.file},
                          {"roles", m.roles},
                          {"version", m.version},
                          {"vertices", m.info.vertices()},
                          {"faces", m.info.faces()},
                          {"levels", m.info.levels()},
                          {"level_vertices", levels},
                          {"progressive_bytes", m.info.progressive_bytes()},
                          {"reliable_bytes", m.info.reliable_bytes()},
                          {"unreliable_bytes", m.info.unreliable_bytes()},
                          {"draco_glb_bytes", e.bytes.size()},
                          {"flattened_vertices", reference.positions.size()},
                          {"flattened_faces", reference.indices.size() / 3}});
  }
  return model_info;
}

// The server on the veth's host address; Die when it cannot start.
void StartServer(const Args& args, const std::string& store, Link& link) {
  link.options = StreamServerOptions(args, store, &link.log);
  link.options.listen = link.ns->host_ip() + ":0";
  link.options.insecure = true;  // a veth address, no authentication: the benchmark's own namespace
  link.options.server_id = "bench-stream-shaped";
  std::fprintf(stderr, "meshstream_bench_stream: shaped link: server on %s, clients in namespace %s (%s)\n",
               link.options.listen.c_str(), link.ns->name().c_str(), link.ns->ns_ip().c_str());
  link.server = Check(Server::Start(link.options), "shaped server");
  link.address = link.server->address();
}

// The UDP relay and the TCP delay proxy, both delaying --shaped-delay-ms.
void StartRelayAndProxy(const Args& args, Link& link) {
  link.udp_upstream = Check(SocketAddress::Parse(link.server->udp_address()), "the UDP endpoint");
  test_util::RelayOptions ro;
  ro.upstream = link.udp_upstream;
  ro.bind = link.ns->host_ip() + ":0";
  ro.to_server.delay_us = ro.to_client.delay_us = static_cast<uint64_t>(args.shaped_delay_ms * 1000);
  link.relay = Check(test_util::UdpRelay::Start(ro), "the UDP relay");
  TcpDelayProxyOptions po;
  po.listen = link.ns->host_ip() + ":0";
  po.upstream = link.address;
  po.delay_us = static_cast<uint64_t>(args.shaped_delay_ms * 1000);
  link.proxy = Check(TcpDelayProxy::Start(po), "the TCP delay proxy");
  link.udp_via = link.relay->front().ToString();
  std::fprintf(stderr, "meshstream_bench_stream: shaped link: gRPC via %s, UDP via %s, %.0f Mbit/s, %.0f ms each way\n",
               link.proxy->address().c_str(), link.udp_via.c_str(), args.shaped_rate_mbit, args.shaped_delay_ms);
}

// What crossed the proxy's client-facing connections closed since
// `closed_before` (the child's connections close when it exits; the proxy
// sees it a moment later).
json WireTcp(const TcpDelayProxy& proxy, size_t closed_before) {
  const auto close_deadline = Clock::now() + std::chrono::seconds(3);
  while (proxy.closed().size() < proxy.accepted() && Clock::now() < close_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const std::vector<TcpConnectionInfo> conns = proxy.closed();
  uint64_t down = 0, up = 0, retrans = 0;
  double srtt = 0;
  for (size_t c = closed_before; c < conns.size(); ++c) {
    down += conns[c].bytes_to_client;
    up += conns[c].bytes_to_server;
    retrans += conns[c].total_retrans;
    srtt = std::max(srtt, conns[c].rtt_ms);
  }
  return {{"connections", conns.size() - closed_before},
          {"bytes_to_client", down},
          {"bytes_to_server", up},
          {"segments_retransmitted", retrans},
          {"srtt_ms_max", srtt}};
}

// The server's log line of the session that ended after `logged`: its rate
// controller; null when it did not come within 5 s.
json ServerLine(ServerLog& log, size_t logged) {
  if (!log.WaitSessions(logged + 1, std::chrono::seconds(5))) return nullptr;
  const std::vector<SessionLogLine> lines = log.SessionsFrom(logged);
  const SessionLogLine& s = lines.back();
  return {{"reason", s.reason},          {"transport", s.transport},
          {"datagrams_sent", s.datagrams_sent}, {"reports", s.reports},
          {"missing", s.missing},        {"final_rate_mbps", s.rate_mbps},
          {"decreases", s.decreases},    {"srtt_ms", s.srtt_ms}};
}

// Which run of the matrix a child is.
struct RunId {
  int loss = 0, run = 0;
  const Model* model = nullptr;
  const char* kind = "";
  std::string view;  // the view run's camera: EX,EY,EZ,TX,TY,TZ,FOV,W,H
};

// The view run's camera for `reference`: outside the low end of the box's
// longest axis, looking along it at the point a quarter of the way in, a
// narrow field of view (30 degrees, 1280 x 720): one side of the model is
// seen, the other is outside the frustum or far.
std::string ViewArg(const Primitive& reference) {
  Vec3d lo = {INFINITY, INFINITY, INFINITY}, hi = {-INFINITY, -INFINITY, -INFINITY};
  for (const Vec3f& p : reference.positions) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(p[a]));
      hi[a] = std::max(hi[a], double(p[a]));
    }
  }
  int axis = 0;
  for (int a = 1; a < 3; ++a) {
    if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
  }
  Vec3d eye, target;
  for (int a = 0; a < 3; ++a) eye[a] = target[a] = (lo[a] + hi[a]) / 2;
  const double extent = hi[axis] - lo[axis];
  target[axis] = lo[axis] + 0.25 * extent;
  eye[axis] = lo[axis] - 0.6 * extent;
  char text[512];
  std::snprintf(text, sizeof text, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,30,1280,720", eye[0], eye[1], eye[2], target[0],
                target[1], target[2]);
  return text;
}

// One child in the namespace: its JSON line, with what crossed the link for
// it (the gRPC probe calls and the channel set-up included) and the
// server's line of its session.
json RunChild(const Args& args, Link& link, const RunId& id, const std::string& snapshot_file, double remembered) {
  static const std::string self = fs::read_symlink("/proc/self/exe").string();
  const std::vector<std::string> cargs = {self,           "--shaped-client",          id.kind,
                                          link.proxy->address(), link.udp_via,        id.model->name,
                                          std::to_string(id.model->version),          snapshot_file,
                                          std::to_string(args.shaped_snapshots),      std::to_string(args.shaped_timeout_s),
                                          std::to_string(remembered),                 id.view};
  std::string command;
  for (const std::string& a : cargs) command += (command.empty() ? "" : " ") + ShellQuote(a);
  const size_t logged = link.log.session_count();
  const size_t closed_before = link.proxy->closed().size();
  const test_util::RelayCounters down0 = link.relay->to_client(), up0 = link.relay->to_server();
  const auto t0 = Clock::now();
  auto [text, code] = Capture(link.ns->Inside(command));
  const double child_ms = Ms(t0, Clock::now());
  const json wire_tcp = WireTcp(*link.proxy, closed_before);
  const test_util::RelayCounters down1 = link.relay->to_client(), up1 = link.relay->to_server();
  json r = json::parse(text.substr(0, text.find('\n')), nullptr, false);
  if (code != 0 || r.is_discarded() || !r.is_object()) {
    r = {{"kind", id.kind}, {"ok", false}, {"error", "the client process failed (exit " + std::to_string(code) + ")"}};
  }
  r["loss_percent"] = id.loss;
  r["model"] = id.model->name;
  if (!id.view.empty()) r["view"] = id.view;
  r["run"] = id.run;
  r["child_process_ms"] = child_ms;
  if (std::string(id.kind) != "draco_export") r["expected_loss_stated"] = remembered;
  r["wire"] = {{"tcp", wire_tcp},
               {"udp", {{"datagrams_to_client", down1.forwarded - down0.forwarded},
                        {"bytes_to_client", down1.bytes - down0.bytes},
                        {"datagrams_to_server", up1.forwarded - up0.forwarded}}}};
  if (std::string(id.kind) != "draco_export") {
    json line = ServerLine(link.log, logged);
    if (!line.is_null()) r["server"] = std::move(line);
  }
  return r;
}

// The runs of the matrix, and per loss what the proxy and the relay saw.
struct Runs {
  json runs = json::array();
  std::vector<std::string> snapshot_files;  // per run, "" when none
  json per_loss = json::array();
  uint64_t failures = 0;
};

void LogRun(const json& r, const RunId& id, size_t done, size_t total) {
  const bool ok = r.value("ok", false);
  std::fprintf(stderr, "meshstream_bench_stream: shaped %3zu/%zu: %2d %% loss, run %d, %s %s: %s\n", done, total,
               id.loss, id.run + 1, id.model->name.c_str(), id.kind,
               ok ? (std::to_string(static_cast<int>(r.value("first_ms", 0.0))) + " ms first, " +
                     std::to_string(static_cast<int>(r.value("full_ms", 0.0))) + " ms full")
                        .c_str()
                  : ("FAILED: " + r.value("error", std::string("?"))).c_str());
}

// The TCP side of one loss level: what the kernel said of the proxy's
// client-facing connections closed since `proxy_before`; the UDP side: the
// relay's counters since up0, down0.
json LossLevelJson(int loss, Clock::time_point loss_start, const Link& link, size_t proxy_before,
                   const test_util::RelayCounters& up0, const test_util::RelayCounters& down0) {
  const std::vector<TcpConnectionInfo> closed = link.proxy->closed();
  std::vector<double> rtts;
  uint64_t retrans = 0, to_client = 0;
  for (size_t i = proxy_before; i < closed.size(); ++i) {
    rtts.push_back(closed[i].rtt_ms);
    retrans += closed[i].total_retrans;
    to_client += closed[i].bytes_to_client;
  }
  const test_util::RelayCounters up1 = link.relay->to_server(), down1 = link.relay->to_client();
  return {{"loss_percent", loss},
          {"wall_s", Ms(loss_start, Clock::now()) / 1000},
          {"proxy", {{"connections_closed", closed.size() - proxy_before},
                     {"srtt_ms_median", Median(rtts)},
                     {"srtt_ms_max", rtts.empty() ? 0.0 : *std::max_element(rtts.begin(), rtts.end())},
                     {"bytes_to_clients", to_client},
                     {"segments_retransmitted", retrans}}},
          {"relay", {{"to_server_forwarded", up1.forwarded - up0.forwarded},
                     {"to_client_forwarded", down1.forwarded - down0.forwarded},
                     {"to_client_bytes", down1.bytes - down0.bytes}}}};
}

// A UDP run's raw loss into `memory`, as sdk::Client adds its sessions'.
void Remember(const json& r, sdk::LossMemory& memory) {
  if (!r.contains("stats")) return;
  memory.Add(r["stats"].value("datagrams_lost", uint64_t{0}), r["stats"].value("udp_datagrams_received", uint64_t{0}));
}

// Every loss, run, model and kind, one child at a time. Each child is a
// new process, so the loss a long-lived client would remember from its
// sessions (sdk::Client::remembered_loss) is passed to it: the UDP runs',
// across models and loss levels (the first run of a level states what the
// levels before it left).
Runs RunMatrix(const Args& args, Link& link, const std::vector<Model>& models, const ShapedMeshes& meshes,
               const std::string& snap_dir) {
  Runs out;
  sdk::LossMemory memory;
  size_t large = 0;
  for (const Model& m : models) large += std::count(m.roles.begin(), m.roles.end(), std::string("large"));
  const size_t total = args.shaped_losses.size() * static_cast<size_t>(args.shaped_runs) *
                       (models.size() * std::size(kShapedKinds) + large);
  size_t done = 0;
  for (int loss : args.shaped_losses) {
    const Status l = link.ns->SetLoss(loss, args.shaped_udp_only_loss);
    if (!l.ok()) Die("nft: " + l.message());
    const size_t proxy_before = link.proxy->closed().size();
    const test_util::RelayCounters up0 = link.relay->to_server(), down0 = link.relay->to_client();
    const auto loss_start = Clock::now();
    for (int run = 0; run < args.shaped_runs; ++run) {
      for (const Model& m : models) {
        std::vector<RunId> ids;
        for (const char* kind : kShapedKinds) ids.push_back(RunId{loss, run, &m, kind, ""});
        if (std::find(m.roles.begin(), m.roles.end(), "large") != m.roles.end()) {
          ids.push_back(RunId{loss, run, &m, kShapedViewKind, ViewArg(meshes.reference.at(m.name))});
        }
        for (const RunId& id : ids) {
          const char* kind = id.kind;
          const std::string file = snap_dir + "/" + std::to_string(out.runs.size()) + ".snap";
          json r = RunChild(args, link, id, file, memory.Rate());
          if (std::string(kind).rfind("udp", 0) == 0) Remember(r, memory);
          if (!r.value("ok", false)) ++out.failures;
          LogRun(r, id, ++done, total);
          out.snapshot_files.push_back(fs::exists(file) ? file : "");
          out.runs.push_back(std::move(r));
        }
      }
    }
    out.per_loss.push_back(LossLevelJson(loss, loss_start, link, proxy_before, up0, down0));
  }
  return out;
}

// Stops the relay, the proxy and the server; the server's UDP totals line.
std::string StopLink(Link& link) {
  (void)link.ns->SetLoss(0, false);
  link.relay->Stop();
  link.proxy->Stop();
  return StopAndTakeUdpTotals(link.server, link.log);
}

json SettingsJson(const Args& args, const json& chosen, const Link& link) {
  return {{"losses_percent", args.shaped_losses},
          {"runs", args.shaped_runs},
          {"rate_mbit", args.shaped_rate_mbit},
          {"delay_ms_each_way", args.shaped_delay_ms},
          {"max_snapshots", args.shaped_snapshots},
          {"samples_per_side", args.shaped_samples},
          {"session_timeout_s", args.shaped_timeout_s},
          {"models_chosen", chosen},
          {"server", {{"listen", link.address},
                      {"udp", link.udp_upstream.ToString()},
                      {"hello_timeout_ms", link.options.hello_timeout_ms},
                      {"max_rate_bps", link.options.max_rate_bps},
                      {"max_session_rate_bps", link.options.max_session_rate_bps}}},
          {"grpc_via", link.proxy->address()},
          {"udp_via", link.udp_via},
          {"loss_udp_only", args.shaped_udp_only_loss},
          {"loss_rule", std::string("nft, in the namespace's input hook: ") +
                            (args.shaped_udp_only_loss ? "meta l4proto udp " : "") + "numgen random mod 100 < P drop" +
                            (args.shaped_udp_only_loss ? " (UDP only)" : " (TCP and UDP)")},
          {"rate_rule", "tc tbf on both veth ends: rate R burst 32kbit latency 100ms"}};
}

// The namespace with tbf on both ends; the reason when it cannot be made.
StatusOr<std::unique_ptr<test_util::NetNs>> MakeNamespace(const Args& args) {
  MS_ASSIGN_OR_RETURN(std::unique_ptr<test_util::NetNs> ns, test_util::NetNs::Create());
  const Status rate = ns->SetRate(args.shaped_rate_mbit);
  if (!rate.ok()) return rate.WithContext("tc tbf");
  return ns;
}

}  // namespace

json RunShaped(const Args& args, const std::string& store, const std::string& folder,
               const std::vector<Model>& main_models) {
  const auto start = Clock::now();
  Link link(args.verbose);
  auto ns = MakeNamespace(args);
  if (!ns.ok()) {
    std::fprintf(stderr, "meshstream_bench_stream: shaped link SKIPPED: %s\n", ns.status().message().c_str());
    return {{"skipped", ns.status().message()}};
  }
  link.ns = std::move(ns).value();
  json chosen;
  std::vector<Model> models = ShapedModels(args, main_models, &chosen);
  if (models.empty()) return {{"skipped", "no model left (see --model)"}};

  StartServer(args, store, link);
  ShapedMeshes meshes;
  json model_info = PrepareModels(link.address, models, meshes);
  StartRelayAndProxy(args, link);
  const std::string snap_dir = folder + "/shaped-snapshots";
  fs::create_directories(snap_dir);
  Runs runs = RunMatrix(args, link, models, meshes, snap_dir);
  const std::string udp_totals = StopLink(link);
  const json notable = link.log.Notable(30);
  link.ns.reset();  // the namespace and its veth go
  const double sessions_s = Ms(start, Clock::now()) / 1000;

  const DistanceCounts distances =
      MeasureShapedDistances(models, meshes, runs.snapshot_files, args.shaped_samples, runs.runs, model_info);
  json out;
  out["settings"] = SettingsJson(args, chosen, link);
  out["models"] = model_info;
  out["summary"] = ShapedSummary(args.shaped_losses, models, runs.runs, args.shaped_rate_mbit);
  out["runs"] = std::move(runs.runs);
  out["per_loss"] = runs.per_loss;
  out["server"] = {{"udp_totals_line", udp_totals}, {"log_notable", notable}};
  out["failures"] = runs.failures;
  out["distinct_meshes_measured"] = distances.distinct_meshes;
  out["snapshots"] = distances.snapshots;
  out["distance_s"] = distances.seconds;
  out["sessions_s"] = sessions_s;
  out["wall_s"] = Ms(start, Clock::now()) / 1000;
  return out;
}

}  // namespace meshstream::bench::stream

// meshstream_bench_stream: the benchmark of the streaming sessions
// (docs/stream-benchmarks.md).
//
// One process runs everything on one machine, in one run:
//   - a meshstream server (Server::Start, in-process, 2 workers, UDP on the
//     next port) on the embedded store (SQLite + blob folder) in a
//     temporary folder; the models are ingested once, before anything is
//     timed: the bunny, the horse and the largest single-file model of the
//     shared folder (by file size);
//   - the clients: threads of this process, each with its own sdk::Client
//     (or AssetClient for the reference).
// What it measures:
//   1. per model and number of concurrent sessions (1, 10, 100): SDK
//      sessions over UDP and over the gRPC stream (tcp_only), each polled
//      to kComplete on its own thread: time to the base mesh and to the
//      full mesh (SessionStats), p50 and p99, the datagrams lost per
//      session over loopback; beside them, in the same rounds, the
//      reference: the same version exported as FORMAT_DRACO_GLB through the
//      same server's AssetService.Export (time to the last byte; the export
//      cache warm, as a server serving that file would have it), and the
//      ratios of both times to it;
//   2. the server's DATA datagrams per second (wall and per CPU-second) with
//      N sessions over UDP on a server started with a high --max-rate and
//      --max-session-rate on the same store, beside the loopback limit: a
//      tight sendmmsg loop of 1200-byte datagrams between two UDP sockets
//      on 127.0.0.1 (net/udp_socket.h), the receiver draining with recvmmsg
//      on another thread;
//   3. the shaped, lossy link (--shaped, the default; skipped with the
//      system's reason where a network namespace cannot be made): a server
//      on the host side of a veth pair, each session (UDP and tcp_only) and
//      each Draco GLB download in a child process inside the namespace,
//      tbf on both ends, nftables dropping 0, 2, 5 and 12 % of TCP and UDP,
//      the same one-way delay on both channels (the UDP relay, the TCP delay
//      proxy); per model (the bunny, the horse, the largest shared model by
//      vertices) the time to the first visible mesh and to the full mesh,
//      and the Hausdorff distance of what is shown over time to the full
//      lossless mesh (snapshots at the events, measured after the runs).
// A session that ends in kError (or does not reach the full mesh, or takes
// longer than the deadline) and an export that fails are counted and
// reported ("failures"; the shaped link's in "shaped"), never timed.
// Writes one JSON object (--out, default docs/bench/stream.json);
// bench/plot_stream.py draws it.
#include <sqlite3.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <google/protobuf/stubs/common.h>
#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/service_load.h"
#include "bench/service_machine.h"
#include "bench/service_stats.h"
#include "bench/tcp_delay_proxy.h"
#include "codec/mesh/scene_flatten.h"
#include "codec/metrics/hausdorff.h"
#include "importers/gltf_import.h"
#include "importers/import.h"
#include "meshstream/v1/asset_service.grpc.pb.h"
#include "net/udp_socket.h"
#include "sdk/client.h"
#include "sdk/session.h"
#include "services/server/server.h"
#include "services/store/blob_store.h"
#include "testing/asset_client.h"
#include "testing/netns.h"
#include "testing/udp_relay.h"

namespace {

using json = nlohmann::json;
namespace ms = meshstream;
namespace v1 = meshstream::v1;
namespace fs = std::filesystem;
using ms::bench::Check;
using ms::bench::Clock;
using ms::bench::Die;
using ms::bench::FirstLineOf;
using ms::bench::Ms;
using ms::bench::NearestRank;
using ms::bench::ParseDouble;
using ms::bench::ParseInt;
using ms::bench::ShellQuote;
using ms::bench::SplitList;
using ms::test_util::AssetClient;

const char kHelp[] =
    "usage: meshstream_bench_stream [--quick] [--models DIR] [--model NAME]... [--concurrency 1,10,100]\n"
    "                               [--samples N] [--min-rounds N] [--largest-rounds-at-100 N]\n"
    "                               [--rate-sessions N] [--rate-seconds S] [--rate-bps BPS]\n"
    "                               [--loopback-seconds S] [--session-timeout-s S] [--workers N]\n"
    "                               [--work-dir DIR] [--out FILE] [--verbose]\n"
    "                               [--shaped | --no-shaped | --only-shaped] [--shaped-runs N]\n"
    "                               [--shaped-rate MBIT] [--shaped-delay-ms MS] [--shaped-loss LIST]\n"
    "                               [--shaped-loss-udp-only] [--shaped-snapshots N] [--shaped-samples N]\n"
    "                               [--shaped-timeout-s S]\n"
    "\n"
    "Benchmarks the streaming sessions (meshstream serve, in this process, SQLite store) against\n"
    "the Draco GLB export of the same server and the loopback's sendmmsg limit, measured in the\n"
    "same run, and then over a shaped, lossy link (a network namespace; skipped, with the reason,\n"
    "where namespaces cannot be made); writes one JSON object (default docs/bench/stream.json).\n"
    "  --quick             a short run: --samples 20 --min-rounds 1 --largest-rounds-at-100 1, 1 s\n"
    "                      rate and loopback runs (about 25 s), --shaped-runs 2 (about 80 s)\n"
    "  --models DIR        folder of the shared models (default: the build's MESHSTREAM_MODELS_DIR)\n"
    "  --model NAME        only this model (file stem, e.g. horse); repeatable\n"
    "  --concurrency LIST  concurrent sessions of the latency rows (default 1,10,100)\n"
    "  --samples N         timed sessions per row at least: ceil(N / sessions) rounds (default 200)\n"
    "  --min-rounds N      rounds per row at least (default 3)\n"
    "  --largest-rounds-at-100 N  rounds of the largest model's rows at 100 or more sessions instead\n"
    "                      (default 2; --quick: 1)\n"
    "  --rate-sessions N   concurrent UDP sessions of the datagram-rate run (default 10)\n"
    "  --rate-seconds S    how long each of them opens session after session (default 4)\n"
    "  --rate-bps BPS      --max-rate and --max-session-rate of the rate run's server (default 1e10)\n"
    "  --loopback-seconds S  each sendmmsg loopback run, one before and one after (default 2)\n"
    "  --session-timeout-s S  a session or export not complete by then is a failure (default 120)\n"
    "  --workers N         job workers of the server (default 2; also its concurrent decoding exports)\n"
    "  --work-dir DIR      where the store lives (default: $TMPDIR or /tmp)\n"
    "  --verbose           the server's log lines on stderr\n"
    "The shaped link (needs root: ip netns, nft, tc tbf):\n"
    "  --shaped, --no-shaped  run it (default) or not; --only-shaped: only it (into the --out file\n"
    "                      of an earlier full run when there is one: its other parts are kept)\n"
    "  --shaped-runs N     runs per loss, model and kind (default 5; --quick: 2)\n"
    "  --shaped-rate MBIT  tbf rate on both veth ends (default 20)\n"
    "  --shaped-delay-ms MS  one-way delay of both channels: UDP relay and TCP proxy (default 20)\n"
    "  --shaped-loss LIST  nftables drop percentages, TCP and UDP (default 0,2,5,12)\n"
    "  --shaped-loss-udp-only  drop UDP only (an experiment: what TCP's losses cost the sessions)\n"
    "  --shaped-snapshots N  meshes kept per session for the distances, base and end included\n"
    "                      (default 12)\n"
    "  --shaped-samples N  surface samples per side of each Hausdorff distance (default 200000)\n"
    "  --shaped-timeout-s S  a session or download not done by then is a failure (default 60)\n";

struct Args {
  std::string models_dir = MESHSTREAM_MODELS_DIR;
  std::vector<std::string> only;
  std::vector<int> concurrency = {1, 10, 100};
  int samples = 200;
  int min_rounds = 3;
  int largest_rounds_at_100 = 2;
  int rate_sessions = 10;
  double rate_seconds = 4;
  double rate_bps = 1e10;
  double loopback_seconds = 2;
  double session_timeout_s = 120;
  int workers = 2;
  std::string work_dir;
  bool quick = false;
  bool verbose = false;
  // 3. the shaped, lossy link
  bool shaped = true;
  bool only_shaped = false;
  int shaped_runs = 5;
  double shaped_rate_mbit = 20;
  double shaped_delay_ms = 20;
  std::vector<int> shaped_losses = {0, 2, 5, 12};
  int shaped_snapshots = 12;
  int64_t shaped_samples = 200000;
  double shaped_timeout_s = 60;
  bool shaped_udp_only_loss = false;
  std::string out = std::string(MESHSTREAM_SOURCE_DIR) + "/docs/bench/stream.json";
};

Args ParseArgs(int argc, char** argv) {
  Args a;
  bool shaped_runs_set = false;
  bool samples_set = false, min_rounds_set = false, rate_s_set = false, loop_s_set = false, largest_set = false;
  ms::bench::ParseFlags(argc, argv, kHelp, [&](const std::string& f, const std::function<std::string()>& next) {
    if (f == "--quick") {
      a.quick = true;
    } else if (f == "--models") {
      a.models_dir = next();
    } else if (f == "--model") {
      a.only.push_back(next());
    } else if (f == "--concurrency") {
      a.concurrency.clear();
      for (const auto& s : SplitList(next())) a.concurrency.push_back(static_cast<int>(ParseInt(s, f, 1, 200)));
      if (a.concurrency.empty()) Die("--concurrency: empty list");
    } else if (f == "--samples") {
      a.samples = static_cast<int>(ParseInt(next(), f, 1, 100000));
      samples_set = true;
    } else if (f == "--min-rounds") {
      a.min_rounds = static_cast<int>(ParseInt(next(), f, 1, 1000));
      min_rounds_set = true;
    } else if (f == "--largest-rounds-at-100") {
      a.largest_rounds_at_100 = static_cast<int>(ParseInt(next(), f, 1, 1000));
      largest_set = true;
    } else if (f == "--rate-sessions") {
      a.rate_sessions = static_cast<int>(ParseInt(next(), f, 1, 200));
    } else if (f == "--rate-seconds") {
      a.rate_seconds = ParseDouble(next(), f);
      if (a.rate_seconds <= 0 || a.rate_seconds > 600) Die("--rate-seconds: (0, 600]");
      rate_s_set = true;
    } else if (f == "--rate-bps") {
      a.rate_bps = ParseDouble(next(), f);
      if (a.rate_bps < 1e6) Die("--rate-bps: at least 1e6");
    } else if (f == "--loopback-seconds") {
      a.loopback_seconds = ParseDouble(next(), f);
      if (a.loopback_seconds <= 0 || a.loopback_seconds > 600) Die("--loopback-seconds: (0, 600]");
      loop_s_set = true;
    } else if (f == "--session-timeout-s") {
      a.session_timeout_s = ParseDouble(next(), f);
      if (a.session_timeout_s <= 0) Die("--session-timeout-s: positive");
    } else if (f == "--workers") {
      a.workers = static_cast<int>(ParseInt(next(), f, 1, 64));
    } else if (f == "--work-dir") {
      a.work_dir = next();
    } else if (f == "--out") {
      a.out = next();
    } else if (f == "--verbose") {
      a.verbose = true;
    } else if (f == "--shaped") {
      a.shaped = true;
    } else if (f == "--no-shaped") {
      a.shaped = false;
    } else if (f == "--only-shaped") {
      a.only_shaped = a.shaped = true;
    } else if (f == "--shaped-runs") {
      a.shaped_runs = static_cast<int>(ParseInt(next(), f, 1, 1000));
      shaped_runs_set = true;
    } else if (f == "--shaped-rate") {
      a.shaped_rate_mbit = ParseDouble(next(), f);
      if (a.shaped_rate_mbit < 0.1 || a.shaped_rate_mbit > 10000) Die("--shaped-rate: 0.1 to 10000 Mbit/s");
    } else if (f == "--shaped-delay-ms") {
      a.shaped_delay_ms = ParseDouble(next(), f);
      if (a.shaped_delay_ms < 0 || a.shaped_delay_ms > 2000) Die("--shaped-delay-ms: 0 to 2000");
    } else if (f == "--shaped-loss") {
      a.shaped_losses.clear();
      for (const auto& s : SplitList(next())) a.shaped_losses.push_back(static_cast<int>(ParseInt(s, f, 0, 99)));
      if (a.shaped_losses.empty()) Die("--shaped-loss: empty list");
    } else if (f == "--shaped-snapshots") {
      a.shaped_snapshots = static_cast<int>(ParseInt(next(), f, 2, 1000));
    } else if (f == "--shaped-samples") {
      a.shaped_samples = ParseInt(next(), f, 0, 100000000);
    } else if (f == "--shaped-loss-udp-only") {
      a.shaped_udp_only_loss = true;
    } else if (f == "--shaped-timeout-s") {
      a.shaped_timeout_s = ParseDouble(next(), f);
      if (a.shaped_timeout_s <= 0) Die("--shaped-timeout-s: positive");
    } else {
      return false;
    }
    return true;
  });
  if (a.quick) {
    if (!samples_set) a.samples = 20;
    if (!min_rounds_set) a.min_rounds = 1;
    if (!largest_set) a.largest_rounds_at_100 = 1;
    if (!rate_s_set) a.rate_seconds = 1;
    if (!loop_s_set) a.loopback_seconds = 1;
    if (!shaped_runs_set) a.shaped_runs = 2;
  }
  if (a.work_dir.empty()) a.work_dir = fs::temp_directory_path().string();
  return a;
}

// ------------------------------------------------------------ the machine

json MachineInfo(const Args& args) {
  json m = ms::bench::ServiceMachineInfo(args.work_dir, MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  m["net_core_rmem_max"] = FirstLineOf("cat /proc/sys/net/core/rmem_max 2>/dev/null");
  m["net_core_wmem_max"] = FirstLineOf("cat /proc/sys/net/core/wmem_max 2>/dev/null");
  return m;
}

// ------------------------------------------------------------- the models

struct Model {
  std::string name;  // the stem: the asset's name
  std::string file;  // the file name in the upload
  std::string path;
  std::vector<std::string> roles;  // "bunny", "horse", "largest"
  std::vector<uint8_t> bytes;
  int64_t version = 0;
  v1::Version info;
};

// The largest single-file model (.obj, .ply, .glb: a .gltf would need its
// resources) anywhere under `dir`, by file size; its path relative to dir.
std::string LargestModel(const std::string& dir) {
  std::string best;
  uintmax_t best_size = 0;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const std::string ext = it->path().extension().string();
    if (ext != ".obj" && ext != ".ply" && ext != ".glb") continue;
    const uintmax_t size = it->file_size(ec);
    if (!ec && size > best_size) {
      best_size = size;
      best = fs::relative(it->path(), dir, ec).string();
    }
  }
  if (best.empty()) Die(dir + ": no .obj, .ply or .glb model");
  return best;
}

// The horse's file: the first "horse.*" of the folder's models.
std::string HorseModel(const std::string& dir) {
  for (const char* ext : {".ply", ".obj", ".glb"}) {
    std::error_code ec;
    if (fs::is_regular_file(fs::path(dir) / (std::string("horse") + ext), ec)) return std::string("horse") + ext;
  }
  Die(dir + ": no horse model (horse.ply, horse.obj or horse.glb)");
}

std::vector<Model> ChooseModels(const Args& args) {
  std::vector<std::pair<std::string, std::string>> wanted = {
      {"stanford-bunny.obj", "bunny"}, {HorseModel(args.models_dir), "horse"}, {LargestModel(args.models_dir), "largest"}};
  std::vector<Model> models;
  for (const auto& [relative, role] : wanted) {
    auto it = std::find_if(models.begin(), models.end(), [&](const Model& m) { return m.path == args.models_dir + "/" + relative; });
    if (it != models.end()) {
      it->roles.push_back(role);
      continue;
    }
    Model m;
    m.path = args.models_dir + "/" + relative;
    m.file = fs::path(relative).filename().string();
    m.name = ms::bench::Stem(relative);
    m.roles = {role};
    models.push_back(m);
  }
  if (!args.only.empty() && !args.only_shaped) {  // the shaped part filters its own
    models.erase(std::remove_if(models.begin(), models.end(),
                                [&](const Model& m) {
                                  return std::find(args.only.begin(), args.only.end(), m.name) == args.only.end();
                                }),
                 models.end());
  }
  if (models.empty()) Die("no model left (see --model)");
  for (Model& m : models) m.bytes = Check(ms::ReadFileBytes(m.path, uint64_t{1} << 30), m.path);
  return models;
}

bool IsLargest(const Model& m) { return std::find(m.roles.begin(), m.roles.end(), "largest") != m.roles.end(); }

// ------------------------------------------------------------- the server

// The server's log lines, and what each "session ... ended" line says.
struct SessionLogLine {
  std::string asset, reason, transport;
  uint64_t datagrams_sent = 0, reports = 0, missing = 0;
  double rate_mbps = 0, srtt_ms = 0;
  unsigned decreases = 0;
};

struct ServerLog {
  std::mutex mutex;
  std::vector<std::string> lines;
  std::vector<SessionLogLine> sessions;
  bool verbose = false;

  void Add(const std::string& line) {
    std::lock_guard<std::mutex> lock(mutex);
    lines.push_back(line);
    if (verbose) std::fprintf(stderr, "[server] %s\n", line.c_str());
    // "session ASSET@V ended (REASON): TRANSPORT, N datagrams sent, R reports, M missing, rate X Mbit/s, D
    // decreases, srtt S ms"
    if (line.rfind("session ", 0) != 0) return;
    const size_t ended = line.find(" ended (");
    const size_t close = line.find("): ", ended == std::string::npos ? 0 : ended);
    if (ended == std::string::npos || close == std::string::npos) return;
    SessionLogLine s;
    s.asset = line.substr(8, ended - 8);
    s.reason = line.substr(ended + 8, close - ended - 8);
    char transport[16] = {0};
    unsigned long long sent = 0, reports = 0, missing = 0;
    if (std::sscanf(line.c_str() + close + 3,
                    "%15[a-z], %llu datagrams sent, %llu reports, %llu missing, rate %lf Mbit/s, %u decreases, srtt "
                    "%lf ms",
                    transport, &sent, &reports, &missing, &s.rate_mbps, &s.decreases, &s.srtt_ms) != 7) {
      return;
    }
    s.transport = transport;
    s.datagrams_sent = sent;
    s.reports = reports;
    s.missing = missing;
    sessions.push_back(s);
  }
  size_t session_count() {
    std::lock_guard<std::mutex> lock(mutex);
    return sessions.size();
  }
  // Waits (at most `timeout`) until at least `n` session lines were logged.
  bool WaitSessions(size_t n, std::chrono::milliseconds timeout) {
    const auto until = Clock::now() + timeout;
    while (session_count() < n) {
      if (Clock::now() > until) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return true;
  }
  std::vector<SessionLogLine> SessionsFrom(size_t first) {
    std::lock_guard<std::mutex> lock(mutex);
    return std::vector<SessionLogLine>(sessions.begin() + static_cast<long>(std::min(first, sessions.size())),
                                       sessions.end());
  }
  // Lines that are neither a session that completed nor the start-up lines.
  json Notable(size_t limit) {
    std::lock_guard<std::mutex> lock(mutex);
    json out = json::array();
    for (const std::string& l : lines) {
      const bool routine_session = l.rfind("session ", 0) == 0 && l.find(" ended (complete)") != std::string::npos;
      if (routine_session) continue;
      if (out.size() < limit) out.push_back(l);
    }
    return out;
  }
};

ms::ServerOptions BaseServerOptions(const Args& args, const std::string& store, ServerLog* log) {
  ms::ServerOptions o;
  o.listen = "127.0.0.1:0";
  o.store = store;
  o.workers = args.workers;
  o.reflection = false;
  o.grace_period_s = 10;
  o.server_id = "bench-stream";
  o.log = [log](const std::string& line) { log->Add(line); };
  return o;
}

void StopServer(std::unique_ptr<ms::Server>& server) {
  if (!server) return;
  server->Drain();
  server->Wait();
  server.reset();
}

std::string StatusText(const grpc::Status& s) {
  return "status " + std::to_string(s.error_code()) + ": " + s.error_message();
}

void Ingest(const std::string& address, Model& m) {
  AssetClient client(address);
  v1::IngestResponse response;
  const grpc::Status s = client.Ingest(m.name, ms::test_util::UploadFile{m.file, m.bytes}, &response);
  if (!s.ok()) Die("ingest " + m.file + ": " + StatusText(s));
  v1::Job job;
  const grpc::Status w = client.Watch(response.job_id(), &job);
  if (!w.ok() || job.state() != v1::JOB_STATE_SUCCEEDED) {
    Die("ingest " + m.file + ": the job did not succeed: " + (w.ok() ? job.message() : StatusText(w)));
  }
  m.version = response.version();
  const grpc::Status g = client.GetVersion(m.name, m.version, &m.info);
  if (!g.ok()) Die("GetVersion " + m.name + ": " + StatusText(g));
}

// ------------------------------------------------------------ the clients

// The kernel's UDP counters of this network namespace (/proc/net/snmp,
// "Udp:"): every UDP socket of the machine's namespace, so the benchmark's
// own; a delta says how many datagrams the kernel dropped, and why.
std::map<std::string, uint64_t> KernelUdp() {
  std::ifstream f("/proc/net/snmp");
  std::string names, values, line;
  while (std::getline(f, line)) {
    if (line.rfind("Udp: ", 0) != 0) continue;
    if (names.empty()) {
      names = line.substr(5);
    } else {
      values = line.substr(5);
      break;
    }
  }
  std::map<std::string, uint64_t> out;
  std::istringstream n(names), v(values);
  std::string name;
  uint64_t value = 0;
  while (n >> name && v >> value) out[name] = value;
  return out;
}

json KernelUdpDelta(const std::map<std::string, uint64_t>& before, const std::map<std::string, uint64_t>& after) {
  json out = json::object();
  for (const char* key : {"InDatagrams", "OutDatagrams", "InErrors", "RcvbufErrors", "SndbufErrors", "MemErrors"}) {
    auto a = after.find(key), b = before.find(key);
    if (a != after.end() && b != before.end()) out[key] = a->second - b->second;
  }
  return out;
}

double ThreadCpuS() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) / 1e9;
}

// Releases every waiting thread at once, when the main thread says so.
class StartGate {
 public:
  void Arrive() {
    std::unique_lock<std::mutex> lock(mutex_);
    ++arrived_;
    cv_.notify_all();
    cv_.wait(lock, [this] { return open_; });
  }
  void OpenWhen(int n) {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [&] { return arrived_ >= n; });
    open_ = true;
    cv_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  int arrived_ = 0;
  bool open_ = false;
};

enum class Kind { kUdp, kTcp, kDraco };
const char* KindName(Kind k) { return k == Kind::kUdp ? "udp" : k == Kind::kTcp ? "tcp_only" : "draco_export"; }

struct Outcome {
  bool ok = false;
  std::string error;
  double base_ms = 0;  // sessions: time_to_base_ms
  double full_ms = 0;  // sessions: time_to_full_ms; exports: request until the last byte
  double wall_ms = 0;  // measured here: before Open (or the export call) until kComplete (the last chunk)
  double thread_cpu_s = 0;  // CPU of the calling thread (the SDK decodes there)
  ms::sdk::SessionStats stats;
  int32_t level = 0, levels = 0;
  uint64_t predicted_vertices = 0;  // at kComplete: vertices whose value was predicted, not decoded
  uint64_t bytes = 0;
};

// One SDK session to kComplete; `client` made before the gate opens.
Outcome RunSession(const ms::sdk::Client& client, const Model& m, bool tcp_only, double timeout_s) {
  Outcome o;
  const double cpu0 = ThreadCpuS();
  const auto t0 = Clock::now();
  ms::sdk::SessionOptions so;
  so.asset = m.name;
  so.version = m.version;
  so.tcp_only = tcp_only;
  auto session = ms::sdk::Session::Open(client, so);
  if (!session.ok()) {
    o.error = "Session::Open: " + session.status().ToString();
    return o;
  }
  ms::sdk::Session& s = *session.value();
  const auto deadline = t0 + std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000));
  bool based = false;
  for (;;) {
    if (Clock::now() > deadline) {
      o.error = "not complete after " + std::to_string(static_cast<int>(timeout_s)) + " s (level " +
                std::to_string(s.level_shown()) + ")";
      s.Cancel();
      break;
    }
    const ms::sdk::Event e = s.Poll(500);
    if (e.type == ms::sdk::EventType::kBaseReady) based = true;
    if (e.type == ms::sdk::EventType::kError) {
      o.error = "kError: " + e.status.ToString();
      break;
    }
    if (e.type == ms::sdk::EventType::kComplete) {
      o.wall_ms = Ms(t0, Clock::now());
      o.stats = s.stats();
      o.level = s.level_shown();
      o.levels = s.levels();
      o.predicted_vertices = s.predicted_vertices();
      if (!based) {
        o.error = "kComplete without kBaseReady";
      } else if (o.level < o.levels) {
        o.error = "kComplete at level " + std::to_string(o.level) + " of " + std::to_string(o.levels) +
                  " (end reason '" + o.stats.end_reason + "')";
      } else {
        o.ok = true;
        o.base_ms = o.stats.time_to_base_ms;
        o.full_ms = o.stats.time_to_full_ms;
      }
      break;
    }
  }
  o.thread_cpu_s = ThreadCpuS() - cpu0;
  return o;
}

// One export of the version as FORMAT_DRACO_GLB until the last chunk, its
// bytes checked against the SHA-256 the server sent.
Outcome RunExport(AssetClient& client, const Model& m, const std::string& expect_sha256) {
  Outcome o;
  const double cpu0 = ThreadCpuS();
  const auto t0 = Clock::now();
  AssetClient::Exported e = client.Export(m.name, m.version, v1::FORMAT_DRACO_GLB);
  o.full_ms = o.wall_ms = Ms(t0, Clock::now());
  o.thread_cpu_s = ThreadCpuS() - cpu0;
  if (!e.status.ok()) {
    o.error = "Export FORMAT_DRACO_GLB: " + StatusText(e.status);
    return o;
  }
  const std::string digest = ms::Sha256Hex(e.bytes.data(), e.bytes.size());
  if (digest != e.sha256 || (!expect_sha256.empty() && digest != expect_sha256)) {
    o.error = "Export FORMAT_DRACO_GLB: the bytes do not match the sha256 (or the first export's)";
    return o;
  }
  o.ok = true;
  o.bytes = e.bytes.size();
  return o;
}

struct Round {
  std::vector<Outcome> outcomes;
  double wall_s = 0;
  ms::bench::CpuSample cpu_before, cpu_after;
  std::map<std::string, uint64_t> udp_before, udp_after;
};

// `n` threads, each running one session (or export) of `kind` on `m`, all
// released together.
Round RunRound(Kind kind, int n, const std::string& address, const Model& m, const std::string& draco_sha256,
               double timeout_s) {
  Round r;
  r.outcomes.resize(static_cast<size_t>(n));
  StartGate gate;
  std::vector<std::thread> threads;
  for (int i = 0; i < n; ++i) {
    threads.emplace_back([&, i] {
      Outcome& o = r.outcomes[static_cast<size_t>(i)];
      if (kind == Kind::kDraco) {
        AssetClient client(address);
        gate.Arrive();
        o = RunExport(client, m, draco_sha256);
      } else {
        auto client = ms::sdk::Client::Create({address, "", false, ""});
        gate.Arrive();
        if (!client.ok()) {
          o.error = "Client::Create: " + client.status().ToString();
          return;
        }
        o = RunSession(*client.value(), m, kind == Kind::kTcp, timeout_s);
      }
    });
  }
  gate.OpenWhen(n);
  r.udp_before = KernelUdp();
  r.cpu_before = ms::bench::SampleCpu();
  const auto t0 = Clock::now();
  for (std::thread& t : threads) t.join();
  r.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  r.cpu_after = ms::bench::SampleCpu();
  r.udp_after = KernelUdp();
  return r;
}

// p50, p90, p99 (nearest rank), mean, min, max of `v` (ms).
json MsSummary(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  json out = {{"n", v.size()}};
  if (v.empty()) return out;
  out["min_ms"] = v.front();
  out["mean_ms"] = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  out["p50_ms"] = NearestRank(v, 0.50);
  out["p90_ms"] = NearestRank(v, 0.90);
  out["p99_ms"] = NearestRank(v, 0.99);
  out["max_ms"] = v.back();
  return out;
}

// One row of "sessions": every round of one model, kind and concurrency.
struct Row {
  std::string model;
  Kind kind = Kind::kUdp;
  int concurrency = 1;
  int rounds = 0;
  std::vector<Outcome> outcomes;
  std::vector<SessionLogLine> server;  // the server's session lines of these rounds
  double wall_s = 0, process_cpu_s = 0;
  uint64_t machine_busy = 0, machine_total = 0;
  bool server_lines_complete = true;
  std::map<std::string, uint64_t> kernel_udp;  // the rounds' deltas, summed
};

json RowJson(const Row& row) {
  std::vector<double> base, full, wall, lost, received, full_clean, full_predicted;
  uint64_t failures = 0, lost_total = 0, received_total = 0, rejected = 0, duplicate = 0, fallbacks = 0;
  uint64_t sessions_with_loss = 0, unreliable = 0, reliable = 0, bytes = 0;
  uint64_t predicted = 0, sessions_predicted = 0, sessions_rejected = 0, sessions_duplicate = 0;
  double thread_cpu = 0;
  json errors = json::array();
  std::map<std::string, uint64_t> transports, fallback_reasons;
  for (const Outcome& o : row.outcomes) {
    thread_cpu += o.thread_cpu_s;
    if (!o.ok) {
      ++failures;
      if (errors.size() < 10) errors.push_back(o.error);
      continue;
    }
    base.push_back(o.base_ms);
    full.push_back(o.full_ms);
    wall.push_back(o.wall_ms);
    bytes = o.bytes;
    if (row.kind == Kind::kDraco) continue;
    ++transports[o.stats.transport];
    lost.push_back(static_cast<double>(o.stats.datagrams_lost));
    received.push_back(static_cast<double>(o.stats.datagrams_received));
    lost_total += o.stats.datagrams_lost;
    received_total += o.stats.datagrams_received;
    rejected += o.stats.datagrams_rejected;
    duplicate += o.stats.datagrams_duplicate;
    unreliable = o.stats.unreliable_bytes;
    reliable = o.stats.reliable_bytes;
    if (o.stats.datagrams_lost > 0) ++sessions_with_loss;
    if (o.stats.datagrams_rejected > 0) ++sessions_rejected;
    if (o.stats.datagrams_duplicate > 0) ++sessions_duplicate;
    predicted += o.predicted_vertices;
    if (o.predicted_vertices > 0) ++sessions_predicted;
    (o.predicted_vertices > 0 ? full_predicted : full_clean).push_back(o.full_ms);
    if (!o.stats.fallback_reason.empty()) {
      ++fallbacks;
      ++fallback_reasons[o.stats.fallback_reason];
    }
  }
  json j = {{"model", row.model},
            {"transport", KindName(row.kind)},
            {"concurrency", row.concurrency},
            {"rounds", row.rounds},
            {"attempted", row.outcomes.size()},
            {"completed", row.outcomes.size() - failures},
            {"failures", failures},
            {"wall_s", row.wall_s},
            {"cpu", {{"process_s", row.process_cpu_s},
                     {"process_ms_per_session",
                      row.outcomes.empty() ? 0.0 : row.process_cpu_s * 1e3 / static_cast<double>(row.outcomes.size())},
                     {"calling_threads_ms_per_session",
                      row.outcomes.empty() ? 0.0 : thread_cpu * 1e3 / static_cast<double>(row.outcomes.size())},
                     {"machine_busy", row.machine_total ? static_cast<double>(row.machine_busy) / row.machine_total
                                                        : 0.0}}}};
  if (!errors.empty()) j["errors"] = errors;
  if (row.kind == Kind::kDraco) {
    j["time_to_last_byte_ms"] = MsSummary(full);
    j["bytes"] = bytes;
    return j;
  }
  j["time_to_base_ms"] = MsSummary(base);
  j["time_to_full_ms"] = MsSummary(full);
  j["open_to_complete_ms"] = MsSummary(wall);
  j["transports"] = transports;
  j["fallbacks"] = fallbacks;
  if (!fallback_reasons.empty()) j["fallback_reasons"] = fallback_reasons;
  const double n = static_cast<double>(lost.size());
  j["datagrams"] = {{"received_total", received_total},
                    {"lost_total", lost_total},
                    {"lost_per_session_mean", n > 0 ? static_cast<double>(lost_total) / n : 0.0},
                    {"lost_per_session_max", lost.empty() ? 0.0 : *std::max_element(lost.begin(), lost.end())},
                    {"sessions_with_loss", sessions_with_loss},
                    {"loss_fraction", received_total + lost_total
                                          ? static_cast<double>(lost_total) / static_cast<double>(received_total + lost_total)
                                          : 0.0},
                    {"rejected_total", rejected},
                    {"sessions_with_rejected", sessions_rejected},
                    {"duplicate_total", duplicate},
                    {"sessions_with_duplicate", sessions_duplicate},
                    {"received_per_session", received.empty() ? 0.0 : received.front()}};
  j["bytes_per_session"] = {{"reliable", reliable}, {"unreliable", unreliable}};
  j["kernel_udp"] = row.kernel_udp;
  // The mesh reached: vertices predicted (not decoded) at kComplete.
  j["predicted_vertices"] = {{"total", predicted},
                             {"sessions_with_predicted", sessions_predicted},
                             {"per_session_mean", n > 0 ? static_cast<double>(predicted) / n : 0.0},
                             {"time_to_full_ms_without", MsSummary(full_clean)},
                             {"time_to_full_ms_with", MsSummary(full_predicted)}};
  // What the server logged for these sessions.
  uint64_t sent = 0, missing = 0, decreases = 0, with_decrease = 0;
  std::vector<double> rates, srtts;
  std::map<std::string, uint64_t> reasons;
  for (const SessionLogLine& s : row.server) {
    sent += s.datagrams_sent;
    missing += s.missing;
    decreases += s.decreases;
    if (s.decreases > 0) ++with_decrease;
    rates.push_back(s.rate_mbps);
    srtts.push_back(s.srtt_ms);
    ++reasons[s.reason];
  }
  j["server"] = {{"sessions_logged", row.server.size()},
                 {"all_logged", row.server_lines_complete},
                 {"end_reasons", reasons},
                 {"datagrams_sent_total", sent},
                 {"reported_missing_total", missing},
                 {"rate_decreases_total", decreases},
                 {"sessions_with_rate_decrease", with_decrease},
                 {"final_rate_mbps_median", ms::bench::Median(rates)},
                 {"srtt_ms_median", ms::bench::Median(srtts)}};
  return j;
}

// ---------------------------------------------------------- datagram rate

// The datagram rate's clients run in a child process (this program again,
// with --rate-client ADDRESS ASSET VERSION SESSIONS SECONDS TIMEOUT_S), so
// that the server's process CPU is the server's alone. The child: N threads
// open UDP session after session for SECONDS; it prints "start" when they
// are released, "end" when the last has finished, then one JSON line.
int RateClientMain(int argc, char** argv) {
  if (argc != 8) Die("--rate-client ADDRESS ASSET VERSION SESSIONS SECONDS TIMEOUT_S");
  const std::string address = argv[2];
  Model m;
  m.name = argv[3];
  m.version = ParseInt(argv[4], "VERSION", 1, INT64_MAX);
  const int sessions = static_cast<int>(ParseInt(argv[5], "SESSIONS", 1, 1000));
  const double seconds = ParseDouble(argv[6], "SECONDS");
  const double timeout_s = ParseDouble(argv[7], "TIMEOUT_S");
  std::vector<std::vector<Outcome>> outcomes(static_cast<size_t>(sessions));
  std::vector<double> thread_cpu(static_cast<size_t>(sessions), 0);
  StartGate gate;
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  for (int i = 0; i < sessions; ++i) {
    threads.emplace_back([&, i] {
      auto client = ms::sdk::Client::Create({address, "", false, ""});
      if (client.ok()) RunSession(*client.value(), m, false, timeout_s);  // warm-up: the connection
      gate.Arrive();
      if (!client.ok()) return;
      const double cpu0 = ThreadCpuS();
      while (!stop.load()) outcomes[static_cast<size_t>(i)].push_back(RunSession(*client.value(), m, false, timeout_s));
      thread_cpu[static_cast<size_t>(i)] = ThreadCpuS() - cpu0;
    });
  }
  gate.OpenWhen(sessions);
  const ms::bench::CpuSample before = ms::bench::SampleCpu();
  const auto t0 = Clock::now();
  std::printf("start\n");
  std::fflush(stdout);
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  stop = true;
  for (std::thread& t : threads) t.join();
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const ms::bench::CpuSample after = ms::bench::SampleCpu();
  std::printf("end\n");
  std::fflush(stdout);
  uint64_t opened = 0, failed = 0, received = 0, lost = 0, rejected = 0, fallbacks = 0, predicted = 0;
  json errors = json::array();
  for (const auto& v : outcomes) {
    for (const Outcome& o : v) {
      ++opened;
      if (!o.ok) {
        ++failed;
        if (errors.size() < 10) errors.push_back(o.error);
        continue;
      }
      received += o.stats.datagrams_received;
      lost += o.stats.datagrams_lost;
      rejected += o.stats.datagrams_rejected;
      predicted += o.predicted_vertices > 0 ? 1 : 0;
      if (o.stats.transport != "udp") ++fallbacks;
    }
  }
  json j = {{"wall_s", wall},
            {"sessions_opened", opened},
            {"sessions_failed", failed},
            {"sessions_fallback_grpc", fallbacks},
            {"sessions_with_predicted_vertices", predicted},
            {"datagrams_received", received},
            {"datagrams_lost", lost},
            {"datagrams_rejected", rejected},
            {"process_cpu_s", after.process_s - before.process_s},
            {"session_threads_cpu_s", std::accumulate(thread_cpu.begin(), thread_cpu.end(), 0.0)}};
  if (!errors.empty()) j["errors"] = errors;
  std::printf("%s\n", j.dump().c_str());
  return 0;
}

// N UDP sessions at a time, session after session, on `m` for `seconds`,
// their clients in a child process; the server in this one.
json DatagramRate(const std::string& address, const Model& m, int sessions, double seconds, double timeout_s,
                  ServerLog& log) {
  const size_t logged_before = log.session_count();
  int out_pipe[2];
  if (pipe(out_pipe) != 0) Die("pipe failed");
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  std::vector<std::string> args = {self,
                                   "--rate-client",
                                   address,
                                   m.name,
                                   std::to_string(m.version),
                                   std::to_string(sessions),
                                   std::to_string(seconds),
                                   std::to_string(timeout_s)};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out_pipe[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, out_pipe[0]);
  posix_spawn_file_actions_addclose(&actions, out_pipe[1]);
  pid_t child = 0;
  if (posix_spawn(&child, self.c_str(), &actions, nullptr, argv.data(), environ) != 0) Die(self + ": cannot start");
  posix_spawn_file_actions_destroy(&actions);
  close(out_pipe[1]);
  FILE* from_child = fdopen(out_pipe[0], "r");
  if (from_child == nullptr) Die("fdopen failed");
  auto next_line = [&]() {
    std::string line;
    int c;
    while ((c = std::fgetc(from_child)) != EOF && c != '\n') line.push_back(static_cast<char>(c));
    if (c == EOF && line.empty()) Die("the rate client ended early");
    return line;
  };
  if (next_line() != "start") Die("the rate client did not start");
  const auto udp_before = KernelUdp();
  const ms::bench::CpuSample before = ms::bench::SampleCpu();
  const size_t logged_start = log.session_count();
  const auto t0 = Clock::now();
  if (next_line() != "end") Die("the rate client did not end");
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const ms::bench::CpuSample after = ms::bench::SampleCpu();
  const auto udp_after = KernelUdp();
  const json client = json::parse(next_line());
  std::fclose(from_child);
  int status = 0;
  waitpid(child, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) Die("the rate client failed");

  const uint64_t opened = client["sessions_opened"].get<uint64_t>();
  // Sessions the server logged from "start": those of the window (the
  // warm-up sessions ended before the clients said "start").
  const bool all_logged = log.WaitSessions(logged_start + opened, std::chrono::seconds(10));
  uint64_t sent = 0, udp_sessions = 0, decreases = 0;
  for (const SessionLogLine& s : log.SessionsFrom(logged_start)) {
    if (s.transport != "udp") continue;
    sent += s.datagrams_sent;
    decreases += s.decreases;
    ++udp_sessions;
  }
  const double server_cpu = after.process_s - before.process_s;
  const double client_cpu = client["process_cpu_s"].get<double>();
  json j = {{"model", m.name},
            {"concurrent_sessions", sessions},
            {"seconds_asked", seconds},
            {"wall_s", wall},
            {"client", client},
            {"warmup_sessions_logged", logged_start - logged_before},
            {"server_udp_sessions_logged", udp_sessions},
            {"all_logged", all_logged},
            {"server_rate_decreases", decreases},
            {"data_datagrams_sent", sent},
            {"kernel_udp", KernelUdpDelta(udp_before, udp_after)},
            {"datagrams_per_s_wall", sent / wall},
            {"server_cpu_s", server_cpu},
            {"client_cpu_s", client_cpu},
            {"datagrams_per_server_cpu_s", server_cpu > 0 ? sent / server_cpu : 0.0},
            {"datagrams_per_cpu_s_both", server_cpu + client_cpu > 0 ? sent / (server_cpu + client_cpu) : 0.0},
            {"machine_busy", after.machine_total > before.machine_total
                                 ? static_cast<double>(after.machine_busy - before.machine_busy) /
                                       static_cast<double>(after.machine_total - before.machine_total)
                                 : 0.0}};
  return j;
}

// A tight sendmmsg loop of 1200-byte datagrams, 64 per call, from one socket
// to another on 127.0.0.1, the receiver draining with recvmmsg (batches of
// 64) on its own thread, for `seconds`.
json LoopbackLimit(double seconds) {
  constexpr size_t kBytes = 1200, kBatch = 64;
  const auto any = Check(ms::SocketAddress::Parse("127.0.0.1:0"), "127.0.0.1:0");
  ms::UdpSocket rx = Check(ms::UdpSocket::Bind(any), "bind the receiver");
  ms::UdpSocket tx = Check(ms::UdpSocket::Bind(any), "bind the sender");
  const ms::SocketAddress to = rx.local();
  std::atomic<bool> stop{false}, receiver_done{false};
  std::atomic<uint64_t> received{0};
  double rx_cpu = 0, tx_cpu = 0;
  std::thread receiver([&] {
    const double cpu0 = ThreadCpuS();
    std::vector<ms::IncomingDatagram> in(kBatch);
    uint64_t n = 0;
    for (;;) {
      auto got = rx.ReceiveBatch(&in, 1500, 50);
      if (!got.ok()) Die("recvmmsg: " + got.status().ToString());
      n += got.value();
      if (got.value() == 0 && stop.load()) break;  // the sender stopped and the socket is drained
    }
    received = n;
    rx_cpu = ThreadCpuS() - cpu0;
    receiver_done = true;
  });
  std::vector<uint8_t> payload(kBytes, 0x5a);
  std::vector<ms::OutgoingDatagram> batch(kBatch, ms::OutgoingDatagram{&to, payload.data(), payload.size()});
  const auto udp_before = KernelUdp();
  const ms::bench::CpuSample before = ms::bench::SampleCpu();
  const auto t0 = Clock::now();
  const auto until = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  uint64_t sent = 0, calls = 0, full = 0;
  {
    const double cpu0 = ThreadCpuS();
    while (Clock::now() < until) {
      auto n = tx.SendBatch(batch.data(), batch.size());
      if (!n.ok()) Die("sendmmsg: " + n.status().ToString());
      ++calls;
      sent += n.value();
      if (n.value() < batch.size()) {
        ++full;
        std::this_thread::yield();
      }
    }
    tx_cpu = ThreadCpuS() - cpu0;
  }
  const double send_wall = std::chrono::duration<double>(Clock::now() - t0).count();
  stop = true;
  receiver.join();
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  const ms::bench::CpuSample after = ms::bench::SampleCpu();
  const auto udp_after = KernelUdp();
  const double process = after.process_s - before.process_s;
  const double got = static_cast<double>(received.load());
  return {{"datagram_bytes", kBytes},
          {"batch", kBatch},
          {"seconds_asked", seconds},
          {"send_wall_s", send_wall},
          {"wall_s", wall},
          {"sent", sent},
          {"sendmmsg_calls", calls},
          {"short_batches", full},
          {"received", received.load()},
          {"lost_in_the_receiver", sent - std::min<uint64_t>(sent, received.load())},
          {"kernel_udp", KernelUdpDelta(udp_before, udp_after)},
          {"sent_per_s", sent / send_wall},
          {"datagrams_per_s_wall", got / wall},
          {"process_cpu_s", process},
          {"sender_thread_cpu_s", tx_cpu},
          {"receiver_thread_cpu_s", rx_cpu},
          {"datagrams_per_cpu_s", process > 0 ? got / process : 0.0},
          {"sent_per_sender_cpu_s", tx_cpu > 0 ? sent / tx_cpu : 0.0},
          {"machine_busy", after.machine_total > before.machine_total
                               ? static_cast<double>(after.machine_busy - before.machine_busy) /
                                     static_cast<double>(after.machine_total - before.machine_total)
                               : 0.0}};
}

// ------------------------------------------------------- the shaped link

using ms::Primitive;
using ms::Scene;
using ms::Status;
using ms::Vec3f;
//
// The server (this process, host namespace) listens on the host side of a
// veth pair (testing/netns.h); the clients are children of this
// program (`ip netns exec NS <this> --shaped-client ...`), so their sockets
// are really inside the namespace, one child per session or download. The
// namespace drops a share of every packet it receives (nftables, TCP and
// UDP: the downloads and the server's ACKs), tbf limits both veth ends to
// --shaped-rate, and both channels see the same one-way delay: the UDP half
// through the UDP relay (udp_via), every gRPC channel (meshstream's and the
// Draco download's) through the TCP delay proxy (bench/tcp_delay_proxy.h),
// both bound on the veth's host address.

// What a child shows over time: the flattened scene at a few events.
struct Snapshot {
  int32_t level = 0;  // 0: the base mesh; the level; -1: kComplete; -2: the Draco GLB decoded
  Primitive mesh;
};

constexpr char kSnapshotMagic[8] = {'M', 'S', 'S', 'N', 'A', 'P', '1', '\n'};

void WriteSnapshots(const std::string& path, const std::vector<Snapshot>& snapshots) {
  std::ofstream f(path, std::ios::binary);
  auto put = [&](const void* p, size_t n) { f.write(static_cast<const char*>(p), static_cast<std::streamsize>(n)); };
  put(kSnapshotMagic, sizeof kSnapshotMagic);
  const uint32_t count = static_cast<uint32_t>(snapshots.size());
  put(&count, sizeof count);
  for (const Snapshot& s : snapshots) {
    const uint64_t nv = s.mesh.positions.size(), ni = s.mesh.indices.size();
    put(&s.level, sizeof s.level);
    put(&nv, sizeof nv);
    put(&ni, sizeof ni);
    put(s.mesh.positions.data(), nv * sizeof(Vec3f));
    put(s.mesh.indices.data(), ni * sizeof(uint32_t));
  }
  if (!f) Die(path + ": cannot write the snapshots");
}

std::vector<Snapshot> ReadSnapshots(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  auto get = [&](void* p, size_t n) {
    f.read(static_cast<char*>(p), static_cast<std::streamsize>(n));
    if (!f) Die(path + ": truncated snapshot file");
  };
  char magic[8];
  get(magic, sizeof magic);
  if (std::memcmp(magic, kSnapshotMagic, sizeof magic) != 0) Die(path + ": not a snapshot file");
  uint32_t count = 0;
  get(&count, sizeof count);
  std::vector<Snapshot> out(count);
  for (Snapshot& s : out) {
    uint64_t nv = 0, ni = 0;
    get(&s.level, sizeof s.level);
    get(&nv, sizeof nv);
    get(&ni, sizeof ni);
    if (nv > (uint64_t{1} << 28) || ni > (uint64_t{1} << 30)) Die(path + ": implausible snapshot sizes");
    s.mesh.positions.resize(nv);
    s.mesh.indices.resize(ni);
    get(s.mesh.positions.data(), nv * sizeof(Vec3f));
    get(s.mesh.indices.data(), ni * sizeof(uint32_t));
  }
  return out;
}

// FNV-1a over the positions' and indices' bytes: equal meshes, equal hashes
// (the distances of a mesh shown in several runs are computed once).
uint64_t MeshHash(const Primitive& p) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* data, size_t n) {
    const auto* b = static_cast<const uint8_t*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  const uint64_t nv = p.positions.size(), ni = p.indices.size();
  mix(&nv, sizeof nv);
  mix(&ni, sizeof ni);
  mix(p.positions.data(), nv * sizeof(Vec3f));
  mix(p.indices.data(), ni * sizeof(uint32_t));
  return h;
}

// Geometry only: what the distances need.
Primitive Geometry(const Scene& scene) {
  Primitive flat = FlattenScene(scene);
  Primitive g;
  g.positions = std::move(flat.positions);
  g.indices = std::move(flat.indices);
  return g;
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

// A unary round trip on a warm channel: the second of two GetVersion calls.
double GrpcRoundTripMs(AssetClient& client, const std::string& asset, int64_t version) {
  v1::Version info;
  (void)client.GetVersion(asset, version, &info);
  const auto t0 = Clock::now();
  const grpc::Status s = client.GetVersion(asset, version, &info);
  return s.ok() ? Ms(t0, Clock::now()) : -1;
}

// The child: --shaped-client KIND SERVER UDP_VIA ASSET VERSION SNAPSHOTS MAX_SNAPSHOTS TIMEOUT_S.
// One session (KIND udp or tcp_only) or one Draco GLB download and decode
// (draco_export) on a warm channel; prints one JSON line; writes what it
// showed (flattened) into SNAPSHOTS after the clock has stopped.
int ShapedClientMain(int argc, char** argv) {
  if (argc != 10) Die("--shaped-client KIND SERVER UDP_VIA ASSET VERSION SNAPSHOTS MAX_SNAPSHOTS TIMEOUT_S");
  const std::string kind = argv[2], server = argv[3], udp_via = argv[4], asset = argv[5];
  const int64_t version = ParseInt(argv[6], "VERSION", 1, INT64_MAX);
  const std::string snapshot_path = argv[7];
  const int max_snapshots = static_cast<int>(ParseInt(argv[8], "MAX_SNAPSHOTS", 2, 1000));
  const double timeout_s = ParseDouble(argv[9], "TIMEOUT_S");
  json j = {{"kind", kind}, {"ok", false}};
  auto finish = [&](const std::vector<Snapshot>& snapshots) {
    WriteSnapshots(snapshot_path, snapshots);
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
    return 0;
  };
  const auto connect_deadline = std::chrono::system_clock::now() + std::chrono::seconds(30);
  std::vector<Snapshot> snapshots;
  if (kind == "draco_export") {
    AssetClient client(server);
    const auto c0 = Clock::now();
    if (!client.channel()->WaitForConnected(connect_deadline)) {
      j["error"] = "the channel did not connect in 30 s";
      return finish(snapshots);
    }
    j["connect_ms"] = Ms(c0, Clock::now());
    j["grpc_rtt_ms"] = GrpcRoundTripMs(client, asset, version);
    const auto t0 = Clock::now();
    AssetClient::Exported e = client.Export(asset, version, v1::FORMAT_DRACO_GLB);
    const auto last_byte = Clock::now();
    if (!e.status.ok()) {
      j["error"] = "Export FORMAT_DRACO_GLB: " + StatusText(e.status);
      return finish(snapshots);
    }
    if (ms::Sha256Hex(e.bytes.data(), e.bytes.size()) != e.sha256) {
      j["error"] = "Export FORMAT_DRACO_GLB: the bytes do not match the sha256";
      return finish(snapshots);
    }
    auto scene = ms::ImportGltfBytes(e.bytes, "", asset + ".glb", ms::ImportOptions());
    const auto decoded = Clock::now();
    if (!scene.ok()) {
      j["error"] = "decoding the Draco GLB: " + scene.status().ToString();
      return finish(snapshots);
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
    return finish(snapshots);
  }
  if (kind != "udp" && kind != "tcp_only") Die("--shaped-client: KIND udp, tcp_only or draco_export");
  auto client = ms::sdk::Client::Create({server, "", false, ""});
  if (!client.ok()) {
    j["error"] = "Client::Create: " + client.status().ToString();
    return finish(snapshots);
  }
  const auto c0 = Clock::now();
  if (!client.value()->channel()->WaitForConnected(connect_deadline)) {
    j["error"] = "the channel did not connect in 30 s";
    return finish(snapshots);
  }
  j["connect_ms"] = Ms(c0, Clock::now());
  {
    AssetClient probe(server);
    j["grpc_rtt_ms"] = GrpcRoundTripMs(probe, asset, version);
  }
  std::vector<Scene> scenes;  // the snapshots as the session gave them; flattened after the clock stops
  std::vector<int32_t> scene_levels;
  json events = json::array(), snapshot_events = json::array();
  double snapshot_ms = 0;
  std::vector<int32_t> planned;
  bool e_complete = false;
  const auto t0 = Clock::now();
  ms::sdk::SessionOptions so;
  so.asset = asset;
  so.version = version;
  so.tcp_only = kind == "tcp_only";
  if (kind == "udp") so.udp_via = udp_via;
  auto session = ms::sdk::Session::Open(*client.value(), so);
  if (!session.ok()) {
    j["error"] = "Session::Open: " + session.status().ToString();
    return finish(snapshots);
  }
  ms::sdk::Session& s = *session.value();
  const auto deadline = t0 + std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000));
  // The mesh shown is the session's current one: when Poll hands out
  // several events of one batch, it is already at the last of them, so a
  // snapshot is labelled with level_shown(), and taken when level_shown()
  // has passed a planned level since the last one (always at the base and
  // at kComplete).
  int32_t last_snapped = -1;
  auto snap = [&](bool always) {
    const int32_t shown = s.level_shown();
    const bool due = std::any_of(planned.begin(), planned.end(),
                                 [&](int32_t l) { return l > last_snapped && l <= shown; });
    if (!always && !due) return;
    const auto a = Clock::now();
    scenes.push_back(s.CurrentScene());
    scene_levels.push_back(always && e_complete ? -1 : shown);
    snapshot_events.push_back(events.size() - 1);
    last_snapped = shown;
    snapshot_ms += Ms(a, Clock::now());
  };
  bool based = false;
  for (;;) {
    if (Clock::now() > deadline) {
      j["error"] = "not complete after " + std::to_string(static_cast<int>(timeout_s)) + " s (level " +
                   std::to_string(s.level_shown()) + ")";
      s.Cancel();
      break;
    }
    const ms::sdk::Event e = s.Poll(200);
    if (e.type == ms::sdk::EventType::kNone) continue;
    const double t = Ms(t0, Clock::now());
    if (e.type == ms::sdk::EventType::kError) {
      j["error"] = "kError: " + e.status.ToString();
      break;
    }
    if (e.type == ms::sdk::EventType::kBaseReady) {
      based = true;
      events.push_back({{"what", "base"}, {"level", 0}, {"shown", s.level_shown()}, {"t_ms", t},
                        {"predicted", s.predicted_vertices()}});
      j["first_ms"] = t;
      planned = SnapshotLevels(s.levels(), max_snapshots);
      snap(true);
    } else if (e.type == ms::sdk::EventType::kLevelReady) {
      events.push_back({{"what", "level"}, {"level", e.level}, {"shown", s.level_shown()}, {"t_ms", t},
                        {"predicted", s.predicted_vertices()}});
      snap(false);
    } else if (e.type == ms::sdk::EventType::kComplete) {
      events.push_back({{"what", "complete"}, {"level", s.level_shown()}, {"shown", s.level_shown()}, {"t_ms", t},
                        {"predicted", s.predicted_vertices()}});
      j["full_ms"] = t;
      e_complete = true;
      snap(true);
      const ms::sdk::SessionStats& st = s.stats();
      j["stats"] = {{"transport", st.transport},
                    {"fallback_reason", st.fallback_reason},
                    {"end_reason", st.end_reason},
                    {"time_to_base_ms", st.time_to_base_ms},
                    {"time_to_full_ms", st.time_to_full_ms},
                    {"hello_rtt_ms", st.hello_rtt_ms},
                    {"hellos_sent", st.hellos_sent},
                    {"reliable_bytes", st.reliable_bytes},
                    {"unreliable_bytes", st.unreliable_bytes},
                    {"datagrams_received", st.datagrams_received},
                    {"datagrams_lost", st.datagrams_lost},
                    {"datagrams_rejected", st.datagrams_rejected},
                    {"datagrams_duplicate", st.datagrams_duplicate}};
      j["level"] = s.level_shown();
      j["levels"] = s.levels();
      j["predicted_vertices"] = s.predicted_vertices();
      if (!based) {
        j["error"] = "kComplete without kBaseReady";
      } else if (s.level_shown() < s.levels()) {
        j["error"] = "kComplete at level " + std::to_string(s.level_shown()) + " of " + std::to_string(s.levels()) +
                     " (end reason '" + st.end_reason + "')";
      } else {
        j["ok"] = true;
      }
      break;
    }
  }
  j["events"] = events;
  j["snapshot_events"] = snapshot_events;
  j["snapshot_ms"] = snapshot_ms;
  session.value().reset();
  for (size_t i = 0; i < scenes.size(); ++i) snapshots.push_back({scene_levels[i], Geometry(scenes[i])});
  return finish(snapshots);
}

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
  auto client = Check(ms::sdk::Client::Create({address, "", false, ""}), "the reference client");
  ms::sdk::SessionOptions so;
  so.asset = m.name;
  so.version = m.version;
  so.tcp_only = true;
  auto session = Check(ms::sdk::Session::Open(*client, so), "the reference session of " + m.name);
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  for (;;) {
    if (Clock::now() > deadline) Die("the reference session of " + m.name + " did not complete");
    const ms::sdk::Event e = session->Poll(500);
    if (e.type == ms::sdk::EventType::kError) Die("the reference session of " + m.name + ": " + e.status.ToString());
    if (e.type == ms::sdk::EventType::kComplete) break;
  }
  if (session->level_shown() != session->levels() || session->predicted_vertices() != 0) {
    Die("the reference session of " + m.name + " is not the full lossless mesh (level " +
        std::to_string(session->level_shown()) + " of " + std::to_string(session->levels()) + ", " +
        std::to_string(session->predicted_vertices()) + " predicted vertices)");
  }
  return Geometry(session->CurrentScene());
}

// The largest single-file model (.obj, .ply, .glb) anywhere under `dir` by
// vertex count (imported, every primitive of the scene counted once).
std::string LargestModelByVertices(const std::string& dir, uint64_t* vertices) {
  std::string best;
  uint64_t most = 0;
  std::error_code ec;
  std::vector<fs::path> files;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const std::string ext = it->path().extension().string();
    if (ext == ".obj" || ext == ".ply" || ext == ".glb") files.push_back(it->path());
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& p : files) {
    auto scene = ms::ImportFile(p.string());
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

// The shaped part's models: the bunny and the horse (those of `models`), and
// the largest shared model by vertices (a new Model when it is neither).
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
    Model m;
    m.path = args.models_dir + "/" + largest;
    m.file = fs::path(largest).filename().string();
    m.name = ms::bench::Stem(largest);
    m.roles = {"largest"};
    m.bytes = Check(ms::ReadFileBytes(m.path, uint64_t{1} << 30), m.path);
    out.push_back(std::move(m));
  }
  return out;
}

json ShapedMsSummary(std::vector<double> v) {
  json out = {{"n", v.size()}};
  if (v.empty()) return out;
  std::sort(v.begin(), v.end());
  out["median_ms"] = ms::bench::Median(v);
  out["min_ms"] = v.front();
  out["max_ms"] = v.back();
  out["runs_ms"] = v;
  return out;
}

const char* const kShapedKinds[] = {"udp", "tcp_only", "draco_export"};

json RunShaped(const Args& args, const std::string& store, const std::string& folder,
               const std::vector<Model>& main_models) {
  const auto start = Clock::now();
  json out;
  auto ns_or = ms::test_util::NetNs::Create();
  if (!ns_or.ok()) {
    std::fprintf(stderr, "meshstream_bench_stream: shaped link SKIPPED: %s\n", ns_or.status().message().c_str());
    return {{"skipped", ns_or.status().message()}};
  }
  std::unique_ptr<ms::test_util::NetNs> ns = std::move(ns_or).value();
  const Status rate = ns->SetRate(args.shaped_rate_mbit);
  if (!rate.ok()) {
    std::fprintf(stderr, "meshstream_bench_stream: shaped link SKIPPED: tc tbf: %s\n", rate.message().c_str());
    return {{"skipped", "tc tbf: " + rate.message()}};
  }
  json chosen;
  std::vector<Model> models = ShapedModels(args, main_models, &chosen);
  if (!args.only.empty()) {
    models.erase(std::remove_if(models.begin(), models.end(),
                                [&](const Model& m) {
                                  return std::find(args.only.begin(), args.only.end(), m.name) == args.only.end();
                                }),
                 models.end());
  }
  if (models.empty()) return {{"skipped", "no model left (see --model)"}};

  ServerLog log;
  log.verbose = args.verbose;
  ms::ServerOptions so = BaseServerOptions(args, store, &log);
  so.listen = ns->host_ip() + ":0";
  so.insecure = true;  // a veth address, no authentication: the benchmark's own namespace
  so.server_id = "bench-stream-shaped";
  std::fprintf(stderr, "meshstream_bench_stream: shaped link: server on %s, clients in namespace %s (%s)\n",
               so.listen.c_str(), ns->name().c_str(), ns->ns_ip().c_str());
  std::unique_ptr<ms::Server> server = Check(ms::Server::Start(so), "shaped server");
  const std::string address = server->address();
  json model_info = json::array();
  std::map<std::string, Primitive> reference;
  std::map<std::string, uint64_t> reference_hash;
  std::map<std::string, json> draco_ref;
  struct DistanceJob {
    std::string model;
    const Primitive* a = nullptr;  // the reference side (its diagonal divides)
    Primitive b;
    ms::SurfaceDistance d;
    bool ok = false;
    std::string error;
  };
  std::map<std::string, Primitive> source_meshes, draco_meshes;
  for (Model& m : models) {
    if (m.version == 0) {
      std::fprintf(stderr, "meshstream_bench_stream: shaped link: ingest %s (%zu bytes)\n", m.file.c_str(),
                   m.bytes.size());
      Ingest(address, m);
    }
    reference[m.name] = ReferenceMesh(address, m);
    reference_hash[m.name] = MeshHash(reference[m.name]);
    AssetClient client(address);
    AssetClient::Exported e = client.Export(m.name, m.version, v1::FORMAT_DRACO_GLB);  // warms the export cache
    if (!e.status.ok()) Die("the Draco export of " + m.name + " failed: " + StatusText(e.status));
    draco_meshes[m.name] = Geometry(Check(ms::ImportGltfBytes(e.bytes, "", m.name + ".glb", ms::ImportOptions()),
                                          "decoding the Draco GLB of " + m.name));
    source_meshes[m.name] = Geometry(Check(ms::ImportFile(m.path), m.path));
    draco_ref[m.name] = {{"bytes", e.bytes.size()}, {"sha256", e.sha256}};
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
                          {"flattened_vertices", reference[m.name].positions.size()},
                          {"flattened_faces", reference[m.name].indices.size() / 3}});
  }

  const ms::SocketAddress udp_upstream = Check(ms::SocketAddress::Parse(server->udp_address()), "the UDP endpoint");
  ms::test_util::RelayOptions ro;
  ro.upstream = udp_upstream;
  ro.bind = ns->host_ip() + ":0";
  ro.to_server.delay_us = ro.to_client.delay_us = static_cast<uint64_t>(args.shaped_delay_ms * 1000);
  std::unique_ptr<ms::test_util::UdpRelay> relay = Check(ms::test_util::UdpRelay::Start(ro), "the UDP relay");
  ms::bench::TcpDelayProxyOptions po;
  po.listen = ns->host_ip() + ":0";
  po.upstream = address;
  po.delay_us = static_cast<uint64_t>(args.shaped_delay_ms * 1000);
  std::unique_ptr<ms::bench::TcpDelayProxy> proxy = Check(ms::bench::TcpDelayProxy::Start(po), "the TCP delay proxy");
  const std::string udp_via = relay->front().ToString();
  std::fprintf(stderr, "meshstream_bench_stream: shaped link: gRPC via %s, UDP via %s, %.0f Mbit/s, %.0f ms each way\n",
               proxy->address().c_str(), udp_via.c_str(), args.shaped_rate_mbit, args.shaped_delay_ms);

  const std::string self = fs::read_symlink("/proc/self/exe").string();
  const std::string snap_dir = folder + "/shaped-snapshots";
  fs::create_directories(snap_dir);
  json runs = json::array();
  std::vector<std::string> snapshot_files;  // per run, "" when none
  json per_loss = json::array();
  uint64_t failures = 0;
  const size_t total = args.shaped_losses.size() * static_cast<size_t>(args.shaped_runs) * models.size() * 3;
  size_t done = 0;
  for (int loss : args.shaped_losses) {
    const Status l = ns->SetLoss(loss, args.shaped_udp_only_loss);
    if (!l.ok()) Die("nft: " + l.message());
    const size_t proxy_before = proxy->closed().size();
    const ms::test_util::RelayCounters up0 = relay->to_server(), down0 = relay->to_client();
    const auto loss_start = Clock::now();
    for (int run = 0; run < args.shaped_runs; ++run) {
      for (const Model& m : models) {
        for (const char* kind : kShapedKinds) {
          ++done;
          const std::string file = snap_dir + "/" + std::to_string(runs.size()) + ".snap";
          const std::vector<std::string> cargs = {self,
                                                  "--shaped-client",
                                                  kind,
                                                  proxy->address(),
                                                  udp_via,
                                                  m.name,
                                                  std::to_string(m.version),
                                                  file,
                                                  std::to_string(args.shaped_snapshots),
                                                  std::to_string(args.shaped_timeout_s)};
          std::string command;
          for (const std::string& a : cargs) command += (command.empty() ? "" : " ") + ShellQuote(a);
          const size_t logged = log.session_count();
          const size_t closed_before = proxy->closed().size();
          const ms::test_util::RelayCounters relay_down0 = relay->to_client(), relay_up0 = relay->to_server();
          const auto t0 = Clock::now();
          auto [text, code] = Capture(ns->Inside(command));
          const double child_ms = Ms(t0, Clock::now());
          // The child's connections close when it exits; the proxy sees it
          // a moment later.
          const auto close_deadline = Clock::now() + std::chrono::seconds(3);
          while (proxy->closed().size() < proxy->accepted() && Clock::now() < close_deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
          }
          const std::vector<ms::bench::TcpConnectionInfo> conns = proxy->closed();
          json wire_tcp = {{"connections", conns.size() - closed_before}};
          {
            uint64_t down = 0, up = 0, retrans = 0;
            double srtt = 0;
            for (size_t c = closed_before; c < conns.size(); ++c) {
              down += conns[c].bytes_to_client;
              up += conns[c].bytes_to_server;
              retrans += conns[c].total_retrans;
              srtt = std::max(srtt, conns[c].rtt_ms);
            }
            wire_tcp["bytes_to_client"] = down;
            wire_tcp["bytes_to_server"] = up;
            wire_tcp["segments_retransmitted"] = retrans;
            wire_tcp["srtt_ms_max"] = srtt;
          }
          const ms::test_util::RelayCounters relay_down1 = relay->to_client(), relay_up1 = relay->to_server();
          json r = json::parse(text.substr(0, text.find('\n')), nullptr, false);
          if (code != 0 || r.is_discarded() || !r.is_object()) {
            r = {{"kind", kind}, {"ok", false}, {"error", "the client process failed (exit " + std::to_string(code) + ")"}};
          }
          r["loss_percent"] = loss;
          r["model"] = m.name;
          r["run"] = run;
          r["child_process_ms"] = child_ms;
          // What crossed the link for it (the gRPC probe calls and the
          // channel set-up included): the proxy's client-facing
          // connections, and the relay's datagrams.
          r["wire"] = {{"tcp", wire_tcp},
                       {"udp", {{"datagrams_to_client", relay_down1.forwarded - relay_down0.forwarded},
                                {"bytes_to_client", relay_down1.bytes - relay_down0.bytes},
                                {"datagrams_to_server", relay_up1.forwarded - relay_up0.forwarded}}}};
          if (std::string(kind) != "draco_export") {
            // The server's log line of the session: its rate controller.
            if (log.WaitSessions(logged + 1, std::chrono::seconds(5))) {
              const std::vector<SessionLogLine> lines = log.SessionsFrom(logged);
              const SessionLogLine& s = lines.back();
              r["server"] = {{"reason", s.reason},          {"transport", s.transport},
                             {"datagrams_sent", s.datagrams_sent}, {"reports", s.reports},
                             {"missing", s.missing},        {"final_rate_mbps", s.rate_mbps},
                             {"decreases", s.decreases},    {"srtt_ms", s.srtt_ms}};
            }
          }
          const bool ok = r.value("ok", false);
          if (!ok) ++failures;
          std::fprintf(stderr, "meshstream_bench_stream: shaped %3zu/%zu: %2d %% loss, run %d, %s %s: %s\n", done, total,
                       loss, run + 1, m.name.c_str(), kind,
                       ok ? (std::to_string(static_cast<int>(r.value("first_ms", 0.0))) + " ms first, " +
                             std::to_string(static_cast<int>(r.value("full_ms", 0.0))) + " ms full")
                                .c_str()
                          : ("FAILED: " + r.value("error", std::string("?"))).c_str());
          snapshot_files.push_back(fs::exists(file) ? file : "");
          runs.push_back(std::move(r));
        }
      }
    }
    // The TCP side of this loss level: what the kernel said of the proxy's
    // client-facing connections; the UDP side: the relay's counters.
    const std::vector<ms::bench::TcpConnectionInfo> closed = proxy->closed();
    std::vector<double> rtts;
    uint64_t retrans = 0, to_client = 0;
    for (size_t i = proxy_before; i < closed.size(); ++i) {
      rtts.push_back(closed[i].rtt_ms);
      retrans += closed[i].total_retrans;
      to_client += closed[i].bytes_to_client;
    }
    const ms::test_util::RelayCounters up1 = relay->to_server(), down1 = relay->to_client();
    per_loss.push_back({{"loss_percent", loss},
                        {"wall_s", Ms(loss_start, Clock::now()) / 1000},
                        {"proxy", {{"connections_closed", closed.size() - proxy_before},
                                   {"srtt_ms_median", ms::bench::Median(rtts)},
                                   {"srtt_ms_max", rtts.empty() ? 0.0 : *std::max_element(rtts.begin(), rtts.end())},
                                   {"bytes_to_clients", to_client},
                                   {"segments_retransmitted", retrans}}},
                        {"relay", {{"to_server_forwarded", up1.forwarded - up0.forwarded},
                                   {"to_client_forwarded", down1.forwarded - down0.forwarded},
                                   {"to_client_bytes", down1.bytes - down0.bytes}}}});
  }
  (void)ns->SetLoss(0, false);
  const std::string udp_totals = [&] {
    relay->Stop();
    proxy->Stop();
    const size_t before = [&] {
      std::lock_guard<std::mutex> lock(log.mutex);
      return log.lines.size();
    }();
    StopServer(server);
    std::lock_guard<std::mutex> lock(log.mutex);
    for (size_t i = before; i < log.lines.size(); ++i) {
      if (log.lines[i].rfind("udp: ", 0) == 0) return log.lines[i];
    }
    return std::string();
  }();
  const json notable = log.Notable(30);
  ns.reset();  // the namespace and its veth go
  const double sessions_s = Ms(start, Clock::now()) / 1000;

  // The distances, after every run: each distinct mesh shown once against
  // its model's reference, on every core, nothing else running; one run's
  // snapshots at a time (the meshes are let go once measured).
  const auto d0 = Clock::now();
  std::vector<std::unique_ptr<DistanceJob>> jobs;
  std::map<std::pair<std::string, uint64_t>, size_t> job_of;
  struct Point {
    size_t run, event;
    int32_t level;
    size_t job;  // SIZE_MAX: the reference itself (distance 0)
  };
  std::vector<Point> points;
  ms::SurfaceDistanceOptions dopt;
  dopt.samples_per_side = args.shaped_samples;
  auto measure = [&](size_t from) {
    std::atomic<size_t> next{from};
    std::vector<std::thread> workers;
    const unsigned n = std::max(1u, std::thread::hardware_concurrency());
    for (unsigned w = 0; w < n; ++w) {
      workers.emplace_back([&] {
        for (size_t i; (i = next++) < jobs.size();) {
          DistanceJob& jb = *jobs[i];
          auto d = ms::ComputeSurfaceDistance(*jb.a, jb.b, dopt);
          if (d.ok()) {
            jb.d = d.value();
            jb.ok = true;
          } else {
            jb.error = d.status().ToString();
          }
          jb.b = Primitive();
        }
      });
    }
    for (std::thread& t : workers) t.join();
  };
  // Per model: Draco's GLB and the source file against the reference, and Draco against the source.
  std::map<std::string, std::array<size_t, 3>> model_jobs;
  for (const Model& m : models) {
    std::array<size_t, 3> idx{};
    const std::pair<const Primitive*, const Primitive*> pairs[3] = {
        {&reference[m.name], &draco_meshes[m.name]},
        {&reference[m.name], &source_meshes[m.name]},
        {&source_meshes[m.name], &draco_meshes[m.name]}};
    for (size_t k = 0; k < 3; ++k) {
      auto jb = std::make_unique<DistanceJob>();
      jb->model = m.name;
      jb->a = pairs[k].first;
      jb->b = *pairs[k].second;
      idx[k] = jobs.size();
      jobs.push_back(std::move(jb));
    }
    model_jobs[m.name] = idx;
  }
  measure(0);
  for (size_t i = 0; i < runs.size(); ++i) {
    if (snapshot_files[i].empty()) continue;
    const std::string model = runs[i]["model"];
    std::vector<Snapshot> snaps = ReadSnapshots(snapshot_files[i]);
    const json ev = runs[i].value("snapshot_events", json::array());
    const size_t first_new = jobs.size();
    for (size_t k = 0; k < snaps.size() && k < ev.size(); ++k) {
      const uint64_t h = MeshHash(snaps[k].mesh);
      size_t job = SIZE_MAX;
      if (h != reference_hash[model]) {
        auto it = job_of.find({model, h});
        if (it == job_of.end()) {
          auto jb = std::make_unique<DistanceJob>();
          jb->model = model;
          jb->a = &reference[model];
          jb->b = std::move(snaps[k].mesh);
          it = job_of.emplace(std::make_pair(model, h), jobs.size()).first;
          jobs.push_back(std::move(jb));
        }
        job = it->second;
      }
      points.push_back({i, ev[k].get<size_t>(), snaps[k].level, job});
    }
    snaps.clear();
    measure(first_new);
    std::error_code ec;
    fs::remove(snapshot_files[i], ec);
  }
  std::fprintf(stderr, "meshstream_bench_stream: shaped link: %zu snapshots, %zu distinct meshes measured in %.0f s\n",
               points.size(), jobs.size(), Ms(d0, Clock::now()) / 1000);
  const double distance_s = Ms(d0, Clock::now()) / 1000;
  auto distance_json = [&](size_t job) -> json {
    if (job == SIZE_MAX) return {{"hausdorff_rel", 0.0}, {"mean_rel", 0.0}, {"exact", true}};
    const DistanceJob& jb = *jobs[job];
    if (!jb.ok) return {{"error", jb.error}};
    const double diag = jb.d.hausdorff > 0 && jb.d.hausdorff_rel > 0 ? jb.d.hausdorff / jb.d.hausdorff_rel : 0;
    return {{"hausdorff_rel", jb.d.hausdorff_rel}, {"mean_rel", diag > 0 ? jb.d.mean_distance / diag : 0.0},
            {"hausdorff", jb.d.hausdorff}, {"mean_distance", jb.d.mean_distance}};
  };
  for (json& r : runs) r["quality"] = json::array();
  for (const Point& p : points) {
    json& r = runs[p.run];
    json q = distance_json(p.job);
    q["level"] = p.level;
    const json& ev = r["events"];
    if (p.event < ev.size()) {
      q["t_ms"] = ev[p.event]["t_ms"];
      q["what"] = ev[p.event]["what"];
      if (ev[p.event].contains("predicted")) q["predicted"] = ev[p.event]["predicted"];
    }
    r["quality"].push_back(q);
  }
  for (json& m : model_info) {
    const std::array<size_t, 3>& idx = model_jobs[m["name"].get<std::string>()];
    m["draco_vs_reference"] = distance_json(idx[0]);
    m["source_vs_reference"] = distance_json(idx[1]);
    m["draco_vs_source"] = distance_json(idx[2]);
  }

  // Per loss, model and kind: the medians over the runs.
  json summary = json::array();
  for (int loss : args.shaped_losses) {
    for (const Model& m : models) {
      std::map<std::string, json> by_kind;
      for (const char* kind : kShapedKinds) {
        std::vector<double> first, full, final_h, predicted, lost, received, rate, srtt, decreases, within1, within01;
        uint64_t n = 0, failed = 0, fallbacks = 0;
        json errors = json::array();
        for (const json& r : runs) {
          if (r["loss_percent"] != loss || r["model"] != m.name || r["kind"] != kind) continue;
          ++n;
          if (!r.value("ok", false)) {
            ++failed;
            if (errors.size() < 5) errors.push_back(r.value("error", std::string("?")));
            continue;
          }
          first.push_back(r["first_ms"]);
          full.push_back(r["full_ms"]);
          const json& q = r["quality"];
          if (!q.empty() && q.back().contains("hausdorff_rel")) final_h.push_back(q.back()["hausdorff_rel"]);
          double t1 = -1, t01 = -1;
          for (const json& p : q) {
            if (!p.contains("hausdorff_rel") || !p.contains("t_ms")) continue;
            const double h = p["hausdorff_rel"];
            if (t1 < 0 && h <= 0.01) t1 = p["t_ms"];
            if (t01 < 0 && h <= 0.001) t01 = p["t_ms"];
          }
          if (t1 >= 0) within1.push_back(t1);
          if (t01 >= 0) within01.push_back(t01);
          if (r.contains("predicted_vertices")) predicted.push_back(r["predicted_vertices"]);
          if (r.contains("stats")) {
            lost.push_back(r["stats"]["datagrams_lost"]);
            received.push_back(r["stats"]["datagrams_received"]);
            if (!r["stats"]["fallback_reason"].get<std::string>().empty()) ++fallbacks;
          }
          if (r.contains("server")) {
            rate.push_back(r["server"]["final_rate_mbps"]);
            srtt.push_back(r["server"]["srtt_ms"]);
            decreases.push_back(r["server"]["decreases"]);
          }
        }
        json s = {{"loss_percent", loss}, {"model", m.name}, {"kind", kind}, {"runs", n}, {"failures", failed},
                  {"first_ms", ShapedMsSummary(first)}, {"full_ms", ShapedMsSummary(full)},
                  {"within_1pct_ms", ShapedMsSummary(within1)}, {"within_0_1pct_ms", ShapedMsSummary(within01)},
                  {"final_hausdorff_rel_median", ms::bench::Median(final_h)},
                  {"final_hausdorff_rel_max", final_h.empty() ? 0.0 : *std::max_element(final_h.begin(), final_h.end())}};
        if (!errors.empty()) s["errors"] = errors;
        if (std::string(kind) != "draco_export") {
          s["predicted_vertices_median"] = ms::bench::Median(predicted);
          s["datagrams_lost_median"] = ms::bench::Median(lost);
          s["datagrams_received_median"] = ms::bench::Median(received);
          s["fallbacks"] = fallbacks;
          s["server_final_rate_mbps_median"] = ms::bench::Median(rate);
          s["server_srtt_ms_median"] = ms::bench::Median(srtt);
          s["server_rate_decreases_median"] = ms::bench::Median(decreases);
        }
        by_kind[kind] = s;
      }
      const json& d = by_kind["draco_export"];
      for (const char* kind : {"udp", "tcp_only"}) {
        json& s = by_kind[kind];
        if (s["first_ms"].contains("median_ms") && d["first_ms"].contains("median_ms")) {
          s["vs_draco"] = {{"first", s["first_ms"]["median_ms"].get<double>() / d["first_ms"]["median_ms"].get<double>()},
                           {"full", s["full_ms"]["median_ms"].get<double>() / d["full_ms"]["median_ms"].get<double>()}};
        }
      }
      for (const char* kind : kShapedKinds) summary.push_back(by_kind[kind]);
    }
  }

  out["settings"] = {{"losses_percent", args.shaped_losses},
                     {"runs", args.shaped_runs},
                     {"rate_mbit", args.shaped_rate_mbit},
                     {"delay_ms_each_way", args.shaped_delay_ms},
                     {"max_snapshots", args.shaped_snapshots},
                     {"samples_per_side", args.shaped_samples},
                     {"session_timeout_s", args.shaped_timeout_s},
                     {"models_chosen", chosen},
                     {"server", {{"listen", address},
                                 {"udp", udp_upstream.ToString()},
                                 {"hello_timeout_ms", so.hello_timeout_ms},
                                 {"max_rate_bps", so.max_rate_bps},
                                 {"max_session_rate_bps", so.max_session_rate_bps}}},
                     {"grpc_via", proxy->address()},
                     {"udp_via", udp_via},
                     {"loss_udp_only", args.shaped_udp_only_loss},
                     {"loss_rule", std::string("nft, in the namespace's input hook: ") +
                                       (args.shaped_udp_only_loss ? "meta l4proto udp " : "") +
                                       "numgen random mod 100 < P drop" +
                                       (args.shaped_udp_only_loss ? " (UDP only)" : " (TCP and UDP)")},
                     {"rate_rule", "tc tbf on both veth ends: rate R burst 32kbit latency 100ms"}};
  out["models"] = model_info;
  out["runs"] = runs;
  out["summary"] = summary;
  out["per_loss"] = per_loss;
  out["server"] = {{"udp_totals_line", udp_totals}, {"log_notable", notable}};
  out["failures"] = failures;
  out["distinct_meshes_measured"] = jobs.size();
  out["snapshots"] = points.size();
  out["distance_s"] = distance_s;
  out["sessions_s"] = sessions_s;
  out["wall_s"] = Ms(start, Clock::now()) / 1000;
  return out;
}

// 1. and 2.: the sessions on loopback and the datagram rate, into `out`;
// returns the failures.
uint64_t RunLoopbackParts(const Args& args, std::vector<Model>& models, const std::string& store, json& out) {
  uint64_t failures = 0;
  ServerLog log;
  log.verbose = args.verbose;
  const ms::ServerOptions server_options = BaseServerOptions(args, store, &log);
  std::fprintf(stderr, "meshstream_bench_stream: starting the server (store in %s)\n", store.c_str());
  std::unique_ptr<ms::Server> server = Check(ms::Server::Start(server_options), "server");
  const std::string address = server->address();

  json model_info = json::array();
  for (Model& m : models) {
    std::fprintf(stderr, "meshstream_bench_stream: ingest %s (%zu bytes)\n", m.file.c_str(), m.bytes.size());
    Ingest(address, m);
    json levels = json::array();
    for (int64_t v : m.info.level_vertices()) levels.push_back(v);
    model_info.push_back({{"name", m.name},
                          {"file", m.file},
                          {"bytes", m.bytes.size()},
                          {"roles", m.roles},
                          {"version", m.version},
                          {"vertices", m.info.vertices()},
                          {"faces", m.info.faces()},
                          {"levels", m.info.levels()},
                          {"progressive_bytes", m.info.progressive_bytes()},
                          {"reliable_bytes", m.info.reliable_bytes()},
                          {"unreliable_bytes", m.info.unreliable_bytes()}});
  }

  out["settings"] = {{"models", model_info},
                     {"concurrency", args.concurrency},
                     {"samples", args.samples},
                     {"min_rounds", args.min_rounds},
                     {"largest_rounds_at_100", args.largest_rounds_at_100},
                     {"session_timeout_s", args.session_timeout_s},
                     {"workers", args.workers},
                     {"quick", args.quick},
                     {"server", {{"max_rate_bps", server_options.max_rate_bps},
                                 {"max_session_rate_bps", server_options.max_session_rate_bps},
                                 {"max_sessions", server_options.max_sessions},
                                 {"max_threads", server_options.max_threads},
                                 {"max_exports", server_options.max_exports},
                                 {"hello_timeout_ms", server_options.hello_timeout_ms},
                                 {"udp", server->udp_address()}}},
                     {"reference_format", "FORMAT_DRACO_GLB"}};

  // Warm-up (not timed): per model one session of each transport and the
  // first Draco export, which decodes, encodes with Draco and stores the
  // export (timed on its own: what the first client of a version waits).
  json draco_first = json::object();
  std::map<std::string, std::string> draco_sha;
  json warmup_failures = json::array();
  for (const Model& m : models) {
    AssetClient client(address);
    const Outcome first = RunExport(client, m, "");
    if (!first.ok) Die("the first Draco export of " + m.name + " failed: " + first.error);
    AssetClient::Exported e = client.Export(m.name, m.version, v1::FORMAT_DRACO_GLB);
    if (!e.status.ok()) Die("the second Draco export of " + m.name + " failed: " + StatusText(e.status));
    draco_sha[m.name] = e.sha256;
    // What a client of the Draco GLB does after its last byte: decode it
    // (importers/, Draco), on one thread, nothing else running.
    std::vector<double> decode;
    for (int i = 0; i < 10; ++i) {
      const auto t0 = Clock::now();
      const ms::Scene scene = Check(ms::ImportGltfBytes(e.bytes, "", m.name + ".glb", ms::ImportOptions()),
                                    "decoding the Draco GLB of " + m.name);
      decode.push_back(Ms(t0, Clock::now()));
      if (scene.meshes.empty()) Die("the Draco GLB of " + m.name + " has no mesh");
    }
    draco_first[m.name] = {{"first_call_ms", first.full_ms},
                           {"bytes", first.bytes},
                           {"client_decode", ms::bench::RunsSummary(decode)}};
    for (Kind k : {Kind::kUdp, Kind::kTcp}) {
      Round r = RunRound(k, 1, address, m, "", args.session_timeout_s);
      if (!r.outcomes[0].ok) {
        ++failures;
        warmup_failures.push_back(m.name + " " + KindName(k) + ": " + r.outcomes[0].error);
        std::fprintf(stderr, "meshstream_bench_stream: warm-up %s %s FAILED: %s\n", m.name.c_str(), KindName(k),
                     r.outcomes[0].error.c_str());
      }
    }
  }
  log.WaitSessions(2 * models.size(), std::chrono::seconds(5));

  // 1. Time to base and to full, per model and concurrency; the three kinds
  // take turns round by round.
  json rows = json::array();
  for (const Model& m : models) {
    for (int n : args.concurrency) {
      int rounds = std::max(args.min_rounds, (args.samples + n - 1) / n);
      if (n >= 100 && IsLargest(m)) rounds = args.largest_rounds_at_100;
      std::map<Kind, Row> by_kind;
      for (Kind k : {Kind::kUdp, Kind::kTcp, Kind::kDraco}) {
        Row& row = by_kind[k];
        row.model = m.name;
        row.kind = k;
        row.concurrency = n;
        row.rounds = rounds;
      }
      for (int round = 0; round < rounds; ++round) {
        for (Kind k : {Kind::kUdp, Kind::kTcp, Kind::kDraco}) {
          std::fprintf(stderr, "meshstream_bench_stream: %s, %3d concurrent, round %d/%d: %s\n", m.name.c_str(), n,
                       round + 1, rounds, KindName(k));
          const size_t logged = log.session_count();
          Round r = RunRound(k, n, address, m, draco_sha[m.name], args.session_timeout_s);
          Row& row = by_kind[k];
          if (k != Kind::kDraco) {
            // Every session the server ran logs one line when it ends.
            if (!log.WaitSessions(logged + static_cast<size_t>(n), std::chrono::seconds(10))) {
              row.server_lines_complete = false;
            }
            for (SessionLogLine& s : log.SessionsFrom(logged)) row.server.push_back(std::move(s));
          }
          for (Outcome& o : r.outcomes) {
            if (!o.ok) {
              std::fprintf(stderr, "meshstream_bench_stream: %s %s x%d: FAILED: %s\n", m.name.c_str(), KindName(k), n,
                           o.error.c_str());
            }
            row.outcomes.push_back(std::move(o));
          }
          const json udp = KernelUdpDelta(r.udp_before, r.udp_after);
          for (auto it = udp.begin(); it != udp.end(); ++it) row.kernel_udp[it.key()] += it.value().get<uint64_t>();
          row.wall_s += r.wall_s;
          row.process_cpu_s += r.cpu_after.process_s - r.cpu_before.process_s;
          row.machine_busy += r.cpu_after.machine_busy - r.cpu_before.machine_busy;
          row.machine_total += r.cpu_after.machine_total - r.cpu_before.machine_total;
        }
      }
      json draco = RowJson(by_kind[Kind::kDraco]);
      rows.push_back(draco);
      for (Kind k : {Kind::kUdp, Kind::kTcp}) {
        json j = RowJson(by_kind[k]);
        failures += j["failures"].get<uint64_t>();
        const json& ref = draco["time_to_last_byte_ms"];
        if (ref.contains("p50_ms") && j["time_to_full_ms"].contains("p50_ms")) {
          j["vs_draco_export"] = {
              {"full_p50", j["time_to_full_ms"]["p50_ms"].get<double>() / ref["p50_ms"].get<double>()},
              {"full_p99", j["time_to_full_ms"]["p99_ms"].get<double>() / ref["p99_ms"].get<double>()},
              {"base_p50", j["time_to_base_ms"]["p50_ms"].get<double>() / ref["p50_ms"].get<double>()},
              {"base_p99", j["time_to_base_ms"]["p99_ms"].get<double>() / ref["p99_ms"].get<double>()}};
        }
        rows.push_back(j);
      }
      failures += draco["failures"].get<uint64_t>();
    }
  }

  // The main server's log: its UDP endpoint's totals come when it stops.
  const size_t lines_before_stop = [&] {
    std::lock_guard<std::mutex> lock(log.mutex);
    return log.lines.size();
  }();
  StopServer(server);
  std::string main_udp_line;
  {
    std::lock_guard<std::mutex> lock(log.mutex);
    for (size_t i = lines_before_stop; i < log.lines.size(); ++i) {
      if (log.lines[i].rfind("udp: ", 0) == 0) main_udp_line = log.lines[i];
    }
  }
  json notable = log.Notable(60);

  // 2. Datagrams per second: a server on the same store with a high
  // --max-rate and --max-session-rate, the loopback limit before and after.
  const Model* rate_model = &models.back();
  for (const Model& m : models) {
    if (IsLargest(m)) rate_model = &m;
  }
  std::fprintf(stderr, "meshstream_bench_stream: loopback sendmmsg limit (%.1f s)\n", args.loopback_seconds);
  json loop_before = LoopbackLimit(args.loopback_seconds);
  ServerLog rate_log;
  rate_log.verbose = args.verbose;
  ms::ServerOptions rate_options = BaseServerOptions(args, store, &rate_log);
  rate_options.max_rate_bps = args.rate_bps;
  rate_options.max_session_rate_bps = args.rate_bps;
  std::fprintf(stderr, "meshstream_bench_stream: datagram rate: %d UDP sessions of %s for %.1f s (max rate %.3g bit/s)\n",
               args.rate_sessions, rate_model->name.c_str(), args.rate_seconds, args.rate_bps);
  std::unique_ptr<ms::Server> rate_server = Check(ms::Server::Start(rate_options), "rate server");
  json rate = DatagramRate(rate_server->address(), *rate_model, args.rate_sessions, args.rate_seconds,
                           args.session_timeout_s, rate_log);
  failures += rate["client"]["sessions_failed"].get<uint64_t>();
  StopServer(rate_server);
  for (const std::string& l : rate_log.lines) {
    if (l.rfind("udp: ", 0) == 0) rate["server_udp_totals_line"] = l;
  }
  json rate_notable = rate_log.Notable(30);
  std::fprintf(stderr, "meshstream_bench_stream: loopback sendmmsg limit again\n");
  json loop_after = LoopbackLimit(args.loopback_seconds);
  auto mean2 = [&](const char* key) {
    return (loop_before[key].get<double>() + loop_after[key].get<double>()) / 2;
  };
  const double loop_wall = mean2("datagrams_per_s_wall");
  const double loop_cpu = mean2("datagrams_per_cpu_s");
  const double loop_sender = mean2("sent_per_sender_cpu_s");
  out["datagram_rate"] = {
      {"meshstream", rate},
      {"server_options", {{"max_rate_bps", rate_options.max_rate_bps},
                          {"max_session_rate_bps", rate_options.max_session_rate_bps}}},
      {"loopback_sendmmsg", {{"before", loop_before},
                             {"after", loop_after},
                             {"datagrams_per_s_wall", loop_wall},
                             {"datagrams_per_cpu_s", loop_cpu},
                             {"sent_per_sender_cpu_s", loop_sender}}},
      // meshstream over the loopback loop: wall; the server's CPU against
      // the loop's sender thread; both ends against both ends.
      {"ratios", {{"wall", rate["datagrams_per_s_wall"].get<double>() / loop_wall},
                  {"server_cpu_vs_sender_cpu", rate["datagrams_per_server_cpu_s"].get<double>() / loop_sender},
                  {"server_cpu_vs_loop_cpu", rate["datagrams_per_server_cpu_s"].get<double>() / loop_cpu},
                  {"both_ends_cpu", rate["datagrams_per_cpu_s_both"].get<double>() / loop_cpu}}},
      {"server_log_notable", rate_notable}};

  out["sessions"] = rows;
  out["draco_reference"] = draco_first;
  out["server"] = {{"udp_totals_line", main_udp_line}, {"log_notable", notable}};
  if (!warmup_failures.empty()) out["warmup_failures"] = warmup_failures;
  return failures;
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::SetProgramName("meshstream_bench_stream");
  if (argc > 1 && std::string(argv[1]) == "--rate-client") return RateClientMain(argc, argv);
  if (argc > 1 && std::string(argv[1]) == "--shaped-client") return ShapedClientMain(argc, argv);
  const Args args = ParseArgs(argc, argv);
  const auto run_start = Clock::now();
  json out;
  out["benchmark"] = "meshstream_bench_stream";
  out["machine"] = MachineInfo(args);

  std::vector<Model> models = ChooseModels(args);

  // The store and the server (production defaults but the port and the workers).
  std::string folder = (fs::path(args.work_dir) / "meshstream-bench-stream-XXXXXX").string();
  if (mkdtemp(folder.data()) == nullptr) Die(args.work_dir + ": mkdtemp failed");
  const std::string store = folder + "/store";
  uint64_t failures = 0;
  bool merged = false;
  if (!args.only_shaped) {
    failures = RunLoopbackParts(args, models, store, out);
  } else {
    // --only-shaped: into the --out file of an earlier full run when there
    // is one (its loopback parts kept as they are), else on its own.
    std::ifstream earlier(args.out);
    json e = earlier ? json::parse(earlier, nullptr, false) : json();
    if (e.is_object() && e.value("benchmark", std::string()) == "meshstream_bench_stream" && e.contains("sessions")) {
      std::fprintf(stderr, "meshstream_bench_stream: --only-shaped: replacing the shaped part of %s\n",
                   args.out.c_str());
      out = std::move(e);
      out.erase("shaped");
      failures = out.value("failures", uint64_t{0});
      merged = true;
    } else {
      json model_info = json::array();
      for (const Model& m : models) model_info.push_back({{"name", m.name}, {"file", m.file}, {"roles", m.roles}});
      out["settings"] = {{"models", model_info}, {"quick", args.quick}, {"only_shaped", true}};
    }
  }
  // 3. The shaped link: a server of its own on the same store (the loopback
  // server has stopped), on the host side of a veth pair.
  uint64_t shaped_failures = 0;
  if (args.shaped) {
    const auto shaped_start = Clock::now();
    json machine = MachineInfo(args);
    json shaped = RunShaped(args, store, folder, models);
    machine["loadavg_at_end"] = ms::bench::LoadAverage();
    machine["run_seconds"] = Ms(shaped_start, Clock::now()) / 1000;
    shaped["machine"] = machine;  // the shaped part's own (a merged run's top-level machine is the earlier run's)
    shaped["run"] = args.only_shaped ? (merged ? "only_shaped, merged into the JSON of an earlier full run"
                                                : "only_shaped")
                                     : "with the loopback parts";
    shaped["quick"] = args.quick;
    shaped_failures = shaped.value("failures", uint64_t{0});
    out["shaped"] = std::move(shaped);
  }
  out["failures"] = failures;  // the loopback parts'; the shaped link's are out["shaped"]["failures"]
  if (!merged) {
    out["machine"]["loadavg_at_end"] = ms::bench::LoadAverage();
    out["machine"]["run_seconds"] = Ms(run_start, Clock::now()) / 1000;
  }
  {
    std::error_code ec;
    fs::remove_all(folder, ec);
  }

  const fs::path out_path(args.out);
  if (out_path.has_parent_path()) fs::create_directories(out_path.parent_path());
  std::ofstream f(args.out);
  f << out.dump(1) << "\n";
  if (!f) Die(args.out + ": cannot write");
  std::fprintf(stderr, "meshstream_bench_stream: wrote %s in %.0f s (%llu failures on loopback, %llu on the shaped link)\n",
               args.out.c_str(), Ms(run_start, Clock::now()) / 1000, static_cast<unsigned long long>(failures),
               static_cast<unsigned long long>(shaped_failures));
  return 0;
}

#include "bench/stream/sessions.h"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <numeric>
#include <sstream>
#include <thread>

#include "bench/bench_util.h"
#include "bench/service_stats.h"
#include "testing/asset_calls.h"

namespace meshstream::bench::stream {

namespace ms = meshstream;
using json = nlohmann::json;

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
void StartGate::Arrive() {
  std::unique_lock<std::mutex> lock(mutex_);
  ++arrived_;
  cv_.notify_all();
  cv_.wait(lock, [this] { return open_; });
}

void StartGate::OpenWhen(int n) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [&] { return arrived_ >= n; });
  open_ = true;
  cv_.notify_all();
}

const char* KindName(Kind k) { return k == Kind::kUdp ? "udp" : k == Kind::kTcp ? "tcp_only" : "draco_export"; }

std::string SessionEndError(const ms::sdk::Session& s, bool based) {
  if (!based) return "kComplete without kBaseReady";
  if (s.level_shown() < s.levels()) {
    return "kComplete at level " + std::to_string(s.level_shown()) + " of " + std::to_string(s.levels()) +
           " (end reason '" + s.stats().end_reason + "')";
  }
  return "";
}

std::string SessionTimeoutError(const ms::sdk::Session& s, double timeout_s) {
  return "not complete after " + std::to_string(static_cast<int>(timeout_s)) + " s (level " +
         std::to_string(s.level_shown()) + ")";
}

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
      o.error = SessionTimeoutError(s, timeout_s);
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
      o.error = SessionEndError(s, based);
      if (o.error.empty()) {
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
// SHA-256 (checked by the client) compared with `expect_sha256`.
Outcome RunExport(AssetApi& api, const Model& m, const std::string& expect_sha256) {
  Outcome o;
  const double cpu0 = ThreadCpuS();
  const auto t0 = Clock::now();
  StatusOr<AssetApi::Exported> exported = api.Export(m.name, m.version, v1::FORMAT_DRACO_GLB);
  o.full_ms = o.wall_ms = Ms(t0, Clock::now());
  o.thread_cpu_s = ThreadCpuS() - cpu0;
  if (!exported.ok()) {
    o.error = "Export FORMAT_DRACO_GLB: " + exported.status().ToString();
    return o;
  }
  const AssetApi::Exported& e = exported.value();
  if (!expect_sha256.empty() && e.sha256 != expect_sha256) {
    o.error = "Export FORMAT_DRACO_GLB: the bytes do not match the first export's sha256";
    return o;
  }
  o.ok = true;
  o.bytes = e.bytes.size();
  return o;
}

// `n` threads, each running one session (or export) of `kind` on `m`, all
// released together.
Round RunRound(Kind kind, int n, const std::string& address, const Model& m, const std::string& draco_sha256,
               double timeout_s, const std::function<void()>& on_release) {
  Round r;
  r.outcomes.resize(static_cast<size_t>(n));
  StartGate gate;
  std::vector<std::thread> threads;
  for (int i = 0; i < n; ++i) {
    threads.emplace_back([&, i] {
      Outcome& o = r.outcomes[static_cast<size_t>(i)];
      if (kind == Kind::kDraco) {
        AssetApi api(address);
        gate.Arrive();
        o = RunExport(api, m, draco_sha256);
      } else {
        auto client = ms::sdk::Client::Create(meshstream::test_util::PlainClientOptions(address));
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
  if (on_release) on_release();
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


}  // namespace meshstream::bench::stream

#include "bench/service/latency.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/service/ingest.h"
#include "bench/service_echo.h"
#include "bench/service_load.h"
#include "bench/service_stats.h"

namespace meshstream::bench::service {

namespace ms = meshstream;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

struct LatencyTarget {
  std::string backend;  // "" for the echo server
  std::string rpc;      // "echo", "health", "GetVersion", "ListVersions"
  ms::bench::UnaryTarget target;
};

std::vector<LatencyTarget> MakeTargets(const std::vector<Backend*>& backends, const std::string& echo_address,
                                       const std::string& asset, int versions,
                                       const std::map<std::string, std::string>& page2_tokens) {
  std::vector<LatencyTarget> out;
  {
    LatencyTarget echo{"", "echo", {}};
    echo.target.address = echo_address;
    echo.target.method = ms::bench::kEchoMethod;
    // About the size of a GetVersionRequest.
    echo.target.requests = {std::string("\x0a\x0clatency-spot\x10\x2a") + std::string(14, 'e')};
    echo.target.check = [r = echo.target.requests[0]](size_t, const std::string& response) {
      return response == r ? std::string() : std::string("echo: the response is not the request");
    };
    out.push_back(std::move(echo));
  }
  for (Backend* b : backends) {
    LatencyTarget health{b->name, "health", {}};
    health.target.address = b->server->address();
    health.target.method = "/grpc.health.v1.Health/Check";
    health.target.requests = {std::string()};
    health.target.check = [](size_t, const std::string& response) {
      return response == std::string("\x08\x01", 2) ? std::string() : std::string("health: not SERVING");
    };
    out.push_back(std::move(health));

    LatencyTarget get{b->name, "GetVersion", {}};
    get.target.address = b->server->address();
    get.target.method = "/meshstream.v1.AssetService/GetVersion";
    for (int v = 1; v <= versions; ++v) {
      v1::GetVersionRequest r;
      r.set_asset(asset);
      r.set_version(v);
      get.target.requests.push_back(r.SerializeAsString());
    }
    get.target.check = [](size_t index, const std::string& response) {
      v1::Version v;
      if (!v.ParseFromString(response)) return std::string("GetVersion: the response does not parse");
      if (v.version() != static_cast<int64_t>(index) + 1 || v.state() != v1::VERSION_STATE_READY) {
        return "GetVersion: got version " + std::to_string(v.version()) + " in state " + std::to_string(v.state());
      }
      return std::string();
    };
    out.push_back(std::move(get));

    LatencyTarget list{b->name, "ListVersions", {}};
    list.target.address = b->server->address();
    list.target.method = "/meshstream.v1.AssetService/ListVersions";
    for (const std::string& token : {std::string(), page2_tokens.at(b->name)}) {
      v1::ListVersionsRequest r;
      r.set_asset(asset);
      r.set_page_size(50);
      r.set_page_token(token);
      list.target.requests.push_back(r.SerializeAsString());
    }
    // The first page holds 50 versions, the second the rest up to 50
    // (--versions may be as low as 51).
    list.target.check = [versions](size_t index, const std::string& response) {
      v1::ListVersionsResponse page;
      if (!page.ParseFromString(response)) return std::string("ListVersions: the response does not parse");
      const int64_t first = index == 0 ? 1 : 51;
      const int expected = index == 0 ? 50 : std::min(50, versions - 50);
      if (page.versions_size() != expected || page.versions(0).version() != first) {
        return "ListVersions: " + std::to_string(page.versions_size()) + " versions, the first " +
               (page.versions_size() ? std::to_string(page.versions(0).version()) : std::string("-"));
      }
      return std::string();
    };
    out.push_back(std::move(list));
  }
  return out;
}

// The asset GetVersion and ListVersions read: `versions` ingests of spot.obj
// (the first encodes it, the artifact cache answers the rest), all READY.
// Returns the page token of the second page of 50.
std::string MakeLatencyAsset(Backend& b, const Model& spot, const std::string& asset, int versions) {
  Model m = spot;
  m.name = asset;
  const auto messages = UploadMessages(m, m.bytes, v1::EncodeOptions(), "");
  v1::IngestResponse last;
  for (int i = 0; i < versions; ++i) {
    last = Check(b.client->Ingest(messages), b.name + ": making the latency asset: Ingest");
  }
  const ms::StatusOr<v1::Job> job = b.client->Watch(last.job_id());
  if (!job.ok() || job->state() != v1::JOB_STATE_SUCCEEDED) Die(b.name + ": the latency asset's last job did not succeed");
  // Every version READY (the jobs ran in order, two at a time), page by page.
  std::string token, second;
  int ready = 0, pages = 0;
  do {
    const v1::ListVersionsResponse page = Check(b.client->ListVersions(asset, 50, token), b.name + ": ListVersions");
    for (const v1::Version& v : page.versions()) {
      if (v.state() != v1::VERSION_STATE_READY) {
        // A job that finished after the last one: wait for it.
        const ms::StatusOr<v1::Job> j = b.client->Watch(v.job_id());
        if (!j.ok() || j->state() != v1::JOB_STATE_SUCCEEDED) {
          Die(b.name + ": latency asset version " + std::to_string(v.version()) + " did not become READY");
        }
      }
      ++ready;
    }
    token = page.next_page_token();
    if (++pages == 1) second = token;
  } while (!token.empty());
  if (ready != versions || second.empty()) Die(b.name + ": the latency asset has " + std::to_string(ready) + " versions");
  return second;
}

// One latency entry: a target's merged calls at `clients` clients (their
// CPU summed over the rounds).
json LatencyEntry(const LatencyTarget& target, int clients, const ms::bench::LoadResult& r) {
  json entry = ms::bench::LatencySummary(r.latencies_us);
  entry["backend"] = target.backend.empty() ? "echo" : target.backend;
  entry["rpc"] = target.rpc;
  entry["clients"] = clients;
  entry["calls_per_client"] = r.calls_per_client;
  entry["failed"] = r.failed;
  entry["warmup_failed"] = r.warmup_failed;
  if (!r.first_error.empty()) entry["first_error"] = r.first_error;
  entry["wall_s"] = r.wall_s;
  entry["throughput_cps"] = r.wall_s > 0 ? static_cast<double>(r.latencies_us.size()) / r.wall_s : 0;
  // CPU while the timed calls ran: the machine's busy share of its cores
  // (every process), and this process's CPU (clients and servers) per call.
  const double calls = static_cast<double>(r.calls_per_client) * clients;
  entry["cpu"] = {{"machine_busy", r.machine_total ? static_cast<double>(r.machine_busy) / r.machine_total : 0.0},
                  {"process_s", r.process_cpu_s},
                  {"process_us_per_call", calls > 0 ? r.process_cpu_s * 1e6 / calls : 0.0}};
  if (r.failed > 0) {
    std::fprintf(stderr, "meshstream_bench_service: %s %s, %d clients: %llu calls FAILED: %s\n",
                 entry["backend"].get<std::string>().c_str(), target.rpc.c_str(), clients,
                 static_cast<unsigned long long>(r.failed), r.first_error.c_str());
  }
  return entry;
}

// Every target at `clients` clients, in --rounds interleaved rounds.
void MeasureLatencyAt(const Args& args, const std::vector<LatencyTarget>& targets, int clients, json& latency) {
  const int per_client = std::max(args.min_calls, args.calls / clients);
  const int per_round = std::max(1, per_client / args.rounds);
  std::vector<ms::bench::LoadResult> merged(targets.size());
  for (int round = 0; round < args.rounds; ++round) {
    for (size_t t = 0; t < targets.size(); ++t) {
      std::fprintf(stderr, "meshstream_bench_service: %3d clients, round %d: %s %s\n", clients, round + 1,
                   targets[t].backend.empty() ? "echo server" : targets[t].backend.c_str(), targets[t].rpc.c_str());
      ms::bench::LoadResult r = ms::bench::RunLoad(targets[t].target, clients, per_round, 3);
      ms::bench::LoadResult& m = merged[t];
      m.clients = clients;
      m.calls_per_client += r.calls_per_client;
      m.latencies_us.insert(m.latencies_us.end(), r.latencies_us.begin(), r.latencies_us.end());
      m.failed += r.failed;
      m.warmup_failed += r.warmup_failed;
      if (m.first_error.empty()) m.first_error = r.first_error;
      m.wall_s += r.wall_s;
      m.process_cpu_s += r.process_cpu_s;
      m.machine_busy += r.machine_busy;
      m.machine_total += r.machine_total;
    }
  }
  for (size_t t = 0; t < targets.size(); ++t) {
    latency.push_back(LatencyEntry(targets[t], clients, merged[t]));
  }
}

}  // namespace

json MeasureLatency(const Args& args, const std::vector<Backend*>& backends, const Model& spot,
                    const std::string& echo_address) {
  std::fprintf(stderr, "meshstream_bench_service: the latency asset (%d versions per backend)\n", args.versions);
  const std::string latency_asset = "latency-spot";
  std::map<std::string, std::string> page2;
  for (Backend* b : backends) page2[b->name] = MakeLatencyAsset(*b, spot, latency_asset, args.versions);
  const std::vector<LatencyTarget> targets = MakeTargets(backends, echo_address, latency_asset, args.versions, page2);
  json latency = json::array();
  for (int clients : args.clients) MeasureLatencyAt(args, targets, clients, latency);
  return latency;
}

json RatiosToEcho(const Args& args, const json& latency) {
  json ratios = json::array();
  for (int clients : args.clients) {
    const json* floor = nullptr;
    for (const json& e : latency) {
      if (e["rpc"] == "echo" && e["clients"] == clients) floor = &e;
    }
    if (floor == nullptr || !floor->contains("p50_us")) continue;
    for (const json& e : latency) {
      if (e["rpc"] == "echo" || e["clients"] != clients || !e.contains("p50_us")) continue;
      ratios.push_back({{"backend", e["backend"]},
                        {"rpc", e["rpc"]},
                        {"clients", clients},
                        {"p50_vs_echo", e["p50_us"].get<double>() / (*floor)["p50_us"].get<double>()},
                        {"p99_vs_echo", e["p99_us"].get<double>() / (*floor)["p99_us"].get<double>()},
                        {"throughput_vs_echo",
                         e["throughput_cps"].get<double>() / (*floor)["throughput_cps"].get<double>()}});
    }
  }
  return ratios;
}

}  // namespace meshstream::bench::service

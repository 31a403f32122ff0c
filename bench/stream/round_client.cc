#include "bench/stream/round_client.h"

#include <cstdio>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/service_load.h"

namespace meshstream::bench::stream {

namespace ms = meshstream;
using json = nlohmann::json;

namespace {

// What the parent reads of an outcome (RowJson, AddSessionFigures).
json ToJson(const Outcome& o) {
  const sdk::SessionStats& st = o.stats;
  return {{"ok", o.ok},
          {"error", o.error},
          {"base_ms", o.base_ms},
          {"full_ms", o.full_ms},
          {"wall_ms", o.wall_ms},
          {"thread_cpu_s", o.thread_cpu_s},
          {"level", o.level},
          {"levels", o.levels},
          {"predicted_vertices", o.predicted_vertices},
          {"bytes", o.bytes},
          {"stats", {{"transport", st.transport},
                     {"fallback_reason", st.fallback_reason},
                     {"end_reason", st.end_reason},
                     {"time_to_base_ms", st.time_to_base_ms},
                     {"time_to_full_ms", st.time_to_full_ms},
                     {"reliable_bytes", st.reliable_bytes},
                     {"unreliable_bytes", st.unreliable_bytes},
                     {"datagrams_received", st.datagrams_received},
                     {"datagrams_lost", st.datagrams_lost},
                     {"datagrams_rejected", st.datagrams_rejected},
                     {"datagrams_duplicate", st.datagrams_duplicate}}}};
}

Outcome FromJson(const json& j) {
  Outcome o;
  o.ok = j.at("ok").get<bool>();
  o.error = j.at("error").get<std::string>();
  o.base_ms = j.at("base_ms").get<double>();
  o.full_ms = j.at("full_ms").get<double>();
  o.wall_ms = j.at("wall_ms").get<double>();
  o.thread_cpu_s = j.at("thread_cpu_s").get<double>();
  o.level = j.at("level").get<int32_t>();
  o.levels = j.at("levels").get<int32_t>();
  o.predicted_vertices = j.at("predicted_vertices").get<uint64_t>();
  o.bytes = j.at("bytes").get<uint64_t>();
  const json& st = j.at("stats");
  sdk::SessionStats& s = o.stats;
  st.at("transport").get_to(s.transport);
  st.at("fallback_reason").get_to(s.fallback_reason);
  st.at("end_reason").get_to(s.end_reason);
  st.at("time_to_base_ms").get_to(s.time_to_base_ms);
  st.at("time_to_full_ms").get_to(s.time_to_full_ms);
  st.at("reliable_bytes").get_to(s.reliable_bytes);
  st.at("unreliable_bytes").get_to(s.unreliable_bytes);
  st.at("datagrams_received").get_to(s.datagrams_received);
  st.at("datagrams_lost").get_to(s.datagrams_lost);
  st.at("datagrams_rejected").get_to(s.datagrams_rejected);
  st.at("datagrams_duplicate").get_to(s.datagrams_duplicate);
  return o;
}

Kind KindFromName(const std::string& name) {
  for (Kind k : {Kind::kUdp, Kind::kTcp, Kind::kDraco}) {
    if (name == KindName(k)) return k;
  }
  Die("--round-client: unknown kind " + name);
}

}  // namespace

int RoundClientMain(int argc, char** argv) {
  if (argc != 3) Die("--round-client ADDRESS");
  const std::string address = argv[2];
  std::string line;
  // KIND N ASSET VERSION SHA256 TIMEOUT_S (SHA256 "-": none)
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string kind, sha;
    int n = 0;
    Model m;
    double timeout_s = 0;
    if (!(in >> kind >> n >> m.name >> m.version >> sha >> timeout_s) || n < 1) Die("--round-client: bad round " + line);
    Round r = RunRound(KindFromName(kind), n, address, m, sha == "-" ? "" : sha, timeout_s, [] {
      std::printf("start\n");
      std::fflush(stdout);
    });
    json outcomes = json::array();
    for (const Outcome& o : r.outcomes) outcomes.push_back(ToJson(o));
    const json answer = {{"outcomes", outcomes},
                         {"wall_s", r.wall_s},
                         {"process_cpu_s", r.cpu_after.process_s - r.cpu_before.process_s}};
    std::printf("%s\n", answer.dump().c_str());
    std::fflush(stdout);
  }
  return 0;
}

RoundClient::RoundClient(const std::string& address, int nice) : child_({"--round-client", address}, nice) {}

RoundClient::~RoundClient() = default;

Round RoundClient::Run(Kind kind, int n, const Model& m, const std::string& draco_sha256, double timeout_s) {
  Round r;
  child_.WriteLine(std::string(KindName(kind)) + " " + std::to_string(n) + " " + m.name + " " +
                   std::to_string(m.version) + " " + (draco_sha256.empty() ? "-" : draco_sha256) + " " +
                   std::to_string(timeout_s));
  if (child_.NextLine() != "start") Die("the round client did not start a round");
  r.udp_before = KernelUdp();
  r.cpu_before = ms::bench::SampleCpu();
  const json answer = json::parse(child_.NextLine(), nullptr, false);
  r.cpu_after = ms::bench::SampleCpu();
  r.udp_after = KernelUdp();
  if (!answer.is_object()) Die("the round client's answer is not JSON");
  for (const json& o : answer.at("outcomes")) r.outcomes.push_back(FromJson(o));
  r.wall_s = answer.at("wall_s").get<double>();
  r.client_cpu_s = answer.at("process_cpu_s").get<double>();
  return r;
}

}  // namespace meshstream::bench::stream

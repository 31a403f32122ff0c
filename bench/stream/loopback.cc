#include "bench/stream/loopback.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/service_stats.h"
#include "bench/stream/rate.h"
#include "bench/stream/round_client.h"
#include "bench/stream/server_log.h"
#include "bench/stream/sessions.h"
#include "importers/gltf_import.h"
#include "importers/import.h"
#include "services/server/server.h"

namespace meshstream::bench::stream {

namespace ms = meshstream;
using json = nlohmann::json;

namespace {

// One row of "sessions": every round of one model, kind and concurrency.
struct Row {
  std::string model;
  Kind kind = Kind::kUdp;
  int concurrency = 1;
  int rounds = 0;
  std::vector<Outcome> outcomes;
  std::vector<SessionLogLine> server;  // the server's session lines of these rounds
  double wall_s = 0, process_cpu_s = 0;  // the server's process
  double client_cpu_s = 0;               // the clients' process (round_client.h)
  uint64_t machine_busy = 0, machine_total = 0;
  bool server_lines_complete = true;
  std::map<std::string, uint64_t> kernel_udp;  // the rounds' deltas, summed
};

// What the sessions of a row said: datagrams, bytes, predicted vertices.
void AddSessionFigures(const Row& row, json& j) {
  std::vector<double> base, full, wall, lost, received, full_clean, full_predicted;
  uint64_t lost_total = 0, received_total = 0, rejected = 0, duplicate = 0, fallbacks = 0;
  uint64_t sessions_with_loss = 0, unreliable = 0, reliable = 0;
  uint64_t predicted = 0, sessions_predicted = 0, sessions_rejected = 0, sessions_duplicate = 0;
  std::map<std::string, uint64_t> transports, fallback_reasons;
  for (const Outcome& o : row.outcomes) {
    if (!o.ok) continue;
    base.push_back(o.base_ms);
    full.push_back(o.full_ms);
    wall.push_back(o.wall_ms);
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
}

// What the server logged for the sessions of a row.
json ServerLinesJson(const Row& row) {
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
  return {{"sessions_logged", row.server.size()},
          {"all_logged", row.server_lines_complete},
          {"end_reasons", reasons},
          {"datagrams_sent_total", sent},
          {"reported_missing_total", missing},
          {"rate_decreases_total", decreases},
          {"sessions_with_rate_decrease", with_decrease},
          {"final_rate_mbps_median", Median(rates)},
          {"srtt_ms_median", Median(srtts)}};
}

json RowJson(const Row& row) {
  std::vector<double> full;
  uint64_t failures = 0, bytes = 0;
  double thread_cpu = 0;
  json errors = json::array();
  for (const Outcome& o : row.outcomes) {
    thread_cpu += o.thread_cpu_s;
    if (!o.ok) {
      ++failures;
      if (errors.size() < 10) errors.push_back(o.error);
      continue;
    }
    full.push_back(o.full_ms);
    bytes = o.bytes;
  }
  const double n = static_cast<double>(row.outcomes.size());
  json j = {{"model", row.model},
            {"transport", KindName(row.kind)},
            {"concurrency", row.concurrency},
            {"rounds", row.rounds},
            {"attempted", row.outcomes.size()},
            {"completed", row.outcomes.size() - failures},
            {"failures", failures},
            {"wall_s", row.wall_s},
            {"cpu", {{"process_s", row.process_cpu_s + row.client_cpu_s},
                     {"process_ms_per_session", n > 0 ? (row.process_cpu_s + row.client_cpu_s) * 1e3 / n : 0.0},
                     {"server_s", row.process_cpu_s},
                     {"server_ms_per_session", n > 0 ? row.process_cpu_s * 1e3 / n : 0.0},
                     {"clients_s", row.client_cpu_s},
                     {"clients_ms_per_session", n > 0 ? row.client_cpu_s * 1e3 / n : 0.0},
                     {"calling_threads_ms_per_session", n > 0 ? thread_cpu * 1e3 / n : 0.0},
                     {"machine_busy", row.machine_total ? static_cast<double>(row.machine_busy) / row.machine_total
                                                        : 0.0}}}};
  if (!errors.empty()) j["errors"] = errors;
  if (row.kind == Kind::kDraco) {
    j["time_to_last_byte_ms"] = MsSummary(full);
    j["bytes"] = bytes;
    return j;
  }
  AddSessionFigures(row, j);
  j["server"] = ServerLinesJson(row);
  // The server's own time from the Open to the base meshes handed to gRPC
  // (its session log lines), beside the clients' time_to_base_ms.
  std::vector<double> server_base;
  for (const SessionLogLine& s : row.server) {
    if (s.open_to_base_ms >= 0) server_base.push_back(s.open_to_base_ms);
  }
  j["server_time_to_base_ms"] = MsSummary(server_base);
  return j;
}

// The models ingested into the server, as "settings"."models" lists them.
json IngestModels(const std::string& address, std::vector<Model>& models) {
  json model_info = json::array();
  for (Model& m : models) {
    std::fprintf(stderr, "meshstream_bench_stream: ingest %s (%zu bytes)\n", m.file.c_str(), m.bytes.size());
    Ingest(address, m);
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
  return model_info;
}

json Settings(const Args& args, json model_info, const ServerOptions& server_options, const Server& server) {
  return {{"models", std::move(model_info)},
          {"concurrency", args.concurrency},
          {"samples", args.samples},
          {"min_rounds", args.min_rounds},
          {"largest_rounds_at_100", args.largest_rounds_at_100},
          {"session_timeout_s", args.session_timeout_s},
          {"workers", args.workers},
          {"client_nice", args.client_nice},
          {"quick", args.quick},
          {"server", {{"max_rate_bps", server_options.max_rate_bps},
                      {"max_session_rate_bps", server_options.max_session_rate_bps},
                      {"max_sessions", server_options.max_sessions},
                      {"max_threads", server_options.max_threads},
                      {"max_exports", server_options.max_exports},
                      {"hello_timeout_ms", server_options.hello_timeout_ms},
                      {"udp", server.udp_address()}}},
          {"reference_format", "FORMAT_DRACO_GLB"}};
}

// The warm-up's results: the first Draco export of each model and the
// SHA-256 every later export must match.
struct Warmup {
  json draco_first = json::object();
  std::map<std::string, std::string> draco_sha;
  json failures = json::array();
};

// Warm-up (not timed): per model one session of each transport and the
// first Draco export, which decodes, encodes with Draco and stores the
// export (timed on its own: what the first client of a version waits); and
// what a client of the Draco GLB does after its last byte: decode it
// (importers/, Draco), on one thread, nothing else running.
Warmup WarmUp(const Args& args, const std::string& address, const std::vector<Model>& models, RoundClient& clients) {
  Warmup w;
  for (const Model& m : models) {
    AssetApi api(address);
    const Outcome first = RunExport(api, m, "");
    if (!first.ok) Die("the first Draco export of " + m.name + " failed: " + first.error);
    const AssetApi::Exported e = Check(api.Export(m.name, m.version, v1::FORMAT_DRACO_GLB),
                                       "the second Draco export of " + m.name);
    w.draco_sha[m.name] = e.sha256;
    std::vector<double> decode;
    for (int i = 0; i < 10; ++i) {
      const auto t0 = Clock::now();
      const ms::Scene scene = Check(ms::ImportGltfBytes(e.bytes, "", m.name + ".glb", ms::ImportOptions()),
                                    "decoding the Draco GLB of " + m.name);
      decode.push_back(Ms(t0, Clock::now()));
      if (scene.meshes.empty()) Die("the Draco GLB of " + m.name + " has no mesh");
    }
    w.draco_first[m.name] = {{"first_call_ms", first.full_ms},
                             {"bytes", first.bytes},
                             {"client_decode", RunsSummary(decode)}};
    for (Kind k : {Kind::kUdp, Kind::kTcp}) {
      Round r = clients.Run(k, 1, m, "", args.session_timeout_s);
      if (!r.outcomes[0].ok) {
        w.failures.push_back(m.name + " " + KindName(k) + ": " + r.outcomes[0].error);
        std::fprintf(stderr, "meshstream_bench_stream: warm-up %s %s FAILED: %s\n", m.name.c_str(), KindName(k),
                     r.outcomes[0].error.c_str());
      }
    }
  }
  return w;
}

// One round of `kind` added to its row: the outcomes, the server's lines of
// its sessions, the kernel's UDP counters and the CPU.
void AddRound(Row& row, Round r, ServerLog& log, size_t logged) {
  if (row.kind != Kind::kDraco) {
    // Every session the server ran logs one line when it ends.
    if (!log.WaitSessions(logged + static_cast<size_t>(row.concurrency), std::chrono::seconds(10))) {
      row.server_lines_complete = false;
    }
    for (SessionLogLine& s : log.SessionsFrom(logged)) row.server.push_back(std::move(s));
  }
  for (Outcome& o : r.outcomes) {
    if (!o.ok) {
      std::fprintf(stderr, "meshstream_bench_stream: %s %s x%d: FAILED: %s\n", row.model.c_str(), KindName(row.kind),
                   row.concurrency, o.error.c_str());
    }
    row.outcomes.push_back(std::move(o));
  }
  const json udp = KernelUdpDelta(r.udp_before, r.udp_after);
  for (auto it = udp.begin(); it != udp.end(); ++it) row.kernel_udp[it.key()] += it.value().get<uint64_t>();
  row.wall_s += r.wall_s;
  row.process_cpu_s += r.cpu_after.process_s - r.cpu_before.process_s;
  row.client_cpu_s += r.client_cpu_s;
  row.machine_busy += r.cpu_after.machine_busy - r.cpu_before.machine_busy;
  row.machine_total += r.cpu_after.machine_total - r.cpu_before.machine_total;
}

// The three rows of one model at `n` concurrent sessions, the kinds taking
// turns round by round; appended to *rows (Draco's first, each session row
// with its ratios to it). Returns their failures.
uint64_t MeasureRows(const Args& args, RoundClient& clients, const Model& m, int n, const std::string& sha,
                     ServerLog& log, json* rows) {
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
      AddRound(by_kind[k], clients.Run(k, n, m, sha, args.session_timeout_s), log, logged);
    }
  }
  json draco = RowJson(by_kind[Kind::kDraco]);
  uint64_t failures = draco["failures"].get<uint64_t>();
  rows->push_back(draco);
  const json& ref = draco["time_to_last_byte_ms"];
  for (Kind k : {Kind::kUdp, Kind::kTcp}) {
    json j = RowJson(by_kind[k]);
    failures += j["failures"].get<uint64_t>();
    if (ref.contains("p50_ms") && j["time_to_full_ms"].contains("p50_ms")) {
      j["vs_draco_export"] = {
          {"full_p50", j["time_to_full_ms"]["p50_ms"].get<double>() / ref["p50_ms"].get<double>()},
          {"full_p99", j["time_to_full_ms"]["p99_ms"].get<double>() / ref["p99_ms"].get<double>()},
          {"base_p50", j["time_to_base_ms"]["p50_ms"].get<double>() / ref["p50_ms"].get<double>()},
          {"base_p99", j["time_to_base_ms"]["p99_ms"].get<double>() / ref["p99_ms"].get<double>()}};
    }
    rows->push_back(j);
  }
  return failures;
}

}  // namespace

uint64_t RunLoopbackParts(const Args& args, std::vector<Model>& models, const std::string& store, json* out) {
  ServerLog log(args.verbose);
  const ServerOptions server_options = StreamServerOptions(args, store, &log);
  std::fprintf(stderr, "meshstream_bench_stream: starting the server (store in %s)\n", store.c_str());
  std::unique_ptr<Server> server = Check(Server::Start(server_options), "server");
  const std::string address = server->address();
  (*out)["settings"] = Settings(args, IngestModels(address, models), server_options, *server);

  // The clients in a process of their own: the server's CPU is its own.
  RoundClient clients(address, args.client_nice);
  const Warmup warmup = WarmUp(args, address, models, clients);
  uint64_t failures = warmup.failures.size();
  log.WaitSessions(2 * models.size(), std::chrono::seconds(5));

  // 1. Time to base and to full, per model and concurrency.
  json rows = json::array();
  for (const Model& m : models) {
    for (int n : args.concurrency) failures += MeasureRows(args, clients, m, n, warmup.draco_sha.at(m.name), log, &rows);
  }
  // The main server's log: its UDP endpoint's totals come when it stops.
  const std::string main_udp_line = StopAndTakeUdpTotals(server, log);
  const json notable = log.Notable(60);

  // 2. Datagrams per second: a server on the same store with a high
  // --max-rate and --max-session-rate, the loopback limit before and after.
  (*out)["datagram_rate"] = RunDatagramRate(args, models, store, &failures);
  (*out)["sessions"] = rows;
  (*out)["draco_reference"] = warmup.draco_first;
  (*out)["server"] = {{"udp_totals_line", main_udp_line}, {"log_notable", notable}};
  if (!warmup.failures.empty()) (*out)["warmup_failures"] = warmup.failures;
  return failures;
}

}  // namespace meshstream::bench::stream

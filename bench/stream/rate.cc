#include "bench/stream/rate.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <numeric>
#include <thread>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/service_load.h"
#include "bench/stream/child.h"
#include "bench/stream/server_log.h"
#include "bench/stream/sessions.h"
#include "net/udp_socket.h"
#include "sdk/client.h"
#include "testing/asset_calls.h"

namespace meshstream::bench::stream {

namespace ms = meshstream;
using json = nlohmann::json;

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
      auto client = ms::sdk::Client::Create(meshstream::test_util::PlainClientOptions(address));
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

namespace {

// N UDP sessions at a time, session after session, on `m` for `seconds`,
// their clients in a child process; the server in this one.
json DatagramRate(const std::string& address, const Model& m, int sessions, double seconds, double timeout_s,
                  int nice, ServerLog& log) {
  const size_t logged_before = log.session_count();
  ChildProcess child({"--rate-client", address, m.name, std::to_string(m.version), std::to_string(sessions),
                      std::to_string(seconds), std::to_string(timeout_s)},
                     nice);
  auto next_line = [&child] { return child.NextLine(); };
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
  child.Wait();

  const uint64_t opened = client["sessions_opened"].get<uint64_t>();
  // Sessions the server logged from "start": those of the window (the
  // warm-up sessions ended before the clients said "start").
  const bool all_logged = log.WaitSessions(logged_start + opened, std::chrono::seconds(10));
  uint64_t sent = 0, udp_sessions = 0, decreases = 0;
  std::vector<double> server_base;
  for (const SessionLogLine& s : log.SessionsFrom(logged_start)) {
    if (s.open_to_base_ms >= 0) server_base.push_back(s.open_to_base_ms);
    if (s.transport != "udp") continue;
    sent += s.datagrams_sent;
    decreases += s.decreases;
    ++udp_sessions;
  }
  const double server_cpu = after.process_s - before.process_s;
  const double client_cpu = client["process_cpu_s"].get<double>();
  json j = {{"model", m.name},
            {"concurrent_sessions", sessions},
            {"client_nice", nice},
            {"seconds_asked", seconds},
            {"wall_s", wall},
            {"client", client},
            {"warmup_sessions_logged", logged_start - logged_before},
            {"server_udp_sessions_logged", udp_sessions},
            {"all_logged", all_logged},
            {"server_rate_decreases", decreases},
            {"data_datagrams_sent", sent},
            {"server_time_to_base_ms", MsSummary(server_base)},
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

// The loopback loop's figures against meshstream's: the mean of the runs
// before and after, and the ratios.
json RateVsLoopback(const json& rate, const json& loop_before, const json& loop_after) {
  auto mean2 = [&](const char* key) {
    return (loop_before[key].get<double>() + loop_after[key].get<double>()) / 2;
  };
  const double loop_wall = mean2("datagrams_per_s_wall");
  const double loop_cpu = mean2("datagrams_per_cpu_s");
  const double loop_sender = mean2("sent_per_sender_cpu_s");
  return {{"loopback_sendmmsg", {{"before", loop_before},
                                 {"after", loop_after},
                                 {"datagrams_per_s_wall", loop_wall},
                                 {"datagrams_per_cpu_s", loop_cpu},
                                 {"sent_per_sender_cpu_s", loop_sender}}},
          // meshstream over the loopback loop: wall; the server's CPU against
          // the loop's sender thread; both ends against both ends.
          {"ratios", {{"wall", rate["datagrams_per_s_wall"].get<double>() / loop_wall},
                      {"server_cpu_vs_sender_cpu", rate["datagrams_per_server_cpu_s"].get<double>() / loop_sender},
                      {"server_cpu_vs_loop_cpu", rate["datagrams_per_server_cpu_s"].get<double>() / loop_cpu},
                      {"both_ends_cpu", rate["datagrams_per_cpu_s_both"].get<double>() / loop_cpu}}}};
}

}  // namespace

json RunDatagramRate(const Args& args, const std::vector<Model>& models, const std::string& store,
                     uint64_t* failures) {
  const Model* rate_model = &models.back();
  for (const Model& m : models) {
    if (IsLargest(m)) rate_model = &m;
  }
  std::fprintf(stderr, "meshstream_bench_stream: loopback sendmmsg limit (%.1f s)\n", args.loopback_seconds);
  json loop_before = LoopbackLimit(args.loopback_seconds);
  ServerLog rate_log(args.verbose);
  ms::ServerOptions rate_options = StreamServerOptions(args, store, &rate_log);
  rate_options.max_rate_bps = args.rate_bps;
  rate_options.max_session_rate_bps = args.rate_bps;
  std::fprintf(stderr, "meshstream_bench_stream: datagram rate: %d UDP sessions of %s for %.1f s (max rate %.3g bit/s)\n",
               args.rate_sessions, rate_model->name.c_str(), args.rate_seconds, args.rate_bps);
  std::unique_ptr<ms::Server> rate_server = Check(ms::Server::Start(rate_options), "rate server");
  json rate = DatagramRate(rate_server->address(), *rate_model, args.rate_sessions, args.rate_seconds,
                           args.session_timeout_s, args.client_nice, rate_log);
  *failures += rate["client"]["sessions_failed"].get<uint64_t>();
  const std::string udp_totals = StopAndTakeUdpTotals(rate_server, rate_log);
  if (!udp_totals.empty()) rate["server_udp_totals_line"] = udp_totals;
  std::fprintf(stderr, "meshstream_bench_stream: loopback sendmmsg limit again\n");
  json out = RateVsLoopback(rate, loop_before, LoopbackLimit(args.loopback_seconds));
  out["meshstream"] = rate;
  out["server_options"] = {{"max_rate_bps", rate_options.max_rate_bps},
                           {"max_session_rate_bps", rate_options.max_session_rate_bps}};
  out["server_log_notable"] = rate_log.Notable(30);
  return out;
}

}  // namespace meshstream::bench::stream

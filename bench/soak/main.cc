// meshstream_bench_soak: the server's memory under a long churn of sessions
// (issue 23's soak; docs/results/stream-benchmarks.md, "Soak").
//
// One run:
//   - a network namespace joined to the host by a veth pair
//     (testing/netns.h), nftables in it dropping --loss % of every packet
//     the clients receive (TCP and UDP, as the shaped link does);
//   - `meshstream serve` as a process of its own on the host side (an
//     embedded store in a temporary folder, production defaults but the
//     address), the model ingested once before anything is timed;
//   - one client process inside the namespace (this binary, --client) that
//     opens --rate sessions per second for --minutes, each on a client (a
//     connection) of its own, polls each to kComplete on a pool of threads,
//     and reports every session's outcome;
//   - every --sample-s seconds the server's resident memory and threads
//     (/proc/PID/status), with the sessions opened and done so far.
// The target: every session complete, and the server's RSS after the first
// minute never more than 10 % above its value at the first minute.
// A session that fails, or that the pool could not open within a second of
// its time (the machine could not keep the rate), is counted and reported.
// Writes one JSON object (--out, default docs/results/bench/soak.json).
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/service_stats.h"
#include "sdk/client.h"
#include "sdk/session.h"
#include "testing/asset_calls.h"
#include "testing/netns.h"
#include "testing/proc_status.h"
#include "testing/serve_process.h"
#include "testing/test_util.h"

namespace {

namespace ms = meshstream;
using json = nlohmann::json;
using ms::bench::Clock;

using ms::bench::Ms;

json MsQuantiles(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  json out = {{"n", v.size()}};
  if (v.empty()) return out;
  out["p50_ms"] = ms::bench::NearestRank(v, 0.50);
  out["p99_ms"] = ms::bench::NearestRank(v, 0.99);
  out["max_ms"] = v.back();
  return out;
}

[[noreturn]] void Usage(const std::string& error) {
  if (!error.empty()) std::fprintf(stderr, "meshstream_bench_soak: %s\n", error.c_str());
  std::fprintf(stderr,
               "usage: meshstream_bench_soak [--minutes M] [--rate N] [--loss P] [--model NAME] [--workers N]\n"
               "                             [--sample-s S] [--session-timeout-s S] [--quick] [--out FILE]\n\n"
               "Opens N sessions per second (default 20) for M minutes (default 30) against a `meshstream serve`\n"
               "process, the clients in a network namespace losing P %% (default 5) of what they receive, and\n"
               "samples the server's resident memory; needs root (ip netns, nft). Writes one JSON object.\n"
               "  --minutes M         how long sessions are opened (default 30; --quick: 1)\n"
               "  --rate N            sessions opened per second (default 20)\n"
               "  --loss P            %% of the packets the clients receive that nftables drops (default 5)\n"
               "  --model NAME        the shared model streamed, by file stem (default spot)\n"
               "  --workers N         client threads polling sessions at once (default 16)\n"
               "  --sample-s S        seconds between memory samples (default 5)\n"
               "  --session-timeout-s S  a session not complete by then is a failure (default 60)\n"
               "  --out FILE          the JSON written (default docs/results/bench/soak.json)\n");
  std::exit(error.empty() ? 0 : 2);
}

struct Args {
  double minutes = 30;
  double rate = 20;
  int loss = 5;
  std::string model = "spot";
  int workers = 16;
  double sample_s = 5;
  double session_timeout_s = 60;
  bool quick = false;
  std::string out = "docs/results/bench/soak.json";
  // --client only
  std::string server;
  std::string asset;
};

double Number(const std::string& flag, const char* text, double lo, double hi) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(v >= lo && v <= hi)) {
    Usage(flag + ": a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], not '" + text + "'");
  }
  return v;
}

Args Parse(int argc, char** argv, int first) {
  Args a;
  bool minutes_set = false;
  for (int i = first; i < argc; ++i) {
    const std::string f = argv[i];
    if (f == "--help" || f == "-h") Usage("");
    if (f == "--quick") {
      a.quick = true;
      continue;
    }
    if (i + 1 >= argc) Usage(f + ": needs a value");
    const char* v = argv[++i];
    if (f == "--minutes") {
      a.minutes = Number(f, v, 0.05, 24 * 60);
      minutes_set = true;
    } else if (f == "--rate") {
      a.rate = Number(f, v, 0.1, 1000);
    } else if (f == "--loss") {
      a.loss = static_cast<int>(Number(f, v, 0, 99));
    } else if (f == "--model") {
      a.model = v;
    } else if (f == "--workers") {
      a.workers = static_cast<int>(Number(f, v, 1, 256));
    } else if (f == "--sample-s") {
      a.sample_s = Number(f, v, 0.1, 600);
    } else if (f == "--session-timeout-s") {
      a.session_timeout_s = Number(f, v, 1, 3600);
    } else if (f == "--out") {
      a.out = v;
    } else if (f == "--server") {
      a.server = v;
    } else if (f == "--asset") {
      a.asset = v;
    } else {
      Usage("unknown flag " + f);
    }
  }
  if (a.quick && !minutes_set) a.minutes = 1;
  return a;
}

// --- the client process, inside the namespace ---------------------------

struct Outcome {
  bool ok = false;
  std::string error;
  double full_ms = 0;
  double lag_ms = 0;  // opened this long after its time in the schedule
  uint64_t lost = 0;
  bool udp = false;
};

Outcome RunOne(const Args& a) {
  Outcome o;
  auto client = ms::sdk::Client::Create(ms::test_util::PlainClientOptions(a.server));
  if (!client.ok()) {
    o.error = "Client::Create: " + client.status().ToString();
    return o;
  }
  ms::sdk::SessionOptions so;
  so.asset = a.asset;
  auto session = ms::sdk::Session::Open(**client, so);
  if (!session.ok()) {
    o.error = "Session::Open: " + session.status().ToString();
    return o;
  }
  const auto deadline = Clock::now() + std::chrono::milliseconds(static_cast<int64_t>(a.session_timeout_s * 1000));
  for (;;) {
    if (Clock::now() > deadline) {
      o.error = "not complete within the session timeout";
      return o;
    }
    const ms::sdk::Event e = (*session)->Poll(200);
    if (e.type == ms::sdk::EventType::kError) {
      o.error = e.status.ToString();
      return o;
    }
    if (e.type == ms::sdk::EventType::kComplete) break;
  }
  const ms::sdk::SessionStats& st = (*session)->stats();
  if ((*session)->level_shown() != (*session)->levels()) {
    o.error = "complete at level " + std::to_string((*session)->level_shown()) + " of " + std::to_string((*session)->levels());
    return o;
  }
  o.ok = true;
  o.full_ms = st.time_to_full_ms;
  o.lost = st.datagrams_lost;
  o.udp = st.transport == "udp";
  return o;
}

int ClientMain(int argc, char** argv) {
  const Args a = Parse(argc, argv, 2);
  if (a.server.empty() || a.asset.empty()) Usage("--client needs --server and --asset");
  const uint64_t total = static_cast<uint64_t>(a.minutes * 60 * a.rate);
  const auto t0 = Clock::now();
  std::atomic<uint64_t> next{0}, done{0}, failed{0};
  std::mutex mutex;
  std::vector<Outcome> outcomes(total);
  auto worker = [&] {
    for (;;) {
      const uint64_t k = next.fetch_add(1);
      if (k >= total) return;
      const auto due = t0 + std::chrono::microseconds(static_cast<int64_t>(1e6 * static_cast<double>(k) / a.rate));
      std::this_thread::sleep_until(due);
      const double lag = Ms(due, Clock::now());
      Outcome o = RunOne(a);
      o.lag_ms = lag;
      if (!o.ok) failed.fetch_add(1);
      done.fetch_add(1);
      std::lock_guard<std::mutex> lock(mutex);
      outcomes[k] = std::move(o);
    }
  };
  std::vector<std::thread> pool;
  for (int i = 0; i < a.workers; ++i) pool.emplace_back(worker);
  std::thread progress([&] {
    while (done.load() < total) {
      std::this_thread::sleep_for(std::chrono::seconds(10));
      std::fprintf(stderr, "meshstream_bench_soak: client: %.0f s, %llu of %llu sessions done, %llu failed\n",
                   Ms(t0, Clock::now()) / 1000, static_cast<unsigned long long>(done.load()),
                   static_cast<unsigned long long>(total), static_cast<unsigned long long>(failed.load()));
    }
  });
  for (std::thread& t : pool) t.join();
  progress.join();

  std::vector<double> full, lag;
  json errors = json::array();
  uint64_t ok = 0, late = 0, udp = 0, lost = 0;
  for (const Outcome& o : outcomes) {
    lag.push_back(o.lag_ms);
    if (o.lag_ms > 1000) ++late;
    if (!o.ok) {
      if (errors.size() < 20) errors.push_back(o.error);
      continue;
    }
    ++ok;
    full.push_back(o.full_ms);
    udp += o.udp ? 1 : 0;
    lost += o.lost;
  }
  json j = {{"sessions", total},
            {"complete", ok},
            {"failed", total - ok},
            {"opened_late", late},
            {"udp_sessions", udp},
            {"datagrams_lost", lost},
            {"time_to_full_ms", MsQuantiles(full)},
            {"open_lag_ms", MsQuantiles(lag)},
            {"errors", errors},
            {"wall_s", Ms(t0, Clock::now()) / 1000}};
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  return 0;
}

// --- the host side: server, namespace, memory samples --------------------

// The client process, its stdout read to the end on a thread.
struct Child {
  pid_t pid = -1;
  std::string out;
  std::thread reader;
};

bool StartChild(const std::string& command, Child& c) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return false;
  c.pid = fork();
  if (c.pid < 0) return false;
  if (c.pid == 0) {
    dup2(pipe_fds[1], STDOUT_FILENO);
    close(pipe_fds[0]);
    execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  close(pipe_fds[1]);
  const int fd = pipe_fds[0];
  c.reader = std::thread([fd, &c] {
    char buffer[4096];
    ssize_t n;
    while ((n = read(fd, buffer, sizeof buffer)) > 0) c.out.append(buffer, static_cast<size_t>(n));
    close(fd);
  });
  return true;
}

int HostMain(int argc, char** argv) {
  const Args a = Parse(argc, argv, 1);
  const auto run_start = Clock::now();
  json out = {{"benchmark", "meshstream_bench_soak"},
              {"settings",
               {{"minutes", a.minutes}, {"rate_per_s", a.rate}, {"loss_percent", a.loss}, {"model", a.model},
                {"workers", a.workers}, {"sample_s", a.sample_s}, {"quick", a.quick}}}};
  out["machine"] = ms::bench::MachineInfo(".", MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  auto ns = ms::test_util::NetNs::Create();
  if (!ns.ok()) {
    std::fprintf(stderr, "meshstream_bench_soak: no network namespace: %s\n", ns.status().ToString().c_str());
    return 1;
  }
  ms::test_util::TempDir dir;
  auto server = ms::test_util::ServeProcess::Start(
      {"--store", dir.File("store"), "--listen", (*ns)->host_ip() + ":0", "--insecure"});
  if (!server.ok()) {
    std::fprintf(stderr, "meshstream_bench_soak: serve: %s\n", server.status().ToString().c_str());
    return 1;
  }
  const std::string path = std::string(MESHSTREAM_MODELS_DIR) + "/" + ms::bench::ChooseSharedModels({a.model}).front();
  {
    const auto assets = ms::test_util::NewAssetClient((*server)->address());
    ms::v1::Job job;
    const std::string name = path.substr(path.find_last_of('/') + 1);
    ms::Status s = ms::test_util::IngestModel(*assets, "soak", path, name, &job);
    if (!s.ok() || job.state() != ms::v1::JOB_STATE_SUCCEEDED) {
      std::fprintf(stderr, "meshstream_bench_soak: ingest %s: %s %s\n", path.c_str(), s.ToString().c_str(),
                   job.message().c_str());
      return 1;
    }
  }
  ms::Status loss = (*ns)->SetLoss(a.loss, false);
  if (!loss.ok()) {
    std::fprintf(stderr, "meshstream_bench_soak: nft: %s\n", loss.ToString().c_str());
    return 1;
  }
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
  if (n <= 0) return 1;
  self[n] = '\0';
  char numbers[256];
  std::snprintf(numbers, sizeof numbers, " --minutes %g --rate %g --workers %d --session-timeout-s %g", a.minutes,
                a.rate, a.workers, a.session_timeout_s);
  const std::string command = (*ns)->Inside(ms::test_util::Quote(self) + " --client --server " +
                                            (*server)->address() + " --asset soak" + numbers);
  std::fprintf(stderr, "meshstream_bench_soak: %g sessions/s of %s for %g min at %d %% loss; server pid %d\n", a.rate,
               a.model.c_str(), a.minutes, a.loss, static_cast<int>((*server)->pid()));
  Child child;
  if (!StartChild(command, child)) return 1;
  const auto t0 = Clock::now();
  json samples = json::array();
  int status = 0;
  for (;;) {
    const ms::test_util::ProcStatus p = ms::test_util::ReadProcStatus((*server)->pid());
    samples.push_back({{"t_s", Ms(t0, Clock::now()) / 1000}, {"rss_kib", p.rss_kib}, {"threads", p.threads}});
    const auto until = Clock::now() + std::chrono::milliseconds(static_cast<int64_t>(a.sample_s * 1000));
    bool exited = false;
    while (Clock::now() < until) {
      if (waitpid(child.pid, &status, WNOHANG) == child.pid) {
        exited = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    if (exited) break;
  }
  child.reader.join();
  const ms::test_util::ProcStatus last = ms::test_util::ReadProcStatus((*server)->pid());
  samples.push_back({{"t_s", Ms(t0, Clock::now()) / 1000}, {"rss_kib", last.rss_kib}, {"threads", last.threads}});
  json client = json::parse(child.out, nullptr, false);
  if (client.is_discarded()) client = {{"error", "the client process printed no JSON (exit status " + std::to_string(status) + ")"}};

  // The memory: its value at the first minute (the sample nearest 60 s; in
  // a shorter run, the last) against the most after it.
  double at_minute = -1, max_after = -1, first_t = 1e300;
  for (const json& s : samples) {
    const double t = s["t_s"], rss = s["rss_kib"];
    if (std::abs(t - 60) < first_t) {
      first_t = std::abs(t - 60);
      at_minute = rss;
    }
  }
  for (const json& s : samples) {
    if (s["t_s"].get<double>() >= 60 - a.sample_s / 2 || a.minutes * 60 < 60) max_after = std::max(max_after, s["rss_kib"].get<double>());
  }
  const double growth = at_minute > 0 ? 100.0 * (max_after - at_minute) / at_minute : -1;
  const uint64_t sessions = client.value("sessions", uint64_t{0}), complete = client.value("complete", uint64_t{0});
  out["server_rss"] = {{"samples", samples},
                       {"at_first_minute_kib", at_minute},
                       {"max_after_first_minute_kib", max_after},
                       {"growth_after_first_minute_percent", growth},
                       {"final_kib", last.rss_kib}};
  out["client"] = client;
  out["target"] = {{"rss_growth_percent_at_most", 10},
                   {"every_session_complete", sessions > 0 && complete == sessions},
                   {"met", sessions > 0 && complete == sessions && growth >= 0 && growth <= 10}};
  out["server_exit"] = (*server)->Terminate();
  out["wall_s"] = Ms(run_start, Clock::now()) / 1000;
  ms::bench::WriteJson(a.out, out);
  std::fprintf(stderr,
               "meshstream_bench_soak: %llu of %llu sessions complete; server RSS %.0f KiB at 1 min, at most %.0f "
               "after (%+.1f %%); wrote %s\n",
               static_cast<unsigned long long>(complete), static_cast<unsigned long long>(sessions), at_minute,
               max_after, growth, a.out.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::SetProgramName("meshstream_bench_soak");
  signal(SIGPIPE, SIG_IGN);
  if (argc > 1 && std::string(argv[1]) == "--client") return ClientMain(argc, argv);
  return HostMain(argc, argv);
}

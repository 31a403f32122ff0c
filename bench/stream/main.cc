// meshstream_bench_stream: the benchmark of the streaming sessions
// (docs/results/stream-benchmarks.md).
//
// One process runs everything on one machine, in one run:
//   - a meshstream server (Server::Start, in-process, 2 workers, UDP on the
//     next port) on the embedded store (SQLite + blob folder) in a
//     temporary folder; the models are ingested once, before anything is
//     timed: the bunny, the horse and the largest single-file model of the
//     shared folder (by file size) (models.h);
//   - the clients: threads of a child process (this program again with
//     --round-client, round_client.h; the rate run's with --rate-client),
//     each with its own sdk::Client (or asset API client for the
//     reference) (sessions.h), so that this process's CPU is the server's.
// What it measures:
//   1. per model and number of concurrent sessions (1, 10, 100): SDK
//      sessions over UDP and over the gRPC stream (tcp_only), each polled
//      to kComplete on its own thread: time to the base mesh and to the
//      full mesh (SessionStats), p50 and p99, the datagrams lost per
//      session over loopback; beside them, in the same rounds, the
//      reference: the same version exported as FORMAT_DRACO_GLB through the
//      same server's AssetService.Export (time to the last byte; the export
//      cache warm, as a server serving that file would have it), and the
//      ratios of both times to it (loopback.h);
//   2. the server's DATA datagrams per second (wall and per CPU-second) with
//      N sessions over UDP on a server started with a high --max-rate and
//      --max-session-rate on the same store, beside the loopback limit: a
//      tight sendmmsg loop of 1200-byte datagrams between two UDP sockets
//      on 127.0.0.1 (net/udp_socket.h), the receiver draining with recvmmsg
//      on another thread (rate.h);
//   3. the shaped, lossy link (--shaped, the default; skipped with the
//      system's reason where a network namespace cannot be made): a server
//      on the host side of a veth pair, each session (UDP and tcp_only) and
//      each Draco GLB download in a child process inside the namespace,
//      tbf on both ends, nftables dropping 0, 2, 5 and 12 % of TCP and UDP,
//      the same one-way delay on both channels (the UDP relay, the TCP delay
//      proxy); per model (the bunny, the horse, the largest shared model by
//      vertices) the time to the first visible mesh and to the full mesh,
//      and the Hausdorff distance of what is shown over time to the full
//      lossless mesh (snapshots at the events, measured after the runs)
//      (shaped.h, shaped_client.h).
// A session that ends in kError (or does not reach the full mesh, or takes
// longer than the deadline) and an export that fails are counted and
// reported ("failures"; the shaped link's in "shaped"), never timed.
// Writes one JSON object (--out, default docs/results/bench/stream.json);
// bench/plot_stream.py draws it.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/stream/args.h"
#include "bench/stream/loopback.h"
#include "bench/stream/models.h"
#include "bench/stream/rate.h"
#include "bench/stream/round_client.h"
#include "bench/stream/shaped.h"
#include "bench/stream/shaped_client.h"

namespace {

namespace ms = meshstream;
namespace stream = meshstream::bench::stream;
using json = nlohmann::json;
using ms::bench::Clock;
using ms::bench::Ms;

json MachineInfo(const stream::Args& args) {
  json m = ms::bench::MachineInfo(args.work_dir, MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  m["net_core_rmem_max"] = ms::bench::FirstLineOf("cat /proc/sys/net/core/rmem_max 2>/dev/null");
  m["net_core_wmem_max"] = ms::bench::FirstLineOf("cat /proc/sys/net/core/wmem_max 2>/dev/null");
  return m;
}

// --only-shaped: into the --out file of an earlier full run when there is
// one (its loopback parts kept as they are; true), else on its own.
bool StartOnlyShaped(const stream::Args& args, const std::vector<stream::Model>& models, json& out) {
  std::ifstream earlier(args.out);
  json e = earlier ? json::parse(earlier, nullptr, false) : json();
  if (e.is_object() && e.value("benchmark", std::string()) == "meshstream_bench_stream" && e.contains("sessions")) {
    std::fprintf(stderr, "meshstream_bench_stream: --only-shaped: replacing the shaped part of %s\n", args.out.c_str());
    out = std::move(e);
    out.erase("shaped");
    return true;
  }
  json model_info = json::array();
  for (const stream::Model& m : models) model_info.push_back({{"name", m.name}, {"file", m.file}, {"roles", m.roles}});
  out["settings"] = {{"models", model_info}, {"quick", args.quick}, {"only_shaped", true}};
  return false;
}

// --no-shaped: the shaped part of the --out file of an earlier run, kept as
// it is (it carries its own machine, date and commit), or null.
json EarlierShaped(const stream::Args& args) {
  std::ifstream earlier(args.out);
  json e = earlier ? json::parse(earlier, nullptr, false) : json();
  if (!e.is_object() || e.value("benchmark", std::string()) != "meshstream_bench_stream" || !e.contains("shaped")) {
    return nullptr;
  }
  std::fprintf(stderr, "meshstream_bench_stream: --no-shaped: keeping the shaped part of %s\n", args.out.c_str());
  return std::move(e["shaped"]);
}

// 3. The shaped link: a server of its own on the same store (the loopback
// server has stopped), on the host side of a veth pair; with the machine's
// facts of its own (a merged run's top-level machine is the earlier run's).
json Shaped(const stream::Args& args, const std::string& store, const std::string& folder,
            const std::vector<stream::Model>& models, bool merged) {
  const auto shaped_start = Clock::now();
  json machine = MachineInfo(args);
  json shaped = stream::RunShaped(args, store, folder, models);
  machine["loadavg_at_end"] = ms::bench::LoadAverage();
  machine["run_seconds"] = Ms(shaped_start, Clock::now()) / 1000;
  shaped["machine"] = machine;
  shaped["run"] = args.only_shaped
                      ? (merged ? "only_shaped, merged into the JSON of an earlier full run" : "only_shaped")
                      : "with the loopback parts";
  shaped["quick"] = args.quick;
  return shaped;
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::SetProgramName("meshstream_bench_stream");
  if (argc > 1 && std::string(argv[1]) == "--rate-client") return stream::RateClientMain(argc, argv);
  if (argc > 1 && std::string(argv[1]) == "--shaped-client") return stream::ShapedClientMain(argc, argv);
  if (argc > 1 && std::string(argv[1]) == "--round-client") return stream::RoundClientMain(argc, argv);
  const stream::Args args = stream::ParseArgs(argc, argv);
  const auto run_start = Clock::now();
  json out;
  out["benchmark"] = "meshstream_bench_stream";
  out["machine"] = MachineInfo(args);
  std::vector<stream::Model> models = stream::ChooseModels(args);

  // The store (production defaults but the port and the workers).
  const std::string folder = ms::bench::MakeTempFolder(args.work_dir, "meshstream-bench-stream");
  const std::string store = folder + "/store";
  uint64_t failures = 0;
  bool merged = false;
  if (!args.only_shaped) {
    failures = stream::RunLoopbackParts(args, models, store, &out);
  } else {
    merged = StartOnlyShaped(args, models, out);
    if (merged) failures = out.value("failures", uint64_t{0});
  }
  uint64_t shaped_failures = 0;
  if (!args.shaped) {
    json shaped = EarlierShaped(args);
    if (!shaped.is_null()) out["shaped"] = std::move(shaped);
  }
  if (args.shaped) {
    json shaped = Shaped(args, store, folder, models, merged);
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
    std::filesystem::remove_all(folder, ec);
  }
  ms::bench::WriteJson(args.out, out);
  std::fprintf(stderr, "meshstream_bench_stream: wrote %s in %.0f s (%llu failures on loopback, %llu on the shaped link)\n",
               args.out.c_str(), Ms(run_start, Clock::now()) / 1000, static_cast<unsigned long long>(failures),
               static_cast<unsigned long long>(shaped_failures));
  return 0;
}

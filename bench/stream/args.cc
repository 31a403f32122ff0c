#include "bench/stream/args.h"

#include <filesystem>
#include <limits>

#include "bench/options.h"

namespace meshstream::bench::stream {

namespace {

constexpr double kMax = std::numeric_limits<double>::max();

const char kAbout[] =
    "Benchmarks the streaming sessions (meshstream serve, in this process, SQLite store) against\n"
    "the Draco GLB export of the same server and the loopback's sendmmsg limit, measured in the\n"
    "same run, and then over a shaped, lossy link (a network namespace; skipped, with the reason,\n"
    "where namespaces cannot be made); writes one JSON object (default docs/results/bench/stream.json).\n";

// The loopback parts' options (1. and 2.).
void LoopbackOptions(Options& o, Args& a) {
  o.Flag("--quick", &a.quick,
         "a short run: --samples 20 --min-rounds 1 --largest-rounds-at-100 1, 1 s\n"
         "rate and loopback runs (about 25 s), --shaped-runs 2 (about 80 s)");
  AddModelOptions(o, &a.models_dir, &a.only, "only this model (file stem, e.g. horse); repeatable");
  o.IntList("--concurrency", "LIST", &a.concurrency, 1, 200, "concurrent sessions of the latency rows (default 1,10,100)");
  o.Int("--samples", "N", &a.samples, 1, 100000, "timed sessions per row at least: ceil(N / sessions) rounds (default 200)");
  o.Int("--min-rounds", "N", &a.min_rounds, 1, 1000, "rounds per row at least (default 3)");
  o.Int("--largest-rounds-at-100", "N", &a.largest_rounds_at_100, 1, 1000,
        "rounds of the largest model's rows at 100 or more sessions instead\n(default 2; --quick: 1)");
  o.Int("--rate-sessions", "N", &a.rate_sessions, 1, 200, "concurrent UDP sessions of the datagram-rate run (default 10)");
  o.Double("--rate-seconds", "S", &a.rate_seconds, 0, 600, "how long each of them opens session after session (default 4)",
           true);
  o.Double("--rate-bps", "BPS", &a.rate_bps, 1e6, kMax,
           "--max-rate and --max-session-rate of the rate run's server (default 1e10)");
  o.Double("--loopback-seconds", "S", &a.loopback_seconds, 0, 600,
           "each sendmmsg loopback run, one before and one after (default 2)", true);
  o.Double("--session-timeout-s", "S", &a.session_timeout_s, 0, kMax,
           "a session or export not complete by then is a failure (default 120)", true);
  o.Int("--workers", "N", &a.workers, 1, 64, "job workers of the server (default 2; also its concurrent decoding exports)");
  o.Int("--client-nice", "N", &a.client_nice, 0, 19,
        "niceness of the clients' processes on loopback (default 0: the server's;\n"
        "19: the server first, as on a machine of its own)");
  o.String("--work-dir", "DIR", &a.work_dir, "where the store lives (default: $TMPDIR or /tmp)");
  o.String("--out", "FILE", &a.out, "the JSON written (default docs/results/bench/stream.json)");
  o.Flag("--verbose", &a.verbose, "the server's log lines on stderr");
}

// The shaped link's options (3.).
void ShapedOptions(Options& o, Args& a) {
  o.Section("The shaped link (needs root: ip netns, nft, tc tbf):");
  o.Action("--shaped", [&a] { a.shaped = true; }, "run it (the default)");
  o.Action("--no-shaped", [&a] { a.shaped = false; },
           "do not run it (the shaped part of the --out file of an earlier run, if\n"
           "any, is kept as it is)");
  o.Action("--only-shaped", [&a] { a.only_shaped = a.shaped = true; },
           "only it (into the --out file of an earlier full run when there is one:\n"
           "its other parts are kept)");
  o.Int("--shaped-runs", "N", &a.shaped_runs, 1, 1000, "runs per loss, model and kind (default 5; --quick: 2)");
  o.Double("--shaped-rate", "MBIT", &a.shaped_rate_mbit, 0.1, 10000, "tbf rate on both veth ends (default 20)");
  o.Double("--shaped-delay-ms", "MS", &a.shaped_delay_ms, 0, 2000,
           "one-way delay of both channels: UDP relay and TCP proxy (default 20)");
  o.IntList("--shaped-loss", "LIST", &a.shaped_losses, 0, 99, "nftables drop percentages, TCP and UDP (default 0,2,5,12)");
  o.Flag("--shaped-large", &a.shaped_large,
         "add the large model: the bunny subdivided twice with scan-like noise\n(557 k vertices, made by the benchmark; named bunny-scan-557k)");
  o.Flag("--shaped-loss-udp-only", &a.shaped_udp_only_loss,
         "drop UDP only (an experiment: what TCP's losses cost the sessions)");
  o.Int("--shaped-snapshots", "N", &a.shaped_snapshots, 2, 1000,
        "meshes kept per session for the distances, base and end included\n(default 12)");
  o.Int64("--shaped-samples", "N", &a.shaped_samples, 0, 100000000,
          "surface samples per side of each Hausdorff distance (default 200000)");
  o.Double("--shaped-timeout-s", "S", &a.shaped_timeout_s, 0, kMax,
           "a session or download not done by then is a failure (default 60)", true);
}

}  // namespace

Args ParseArgs(int argc, char** argv) {
  Args a;
  Options o("meshstream_bench_stream", kAbout);
  LoopbackOptions(o, a);
  ShapedOptions(o, a);
  o.Parse(argc, argv);
  if (a.quick) {
    if (!o.Given("--samples")) a.samples = 20;
    if (!o.Given("--min-rounds")) a.min_rounds = 1;
    if (!o.Given("--largest-rounds-at-100")) a.largest_rounds_at_100 = 1;
    if (!o.Given("--rate-seconds")) a.rate_seconds = 1;
    if (!o.Given("--loopback-seconds")) a.loopback_seconds = 1;
    if (!o.Given("--shaped-runs")) a.shaped_runs = 2;
  }
  if (a.work_dir.empty()) a.work_dir = std::filesystem::temp_directory_path().string();
  return a;
}

}  // namespace meshstream::bench::stream

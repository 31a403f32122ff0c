#include "bench/service/args.h"

#include <filesystem>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/options.h"

namespace meshstream::bench::service {

namespace ms = meshstream;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

const char kAbout[] =
    "Benchmarks the asset service (meshstream serve, in this process) on both stores, beside\n"
    "the floors measured in the same run; writes one JSON object (default docs/results/bench/service.json).\n";

}  // namespace

Args ParseArgs(int argc, char** argv) {
  Args a;
  ms::bench::Options o("meshstream_bench_service", kAbout);
  o.Flag("--quick", &a.quick, "a short run: bunny, horse and spot, one of each ingest, fewer calls");
  AddModelOptions(o, &a.models_dir, &a.only, "only this model (file stem, e.g. horse); repeatable");
  o.Custom("--backends", "LIST", [&a](const std::string& v) {
    a.backends = SplitList(v);
    for (const auto& b : a.backends) {
      if (b != "sqlite" && b != "postgresql") Die("--backends: '" + b + "' is not sqlite or postgresql");
    }
    if (a.backends.empty()) Die("--backends: empty list");
  }, "sqlite, postgresql or both (default both)");
  o.Int("--repeat", "N", &a.repeat, 1, 100, "fresh plain ingests per model and backend (default 5)");
  o.Int("--resumable-repeat", "N", &a.resumable_repeat, 0, 100,
        "fresh resumable ingests (upload_id) per model and backend (default 3)");
  o.Int("--cache-repeat", "N", &a.cache_repeat, 0, 100, "ingests the artifact cache answers, per model and backend (default 3)");
  o.IntList("--clients", "LIST", &a.clients, 1, 1000, "concurrent clients of the latency runs (default 1,10,100)");
  o.Int("--calls", "N", &a.calls, 1, 10000000, "calls per RPC and client count, spread over the clients (default 4000)");
  o.Int("--min-calls", "N", &a.min_calls, 1, 1000000, "at least this many calls per client (default 20)");
  o.Int("--rounds", "N", &a.rounds, 1, 100, "the calls in N interleaved rounds of every RPC (default 2)");
  o.Int("--versions", "N", &a.versions, 51, 10000, "versions of the asset ListVersions and GetVersion read (default 100)");
  o.Int("--workers", "N", &a.workers, 1, 64, "job workers of each server (default 2)");
  o.String("--work-dir", "DIR", &a.work_dir, "where the stores and the PostgreSQL cluster live (default: $TMPDIR or /tmp)");
  o.Custom("--pg-fsync", "on|off", [&a](const std::string& v) {
    if (v != "on" && v != "off") Die("--pg-fsync: on or off");
    a.pg_fsync = v == "on";
  }, "PostgreSQL's fsync (default on: what a deployment pays)");
  o.String("--out", "FILE", &a.out, "the JSON written (default docs/results/bench/service.json)");
  o.Flag("--verbose", &a.verbose, "the servers' log lines on stderr");
  o.Parse(argc, argv);
  if (a.quick) {
    if (a.only.empty()) a.only = {"stanford-bunny", "horse", "spot"};
    if (!o.Given("--repeat")) a.repeat = 1;
    if (!o.Given("--resumable-repeat")) a.resumable_repeat = 1;
    if (!o.Given("--cache-repeat")) a.cache_repeat = 1;
    if (!o.Given("--calls")) a.calls = 400;
    if (!o.Given("--rounds")) a.rounds = 1;
  }
  if (a.work_dir.empty()) a.work_dir = fs::temp_directory_path().string();
  return a;
}

}  // namespace meshstream::bench::service

// meshstream_bench_service: the benchmark of the asset service
// (docs/results/service-benchmarks.md).
//
// One process runs everything on one machine, in one run:
//   - a meshstream server per backend (Server::Start, in-process, 2 workers):
//     the embedded store (SQLite + blob folder) in a temporary folder, and the
//     shared store (PostgreSQL) on a throwaway cluster this program starts
//     with fsync=on; both run for the whole benchmark and are measured
//     interleaved, so that they see the same machine;
//   - a trivial gRPC server (bench/service_echo.h): the floors;
//   - the clients (threads of this process).
// What it measures:
//   - per shared model and backend: Ingest (the upload until IngestResponse;
//     plain and resumable), time to READY (IngestResponse until WatchJob
//     reports SUCCEEDED; also from the store's own job stamps), a cache hit,
//     and the references beside them: the same messages streamed into the
//     echo server's sink, the bytes written and fsync'd into a file, their
//     SHA-256, the job's import + encode (ProcessSource) run in this process;
//   - GetVersion, ListVersions (page_size 50 over an asset with 100
//     versions) and the server's health Check with 1, 10 and 100 concurrent
//     clients beside an echo of the trivial server, measured the same way
//     in the same rounds (bench/service_load.h);
//   - Export: FORMAT_PROGRESSIVE_GLB (a verified blob read), FORMAT_GLB first
//     call (decode + export + store) and second call (the export cache).
// Every call's status is checked; a failed call is counted and reported in
// the JSON ("failures"), never timed. Writes one JSON object (--out, default
// docs/results/bench/service.json); bench/plot_service.py draws it.
// The parts: args, models, backend, ingest, references, latency (bench/README.md).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <pqxx/version.hxx>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/service/args.h"
#include "bench/service/backend.h"
#include "bench/service/ingest.h"
#include "bench/service/latency.h"
#include "bench/service/models.h"
#include "bench/service/references.h"
#include "bench/service_echo.h"

namespace {

namespace ms = meshstream;
namespace service = meshstream::bench::service;
using json = nlohmann::json;
using ms::bench::Check;
using ms::bench::Clock;
using ms::bench::Ms;

json MachineInfo(const service::Args& args) {
  json m = ms::bench::MachineInfo(args.work_dir, MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  m["libpqxx"] = PQXX_VERSION;
  return m;
}

json SettingsJson(const service::Args& args, const std::vector<service::Model>& models) {
  json names = json::array();
  for (const service::Model& m : models) names.push_back(m.file);
  return {
      {"models", names},
      {"backends", args.backends},
      {"workers", args.workers},
      {"repeat", args.repeat},
      {"resumable_repeat", args.resumable_repeat},
      {"cache_repeat", args.cache_repeat},
      {"clients", args.clients},
      {"calls", args.calls},
      {"min_calls_per_client", args.min_calls},
      {"rounds", args.rounds},
      {"latency_versions", args.versions},
      {"page_size", 50},
      {"chunk_bytes", 1 << 20},
      {"quick", args.quick},
      {"pg_fsync", args.pg_fsync},
      {"MB", "10^6 bytes"},
      {"percentiles", "nearest rank over every successful call of all clients and rounds"},
      {"channels", "one channel per client thread, each its own TCP connection (GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL)"},
      {"client_call", "grpc::GenericStub::PrepareUnaryCall on the thread's own CompletionQueue, serialized requests; "
                      "latency = prepare until the response is parsed and checked"},
      {"variants", "fresh ingest k: the model's bytes with a comment (OBJ, PLY) or JSON whitespace (.glb) "
                   "added, and qt 10 + k (qn 8 + k for a model with texture coordinates), bits of an attribute "
                   "the model lacks: source blob, artifact and export cache are all new, the encoder's work the "
                   "same"},
  };
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::SetProgramName("meshstream_bench_service");
  const service::Args args = service::ParseArgs(argc, argv);
  const auto run_start = Clock::now();
  json out;
  out["benchmark"] = "meshstream_bench_service";
  out["machine"] = MachineInfo(args);
  const std::vector<service::Model> models = service::LoadModels(args);
  const service::Model spot = service::LoadModel(args.models_dir, "spot.obj");

  // Servers: the echo floor and one meshstream server per backend.
  auto echo = Check(ms::bench::EchoServer::Start(), "echo server");
  std::vector<std::unique_ptr<service::Backend>> owned;
  std::vector<service::Backend*> backends;
  for (const std::string& name : args.backends) {
    owned.push_back(std::make_unique<service::Backend>());
    owned.back()->name = name;
    std::fprintf(stderr, "meshstream_bench_service: starting the %s server\n", name.c_str());
    service::StartBackend(*owned.back(), args);
    backends.push_back(owned.back().get());
  }
  json backends_info = service::BackendsInfo(backends, args);
  out["settings"] = SettingsJson(args, models);
  service::WarmUp(backends, spot);
  out["references"] = service::References(args, models, backends, echo->address());
  for (const service::Model& m : models) service::MeasureIngest(args, m, backends);

  const json latency = service::MeasureLatency(args, backends, spot, echo->address());
  service::AddStoreSizes(backends, backends_info);

  json backend_results = json::array();
  uint64_t failures = 0;
  for (service::Backend* b : backends) {
    failures += b->failures.size();
    backend_results.push_back({{"name", b->name},
                               {"info", backends_info[b->name]},
                               {"ingest", b->ingest},
                               {"export", b->exports},
                               {"failures", b->failures}});
  }
  uint64_t failed_calls = 0;
  for (const json& e : latency) failed_calls += e["failed"].get<uint64_t>() + e["warmup_failed"].get<uint64_t>();
  out["backends"] = backend_results;
  out["latency"] = latency;
  out["ratios"] = service::RatiosToEcho(args, latency);
  out["failures"] = {{"ingest_and_export", failures}, {"latency_calls", failed_calls}};
  out["machine"]["loadavg_at_end"] = ms::bench::LoadAverage();
  out["machine"]["run_seconds"] = Ms(run_start, Clock::now()) / 1000;

  for (auto& b : owned) service::StopBackend(*b);
  echo.reset();
  ms::bench::WriteJson(args.out, out);
  std::fprintf(stderr, "meshstream_bench_service: wrote %s in %.0f s (%llu failed ingests or exports, %llu failed "
                       "calls)\n",
               args.out.c_str(), out["machine"]["run_seconds"].get<double>(),
               static_cast<unsigned long long>(failures), static_cast<unsigned long long>(failed_calls));
  return 0;
}

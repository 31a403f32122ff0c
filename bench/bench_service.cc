// meshstream_bench_service: the benchmark of the asset service
// (docs/service-benchmarks.md).
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
// docs/bench/service.json); bench/plot_service.py draws it.
#include <fcntl.h>
#include <pqxx/version.hxx>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <google/protobuf/stubs/common.h>
#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/service_echo.h"
#include "bench/service_load.h"
#include "bench/harness.h"
#include "bench/options.h"
#include "bench/service_stats.h"
#include "importers/import.h"
#include "meshstream/v1/asset_service.grpc.pb.h"
#include "services/pipeline/encode_options.h"
#include "services/pipeline/process_source.h"
#include "services/server/server.h"
#include "services/store/blob_store.h"
#include "testing/pg_cluster.h"

namespace {

using json = nlohmann::json;
namespace ms = meshstream;
namespace v1 = meshstream::v1;
namespace fs = std::filesystem;
using ms::bench::Check;
using ms::bench::Clock;
using ms::bench::Die;
using ms::bench::FirstLineOf;
using ms::bench::Median;
using ms::bench::Ms;
using ms::bench::ShellQuote;
using ms::bench::SplitList;
using ms::bench::StopServer;
using ms::bench::AssetApi;

const char kAbout[] =
    "Benchmarks the asset service (meshstream serve, in this process) on both stores, beside\n"
    "the floors measured in the same run; writes one JSON object (default docs/bench/service.json).\n";

struct Args {
  std::string models_dir = MESHSTREAM_MODELS_DIR;
  std::vector<std::string> only;
  std::vector<std::string> backends = {"sqlite", "postgresql"};
  int repeat = 5;
  int resumable_repeat = 3;
  int cache_repeat = 3;
  std::vector<int> clients = {1, 10, 100};
  int calls = 4000;
  int min_calls = 20;
  int rounds = 2;
  int versions = 100;
  int workers = 2;
  std::string work_dir;
  bool pg_fsync = true;
  bool quick = false;
  bool verbose = false;
  std::string out = std::string(MESHSTREAM_SOURCE_DIR) + "/docs/bench/service.json";
};

Args ParseArgs(int argc, char** argv) {
  Args a;
  ms::bench::Options o("meshstream_bench_service", kAbout);
  o.Flag("--quick", &a.quick, "a short run: bunny, horse and spot, one of each ingest, fewer calls");
  o.String("--models", "DIR", &a.models_dir, "folder of the shared models (default: the build's MESHSTREAM_MODELS_DIR)");
  o.Append("--model", "NAME", &a.only, "only this model (file stem, e.g. horse); repeatable");
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
  o.String("--out", "FILE", &a.out, "the JSON written (default docs/bench/service.json)");
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

// ------------------------------------------------------------ the machine

json MachineInfo(const Args& args) {
  json m = ms::bench::MachineInfo(args.work_dir, MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  m["libpqxx"] = PQXX_VERSION;
  return m;
}

// ------------------------------------------------------------- the models

struct Model {
  std::string name;      // the stem: the asset's name
  std::string file;      // the file name in the upload
  std::string path;
  std::vector<uint8_t> bytes;
  bool has_normals = false, has_texcoords = false;  // in any primitive
};

const char* const kModelFiles[] = {"stanford-bunny.obj", "horse.ply",  "fandisk.obj",
                                   "rocker-arm.obj",     "spot.obj",   "gltf/2CylinderEngine.glb"};

Model LoadModel(const std::string& dir, const std::string& relative) {
  Model m;
  m.path = dir + "/" + relative;
  m.file = fs::path(relative).filename().string();
  m.name = ms::bench::Stem(relative);
  m.bytes = Check(ms::ReadFileBytes(m.path, uint64_t{1} << 30), m.path);
  const ms::Scene scene = Check(ms::ImportFile(m.path), m.path);
  for (const ms::Primitive* p : ms::bench::Primitives(scene)) {
    m.has_normals = m.has_normals || !p->normals.empty();
    m.has_texcoords = m.has_texcoords || !p->texcoords.empty();
  }
  return m;
}

// Variant k of a model's bytes: the same mesh in other bytes, so that the
// source blob is new (the PostgreSQL store would skip storing bytes it has)
// -- a comment for OBJ and PLY, whitespace in the JSON chunk of a .glb.
std::vector<uint8_t> VariantBytes(const Model& m, int k) {
  std::vector<uint8_t> b = m.bytes;
  const std::string tag = "meshstream_bench_service variant " + std::to_string(k);
  const std::string ext = fs::path(m.file).extension().string();
  if (ext == ".obj") {
    const std::string line = "\n# " + tag + "\n";
    b.insert(b.end(), line.begin(), line.end());
  } else if (ext == ".ply") {
    // After "ply" and the "format" line, where a comment may be.
    auto eol = std::find(b.begin(), b.end(), '\n');
    if (eol != b.end()) eol = std::find(eol + 1, b.end(), '\n');
    if (eol == b.end()) Die(m.path + ": not a PLY header");
    const std::string line = "comment " + tag + "\n";
    b.insert(eol + 1, line.begin(), line.end());
  } else if (ext == ".glb") {
    auto u32 = [&b](size_t at) {
      return uint32_t{b[at]} | uint32_t{b[at + 1]} << 8 | uint32_t{b[at + 2]} << 16 | uint32_t{b[at + 3]} << 24;
    };
    auto put = [&b](size_t at, uint32_t v) {
      for (int i = 0; i < 4; ++i) b[at + static_cast<size_t>(i)] = static_cast<uint8_t>(v >> (8 * i));
    };
    if (b.size() < 20 || u32(16) != 0x4E4F534Au) Die(m.path + ": not a .glb with a JSON chunk first");
    const uint32_t json_length = u32(12);
    const size_t pad = 4 * static_cast<size_t>(k + 1);  // JSON whitespace, the chunk stays 4-aligned
    b.insert(b.begin() + 20 + json_length, pad, ' ');
    put(12, json_length + static_cast<uint32_t>(pad));
    put(8, static_cast<uint32_t>(b.size()));
  } else {
    Die(m.path + ": no way to vary a " + ext + " file");
  }
  return b;
}

// The encode options of variant k: the defaults but the bits of an attribute
// the model does not have (qt 10 + k without texture coordinates, else qn
// 8 + k without normals): the stream header records them, so the artifact
// (and the export cache's key) is new too, while the encoder does the same
// work. (packet_bytes would not do: datagrams are cut evenly, and a few bytes
// more or less rarely move a cut.)
v1::EncodeOptions VariantOptions(const Model& m, int k) {
  v1::EncodeOptions o;
  if (!m.has_texcoords) {
    if (10 + k > 30) Die("too many variants for qt (at most 21)");
    o.set_qt(10 + k);
  } else if (!m.has_normals) {
    if (8 + k > 15) Die(m.file + ": too many variants for qn (at most 8)");
    o.set_qn(8 + k);
  } else {
    Die(m.file + ": has normals and texture coordinates: no option to vary without changing the work");
  }
  return o;
}

double MBps(uint64_t bytes, double ms) { return ms > 0 ? static_cast<double>(bytes) / 1e6 / (ms / 1e3) : 0; }

int64_t TimestampMs(const google::protobuf::Timestamp& t) { return t.seconds() * 1000 + t.nanos() / 1000000; }

// ------------------------------------------------------------ the backends

struct Backend {
  std::string name;   // "sqlite" or "postgresql"
  std::string store;  // the --store value
  std::string folder; // the temporary folder of the SQLite store
  std::unique_ptr<ms::test_util::PgCluster> pg;
  std::unique_ptr<ms::Server> server;
  std::unique_ptr<AssetApi> client;
  json failures = json::array();
  json ingest = json::object();
  json exports = json::object();
  std::vector<std::string> log;
};

void Fail(Backend& b, const std::string& what, const std::string& error) {
  std::fprintf(stderr, "meshstream_bench_service: %s: %s: FAILED: %s\n", b.name.c_str(), what.c_str(), error.c_str());
  b.failures.push_back({{"what", what}, {"error", error}});
}

std::string StatusText(const grpc::Status& s) {
  return "status " + std::to_string(s.error_code()) + ": " + s.error_message();
}

void StartBackend(Backend& b, const Args& args) {
  if (b.name == "sqlite") {
    b.folder = ms::bench::MakeTempFolder(args.work_dir, "meshstream-bench-sqlite");
    b.store = b.folder + "/store";
  } else {
    b.pg = Check(ms::test_util::PgCluster::Start({args.work_dir, args.pg_fsync}), "PostgreSQL cluster");
    b.store = b.pg->uri();
  }
  std::vector<std::string>* log = &b.log;
  const bool verbose = args.verbose;
  const std::string name = b.name;
  const ms::ServerOptions o = ms::bench::BenchServerOptions(
      b.store, args.workers, "bench-" + b.name, [log, verbose, name](const std::string& line) {
        log->push_back(line);
        if (verbose) std::fprintf(stderr, "[%s server] %s\n", name.c_str(), line.c_str());
      });
  b.server = Check(ms::Server::Start(o), b.name + " server");
  b.client = std::make_unique<AssetApi>(b.server->address());
}

void StopBackend(Backend& b) {
  b.client.reset();
  StopServer(b.server);
  b.pg.reset();
  if (!b.folder.empty()) {
    std::error_code ec;
    fs::remove_all(b.folder, ec);
  }
}

// ------------------------------------------------------------------ ingest

struct IngestRun {
  bool ok = false;
  std::string error;
  double upload_ms = 0;        // Ingest: first message written until IngestResponse
  double ready_watch_ms = 0;   // IngestResponse until WatchJob delivered SUCCEEDED
  double ready_server_ms = 0;  // the job's updated - created stamps (the store's clock, ms)
  v1::IngestResponse response;
  v1::Job last;
  json watch = json::array();  // every Job WatchJob sent: client time, state, progress, server time
};

std::vector<v1::IngestRequest> UploadMessages(const Model& m, const std::vector<uint8_t>& bytes,
                                              const v1::EncodeOptions& options, const std::string& upload_id) {
  ms::bench::Upload upload;
  upload.asset = m.name;
  upload.file = m.file;
  upload.bytes = &bytes;
  upload.options = options;
  upload.upload_id = upload_id;
  return ms::bench::IngestMessages(upload);
}

// One Ingest, then WatchJob until the job ends; nothing else runs meanwhile.
IngestRun IngestAndWait(Backend& b, const std::vector<v1::IngestRequest>& messages) {
  IngestRun run;
  const auto t0 = Clock::now();
  ms::StatusOr<v1::IngestResponse> response = b.client->Ingest(messages);
  const auto t1 = Clock::now();
  if (!response.ok()) {
    run.error = "Ingest: " + response.status().ToString();
    return run;
  }
  run.response = response.value();
  run.upload_ms = Ms(t0, t1);
  Clock::time_point final_seen = t1;
  ms::StatusOr<v1::Job> last = b.client->Watch(run.response.job_id(), [&](const v1::Job& job) {
    const auto now = Clock::now();
    run.watch.push_back({{"t_ms", Ms(t1, now)},
                         {"state", v1::JobState_Name(job.state())},
                         {"progress", job.progress()},
                         {"server_ms", TimestampMs(job.updated()) - TimestampMs(job.created())}});
    final_seen = now;
  });
  if (!last.ok()) {
    run.error = "WatchJob: " + last.status().ToString();
    return run;
  }
  run.last = last.value();
  if (run.last.state() != v1::JOB_STATE_SUCCEEDED) {
    run.error = "job " + run.response.job_id() + " ended " + v1::JobState_Name(run.last.state()) + ": " +
                run.last.message();
    return run;
  }
  run.ready_watch_ms = Ms(t1, final_seen);
  run.ready_server_ms = static_cast<double>(TimestampMs(run.last.updated()) - TimestampMs(run.last.created()));
  run.ok = true;
  return run;
}

json RunJson(const IngestRun& r, int variant, uint64_t bytes) {
  return {{"variant", variant},
          {"bytes", bytes},
          {"upload_ms", r.upload_ms},
          {"upload_MBps", MBps(bytes, r.upload_ms)},
          {"ready_watch_ms", r.ready_watch_ms},
          {"ready_server_ms", r.ready_server_ms},
          {"version", r.response.version()},
          {"job_message", r.last.message()},
          {"attempts", r.last.attempts()},
          {"watch", r.watch}};
}

// ------------------------------------------------------------------ export

struct ExportTiming {
  bool ok = false;
  std::string error;
  double ms = 0;
  uint64_t bytes = 0;
  std::string sha256;
};

ExportTiming TimeExport(Backend& b, const std::string& asset, int64_t version, v1::Format format) {
  ExportTiming t;
  const auto t0 = Clock::now();
  ms::StatusOr<AssetApi::Exported> exported = b.client->Export(asset, version, format);
  t.ms = Ms(t0, Clock::now());
  if (!exported.ok()) {
    t.error = "Export " + v1::Format_Name(format) + ": " + exported.status().ToString();
    return t;
  }
  const AssetApi::Exported& e = exported.value();
  const std::string digest = ms::Sha256Hex(e.bytes.data(), e.bytes.size());
  if (digest != e.sha256) {
    t.error = "Export " + v1::Format_Name(format) + ": the bytes do not match the sha256 of the last chunk";
    return t;
  }
  t.ok = true;
  t.bytes = e.bytes.size();
  t.sha256 = digest;
  return t;
}

// ------------------------------------------------------------- references

// What a blob commit costs at least: the bytes into a new file, fsync, rename,
// fsync of the folder (services/store/blob_store.cc does this and more).
double DiskWriteFsyncMs(const std::string& dir, const std::vector<uint8_t>& bytes) {
  const std::string tmp = dir + "/write-test.part", target = dir + "/write-test";
  const auto t0 = Clock::now();
  const int fd = open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) Die(tmp + ": cannot create");
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = write(fd, bytes.data() + done, bytes.size() - done);
    if (n <= 0) Die(tmp + ": write failed");
    done += static_cast<size_t>(n);
  }
  if (fsync(fd) != 0) Die(tmp + ": fsync failed");
  close(fd);
  if (rename(tmp.c_str(), target.c_str()) != 0) Die(target + ": rename failed");
  const int dfd = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0 || fsync(dfd) != 0) Die(dir + ": fsync of the folder failed");
  close(dfd);
  const double ms = Ms(t0, Clock::now());
  unlink(target.c_str());
  return ms;
}

// The cost of one small durable commit: 4 KiB written at the same offset and
// fdatasync'd, n times (what a WAL commit waits for at least).
json FsyncFloor(const std::string& dir, int n) {
  const std::string path = dir + "/fsync-test";
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) Die(path + ": cannot create");
  std::vector<char> page(4096, 'x');
  std::vector<double> us;
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    if (pwrite(fd, page.data(), page.size(), 0) != static_cast<ssize_t>(page.size()) || fdatasync(fd) != 0) {
      Die(path + ": write or fdatasync failed");
    }
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  close(fd);
  unlink(path.c_str());
  json s = ms::bench::LatencySummary(us);
  s.erase("histogram");
  return s;
}

// ----------------------------------------------------------------- latency

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

// version(), and the settings that decide what a commit costs.
std::map<std::string, std::string> DescribePostgres(const ms::test_util::PgCluster& pg) {
  std::map<std::string, std::string> out;
  out["version"] = pg.Query("SELECT version()");
  for (const char* name : {"fsync", "synchronous_commit", "full_page_writes", "wal_sync_method", "shared_buffers",
                           "max_connections", "default_toast_compression"}) {
    out[name] = pg.Query(std::string("SHOW ") + name);
  }
  return out;
}

// ------------------------------------------------------------ the run steps

// The models of --model (all of kModelFiles without it); spot.obj, which
// the warm-up and the latency asset use, is loaded by the caller.
std::vector<Model> LoadModels(const Args& args) {
  std::vector<Model> models;
  for (const char* relative : kModelFiles) {
    const std::string stem = ms::bench::Stem(relative);
    if (!args.only.empty() && std::find(args.only.begin(), args.only.end(), stem) == args.only.end()) continue;
    models.push_back(LoadModel(args.models_dir, relative));
  }
  if (models.empty()) Die("no model left (see --model)");
  return models;
}

// Each backend's address, store and (PostgreSQL) settings.
json BackendsInfo(const std::vector<Backend*>& backends, const Args& args) {
  json backends_info = json::object();
  for (Backend* b : backends) {
    json info = {{"address", b->server->address()}, {"workers", args.workers}};
    if (b->pg) {
      info["postgresql"] = DescribePostgres(*b->pg);
      info["pool_size"] = 4;
      info["store"] = "postgresql:///postgres?host=<cluster folder>&user=postgres (Unix socket)";
    } else {
      info["store"] = "<work_dir>/meshstream-bench-sqlite-*/store";
    }
    backends_info[b->name] = info;
  }
  return backends_info;
}

json SettingsJson(const Args& args, const std::vector<Model>& models) {
  json names = json::array();
  for (const Model& m : models) names.push_back(m.file);
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

// Warm-up: the first connection of each client, PostgreSQL's pool, the
// encoder's first run; untimed.
void WarmUp(const std::vector<Backend*>& backends, const Model& spot) {
  std::fprintf(stderr, "meshstream_bench_service: warming up\n");
  for (Backend* b : backends) {
    Model w = spot;
    w.name = "warmup";
    IngestRun r = IngestAndWait(*b, UploadMessages(w, w.bytes, v1::EncodeOptions(), ""));
    if (!r.ok) Die(b->name + ": the warm-up ingest failed: " + r.error);
    TimeExport(*b, "warmup", r.response.version(), v1::FORMAT_GLB);
  }
}

// What an upload of `m` costs without a server, `repeat` times each: the
// job's import + encode (ProcessSource) in this process, the same messages
// streamed into the echo server's sink, the bytes written and fsync'd into a
// file in `disk_dir`, their SHA-256.
json ModelReference(const Model& m, int repeat, const std::shared_ptr<grpc::Channel>& echo_channel,
                    const std::string& disk_dir) {
  static const auto settings = Check(ms::ResolveSettings(ms::EncodeSettings{}), "default encode settings");
  std::vector<double> encode, sink, disk, sha;
  const auto messages = UploadMessages(m, m.bytes, VariantOptions(m, 0), "");
  std::vector<grpc::ByteBuffer> buffers;
  uint64_t message_bytes = 0;
  for (const auto& msg : messages) {
    buffers.push_back(ms::bench::ToByteBuffer(msg.SerializeAsString()));
    message_bytes += buffers.back().Length();
  }
  json figures;
  for (int i = 0; i < repeat; ++i) {
    auto t0 = Clock::now();
    auto result = ms::ProcessSource(m.path, settings, nullptr);
    encode.push_back(Ms(t0, Clock::now()));
    if (!result.ok()) Die(m.path + ": ProcessSource: " + result.status().ToString());
    figures = {{"vertices", result->summary.vertices},
               {"faces", result->summary.faces},
               {"levels", result->summary.levels},
               {"progressive_bytes", result->summary.progressive_bytes}};
    uint64_t received = 0;
    t0 = Clock::now();
    const grpc::Status s = ms::bench::SinkStream(echo_channel, buffers, &received);
    sink.push_back(Ms(t0, Clock::now()));
    if (!s.ok() || received != message_bytes) Die("the echo sink failed: " + StatusText(s));
    disk.push_back(DiskWriteFsyncMs(disk_dir, m.bytes));
    t0 = Clock::now();
    const std::string digest = ms::Sha256Hex(m.bytes.data(), m.bytes.size());
    sha.push_back(Ms(t0, Clock::now()));
    if (digest.size() != 64) Die("Sha256Hex failed");
  }
  auto with_rate = [&m](const std::vector<double>& runs) {
    json j = ms::bench::RunsSummary(runs);
    j["MBps"] = MBps(m.bytes.size(), j["median_ms"].get<double>());
    return j;
  };
  return {{"file", m.file},
          {"bytes", m.bytes.size()},
          {"figures", figures},
          {"encode_inprocess", ms::bench::RunsSummary(encode)},
          {"transport_sink", with_rate(sink)},
          {"disk_write_fsync", with_rate(disk)},
          {"sha256", with_rate(sha)}};
}

// PostgreSQL's side of a blob: the file inserted as one bytea value into a
// table like blob_chunks (storage EXTENDED: TOAST compresses it with the
// cluster's default, pglz) and into one with storage EXTERNAL (no
// compression), timed inside the backend (the commit's WAL flush not
// included): what compression costs the shared store's ingest. Into
// ref_models[model]["pg_bytea_insert"]. False when the tables could not be
// set up.
bool PgByteaReference(ms::test_util::PgCluster& pg, const std::vector<Model>& models, int repeat, json& ref_models) {
  const std::string setup =
      "CREATE TABLE bench_toast_x (d bytea); CREATE TABLE bench_toast_e (d bytea); "
      "ALTER TABLE bench_toast_e ALTER d SET STORAGE EXTERNAL; "
      "CREATE FUNCTION bench_insert_ms(tbl text, path text) RETURNS double precision AS $f$ "
      "DECLARE t0 timestamptz; BEGIN t0 := clock_timestamp(); "
      "EXECUTE format('INSERT INTO %I SELECT pg_read_binary_file(%L)', tbl, path); "
      "RETURN extract(epoch FROM clock_timestamp() - t0) * 1000; END $f$ LANGUAGE plpgsql; SELECT 'ok'";
  if (pg.Query(setup) != "ok") {
    std::fprintf(stderr, "meshstream_bench_service: the PostgreSQL bytea reference could not be set up; skipped\n");
    return false;
  }
  for (const Model& m : models) {
    std::error_code ec;
    const std::string path = fs::canonical(m.path, ec).string();
    std::vector<double> compressed, external;
    for (int i = 0; i < repeat; ++i) {
      for (const char* table : {"bench_toast_x", "bench_toast_e"}) {
        const std::string v = pg.Query(std::string("SELECT bench_insert_ms('") + table + "', '" + path + "')");
        char* end = nullptr;
        const double ms_taken = std::strtod(v.c_str(), &end);
        if (v.empty() || end == v.c_str()) continue;
        (table[12] == 'x' ? compressed : external).push_back(ms_taken);
      }
    }
    if (compressed.empty() || external.empty()) continue;  // e.g. the file is not readable by postgres
    const std::string stored = pg.Query("SELECT sum(pg_column_size(d)) || ' ' || sum(octet_length(d)) FROM "
                                        "bench_toast_x");
    pg.Query("TRUNCATE bench_toast_x, bench_toast_e");
    json r = {{"compressed", ms::bench::RunsSummary(compressed)}, {"uncompressed", ms::bench::RunsSummary(external)}};
    const size_t space = stored.find(' ');
    if (space != std::string::npos) {
      const double a = std::strtod(stored.c_str(), nullptr), t = std::strtod(stored.c_str() + space, nullptr);
      if (t > 0) r["compressed_stored_fraction"] = a / t;
    }
    ref_models[m.name]["pg_bytea_insert"] = r;
  }
  pg.Query("DROP TABLE bench_toast_x, bench_toast_e; DROP FUNCTION bench_insert_ms; SELECT 'ok'");
  return true;
}

// References that need no server (and PostgreSQL's bytea insert on each
// PostgreSQL backend): the "references" object.
json References(const Args& args, const std::vector<Model>& models, const std::vector<Backend*>& backends,
                const std::string& echo_address) {
  std::fprintf(stderr, "meshstream_bench_service: references (disk, encoder, transport)\n");
  const std::string disk_dir = ms::bench::MakeTempFolder(args.work_dir, "meshstream-bench-disk");
  json references = {{"fsync_4k", FsyncFloor(disk_dir, args.quick ? 50 : 200)}};
  json ref_models = json::object();
  const auto echo_channel = grpc::CreateChannel(echo_address, grpc::InsecureChannelCredentials());
  const int ref_repeat = std::max(args.repeat, 3);
  for (const Model& m : models) ref_models[m.name] = ModelReference(m, ref_repeat, echo_channel, disk_dir);
  for (Backend* b : backends) {
    if (b->pg && !PgByteaReference(*b->pg, models, ref_repeat, ref_models)) break;
  }
  references["models"] = ref_models;
  std::error_code ec;
  fs::remove_all(disk_dir, ec);
  return references;
}

// What one backend measured of one model, over its ingests.
struct Slot {
  json plain = json::array(), resumable = json::array(), cache = json::array();
  std::vector<double> progressive, glb_first, glb_cached;
  uint64_t progressive_bytes = 0, glb_bytes = 0;
  std::vector<std::string> artifacts;
};

// One ingest of `m` (variant k; `cache`: one the artifact cache answers;
// `resumable`: with an upload_id) into `b`, then for a fresh version its
// exports: the stored artifact, then .glb twice.
void IngestOnce(Backend& b, const Model& m, int k, bool cache, bool resumable, Slot& slot) {
  const int variant = cache ? 0 : k;
  const auto bytes = VariantBytes(m, variant);
  const std::string upload_id = resumable ? m.name + "-resume-" + std::to_string(k) : "";
  const std::string what = m.file + (cache ? " cache hit" : resumable ? " resumable" : " plain") + " #" +
                           std::to_string(k);
  IngestRun r = IngestAndWait(b, UploadMessages(m, bytes, VariantOptions(m, variant), upload_id));
  if (!r.ok) return Fail(b, "ingest " + what, r.error);
  const bool reused = r.last.message().find("reused") != std::string::npos;
  if (cache != reused) {
    return Fail(b, "ingest " + what,
                std::string(cache ? "the artifact cache did not answer" : "the artifact cache answered a fresh "
                                                                          "variant") +
                    " (job message: " + r.last.message() + ")");
  }
  (cache ? slot.cache : resumable ? slot.resumable : slot.plain).push_back(RunJson(r, variant, bytes.size()));
  if (cache) return;
  const int64_t version = r.response.version();
  ExportTiming p = TimeExport(b, m.name, version, v1::FORMAT_PROGRESSIVE_GLB);
  if (!p.ok) return Fail(b, "export " + what, p.error);
  if (std::find(slot.artifacts.begin(), slot.artifacts.end(), p.sha256) != slot.artifacts.end()) {
    return Fail(b, "export " + what, "the artifact is one of an earlier variant: its .glb export would be cached");
  }
  slot.artifacts.push_back(p.sha256);
  slot.progressive.push_back(p.ms);
  slot.progressive_bytes = p.bytes;
  ExportTiming g1 = TimeExport(b, m.name, version, v1::FORMAT_GLB);
  ExportTiming g2 = g1.ok ? TimeExport(b, m.name, version, v1::FORMAT_GLB) : ExportTiming{};
  if (!g1.ok || !g2.ok) return Fail(b, "export glb " + what, g1.ok ? g2.error : g1.error);
  if (g1.sha256 != g2.sha256) return Fail(b, "export glb " + what, "the cached .glb differs from the first");
  slot.glb_first.push_back(g1.ms);
  slot.glb_cached.push_back(g2.ms);
  slot.glb_bytes = g1.bytes;
}

// A slot's medians into b.ingest[m] and b.exports[m].
void Summarize(Backend& b, const Model& m, const Slot& slot) {
  auto median_of = [](const json& runs, const char* key) {
    std::vector<double> v;
    for (const json& r : runs) v.push_back(r[key].get<double>());
    return Median(v);
  };
  json fresh_runs = slot.plain;
  for (const json& r : slot.resumable) fresh_runs.push_back(r);
  const json summary = {
      {"upload_ms", median_of(slot.plain, "upload_ms")},
      {"upload_MBps", MBps(m.bytes.size(), median_of(slot.plain, "upload_ms"))},
      {"ready_watch_ms", median_of(slot.plain, "ready_watch_ms")},
      {"ready_server_ms", median_of(slot.plain, "ready_server_ms")},
      {"resumable_upload_ms", median_of(slot.resumable, "upload_ms")},
      {"resumable_upload_MBps", MBps(m.bytes.size(), median_of(slot.resumable, "upload_ms"))},
      {"resumable_ready_watch_ms", median_of(slot.resumable, "ready_watch_ms")},
      {"cache_upload_ms", median_of(slot.cache, "upload_ms")},
      {"cache_ready_watch_ms", median_of(slot.cache, "ready_watch_ms")},
      {"cache_ready_server_ms", median_of(slot.cache, "ready_server_ms")},
      {"fresh_ready_watch_ms", median_of(fresh_runs, "ready_watch_ms")},
      {"fresh_ready_server_ms", median_of(fresh_runs, "ready_server_ms")},
  };
  b.ingest[m.name] = {{"file", m.file},
                      {"bytes", m.bytes.size()},
                      {"plain", slot.plain},
                      {"resumable", slot.resumable},
                      {"cache_hit", slot.cache},
                      {"summary", summary}};
  auto exp = [](const std::vector<double>& runs, uint64_t bytes) {
    json j = ms::bench::RunsSummary(runs);
    j["bytes"] = bytes;
    j["MBps"] = MBps(bytes, Median(runs));
    return j;
  };
  b.exports[m.name] = {{"progressive_glb", exp(slot.progressive, slot.progressive_bytes)},
                       {"glb_first", exp(slot.glb_first, slot.glb_bytes)},
                       {"glb_cached", exp(slot.glb_cached, slot.glb_bytes)},
                       {"distinct_artifacts", slot.artifacts.size()}};
}

// Ingest, READY and export of one model: plain, resumable, then cache-hit
// ingests, the backends taking turns (who goes first alternates).
void MeasureIngest(const Args& args, const Model& m, const std::vector<Backend*>& backends) {
  std::fprintf(stderr, "meshstream_bench_service: ingest %s (%zu bytes)\n", m.file.c_str(), m.bytes.size());
  std::map<std::string, Slot> slots;
  const int fresh = args.repeat + args.resumable_repeat;
  for (int k = 0; k < fresh + args.cache_repeat; ++k) {
    const bool cache = k >= fresh;
    const bool resumable = !cache && k >= args.repeat;
    for (size_t i = 0; i < backends.size(); ++i) {
      Backend& b = *backends[(i + static_cast<size_t>(k)) % backends.size()];
      IngestOnce(b, m, k, cache, resumable, slots[b.name]);
    }
  }
  for (Backend* b : backends) Summarize(*b, m, slots[b->name]);
}

// One latency entry: a target's merged calls at `clients` clients.
json LatencyEntry(const LatencyTarget& target, int clients, const ms::bench::LoadResult& r, double process_s,
                  uint64_t busy, uint64_t total) {
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
  entry["cpu"] = {{"machine_busy", total ? static_cast<double>(busy) / total : 0.0},
                  {"process_s", process_s},
                  {"process_us_per_call", calls > 0 ? process_s * 1e6 / calls : 0.0}};
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
  struct Cpu {
    double process_s = 0;
    uint64_t busy = 0, total = 0;
  };
  std::vector<Cpu> cpu(targets.size());
  for (int round = 0; round < args.rounds; ++round) {
    for (size_t t = 0; t < targets.size(); ++t) {
      std::fprintf(stderr, "meshstream_bench_service: %3d clients, round %d: %s %s\n", clients, round + 1,
                   targets[t].backend.empty() ? "echo server" : targets[t].backend.c_str(), targets[t].rpc.c_str());
      ms::bench::LoadResult r = ms::bench::RunLoad(targets[t].target, clients, per_round, 3);
      cpu[t].process_s += r.process_cpu_s;
      cpu[t].busy += r.machine_busy;
      cpu[t].total += r.machine_total;
      ms::bench::LoadResult& m = merged[t];
      m.clients = clients;
      m.calls_per_client += r.calls_per_client;
      m.latencies_us.insert(m.latencies_us.end(), r.latencies_us.begin(), r.latencies_us.end());
      m.failed += r.failed;
      m.warmup_failed += r.warmup_failed;
      if (m.first_error.empty()) m.first_error = r.first_error;
      m.wall_s += r.wall_s;
    }
  }
  for (size_t t = 0; t < targets.size(); ++t) {
    latency.push_back(LatencyEntry(targets[t], clients, merged[t], cpu[t].process_s, cpu[t].busy, cpu[t].total));
  }
}

// Ratios to the echo floor, at each client count.
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

// What the stores hold afterwards, into backends_info.
void AddStoreSizes(const std::vector<Backend*>& backends, json& backends_info) {
  for (Backend* b : backends) {
    if (b->pg) {
      backends_info[b->name]["blob_chunks"] = {
          {"raw_bytes", b->pg->Query("SELECT coalesce(sum(octet_length(data)), 0) FROM meshstream.blob_chunks")},
          {"stored_bytes", b->pg->Query("SELECT coalesce(sum(pg_column_size(data)), 0) FROM meshstream.blob_chunks")},
          {"column_storage", b->pg->Query("SELECT attstorage FROM pg_attribute WHERE attrelid = "
                                          "'meshstream.blob_chunks'::regclass AND attname = 'data'")}};
      backends_info[b->name]["database_bytes"] = b->pg->Query("SELECT pg_database_size('postgres')");
    } else {
      backends_info[b->name]["store_bytes"] = FirstLineOf("du -sb " + ShellQuote(b->folder) + " | cut -f1");
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::SetProgramName("meshstream_bench_service");
  const Args args = ParseArgs(argc, argv);
  const auto run_start = Clock::now();
  json out;
  out["benchmark"] = "meshstream_bench_service";
  out["machine"] = MachineInfo(args);
  const std::vector<Model> models = LoadModels(args);
  const Model spot = LoadModel(args.models_dir, "spot.obj");

  // Servers: the echo floor and one meshstream server per backend.
  auto echo = Check(ms::bench::EchoServer::Start(), "echo server");
  std::vector<std::unique_ptr<Backend>> owned;
  std::vector<Backend*> backends;
  for (const std::string& name : args.backends) {
    owned.push_back(std::make_unique<Backend>());
    owned.back()->name = name;
    std::fprintf(stderr, "meshstream_bench_service: starting the %s server\n", name.c_str());
    StartBackend(*owned.back(), args);
    backends.push_back(owned.back().get());
  }
  json backends_info = BackendsInfo(backends, args);
  out["settings"] = SettingsJson(args, models);
  WarmUp(backends, spot);
  out["references"] = References(args, models, backends, echo->address());
  for (const Model& m : models) MeasureIngest(args, m, backends);

  // Latency.
  std::fprintf(stderr, "meshstream_bench_service: the latency asset (%d versions per backend)\n", args.versions);
  const std::string latency_asset = "latency-spot";
  std::map<std::string, std::string> page2;
  for (Backend* b : backends) page2[b->name] = MakeLatencyAsset(*b, spot, latency_asset, args.versions);
  const std::vector<LatencyTarget> targets = MakeTargets(backends, echo->address(), latency_asset, args.versions, page2);
  json latency = json::array();
  for (int clients : args.clients) MeasureLatencyAt(args, targets, clients, latency);
  AddStoreSizes(backends, backends_info);

  json backend_results = json::array();
  uint64_t failures = 0;
  for (Backend* b : backends) {
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
  out["ratios"] = RatiosToEcho(args, latency);
  out["failures"] = {{"ingest_and_export", failures}, {"latency_calls", failed_calls}};
  out["machine"]["loadavg_at_end"] = ms::bench::LoadAverage();
  out["machine"]["run_seconds"] = Ms(run_start, Clock::now()) / 1000;

  for (auto& b : owned) StopBackend(*b);
  echo.reset();
  ms::bench::WriteJson(args.out, out);
  std::fprintf(stderr, "meshstream_bench_service: wrote %s in %.0f s (%llu failed ingests or exports, %llu failed "
                       "calls)\n",
               args.out.c_str(), out["machine"]["run_seconds"].get<double>(),
               static_cast<unsigned long long>(failures), static_cast<unsigned long long>(failed_calls));
  return 0;
}

// Ranged GETs of the stored progressive file per second (docs/results/http-ranges.md):
// the HTTP asset route (services/http_routes/asset_route.h) called as the
// HTTP server calls it, on a real SQLite store whose versions the real
// worker pool made, with the file served two ways in the same run:
//   store   the export path, as before: each request reads the whole blob
//           and checks its SHA-256 (ExportVersion), then slices it;
//   hot     the session host's hot artifacts: the first request loads the
//           copy sessions read, each after is a lookup and a slice.
// Models: the bunny, and the bunny subdivided twice with scan-like noise
// (about 557 k vertices; bench/scaling's "noisy" level 2, same seed), made
// here and never committed. Requests: the kinds a browser's view makes
// (web/src: the file's first 64 KiB, then the rest) and the whole file.
// Rounds interleave the two ways so that the machine's drift falls on
// both; the JSON keeps every round, the doc the medians and the ratio.
//
// The socket is left out on purpose: the change is the route's, and the
// HTTP server's cost per request is the same both ways. As the floor of
// that cost, the same run measures copying the bytes a request serves once
// (memcpy into a buffer of their size: what writing them to a socket costs
// at least), so the doc can say what the hot path leaves to the server.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/options.h"
#include "bench/scaling/subdivide.h"
#include "bench/scaling/surface_noise.h"
#include "importers/import.h"
#include "importers/mesh_writer.h"
#include "parallel/call_limit.h"
#include "services/auth/authenticator.h"
#include "services/http_routes/asset_route.h"
#include "services/store/open_store.h"
#include "services/streaming/session_host.h"
#include "testing/stored_version.h"
#include "testing/test_util.h"

namespace ms = meshstream;
using json = nlohmann::json;

namespace {

struct Args {
  std::string out = std::string(MESHSTREAM_SOURCE_DIR) + "/docs/results/bench/http-ranges.json";
  int rounds = 7;
  double seconds = 0.3;  // per way, kind and round
  bool quick = false;    // the bunny only
  double noise = 0.25;   // as bench/scaling's default
  std::string work_dir;
};

struct Kind {
  std::string name;
  std::string range;  // empty: the whole file
  uint64_t bytes;     // what the answer carries
};

ms::HttpRequest Get(const std::string& path, const std::string& range) {
  ms::HttpRequest r;
  r.method = "GET";
  r.target = path;
  r.path = path;
  if (!range.empty()) r.headers.push_back({"range", range});
  return r;
}

// GETs per second of `route` for `seconds` (at least 3 requests); Die on an answer that is not `status`.
double Rate(ms::AssetRoute& route, const ms::HttpRequest& request, int status, size_t bytes, double seconds) {
  const auto start = ms::bench::Clock::now();
  int n = 0;
  for (;;) {
    const ms::HttpResponse r = route.Handle(request);
    if (r.status != status || r.size != bytes) {
      ms::bench::Die(request.target + " " + (request.headers.empty() ? "" : request.headers[0].second) + ": status " +
                     std::to_string(r.status) + ", " + std::to_string(r.size) + " bytes");
    }
    ++n;
    const double ms_ = ms::bench::Ms(start, ms::bench::Clock::now());
    if (n >= 3 && ms_ >= seconds * 1000) return n / (ms_ / 1000);
  }
}

std::vector<uint8_t> LargeModel(const std::string& dir, double noise) {
  ms::Scene scene = ms::bench::Check(ms::ImportFile(std::string(MESHSTREAM_MODELS_DIR) + "/stanford-bunny.obj"),
                                     "reading stanford-bunny.obj");
  const std::vector<const ms::Primitive*> primitives = ms::bench::Primitives(scene);
  ms::Primitive mesh;
  mesh.positions = primitives.at(0)->positions;
  mesh.indices = primitives.at(0)->indices;
  for (int level = 1; level <= 2; ++level) mesh = ms::bench::SubdivideMidpoint(mesh);
  mesh = ms::bench::WithSurfaceNoise(mesh, noise, 1000 + 2);  // bench/scaling's seed of level 2
  const std::string path = dir + "/bunny-557k.ply";
  const ms::Status written = ms::WriteMeshFile(ms::SceneFromPrimitive(mesh, "bunny-557k"), path);
  if (!written.ok()) ms::bench::Die("writing " + path + ": " + written.ToString());
  std::fprintf(stderr, "meshstream_bench_ranges: bunny-557k, %llu vertices\n",
               static_cast<unsigned long long>(mesh.vertex_count()));
  return ms::bench::Check(ms::ReadFileBytes(path, uint64_t{1} << 32), "reading " + path);
}

// Copies of `bytes` bytes per second (at least 3, `seconds` long).
double CopyRate(const std::vector<uint8_t>& from, size_t bytes, double seconds) {
  std::vector<uint8_t> to(bytes);
  const auto start = ms::bench::Clock::now();
  int n = 0;
  for (;;) {
    std::memcpy(to.data(), from.data(), bytes);
    asm volatile("" : : "r"(to.data()) : "memory");  // the copy is used
    ++n;
    const double ms_ = ms::bench::Ms(start, ms::bench::Clock::now());
    if (n >= 3 && ms_ >= seconds * 1000) return n / (ms_ / 1000);
  }
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::SetProgramName("meshstream_bench_ranges");
  Args args;
  ms::bench::Options o("meshstream_bench_ranges",
                       "Ranged GETs of the stored progressive file per second, from the store (each request reads\n"
                       "and hashes the blob) and from the session host's hot artifacts; writes one JSON object.\n");
  o.String("--out", "FILE", &args.out, "the JSON (default docs/results/bench/http-ranges.json)");
  o.Int("--rounds", "N", &args.rounds, 1, 1000, "interleaved rounds (default 7)");
  o.Double("--seconds", "S", &args.seconds, 0, 60, "time per way, kind and round (default 0.3)", true);
  o.Double("--noise", "A", &args.noise, 0, 10, "the large model's noise in mean edge lengths (default 0.25)");
  o.Flag("--quick", &args.quick, "the bunny only, 3 rounds");
  o.String("--work-dir", "DIR", &args.work_dir, "where the store goes (default $TMPDIR)");
  o.Parse(argc, argv);
  if (args.quick && !o.Given("--rounds")) args.rounds = 3;

  ms::test_util::TempDir dir;
  const std::string root = args.work_dir.empty() ? dir.path() : args.work_dir;
  std::filesystem::create_directories(root + "/work");
  json out;
  out["machine"] = ms::bench::MachineInfo(root, MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  out["settings"] = {{"rounds", args.rounds}, {"seconds", args.seconds}, {"noise", args.noise}};
  std::unique_ptr<ms::Store> store = ms::bench::Check(ms::OpenStore(root + "/store"), "opening the store");
  ms::Authenticator auth(store.get(), false);
  std::atomic<bool> draining{false};
  ms::SessionHost host(store.get(), &auth, ms::SessionHostOptions(), &draining);
  ms::CallLimit exports(2);
  ms::AssetRoute from_store(store.get(), &auth, &exports, ms::AssetRouteOptions());
  ms::AssetRoute hot(store.get(), &auth, &exports, ms::AssetRouteOptions(), &host);

  struct Model {
    std::string name;
    std::string filename;
    std::vector<uint8_t> bytes;
  };
  std::vector<Model> models;
  models.push_back({"bunny", "stanford-bunny.obj",
                    ms::bench::Check(ms::ReadFileBytes(std::string(MESHSTREAM_MODELS_DIR) + "/stanford-bunny.obj",
                                                       uint64_t{1} << 30),
                                     "reading the bunny")});
  if (!args.quick) models.push_back({"bunny-557k", "bunny-557k.ply", LargeModel(root, args.noise)});

  json rows = json::array();
  for (const Model& m : models) {
    const auto t0 = ms::bench::Clock::now();
    const ms::VersionRecord version = ms::bench::Check(
        ms::test_util::StoreReadyVersion(*store, ms::kDefaultTenant, m.name, m.filename, m.bytes, root + "/work"),
        "ingesting " + m.name);
    std::fprintf(stderr, "meshstream_bench_ranges: %s ingested in %.1f s\n", m.name.c_str(),
                 ms::bench::Ms(t0, ms::bench::Clock::now()) / 1000);
    const uint64_t size = version.artifact.progressive_bytes;
    const std::string url = "/v1/assets/" + m.name + "/versions/" + std::to_string(version.version) + "/progressive";
    if (size <= 65536) ms::bench::Die(m.name + ": a progressive file of at most 64 KiB");
    const std::vector<Kind> kinds = {{"first 64 KiB", "bytes=0-65535", 65536},
                                     {"the rest", "bytes=65536-", size - 65536},
                                     {"whole file", "", size}};
    for (const Kind& k : kinds) {
      const ms::HttpRequest request = Get(url, k.range);
      const int status = k.range.empty() ? 200 : 206;
      json row = {{"model", m.name}, {"file_bytes", size}, {"kind", k.name}, {"range", k.range}, {"bytes", k.bytes}};
      const std::vector<uint8_t> file = ms::bench::Check(store->GetBlob(version.artifact.artifact_sha256, size + 1),
                                                         "reading the progressive file");
      std::vector<double> store_rate, hot_rate, copy_rate, ratio;
      for (int round = 0; round < args.rounds; ++round) {
        const double a = Rate(from_store, request, status, k.bytes, args.seconds);
        const double b = Rate(hot, request, status, k.bytes, args.seconds);
        const double c = CopyRate(file, k.bytes, args.seconds);
        store_rate.push_back(a);
        hot_rate.push_back(b);
        copy_rate.push_back(c);
        ratio.push_back(b / a);
      }
      row["copy_per_s"] = copy_rate;
      row["median_copy_per_s"] = ms::bench::Median(copy_rate);
      row["store_gets_per_s"] = store_rate;
      row["hot_gets_per_s"] = hot_rate;
      row["median_store_gets_per_s"] = ms::bench::Median(store_rate);
      row["median_hot_gets_per_s"] = ms::bench::Median(hot_rate);
      row["median_ratio"] = ms::bench::Median(ratio);
      std::fprintf(stderr, "meshstream_bench_ranges: %s, %s: store %.0f/s, hot %.0f/s, x %.1f\n", m.name.c_str(),
                   k.name.c_str(), ms::bench::Median(store_rate), ms::bench::Median(hot_rate),
                   ms::bench::Median(ratio));
      rows.push_back(row);
    }
  }
  const ms::HotArtifactsStats stats = host.hot_artifacts();
  out["hot_artifacts"] = {{"loads", stats.loads}, {"hits", stats.hits}, {"bytes", stats.bytes}};
  out["rows"] = rows;
  out["machine"]["load_at_end"] = ms::bench::LoadAverage();
  ms::bench::WriteJson(args.out, out);
  std::fprintf(stderr, "meshstream_bench_ranges: wrote %s\n", args.out.c_str());
  return 0;
}

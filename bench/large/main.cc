// meshstream_bench_large: a mesh of about 10 M vertices end to end
// (docs/results/large-assets.md): the bunny subdivided N times (default 4:
// 9.2 M vertices) with scan-like noise (bench/scaling/surface_noise.h,
// WithGridNoise: each vertex a subdivision added moved by up to one grid step
// of qp 11 per axis), written as a PLY (never committed), then, as child
// processes of the meshstream CLI, each measured by the kernel (wall, CPU,
// peak resident memory; bench/scaling/measured_run.h):
//   - Draco: `convert --draco --qp 11 --cl 7` and the decode of its file
//     (`convert draco.glb`), the reference of the same run;
//   - `meshstream serve` (one job worker, --encode-threads T), and against it
//     `ingest --wait` (upload to READY: import, spatial parts, both profiles,
//     the harm estimate, storing), `export` (the stored progressive .glb),
//     `fetch --tcp-only --threads T` (a session: the SDK receives and decodes
//     every level) and `fetch` of the base alone (--lod 0);
//   - `decode --threads 1` and `--threads T` of the exported file (the
//     decode alone is decode --json's decode_ms).
// The server's peak is its VmHWM just before it is stopped.
// Targets (issue "Large assets"): ingest to READY within 5 minutes, the
// server's peak at most 8 GB, the SDK's decode at most 1.0 x Draco's decode
// time with 2 threads.
// Writes one JSON object (--out, default docs/results/bench/large.json) and
// prints the table as markdown.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/options.h"
#include "bench/scaling/measured_run.h"
#include "bench/scaling/subdivide.h"
#include "bench/scaling/surface_noise.h"
#include "importers/import.h"
#include "importers/mesh_writer.h"
#include "testing/proc_status.h"
#include "testing/serve_process.h"

namespace {

namespace ms = meshstream;
using json = nlohmann::json;

struct Args {
  std::string model = "stanford-bunny.obj";
  int subdivisions = 4;
  int threads = 2;
  double noise_steps = 1.0;  // the scan's noise, in grid steps of qp 11 (see Usage)
  std::string work_dir = "/tmp";
  std::string out = "docs/results/bench/large.json";
};

// The option table (bench/options.h): --help is made from it.
Args Parse(int argc, char** argv) {
  Args a;
  if (const char* tmp = std::getenv("TMPDIR")) a.work_dir = tmp;
  ms::bench::Options o(
      "meshstream_bench_large",
      "A mesh of about 10 M vertices end to end: FILE (default stanford-bunny.obj) subdivided N\n"
      "times (default 4: 9.2 M vertices) with scan-like noise, then Draco's encode and decode, and\n"
      "against a `meshstream serve` (one job worker, --encode-threads T, default 2): ingest to\n"
      "READY, export, a session that streams and decodes everything (fetch --threads T) and one\n"
      "of the base alone, and decode on 1 and T threads; wall, CPU and peak memory of each, the\n"
      "server's peak. About 10 minutes and 10 GB of memory on 2 cores. Writes one JSON object\n"
      "(default docs/results/bench/large.json) and prints a markdown table.\n");
  o.String("--model", "FILE", &a.model, "the shared model to subdivide (default stanford-bunny.obj)");
  o.Int("--subdivisions", "N", &a.subdivisions, 0, 5, "subdivisions (default 4)");
  o.Double("--noise-steps", "S", &a.noise_steps, 0, 100,
           "each vertex the subdivisions added moves by up to S grid steps of qp 11 along each axis\n"
           "(default 1: a displacement of one grid step, root mean square; Draco cl7 codes the bunny\n"
           "subdivided twice at 7.6 bits a vertex, 10.1 with 2)");
  o.Int("--threads", "T", &a.threads, 1, 64, "encode and decode threads (default 2)");
  o.String("--work-dir", "DIR", &a.work_dir, "where the meshes and the store go (default $TMPDIR, else /tmp)");
  o.String("--out", "FILE", &a.out, "the JSON (default docs/results/bench/large.json)");
  o.Parse(argc, argv);
  return a;
}

uint64_t FileBytes(const std::string& path) {
  std::error_code ec;
  const auto n = std::filesystem::file_size(path, ec);
  return ec ? 0 : static_cast<uint64_t>(n);
}

// One step: the command measured, its JSON output (when it printed one) kept.
json Step(const std::string& name, const std::vector<std::string>& argv) {
  std::fprintf(stderr, "meshstream_bench_large: %s\n", name.c_str());
  const ms::bench::MeasuredRun r = ms::bench::RunMeasured(argv);
  if (r.exit_code != 0) ms::bench::Die(name + " exited " + std::to_string(r.exit_code) + ": " + r.out);
  json out = {{"wall_s", r.wall_s}, {"cpu_s", r.cpu_s}, {"peak_rss_bytes", r.peak_rss_bytes}};
  const json printed = json::parse(r.out, nullptr, false);
  if (printed.is_object()) out["output"] = printed;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::StartSpawner();  // before anything is allocated (measured_run.h)
  ms::bench::SetProgramName("meshstream_bench_large");
  const Args args = Parse(argc, argv);
  const std::string cli = MESHSTREAM_CLI;
  const std::string dir = ms::bench::MakeTempFolder(args.work_dir, "meshstream-large");
  const std::string in = dir + "/scan.ply";
  uint64_t vertices = 0, faces = 0;
  {
    ms::Scene scene =
        ms::bench::Check(ms::ImportFile(std::string(MESHSTREAM_MODELS_DIR) + "/" + args.model), "reading " + args.model);
    const std::vector<const ms::Primitive*> primitives = ms::bench::Primitives(scene);
    if (primitives.size() != 1) ms::bench::Die(args.model + ": one primitive expected");
    ms::Primitive mesh;
    mesh.positions = primitives[0]->positions;
    mesh.indices = primitives[0]->indices;
    const size_t original = mesh.positions.size();
    for (int level = 0; level < args.subdivisions; ++level) mesh = ms::bench::SubdivideMidpoint(mesh);
    mesh = ms::bench::WithGridNoise(mesh, original, args.noise_steps, 11, 2000 + static_cast<uint64_t>(args.subdivisions));
    vertices = mesh.vertex_count();
    faces = mesh.face_count();
    std::fprintf(stderr, "meshstream_bench_large: %llu vertices, %llu triangles\n",
                 static_cast<unsigned long long>(vertices), static_cast<unsigned long long>(faces));
    const ms::Status written = ms::WriteMeshFile(ms::SceneFromPrimitive(mesh, "scan"), in);
    if (!written.ok()) ms::bench::Die("writing " + in + ": " + written.ToString());
  }
  const std::string threads = std::to_string(args.threads);
  json steps = json::object();
  const std::string draco = dir + "/draco.glb", plain = dir + "/draco-decoded.glb";
  steps["draco_encode"] = Step("Draco encode", {cli, "convert", "--quiet", "--draco", "--qp", "11", "--cl", "7", in, draco});
  steps["draco_encode"]["output_bytes"] = FileBytes(draco);
  steps["draco_decode"] = Step("Draco decode", {cli, "convert", "--quiet", draco, plain});
  std::filesystem::remove(plain);

  auto server = ms::test_util::ServeProcess::Start({"--store", dir + "/store", "--workers", "1", "--encode-threads",
                                                    threads, "--udp-listen", "off", "--max-upload", "4294967296"});
  if (!server.ok()) ms::bench::Die("meshstream serve: " + server.status().ToString());
  const std::string address = (*server)->address();
  steps["ingest"] = Step("ingest to READY", {cli, "ingest", "--server", address, "--asset", "scan", in, "--wait", "--json"});
  const std::string exported = dir + "/scan.glb";
  steps["export"] = Step("export", {cli, "export", "--server", address, "scan", "--format", "progressive", "-o", exported, "--json"});
  steps["export"]["output_bytes"] = FileBytes(exported);
  const std::string fetched = dir + "/fetched.glb";
  steps["fetch"] = Step("fetch (stream and decode)",
                        {cli, "fetch", "--server", address, "scan", "-o", fetched, "--tcp-only", "--threads", threads, "--json"});
  std::filesystem::remove(fetched);
  steps["fetch_base"] = Step("fetch the base", {cli, "fetch", "--server", address, "scan", "-o", fetched, "--tcp-only",
                                               "--lod", "0", "--json"});
  std::filesystem::remove(fetched);
  const ms::test_util::ProcStatus server_status = ms::test_util::ReadProcStatus((*server)->pid());
  const int stopped = (*server)->Terminate();
  if (stopped != 0) ms::bench::Die("meshstream serve exited " + std::to_string(stopped) + ": " + (*server)->log());
  const std::string decoded = dir + "/decoded.glb";
  steps["decode_1thread"] = Step("decode, 1 thread", {cli, "decode", "--json", "--threads", "1", exported, "-o", decoded});
  steps["decode_threads"] = Step("decode, " + threads + " threads",
                                 {cli, "decode", "--json", "--threads", threads, exported, "-o", decoded});
  std::filesystem::remove_all(dir);

  const double draco_decode_s = steps["draco_decode"]["wall_s"].get<double>();
  const json& fetch_out = steps["fetch"].value("output", json::object());
  json out;
  out["benchmark"] = "meshstream_bench_large";
  out["machine"] = ms::bench::MachineInfo(args.work_dir, MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  out["settings"] = {{"model", args.model}, {"subdivisions", args.subdivisions}, {"threads", args.threads},
                     {"noise_steps", args.noise_steps}, {"qp", 11}, {"draco_compression_level", 7}};
  out["vertices"] = vertices;
  out["faces"] = faces;
  out["steps"] = steps;
  out["server_peak_rss_bytes"] = server_status.peak_rss_kib * 1024;
  out["ratios"] = {
      {"ingest_s", steps["ingest"]["wall_s"]},
      {"ingest_vs_draco_encode", steps["ingest"]["wall_s"].get<double>() / steps["draco_encode"]["wall_s"].get<double>()},
      {"sdk_full_vs_draco_decode", fetch_out.value("time_to_full_ms", 0.0) / 1000.0 / draco_decode_s},
      {"fetch_wall_vs_draco_decode", steps["fetch"]["wall_s"].get<double>() / draco_decode_s},
      {"decode_threads_vs_draco_decode", steps["decode_threads"]["wall_s"].get<double>() / draco_decode_s},
      {"decode_1thread_vs_draco_decode", steps["decode_1thread"]["wall_s"].get<double>() / draco_decode_s},
      {"file_vs_draco_bytes",
       steps["export"]["output_bytes"].get<double>() / steps["draco_encode"]["output_bytes"].get<double>()}};
  ms::bench::WriteJson(args.out, out);

  std::printf("%llu vertices, %llu triangles; server peak %.2f GB\n\n| step | wall s | CPU s | peak MB | note |\n|---|---:|---:|---:|---|\n",
              static_cast<unsigned long long>(vertices), static_cast<unsigned long long>(faces),
              server_status.peak_rss_kib / 1048576.0);
  for (const char* name : {"draco_encode", "draco_decode", "ingest", "export", "fetch", "fetch_base", "decode_1thread",
                           "decode_threads"}) {
    const json& s = steps[name];
    std::string note;
    if (s.contains("output_bytes")) note = std::to_string(s["output_bytes"].get<uint64_t>()) + " bytes";
    if (s.contains("output") && s["output"].contains("time_to_full_ms")) {
      note = "full after " + std::to_string(static_cast<int>(s["output"]["time_to_full_ms"].get<double>())) + " ms, base after " +
             std::to_string(static_cast<int>(s["output"]["time_to_base_ms"].get<double>())) + " ms";
    }
    if (s.contains("output") && s["output"].contains("decode_ms")) {
      note = "decode " + std::to_string(static_cast<int>(s["output"]["decode_ms"].get<double>())) + " ms";
    }
    std::printf("| %s | %.2f | %.2f | %.0f | %s |\n", name, s["wall_s"].get<double>(), s["cpu_s"].get<double>(),
                s["peak_rss_bytes"].get<double>() / 1e6, note.c_str());
  }
  std::fprintf(stderr, "meshstream_bench_large: wrote %s\n", args.out.c_str());
  return 0;
}

// meshstream_bench_scaling: the encoder at scale (issue 24; docs/benchmarks.md,
// "The encoder at scale"). A shared model subdivided 0..N times (1-to-4
// midpoint subdivision, bench/scaling/subdivide.h: the bunny's 35 k vertices
// become 140 k, 560 k, 2.2 M), each written as a PLY, then three commands of
// the meshstream CLI as child processes, measured by the kernel
// (bench/scaling/measured_run.h: wall, CPU, peak resident memory):
//   - `meshstream convert IN OUT.glb`: reading and writing alone;
//   - `meshstream convert --draco --qp Q --cl 7 IN OUT.glb`: Draco;
//   - `meshstream encode IN -o OUT.glb --qp Q`: the progressive encoder.
// Reported per size: each one's time and peak memory, bytes of peak memory
// per input vertex, the encoder's ratios to Draco, and the growth of the
// encoder's time and memory per 4 x vertices (n log n grows 4.4-4.6 x at these
// sizes). Targets of issue 24: at most 250 bytes per input vertex at the
// peak, at most 3 x Draco's encode time at 2 M vertices. And the decoders
// (issue 25): `meshstream decode` against `meshstream convert` of the Draco
// file, time and peak memory (targets: 1.0 x and 1.3 x Draco's).
// Writes one JSON object (--out, default docs/bench/scaling.json) and prints
// the table as markdown.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/harness.h"
#include "bench/scaling/measured_run.h"
#include "bench/scaling/subdivide.h"
#include "importers/import.h"
#include "importers/mesh_writer.h"

namespace {

namespace ms = meshstream;
using json = nlohmann::json;

struct Args {
  std::string model = "stanford-bunny.obj";
  int subdivisions = 3;
  int runs = 3;  // Draco's own time moves by 20 % between single runs on a 2-core machine
  int qp = 11;
  std::string work_dir = "/tmp";
  std::string out = "docs/bench/scaling.json";
  std::string keep_inputs;  // copy each subdivided mesh here (for profiling)
};

void Usage() {
  std::printf(
      "usage: meshstream_bench_scaling [--model FILE] [--subdivisions N] [--runs N] [--qp Q]\n"
      "                                [--work-dir DIR] [--out FILE] [--keep-inputs DIR]\n\n"
      "The encoder at scale: FILE (a shared model, default stanford-bunny.obj) subdivided 0..N\n"
      "times (default 3: 35 k to 2.2 M vertices for the bunny), each encoded by `meshstream\n"
      "encode` and by Draco (`meshstream convert --draco --cl 7`) as child processes: wall and\n"
      "CPU time and peak resident memory, medians of --runs (default 3). About 9 minutes for\n"
      "the default. Writes one JSON object (default docs/bench/scaling.json). --keep-inputs DIR\n"
      "keeps the subdivided meshes there (levelN.ply) to profile the encoder on them.\n");
}

Args Parse(int argc, char** argv) {
  Args a;
  if (const char* tmp = std::getenv("TMPDIR")) a.work_dir = tmp;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) ms::bench::Die(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--help" || flag == "-h") {
      Usage();
      std::exit(0);
    } else if (flag == "--model") {
      a.model = value();
    } else if (flag == "--subdivisions") {
      a.subdivisions = static_cast<int>(ms::bench::ParseInt(value(), flag, 0, 5));
    } else if (flag == "--runs") {
      a.runs = static_cast<int>(ms::bench::ParseInt(value(), flag, 1, 99));
    } else if (flag == "--qp") {
      a.qp = static_cast<int>(ms::bench::ParseInt(value(), flag, 1, 30));
    } else if (flag == "--work-dir") {
      a.work_dir = value();
    } else if (flag == "--out") {
      a.out = value();
    } else if (flag == "--keep-inputs") {
      a.keep_inputs = value();
    } else {
      ms::bench::Die("unknown flag " + flag + " (--help lists them)");
    }
  }
  return a;
}

// The medians of `runs` runs of `argv`; Die when one fails. With
// `decode_ms`, each run's stdout is a JSON object whose "decode_ms" is kept.
json Measure(const std::vector<std::string>& argv, int runs, uint64_t vertices,
             std::vector<double>* decode_ms = nullptr) {
  std::vector<double> wall, cpu, rss;
  for (int r = 0; r < runs; ++r) {
    const ms::bench::MeasuredRun m = ms::bench::RunMeasured(argv);
    if (m.exit_code != 0) ms::bench::Die(argv[1] + " failed (exit " + std::to_string(m.exit_code) + ") on " + argv.back());
    if (decode_ms) {
      const json j = json::parse(m.out, nullptr, false);
      if (j.is_discarded() || !j.contains("decode_ms")) ms::bench::Die(argv[1] + ": no decode_ms in its --json output");
      decode_ms->push_back(j["decode_ms"].get<double>());
    }
    wall.push_back(m.wall_s);
    cpu.push_back(m.cpu_s);
    rss.push_back(static_cast<double>(m.peak_rss_bytes));
  }
  const double peak = ms::bench::Median(rss);
  return {{"wall_s", ms::bench::Median(wall)},
          {"cpu_s", ms::bench::Median(cpu)},
          {"peak_rss_bytes", peak},
          {"peak_bytes_per_vertex", peak / static_cast<double>(vertices)}};
}

uint64_t FileBytes(const std::string& path) {
  std::error_code ec;
  const auto n = std::filesystem::file_size(path, ec);
  return ec ? 0 : static_cast<uint64_t>(n);
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::StartSpawner();  // before anything is allocated (measured_run.h)
  ms::bench::SetProgramName("meshstream_bench_scaling");
  const Args args = Parse(argc, argv);
  const std::string cli = MESHSTREAM_CLI;
  const std::string dir = ms::bench::MakeTempFolder(args.work_dir, "meshstream-scaling");
  ms::Scene scene =
      ms::bench::Check(ms::ImportFile(std::string(MESHSTREAM_MODELS_DIR) + "/" + args.model), "reading " + args.model);
  const std::vector<const ms::Primitive*> primitives = ms::bench::Primitives(scene);
  if (primitives.size() != 1) ms::bench::Die(args.model + ": one primitive expected");
  ms::Primitive mesh;
  mesh.positions = primitives[0]->positions;
  mesh.indices = primitives[0]->indices;

  json rows = json::array();
  for (int level = 0; level <= args.subdivisions; ++level) {
    if (level > 0) mesh = ms::bench::SubdivideMidpoint(mesh);
    const std::string in = dir + "/level" + std::to_string(level) + ".ply";
    const ms::Status written = ms::WriteMeshFile(ms::SceneFromPrimitive(mesh, "scaled"), in);
    if (!written.ok()) ms::bench::Die("writing " + in + ": " + written.ToString());
    const uint64_t vertices = mesh.vertex_count();
    std::fprintf(stderr, "meshstream_bench_scaling: %llu vertices, %zu triangles\n",
                 static_cast<unsigned long long>(vertices), mesh.face_count());
    if (!args.keep_inputs.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(args.keep_inputs, ec);
      std::filesystem::copy_file(in, args.keep_inputs + "/level" + std::to_string(level) + ".ply",
                                 std::filesystem::copy_options::overwrite_existing, ec);
      if (ec) ms::bench::Die("keeping " + in + " in " + args.keep_inputs + ": " + ec.message());
    }
    const std::string plain = dir + "/plain.glb", draco = dir + "/draco.glb", ours = dir + "/ours.glb";
    const std::string qp = std::to_string(args.qp);
    json row = {{"subdivisions", level}, {"vertices", vertices}, {"faces", mesh.face_count()}};
    row["read_and_write"] = Measure({cli, "convert", "--quiet", in, plain}, args.runs, vertices);
    row["draco"] = Measure({cli, "convert", "--quiet", "--draco", "--qp", qp, "--cl", "7", in, draco}, args.runs, vertices);
    row["draco"]["output_bytes"] = FileBytes(draco);
    row["meshstream"] = Measure({cli, "encode", "--qp", qp, in, "-o", ours}, args.runs, vertices);
    row["meshstream"]["output_bytes"] = FileBytes(ours);
    // Issue 25: the decoders, whole processes that read the .glb, decode
    // and write a plain .glb: `meshstream decode` (all levels; it also checks the
    // mesh's health, as it does for a user) against `meshstream convert` of
    // the Draco file (Draco's decoder through the glTF importer). The decode
    // alone, in the process, is what `decode --json` reports as decode_ms.
    const std::string decoded = dir + "/decoded.glb";
    std::vector<double> decode_ms;
    row["meshstream_decode"] = Measure({cli, "decode", "--json", ours, "-o", decoded}, args.runs, vertices, &decode_ms);
    row["meshstream_decode"]["decode_ms"] = ms::bench::Median(decode_ms);
    row["draco_decode"] = Measure({cli, "convert", "--quiet", draco, decoded}, args.runs, vertices);
    // The same decode on 2 threads (decode --threads 2: whole refinements planned in parallel).
    std::vector<double> decode2_ms;
    row["meshstream_decode_2threads"] =
        Measure({cli, "decode", "--json", "--threads", "2", ours, "-o", decoded}, args.runs, vertices, &decode2_ms);
    row["meshstream_decode_2threads"]["decode_ms"] = ms::bench::Median(decode2_ms);
    row["ratios"] = {
        {"time_vs_draco", row["meshstream"]["wall_s"].get<double>() / row["draco"]["wall_s"].get<double>()},
        {"memory_vs_draco",
         row["meshstream"]["peak_rss_bytes"].get<double>() / row["draco"]["peak_rss_bytes"].get<double>()},
        {"decode_time_vs_draco",
         row["meshstream_decode"]["wall_s"].get<double>() / row["draco_decode"]["wall_s"].get<double>()},
        {"decode_memory_vs_draco", row["meshstream_decode"]["peak_rss_bytes"].get<double>() /
                                       row["draco_decode"]["peak_rss_bytes"].get<double>()},
        {"decode_2threads_time_vs_draco", row["meshstream_decode_2threads"]["wall_s"].get<double>() /
                                              row["draco_decode"]["wall_s"].get<double>()}};
    if (!rows.empty()) {
      const json& before = rows.back();
      row["growth_per_4x"] = {
          {"time", row["meshstream"]["wall_s"].get<double>() / before["meshstream"]["wall_s"].get<double>()},
          {"memory",
           row["meshstream"]["peak_rss_bytes"].get<double>() / before["meshstream"]["peak_rss_bytes"].get<double>()},
          {"draco_time", row["draco"]["wall_s"].get<double>() / before["draco"]["wall_s"].get<double>()}};
    }
    rows.push_back(row);
  }
  std::filesystem::remove_all(dir);

  json out;
  out["benchmark"] = "meshstream_bench_scaling";
  out["machine"] = ms::bench::MachineInfo(args.work_dir, MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  out["settings"] = {{"model", args.model}, {"subdivisions", args.subdivisions}, {"runs", args.runs}, {"qp", args.qp},
                     {"draco_compression_level", 7}};
  out["rows"] = rows;
  ms::bench::WriteJson(args.out, out);

  std::printf("| vertices | meshstream encode s | peak MB | bytes/vertex | Draco s | Draco peak MB | time vs Draco | growth per 4 x (time, memory) |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|---:|---|\n");
  for (const json& r : rows) {
    const json& m = r["meshstream"];
    const json& d = r["draco"];
    std::string growth = "-";
    if (r.contains("growth_per_4x")) {
      char g[64];
      std::snprintf(g, sizeof g, "%.2f x, %.2f x", r["growth_per_4x"]["time"].get<double>(),
                    r["growth_per_4x"]["memory"].get<double>());
      growth = g;
    }
    std::printf("| %llu | %.2f | %.0f | %.0f | %.2f | %.0f | %.2f | %s |\n",
                static_cast<unsigned long long>(r["vertices"].get<uint64_t>()), m["wall_s"].get<double>(),
                m["peak_rss_bytes"].get<double>() / 1e6, m["peak_bytes_per_vertex"].get<double>(),
                d["wall_s"].get<double>(), d["peak_rss_bytes"].get<double>() / 1e6,
                r["ratios"]["time_vs_draco"].get<double>(), growth.c_str());
  }
  std::printf("\n| vertices | meshstream decode s (decode alone) | peak MB | Draco decode s | Draco peak MB | time vs Draco | memory vs Draco | 2 threads s (decode alone) | 2 threads vs Draco |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const json& r : rows) {
    const json& m = r["meshstream_decode"];
    const json& d = r["draco_decode"];
    const json& m2 = r["meshstream_decode_2threads"];
    std::printf("| %llu | %.2f (%.2f) | %.0f | %.2f | %.0f | %.2f | %.2f | %.2f (%.2f) | %.2f |\n",
                static_cast<unsigned long long>(r["vertices"].get<uint64_t>()), m["wall_s"].get<double>(),
                m["decode_ms"].get<double>() / 1000.0, m["peak_rss_bytes"].get<double>() / 1e6, d["wall_s"].get<double>(),
                d["peak_rss_bytes"].get<double>() / 1e6, r["ratios"]["decode_time_vs_draco"].get<double>(),
                r["ratios"]["decode_memory_vs_draco"].get<double>(), m2["wall_s"].get<double>(),
                m2["decode_ms"].get<double>() / 1000.0, r["ratios"]["decode_2threads_time_vs_draco"].get<double>());
  }
  std::fprintf(stderr, "meshstream_bench_scaling: wrote %s\n", args.out.c_str());
  return 0;
}

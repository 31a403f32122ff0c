// meshstream_bench_scaling: the encoder at scale (issue 24; docs/results/benchmarks.md,
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
// Issue 42: the encoder runs `--profile both --json` (what an ingest stores:
// both profiles, the harm estimate, the delivery record) and each row keeps
// the medians of its step times (`step_ms`: hierarchy, stream, harm,
// delivery); both profiles are decoded (the reliable one is what `decode`
// takes by default); and the series runs twice, on the smooth subdivision
// and on the same meshes with scan-like surface noise
// (bench/scaling/surface_noise.h), whose rows carry "surface": "noisy".
// Large assets: a third surface, "scan" (bench/scaling/surface_noise.h,
// WithGridNoise: each vertex a subdivision added moved by up to a grid step
// of qp 11 per axis), and per row the encoder on one thread (the
// "meshstream" row), on two (encode --threads 2: spatial parts at once) and
// as one part (--part-vertices 0: what the parts cost in bytes), with their
// ratios (encode_2threads_time_vs_draco, bytes_vs_one_part,
// reliable_bytes_vs_draco).
// Writes one JSON object (--out, default docs/results/bench/scaling.json) and prints
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
#include "bench/options.h"
#include "bench/scaling/measured_run.h"
#include "bench/scaling/subdivide.h"
#include "bench/scaling/surface_noise.h"
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
  std::string out = "docs/results/bench/scaling.json";
  std::string keep_inputs;  // copy each subdivided mesh here (for profiling)
  std::vector<std::string> surfaces = {"smooth", "noisy"};
  double noise = 0.25;  // the noisy surface's amplitude, in mean edge lengths
};

// The option table (bench/options.h): --help is made from it.
Args Parse(int argc, char** argv) {
  Args a;
  if (const char* tmp = std::getenv("TMPDIR")) a.work_dir = tmp;
  ms::bench::Options o(
      "meshstream_bench_scaling",
      "The encoder at scale: FILE (a shared model, default stanford-bunny.obj) subdivided 0..N\n"
      "times (default 3: 35 k to 2.2 M vertices for the bunny), each encoded by `meshstream\n"
      "encode` and by Draco (`meshstream convert --draco --cl 7`) as child processes: wall and\n"
      "CPU time and peak resident memory, medians of --runs (default 3). About 13 minutes on 2 cores for\n"
      "the default. Writes one JSON object (default docs/results/bench/scaling.json). --keep-inputs DIR\n"
      "keeps the subdivided meshes there (levelN.ply, noisyN.ply) to profile the encoder on them.\n"
      "The encoder runs as an ingest does (--profile both: both profiles, the harm estimate,\n"
      "the delivery record; each row keeps its step times), both profiles are decoded, and\n"
      "--surfaces (default smooth,noisy) runs the series on the smooth subdivision and on the\n"
      "same meshes with surface noise like a scan's: every vertex moved along its normal by up\n"
      "to --noise (default 0.25) mean edge lengths; scan: every vertex a subdivision added moved\n"
      "by up to one grid step of qp 11 along each axis (the shaped-link race's large model).\n"
      "Each row also encodes on two threads and as one spatial part (--part-vertices 0).\n");
  o.String("--model", "FILE", &a.model, "the shared model to subdivide (default stanford-bunny.obj)");
  o.Int("--subdivisions", "N", &a.subdivisions, 0, 5, "subdivisions (default 3)");
  o.Int("--runs", "N", &a.runs, 1, 99, "runs per measure, their median kept (default 3)");
  o.Int("--qp", "Q", &a.qp, 1, 30, "position bits (default 11)");
  o.String("--work-dir", "DIR", &a.work_dir, "where the meshes go (default $TMPDIR, else /tmp)");
  o.String("--out", "FILE", &a.out, "the JSON (default docs/results/bench/scaling.json)");
  o.String("--keep-inputs", "DIR", &a.keep_inputs, "copy each subdivided mesh here (for profiling)");
  o.Custom("--surfaces", "LIST",
           [&a](const std::string& list) {
             a.surfaces.clear();
             for (size_t at = 0; at <= list.size();) {
               const size_t comma = std::min(list.find(',', at), list.size());
               const std::string name = list.substr(at, comma - at);
               if (name != "smooth" && name != "noisy" && name != "scan") {
                 ms::bench::Die("--surfaces: '" + name + "' is not smooth, noisy or scan");
               }
               a.surfaces.push_back(name);
               at = comma + 1;
             }
           },
           "smooth, noisy and scan, comma-separated (default smooth,noisy)");
  o.Double("--noise", "A", &a.noise, 0, 10, "the noisy surface's amplitude, in mean edge lengths (default 0.25)");
  o.Parse(argc, argv);
  return a;
}

// The medians of `runs` runs of `argv`; Die when one fails. With `outputs`,
// each run's stdout is a JSON object, kept.
json Measure(const std::vector<std::string>& argv, int runs, uint64_t vertices, std::vector<json>* outputs = nullptr) {
  std::vector<double> wall, cpu, rss;
  for (int r = 0; r < runs; ++r) {
    const ms::bench::MeasuredRun m = ms::bench::RunMeasured(argv);
    if (m.exit_code != 0) ms::bench::Die(argv[1] + " failed (exit " + std::to_string(m.exit_code) + ") on " + argv.back());
    if (outputs) {
      const json j = json::parse(m.out, nullptr, false);
      if (j.is_discarded() || !j.is_object()) ms::bench::Die(argv[1] + ": its --json output is not a JSON object");
      outputs->push_back(j);
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

// The median over `outputs` of the number at `key` (a member, or a member of
// the member `parent`); Die when a run lacks it.
double MedianOf(const std::vector<json>& outputs, const std::string& key, const std::string& parent = "") {
  std::vector<double> values;
  for (const json& j : outputs) {
    const json& o = parent.empty() ? j : j.value(parent, json::object());
    if (!o.contains(key) || !o[key].is_number()) ms::bench::Die("no " + parent + (parent.empty() ? "" : ".") + key + " in a --json output");
    values.push_back(o[key].get<double>());
  }
  return ms::bench::Median(values);
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
  ms::Primitive source;
  source.positions = primitives[0]->positions;
  source.indices = primitives[0]->indices;

  json rows = json::array();
  for (const std::string& surface : args.surfaces) {
    const bool noisy = surface == "noisy";
    const bool scan = surface == "scan";
    ms::Primitive smooth = source;
    size_t first_row = rows.size();
    for (int level = 0; level <= args.subdivisions; ++level) {
      if (level > 0) smooth = ms::bench::SubdivideMidpoint(smooth);
      const ms::Primitive mesh =
          noisy  ? ms::bench::WithSurfaceNoise(smooth, args.noise, 1000 + static_cast<uint64_t>(level))
          : scan ? ms::bench::WithGridNoise(smooth, source.positions.size(), 1.0, 11, 2000 + static_cast<uint64_t>(level))
                 : smooth;
      const std::string stem = (noisy ? "noisy" : scan ? "scan" : "level") + std::to_string(level);
      const std::string in = dir + "/" + stem + ".ply";
      const ms::Status written = ms::WriteMeshFile(ms::SceneFromPrimitive(mesh, "scaled"), in);
      if (!written.ok()) ms::bench::Die("writing " + in + ": " + written.ToString());
      const uint64_t vertices = mesh.vertex_count();
      std::fprintf(stderr, "meshstream_bench_scaling: %s, %llu vertices, %zu triangles\n", surface.c_str(),
                   static_cast<unsigned long long>(vertices), mesh.face_count());
      if (!args.keep_inputs.empty()) {
        std::error_code ec;
        std::filesystem::create_directories(args.keep_inputs, ec);
        std::filesystem::copy_file(in, args.keep_inputs + "/" + stem + ".ply",
                                   std::filesystem::copy_options::overwrite_existing, ec);
        if (ec) ms::bench::Die("keeping " + in + " in " + args.keep_inputs + ": " + ec.message());
      }
      const std::string plain = dir + "/plain.glb", draco = dir + "/draco.glb", ours = dir + "/ours.glb";
      const std::string qp = std::to_string(args.qp);
      json row = {{"surface", surface}, {"subdivisions", level}, {"vertices", vertices}, {"faces", mesh.face_count()}};
      row["read_and_write"] = Measure({cli, "convert", "--quiet", in, plain}, args.runs, vertices);
      row["draco"] =
          Measure({cli, "convert", "--quiet", "--draco", "--qp", qp, "--cl", "7", in, draco}, args.runs, vertices);
      row["draco"]["output_bytes"] = FileBytes(draco);
      // The encoder as an ingest runs it: both profiles in one file.
      std::vector<json> encodes;
      row["meshstream"] = Measure({cli, "encode", "--json", "--profile", "both", "--threads", "1", "--qp", qp, in, "-o", ours},
                                  args.runs, vertices, &encodes);
      row["meshstream"]["output_bytes"] = FileBytes(ours);
      row["meshstream"]["profile"] = "both";
      row["meshstream"]["reliable_profile_bytes"] = encodes.front().value("reliable_level_bytes", json::array()).empty()
                                                        ? json(nullptr)
                                                        : encodes.front()["reliable_level_bytes"].back();
      row["meshstream"]["step_ms"] = json::object();
      for (const char* step : {"hierarchy", "stream", "harm", "delivery"}) {
        row["meshstream"]["step_ms"][step] = MedianOf(encodes, step, "step_ms");
      }
      row["meshstream"]["streams"] = encodes.front().value("primitives", 0);
      // The same on two threads (spatial parts encoded at once; the same file).
      const std::string ours2 = dir + "/ours2.glb", one_part = dir + "/one_part.glb";
      row["meshstream_2threads"] =
          Measure({cli, "encode", "--json", "--profile", "both", "--threads", "2", "--qp", qp, in, "-o", ours2}, args.runs,
                  vertices);
      row["meshstream_2threads"]["output_bytes"] = FileBytes(ours2);
      // As one part: what the parts cost in bytes.
      std::vector<json> one_part_encodes;
      row["meshstream_one_part"] = Measure({cli, "encode", "--json", "--profile", "both", "--threads", "1",
                                            "--part-vertices", "0", "--qp", qp, in, "-o", one_part},
                                           1, vertices, &one_part_encodes);
      row["meshstream_one_part"]["output_bytes"] = FileBytes(one_part);
      auto reliable_bytes = [](const json& e) {
        return e.value("reliable_level_bytes", json::array()).empty() ? 0.0 : e["reliable_level_bytes"].back().get<double>();
      };
      row["meshstream_one_part"]["reliable_profile_bytes"] = reliable_bytes(one_part_encodes.front());
      row["meshstream_one_part"]["loss_tolerant_bytes"] = one_part_encodes.front().value("total_bytes", 0.0) +
                                                          one_part_encodes.front().value("base_bytes", 0.0);
      row["meshstream"]["loss_tolerant_bytes"] = encodes.front().value("total_bytes", 0.0) +
                                                 encodes.front().value("base_bytes", 0.0);
      // Issue 25: the decoders, whole processes that read the .glb, decode
      // and write a plain .glb: `meshstream decode` (all levels; it also checks the
      // mesh's health, as it does for a user) against `meshstream convert` of
      // the Draco file (Draco's decoder through the glTF importer). The decode
      // alone, in the process, is what `decode --json` reports as decode_ms.
      // `decode` takes the reliable profile of the file; the loss-tolerant one
      // is meshstream_decode_loss_tolerant.
      const std::string decoded = dir + "/decoded.glb";
      std::vector<json> decodes;
      row["meshstream_decode"] = Measure({cli, "decode", "--json", ours, "-o", decoded}, args.runs, vertices, &decodes);
      row["meshstream_decode"]["decode_ms"] = MedianOf(decodes, "decode_ms");
      row["meshstream_decode"]["profile"] = decodes.front().value("profile", "");
      std::vector<json> lt_decodes;
      row["meshstream_decode_loss_tolerant"] =
          Measure({cli, "decode", "--json", "--profile", "loss-tolerant", ours, "-o", decoded}, args.runs, vertices,
                  &lt_decodes);
      row["meshstream_decode_loss_tolerant"]["decode_ms"] = MedianOf(lt_decodes, "decode_ms");
      row["draco_decode"] = Measure({cli, "convert", "--quiet", draco, decoded}, args.runs, vertices);
      // The same decode on 2 threads (decode --threads 2: whole refinements planned in parallel).
      std::vector<json> decodes2;
      row["meshstream_decode_2threads"] =
          Measure({cli, "decode", "--json", "--threads", "2", ours, "-o", decoded}, args.runs, vertices, &decodes2);
      row["meshstream_decode_2threads"]["decode_ms"] = MedianOf(decodes2, "decode_ms");
      const double draco_decode_s = row["draco_decode"]["wall_s"].get<double>();
      row["ratios"] = {
          {"time_vs_draco", row["meshstream"]["wall_s"].get<double>() / row["draco"]["wall_s"].get<double>()},
          {"memory_vs_draco",
           row["meshstream"]["peak_rss_bytes"].get<double>() / row["draco"]["peak_rss_bytes"].get<double>()},
          {"decode_time_vs_draco", row["meshstream_decode"]["wall_s"].get<double>() / draco_decode_s},
          {"decode_loss_tolerant_time_vs_draco",
           row["meshstream_decode_loss_tolerant"]["wall_s"].get<double>() / draco_decode_s},
          {"decode_memory_vs_draco", row["meshstream_decode"]["peak_rss_bytes"].get<double>() /
                                         row["draco_decode"]["peak_rss_bytes"].get<double>()},
          {"decode_2threads_time_vs_draco", row["meshstream_decode_2threads"]["wall_s"].get<double>() / draco_decode_s},
          {"encode_2threads_time_vs_draco",
           row["meshstream_2threads"]["wall_s"].get<double>() / row["draco"]["wall_s"].get<double>()},
          {"reliable_bytes_vs_one_part", row["meshstream"]["reliable_profile_bytes"].is_number()
                                             ? row["meshstream"]["reliable_profile_bytes"].get<double>() /
                                                   row["meshstream_one_part"]["reliable_profile_bytes"].get<double>()
                                             : 0.0},
          {"loss_tolerant_bytes_vs_one_part", row["meshstream"]["loss_tolerant_bytes"].get<double>() /
                                                  row["meshstream_one_part"]["loss_tolerant_bytes"].get<double>()},
          {"reliable_bytes_vs_draco", row["meshstream"]["reliable_profile_bytes"].is_number()
                                          ? row["meshstream"]["reliable_profile_bytes"].get<double>() /
                                                row["draco"]["output_bytes"].get<double>()
                                          : 0.0}};
      if (rows.size() > first_row) {
        const json& before = rows.back();
        row["growth_per_4x"] = {
            {"time", row["meshstream"]["wall_s"].get<double>() / before["meshstream"]["wall_s"].get<double>()},
            {"memory",
             row["meshstream"]["peak_rss_bytes"].get<double>() / before["meshstream"]["peak_rss_bytes"].get<double>()},
            {"draco_time", row["draco"]["wall_s"].get<double>() / before["draco"]["wall_s"].get<double>()}};
      }
      rows.push_back(row);
    }
  }
  std::filesystem::remove_all(dir);

  json out;
  out["benchmark"] = "meshstream_bench_scaling";
  out["machine"] = ms::bench::MachineInfo(args.work_dir, MESHSTREAM_SOURCE_DIR, MESHSTREAM_BUILD_TYPE);
  out["settings"] = {{"model", args.model},   {"subdivisions", args.subdivisions}, {"runs", args.runs},
                     {"qp", args.qp},         {"draco_compression_level", 7},      {"surfaces", args.surfaces},
                     {"noise", args.noise},   {"profile", "both"}};
  out["rows"] = rows;
  ms::bench::WriteJson(args.out, out);

  std::printf("| surface | vertices | meshstream encode s (hierarchy, stream, harm, delivery) | peak MB | bytes/vertex | Draco s | Draco peak MB | time vs Draco | growth per 4 x (time, memory) |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---|\n");
  for (const json& r : rows) {
    const json& m = r["meshstream"];
    const json& d = r["draco"];
    const json& st = m["step_ms"];
    std::string growth = "-";
    if (r.contains("growth_per_4x")) {
      char g[64];
      std::snprintf(g, sizeof g, "%.2f x, %.2f x", r["growth_per_4x"]["time"].get<double>(),
                    r["growth_per_4x"]["memory"].get<double>());
      growth = g;
    }
    std::printf("| %s | %llu | %.2f (%.2f, %.2f, %.2f, %.2f) | %.0f | %.0f | %.2f | %.0f | %.2f | %s |\n",
                r["surface"].get<std::string>().c_str(), static_cast<unsigned long long>(r["vertices"].get<uint64_t>()),
                m["wall_s"].get<double>(), st["hierarchy"].get<double>() / 1000.0, st["stream"].get<double>() / 1000.0,
                st["harm"].get<double>() / 1000.0, st["delivery"].get<double>() / 1000.0,
                m["peak_rss_bytes"].get<double>() / 1e6, m["peak_bytes_per_vertex"].get<double>(),
                d["wall_s"].get<double>(), d["peak_rss_bytes"].get<double>() / 1e6,
                r["ratios"]["time_vs_draco"].get<double>(), growth.c_str());
  }
  std::printf("\n| surface | vertices | reliable decode s (decode alone) | loss-tolerant s (alone) | peak MB | Draco decode s | Draco peak MB | reliable vs Draco | loss-tolerant vs Draco | memory vs Draco | 2 threads s (alone) | 2 threads vs Draco |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const json& r : rows) {
    const json& m = r["meshstream_decode"];
    const json& lt = r["meshstream_decode_loss_tolerant"];
    const json& d = r["draco_decode"];
    const json& m2 = r["meshstream_decode_2threads"];
    std::printf("| %s | %llu | %.2f (%.2f) | %.2f (%.2f) | %.0f | %.2f | %.0f | %.2f | %.2f | %.2f | %.2f (%.2f) | %.2f |\n",
                r["surface"].get<std::string>().c_str(), static_cast<unsigned long long>(r["vertices"].get<uint64_t>()),
                m["wall_s"].get<double>(), m["decode_ms"].get<double>() / 1000.0, lt["wall_s"].get<double>(),
                lt["decode_ms"].get<double>() / 1000.0, m["peak_rss_bytes"].get<double>() / 1e6,
                d["wall_s"].get<double>(), d["peak_rss_bytes"].get<double>() / 1e6,
                r["ratios"]["decode_time_vs_draco"].get<double>(),
                r["ratios"]["decode_loss_tolerant_time_vs_draco"].get<double>(),
                r["ratios"]["decode_memory_vs_draco"].get<double>(), m2["wall_s"].get<double>(),
                m2["decode_ms"].get<double>() / 1000.0, r["ratios"]["decode_2threads_time_vs_draco"].get<double>());
  }
  std::printf("\n| surface | vertices | streams | encode 1 thread s | 2 threads s | 2 threads vs Draco | reliable bytes | vs one part | loss-tolerant vs one part | reliable vs Draco's bytes |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const json& r : rows) {
    const json& q = r["ratios"];
    std::printf("| %s | %llu | %d | %.2f | %.2f | %.2f | %.0f | %.3f | %.3f | %.2f |\n", r["surface"].get<std::string>().c_str(),
                static_cast<unsigned long long>(r["vertices"].get<uint64_t>()), r["meshstream"]["streams"].get<int>(),
                r["meshstream"]["wall_s"].get<double>(), r["meshstream_2threads"]["wall_s"].get<double>(),
                q["encode_2threads_time_vs_draco"].get<double>(),
                r["meshstream"]["reliable_profile_bytes"].is_number() ? r["meshstream"]["reliable_profile_bytes"].get<double>() : 0.0,
                q["reliable_bytes_vs_one_part"].get<double>(), q["loss_tolerant_bytes_vs_one_part"].get<double>(),
                q["reliable_bytes_vs_draco"].get<double>());
  }
  std::fprintf(stderr, "meshstream_bench_scaling: wrote %s\n", args.out.c_str());
  return 0;
}

// meshstream_bench_decode: the decoding speed of issue 11 (docs/results/decode-profile.md).
//
// For every shared model (or --model), encoded once with EncodeProgressiveGlb
// (default options at --qp, default 11) and once with Draco at compression
// level 7 (EncodeDracoPrimitive, same quantization), times interleaved, round
// by round after one untimed warm-up round:
//   (a) DecodeProgressiveGlb, all levels (the .glb bytes in memory to the
//       final Scene in memory);
//   (b) the same with lod 0 (the base alone);
//   (c) draco::Decoder::DecodeMeshFromBuffer of the whole mesh (cl 7).
// With --threads N (N > 1), also (d) all levels with a pool of N threads
// (parallel/fork_join_pool.h), whose decode must hash the same as (a).
// Prints the medians and the ratios a/c and b/c; --json FILE writes them.
// Every round also checks that the decode is the same bit for bit as the
// first (a hash of the decoded Scene's vertex and index arrays, printed so
// that runs before and after a change can be compared).
//
// --loop MODEL SECONDS decodes that model (all levels, or --lod N) in a loop
// for about that long and nothing else: the process to run under
// `perf record -g`.
#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>

#include <cstdio>
#include <ctime>
#include <cstring>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/options.h"
#include "codec/core/fnv.h"
#include "importers/draco_codec.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "parallel/fork_join_pool.h"

namespace {

using json = nlohmann::json;
namespace ms = meshstream;
using ms::bench::Check;
using ms::bench::Clock;
using ms::bench::Die;
using ms::bench::Median;
using ms::bench::Ms;
using ms::bench::ParseDouble;
using ms::bench::Primitives;
using ms::bench::Stem;

const char kAbout[] =
    "Times DecodeProgressiveGlb (all levels, and the base alone) against Draco's decode of the\n"
    "whole mesh (compression level 7, same quantization), interleaved round by round after one\n"
    "warm-up round, and prints the medians and the ratios. With --loop: only decodes MODEL.\n";

struct Args {
  std::string models_dir = MESHSTREAM_MODELS_DIR;
  std::vector<std::string> only;
  int qp = 11;
  int rounds = 30;
  std::string json_out;
  std::string loop_model;
  double loop_seconds = 0;
  int loop_lod = -1;
  int threads = 1;
  std::string profile = "loss-tolerant";  // the streams encoded (format version 4's profiles)
};

Args ParseArgs(int argc, char** argv) {
  Args a;
  ms::bench::Options o("meshstream_bench_decode", kAbout);
  ms::bench::AddModelOptions(o, &a.models_dir, &a.only,
                             "only this model (file name, with or without extension); repeatable\n"
                             "(default: stanford-bunny, horse, fandisk, rocker-arm, spot)");
  o.Int("--qp", "N", &a.qp, 1, 30, "position bits of both codecs (default 11; normals 8, texcoords 10)");
  o.Int("--rounds", "N", &a.rounds, 1, 100000, "timed rounds (default 30)");
  o.String("--json", "FILE", &a.json_out, "also write the medians and ratios as JSON");
  o.CustomN("--loop", "MODEL SEC", 2, [&a](const std::vector<std::string>& v) {
    a.loop_model = v[0];
    a.loop_seconds = ParseDouble(v[1], "--loop");
    if (a.loop_seconds <= 0) Die("--loop: SECONDS must be positive");
  }, "only decode MODEL (all levels) in a loop for SEC seconds (for perf)");
  o.Int("--threads", "N", &a.threads, 1, ms::ForkJoinPool::kMaxWorkers,
        "also time all levels on N threads (default 1: not timed); with --loop: decode on N threads");
  o.Int("--lod", "N", &a.loop_lod, -1, 1 << 20, "with --loop: decode N levels (0: the base alone; default -1: all)");
  o.String("--profile", "P", &a.profile,
           "loss-tolerant (default) or reliable: the profile the models are encoded in (docs/spec/progressive-format.md)");
  o.Parse(argc, argv);
  if (a.profile != "loss-tolerant" && a.profile != "reliable") Die("--profile: loss-tolerant or reliable");
  return a;
}

// A hash of every refined primitive's arrays: equal hashes, equal decodes.
uint64_t SceneHash(const ms::Scene& scene) {
  ms::Fnv1a h;
  for (const ms::Primitive* p : Primitives(scene)) {
    h.AddVector(p->positions);
    h.AddVector(p->normals);
    for (const auto& t : p->texcoords) h.AddVector(t);
    h.AddVector(p->colors);
    h.AddVector(p->indices);
  }
  return h.value;
}

struct Model {
  std::string name;
  uint64_t vertices = 0, faces = 0;
  std::vector<uint8_t> glb;
  std::vector<ms::DracoEncoded> draco;  // cl 7, one per primitive
};

Model Prepare(const std::string& models_dir, const std::string& file, int qp, const std::string& profile) {
  Model m;
  m.name = Stem(file);
  const std::string path = models_dir + "/" + file;
  const ms::Scene scene = Check(ms::ImportFile(path), path);
  const auto prims = Primitives(scene);
  if (prims.empty()) Die(path + ": no triangles");
  ms::ProgressiveGlbOptions options;
  options.encode.quantization.qp = qp;
  options.profiles = profile == "reliable" ? ms::ProfileSet::kReliable : ms::ProfileSet::kLossTolerant;
  ms::ProgressiveGlbReport report;
  m.glb = Check(ms::EncodeProgressiveGlb(scene, options, &report), m.name + ": EncodeProgressiveGlb");
  m.vertices = report.Total().vertices;
  m.faces = report.Total().faces;
  ms::DracoEncodeOptions d;
  d.qp = options.encode.quantization.qp;
  d.qn = options.encode.quantization.qn;
  d.qt = options.encode.quantization.qt;
  d.qc = options.encode.quantization.qc;
  d.compression_level = 7;
  for (const ms::Primitive* p : prims) {
    m.draco.push_back(Check(ms::EncodeDracoPrimitive(*p, d), m.name + ": EncodeDracoPrimitive"));
  }
  return m;
}

uint64_t DecodeMeshstream(const Model& m, int lod, ms::TaskRunner* runner = nullptr) {
  ms::ProgressiveDecodeOptions o;
  o.lod = lod;
  o.runner = runner;
  auto s = ms::DecodeProgressiveGlb(m.glb, o, nullptr);
  if (!s.ok()) Die(m.name + ": DecodeProgressiveGlb: " + s.status().ToString());
  return SceneHash(s.value());
}

size_t DecodeDraco(const Model& m) {
  size_t points = 0;
  for (const auto& e : m.draco) {
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char*>(e.bytes.data()), e.bytes.size());
    draco::Decoder decoder;
    auto mesh = decoder.DecodeMeshFromBuffer(&buffer);
    if (!mesh.ok()) Die(m.name + ": draco::Decoder: " + mesh.status().error_msg_string());
    points += mesh.value()->num_points();
  }
  return points;
}

// CPU time of this process (ms): unlike the wall clock, it leaves out the
// time other processes had the core.
double CpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

int Loop(const Args& args) {
  const Model m = Prepare(args.models_dir, ms::bench::ChooseSharedModels({args.loop_model}).front(), args.qp, args.profile);
  const auto start = Clock::now();
  const double cpu_start = CpuMs();
  size_t runs = 0;
  ms::ForkJoinPool pool(args.threads);
  do {  // at least one decode, however short SECONDS (valgrind)
    ms::ProgressiveDecodeOptions o;
    o.lod = args.loop_lod;
    if (args.threads > 1) o.runner = &pool;
    auto s = ms::DecodeProgressiveGlb(m.glb, o, nullptr);
    if (!s.ok()) Die(m.name + ": DecodeProgressiveGlb: " + s.status().ToString());
    ++runs;
  } while (Ms(start, Clock::now()) < args.loop_seconds * 1000);
  const double ms_total = Ms(start, Clock::now());
  const double cpu_total = CpuMs() - cpu_start;
  std::printf("%s: %zu decodes in %.0f ms (%.3f ms each; %.3f ms of CPU time each)\n", m.name.c_str(), runs,
              ms_total, ms_total / runs, cpu_total / runs);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ms::bench::SetProgramName("meshstream_bench_decode");
  const Args args = ParseArgs(argc, argv);
  if (!args.loop_model.empty()) return Loop(args);

  json out;
  out["schema"] = "meshstream-bench-decode/1";
  out["machine"] = {{"cpu", ms::bench::CpuModel()},
                    {"kernel", ms::bench::KernelName()},
                    {"load_average", ms::bench::LoadAverage()},
                    {"time", ms::bench::UtcNow()},
                    {"commit", ms::bench::GitShortCommit(MESHSTREAM_SOURCE_DIR)},
                    {"build_type", MESHSTREAM_BUILD_TYPE}};
  out["settings"] = {{"qp", args.qp}, {"rounds", args.rounds}, {"draco_compression_level", 7}};
  out["models"] = json::array();

  out["settings"]["threads"] = args.threads;
  ms::ForkJoinPool pool(args.threads);
  std::printf("%-15s %8s %8s | %9s %9s %9s | %6s %6s | %s\n", "model", "vertices", "faces", "all ms", "base ms",
              "draco ms", "all/d", "base/d", "decode hash");
  for (const std::string& file : ms::bench::ChooseSharedModels(args.only)) {
    const Model m = Prepare(args.models_dir, file, args.qp, args.profile);
    struct Timed {
      std::function<uint64_t()> run;
      std::vector<double> times;
      uint64_t first = 0;
    };
    std::vector<Timed> timed = {{[&m] { return DecodeMeshstream(m, -1); }, {}, 0},
                                {[&m] { return DecodeMeshstream(m, 0); }, {}, 0},
                                {[&m] { return uint64_t{DecodeDraco(m)}; }, {}, 0}};
    if (args.threads > 1) timed.push_back({[&m, &pool] { return DecodeMeshstream(m, -1, &pool); }, {}, 0});
    for (Timed& t : timed) t.first = t.run();  // the warm-up round
    if (args.threads > 1 && timed[3].first != timed[0].first) {
      Die(m.name + ": the decode on " + std::to_string(args.threads) + " threads differs from the one-thread decode");
    }
    for (int i = 0; i < args.rounds; ++i) {
      for (Timed& t : timed) {
        const auto s = Clock::now();
        const uint64_t h = t.run();
        t.times.push_back(Ms(s, Clock::now()));
        if (h != t.first) Die(m.name + ": a decode differs from the first one");
      }
    }
    const double all = Median(timed[0].times), base = Median(timed[1].times), draco = Median(timed[2].times);
    std::printf("%-15s %8llu %8llu | %9.3f %9.3f %9.3f | %6.2f %6.2f | %016llx\n", m.name.c_str(),
                static_cast<unsigned long long>(m.vertices), static_cast<unsigned long long>(m.faces), all, base,
                draco, all / draco, base / draco, static_cast<unsigned long long>(timed[0].first));
    json parallel;
    if (args.threads > 1) {
      const double threaded = Median(timed[3].times);
      std::printf("%-15s %d threads: all levels %.3f ms, %.2f x one thread, %.2f x draco (same hash)\n", "",
                  args.threads, threaded, threaded / all, threaded / draco);
      parallel = {{"threads", args.threads},
                  {"decode_all_ms", threaded},
                  {"over_one_thread", threaded / all},
                  {"over_draco", threaded / draco},
                  {"all_ms", timed[3].times}};
    }
    std::fflush(stdout);
    out["models"].push_back({{"name", m.name},
                             {"vertices", m.vertices},
                             {"faces", m.faces},
                             {"glb_bytes", m.glb.size()},
                             {"decode_all_ms", all},
                             {"decode_base_ms", base},
                             {"draco7_decode_ms", draco},
                             {"all_over_draco", all / draco},
                             {"base_over_draco", base / draco},
                             {"decode_all_hash", timed[0].first},
                             {"decode_base_hash", timed[1].first},
                             {"all_ms", timed[0].times},
                             {"base_ms", timed[1].times},
                             {"draco_ms", timed[2].times},
                             {"parallel", parallel}});
  }
  if (!args.json_out.empty()) {
    std::ofstream f(args.json_out);
    f << out.dump(2) << "\n";
    if (!f) Die("cannot write " + args.json_out);
  }
  return 0;
}

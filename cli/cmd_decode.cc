// meshstream decode IN.glb -o OUT [--lod K] [--loss P] [--seed S] [--burst B] [--reorder R]
//   [--duplicate D] [--recovery predict|lwop] [--threads N] [--repeat N] [--json]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli/json_out.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "codec/mesh/mesh_health.h"
#include "codec/progressive/coding_tools.h"
#include "fec/reed_solomon.h"
#include "importers/gltf_export.h"
#include "importers/import.h"
#include "importers/mesh_writer.h"
#include "importers/progressive_glb.h"
#include "parallel/fork_join_pool.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "IN is a progressive .glb made by `meshstream encode` (a plain .glb is its own base);\n"
    "OUT is .glb .gltf .obj or .ply. --lod K decodes level K (0 = the base mesh; by default\n"
    "all): one primitive's K refinements; in a scene of several, the refinements of each that\n"
    "the scene's level K has (those that leave the larger errors first; K of each, clamped,\n"
    "in a file made before the errors were recorded). The refinements cross a simulated\n"
    "network, seeded so that a run repeats exactly: the control blocks reliably, the\n"
    "datagrams with loss, reordering and duplication. What is lost is predicted (paper,\n"
    "section 4.4) or, with --recovery lwop, abandoned with every split that depends on it.\n"
    "With no loss the result is the lossless mesh, through the same code path. The\n"
    "refinements of the file's reliable cut travel with their datagrams on the reliable\n"
    "channel, as a session sends them (--reliable-share 0: none, the paper's scheme); the\n"
    "refinements it protects get parity datagrams as a session sends them, sized for the\n"
    "simulated loss, which rebuild lost datagrams (--no-parity: none; docs/design/loss-protection.md).\n"
    "--threads N decodes each refinement that arrived whole on N threads (0: one per core;\n"
    "the mesh is the same bit for bit as on one thread, the default); --json's\n"
    "parallel_splits counts the splits decoded that way.\n"
    "--json prints counts, mesh health and decode_ms (from the file's bytes in memory to\n"
    "the final mesh in memory: Draco base decode, reconstruction and every split).\n"
    "\n"
    "Example:\n"
    "  meshstream decode --json --loss 0.1 --seed 7 bunny.glb -o lossy.ply";

struct DecodeArgs {
  std::string in, out;
  int lod = -1;
  int repeat = 1;
  double loss = 0, burst = 0, reorder = 0, duplicate = 0;
  int seed = 1;
  std::string recovery = "predict";
  std::string profile = "auto";
  double reliable_share = -1;
  bool no_parity = false;
  int threads = 1;
  bool json = false;
};

// The profile the streams were decoded from: "reliable", "loss-tolerant",
// "mixed" (a scene whose primitives differ) or "none" (a plain glTF file).
const char* ProfileOf(const ProgressiveDecodeReport& report) {
  if (report.reliable_profile_streams == 0) return report.loss_tolerant_streams == 0 ? "none" : "loss-tolerant";
  return report.loss_tolerant_streams == 0 ? "reliable" : "mixed";
}

int RunDecode(const DecodeArgs& args) {
  const std::string& in = args.in;
  const std::string& out = args.out;
  const std::string ext = FileExtension(out);
  if (ext != ".glb" && ext != ".gltf" && ext != ".obj" && ext != ".ply") {
    return ReportError("decode", InvalidArgument(out + ": OUT must end in .glb, .gltf, .obj or .ply"));
  }
  auto bytes = ReadFileBytes(in, kDefaultMaxInputBytes);
  if (!bytes.ok()) return ReportError("decode", bytes.status());
  ProgressiveDecodeOptions options;
  options.lod = args.lod;
  options.loss.loss = args.loss;
  options.loss.burst = args.burst;
  options.loss.reorder = args.reorder;
  options.loss.duplicate = args.duplicate;
  options.loss.seed = static_cast<uint64_t>(args.seed);
  options.reliable_share = args.reliable_share;
  options.profile = args.profile == "reliable"        ? DecodeProfile::kReliable
                    : args.profile == "loss-tolerant" ? DecodeProfile::kLossTolerant
                                                      : DecodeProfile::kAuto;
  if (!args.no_parity) options.parity = &fec::DefaultErasureCode();
  const std::string& recovery = args.recovery;
  options.recovery = recovery == "lwop" ? Recovery::kLwop : Recovery::kPredict;
  // The pool's threads start once, outside the timed decodes.
  const int threads = args.threads == 0 ? ForkJoinPool::HardwareWorkers() : args.threads;
  std::unique_ptr<ForkJoinPool> pool;
  if (threads > 1) {
    pool = std::make_unique<ForkJoinPool>(threads);
    options.runner = pool.get();
  }
  std::vector<double> times;
  StatusOr<Scene> scene = InvalidInput("not decoded");
  ProgressiveDecodeReport report;
  for (int i = 0; i < args.repeat; ++i) {
    const auto start = std::chrono::steady_clock::now();
    scene = DecodeProgressiveGlb(bytes.value(), options, &report);
    times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    if (!scene.ok()) return ReportError("decode", scene.status().WithContext(in));
  }
  std::sort(times.begin(), times.end());
  const double decode_ms = times[times.size() / 2];
  if (args.lod >= 0 && static_cast<uint64_t>(args.lod) > report.levels) {
    return ReportError("decode", InvalidArgument("--lod " + std::to_string(args.lod) + " is beyond the file's " +
                                                 std::to_string(report.levels) + " levels"));
  }
  const Status written = (ext == ".glb" || ext == ".gltf") ? ExportGltfFile(scene.value(), out, {})
                                                           : WriteMeshFile(scene.value(), out);
  if (!written.ok()) return ReportError("decode", written);

  MeshHealth health;
  std::vector<std::string> attributes;
  for (const Mesh& m : scene->meshes)
    for (const Primitive& p : m.primitives) {
      health.Add(ComputeHealth(p));
      for (const std::string& a : p.AttributeNames())
        if (std::find(attributes.begin(), attributes.end(), a) == attributes.end()) attributes.push_back(a);
    }
  nlohmann::json j = {
      {"input", Utf8(in)},
      {"output", Utf8(out)},
      {"vertices", health.vertices},
      {"faces", health.faces},
      {"attributes", Utf8(attributes)},
      {"levels", report.levels},
      {"levels_applied", report.levels_applied},
      {"tools", ToolNamesOf(report.tools)},
      {"profile", ProfileOf(report)},
      {"reliable_profile_streams", report.reliable_profile_streams},
      {"loss_tolerant_streams", report.loss_tolerant_streams},
      {"level_vertices", report.level_vertices},
      {"datagrams", report.datagrams},
      {"lost_datagrams", report.lost_datagrams},
      {"late_datagrams", report.late_datagrams},
      {"reliable_datagrams", report.reliable_datagrams},
      {"reliable_datagram_bytes", report.reliable_datagram_bytes},
      {"recovery", recovery},
      {"loss", args.loss},
      {"seed", args.seed},
      {"predicted_vertices", report.predicted_vertices},
      {"parity_datagrams", report.parity_datagrams},
      {"parity_bytes", report.parity_bytes},
      {"datagrams_recovered", report.recovered_datagrams},
      {"refinements_decoded_again", report.refinements_decoded_again},
      {"unreferenced_vertices", health.unreferenced_vertices},
      {"degenerate_faces", health.degenerate_faces},
      {"nonmanifold_edges", health.nonmanifold_edges},
      {"decode_ms", decode_ms},
      {"repeat", args.repeat},
      {"threads", threads},
      {"parallel_splits", report.recovery.planned},
  };
  if (options.recovery == Recovery::kLwop) {
    j["abandoned_splits"] = report.recovery.abandoned;
  } else {
    j["predicted_splits"] = report.recovery.predicted();
    j["predicted_structure_only"] = report.recovery.predicted_structure;
    j["predicted_geometry_only"] = report.recovery.predicted_geometry;
    j["structure_fallbacks"] = report.recovery.structure_fallbacks;
    j["structure_distrusted"] = report.recovery.structure_distrusted;
  }
  if (args.json) {
    PrintJson(j);
  } else {
    std::printf("%s -> %s: level %llu of %llu, %llu vertices, %llu faces, decoded in %.2f ms\n", in.c_str(), out.c_str(),
                static_cast<unsigned long long>(report.levels_applied), static_cast<unsigned long long>(report.levels),
                static_cast<unsigned long long>(health.vertices), static_cast<unsigned long long>(health.faces), decode_ms);
  }
  return kExitOk;
}

}  // namespace

Verb AddDecode(CLI::App& root) {
  auto args = std::make_shared<DecodeArgs>();
  CLI::App* cmd = AddVerb(root, "decode",
                          "Decodes a level of detail of a progressive .glb, across a simulated lossy network.", kDetails);
  cmd->add_option("IN", args->in, "the progressive .glb")->required();
  cmd->add_option("-o,--output", args->out, "the decoded mesh: .glb .gltf .obj or .ply")->required();
  cmd->add_option("--lod", args->lod, "the level to decode (default: all)")
      ->check(CLI::Range(0, static_cast<int>(kMaxRefinements)));
  cmd->add_option("--loss", args->loss, "probability that a datagram is lost")->check(NumberIn(0, 1))->capture_default_str();
  cmd->add_option("--burst", args->burst, "mean length of a loss burst (0: independent losses)")
      ->check(NumberIn(0, 1e6))->capture_default_str();
  cmd->add_option("--reorder", args->reorder, "fraction of datagrams delayed behind later ones")
      ->check(NumberIn(0, 1))->capture_default_str();
  cmd->add_option("--duplicate", args->duplicate, "fraction of datagrams delivered twice")
      ->check(NumberIn(0, 1))->capture_default_str();
  cmd->add_option("--seed", args->seed, "seed of the simulated network")->check(CLI::Range(0, 2147483647))
      ->capture_default_str();
  cmd->add_option("--profile", args->profile,
                  "the stream to decode where the file has both: auto (the reliable one unless --loss, --reorder "
                  "or --duplicate simulate a network), reliable or loss-tolerant; docs/spec/progressive-format.md")
      ->check(CLI::IsMember({"auto", "reliable", "loss-tolerant"}))
      ->capture_default_str();
  cmd->add_option("--recovery", args->recovery, "predict: predict lost splits; lwop: abandon them and their dependants")
      ->check(CLI::IsMember({"predict", "lwop"}))->capture_default_str();
  cmd->add_option("--reliable-share", args->reliable_share,
                  "share of each stream's bytes whose refinements travel reliably (default: the cut the file "
                  "records; 0: none, the paper's scheme)")
      ->check(NumberIn(0, 1));
  cmd->add_flag("--no-parity", args->no_parity,
                "send no parity datagrams: what the network loses is predicted, never rebuilt");
  cmd->add_option("--threads", args->threads,
                  "threads for refinements that arrived whole (0: one per core; the output does not change)")
      ->check(CLI::Range(0, ForkJoinPool::kMaxWorkers))->capture_default_str();
  cmd->add_option("--repeat", args->repeat, "decode N times in-process and report the median decode_ms")
      ->check(CLI::Range(1, 1000))->capture_default_str();
  cmd->add_flag("--json", args->json, "print one JSON object");
  return {cmd, [args] { return RunDecode(*args); }};
}

}  // namespace meshstream::cli

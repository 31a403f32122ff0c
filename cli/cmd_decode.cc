// meshstream decode IN.glb -o OUT [--lod K] [--loss P] [--seed S] [--burst B] [--reorder R]
//   [--duplicate D] [--recovery predict|lwop] [--repeat N] [--json]
#include <algorithm>
#include <chrono>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "cli/args.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "codec/mesh/mesh_health.h"
#include "importers/gltf_export.h"
#include "importers/import.h"
#include "importers/mesh_writer.h"
#include "importers/progressive_glb.h"

namespace meshstream::cli {

namespace {

const char kHelp[] =
    "usage: meshstream decode IN.glb -o OUT.(glb|gltf|obj|ply) [--lod K] [--loss P] [--seed S]\n"
    "         [--burst B] [--reorder R] [--duplicate D] [--recovery predict|lwop] [--repeat N] [--json]\n"
    "\n"
    "Decodes a progressive .glb made by `meshstream encode` to the level of detail K\n"
    "(0 = the base mesh, `levels` = the full mesh, the default) and writes it. The\n"
    "refinements cross a simulated network (seeded, so a run repeats exactly): the\n"
    "control blocks reliably, the datagrams with loss, reordering and duplication;\n"
    "what is lost is predicted (or abandoned with --recovery lwop). With no loss the\n"
    "result is the lossless mesh, through the same code path.\n"
    "\n"
    "Options:\n"
    "  --lod K         refinements to apply (per primitive, clamped to its own count)\n"
    "  --loss P        probability that a datagram is lost, 0..1 (default 0)\n"
    "  --burst B       mean length of a loss burst (default: independent losses)\n"
    "  --reorder R     fraction of datagrams delayed behind later ones, 0..1 (default 0)\n"
    "  --duplicate D   fraction of datagrams delivered twice, 0..1 (default 0)\n"
    "  --seed S        seed of the simulated network (default 1)\n"
    "  --recovery M    predict (default): predict lost splits (paper, section 4.4);\n"
    "                  lwop: abandon them and every split that depends on them\n"
    "  --repeat N   decode N times in-process and report the median decode_ms (default 1)\n"
    "  --json       print one JSON object: counts, mesh health, decode_ms (from the file's\n"
    "               bytes in memory to the final mesh in memory: Draco base decode,\n"
    "               reconstruction and every split; file I/O excluded)\n";

}  // namespace

int RunDecode(const std::vector<std::string>& argv) {
  auto parsed = ParseArgs(argv, {{"o", true},
                                 {"output", true},
                                 {"lod", true},
                                 {"repeat", true},
                                 {"loss", true},
                                 {"seed", true},
                                 {"burst", true},
                                 {"reorder", true},
                                 {"duplicate", true},
                                 {"recovery", true},
                                 {"json", false}});
  if (!parsed.ok()) return ReportError("decode", parsed.status());
  const ParsedArgs& args = parsed.value();
  if (args.Has("help")) {
    std::fputs(kHelp, stdout);
    return kExitOk;
  }
  const std::string out = args.String("o", args.String("output", ""));
  if (args.positional.size() != 1 || out.empty()) return ReportError("decode", InvalidArgument("expected IN.glb and -o OUT"));
  const std::string ext = FileExtension(out);
  if (ext != ".glb" && ext != ".gltf" && ext != ".obj" && ext != ".ply") {
    return ReportError("decode", InvalidArgument(out + ": OUT must end in .glb, .gltf, .obj or .ply"));
  }
  auto lod = args.Int("lod", -1, 0, static_cast<int>(kMaxRefinements));
  auto repeat = args.Int("repeat", 1, 1, 1000);
  if (!lod.ok()) return ReportError("decode", lod.status());
  if (!repeat.ok()) return ReportError("decode", repeat.status());

  const std::string& in = args.positional[0];
  auto bytes = ReadFileBytes(in, kDefaultMaxInputBytes);
  if (!bytes.ok()) return ReportError("decode", bytes.status());
  ProgressiveDecodeOptions options;
  options.lod = *lod;
  auto loss = args.Double("loss", 0, 0, 1);
  auto burst = args.Double("burst", 0, 0, 1e6);
  auto reorder = args.Double("reorder", 0, 0, 1);
  auto duplicate = args.Double("duplicate", 0, 0, 1);
  auto seed = args.Int("seed", 1, 0, 2147483647);
  for (const Status& s : {loss.status(), burst.status(), reorder.status(), duplicate.status(), seed.status()}) {
    if (!s.ok()) return ReportError("decode", s);
  }
  options.loss.loss = *loss;
  options.loss.burst = *burst;
  options.loss.reorder = *reorder;
  options.loss.duplicate = *duplicate;
  options.loss.seed = static_cast<uint64_t>(*seed);
  const std::string recovery = args.String("recovery", "predict");
  if (recovery != "predict" && recovery != "lwop") {
    return ReportError("decode", InvalidArgument("--recovery must be predict or lwop, not '" + recovery + "'"));
  }
  options.recovery = recovery == "lwop" ? Recovery::kLwop : Recovery::kPredict;
  std::vector<double> times;
  StatusOr<Scene> scene = InvalidInput("not decoded");
  ProgressiveDecodeReport report;
  for (int i = 0; i < *repeat; ++i) {
    const auto start = std::chrono::steady_clock::now();
    scene = DecodeProgressiveGlb(bytes.value(), options, &report);
    times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    if (!scene.ok()) return ReportError("decode", scene.status().WithContext(in));
  }
  std::sort(times.begin(), times.end());
  const double decode_ms = times[times.size() / 2];
  if (*lod >= 0 && static_cast<uint64_t>(*lod) > report.levels) {
    return ReportError("decode", InvalidArgument("--lod " + std::to_string(*lod) + " is beyond the file's " +
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
      {"input", in},
      {"output", out},
      {"vertices", health.vertices},
      {"faces", health.faces},
      {"attributes", attributes},
      {"levels", report.levels},
      {"levels_applied", report.levels_applied},
      {"level_vertices", report.level_vertices},
      {"datagrams", report.datagrams},
      {"lost_datagrams", report.lost_datagrams},
      {"late_datagrams", report.late_datagrams},
      {"recovery", recovery},
      {"loss", *loss},
      {"seed", *seed},
      {"predicted_vertices", report.predicted_vertices},
      {"unreferenced_vertices", health.unreferenced_vertices},
      {"degenerate_faces", health.degenerate_faces},
      {"nonmanifold_edges", health.nonmanifold_edges},
      {"decode_ms", decode_ms},
      {"repeat", *repeat},
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
  if (args.Has("json")) {
    std::puts(j.dump().c_str());
  } else {
    std::printf("%s -> %s: level %llu of %llu, %llu vertices, %llu faces, decoded in %.2f ms\n", in.c_str(), out.c_str(),
                static_cast<unsigned long long>(report.levels_applied), static_cast<unsigned long long>(report.levels),
                static_cast<unsigned long long>(health.vertices), static_cast<unsigned long long>(health.faces), decode_ms);
  }
  return kExitOk;
}

}  // namespace meshstream::cli

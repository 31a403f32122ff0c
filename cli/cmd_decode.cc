// meshstream decode IN.glb -o OUT [--lod K] [--repeat N] [--json]
#include <algorithm>
#include <chrono>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "cli/args.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "codec/mesh_health.h"
#include "importers/gltf_export.h"
#include "importers/import.h"
#include "importers/mesh_writer.h"
#include "importers/progressive_glb.h"

namespace meshstream::cli {

namespace {

const char kHelp[] =
    "usage: meshstream decode IN.glb -o OUT.(glb|gltf|obj|ply) [--lod K] [--repeat N] [--json]\n"
    "\n"
    "Decodes a progressive .glb made by `meshstream encode` to the level of detail K\n"
    "(0 = the base mesh, `levels` = the full mesh, the default) and writes it.\n"
    "\n"
    "Options:\n"
    "  --lod K      refinements to apply (per primitive, clamped to its own count)\n"
    "  --repeat N   decode N times in-process and report the median decode_ms (default 1)\n"
    "  --json       print one JSON object: counts, mesh health, decode_ms (from the file's\n"
    "               bytes in memory to the final mesh in memory: Draco base decode,\n"
    "               reconstruction and every split; file I/O excluded)\n";

}  // namespace

int RunDecode(const std::vector<std::string>& argv) {
  auto parsed = ParseArgs(argv, {{"o", true}, {"output", true}, {"lod", true}, {"repeat", true}, {"json", false}});
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
      {"unreferenced_vertices", health.unreferenced_vertices},
      {"degenerate_faces", health.degenerate_faces},
      {"nonmanifold_edges", health.nonmanifold_edges},
      {"decode_ms", decode_ms},
      {"repeat", *repeat},
  };
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

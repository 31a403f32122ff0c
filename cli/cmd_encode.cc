// meshstream encode IN -o OUT.glb [options]
#include <unistd.h>

#include <chrono>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "cli/args.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"

namespace meshstream::cli {

namespace {

const char kHelp[] =
    "usage: meshstream encode IN -o OUT.glb [--qp 11] [--qn 8] [--qt 10] [--qc 8] [--levels N]\n"
    "                         [--base-ratio F] [--packing split|bundled] [--packet-bytes 1200]\n"
    "                         [--cl 7] [--json]\n"
    "\n"
    "Encodes every primitive of IN (.gltf .glb .obj .ply .off .stl) into a progressive .glb:\n"
    "the base mesh under KHR_draco_mesh_compression (any glTF viewer shows it) and the\n"
    "refinements in the MESHSTREAM_progressive extension (docs/progressive-format.md).\n"
    "\n"
    "Options:\n"
    "  --qp/--qn/--qt/--qc N   quantization bits of positions, normals, UVs, colours\n"
    "  --levels N              at most N refinements (default 40)\n"
    "  --base-ratio F          stop simplifying at F of the vertices (default 0.02)\n"
    "  --packing P             split (structure and geometry in separate datagrams, the\n"
    "                          default) or bundled (one fragment per split)\n"
    "  --packet-bytes N        datagram payload limit, header included (default 1200)\n"
    "  --cl N                  Draco compression level of the base mesh (default 7)\n"
    "  --json                  print one JSON object with sizes and timings\n";

}  // namespace

int RunEncode(const std::vector<std::string>& argv) {
  auto parsed = ParseArgs(argv, {{"o", true}, {"output", true}, {"qp", true}, {"qn", true}, {"qt", true}, {"qc", true},
                                 {"levels", true}, {"base-ratio", true}, {"packing", true}, {"packet-bytes", true},
                                 {"cl", true}, {"json", false}});
  if (!parsed.ok()) return ReportError("encode", parsed.status());
  const ParsedArgs& args = parsed.value();
  if (args.Has("help")) {
    std::fputs(kHelp, stdout);
    return kExitOk;
  }
  const std::string out = args.String("o", args.String("output", ""));
  if (args.positional.size() != 1 || out.empty()) return ReportError("encode", InvalidArgument("expected IN and -o OUT.glb"));
  if (FileExtension(out) != ".glb") return ReportError("encode", InvalidArgument(out + ": the progressive file must be a .glb"));

  ProgressiveGlbOptions options;
  QuantizationParams& q = options.encode.quantization;
  auto qp = args.Int("qp", q.qp, 1, 30);
  auto qn = args.Int("qn", q.qn, 2, 15);
  auto qt = args.Int("qt", q.qt, 1, 30);
  auto qc = args.Int("qc", q.qc, 1, 16);
  auto levels = args.Int("levels", static_cast<int>(options.encode.simplify.max_levels), 0, static_cast<int>(kMaxRefinements));
  auto ratio = args.Double("base-ratio", options.encode.simplify.base_ratio, 1e-6, 1.0);
  auto packet = args.Int("packet-bytes", static_cast<int>(options.stream.packet_bytes), kMinPacketBytes, kMaxPacketBytes);
  auto cl = args.Int("cl", options.draco_compression_level, 0, 10);
  for (const Status& s : {qp.status(), qn.status(), qt.status(), qc.status(), levels.status(), ratio.status(),
                          packet.status(), cl.status()}) {
    if (!s.ok()) return ReportError("encode", s);
  }
  const std::string packing = args.String("packing", "split");
  if (packing != "split" && packing != "bundled") {
    return ReportError("encode", InvalidArgument("--packing must be split or bundled, got '" + packing + "'"));
  }
  q = {*qp, *qn, *qt, *qc};
  options.encode.simplify.max_levels = static_cast<uint32_t>(*levels);
  options.encode.simplify.base_ratio = *ratio;
  options.stream.packet_bytes = static_cast<uint32_t>(*packet);
  options.stream.packing = packing == "split" ? Packing::kSplit : Packing::kBundled;
  options.draco_compression_level = *cl;
  const bool json_out = args.Has("json");
  if (!json_out && isatty(STDERR_FILENO)) {
    options.progress = [](size_t primitive, int batch, size_t left) {
      std::fprintf(stderr, "\rencoding primitive %zu: refinement %d, %zu vertices left   ", primitive, batch, left);
      std::fflush(stderr);
    };
  }

  const std::string& in = args.positional[0];
  auto scene = ImportFile(in);
  if (!scene.ok()) return ReportError("encode", scene.status());
  for (const std::string& w : scene->warnings) std::fprintf(stderr, "meshstream encode: warning: %s: %s\n", in.c_str(), w.c_str());

  const auto start = std::chrono::steady_clock::now();
  ProgressiveGlbReport report;
  auto glb = EncodeProgressiveGlb(scene.value(), options, &report);
  const double encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (options.progress) std::fputs("\r\033[K", stderr);
  if (!glb.ok()) return ReportError("encode", glb.status().WithContext(in));
  const Status written = WriteFileBytes(out, glb.value());
  if (!written.ok()) return ReportError("encode", written);

  const PrimitiveStreamReport total = report.Total();
  const uint64_t vertices = total.vertices, faces = total.faces, base_bytes = total.base_bytes,
                 reliable = total.base_bytes + total.reliable_bytes, unreliable = total.unreliable_bytes,
                 datagrams = total.datagrams, removed = total.removed_faces;
  const std::vector<uint32_t>& level_vertices = total.level_vertices;
  const double v = vertices ? static_cast<double>(vertices) : 1.0;
  nlohmann::json j = {
      {"input", in},
      {"output", out},
      {"vertices", vertices},
      {"faces", faces},
      {"primitives", report.primitives.size()},
      {"levels", level_vertices.empty() ? 0 : level_vertices.size() - 1},
      {"level_vertices", level_vertices},
      {"base_vertices", level_vertices.empty() ? 0 : level_vertices.front()},
      {"base_bytes", base_bytes},
      {"reliable_bytes", reliable},
      {"unreliable_bytes", unreliable},
      {"datagrams", datagrams},
      {"total_bytes", reliable + unreliable},
      {"file_bytes", report.file_bytes},
      {"reliable_bpv", 8.0 * reliable / v},
      {"unreliable_bpv", 8.0 * unreliable / v},
      {"total_bpv", 8.0 * (reliable + unreliable) / v},
      {"removed_faces", removed},
      {"packing", packing},
      {"packet_bytes", options.stream.packet_bytes},
      {"qp", q.qp},
      {"encode_ms", encode_ms},
  };
  if (json_out) {
    std::puts(j.dump().c_str());
  } else {
    std::printf("%s -> %s: %llu vertices in %zu levels (base %u), %llu bytes (%.2f bits/vertex: %.2f reliable, %.2f in %llu datagrams), %.0f ms\n",
                in.c_str(), out.c_str(), static_cast<unsigned long long>(vertices),
                level_vertices.empty() ? 0 : level_vertices.size() - 1, level_vertices.empty() ? 0u : level_vertices.front(),
                static_cast<unsigned long long>(reliable + unreliable), 8.0 * (reliable + unreliable) / v,
                8.0 * reliable / v, 8.0 * unreliable / v, static_cast<unsigned long long>(datagrams), encode_ms);
  }
  return kExitOk;
}

}  // namespace meshstream::cli

// meshstream convert IN OUT [--draco] [--qp N] [--qn N] [--qt N] [--qc N] [--cl N]
#include <cstdio>

#include "cli/args.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "importers/gltf_export.h"
#include "importers/import.h"

namespace meshstream::cli {

namespace {

const char kHelp[] =
    "usage: meshstream convert IN OUT [--draco] [--qp N] [--qn N] [--qt N] [--qc N] [--cl N]\n"
    "\n"
    "Converts IN (.gltf .glb .obj .ply .off .stl) to OUT (.gltf or .glb, chosen by OUT's\n"
    "extension; a .gltf gets its binary data in a .bin beside it). Materials, textures,\n"
    "cameras and the node hierarchy of glTF inputs are kept.\n"
    "\n"
    "Options:\n"
    "  --draco    compress every primitive with KHR_draco_mesh_compression\n"
    "  --qp N     position quantization bits with --draco (default 11). Positions land on\n"
    "             the grid of `meshstream compare --qp N`, so the result is same_on_grid\n"
    "  --qn N     normal bits (default 8)       --qt N   texture coordinate bits (default 10)\n"
    "  --qc N     colour bits (default 8)       --cl N   Draco compression level 0-10 (default 7)\n"
    "  --quiet    print nothing on success\n";

}  // namespace

int RunConvert(const std::vector<std::string>& argv) {
  auto parsed = ParseArgs(argv, {{"draco", false}, {"qp", true}, {"qn", true}, {"qt", true}, {"qc", true},
                                 {"cl", true}, {"quiet", false}});
  if (!parsed.ok()) return ReportError("convert", parsed.status());
  const ParsedArgs& args = parsed.value();
  if (args.Has("help")) {
    std::fputs(kHelp, stdout);
    return kExitOk;
  }
  if (args.positional.size() != 2) return ReportError("convert", InvalidArgument("expected IN and OUT"));
  const std::string& in = args.positional[0];
  const std::string& out = args.positional[1];
  const std::string out_ext = FileExtension(out);
  if (out_ext != ".gltf" && out_ext != ".glb") {
    return ReportError("convert", InvalidArgument(out + ": OUT must end in .gltf or .glb"));
  }
  ExportOptions options;
  options.draco = args.Has("draco");
  DracoEncodeOptions& d = options.draco_options;
  auto qp = args.Int("qp", d.qp, 1, 30);
  auto qn = args.Int("qn", d.qn, 1, 30);
  auto qt = args.Int("qt", d.qt, 1, 30);
  auto qc = args.Int("qc", d.qc, 1, 30);
  auto cl = args.Int("cl", d.compression_level, 0, 10);
  for (const auto* v : {&qp, &qn, &qt, &qc, &cl}) {
    if (!v->ok()) return ReportError("convert", v->status());
  }
  if (!options.draco) {
    for (const char* flag : {"qp", "qn", "qt", "qc", "cl"}) {
      if (args.Has(flag)) {
        return ReportError("convert", InvalidArgument(std::string("--") + flag + " only applies with --draco"));
      }
    }
  }
  d.qp = *qp; d.qn = *qn; d.qt = *qt; d.qc = *qc; d.compression_level = *cl;

  auto scene = ImportFile(in);
  if (!scene.ok()) return ReportError("convert", scene.status());
  for (const std::string& w : scene->warnings) std::fprintf(stderr, "meshstream convert: warning: %s: %s\n", in.c_str(), w.c_str());
  const Status written = ExportGltfFile(scene.value(), out, options);
  if (!written.ok()) return ReportError("convert", written);
  if (!args.Has("quiet")) {
    std::printf("%s -> %s (%zu vertices, %zu faces%s)\n", in.c_str(), out.c_str(), scene->total_vertices(),
                scene->total_faces(), options.draco ? ", Draco" : "");
  }
  return kExitOk;
}

}  // namespace meshstream::cli

// meshstream convert IN OUT [--draco] [--qp N] [--qn N] [--qt N] [--qc N] [--cl N]
#include <cstdio>
#include <memory>

#include "cli/exit_codes.h"
#include "cli/json_out.h"
#include "cli/verbs.h"
#include "codec/mesh/quantization.h"
#include "importers/gltf_export.h"
#include "importers/import.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "IN is .gltf .glb .obj .ply .off .stl; OUT's extension chooses .gltf or .glb (a .gltf\n"
    "gets its binary data in a .bin beside it). Materials, textures, cameras and the node\n"
    "hierarchy of glTF inputs are kept. With --draco, positions land on the grid of\n"
    "`meshstream compare --qp N`, so the result is same_on_grid.\n"
    "\n"
    "Example:\n"
    "  meshstream convert --draco --qp 14 bunny.obj bunny.glb";

struct ConvertArgs {
  std::string in, out;
  ExportOptions options;
  bool quiet = false;
};

int RunConvert(ConvertArgs& args) {
  const std::string out_ext = FileExtension(args.out);
  if (out_ext != ".gltf" && out_ext != ".glb") {
    return ReportError("convert", InvalidArgument(args.out + ": OUT must end in .gltf or .glb"));
  }
  auto scene = ImportFile(args.in);
  if (!scene.ok()) return ReportError("convert", scene.status());
  const Status written = ExportGltfFile(scene.value(), args.out, args.options);
  if (!written.ok()) return ReportError("convert", written);  // one line: the warnings only on success
  for (const std::string& w : scene->warnings) {
    std::fprintf(stderr, "meshstream convert: warning: %s: %s\n", args.in.c_str(), w.c_str());
  }
  if (!args.quiet) {
    std::printf("%s -> %s (%zu vertices, %zu faces%s)\n", args.in.c_str(), args.out.c_str(), scene->total_vertices(),
                scene->total_faces(), args.options.draco ? ", Draco" : "");
  }
  return kExitOk;
}

}  // namespace

Verb AddConvert(CLI::App& root) {
  auto args = std::make_shared<ConvertArgs>();
  CLI::App* cmd = AddVerb(root, "convert", "Converts any supported mesh or scene to .gltf or .glb, optionally Draco-compressed.",
                          kDetails);
  cmd->add_option("IN", args->in, "the input file")->required();
  cmd->add_option("OUT", args->out, "the output file, .gltf or .glb")->required();
  DracoEncodeOptions& d = args->options.draco_options;
  CLI::Option* draco = cmd->add_flag("--draco", args->options.draco, "compress every primitive with KHR_draco_mesh_compression");
  const auto bits = CLI::Range(kMinQuantizationBits, kMaxQuantizationBits);
  cmd->add_option("--qp", d.qp, "position quantization bits")->check(bits)->needs(draco)->capture_default_str();
  cmd->add_option("--qn", d.qn, "normal bits")->check(bits)->needs(draco)->capture_default_str();
  cmd->add_option("--qt", d.qt, "texture coordinate bits")->check(bits)->needs(draco)->capture_default_str();
  cmd->add_option("--qc", d.qc, "colour bits")->check(bits)->needs(draco)->capture_default_str();
  cmd->add_option("--cl", d.compression_level, "Draco compression level")->check(CLI::Range(0, 10))->needs(draco)
      ->capture_default_str();
  cmd->add_flag("--quiet", args->quiet, "no summary line on success (warnings still go to stderr)");
  return {cmd, [args] { return RunConvert(*args); }};
}

}  // namespace meshstream::cli

// meshstream: the command-line tool of the meshstream asset pipeline.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cli/exit_codes.h"
#include "cli/verbs.h"

namespace {

const char kUsage[] =
    "usage: meshstream <verb> [options]\n"
    "\n"
    "Verbs:\n"
    "  info FILE [--json]                      what a mesh or scene file holds, and its health\n"
    "  convert IN OUT [--draco] [--qp N] ...   any supported input to .gltf or .glb\n"
    "  compare A B [--qp N] [--json]           distances between two meshes (Hausdorff, Laplacian)\n"
    "  encode IN -o OUT.glb [--qp N] ...       a progressive .glb (base mesh + refinements)\n"
    "  decode IN.glb -o OUT [--lod K] ...      a level of detail of a progressive .glb\n"
    "\n"
    "Inputs: .gltf .glb .obj .ply .off .stl. Outputs: .gltf .glb.\n"
    "Run 'meshstream <verb> --help' for the options of a verb.\n"
    "Exit status: 0 success, 1 bad input, 2 bad usage.\n";

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return meshstream::cli::kExitUsage;
  }
  const std::string verb = argv[1];
  const std::vector<std::string> args(argv + 2, argv + argc);
  if (verb == "--help" || verb == "-h" || verb == "help") {
    std::fputs(kUsage, stdout);
    return meshstream::cli::kExitOk;
  }
  if (verb == "--version") {
    std::puts("meshstream 0.1.0");
    return meshstream::cli::kExitOk;
  }
  if (verb == "info") return meshstream::cli::RunInfo(args);
  if (verb == "convert") return meshstream::cli::RunConvert(args);
  if (verb == "compare") return meshstream::cli::RunCompare(args);
  if (verb == "encode") return meshstream::cli::RunEncode(args);
  if (verb == "decode") return meshstream::cli::RunDecode(args);
  std::fprintf(stderr, "meshstream: unknown verb '%s'\n\n%s", verb.c_str(), kUsage);
  return meshstream::cli::kExitUsage;
}

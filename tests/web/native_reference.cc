// The native side of the wasm-against-native test (tests/web): decodes a
// progressive .glb with DecodeProgressiveGlb, the native decoder, and prints
// one line per refined primitive, in stream order:
//   <stream id> <vertices> <indices> <PrimitiveHash, 16 hex digits>
// usage: meshstream_wasm_reference FILE.glb [--loss P] [--burst B] [--seed S] [--lod K]
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "codec/mesh/mesh.h"
#include "importers/progressive_glb.h"

int main(int argc, char** argv) {
  using namespace meshstream;
  if (argc < 2) {
    std::fprintf(stderr, "usage: meshstream_wasm_reference FILE.glb [--loss P] [--burst B] [--seed S] [--lod K]\n");
    return 2;
  }
  ProgressiveDecodeOptions options;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--loss") options.loss.loss = std::atof(argv[i + 1]);
    else if (flag == "--burst") options.loss.burst = std::atof(argv[i + 1]);
    else if (flag == "--seed") options.loss.seed = std::strtoull(argv[i + 1], nullptr, 10);
    else if (flag == "--lod") options.lod = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "meshstream_wasm_reference: unknown option %s\n", argv[i]);
      return 2;
    }
  }
  std::ifstream in(argv[1], std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "meshstream_wasm_reference: cannot read %s\n", argv[1]);
    return 1;
  }
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ProgressiveDecodeReport report;
  auto scene = DecodeProgressiveGlb(bytes, options, &report);
  if (!scene.ok()) {
    std::fprintf(stderr, "meshstream_wasm_reference: %s\n", scene.status().ToString().c_str());
    return 1;
  }
  // The refined primitives in stream order: meshes in order, each mesh's
  // primitives in file order, carried ones skipped.
  uint32_t stream_id = 0;
  for (const Mesh& mesh : scene->meshes) {
    for (const Mesh::Ref& ref : mesh.Order()) {
      if (ref.carried) continue;
      const Primitive& p = mesh.primitives[ref.index];
      std::printf("%u %zu %zu %016llx\n", stream_id++, p.positions.size(), p.indices.size(),
                  static_cast<unsigned long long>(PrimitiveHash(p)));
    }
  }
  return 0;
}

// The native side of the wasm-against-native test (tests/web): decodes a
// progressive .glb with DecodeProgressiveGlb, the native decoder, and prints
// one line per refined primitive, in stream order:
//   <stream id> <vertices> <indices> <PrimitiveHash, 16 hex digits>
// With --repeat N it decodes N times and prints, after those lines, the
// median decode time: "time_ms <median>" (make bench-web compares it with
// the wasm decoder's, docs/results/web-benchmarks.md).
// usage: meshstream_wasm_reference FILE.glb [--loss P] [--burst B] [--seed S] [--lod K] [--repeat N] [--profile auto|reliable|loss-tolerant]
#include <algorithm>
#include <chrono>
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
    std::fprintf(stderr,
                 "usage: meshstream_wasm_reference FILE.glb [--loss P] [--burst B] [--seed S] [--lod K] [--repeat N] [--profile auto|reliable|loss-tolerant]\n");
    return 2;
  }
  ProgressiveDecodeOptions options;
  int repeat = 1;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--loss") options.loss.loss = std::atof(argv[i + 1]);
    else if (flag == "--burst") options.loss.burst = std::atof(argv[i + 1]);
    else if (flag == "--seed") options.loss.seed = std::strtoull(argv[i + 1], nullptr, 10);
    else if (flag == "--lod") options.lod = std::atoi(argv[i + 1]);
    else if (flag == "--repeat") repeat = std::max(1, std::atoi(argv[i + 1]));
    else if (flag == "--profile") {
      const std::string p = argv[i + 1];
      options.profile = p == "reliable"        ? DecodeProfile::kReliable
                        : p == "loss-tolerant" ? DecodeProfile::kLossTolerant
                                               : DecodeProfile::kAuto;
    }
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
  std::vector<double> ms;
  auto scene = DecodeProgressiveGlb(bytes, options, &report);
  for (int r = 0; repeat > 1 && r < repeat && scene.ok(); ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    scene = DecodeProgressiveGlb(bytes, options, &report);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
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
  if (repeat > 1) {
    std::sort(ms.begin(), ms.end());
    std::printf("time_ms %.3f\n", ms[ms.size() / 2]);
  }
  return 0;
}

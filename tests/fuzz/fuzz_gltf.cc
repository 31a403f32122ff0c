// libFuzzer target for the glTF/GLB importer (docs/design/design.md, "Hostile input"
// gets a clear error, never a crash).
//
// Every input goes through ImportGltfBytes with no base folder, so no URI can
// open a file. When the import succeeds, the scene is exported as GLB, plain
// and with Draco, and the export is imported again: a scene we accepted must
// survive the round trip. The plain round trip keeps every triangle; the Draco
// one may only drop triangles that repeat a vertex.
//
// Export may refuse a scene it documents as unwritable (a mesh with no
// triangle left, a Draco primitive whose every triangle repeats a vertex);
// that is an error, not a bug. An Internal error, a failed re-import or a
// changed triangle count is a bug and stops the fuzzer (__builtin_trap).
//
// Built as a real libFuzzer binary with MESHSTREAM_FUZZ=ON (make fuzz), and
// always as fuzz_gltf_replay, which replays corpus/gltf/ under ctest.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"
#include "importers/gltf_export.h"
#include "importers/gltf_import.h"
#include "importers/import.h"

namespace {

using meshstream::Scene;
using meshstream::Status;
using meshstream::StatusCode;

constexpr uint64_t kMaxInputBytes = uint64_t{8} << 20;  // 8 MiB

meshstream::ImportOptions Options() {
  meshstream::ImportOptions options;
  options.max_input_bytes = kMaxInputBytes;
  return options;
}

[[noreturn]] void Bug(const char* what, const Status& status) {
  std::fprintf(stderr, "fuzz_gltf: %s: %s\n", what, status.ToString().c_str());
  __builtin_trap();
}

void RoundTrip(const Scene& scene, bool draco) {
  meshstream::ExportOptions export_options;
  export_options.draco = draco;
  auto glb = meshstream::ExportGlb(scene, export_options);
  if (!glb.ok()) {
    if (glb.status().code() == StatusCode::kInternal) {
      Bug(draco ? "Draco export failed internally" : "export failed internally", glb.status());
    }
    return;  // a documented refusal
  }
  auto again = meshstream::ImportGltfBytes(glb.value(), /*base_dir=*/"", "roundtrip.glb", Options());
  if (!again.ok()) Bug(draco ? "re-import of the Draco export failed" : "re-import of the export failed", again.status());
  const size_t before = scene.total_faces();
  const size_t after = again->total_faces();
  if (draco ? after > before : after != before) {
    Bug(draco ? "the Draco round trip added triangles" : "the plain round trip changed the triangle count",
        meshstream::Internal(std::to_string(before) + " triangles became " + std::to_string(after)));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > kMaxInputBytes) return 0;
  const std::vector<uint8_t> bytes(data, data + size);
  auto scene = meshstream::ImportGltfBytes(bytes, /*base_dir=*/"", "fuzz", Options());
  if (!scene.ok()) {
    if (scene.status().message().empty()) Bug("an error without a message", scene.status());
    return 0;
  }
  RoundTrip(scene.value(), /*draco=*/false);
  RoundTrip(scene.value(), /*draco=*/true);
  return 0;
}

// Shared body of the file-based mesh fuzz targets (fuzz_obj, fuzz_ply,
// fuzz_off, fuzz_stl): the readers behind ImportFile take a path (OpenMesh's
// OFF reader only reads by name), so each input is written to a temporary
// file with the format's extension, imported through the public ImportFile,
// and removed again.
//
// The file lives under /dev/shm when it exists (else TMPDIR, else /tmp) and
// its name holds the process id, so parallel fuzzers (-jobs, -workers) never
// share one. When the import succeeds, the scene must satisfy what the
// importer promises: ValidateScene passes, one mesh with one primitive whose
// indices are in range and a multiple of three, at least one triangle,
// attribute arrays empty or one per vertex, source_vertices no more than the
// vertex count, every name and warning valid UTF-8, and the scene exports as
// GLB. An Internal error, or an error without a message, is a bug: the
// fuzzer stops (__builtin_trap).
#ifndef MESHSTREAM_TESTS_FUZZ_MESH_FILE_FUZZ_H_
#define MESHSTREAM_TESTS_FUZZ_MESH_FILE_FUZZ_H_

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "codec/core/status.h"
#include "codec/core/utf8.h"
#include "codec/mesh/mesh.h"
#include "importers/gltf_export.h"
#include "importers/import.h"

namespace meshstream_fuzz {

constexpr uint64_t kMaxInputBytes = uint64_t{8} << 20;  // 8 MiB

[[noreturn]] inline void Bug(const char* target, const std::string& what) {
  std::fprintf(stderr, "%s: %s\n", target, what.c_str());
  __builtin_trap();
}

inline std::string TempFolder() {
  if (access("/dev/shm", W_OK) == 0) return "/dev/shm";
  const char* tmp = std::getenv("TMPDIR");
  return tmp != nullptr && *tmp != '\0' ? tmp : "/tmp";
}

inline void CheckScene(const char* target, const meshstream::Scene& scene) {
  const meshstream::Status valid = meshstream::ValidateScene(scene);
  if (!valid.ok()) Bug(target, "an accepted scene is invalid: " + valid.ToString());
  if (scene.meshes.size() != 1 || scene.meshes[0].primitives.size() != 1 || scene.nodes.size() != 1) {
    Bug(target, "a mesh file must give one mesh of one primitive on one node");
  }
  const meshstream::Primitive& p = scene.meshes[0].primitives[0];
  const size_t n = p.positions.size();
  if (p.indices.empty() || p.indices.size() % 3 != 0) Bug(target, "index count is not a positive multiple of 3");
  for (uint32_t i : p.indices) {
    if (i >= n) Bug(target, "index " + std::to_string(i) + " out of range (" + std::to_string(n) + " vertices)");
  }
  if (!p.normals.empty() && p.normals.size() != n) Bug(target, "normal count differs from vertex count");
  if (!p.colors.empty() && p.colors.size() != n) Bug(target, "colour count differs from vertex count");
  for (const auto& uv : p.texcoords) {
    if (uv.size() != n) Bug(target, "texcoord count differs from vertex count");
  }
  if (scene.source_vertices > n) Bug(target, "source_vertices above the vertex count");
  if (!meshstream::IsValidUtf8(scene.meshes[0].name) || !meshstream::IsValidUtf8(scene.nodes[0].name)) {
    Bug(target, "a name is not valid UTF-8");
  }
  for (const std::string& w : scene.warnings) {
    if (!meshstream::IsValidUtf8(w)) Bug(target, "a warning is not valid UTF-8");
  }
  auto glb = meshstream::ExportGlb(scene, meshstream::ExportOptions{});
  if (!glb.ok() && glb.status().code() == meshstream::StatusCode::kInternal) {
    Bug(target, "export failed internally: " + glb.status().ToString());
  }
}

// Writes `data` to a per-process temporary file ending in `extension`,
// imports it and checks the result.
inline int RunMeshFile(const char* target, const char* extension, const uint8_t* data, size_t size) {
  if (size > kMaxInputBytes) return 0;
  static const std::string path =
      TempFolder() + "/meshstream_" + target + "_" + std::to_string(getpid()) + extension;
  {
    FILE* file = std::fopen(path.c_str(), "wb");
    if (file == nullptr) Bug(target, "cannot create " + path);
    if (size > 0 && std::fwrite(data, 1, size, file) != size) Bug(target, "cannot write " + path);
    std::fclose(file);
  }
  meshstream::ImportOptions options;
  options.max_input_bytes = kMaxInputBytes;
  auto scene = meshstream::ImportFile(path, options);
  std::remove(path.c_str());
  if (!scene.ok()) {
    if (scene.status().message().empty()) Bug(target, "an error without a message");
    if (scene.status().code() == meshstream::StatusCode::kInternal) {
      Bug(target, "internal error: " + scene.status().ToString());
    }
    return 0;
  }
  CheckScene(target, scene.value());
  return 0;
}

}  // namespace meshstream_fuzz

#endif  // MESHSTREAM_TESTS_FUZZ_MESH_FILE_FUZZ_H_

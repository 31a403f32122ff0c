// libFuzzer target for the progressive container (docs/design/design.md, "Hostile input" and "glTF container"):
// DecodeProgressiveGlb on arbitrary bytes returns a scene or an error with a
// message, and never crashes, hangs or allocates without bound.
//
// When the full decode succeeds, every triangle must refer to existing
// vertices, and decoding the same bytes to level 0 and to level 1 must
// succeed too (a prefix of a stream that decodes whole decodes), with
// levels_applied and the level's vertex count as the report says: the
// primitives carrying our extension have level_vertices[K] vertices between
// them. The decode on two threads (a ForkJoinPool as the decode's TaskRunner,
// codec/progressive/parallel_refinement.h) must end the same way: the same
// error, or the same scene bit for bit. Where the file holds the reliable
// profile (format version 4), its loss-tolerant stream is decoded too
// (DecodeProfile::kLossTolerant): a scene of valid triangles, or an error
// with a message (a file of one profile has no other). Anything else stops
// the fuzzer (__builtin_trap).
//
// Built as a real libFuzzer binary with MESHSTREAM_FUZZ=ON (make fuzz), and
// always as fuzz_progressive_glb_replay, which replays
// corpus/progressive_glb/ under ctest. Seeds: make_progressive_corpus.py.
#include <algorithm>
#include <cstring>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"
#include "importers/progressive_glb.h"
#include "parallel/fork_join_pool.h"

namespace {

using meshstream::ProgressiveDecodeOptions;
using meshstream::ProgressiveDecodeReport;
using meshstream::Scene;

constexpr size_t kMaxInputBytes = size_t{4} << 20;

[[noreturn]] void Bug(const std::string& what) {
  std::fprintf(stderr, "fuzz_progressive_glb: %s\n", what.c_str());
  __builtin_trap();
}

uint64_t CheckScene(const Scene& scene) {
  uint64_t vertices = 0;
  for (const meshstream::Mesh& m : scene.meshes)
    for (const meshstream::Primitive& p : m.primitives) {
      if (p.indices.size() % 3 != 0) Bug("indices are not triangles");
      for (uint32_t i : p.indices)
        if (i >= p.vertex_count()) Bug("a triangle refers to a missing vertex");
      vertices += p.vertex_count();
    }
  return vertices;
}

template <class T>
bool SameBits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

bool SameScene(const Scene& a, const Scene& b) {
  if (a.meshes.size() != b.meshes.size()) return false;
  for (size_t m = 0; m < a.meshes.size(); ++m) {
    if (a.meshes[m].primitives.size() != b.meshes[m].primitives.size()) return false;
    for (size_t k = 0; k < a.meshes[m].primitives.size(); ++k) {
      const meshstream::Primitive& p = a.meshes[m].primitives[k];
      const meshstream::Primitive& q = b.meshes[m].primitives[k];
      if (!SameBits(p.positions, q.positions) || !SameBits(p.normals, q.normals) || !SameBits(p.colors, q.colors) ||
          !SameBits(p.indices, q.indices) || p.texcoords.size() != q.texcoords.size()) {
        return false;
      }
      for (size_t t = 0; t < p.texcoords.size(); ++t)
        if (!SameBits(p.texcoords[t], q.texcoords[t])) return false;
    }
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > kMaxInputBytes) return 0;
  const std::vector<uint8_t> bytes(data, data + size);
  ProgressiveDecodeReport full_report;
  auto full = meshstream::DecodeProgressiveGlb(bytes, ProgressiveDecodeOptions{}, &full_report);
  {
    static meshstream::ForkJoinPool pool(2);
    ProgressiveDecodeOptions threaded;
    threaded.runner = &pool;
    auto parallel = meshstream::DecodeProgressiveGlb(bytes, threaded, nullptr);
    if (parallel.ok() != full.ok()) Bug("the decode on two threads ends otherwise than on one");
    if (!full.ok() && parallel.status().ToString() != full.status().ToString()) {
      Bug("the decode on two threads fails otherwise: " + parallel.status().ToString() + " against " +
          full.status().ToString());
    }
    if (full.ok() && !SameScene(parallel.value(), full.value())) Bug("the decode on two threads differs");
  }
  if (full.ok() && full_report.reliable_profile_streams > 0) {
    ProgressiveDecodeOptions other;
    other.profile = meshstream::DecodeProfile::kLossTolerant;
    auto loss_tolerant = meshstream::DecodeProgressiveGlb(bytes, other, nullptr);
    if (loss_tolerant.ok()) {
      CheckScene(loss_tolerant.value());
    } else if (loss_tolerant.status().message().empty()) {
      Bug("an error without a message (the loss-tolerant profile)");
    }
  }
  if (!full.ok()) {
    if (full.status().message().empty()) Bug("an error without a message");
    return 0;
  }
  const uint64_t full_vertices = CheckScene(full.value());
  if (full_report.levels_applied != full_report.levels) Bug("the full decode did not apply every level");
  // Empty when no primitive carries our extension.
  if (full_report.levels > 0 ? full_report.level_vertices.size() != full_report.levels + 1
                             : full_report.level_vertices.size() > 1) {
    Bug("level_vertices does not have levels + 1 entries");
  }
  // Vertices of primitives without our extension, which every level keeps.
  const uint64_t extension_full = full_report.level_vertices.empty() ? 0 : full_report.level_vertices.back();
  // level_vertices are the streams' lossless counts; a stream whose data is
  // damaged (bit flips the datagrams do not detect) may leave vertices
  // absent, which only a decode that predicted something can.
  if (full_report.predicted_vertices > 0) return 0;
  if (extension_full > full_vertices) Bug("the report counts more vertices than the scene has");
  const uint64_t others = full_vertices - extension_full;
  for (int lod : {0, 1}) {
    if (static_cast<uint64_t>(lod) > full_report.levels) break;
    ProgressiveDecodeOptions options;
    options.lod = lod;
    ProgressiveDecodeReport report;
    auto partial = meshstream::DecodeProgressiveGlb(bytes, options, &report);
    if (!partial.ok()) Bug("level " + std::to_string(lod) + " fails where the full decode works: " + partial.status().ToString());
    if (report.levels_applied != static_cast<uint64_t>(lod)) Bug("levels_applied is not the requested level");
    const uint64_t expected = others + (report.level_vertices.empty() ? 0 : report.level_vertices[lod]);
    const uint64_t got = CheckScene(partial.value());
    if (report.predicted_vertices == 0 && got != expected) Bug("level " + std::to_string(lod) + " has " + std::to_string(got) + " vertices, expected " +
                             std::to_string(expected));
  }
  return 0;
}

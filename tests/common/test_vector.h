// The test vector of docs/spec/progressive-format.md ("Test vector"): the
// octahedron subdivided once (tests/data/vector/octahedron.obj) encoded with
// fixed options, its .glb and stream blob stored beside it
// (tests/data/vector/regenerate.sh writes them with the CLI). The tests
// re-encode it with these options and compare bytes, and patch its fields to
// check that the decoder refuses what the spec does not define.
#ifndef MESHSTREAM_TESTS_COMMON_TEST_VECTOR_H_
#define MESHSTREAM_TESTS_COMMON_TEST_VECTOR_H_

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "codec/bitstream/format.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

inline std::string VectorPath(const std::string& name) { return SourcePath("tests/data/vector/" + name); }

// The options of regenerate.sh: --qp 8 --levels 1 --profile loss-tolerant
// --packing bundled --packet-bytes 1200 --cl 7 (octahedron-qp8-bundled);
// ReliableVectorOptions: --profile reliable (octahedron-qp8-reliable).
inline ProgressiveGlbOptions VectorOptions() {
  ProgressiveGlbOptions o;
  o.profiles = ProfileSet::kLossTolerant;
  o.encode.quantization.qp = 8;
  o.encode.simplify.max_levels = 1;
  o.stream.packing = Packing::kBundled;
  o.stream.packet_bytes = 1200;
  o.draco_compression_level = 7;
  return o;
}

inline ProgressiveGlbOptions ReliableVectorOptions() {
  ProgressiveGlbOptions o = VectorOptions();
  o.profiles = ProfileSet::kReliable;
  return o;
}

inline std::vector<uint8_t> ReadBytes(const std::string& path) {
  const std::string text = ReadText(path);
  return std::vector<uint8_t>(text.begin(), text.end());
}

inline uint32_t GlbU32(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

// The JSON chunk of a .glb, and the binary chunk's offset in the file.
inline nlohmann::json GlbJson(const std::vector<uint8_t>& glb) {
  const uint32_t length = GlbU32(glb, 12);
  return nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + length);
}

// The stream blob of the first primitive (its MESHSTREAM_progressive bufferView).
inline std::vector<uint8_t> BlobOf(const std::vector<uint8_t>& glb) {
  const nlohmann::json doc = GlbJson(glb);
  const size_t view = doc["meshes"][0]["primitives"][0]["extensions"][kProgressiveExtension]["bufferView"];
  const size_t bin = 20 + GlbU32(glb, 12) + 8;
  const size_t offset = bin + doc["bufferViews"][view].value("byteOffset", size_t{0});
  const size_t length = doc["bufferViews"][view]["byteLength"];
  return std::vector<uint8_t>(glb.begin() + offset, glb.begin() + offset + length);
}

// The .glb with its JSON chunk replaced (padded with spaces), binary chunk kept.
inline std::vector<uint8_t> WithGlbJson(const std::vector<uint8_t>& glb, const nlohmann::json& doc) {
  const uint32_t old_length = GlbU32(glb, 12);
  std::string text = doc.dump();
  while (text.size() % 4) text.push_back(' ');
  std::vector<uint8_t> out(glb.begin(), glb.begin() + 12);
  auto u32 = [&out](uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
  };
  u32(static_cast<uint32_t>(text.size()));
  u32(0x4E4F534A);  // "JSON"
  out.insert(out.end(), text.begin(), text.end());
  out.insert(out.end(), glb.begin() + 20 + old_length, glb.end());
  const uint32_t total = static_cast<uint32_t>(out.size());
  std::memcpy(out.data() + 8, &total, 4);
  return out;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_TEST_VECTOR_H_

// Hostile glTF/GLB input (docs/design/design.md, "Hostile input"): every malformed, lying or
// escaping document gets the expected StatusCode and a message that names the
// problem; nothing crashes, nothing outside the asset's folder is opened. The
// good side too: strips, fans, sparse accessors, KHR_mesh_quantization,
// data: URIs and optional extensions give exactly the expected scene.
// Every document is built here with nlohmann::json, so the answers are known.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"
#include "importers/gltf_export.h"
#include "importers/gltf_import.h"
#include "importers/import.h"

namespace meshstream {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

constexpr int kByte = 5120;
constexpr int kUnsignedByte = 5121;
constexpr int kShort = 5122;
constexpr int kUnsignedShort = 5123;
constexpr int kUnsignedInt = 5125;
constexpr int kFloat = 5126;

// ---------------------------------------------------------------------------
// Helpers: base64, GLB packing, a small document builder.

std::string Base64(const std::vector<uint8_t>& bytes) {
  static const char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (uint32_t(bytes[i]) << 16) | (uint32_t(bytes[i + 1]) << 8) | bytes[i + 2];
    for (int s = 18; s >= 0; s -= 6) out.push_back(kAlphabet[(v >> s) & 63]);
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = uint32_t(bytes[i]) << 16;
    out += {kAlphabet[(v >> 18) & 63], kAlphabet[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = (uint32_t(bytes[i]) << 16) | (uint32_t(bytes[i + 1]) << 8);
    out += {kAlphabet[(v >> 18) & 63], kAlphabet[(v >> 12) & 63], kAlphabet[(v >> 6) & 63], '='};
  }
  return out;
}

std::string DataUri(const std::vector<uint8_t>& bytes) {
  return "data:application/octet-stream;base64," + Base64(bytes);
}

void PutU32(std::vector<uint8_t>& out, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) out[at + i] = static_cast<uint8_t>(v >> (8 * i));
}

void AppendU32(std::vector<uint8_t>& out, uint32_t v) {
  out.resize(out.size() + 4);
  PutU32(out, out.size() - 4, v);
}

// A well-formed GLB: JSON padded with spaces, BIN (if any) padded with zeros.
struct PackedGlb {
  std::vector<uint8_t> bytes;
  size_t json_chunk = 12;  // offset of the JSON chunk header
  size_t bin_chunk = 0;    // offset of the BIN chunk header (0: none)
};

PackedGlb PackGlb(std::string text, const std::vector<uint8_t>& bin) {
  while (text.size() % 4) text.push_back(' ');
  PackedGlb glb;
  std::vector<uint8_t>& out = glb.bytes;
  AppendU32(out, 0x46546C67);  // "glTF"
  AppendU32(out, 2);
  AppendU32(out, 0);  // total length, patched below
  AppendU32(out, static_cast<uint32_t>(text.size()));
  AppendU32(out, 0x4E4F534A);  // "JSON"
  out.insert(out.end(), text.begin(), text.end());
  if (!bin.empty()) {
    glb.bin_chunk = out.size();
    const size_t padded = (bin.size() + 3) & ~size_t{3};
    AppendU32(out, static_cast<uint32_t>(padded));
    AppendU32(out, 0x004E4942);  // "BIN\0"
    out.insert(out.end(), bin.begin(), bin.end());
    out.resize(out.size() + (padded - bin.size()), 0);
  }
  PutU32(out, 8, static_cast<uint32_t>(out.size()));
  return glb;
}

std::vector<uint8_t> Bytes(const std::string& s) { return std::vector<uint8_t>(s.begin(), s.end()); }

template <typename T>
std::vector<uint8_t> RawBytes(const std::vector<T>& values) {
  std::vector<uint8_t> out(values.size() * sizeof(T));
  if (!values.empty()) std::memcpy(out.data(), values.data(), out.size());
  return out;
}

// A glTF document with one buffer (`bin`), one mesh, one node, one scene.
class Doc {
 public:
  Doc() {
    doc_ = {{"asset", {{"version", "2.0"}}},
            {"scene", 0},
            {"scenes", json::array({{{"nodes", json::array({0})}}})},
            {"nodes", json::array({{{"mesh", 0}}})},
            {"meshes", json::array({{{"primitives", json::array()}}})},
            {"bufferViews", json::array()},
            {"accessors", json::array()}};
  }

  // Appends bytes (4-aligned) as a new bufferView; returns its index.
  int View(const std::vector<uint8_t>& bytes, int stride = 0) {
    while (bin_.size() % 4) bin_.push_back(0);
    json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", bytes.size()}};
    if (stride) view["byteStride"] = stride;
    bin_.insert(bin_.end(), bytes.begin(), bytes.end());
    doc_["bufferViews"].push_back(view);
    return static_cast<int>(doc_["bufferViews"].size()) - 1;
  }

  int Accessor(json accessor) {
    doc_["accessors"].push_back(std::move(accessor));
    return static_cast<int>(doc_["accessors"].size()) - 1;
  }

  int Floats(const std::vector<float>& values, const char* type, int components) {
    const int view = View(RawBytes(values));
    return Accessor({{"bufferView", view}, {"componentType", kFloat},
                     {"count", values.size() / components}, {"type", type}});
  }
  int Positions(const std::vector<float>& xyz) { return Floats(xyz, "VEC3", 3); }

  int Indices16(const std::vector<uint16_t>& indices) {
    const int view = View(RawBytes(indices));
    return Accessor({{"bufferView", view}, {"componentType", kUnsignedShort},
                     {"count", indices.size()}, {"type", "SCALAR"}});
  }

  void Primitive(json prim) { doc_["meshes"][0]["primitives"].push_back(std::move(prim)); }

  // The standard case: one triangle, positions accessor 0, indices accessor 1.
  static Doc Triangle() {
    Doc d;
    const int pos = d.Positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const int idx = d.Indices16({0, 1, 2});
    d.Primitive({{"attributes", {{"POSITION", pos}}}, {"indices", idx}});
    return d;
  }

  json& doc() { return doc_; }
  std::vector<uint8_t>& bin() { return bin_; }

  // The document with the buffer as a data: URI.
  json WithDataUri() const {
    json d = doc_;
    if (!bin_.empty()) d["buffers"] = json::array({{{"byteLength", bin_.size()}, {"uri", DataUri(bin_)}}});
    return d;
  }
  std::vector<uint8_t> Gltf() const { return Bytes(WithDataUri().dump()); }

  // The document with the buffer in the GLB BIN chunk.
  PackedGlb Glb() const {
    json d = doc_;
    if (!bin_.empty()) d["buffers"] = json::array({{{"byteLength", bin_.size()}}});
    return PackGlb(d.dump(), bin_);
  }

 private:
  json doc_;
  std::vector<uint8_t> bin_;
};

StatusOr<Scene> Import(const std::vector<uint8_t>& bytes) {
  return ImportGltfBytes(bytes, /*base_dir=*/"", "test.gltf", ImportOptions{});
}
StatusOr<Scene> Import(const json& doc) { return Import(Bytes(doc.dump())); }

// The import failed with `code` and a message containing every word.
::testing::AssertionResult Fails(const StatusOr<Scene>& result, StatusCode code,
                                 std::initializer_list<const char*> words) {
  if (result.ok()) return ::testing::AssertionFailure() << "the import succeeded";
  const Status& s = result.status();
  if (s.code() != code) {
    return ::testing::AssertionFailure() << "code " << StatusCodeName(s.code()) << " instead of "
                                         << StatusCodeName(code) << ": " << s.message();
  }
  for (const char* w : words) {
    if (s.message().find(w) == std::string::npos) {
      return ::testing::AssertionFailure() << "message lacks '" << w << "': " << s.message();
    }
  }
  return ::testing::AssertionSuccess() << s.message();
}

const Primitive& OnlyPrimitive(const Scene& scene) {
  return scene.meshes.at(0).primitives.at(0);
}

// ---------------------------------------------------------------------------
// GLB framing.

TEST(GltfHostileGlb, WellFormedGlbImports) {
  const PackedGlb glb = Doc::Triangle().Glb();
  auto scene = Import(glb.bytes);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(OnlyPrimitive(*scene).indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST(GltfHostileGlb, TruncatedAtManyOffsetsIsRefused) {
  const PackedGlb glb = Doc::Triangle().Glb();
  ASSERT_GT(glb.bin_chunk, 0u);
  const size_t json_size = glb.bin_chunk - 20;
  const std::vector<size_t> cuts = {
      4, 8, 12, 19,                                    // inside the header
      20, 20 + json_size / 2, glb.bin_chunk - 1,       // inside the JSON chunk
      glb.bin_chunk + 4,                               // inside the BIN chunk header
      glb.bin_chunk + 8 + 5, glb.bytes.size() - 1};    // inside the BIN chunk
  for (size_t cut : cuts) {
    SCOPED_TRACE("cut at " + std::to_string(cut));
    std::vector<uint8_t> bytes(glb.bytes.begin(), glb.bytes.begin() + cut);
    EXPECT_TRUE(Fails(Import(bytes), StatusCode::kInvalidInput, {"GLB"}));
  }
  EXPECT_TRUE(Fails(Import(std::vector<uint8_t>(glb.bytes.begin(), glb.bytes.begin() + 10)),
                    StatusCode::kInvalidInput, {"GLB", "too short"}));
  EXPECT_TRUE(Fails(Import(std::vector<uint8_t>(glb.bytes.begin(), glb.bytes.end() - 1)),
                    StatusCode::kInvalidInput, {"GLB", "larger than the file"}));
}

TEST(GltfHostileGlb, LyingTotalLength) {
  PackedGlb glb = Doc::Triangle().Glb();
  std::vector<uint8_t> longer = glb.bytes;
  PutU32(longer, 8, static_cast<uint32_t>(longer.size() + 100));
  EXPECT_TRUE(Fails(Import(longer), StatusCode::kInvalidInput, {"GLB", "header length"}));

  std::vector<uint8_t> huge = glb.bytes;
  PutU32(huge, 8, 0xFFFFFFF0u);
  EXPECT_TRUE(Fails(Import(huge), StatusCode::kInvalidInput, {"GLB", "4294967280"}));

  std::vector<uint8_t> tiny = glb.bytes;
  PutU32(tiny, 8, 16);
  EXPECT_TRUE(Fails(Import(tiny), StatusCode::kInvalidInput, {"GLB", "too small"}));

  // A total length that ends right after the JSON chunk hides the BIN chunk
  // the buffer needs.
  std::vector<uint8_t> short_total = glb.bytes;
  PutU32(short_total, 8, static_cast<uint32_t>(glb.bin_chunk));
  EXPECT_TRUE(Fails(Import(short_total), StatusCode::kInvalidInput, {"buffers[0]", "BIN chunk"}));

  // A total length that cuts the BIN chunk in the middle.
  std::vector<uint8_t> mid_bin = glb.bytes;
  PutU32(mid_bin, 8, static_cast<uint32_t>(glb.bin_chunk + 12));
  EXPECT_TRUE(Fails(Import(mid_bin), StatusCode::kInvalidInput, {"GLB", "chunk 1"}));
}

TEST(GltfHostileGlb, LyingJsonChunkLength) {
  const PackedGlb glb = Doc::Triangle().Glb();
  for (uint32_t lie : {0xFFFFFFF0u, 0xFFFFFFFFu, static_cast<uint32_t>(glb.bytes.size())}) {
    SCOPED_TRACE(lie);
    std::vector<uint8_t> bytes = glb.bytes;
    PutU32(bytes, 12, lie);
    EXPECT_TRUE(Fails(Import(bytes), StatusCode::kInvalidInput, {"GLB", "chunk 0", std::to_string(lie).c_str()}));
  }
  std::vector<uint8_t> empty_json = glb.bytes;
  PutU32(empty_json, 12, 0);
  EXPECT_TRUE(Fails(Import(empty_json), StatusCode::kInvalidInput, {"GLB"}));
  std::vector<uint8_t> not_json = glb.bytes;
  PutU32(not_json, 16, 0x12345678);
  EXPECT_TRUE(Fails(Import(not_json), StatusCode::kInvalidInput, {"GLB", "not JSON"}));
}

TEST(GltfHostileGlb, LyingBinChunkLength) {
  const PackedGlb glb = Doc::Triangle().Glb();
  const size_t bin_body = glb.bytes.size() - glb.bin_chunk - 8;
  // 0xFFFFFFF0 would overflow a 32-bit "offset + length"; 8 more bytes than
  // present is what a check that forgets the chunk header would let through.
  for (uint32_t lie : {0xFFFFFFF0u, 0xFFFFFFFFu, static_cast<uint32_t>(bin_body + 8),
                       static_cast<uint32_t>(bin_body + 4)}) {
    SCOPED_TRACE(lie);
    std::vector<uint8_t> bytes = glb.bytes;
    PutU32(bytes, glb.bin_chunk, lie);
    EXPECT_TRUE(Fails(Import(bytes), StatusCode::kInvalidInput, {"GLB", "chunk 1", std::to_string(lie).c_str()}));
  }
}

TEST(GltfHostileGlb, VersionOneIsUnsupported) {
  std::vector<uint8_t> bytes = Doc::Triangle().Glb().bytes;
  PutU32(bytes, 4, 1);
  EXPECT_TRUE(Fails(Import(bytes), StatusCode::kUnsupported, {"GLB", "version 1"}));
}

TEST(GltfHostileGlb, UnpaddedJsonChunkBeforeBinIsRefused) {
  // The JSON chunk's length is not a multiple of 4 and a BIN chunk follows:
  // where the BIN chunk starts is ambiguous, so the file is refused rather
  // than read one way by the validation and another way by the parser.
  Doc d = Doc::Triangle();
  json doc = d.doc();
  doc["buffers"] = json::array({{{"byteLength", d.bin().size()}}});
  std::string text = doc.dump();
  while (text.size() % 4 != 1) text.push_back(' ');
  std::vector<uint8_t> out;
  AppendU32(out, 0x46546C67);
  AppendU32(out, 2);
  AppendU32(out, 0);
  AppendU32(out, static_cast<uint32_t>(text.size()));
  AppendU32(out, 0x4E4F534A);
  out.insert(out.end(), text.begin(), text.end());
  out.resize(out.size() + 3, ' ');
  AppendU32(out, static_cast<uint32_t>(d.bin().size()));
  AppendU32(out, 0x004E4942);
  out.insert(out.end(), d.bin().begin(), d.bin().end());
  PutU32(out, 8, static_cast<uint32_t>(out.size()));
  EXPECT_TRUE(Fails(Import(out), StatusCode::kInvalidInput, {"GLB", "chunk 0", "multiple of 4"}));
}

TEST(GltfHostileGlb, UnpaddedLastJsonChunkIsTolerated) {
  // No BIN chunk follows: nothing is ambiguous, the file imports.
  Doc d = Doc::Triangle();
  std::string text = d.WithDataUri().dump();
  while (text.size() % 4 != 2) text.push_back(' ');
  std::vector<uint8_t> out;
  AppendU32(out, 0x46546C67);
  AppendU32(out, 2);
  AppendU32(out, static_cast<uint32_t>(20 + text.size()));
  AppendU32(out, static_cast<uint32_t>(text.size()));
  AppendU32(out, 0x4E4F534A);
  out.insert(out.end(), text.begin(), text.end());
  auto scene = Import(out);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(OnlyPrimitive(*scene).indices, (std::vector<uint32_t>{0, 1, 2}));
}

// ---------------------------------------------------------------------------
// Buffers, views, accessors.

TEST(GltfHostileAccessors, CountLargerThanItsBufferView) {
  Doc d = Doc::Triangle();
  d.doc()["accessors"][0]["count"] = 4;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0]", "bufferViews[0]"}));
}

TEST(GltfHostileAccessors, ByteOffsetPastTheView) {
  Doc d = Doc::Triangle();
  d.doc()["accessors"][0]["byteOffset"] = 40;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0]", "bufferViews[0]"}));
  d.doc()["accessors"][0]["byteOffset"] = 4;  // 4 + 36 > 36
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0]"}));
  d.doc()["accessors"][0]["byteOffset"] = -4;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0].byteOffset"}));
}

TEST(GltfHostileAccessors, BufferViewPastItsBuffer) {
  Doc d = Doc::Triangle();
  d.doc()["bufferViews"][0]["byteOffset"] = 1000;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"bufferViews[0]", "buffers[0]"}));
  Doc e = Doc::Triangle();
  e.doc()["bufferViews"][1]["byteLength"] = 1u << 20;
  EXPECT_TRUE(Fails(Import(e.Glb().bytes), StatusCode::kInvalidInput, {"bufferViews[1]", "buffers[0]"}));
  Doc f = Doc::Triangle();
  f.doc()["bufferViews"][0]["buffer"] = 3;
  EXPECT_TRUE(Fails(Import(f.Gltf()), StatusCode::kInvalidInput, {"bufferViews[0].buffer", "does not exist"}));
}

TEST(GltfHostileAccessors, BufferLargerThanTheBinChunk) {
  Doc d = Doc::Triangle();
  json doc = d.doc();
  doc["buffers"] = json::array({{{"byteLength", d.bin().size() + 4}}});
  const PackedGlb glb = PackGlb(doc.dump(), d.bin());
  EXPECT_TRUE(Fails(Import(glb.bytes), StatusCode::kInvalidInput, {"buffers[0].byteLength", "BIN chunk"}));
}

TEST(GltfHostileAccessors, DataUriShorterThanByteLength) {
  Doc d = Doc::Triangle();
  json doc = d.WithDataUri();
  doc["buffers"][0]["byteLength"] = d.bin().size() + 8;
  EXPECT_FALSE(Import(doc).ok());
}

TEST(GltfHostileAccessors, ZeroByteLengthsAreRefused) {
  Doc d = Doc::Triangle();
  json doc = d.doc();
  doc["buffers"] = json::array({{{"byteLength", 0}}});
  doc["bufferViews"] = json::array();
  doc["meshes"][0]["primitives"][0] = {{"attributes", {{"POSITION", 0}}}};
  doc["accessors"] = json::array({{{"componentType", kFloat}, {"count", 3}, {"type", "VEC3"}}});
  EXPECT_TRUE(Fails(Import(PackGlb(doc.dump(), d.bin()).bytes), StatusCode::kInvalidInput,
                    {"buffers[0].byteLength"}));
  Doc e = Doc::Triangle();
  e.doc()["bufferViews"][1]["byteLength"] = 0;
  EXPECT_TRUE(Fails(Import(e.Gltf()), StatusCode::kInvalidInput, {"bufferViews[1].byteLength"}));
}

TEST(GltfHostileAccessors, IndexOutOfRange) {
  Doc d;
  const int pos = d.Positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
  const int idx = d.Indices16({0, 1, 7});
  d.Primitive({{"attributes", {{"POSITION", pos}}}, {"indices", idx}});
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput,
                    {"meshes[0].primitives[0]", "index 7", "3 vertices"}));
}

TEST(GltfHostileAccessors, IndicesMustBeUnsigned) {
  Doc d = Doc::Triangle();
  d.doc()["accessors"][1]["componentType"] = kShort;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"indices", "unsigned"}));
}

TEST(GltfHostileAccessors, AbsurdCounts) {
  Doc d = Doc::Triangle();
  d.doc()["accessors"][0]["count"] = 4000000000u;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kResourceExhausted, {"accessors[0].count", "4000000000"}));
  d.doc()["accessors"][0]["count"] = 4e9;  // a JSON float, not an integer
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0].count", "integer"}));
  d.doc()["accessors"][0]["count"] = -3;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0].count"}));
  d.doc()["accessors"][0]["count"] = 0;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0].count"}));
  d.doc()["accessors"][0]["count"] = 18446744073709551615u;
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kResourceExhausted, {"accessors[0].count"}));
}

TEST(GltfHostileAccessors, HugeAccessorWithoutBufferViewIsNotAllocated) {
  // No bufferView means "all zeros": 2^31 VEC3 would be 24 GiB of floats
  // conjured from a few hundred bytes.
  Doc d;
  d.Accessor({{"componentType", kFloat}, {"count", 2147483648u}, {"type", "VEC3"}});
  d.Primitive({{"attributes", {{"POSITION", 0}}}});
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kResourceExhausted, {"accessors[0]", "no bufferView"}));
  Doc e;
  e.Accessor({{"componentType", kFloat}, {"count", 100000000}, {"type", "VEC3"}});
  e.Primitive({{"attributes", {{"POSITION", 0}}}});
  EXPECT_TRUE(Fails(Import(e.Gltf()), StatusCode::kResourceExhausted, {"accessors[0]", "no bufferView"}));
}

TEST(GltfHostileAccessors, SmallAccessorWithoutBufferViewIsZeros) {
  Doc d;
  d.Accessor({{"componentType", kFloat}, {"count", 3}, {"type", "VEC3"}});
  d.Primitive({{"attributes", {{"POSITION", 0}}}});
  auto scene = Import(d.WithDataUri());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  const Primitive& p = OnlyPrimitive(*scene);
  ASSERT_EQ(p.positions.size(), 3u);
  for (const Vec3f& v : p.positions) EXPECT_EQ(v, (Vec3f{0, 0, 0}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST(GltfHostileAccessors, SharedAccessorAmplificationIsBounded) {
  // One accessor of 3000 vertices referenced by 6000 primitives: a few
  // hundred kilobytes that would decode to 54 million floats.
  Doc d;
  std::vector<float> xyz(3000 * 3);
  for (size_t i = 0; i < xyz.size(); ++i) xyz[i] = static_cast<float>(i % 97);
  const int pos = d.Positions(xyz);
  for (int k = 0; k < 6000; ++k) d.Primitive({{"attributes", {{"POSITION", pos}}}});
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kResourceExhausted, {"meshes[0].primitives[", "decod"}));
  // The same accessor shared by a handful of primitives is fine.
  Doc e;
  const int pos_e = e.Positions(xyz);
  for (int k = 0; k < 8; ++k) e.Primitive({{"attributes", {{"POSITION", pos_e}}}});
  auto scene = Import(e.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(scene->meshes[0].primitives.size(), 8u);
}

TEST(GltfHostileAccessors, SparseIndicesOutOfRange) {
  Doc d;
  const int pos_view = d.View(RawBytes(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  const int idx_view = d.View(RawBytes(std::vector<uint16_t>{5, 0}));
  const int val_view = d.View(RawBytes(std::vector<float>{9, 9, 9}));
  d.Accessor({{"bufferView", pos_view}, {"componentType", kFloat}, {"count", 3}, {"type", "VEC3"},
              {"sparse", {{"count", 1},
                          {"indices", {{"bufferView", idx_view}, {"componentType", kUnsignedShort}}},
                          {"values", {{"bufferView", val_view}}}}}});
  d.Primitive({{"attributes", {{"POSITION", 0}}}});
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0]", "sparse index 5"}));
}

TEST(GltfHostileAccessors, SparseIndicesNotIncreasing) {
  for (const std::vector<uint16_t>& order : {std::vector<uint16_t>{2, 1}, std::vector<uint16_t>{1, 1}}) {
    Doc d;
    const int pos_view = d.View(RawBytes(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
    const int idx_view = d.View(RawBytes(order));
    const int val_view = d.View(RawBytes(std::vector<float>{9, 9, 9, 8, 8, 8}));
    d.Accessor({{"bufferView", pos_view}, {"componentType", kFloat}, {"count", 3}, {"type", "VEC3"},
                {"sparse", {{"count", 2},
                            {"indices", {{"bufferView", idx_view}, {"componentType", kUnsignedShort}}},
                            {"values", {{"bufferView", val_view}}}}}});
    d.Primitive({{"attributes", {{"POSITION", 0}}}});
    EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0]", "not increasing"}));
  }
}

TEST(GltfHostileAccessors, SparseCountLargerThanAccessor) {
  Doc d;
  const int pos_view = d.View(RawBytes(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
  const int idx_view = d.View(RawBytes(std::vector<uint16_t>{0, 1, 2, 3}));
  const int val_view = d.View(RawBytes(std::vector<float>(12, 1.0f)));
  d.Accessor({{"bufferView", pos_view}, {"componentType", kFloat}, {"count", 3}, {"type", "VEC3"},
              {"sparse", {{"count", 4},
                          {"indices", {{"bufferView", idx_view}, {"componentType", kUnsignedShort}}},
                          {"values", {{"bufferView", val_view}}}}}});
  d.Primitive({{"attributes", {{"POSITION", 0}}}});
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0].sparse.count"}));
}

TEST(GltfHostileAccessors, NonFinitePositions) {
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                    -std::numeric_limits<float>::infinity()}) {
    SCOPED_TRACE(bad);
    Doc d;
    const int pos = d.Positions({0, 0, 0, 1, bad, 0, 0, 1, 0});
    const int idx = d.Indices16({0, 1, 2});
    d.Primitive({{"attributes", {{"POSITION", pos}}}, {"indices", idx}});
    EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"meshes[0].primitives[0]", "POSITION", "finite"}));
    EXPECT_TRUE(Fails(Import(d.Glb().bytes), StatusCode::kInvalidInput, {"finite"}));
  }
}

TEST(GltfHostileAccessors, NodeCycleIsRefused) {
  Doc d = Doc::Triangle();
  d.doc()["nodes"] = json::array({{{"mesh", 0}, {"children", {1}}}, {{"children", {2}}}, {{"children", {1}}}});
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"nodes["}));
  d.doc()["nodes"] = json::array({{{"mesh", 0}, {"children", {1}}}, {{"children", {0}}}});
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"nodes[", "cycle"}));
}

TEST(GltfHostileAccessors, LongNodeChainImports) {
  // 40,000 nodes, each the child of the previous one: the hierarchy check
  // must be linear, not walk to the root from every node.
  Doc d = Doc::Triangle();
  json nodes = json::array();
  constexpr int kNodes = 40000;
  for (int i = 0; i < kNodes; ++i) {
    json node = json::object();
    if (i + 1 < kNodes) node["children"] = json::array({i + 1});
    if (i + 1 == kNodes) node["mesh"] = 0;
    nodes.push_back(std::move(node));
  }
  d.doc()["nodes"] = nodes;
  auto scene = Import(d.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(scene->nodes.size(), static_cast<size_t>(kNodes));
}

TEST(GltfHostileAccessors, DanglingReferences) {
  Doc d = Doc::Triangle();
  d.doc()["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 9;
  EXPECT_FALSE(Import(d.Gltf()).ok());
  Doc e = Doc::Triangle();
  e.doc()["nodes"][0]["mesh"] = 4;
  EXPECT_TRUE(Fails(Import(e.Gltf()), StatusCode::kInvalidInput, {"nodes[0].mesh"}));
  Doc f = Doc::Triangle();
  f.doc()["meshes"][0]["primitives"][0]["material"] = 2;
  EXPECT_FALSE(Import(f.Gltf()).ok());
  Doc g = Doc::Triangle();
  g.doc()["scene"] = 5;
  EXPECT_TRUE(Fails(Import(g.Gltf()), StatusCode::kInvalidInput, {"scene 5"}));
  Doc h = Doc::Triangle();
  h.doc()["materials"] = json::array({{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 3}}}}}}});
  h.doc()["meshes"][0]["primitives"][0]["material"] = 0;
  EXPECT_TRUE(Fails(Import(h.Gltf()), StatusCode::kInvalidInput, {"materials[0]", "texture 3"}));
  h.doc()["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = -1;
  EXPECT_TRUE(Fails(Import(h.Gltf()), StatusCode::kInvalidInput, {"materials[0]", "texture -1"}));
  // Extras belong to the application: a "...Texture" there is not ours to check.
  Doc k = Doc::Triangle();
  k.doc()["materials"] = json::array({{{"extras", {{"myTexture", {{"index", 99}}}}}}});
  k.doc()["meshes"][0]["primitives"][0]["material"] = 0;
  auto with_extras = Import(k.Gltf());
  EXPECT_TRUE(with_extras.ok()) << with_extras.status().ToString();
}

// ---------------------------------------------------------------------------
// JSON that is not a glTF document at all.

TEST(GltfHostileJson, DeepNestingIsAClearError) {
  const std::string deep = std::string(10000, '[') + std::string(10000, ']');
  EXPECT_TRUE(Fails(Import(Bytes(deep)), StatusCode::kInvalidInput, {"nests deeper"}));
  // The same depth hidden inside a valid document's extras, in a GLB.
  Doc d = Doc::Triangle();
  std::string text = d.WithDataUri().dump();
  text.pop_back();  // drop the closing brace
  std::string open, close;
  for (int i = 0; i < 10000; ++i) {
    open += "{\"a\":";
    close += "}";
  }
  text += ",\"extras\":" + open + "1" + close + "}";
  ASSERT_TRUE(json::parse(text, nullptr, false).is_object());
  EXPECT_TRUE(Fails(Import(PackGlb(text, {}).bytes), StatusCode::kInvalidInput, {"nests deeper"}));
  EXPECT_TRUE(Fails(Import(Bytes(text)), StatusCode::kInvalidInput, {"nests deeper"}));
}

TEST(GltfHostileJson, GarbageAndEmpty) {
  EXPECT_TRUE(Fails(Import(Bytes("\x01\x02garbage{{ not json")), StatusCode::kInvalidInput, {"JSON", "parse"}));
  EXPECT_TRUE(Fails(Import(std::vector<uint8_t>{}), StatusCode::kInvalidInput, {"empty"}));
  EXPECT_TRUE(Fails(Import(Bytes("[1,2,3]")), StatusCode::kInvalidInput, {"not an object"}));
  EXPECT_TRUE(Fails(Import(Bytes("{}")), StatusCode::kInvalidInput, {"asset"}));
  EXPECT_TRUE(Fails(Import(json{{"asset", {{"version", "1.0"}}}}), StatusCode::kUnsupported, {"1.0"}));
  EXPECT_TRUE(Fails(Import(Bytes("glTF")), StatusCode::kInvalidInput, {"GLB"}));
}

TEST(GltfHostileJson, WrongTypesAreRefused) {
  Doc d = Doc::Triangle();
  d.doc()["accessors"][0]["count"] = "three";
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"accessors[0].count"}));
  Doc e = Doc::Triangle();
  e.doc()["bufferViews"] = json::object();
  EXPECT_TRUE(Fails(Import(e.Gltf()), StatusCode::kInvalidInput, {"bufferViews", "array"}));
  Doc f = Doc::Triangle();
  f.doc()["accessors"][0]["type"] = "VEC7";
  EXPECT_TRUE(Fails(Import(f.Gltf()), StatusCode::kInvalidInput, {"accessors[0].type"}));
  Doc g = Doc::Triangle();
  g.doc()["accessors"][0]["componentType"] = 5124;  // INT is not a glTF accessor type
  EXPECT_TRUE(Fails(Import(g.Gltf()), StatusCode::kInvalidInput, {"accessors[0].componentType"}));
  // Huge indices and enum values are invalid, not "too large to handle".
  g.doc()["accessors"][0]["componentType"] = uint64_t{1} << 50;
  EXPECT_TRUE(Fails(Import(g.Gltf()), StatusCode::kInvalidInput, {"accessors[0].componentType"}));
  Doc h = Doc::Triangle();
  h.doc()["bufferViews"][0]["buffer"] = uint64_t{1} << 50;
  EXPECT_TRUE(Fails(Import(h.Gltf()), StatusCode::kInvalidInput, {"bufferViews[0].buffer"}));
}

// ---------------------------------------------------------------------------
// Features meshstream refuses, clearly.

// Points, lines, skinning attributes and morph targets are carried, not
// refused (tests/importers/gltf_carry_test.cc); a mode that is not glTF's is.
TEST(GltfHostileFeatures, PointsAndLinesAreCarried) {
  Doc d = Doc::Triangle();
  for (int mode : {0, 1, 2, 3}) {
    d.doc()["meshes"][0]["primitives"][0]["mode"] = mode;
    auto scene = Import(d.Gltf());
    ASSERT_TRUE(scene.ok()) << mode << ": " << scene.status().ToString();
    ASSERT_EQ(scene->meshes[0].carried.size(), 1u);
    EXPECT_EQ(scene->meshes[0].carried[0].mode, mode);
    EXPECT_TRUE(scene->meshes[0].primitives.empty());
  }
  d.doc()["meshes"][0]["primitives"][0]["mode"] = 9;
  EXPECT_FALSE(Import(d.Gltf()).ok());
}

TEST(GltfHostileFeatures, SkinningAttributesAreCarried) {
  for (const char* name : {"JOINTS_0", "WEIGHTS_0"}) {
    Doc d = Doc::Triangle();
    const int view = d.View(std::vector<uint8_t>(12, 0));
    const int acc = d.Accessor({{"bufferView", view}, {"componentType", kUnsignedByte}, {"count", 3},
                                {"type", "VEC4"}, {"normalized", std::string(name) == "WEIGHTS_0"}});
    d.doc()["meshes"][0]["primitives"][0]["attributes"][name] = acc;
    auto scene = Import(d.Gltf());
    ASSERT_TRUE(scene.ok()) << name << ": " << scene.status().ToString();
    ASSERT_EQ(scene->meshes[0].carried.size(), 1u);
    EXPECT_EQ(scene->meshes[0].carried[0].attributes.size(), 2u);
  }
}

TEST(GltfHostileFeatures, MorphTargetsAreCarried) {
  Doc d = Doc::Triangle();
  const int delta = d.Positions({0, 0, 1, 0, 0, 1, 0, 0, 1});
  d.doc()["meshes"][0]["primitives"][0]["targets"] = json::array({{{"POSITION", delta}}});
  auto scene = Import(d.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  ASSERT_EQ(scene->meshes[0].carried.size(), 1u);
  EXPECT_EQ(scene->meshes[0].carried[0].targets.size(), 1u);
}

TEST(GltfHostileFeatures, UnknownRequiredExtensionIsUnsupported) {
  Doc d = Doc::Triangle();
  d.doc()["extensionsUsed"] = json::array({"EXT_made_up_required"});
  d.doc()["extensionsRequired"] = json::array({"EXT_made_up_required"});
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kUnsupported, {"EXT_made_up_required"}));
}

TEST(GltfHostileFeatures, DracoPrimitiveWithGarbageBytes) {
  Doc d;
  std::vector<uint8_t> garbage(64);
  for (size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<uint8_t>(i * 37 + 11);
  const int view = d.View(garbage);
  const int pos = d.Accessor({{"componentType", kFloat}, {"count", 3}, {"type", "VEC3"}});
  const int idx = d.Accessor({{"componentType", kUnsignedShort}, {"count", 3}, {"type", "SCALAR"}});
  d.Primitive({{"attributes", {{"POSITION", pos}}},
               {"indices", idx},
               {"extensions", {{"KHR_draco_mesh_compression", {{"bufferView", view}, {"attributes", {{"POSITION", 0}}}}}}}});
  d.doc()["extensionsUsed"] = json::array({"KHR_draco_mesh_compression"});
  d.doc()["extensionsRequired"] = json::array({"KHR_draco_mesh_compression"});
  EXPECT_TRUE(Fails(Import(d.Glb().bytes), StatusCode::kInvalidInput, {"meshes[0].primitives[0]", "Draco"}));
  EXPECT_TRUE(Fails(Import(d.Gltf()), StatusCode::kInvalidInput, {"Draco"}));
  // A "Draco" stream that starts with the real magic but then lies.
  Doc e = d;
  std::vector<uint8_t> lying = {'D', 'R', 'A', 'C', 'O', 2, 2, 1, 1, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF, 0x0F};
  lying.resize(64, 0xFF);
  std::copy(lying.begin(), lying.end(), e.bin().begin());
  EXPECT_TRUE(Fails(Import(e.Glb().bytes), StatusCode::kInvalidInput, {"Draco"}));
}

// ---------------------------------------------------------------------------
// URIs: nothing outside the asset's folder is opened.

class GltfUriTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::path(::testing::TempDir()) / "gltf_uri_XXXXXX").string();
    ASSERT_NE(mkdtemp(pattern.data()), nullptr);
    root_ = pattern;
    asset_ = root_ / "asset";
    fs::create_directories(asset_ / "sub");
    // The triangle's buffer, in the asset's folder, in a subfolder, and as a
    // "secret" outside the asset's folder that hostile URIs try to reach.
    Doc d = Doc::Triangle();
    bin_ = d.bin();
    doc_ = d.doc();
    Write(asset_ / "model.bin", bin_);
    Write(asset_ / "sub" / "inner.bin", bin_);
    Write(root_ / "secret.bin", bin_);
    fs::create_symlink(root_ / "secret.bin", asset_ / "link.bin");
    fs::create_directory_symlink(root_, asset_ / "linkdir");
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }

  static void Write(const fs::path& path, const std::vector<uint8_t>& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }

  // Writes asset/model.gltf with the buffer at `uri` and imports it.
  StatusOr<Scene> ImportWithBufferUri(const std::string& uri) {
    json doc = doc_;
    doc["buffers"] = json::array({{{"byteLength", bin_.size()}, {"uri", uri}}});
    const std::string text = doc.dump();
    Write(asset_ / "model.gltf", Bytes(text));
    return ImportGltfFile((asset_ / "model.gltf").string(), ImportOptions{});
  }

  // The same with an image at `uri` (the buffer is a data: URI).
  StatusOr<Scene> ImportWithImageUri(const std::string& uri) {
    json doc = doc_;
    doc["buffers"] = json::array({{{"byteLength", bin_.size()}, {"uri", DataUri(bin_)}}});
    doc["images"] = json::array({{{"uri", uri}}});
    doc["textures"] = json::array({{{"source", 0}}});
    Write(asset_ / "model.gltf", Bytes(doc.dump()));
    return ImportGltfFile((asset_ / "model.gltf").string(), ImportOptions{});
  }

  std::vector<std::string> HostileUris() const {
    const std::string secret = (root_ / "secret.bin").string();
    return {"../secret.bin", secret, "/etc/passwd", "%2e%2e/secret.bin", "%2E%2E%2Fsecret.bin",
            "file://" + secret, "file:///etc/passwd", "http://example.com/a.bin",
            "sub/../../secret.bin", "sub/%2e%2e/%2e%2e/secret.bin", "..\\secret.bin",
            "./../secret.bin", "sub/../../asset/../secret.bin"};
  }

  fs::path root_, asset_;
  std::vector<uint8_t> bin_;
  json doc_;
};

TEST_F(GltfUriTest, FilesInsideTheFolderLoad) {
  for (const char* uri : {"model.bin", "sub/inner.bin", "./model.bin", "sub%2Finner.bin"}) {
    SCOPED_TRACE(uri);
    auto scene = ImportWithBufferUri(uri);
    ASSERT_TRUE(scene.ok()) << scene.status().ToString();
    EXPECT_EQ(OnlyPrimitive(*scene).indices, (std::vector<uint32_t>{0, 1, 2}));
  }
}

TEST_F(GltfUriTest, BufferUrisLeavingTheFolderAreRefused) {
  for (const std::string& uri : HostileUris()) {
    SCOPED_TRACE(uri);
    auto scene = ImportWithBufferUri(uri);
    EXPECT_TRUE(Fails(scene, StatusCode::kInvalidInput, {"buffers[0]"}));
  }
}

TEST_F(GltfUriTest, SymlinksLeavingTheFolderAreRefused) {
  // Lexically fine URIs whose real path lies outside the asset's folder.
  for (const char* uri : {"link.bin", "linkdir/secret.bin"}) {
    SCOPED_TRACE(uri);
    auto scene = ImportWithBufferUri(uri);
    ASSERT_FALSE(scene.ok());
    EXPECT_NE(scene.status().message().find(uri), std::string::npos) << scene.status().message();
    EXPECT_NE(scene.status().message().find("outside the asset's folder"), std::string::npos)
        << scene.status().message();
  }
}

TEST_F(GltfUriTest, OnlyRealDataUrisSkipThePathChecks) {
  // "data:" followed by something the parser does not decode would be taken
  // for a file name; with a folder named "data:" it would even resolve.
  fs::create_directories(asset_ / "data:");
  for (const char* uri : {"data:/../model.bin", "data:/../../secret.bin", "data:application/x-made-up;base64,AAAA",
                          "data:application/octet-stream,plain"}) {
    SCOPED_TRACE(uri);
    EXPECT_TRUE(Fails(ImportWithBufferUri(uri), StatusCode::kInvalidInput, {"buffers[0]", "data: URI"}));
    EXPECT_TRUE(Fails(ImportWithImageUri(uri), StatusCode::kInvalidInput, {"images[0]", "data: URI"}));
  }
  auto gltf_buffer = ImportWithBufferUri("data:application/gltf-buffer;base64," + Base64(bin_));
  EXPECT_TRUE(gltf_buffer.ok()) << gltf_buffer.status().ToString();
}

TEST_F(GltfUriTest, MissingFileIsNotFound) {
  auto scene = ImportWithBufferUri("nothere.bin");
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().code(), StatusCode::kNotFound) << scene.status().message();
  EXPECT_NE(scene.status().message().find("nothere.bin"), std::string::npos) << scene.status().message();
}

TEST_F(GltfUriTest, ImageUrisLeavingTheFolderAreRefused) {
  Write(asset_ / "tex.png", {0x89, 'P', 'N', 'G', 13, 10, 26, 10, 1, 2, 3, 4});
  auto good = ImportWithImageUri("tex.png");
  ASSERT_TRUE(good.ok()) << good.status().ToString();
  ASSERT_EQ(good->images.size(), 1u);
  EXPECT_EQ(good->images[0].bytes.size(), 12u);
  EXPECT_EQ(good->images[0].mime_type, "image/png");

  for (const std::string& uri : HostileUris()) {
    SCOPED_TRACE(uri);
    EXPECT_TRUE(Fails(ImportWithImageUri(uri), StatusCode::kInvalidInput, {"images[0]"}));
  }
  for (const char* uri : {"link.bin", "linkdir/secret.bin"}) {
    SCOPED_TRACE(uri);
    auto scene = ImportWithImageUri(uri);
    ASSERT_FALSE(scene.ok());
    EXPECT_NE(scene.status().message().find("images[0]"), std::string::npos) << scene.status().message();
    EXPECT_NE(scene.status().message().find("outside the asset's folder"), std::string::npos)
        << scene.status().message();
  }
}

TEST_F(GltfUriTest, NoBaseDirRefusesEveryExternalFile) {
  json doc = doc_;
  doc["buffers"] = json::array({{{"byteLength", bin_.size()}, {"uri", "model.bin"}}});
  EXPECT_FALSE(ImportGltfBytes(Bytes(doc.dump()), "", "bytes", ImportOptions{}).ok());
}

// ---------------------------------------------------------------------------
// The good side: what is accepted comes out exactly right.

TEST(GltfGoodInput, TriangleStripTriangulates) {
  Doc d;
  const int pos = d.Positions({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 2, 0});
  d.Primitive({{"attributes", {{"POSITION", pos}}}, {"mode", 5}});
  auto scene = Import(d.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(OnlyPrimitive(*scene).indices, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2, 2, 3, 4}));

  // Repeated indices (a restart by degenerate triangles) are dropped.
  Doc e;
  const int pos_e = e.Positions({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 2, 0});
  const int idx_e = e.Indices16({0, 1, 2, 2, 3, 4});
  e.Primitive({{"attributes", {{"POSITION", pos_e}}}, {"indices", idx_e}, {"mode", 5}});
  auto strip = Import(e.Glb().bytes);
  ASSERT_TRUE(strip.ok()) << strip.status().ToString();
  EXPECT_EQ(OnlyPrimitive(*strip).indices, (std::vector<uint32_t>{0, 1, 2, 2, 4, 3}));
}

TEST(GltfGoodInput, TriangleFanTriangulates) {
  Doc d;
  const int pos = d.Positions({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
  const int idx = d.Indices16({0, 1, 2, 3});
  d.Primitive({{"attributes", {{"POSITION", pos}}}, {"indices", idx}, {"mode", 6}});
  auto scene = Import(d.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(OnlyPrimitive(*scene).indices, (std::vector<uint32_t>{1, 2, 0, 2, 3, 0}));
}

TEST(GltfGoodInput, NonIndexedTriangles) {
  Doc d;
  const int pos = d.Positions({0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 5, 6, 5, 5, 5, 6, 5});
  d.Primitive({{"attributes", {{"POSITION", pos}}}});
  auto scene = Import(d.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(OnlyPrimitive(*scene).indices, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5}));
  Doc e;
  const int pos_e = e.Positions({0, 0, 0, 1, 0, 0, 0, 1, 0, 5, 5, 5});
  e.Primitive({{"attributes", {{"POSITION", pos_e}}}});
  EXPECT_TRUE(Fails(Import(e.Gltf()), StatusCode::kInvalidInput, {"multiple of 3"}));
}

TEST(GltfGoodInput, SparseAccessorSubstitutes) {
  Doc d;
  const int pos_view = d.View(RawBytes(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}));
  const int idx_view = d.View(RawBytes(std::vector<uint8_t>{1, 3}));
  const int val_view = d.View(RawBytes(std::vector<float>{9, 8, 7, -1, -2, -3}));
  d.Accessor({{"bufferView", pos_view}, {"componentType", kFloat}, {"count", 4}, {"type", "VEC3"},
              {"sparse", {{"count", 2},
                          {"indices", {{"bufferView", idx_view}, {"componentType", kUnsignedByte}}},
                          {"values", {{"bufferView", val_view}}}}}});
  const int idx = d.Indices16({0, 1, 2, 2, 1, 3});
  d.Primitive({{"attributes", {{"POSITION", 0}}}, {"indices", idx}});
  auto scene = Import(d.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  const Primitive& p = OnlyPrimitive(*scene);
  ASSERT_EQ(p.positions.size(), 4u);
  EXPECT_EQ(p.positions[0], (Vec3f{0, 0, 0}));
  EXPECT_EQ(p.positions[1], (Vec3f{9, 8, 7}));
  EXPECT_EQ(p.positions[2], (Vec3f{0, 1, 0}));
  EXPECT_EQ(p.positions[3], (Vec3f{-1, -2, -3}));

  // Sparse values over an accessor without bufferView (zeros elsewhere).
  Doc e;
  const int idx_view_e = e.View(RawBytes(std::vector<uint32_t>{2}));
  const int val_view_e = e.View(RawBytes(std::vector<float>{4, 5, 6}));
  e.Accessor({{"componentType", kFloat}, {"count", 3}, {"type", "VEC3"},
              {"sparse", {{"count", 1},
                          {"indices", {{"bufferView", idx_view_e}, {"componentType", kUnsignedInt}}},
                          {"values", {{"bufferView", val_view_e}}}}}});
  e.Primitive({{"attributes", {{"POSITION", 0}}}});
  auto zeros = Import(e.Gltf());
  ASSERT_TRUE(zeros.ok()) << zeros.status().ToString();
  const Primitive& z = OnlyPrimitive(*zeros);
  ASSERT_EQ(z.positions.size(), 3u);
  EXPECT_EQ(z.positions[0], (Vec3f{0, 0, 0}));
  EXPECT_EQ(z.positions[1], (Vec3f{0, 0, 0}));
  EXPECT_EQ(z.positions[2], (Vec3f{4, 5, 6}));
}

TEST(GltfGoodInput, MeshQuantizationNormalizedShorts) {
  Doc d;
  // VEC3 SHORT normalized positions, padded to 8 bytes per vertex (stride 8).
  const std::vector<int16_t> raw = {32767, 0, -32767, 0,
                                    -32768, 16384, 1, 0,
                                    0, -16384, 32767, 0};
  const int view = d.View(RawBytes(raw), 8);
  d.Accessor({{"bufferView", view}, {"componentType", kShort}, {"normalized", true},
              {"count", 3}, {"type", "VEC3"}});
  // TEXCOORD_0 as normalized unsigned shorts, NORMAL as normalized bytes.
  const int uv_view = d.View(RawBytes(std::vector<uint16_t>{0, 65535, 65535, 0, 32768, 32768}));
  d.Accessor({{"bufferView", uv_view}, {"componentType", kUnsignedShort}, {"normalized", true},
              {"count", 3}, {"type", "VEC2"}});
  const int n_view = d.View(RawBytes(std::vector<int8_t>{0, 0, 127, 0, 0, 0, -127, 0, 0, -128, 0, 0}), 4);
  d.Accessor({{"bufferView", n_view}, {"componentType", kByte}, {"normalized", true},
              {"count", 3}, {"type", "VEC3"}});
  d.Primitive({{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}, {"NORMAL", 2}}}});
  d.doc()["extensionsUsed"] = json::array({"KHR_mesh_quantization"});
  d.doc()["extensionsRequired"] = json::array({"KHR_mesh_quantization"});
  auto scene = Import(d.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  const Primitive& p = OnlyPrimitive(*scene);
  ASSERT_EQ(p.positions.size(), 3u);
  EXPECT_EQ(p.positions[0], (Vec3f{1.0f, 0.0f, -1.0f}));
  EXPECT_EQ(p.positions[1][0], -1.0f);  // -32768 clamps to -1
  EXPECT_FLOAT_EQ(p.positions[1][1], 16384.0f / 32767.0f);
  EXPECT_FLOAT_EQ(p.positions[1][2], 1.0f / 32767.0f);
  EXPECT_FLOAT_EQ(p.positions[2][1], -16384.0f / 32767.0f);
  EXPECT_EQ(p.positions[2][2], 1.0f);
  ASSERT_EQ(p.texcoords.size(), 1u);
  EXPECT_EQ(p.texcoords[0][0], (Vec2f{0.0f, 1.0f}));
  EXPECT_EQ(p.texcoords[0][1], (Vec2f{1.0f, 0.0f}));
  EXPECT_FLOAT_EQ(p.texcoords[0][2][0], 32768.0f / 65535.0f);
  ASSERT_EQ(p.normals.size(), 3u);
  EXPECT_EQ(p.normals[0], (Vec3f{0, 0, 1}));
  EXPECT_EQ(p.normals[1], (Vec3f{0, 0, -1}));
  EXPECT_EQ(p.normals[2], (Vec3f{0, -1, 0}));  // -128 clamps to -1
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST(GltfGoodInput, UnnormalizedBytePositions) {
  Doc d;
  const int view = d.View(RawBytes(std::vector<uint8_t>{0, 0, 0, 0, 200, 0, 0, 0, 0, 100, 0, 0}), 4);
  d.Accessor({{"bufferView", view}, {"componentType", kUnsignedByte}, {"count", 3}, {"type", "VEC3"}});
  d.Primitive({{"attributes", {{"POSITION", 0}}}});
  d.doc()["extensionsUsed"] = json::array({"KHR_mesh_quantization"});
  d.doc()["extensionsRequired"] = json::array({"KHR_mesh_quantization"});
  auto scene = Import(d.Glb().bytes);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(OnlyPrimitive(*scene).positions[1], (Vec3f{200, 0, 0}));
  EXPECT_EQ(OnlyPrimitive(*scene).positions[2], (Vec3f{0, 100, 0}));
}

TEST(GltfGoodInput, UnknownOptionalExtensionIsAWarning) {
  Doc d = Doc::Triangle();
  d.doc()["extensionsUsed"] = json::array({"EXT_made_up_optional"});
  auto scene = Import(d.Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  bool warned = false;
  for (const std::string& w : scene->warnings) warned |= w.find("EXT_made_up_optional") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(GltfGoodInput, DataUriBuffersAndImages) {
  Doc d = Doc::Triangle();
  json doc = d.WithDataUri();
  ASSERT_EQ(doc["buffers"][0]["uri"].get<std::string>().rfind("data:", 0), 0u);
  const std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', 13, 10, 26, 10, 0, 0, 0, 0};
  doc["images"] = json::array({{{"uri", "data:image/png;base64," + Base64(png)}}});
  doc["textures"] = json::array({{{"source", 0}}});
  doc["materials"] = json::array({{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}});
  doc["meshes"][0]["primitives"][0]["material"] = 0;
  auto scene = Import(doc);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  const Primitive& p = OnlyPrimitive(*scene);
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_EQ(p.material, 0);
  ASSERT_EQ(scene->images.size(), 1u);
  EXPECT_EQ(scene->images[0].bytes, png);
  EXPECT_EQ(scene->images[0].mime_type, "image/png");
}

TEST(GltfGoodInput, ExportedSceneRoundTrips) {
  auto scene = Import(Doc::Triangle().Gltf());
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  for (bool draco : {false, true}) {
    SCOPED_TRACE(draco ? "draco" : "plain");
    ExportOptions options;
    options.draco = draco;
    auto glb = ExportGlb(*scene, options);
    ASSERT_TRUE(glb.ok()) << glb.status().ToString();
    auto again = Import(*glb);
    ASSERT_TRUE(again.ok()) << again.status().ToString();
    EXPECT_EQ(OnlyPrimitive(*again).face_count(), 1u);
    EXPECT_EQ(OnlyPrimitive(*again).vertex_count(), 3u);
  }
}

TEST(GltfGoodInput, SharedBoxTexturedImports) {
  const fs::path path = fs::path(MESHSTREAM_MODELS_DIR) / "gltf" / "BoxTextured.glb";
  ASSERT_TRUE(fs::exists(path)) << path << " is missing: the tests need ../shared/models";
  auto scene = ImportGltfFile(path.string(), ImportOptions{});
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(scene->total_faces(), 12u);
  EXPECT_EQ(scene->images.size(), 1u);
}

}  // namespace
}  // namespace meshstream

// The test vector of docs/progressive-format.md ("Test vector"): the encoder
// still writes exactly the stored bytes, and the decoder gives the mesh the
// spec documents.
#include <algorithm>

#include <gtest/gtest.h>

#include "codec/bitstream/format.h"
#include "codec/progressive/split_bit_contexts.h"
#include "tests/common/test_vector.h"

namespace meshstream {
namespace {

using test_util::BlobOf;
using test_util::VectorPath;

TEST(TestVector, TheEncoderStillWritesTheStoredBytes) {
  const std::vector<uint8_t> stored = test_util::ReadBytes(VectorPath("octahedron-qp8-bundled.glb"));
  const std::vector<uint8_t> blob = test_util::ReadBytes(VectorPath("octahedron-qp8-bundled.msps"));
  ASSERT_EQ(blob.size(), 90u);
  auto scene = ImportFile(VectorPath("octahedron.obj"));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  auto glb = EncodeProgressiveGlb(scene.value(), test_util::VectorOptions(), nullptr);
  ASSERT_TRUE(glb.ok()) << glb.status().ToString();
  EXPECT_EQ(glb.value(), stored);
  EXPECT_EQ(BlobOf(glb.value()), blob);
}

// Version 2 is still written on request (--format-version 2), byte for byte
// as when it was the current version.
TEST(TestVector, VersionTwoIsStillWrittenByteForByte) {
  const std::vector<uint8_t> stored = test_util::ReadBytes(VectorPath("octahedron-qp8-bundled-v2.glb"));
  auto scene = ImportFile(VectorPath("octahedron.obj"));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  ProgressiveGlbOptions options = test_util::VectorOptions();
  options.stream.version = 2;
  auto glb = EncodeProgressiveGlb(scene.value(), options, nullptr);
  ASSERT_TRUE(glb.ok()) << glb.status().ToString();
  EXPECT_EQ(glb.value(), stored);
  EXPECT_EQ(BlobOf(glb.value()), test_util::ReadBytes(VectorPath("octahedron-qp8-bundled-v2.msps")));
}

TEST(TestVector, TheStreamBlobHasTheDocumentedFields) {
  const std::vector<uint8_t> blob = test_util::ReadBytes(VectorPath("octahedron-qp8-bundled.msps"));
  auto stream = ProgressiveStream::Parse(blob.data(), blob.size());
  ASSERT_TRUE(stream.ok()) << stream.status().ToString();
  EXPECT_EQ(stream->header.size(), 44u);
  ASSERT_EQ(stream->control.size(), 1u);
  EXPECT_EQ(stream->control[0].size(), 17u);
  ASSERT_EQ(stream->datagrams[0].size(), 1u);
  EXPECT_EQ(stream->datagrams[0][0].size(), 19u);
  auto header = StreamHeader::Parse(stream->header.data(), stream->header.size());
  ASSERT_TRUE(header.ok()) << header.status().ToString();
  EXPECT_EQ(header->packing, Packing::kBundled);
  EXPECT_EQ(header->version, 3);
  // No texture coordinates or colours, no seams.
  EXPECT_EQ(header->tools, kAllTools & ~kToolTexcoordPrediction & ~kToolSeams);
  EXPECT_EQ(header->quantization.qp, 8);
  EXPECT_EQ(header->grids.position_grid.origin[0], -1.0f);
  EXPECT_EQ(header->grids.position_grid.range, 2.0f);
  EXPECT_EQ(header->base_vertices, 15u);
  EXPECT_EQ(header->base_faces, 26u);
  EXPECT_EQ(header->base_method, 0);
  EXPECT_EQ(header->split_counts, std::vector<uint32_t>{3});
  ASSERT_TRUE(header->DecodeFixups().ok());
  EXPECT_EQ(header->base_position_fix, std::vector<int32_t>(45, 0));
}

// The split bits' contexts the spec lists (section 9, "The split bits'
// contexts"), from the base as the decoder has it.
TEST(TestVector, SplitBitContextsAreTheDocumentedOnes) {
  const std::vector<uint8_t> stored = test_util::ReadBytes(VectorPath("octahedron-qp8-bundled.glb"));
  ProgressiveDecodeOptions options;
  options.lod = 0;
  auto scene = DecodeProgressiveGlb(stored, options, nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  const Primitive& base = scene->meshes[0].primitives[0];
  SplitBitContexts contexts;
  ASSERT_TRUE(contexts.Reset(static_cast<uint32_t>(base.vertex_count()), base.indices).ok());
  std::vector<uint8_t> bits(15, 0);
  bits[1] = bits[8] = bits[11] = 1;
  std::vector<int> got;
  for (uint32_t v = 0; v < 15; ++v) got.push_back(contexts.Context(v, bits));
  EXPECT_EQ(got, (std::vector<int>{3, 3, 40, 40, 40, 40, 40, 3, 3, 40, 3, 3, 40, 40, 40}));
  EXPECT_EQ(contexts.Encode(bits), (std::vector<uint8_t>{0x42, 0xC2, 0x2A, 0xF1, 0xD1}));
}

// The vector of version 3 and those of versions 2 and 1 (which a version 3
// decoder still reads) give the same mesh.
TEST(TestVector, DecodesToTheDocumentedMesh) {
  for (const char* file : {"octahedron-qp8-bundled.glb", "octahedron-qp8-bundled-v2.glb", "octahedron-qp8-bundled-v1.glb"}) {
  SCOPED_TRACE(file);
  const std::vector<uint8_t> stored = test_util::ReadBytes(VectorPath(file));
  for (int lod : {0, 1}) {
    ProgressiveDecodeOptions options;
    options.lod = lod;
    ProgressiveDecodeReport report;
    auto scene = DecodeProgressiveGlb(stored, options, &report);
    ASSERT_TRUE(scene.ok()) << scene.status().ToString();
    EXPECT_EQ(report.level_vertices, (std::vector<uint32_t>{15, 18}));
    const Primitive& p = scene->meshes[0].primitives[0];
    EXPECT_EQ(p.vertex_count(), lod == 0 ? 15u : 18u);
    EXPECT_EQ(p.face_count(), lod == 0 ? 26u : 32u);
    // Grid: origin -1, step 2/255; q dequantizes to -1 + q 2/255 (docs: "Test vector").
    auto at = [](int q) { return static_cast<float>(-1.0 + q * (2.0 / 255.0)); };
    auto expect = [&](size_t v, int x, int y, int z) {
      EXPECT_FLOAT_EQ(p.positions[v][0], at(x)) << "lod " << lod << " vertex " << v;
      EXPECT_FLOAT_EQ(p.positions[v][1], at(y)) << "lod " << lod << " vertex " << v;
      EXPECT_FLOAT_EQ(p.positions[v][2], at(z)) << "lod " << lod << " vertex " << v;
    };
    expect(0, 128, 128, 0);
    expect(13, 128, 255, 128);
    if (lod == 0) {
      expect(8, 18, 173, 128);  // the midpoint of (0, 128, 128) and (37, 218, 128)
    } else {
      expect(8, 0, 128, 128);
      expect(16, 37, 218, 128);
      // The split of vertex 8 into 8 and 16 adds (w, n, a) and (n, w, b).
      const std::vector<uint32_t> expected = {8, 16, 2, 16, 8, 9};
      EXPECT_TRUE(std::search(p.indices.begin(), p.indices.end(), expected.begin(), expected.end()) != p.indices.end());
    }
  }
  }
}

}  // namespace
}  // namespace meshstream

// The test vector of docs/spec/progressive-format.md ("Test vector"): the encoder
// still writes exactly the stored bytes, and the decoder gives the mesh the
// spec documents.
#include <algorithm>

#include <gtest/gtest.h>

#include "codec/bitstream/format.h"
#include "codec/progressive/split_bit_contexts.h"
#include "codec/progressive/split_bits_connected.h"
#include "tests/common/test_vector.h"

namespace meshstream {
namespace {

using test_util::BlobOf;
using test_util::VectorPath;

// One vector per profile of version 4: the encoder still writes exactly the
// stored bytes.
TEST(TestVector, TheEncoderStillWritesTheStoredBytes) {
  auto scene = ImportFile(VectorPath("octahedron.obj"));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  struct Case {
    const char* name;
    ProgressiveGlbOptions options;
    size_t blob_bytes;
  };
  for (const Case& c : {Case{"octahedron-qp8-bundled", test_util::VectorOptions(), 91},
                        Case{"octahedron-qp8-reliable", test_util::ReliableVectorOptions(), 77}}) {
    SCOPED_TRACE(c.name);
    const std::vector<uint8_t> stored = test_util::ReadBytes(VectorPath(std::string(c.name) + ".glb"));
    const std::vector<uint8_t> blob = test_util::ReadBytes(VectorPath(std::string(c.name) + ".msps"));
    ASSERT_EQ(blob.size(), c.blob_bytes);
    auto glb = EncodeProgressiveGlb(scene.value(), c.options, nullptr);
    ASSERT_TRUE(glb.ok()) << glb.status().ToString();
    EXPECT_EQ(glb.value(), stored);
    EXPECT_EQ(BlobOf(glb.value()), blob);
  }
}

// Versions 3 and 2 are still written on request (--format-version 3, 2),
// byte for byte as when each was the current version.
TEST(TestVector, VersionsThreeAndTwoAreStillWrittenByteForByte) {
  auto scene = ImportFile(VectorPath("octahedron.obj"));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  for (int version : {3, 2}) {
    SCOPED_TRACE("version " + std::to_string(version));
    const std::string name = "octahedron-qp8-bundled-v" + std::to_string(version);
    ProgressiveGlbOptions options = test_util::VectorOptions();
    options.stream.version = static_cast<uint8_t>(version);
    auto glb = EncodeProgressiveGlb(scene.value(), options, nullptr);
    ASSERT_TRUE(glb.ok()) << glb.status().ToString();
    EXPECT_EQ(glb.value(), test_util::ReadBytes(VectorPath(name + ".glb")));
    EXPECT_EQ(BlobOf(glb.value()), test_util::ReadBytes(VectorPath(name + ".msps")));
  }
}

TEST(TestVector, TheStreamBlobHasTheDocumentedFields) {
  const std::vector<uint8_t> blob = test_util::ReadBytes(VectorPath("octahedron-qp8-bundled.msps"));
  auto stream = ProgressiveStream::Parse(blob.data(), blob.size());
  ASSERT_TRUE(stream.ok()) << stream.status().ToString();
  EXPECT_EQ(stream->header.size(), 45u);
  ASSERT_EQ(stream->control.size(), 1u);
  EXPECT_EQ(stream->control[0].size(), 17u);
  ASSERT_EQ(stream->datagrams[0].size(), 1u);
  EXPECT_EQ(stream->datagrams[0][0].size(), 19u);
  auto header = StreamHeader::Parse(stream->header.data(), stream->header.size());
  ASSERT_TRUE(header.ok()) << header.status().ToString();
  EXPECT_EQ(header->packing, Packing::kBundled);
  EXPECT_EQ(header->version, 4);
  EXPECT_EQ(header->profile, Profile::kLossTolerant);
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

// The reliable profile's vector (section 9, "The reliable profile's vector").
TEST(TestVector, TheReliableVectorHasTheDocumentedFields) {
  const std::vector<uint8_t> blob = test_util::ReadBytes(VectorPath("octahedron-qp8-reliable.msps"));
  auto stream = ProgressiveStream::Parse(blob.data(), blob.size());
  ASSERT_TRUE(stream.ok()) << stream.status().ToString();
  EXPECT_EQ(stream->header.size(), 45u);
  ASSERT_EQ(stream->control.size(), 1u);
  EXPECT_EQ(stream->control[0].size(), 23u);
  ASSERT_EQ(stream->datagrams[0].size(), 0u) << "no datagrams";
  auto header = StreamHeader::Parse(stream->header.data(), stream->header.size());
  ASSERT_TRUE(header.ok()) << header.status().ToString();
  EXPECT_EQ(header->version, 4);
  EXPECT_EQ(header->profile, Profile::kReliable);
  EXPECT_EQ(header->packing, Packing::kSplit) << "the byte is 0";
  EXPECT_EQ(header->tools, kToolGeometryPrediction | kToolLocalFrame | kToolWingRank | kToolAttributePrediction |
                               kToolRingPredictor);
  // The control block: split bits (a 5-byte block), the predictor record 0,
  // then the 16-byte payload of the three splits.
  const std::vector<uint8_t>& c = stream->control[0];
  EXPECT_EQ(c[0], 5);
  EXPECT_EQ(c[6], 0);
  EXPECT_EQ(c.size() - 7, 16u);
}

// The reliable profile's split bits (section 11), in the contexts the spec
// lists for the vector: from the base's connectivity as the decoder has it.
TEST(TestVector, ReliableSplitBitContextsAreTheDocumentedOnes) {
  const std::vector<uint8_t> stored = test_util::ReadBytes(VectorPath("octahedron-qp8-reliable.glb"));
  ProgressiveDecodeOptions options;
  options.lod = 0;
  auto scene = DecodeProgressiveGlb(stored, options, nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  const Primitive& base = scene->meshes[0].primitives[0];
  SplitConnectivity mesh;
  ASSERT_TRUE(mesh.Reset(static_cast<uint32_t>(base.vertex_count()), base.indices).ok());
  ConnectedSplitBits coder;
  coder.Reset(mesh);
  std::vector<uint8_t> bits(15, 0);
  bits[1] = bits[8] = bits[11] = 1;
  EXPECT_EQ(coder.Contexts(bits, mesh, nullptr),
            (std::vector<int>{6, 7, 15, 15, 16, 15, 16, 7, 7, 15, 6, 7, 15, 15, 25}));
  const std::vector<uint8_t> block = coder.Encode(bits, mesh, nullptr);
  EXPECT_EQ(block, (std::vector<uint8_t>{0x40, 0x9F, 0x24, 0x2B, 0xE4}));
  ConnectedSplitBits fresh;
  fresh.Reset(mesh);
  auto decoded = fresh.Decode(block.data(), block.size(), mesh, nullptr);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  EXPECT_EQ(decoded->bits, bits);
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

// The vectors of version 4 (both profiles) and those of versions 3, 2 and 1
// (which a version 4 decoder still reads) give the same mesh.
TEST(TestVector, DecodesToTheDocumentedMesh) {
  for (const char* file : {"octahedron-qp8-bundled.glb", "octahedron-qp8-reliable.glb", "octahedron-qp8-bundled-v3.glb",
                           "octahedron-qp8-bundled-v2.glb", "octahedron-qp8-bundled-v1.glb"}) {
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

// Golden files of the released progressive formats (docs/spec/progressive-format.md,
// versions 1, 2 and 3). They were written once by `meshstream encode` and must
// decode forever, to the same levels and losslessly against their sources:
//   fandisk-qp11-v1.glb:          encode fandisk.obj (qp 11, split packing, 1200 bytes), version 1
//   spot-qp11-bundled-v1.glb:     encode spot.obj --packing bundled --packet-bytes 600, version 1
//   fandisk-qp11-v2.glb, spot-qp11-bundled-v2.glb: the same with version 2 (tools 15)
//   horse-qp11-v2.glb:            encode horse.ply (normals predicted), version 2
//   spot-qp11-bundled-v2-tools31.glb: spot.obj as above, version 2 with texture
//                                 coordinate prediction (tools 31)
//   spot-qp11-bundled-v2-tools63.glb: the same with seams collapsed on both
//                                 sides (tools 63): a smaller base
//   fandisk-qp11-v3.glb, horse-qp11-v3.glb: as above, version 3 (tools 79,
//                                 split bits in context)
//   spot-qp11-bundled-v3.glb:     spot.obj --packing bundled --packet-bytes 600,
//                                 version 3 (tools 255: and model modes)
//   spot-qp11-bundled-v3-tools511.glb: the same with the ring predictor
//                                 (tools 511)
//   fandisk-qp11-v3-ring.glb:     encode fandisk.obj --ring-term-bits 0: the ring
//                                 predictor with its 2-ring term in refinement 20
// Never regenerate them for a format change: bump the version (or add a tool
// bit) and add new files.
#include <set>

#include <gtest/gtest.h>

#include "codec/bitstream/format.h"
#include "codec/bitstream/slot_model.h"
#include "codec/core/byte_io.h"
#include "codec/entropy/symbol_model.h"
#include "codec/metrics/grid_equality.h"
#include "codec/mesh/quantization.h"
#include "codec/mesh/scene_flatten.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "testing/test_util.h"
#include "tests/common/test_vector.h"

namespace meshstream {
namespace {

struct Golden {
  const char* file;
  const char* source;
  std::vector<uint32_t> level_vertices;
  std::vector<std::string> attributes;
};

// Vertices per level of the models' hierarchies (the same in every format
// version and packing: they come from the simplifier).
const std::vector<uint32_t> kFandiskLevels = {130,  153,  180,  214,  253,  301,  354,  419,  497,  591,  697,  820,
                                              976,  1161, 1379, 1645, 1952, 2318, 2743, 3265, 3891, 4610, 5485, 6475};
const std::vector<uint32_t> kSpotLevels = {642,  645,  648,  656,  664,  675,  689,  706,  733,  764,  804,  853,
                                           912,  980,  1066, 1169, 1299, 1449, 1631, 1847, 2103, 2412, 2800, 3225};

const std::vector<uint32_t> kSpotSeamLevels = {235,  251,  270,  289,  319,  353,  393,  443,  497,  572, 664,
                                               771,  904,  1052, 1225, 1432, 1688, 1983, 2349, 2761, 3225};

const std::vector<uint32_t> kHorseLevels = {938,   1114,  1321,  1565,  1863,  2217,  2633,  3123,
                                            3720,  4420,  5252,  6249,  7432,  8822,  10473, 12438,
                                            14773, 17529, 20790, 24676, 29299, 34773, 41326, 48485};

const std::vector<Golden>& Goldens() {
  static const std::vector<Golden> goldens = {
      {"fandisk-qp11-v1.glb", "fandisk.obj",
       kFandiskLevels,
       {"POSITION"}},
      {"spot-qp11-bundled-v1.glb", "spot.obj",
       kSpotLevels,
       {"POSITION", "TEXCOORD_0"}},
      {"fandisk-qp11-v2.glb", "fandisk.obj",
       kFandiskLevels,
       {"POSITION"}},
      {"spot-qp11-bundled-v2.glb", "spot.obj",
       kSpotLevels,
       {"POSITION", "TEXCOORD_0"}},
      {"spot-qp11-bundled-v2-tools31.glb", "spot.obj",
       kSpotLevels,
       {"POSITION", "TEXCOORD_0"}},
      {"spot-qp11-bundled-v2-tools63.glb", "spot.obj",
       kSpotSeamLevels,
       {"POSITION", "TEXCOORD_0"}},
      {"horse-qp11-v2.glb", "horse.ply", kHorseLevels, {"POSITION", "NORMAL"}},
      {"fandisk-qp11-v3.glb", "fandisk.obj", kFandiskLevels, {"POSITION"}},
      {"spot-qp11-bundled-v3.glb", "spot.obj", kSpotSeamLevels, {"POSITION", "TEXCOORD_0"}},
      {"horse-qp11-v3.glb", "horse.ply", kHorseLevels, {"POSITION", "NORMAL"}},
      {"spot-qp11-bundled-v3-tools511.glb", "spot.obj", kSpotSeamLevels, {"POSITION", "TEXCOORD_0"}},
      {"fandisk-qp11-v3-ring.glb", "fandisk.obj", kFandiskLevels, {"POSITION"}},
  };
  return goldens;
}

TEST(Golden, DecodesToEveryLevelAndLosslessly) {
  for (const Golden& g : Goldens()) {
    auto bytes = ReadFileBytes(test_util::SourcePath(std::string("tests/data/golden/") + g.file), kDefaultMaxInputBytes);
    ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
    for (size_t lod = 0; lod < g.level_vertices.size(); ++lod) {
      ProgressiveDecodeOptions options;
      options.lod = static_cast<int>(lod);
      ProgressiveDecodeReport report;
      auto scene = DecodeProgressiveGlb(bytes.value(), options, &report);
      ASSERT_TRUE(scene.ok()) << g.file << " lod " << lod << ": " << scene.status().ToString();
      EXPECT_EQ(report.level_vertices, g.level_vertices) << g.file;
      // Version 3's files code their split bits in context (the tool that defines it).
      EXPECT_EQ((report.tools & kToolSplitContexts) != 0, std::string(g.file).find("-v3") != std::string::npos)
          << g.file;
      EXPECT_EQ(scene->total_vertices(), g.level_vertices[lod]) << g.file << " lod " << lod;
      EXPECT_EQ(scene->meshes[0].primitives[0].AttributeNames(), g.attributes) << g.file;
      if (lod + 1 == g.level_vertices.size()) {
        auto source = ImportFile(test_util::ModelPath(g.source));
        ASSERT_TRUE(source.ok());
        auto same = CompareOnGrid(FlattenScene(source.value()), FlattenScene(scene.value()), 11);
        ASSERT_TRUE(same.ok());
        EXPECT_TRUE(same->equal) << g.file << ": " << same->differing() << " triangles differ";
        // Texture coordinates come back on their grid: equal multisets of
        // (position, UV) on the source's grids.
        const Primitive& a = source->meshes[0].primitives[0];
        const Primitive& b = scene->meshes[0].primitives[0];
        if (!a.texcoords.empty()) {
          auto pos_grid = PositionGrid(a.positions, a.indices, 11);
          auto uv_grid = GridOf(a.texcoords[0], 10);
          ASSERT_TRUE(pos_grid.ok() && uv_grid.ok());
          auto keys = [&](const Primitive& p) {
            std::multiset<std::array<int64_t, 5>> out;
            for (size_t v = 0; v < p.vertex_count(); ++v) {
              out.insert({pos_grid->Quantize(p.positions[v][0], 0), pos_grid->Quantize(p.positions[v][1], 1),
                          pos_grid->Quantize(p.positions[v][2], 2), uv_grid->Quantize(p.texcoords[0][v][0], 0),
                          uv_grid->Quantize(p.texcoords[0][v][1], 1)});
            }
            return out;
          };
          EXPECT_TRUE(keys(a) == keys(b)) << g.file << ": UVs differ";
        }
      }
    }
  }
}

// The ring predictor's records of a stream without channels (section 5:
// split bits, five slots, the record): per refinement, the weights it sends
// (empty when it keeps the previous ones).
std::vector<std::vector<int32_t>> PredictorRecords(const std::vector<uint8_t>& glb) {
  std::vector<std::vector<int32_t>> out;
  const std::vector<uint8_t> blob = test_util::BlobOf(glb);
  auto stream = ProgressiveStream::Parse(blob.data(), blob.size());
  if (!stream.ok()) return out;
  for (const std::vector<uint8_t>& control : stream->control) {
    ByteReader r(control.data(), control.size());
    size_t length = 0;
    r.Block("split bits", &length).value();
    for (int k = 0; k < 5; ++k) {
      const uint8_t mode = r.U8("mode").value();
      if (mode == static_cast<uint8_t>(ModelMode::kParametric)) r.U8("parameter").value();
      else if (mode != static_cast<uint8_t>(ModelMode::kReuse)) StaticModel::Parse(r).value();
    }
    std::vector<int32_t> weights;
    if (r.U8("record").value() == 1) {
      for (int k = 0; k < 6; ++k) weights.push_back(UnZigZag(static_cast<uint32_t>(r.Varint("weight", 1 << 16).value())));
    }
    out.push_back(weights);
  }
  return out;
}

// The ring file pins the 2-ring term's arithmetic: some refinement's weights read it.
TEST(Golden, TheRingFileReadsTheTwoRing) {
  auto bytes = ReadFileBytes(test_util::SourcePath("tests/data/golden/fandisk-qp11-v3-ring.glb"), kDefaultMaxInputBytes);
  ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
  const auto records = PredictorRecords(bytes.value());
  ASSERT_EQ(records.size(), kFandiskLevels.size() - 1);
  bool ring = false;
  for (const auto& w : records) ring |= w.size() == 6 && (w[2] != 0 || w[5] != 0);
  EXPECT_TRUE(ring);
}

}  // namespace
}  // namespace meshstream

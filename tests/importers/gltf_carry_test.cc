// What the codec does not refine is carried through unchanged
// (docs/spec/gltf-support.md, "Carried through"): points and lines primitives,
// skinned and morphed primitives, skins, animations. Each round trip (export
// to .glb and .gltf, plain and --draco; progressive encode and decode at
// every level) gives back byte-equal carried data, the Khronos validator
// reports no error, and the refinable triangles still decode losslessly.
// Hostile carried data is refused with the JSON path named.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "codec/metrics/grid_equality.h"
#include "importers/gltf_export.h"
#include "importers/gltf_import.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "tests/common/carry_util.h"
#include "tests/common/cli_util.h"

namespace meshstream {
namespace {

using json = nlohmann::json;
using test_util::CarriedSummary;
using test_util::ModelPath;
using test_util::TempDir;

const char kMorphCube[] = "gltf/AnimatedMorphCube/AnimatedMorphCube.gltf";
const char kSimpleSkin[] = "gltf/simple_skin/simple_skin.gltf";

Scene MustImport(const std::string& path) {
  auto scene = ImportFile(path);
  EXPECT_TRUE(scene.ok()) << path << ": " << scene.status().ToString();
  return scene.ok() ? std::move(scene).value() : Scene{};
}

int ValidatorErrors(const std::string& file) {
  const auto reports = test_util::ValidateGltf({file});
  if (reports.empty() || !reports[0].is_object()) return -1;
  EXPECT_EQ(reports[0]["errors"], 0) << file << ": " << reports[0].dump();
  return reports[0].value("errors", -1);
}

// The three sources: what each is known to hold, so that an importer that
// carried nothing could not pass the equality tests below.
TEST(GltfCarry, ImportKeepsWhatItDoesNotRefine) {
  TempDir dir;
  const Scene morph = MustImport(ModelPath(kMorphCube));
  ASSERT_EQ(morph.meshes.size(), 1u);
  EXPECT_TRUE(morph.meshes[0].primitives.empty());
  ASSERT_EQ(morph.meshes[0].carried.size(), 1u);
  const CarriedPrimitive& cube = morph.meshes[0].carried[0];
  EXPECT_EQ(cube.targets.size(), 2u);
  EXPECT_EQ(cube.attributes.size(), 3u);  // NORMAL, POSITION, TANGENT: nothing dropped
  EXPECT_EQ(morph.meshes[0].weights, (std::vector<double>{0, 0}));
  ASSERT_EQ(morph.animations.size(), 1u);
  EXPECT_EQ(morph.animations[0].name, "Square");
  EXPECT_EQ(morph.animations[0].channels[0].path, "weights");

  const Scene skin = MustImport(ModelPath(kSimpleSkin));
  ASSERT_EQ(skin.skins.size(), 1u);
  EXPECT_EQ(skin.skins[0].joints, (std::vector<int32_t>{1, 2}));
  ASSERT_GE(skin.skins[0].inverse_bind_matrices, 0);
  EXPECT_EQ(skin.carried_accessors[skin.skins[0].inverse_bind_matrices].count, 2u);
  EXPECT_EQ(skin.nodes[0].skin, 0);
  ASSERT_EQ(skin.meshes[0].carried.size(), 1u);
  EXPECT_EQ(skin.animations.size(), 1u);
  EXPECT_EQ(skin.animations[0].channels[0].node, 2);

  const Scene helpers = MustImport(test_util::WritePointsLinesScene(dir.path()));
  ASSERT_EQ(helpers.meshes.size(), 1u);
  ASSERT_EQ(helpers.meshes[0].primitives.size(), 1u);  // the sphere
  EXPECT_EQ(helpers.meshes[0].primitives[0].face_count(), 8u * 12 * 2 - 2 * 12);
  ASSERT_EQ(helpers.meshes[0].carried.size(), 3u);
  EXPECT_EQ(helpers.meshes[0].carried[0].slot, 0u);
  EXPECT_EQ(helpers.meshes[0].carried[0].mode, 0);
  EXPECT_EQ(helpers.meshes[0].carried[1].slot, 2u);
  EXPECT_EQ(helpers.meshes[0].carried[1].mode, 1);
  EXPECT_EQ(helpers.meshes[0].carried[2].mode, 3);
  // The strip shares the lines' positions: one carried accessor for both.
  EXPECT_EQ(helpers.meshes[0].carried[1].attributes[0].second, helpers.meshes[0].carried[2].attributes[0].second);
  const CarriedAccessor& colors = helpers.carried_accessors[helpers.meshes[0].carried[0].attributes[0].first == "COLOR_0"
                                                                ? helpers.meshes[0].carried[0].attributes[0].second
                                                                : helpers.meshes[0].carried[0].attributes[1].second];
  EXPECT_TRUE(colors.normalized);
  EXPECT_EQ(colors.bytes, (std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 10, 20, 30, 40, 255,
                                                255, 255, 128}));
  EXPECT_TRUE(helpers.warnings.empty()) << helpers.warnings[0];
}

struct Source {
  std::string name;
  std::string path;
};

std::vector<Source> Sources(const TempDir& dir) {
  return {{"AnimatedMorphCube", ModelPath(kMorphCube)},
          {"simple_skin", ModelPath(kSimpleSkin)},
          {"points_lines", test_util::WritePointsLinesScene(dir.path())}};
}

TEST(GltfCarry, ExportRoundTripsKeepCarriedDataAndValidate) {
  TempDir dir;
  for (const Source& src : Sources(dir)) {
    const Scene input = MustImport(src.path);
    const json expected = CarriedSummary(input);
    for (const char* ext : {".glb", ".gltf"}) {
      for (bool draco : {false, true}) {
        ExportOptions options;
        options.draco = draco;
        const std::string out = dir.File(src.name + (draco ? "-draco" : "") + ext);
        ASSERT_TRUE(ExportGltfFile(input, out, options).ok()) << out;
        EXPECT_EQ(ValidatorErrors(out), 0) << out;
        const Scene back = MustImport(out);
        EXPECT_EQ(CarriedSummary(back), expected) << out;
        EXPECT_EQ(back.total_faces(), input.total_faces()) << out;
        if (!draco) {
          // Plain exports are a fixed point: exporting again changes nothing.
          ExportOptions plain;
          auto once = ExportGlb(input, plain), twice = ExportGlb(back, plain);
          ASSERT_TRUE(once.ok() && twice.ok());
          EXPECT_EQ(once.value(), twice.value()) << out;
        }
      }
    }
  }
}

TEST(GltfCarry, ProgressiveEncodeStoresCarriedDataAsPlainGltfAtEveryLevel) {
  TempDir dir;
  for (const Source& src : Sources(dir)) {
    const Scene input = MustImport(src.path);
    const json expected = CarriedSummary(input);
    ProgressiveGlbOptions options;
    ProgressiveGlbReport report;
    auto glb = EncodeProgressiveGlb(input, options, &report);
    ASSERT_TRUE(glb.ok()) << src.name << ": " << glb.status().ToString();
    EXPECT_EQ(report.primitives.size(), input.total_primitives()) << src.name;  // refined ones only
    const std::string encoded = dir.File(src.name + ".progressive.glb");
    ASSERT_TRUE(WriteFileBytes(encoded, glb.value()).ok());
    EXPECT_EQ(ValidatorErrors(encoded), 0) << encoded;
    size_t levels = 0;
    for (const auto& p : report.primitives) levels = std::max(levels, p.level_vertices.size() - 1);
    if (src.name == "points_lines") {
      EXPECT_GT(levels, 0u) << "the sphere should have refinements";
    }
    for (int lod = 0; lod <= static_cast<int>(levels); ++lod) {
      ProgressiveDecodeOptions decode;
      decode.lod = lod;
      auto scene = DecodeProgressiveGlb(glb.value(), decode, nullptr);
      ASSERT_TRUE(scene.ok()) << src.name << " lod " << lod << ": " << scene.status().ToString();
      EXPECT_EQ(CarriedSummary(scene.value()), expected) << src.name << " lod " << lod;
      const std::string out = dir.File(src.name + "-lod" + std::to_string(lod) + ".glb");
      ASSERT_TRUE(ExportGltfFile(scene.value(), out, {}).ok());
      EXPECT_EQ(ValidatorErrors(out), 0) << out;
      EXPECT_EQ(CarriedSummary(MustImport(out)), expected) << out;
      if (lod == static_cast<int>(levels)) {
        // Every level applied: the refinable triangles come back on the grid.
        for (size_t m = 0; m < input.meshes.size(); ++m) {
          for (size_t k = 0; k < input.meshes[m].primitives.size(); ++k) {
            auto same = CompareOnGrid(input.meshes[m].primitives[k], scene->meshes[m].primitives[k],
                                      options.encode.quantization.qp);
            ASSERT_TRUE(same.ok());
            EXPECT_TRUE(same->equal) << src.name << " meshes[" << m << "].primitives[" << k << "]";
          }
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------
// Names that are not valid UTF-8. nlohmann's parser (and so tinygltf's)
// refuses such a document whole ("invalid string: ill-formed UTF-8 byte");
// the importer repairs the text with ToValidUtf8 first and says so.

TEST(GltfCarry, InvalidUtf8NamesAreRepairedWithAWarning) {
  TempDir dir;
  Scene source = MustImport(ModelPath(kSimpleSkin));
  // Give three objects marker names, then break their bytes inside the JSON chunk.
  Scene scene = source;
  scene.meshes[0].name = "MESHNAME";
  scene.nodes[1].name = "NODENAME";
  scene.animations[0].name = "ANIMNAME";
  auto named = ExportGlb(scene, {});
  ASSERT_TRUE(named.ok());
  std::vector<uint8_t> bytes = named.value();
  const std::string text(bytes.begin(), bytes.end());
  for (const char* marker : {"MESHNAME", "NODENAME", "ANIMNAME"}) {
    const size_t at = text.find(marker);
    ASSERT_NE(at, std::string::npos);
    bytes[at + 1] = 0xC3;  // a lead byte followed by ASCII: ill-formed
    bytes[at + 4] = 0xFF;  // never valid in UTF-8
  }
  // What the JSON library alone does with it.
  const uint32_t json_len = bytes[12] | (bytes[13] << 8) | (bytes[14] << 16) | (uint32_t(bytes[15]) << 24);
  EXPECT_TRUE(json::parse(bytes.begin() + 20, bytes.begin() + 20 + json_len, nullptr, false).is_discarded());

  auto repaired = ImportGltfBytes(bytes, "", "bad-utf8.glb", {});
  ASSERT_TRUE(repaired.ok()) << repaired.status().ToString();
  ASSERT_FALSE(repaired->warnings.empty());
  EXPECT_NE(repaired->warnings[0].find("UTF-8"), std::string::npos) << repaired->warnings[0];
  EXPECT_EQ(repaired->meshes[0].name, "M\xEF\xBF\xBD" "SH\xEF\xBF\xBD" "AME");
  EXPECT_EQ(repaired->nodes[1].name, "N\xEF\xBF\xBD" "DE\xEF\xBF\xBD" "AME");
  EXPECT_EQ(repaired->animations[0].name, "A\xEF\xBF\xBD" "IM\xEF\xBF\xBD" "AME");
  EXPECT_EQ(CarriedSummary(repaired.value())["skins"], CarriedSummary(source)["skins"]);
  const std::string out = dir.File("repaired.glb");
  ASSERT_TRUE(ExportGltfFile(repaired.value(), out, {}).ok());
  EXPECT_EQ(ValidatorErrors(out), 0);

  // A scene built in code with a bad name still writes (the writer replaces).
  Scene built = source;
  built.meshes[0].name = std::string("bad\xC3(", 5);
  auto written = ExportGlb(built, {});
  ASSERT_TRUE(written.ok());
  auto reread = ImportGltfBytes(written.value(), "", "written.glb", {});
  ASSERT_TRUE(reread.ok()) << reread.status().ToString();
  EXPECT_EQ(reread->meshes[0].name, "bad\xEF\xBF\xBD(");
}

// ---------------------------------------------------------------------------
// Hostile carried data: refused, naming the JSON path.

json SkinDoc() {
  return json::parse(test_util::ReadText(ModelPath(kSimpleSkin)));
}

StatusOr<Scene> ImportDoc(const json& doc) {
  const std::string text = doc.dump();
  // simple_skin keeps its buffer in a data: URI, so no folder is needed.
  return ImportGltfBytes(std::vector<uint8_t>(text.begin(), text.end()), "", "hostile.gltf", {});
}

void ExpectRefused(const json& doc, StatusCode code, const std::vector<std::string>& words) {
  auto scene = ImportDoc(doc);
  ASSERT_FALSE(scene.ok()) << "accepted: " << doc.dump().substr(0, 200);
  EXPECT_EQ(scene.status().code(), code) << scene.status().ToString();
  for (const std::string& w : words) {
    EXPECT_NE(scene.status().message().find(w), std::string::npos) << "'" << w << "' not in: " << scene.status().message();
  }
}

TEST(GltfCarryHostile, SourceDocumentImports) { ASSERT_TRUE(ImportDoc(SkinDoc()).ok()); }

TEST(GltfCarryHostile, SkinJointNamingAMissingNode) {
  json doc = SkinDoc();
  doc["skins"][0]["joints"][1] = 7;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"skins[0].joints[1]", "node 7"});
  doc = SkinDoc();
  doc["skins"][0]["skeleton"] = 99;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"skins[0].skeleton"});
  doc = SkinDoc();
  doc["nodes"][0]["skin"] = 3;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"nodes[0].skin 3"});
}

TEST(GltfCarryHostile, InverseBindMatricesOutOfRangeOrTooFew) {
  json doc = SkinDoc();
  doc["skins"][0]["inverseBindMatrices"] = 40;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"skins[0].inverseBindMatrices", "40"});
  doc = SkinDoc();
  doc["accessors"][4]["count"] = 1;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"skins[0].inverseBindMatrices"});
  doc = SkinDoc();
  doc["accessors"][4]["count"] = 100000;  // beyond its bufferView
  ExpectRefused(doc, StatusCode::kInvalidInput, {"accessors[4]"});
}

TEST(GltfCarryHostile, AnimationChannelTargetingAMissingNode) {
  json doc = SkinDoc();
  doc["animations"][0]["channels"][0]["target"]["node"] = 12;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"animations[0].channels[0]"});
  doc = SkinDoc();
  doc["animations"][0]["channels"][0]["sampler"] = 5;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"animations[0].channels[0].sampler"});
  doc = SkinDoc();
  doc["animations"][0]["samplers"][0]["output"] = 77;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"animations[0].samplers[0].output"});
  doc = SkinDoc();
  doc["animations"][0]["samplers"][0]["input"] = 4;  // a MAT4, not key times
  ExpectRefused(doc, StatusCode::kInvalidInput, {"animations[0].samplers[0].input"});
}

TEST(GltfCarryHostile, CarriedPrimitiveAccessorsOutOfRange) {
  json doc = SkinDoc();
  doc["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"] = 50;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"meshes[0].primitives[0].JOINTS_0", "50"});
  doc = SkinDoc();
  doc["accessors"][3]["count"] = 9;  // WEIGHTS_0 shorter than POSITION
  ExpectRefused(doc, StatusCode::kInvalidInput, {"meshes[0].primitives[0]", "WEIGHTS_0"});
  doc = SkinDoc();
  doc["accessors"][2]["byteOffset"] = 1 << 20;  // JOINTS_0 outside its bufferView
  ExpectRefused(doc, StatusCode::kInvalidInput, {"accessors[2]", "bufferViews[2]"});
  doc = SkinDoc();
  doc["accessors"][1]["count"] = 5;  // indices now reach past the vertices
  doc["accessors"][1].erase("max");
  doc["accessors"][2]["count"] = 5;
  doc["accessors"][3]["count"] = 5;
  ExpectRefused(doc, StatusCode::kInvalidInput, {"meshes[0].primitives[0]", "out of range"});
  doc = SkinDoc();
  doc["meshes"][0]["primitives"][0]["targets"] = json::array({{{"POSITION", 60}}});
  ExpectRefused(doc, StatusCode::kInvalidInput, {"meshes[0].primitives[0].targets[0].POSITION"});
}

TEST(GltfCarryHostile, DracoCompressedSkinnedPrimitiveIsUnsupported) {
  json doc = SkinDoc();
  doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"] = {{"bufferView", 0},
                                                                                   {"attributes", {{"POSITION", 0}}}};
  doc["extensionsUsed"] = json::array({"KHR_draco_mesh_compression"});
  ExpectRefused(doc, StatusCode::kUnsupported, {"meshes[0].primitives[0]", "Draco"});
}

}  // namespace
}  // namespace meshstream

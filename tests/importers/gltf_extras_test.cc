// Application data and lights survive every round trip (docs/spec/gltf-support.md):
// "extras" on meshes, nodes, scenes, carried primitives, skins and
// animations, and KHR_lights_punctual (the root's lights, each node's light),
// through import, export (.glb and .gltf, plain and Draco), and the
// progressive encode and decode at every level; each output passes the
// Khronos validator. Broken lights are refused naming the JSON path.
#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "importers/gltf_export.h"
#include "importers/gltf_import.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "tests/common/carry_util.h"
#include "tests/common/cli_util.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using nlohmann::json;
using test_util::ModelPath;
using test_util::TempDir;

// Every extras and light a Scene holds, parsed, for comparing two scenes.
json ExtrasSummary(const Scene& scene) {
  auto parsed = [](const std::string& text) { return text.empty() ? json() : json::parse(text); };
  json out = {{"lights", json::array()}};
  for (const std::string& light : scene.lights) out["lights"].push_back(json::parse(light));
  for (const Mesh& m : scene.meshes) {
    json carried = json::array();
    for (const CarriedPrimitive& p : m.carried) carried.push_back(parsed(p.extras_json));
    out["meshes"].push_back({{"extras", parsed(m.extras_json)}, {"carried", carried}});
  }
  for (const Node& n : scene.nodes) out["nodes"].push_back({{"extras", parsed(n.extras_json)}, {"light", n.light}});
  for (const SceneRoot& r : scene.scenes) out["scenes"].push_back(parsed(r.extras_json));
  for (const Skin& s : scene.skins) out["skins"].push_back(parsed(s.extras_json));
  for (const Animation& a : scene.animations) out["animations"].push_back(parsed(a.extras_json));
  return out;
}

Scene MustImport(const std::string& path) {
  auto scene = ImportFile(path);
  EXPECT_TRUE(scene.ok()) << path << ": " << scene.status().ToString();
  return scene.ok() ? std::move(scene).value() : Scene();
}

int ValidatorErrors(const std::string& file) {
  const auto reports = test_util::ValidateGltf({file});
  return reports.size() == 1 ? reports[0].value("errors", -1) : -1;
}

const json kLights = json::array({{{"type", "point"}, {"color", {1.0, 0.5, 0.25}}, {"intensity", 3.0}},
                                  {{"type", "spot"}, {"spot", {{"outerConeAngle", 0.5}}}, {"name", "key"}}});

// The points/lines/sphere scene with extras everywhere and two lights, one on
// a node of its own.
std::string WriteExtrasScene(const std::string& dir) {
  const std::string path = test_util::WritePointsLinesScene(dir);
  json doc = json::parse(test_util::ReadText(path));
  doc["meshes"][0]["extras"] = {{"targetNames", json::array()}, {"lod_bias", 2}};
  doc["meshes"][0]["primitives"][0]["extras"] = {{"role", "markers"}};
  doc["meshes"][0]["primitives"][2]["extras"] = {{"role", "outline"}, {"width", 1.5}};
  doc["nodes"][0]["extras"] = {{"blender", {{"prop", "h\xC3\xA9llo"}, {"list", {1, 2, 3}}}}};
  doc["nodes"][0]["extensions"]["KHR_lights_punctual"] = {{"light", 1}};
  doc["nodes"].push_back({{"name", "lamp"}, {"translation", {0, 2, 0}},
                          {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  doc["scenes"][0]["nodes"] = {0, 1};
  doc["scenes"][0]["extras"] = {{"level", "intro"}};
  doc["extensions"]["KHR_lights_punctual"] = {{"lights", kLights}};
  doc["extensionsUsed"] = {"KHR_lights_punctual"};
  test_util::WriteText(path, doc.dump(2));
  return path;
}

TEST(GltfExtras, ImportKeepsExtrasAndLights) {
  TempDir dir;
  const Scene scene = MustImport(WriteExtrasScene(dir.path()));
  const json s = ExtrasSummary(scene);
  EXPECT_EQ(s["lights"], kLights);
  EXPECT_EQ(s["nodes"][0]["light"], 1);
  EXPECT_EQ(s["nodes"][1]["light"], 0);
  EXPECT_EQ(s["nodes"][0]["extras"]["blender"]["prop"], "h\xC3\xA9llo");
  EXPECT_EQ(s["meshes"][0]["extras"]["lod_bias"], 2);
  EXPECT_EQ(s["meshes"][0]["carried"][0]["role"], "markers");  // the points (slot 0)
  EXPECT_EQ(s["meshes"][0]["carried"][1]["role"], "outline");  // the lines (slot 2)
  EXPECT_TRUE(s["meshes"][0]["carried"][2].is_null());         // the strip has none
  EXPECT_EQ(s["scenes"][0]["level"], "intro");
  for (const std::string& w : scene.warnings) EXPECT_EQ(w.find("KHR_lights_punctual"), std::string::npos) << w;
}

TEST(GltfExtras, ExtrasOfARefinedPrimitiveAreDroppedWithAWarning) {
  TempDir dir;
  const std::string path = WriteExtrasScene(dir.path());
  json doc = json::parse(test_util::ReadText(path));
  doc["meshes"][0]["primitives"][1]["extras"] = {{"role", "body"}};  // the sphere, which is refined
  test_util::WriteText(path, doc.dump());
  const Scene scene = MustImport(path);
  EXPECT_TRUE(std::any_of(scene.warnings.begin(), scene.warnings.end(), [](const std::string& w) {
    return w.find("meshes[0].primitives[1]: extras of a refined primitive dropped") != std::string::npos;
  }));
}

TEST(GltfExtras, ExportAndProgressiveRoundTripsKeepThem) {
  TempDir dir;
  std::vector<std::string> sources = {WriteExtrasScene(dir.path())};
  // simple_skin with extras on its skin and animation.
  json skin = json::parse(test_util::ReadText(ModelPath("gltf/simple_skin/simple_skin.gltf")));
  skin["skins"][0]["extras"] = {{"rig", "arm"}};
  skin["animations"][0]["extras"] = {{"loop", true}};
  sources.push_back(dir.File("simple_skin_extras.gltf"));
  test_util::WriteText(sources.back(), skin.dump());
  for (const std::string& src : sources) {
    const Scene input = MustImport(src);
    const json expected = ExtrasSummary(input);
    for (bool draco : {false, true}) {
      for (const char* ext : {".glb", ".gltf"}) {
        const std::string out = dir.File(std::string("out") + (draco ? "-draco" : "") + ext);
        ExportOptions options;
        options.draco = draco;
        ASSERT_TRUE(ExportGltfFile(input, out, options).ok()) << out;
        EXPECT_EQ(ValidatorErrors(out), 0) << src << " -> " << out;
        EXPECT_EQ(ExtrasSummary(MustImport(out)), expected) << src << " -> " << out;
      }
    }
    auto glb = EncodeProgressiveGlb(input, ProgressiveGlbOptions(), nullptr);
    ASSERT_TRUE(glb.ok()) << glb.status().ToString();
    const std::string encoded = dir.File("progressive.glb");
    ASSERT_TRUE(WriteFileBytes(encoded, glb.value()).ok());
    EXPECT_EQ(ValidatorErrors(encoded), 0) << src;
    for (int lod : {0, -1}) {
      ProgressiveDecodeOptions decode;
      decode.lod = lod;
      auto scene = DecodeProgressiveGlb(glb.value(), decode, nullptr);
      ASSERT_TRUE(scene.ok()) << scene.status().ToString();
      EXPECT_EQ(ExtrasSummary(scene.value()), expected) << src << " lod " << lod;
    }
  }
}

StatusOr<Scene> ImportText(const json& doc, const std::string& dir) {
  const std::string path = dir + "/hostile.gltf";
  test_util::WriteText(path, doc.dump());
  return ImportFile(path);
}

TEST(GltfExtras, BrokenLightsAreRefusedNamingThePath) {
  TempDir dir;
  const json good = json::parse(test_util::ReadText(WriteExtrasScene(dir.path())));
  struct Case {
    std::function<void(json&)> patch;
    std::string words;
  };
  const std::vector<Case> cases = {
      {[](json& d) { d["nodes"][1]["extensions"]["KHR_lights_punctual"]["light"] = 2; },
       "nodes[1].extensions.KHR_lights_punctual.light 2 does not exist"},
      {[](json& d) { d["nodes"][1]["extensions"]["KHR_lights_punctual"]["light"] = "0"; },
       "nodes[1].extensions.KHR_lights_punctual.light must be an integer"},
      {[](json& d) { d["extensions"]["KHR_lights_punctual"]["lights"] = {{"type", "point"}}; },
       "extensions.KHR_lights_punctual.lights must be an array"},
      {[](json& d) { d["extensions"]["KHR_lights_punctual"]["lights"][1]["type"] = "area"; },
       "extensions.KHR_lights_punctual.lights[1].type \"area\" is not directional, point or spot"},
      {[](json& d) { d["extensions"].erase("KHR_lights_punctual"); },
       "nodes[0].extensions.KHR_lights_punctual.light 1 does not exist"},
  };
  for (const Case& c : cases) {
    json doc = good;
    c.patch(doc);
    auto scene = ImportText(doc, dir.path());
    ASSERT_FALSE(scene.ok()) << c.words;
    EXPECT_EQ(scene.status().code(), StatusCode::kInvalidInput) << scene.status().ToString();
    EXPECT_NE(scene.status().message().find(c.words), std::string::npos) << scene.status().message();
  }
}

}  // namespace
}  // namespace meshstream

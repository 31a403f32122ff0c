// The CLI verbs keep what the codec does not refine (docs/spec/gltf-support.md,
// "Carried through"): `convert` (to .glb and .gltf, plain and --draco),
// `encode` and `decode` at every --lod of AnimatedMorphCube, simple_skin and a
// scene of points, lines and a refinable sphere. Every output passes the
// Khronos validator with 0 errors and holds byte-equal carried data.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "importers/import.h"
#include "tests/common/carry_util.h"
#include "tests/common/cli_util.h"

namespace meshstream {
namespace {

using nlohmann::json;
using test_util::CarriedSummary;
using test_util::Cli;
using test_util::ModelPath;
using test_util::Quote;
using test_util::RunCommand;
using test_util::TempDir;

json Summary(const std::string& path) {
  auto scene = ImportFile(path);
  EXPECT_TRUE(scene.ok()) << path << ": " << scene.status().ToString();
  return scene.ok() ? CarriedSummary(scene.value()) : json();
}

void ExpectValid(const std::string& file) {
  const auto reports = test_util::ValidateGltf({file});
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0]["errors"], 0) << file << ": " << reports[0].dump();
}

struct Source {
  std::string name;
  std::string path;
};

std::vector<Source> Sources(const TempDir& dir) {
  return {{"AnimatedMorphCube", ModelPath("gltf/AnimatedMorphCube/AnimatedMorphCube.gltf")},
          {"simple_skin", ModelPath("gltf/simple_skin/simple_skin.gltf")},
          {"points_lines", test_util::WritePointsLinesScene(dir.path())}};
}

TEST(CarryCli, ConvertKeepsSkinsMorphsAnimationsPointsAndLines) {
  TempDir dir;
  for (const Source& src : Sources(dir)) {
    const json expected = Summary(src.path);
    ASSERT_FALSE(expected.is_null());
    for (const char* flags : {"", "--draco"}) {
      for (const char* ext : {".glb", ".gltf"}) {
        const std::string out = dir.File(src.name + (*flags ? "-draco" : "") + ext);
        const auto r = RunCommand(Cli() + " convert --quiet " + flags + " " + Quote(src.path) + " " + Quote(out));
        ASSERT_EQ(r.exit_code, 0) << src.name << " " << flags << ": " << r.err;
        ExpectValid(out);
        EXPECT_EQ(Summary(out), expected) << out;
      }
    }
  }
}

TEST(CarryCli, EncodeAndDecodeAtEveryLodKeepCarriedData) {
  TempDir dir;
  for (const Source& src : Sources(dir)) {
    const json expected = Summary(src.path);
    const std::string glb = dir.File(src.name + ".progressive.glb");
    const auto r = RunCommand(Cli() + " encode --json " + Quote(src.path) + " -o " + Quote(glb));
    ASSERT_EQ(r.exit_code, 0) << src.name << ": " << r.err;
    const json report = json::parse(r.out, nullptr, false);
    ASSERT_TRUE(report.is_object()) << r.out;
    ExpectValid(glb);
    EXPECT_EQ(Summary(glb), expected) << glb;
    const int levels = report.value("levels", 0);
    if (src.name == "points_lines") {
      EXPECT_GT(levels, 0);
    }
    for (int lod = 0; lod <= levels; ++lod) {
      for (const char* ext : {".glb", ".gltf"}) {
        const std::string out = dir.File(src.name + "-lod" + std::to_string(lod) + ext);
        const auto d = RunCommand(Cli() + " decode --lod " + std::to_string(lod) + " " + Quote(glb) + " -o " + Quote(out));
        ASSERT_EQ(d.exit_code, 0) << src.name << " lod " << lod << ": " << d.err;
        ExpectValid(out);
        EXPECT_EQ(Summary(out), expected) << out;
      }
    }
    // Without --lod: everything applied, the sphere back on the grid.
    const std::string full = dir.File(src.name + "-full.glb");
    ASSERT_EQ(RunCommand(Cli() + " decode " + Quote(glb) + " -o " + Quote(full)).exit_code, 0);
    if (src.name == "points_lines") {
      const json c = test_util::RunCliJson("compare --json --qp " + std::to_string(report.value("qp", 0)) + " " +
                                           Quote(src.path) + " " + Quote(full));
      EXPECT_EQ(c.value("same_on_grid", false), true) << c.dump();
    }
  }
}

TEST(CarryCli, InfoCountsWhatIsCarried) {
  TempDir dir;
  const json cube = test_util::RunCliJson(
      "info --json " + Quote(ModelPath("gltf/AnimatedMorphCube/AnimatedMorphCube.gltf")));
  EXPECT_EQ(cube.value("primitives", -1), 0) << cube.dump();  // its one triangle primitive is morphed
  EXPECT_EQ(cube.value("carried_primitives", -1), 1) << cube.dump();
  EXPECT_GE(cube.value("animations", -1), 1) << cube.dump();
  const json skin = test_util::RunCliJson("info --json " + Quote(ModelPath("gltf/simple_skin/simple_skin.gltf")));
  EXPECT_EQ(skin.value("skins", -1), 1) << skin.dump();
  EXPECT_EQ(skin.value("carried_primitives", -1), 1) << skin.dump();
  const json lines = test_util::RunCliJson("info --json " + Quote(test_util::WritePointsLinesScene(dir.path())));
  EXPECT_EQ(lines.value("primitives", -1), 1) << lines.dump();  // the sphere
  EXPECT_EQ(lines.value("carried_primitives", -1), 3) << lines.dump();
  const auto text = RunCommand(Cli() + " info " + Quote(ModelPath("gltf/simple_skin/simple_skin.gltf")));
  EXPECT_NE(text.out.find("carried as they are: primitives 1, skins 1"), std::string::npos) << text.out;
}

}  // namespace
}  // namespace meshstream

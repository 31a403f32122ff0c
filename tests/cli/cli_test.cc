// The CLI contract of build/bin/meshstream, run as a real process on the
// shared models, with the Khronos validator on every export.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/common/cli_util.h"

namespace meshstream {
namespace {

using nlohmann::json;
using test_util::Cli;
using test_util::ModelPath;
using test_util::Quote;
using test_util::RunCommand;
using test_util::TempDir;

const auto RunJson = test_util::RunCliJson;

json Validate(const std::string& file) {
  const auto reports = test_util::ValidateGltf({file});
  return reports.empty() ? json::object() : reports[0];
}

struct ModelCase {
  const char* file;
  uint64_t vertices;
  uint64_t faces;
  uint64_t unreferenced;
  std::vector<std::string> attributes;
};

const std::vector<ModelCase>& SharedModels() {
  static const std::vector<ModelCase> models = {
      {"stanford-bunny.obj", 35947, 69451, 1113, {"POSITION"}},
      {"horse.ply", 48485, 96966, 0, {"POSITION", "NORMAL"}},
      {"fandisk.obj", 6475, 12946, 0, {"POSITION"}},
      {"rocker-arm.obj", 10044, 20088, 0, {"POSITION"}},
      {"spot.obj", 2930, 5856, 0, {"POSITION", "TEXCOORD_0"}},
  };
  return models;
}

TEST(CliInfo, SharedModelsHaveTheBriefsCounts) {
  for (const ModelCase& m : SharedModels()) {
    const json info = RunJson("info --json " + Quote(ModelPath(m.file)));
    EXPECT_EQ(info["vertices"], m.vertices) << m.file;
    EXPECT_EQ(info["faces"], m.faces) << m.file;
    EXPECT_EQ(info["primitives"], 1) << m.file;
    EXPECT_EQ(info["unreferenced_vertices"], m.unreferenced) << m.file;
    EXPECT_EQ(info["attributes"], json(m.attributes)) << m.file;
    ASSERT_EQ(info["bbox_min"].size(), 3u);
    ASSERT_EQ(info["bbox_max"].size(), 3u);
    for (int c = 0; c < 3; ++c) EXPECT_LT(info["bbox_min"][c].get<double>(), info["bbox_max"][c].get<double>());
    EXPECT_TRUE(info.contains("degenerate_faces"));
    EXPECT_TRUE(info.contains("nonmanifold_edges"));
  }
}

TEST(CliInfo, SpotSplitsVerticesAtUvSeams) {
  const json info = RunJson("info --json " + Quote(ModelPath("spot.obj")));
  EXPECT_EQ(info["vertices"], 2930);
  // Seams split positions: the primitive has more vertices than the file's positions.
  EXPECT_GT(info["primitive_vertices"].get<uint64_t>(), 2930u);
}

TEST(CliInfo, SceneCountsOfTheEngine) {
  const json info = RunJson("info --json " + Quote(ModelPath("gltf/2CylinderEngine.glb")));
  EXPECT_EQ(info["nodes"], 82);
  EXPECT_EQ(info["meshes"], 29);
  EXPECT_EQ(info["primitives"], 34);
  EXPECT_EQ(info["faces"], 75730);
}

TEST(CliErrors, UsageAndInputErrorsHaveDistinctExitCodes) {
  EXPECT_EQ(RunCommand(Cli()).exit_code, 2);
  EXPECT_EQ(RunCommand(Cli() + " frobnicate").exit_code, 2);
  EXPECT_EQ(RunCommand(Cli() + " info").exit_code, 2);
  EXPECT_EQ(RunCommand(Cli() + " info --bogus x.obj").exit_code, 2);
  EXPECT_EQ(RunCommand(Cli() + " convert a.obj").exit_code, 2);
  EXPECT_EQ(RunCommand(Cli() + " convert " + Quote(ModelPath("spot.obj")) + " out.fbx").exit_code, 2);
  EXPECT_EQ(RunCommand(Cli() + " convert --draco --qp 99 " + Quote(ModelPath("spot.obj")) + " /tmp/x.glb").exit_code, 2);
  const auto missing = RunCommand(Cli() + " info /nonexistent/model.glb");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("/nonexistent/model.glb"), std::string::npos) << missing.err;
  // One line on stderr.
  EXPECT_EQ(std::count(missing.err.begin(), missing.err.end(), '\n'), 1) << missing.err;
  TempDir dir;
  test_util::WriteText(dir.File("bad.glb"), "glTF\x02\x00\x00\x00garbage");
  const auto bad = RunCommand(Cli() + " info " + Quote(dir.File("bad.glb")));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("bad.glb"), std::string::npos) << bad.err;
  const auto unsupported = RunCommand(Cli() + " info " + Quote(dir.File("mesh.fbx")));
  EXPECT_EQ(unsupported.exit_code, 1);
}

TEST(CliHelp, EveryVerbHasHelp) {
  for (const char* verb : {"info", "convert", "compare"}) {
    const auto r = RunCommand(Cli() + " " + verb + " --help");
    EXPECT_EQ(r.exit_code, 0) << verb;
    EXPECT_NE(r.out.find(std::string("usage: meshstream ") + verb), std::string::npos) << r.out;
  }
  const auto top = RunCommand(Cli() + " --help");
  EXPECT_EQ(top.exit_code, 0);
  EXPECT_NE(top.out.find("compare"), std::string::npos);
}

TEST(CliCompare, IdenticalMeshesGiveZero) {
  const json c = RunJson("compare --json --qp 11 " + Quote(ModelPath("fandisk.obj")) + " " + Quote(ModelPath("fandisk.obj")));
  EXPECT_EQ(c["vertices_a"], 6475);
  EXPECT_EQ(c["faces_b"], 12946);
  EXPECT_LT(c["hausdorff_rel"].get<double>(), 1e-9);
  EXPECT_LT(c["hausdorff_vertex_rel"].get<double>(), 1e-9);
  EXPECT_LT(c["mean_distance"].get<double>(), 1e-9);
  EXPECT_EQ(c["laplacian"].get<double>(), 0.0);
  EXPECT_TRUE(c["same_on_grid"].get<bool>());
}

TEST(CliCompare, DifferentMeshesGiveNullLaplacianAndPositiveDistance) {
  const json c = RunJson("compare --json " + Quote(ModelPath("fandisk.obj")) + " " + Quote(ModelPath("rocker-arm.obj")));
  EXPECT_TRUE(c["laplacian"].is_null());
  EXPECT_GT(c["hausdorff"].get<double>(), 0.0);
  EXPECT_FALSE(c.contains("same_on_grid"));
}

// convert, then import: the same mesh without Draco (Hausdorff 0), on the
// grid with Draco; every export passes the Khronos validator.
TEST(CliConvert, SharedModelsRoundTripAndValidate) {
  TempDir dir;
  for (const ModelCase& m : SharedModels()) {
    const std::string src = Quote(ModelPath(m.file));
    const std::string plain = dir.File(std::string(m.file) + ".glb");
    const std::string draco = dir.File(std::string(m.file) + ".draco.glb");
    const std::string gltf = dir.File(std::string(m.file) + ".gltf");
    ASSERT_EQ(RunCommand(Cli() + " convert --quiet " + src + " " + Quote(plain)).exit_code, 0) << m.file;
    ASSERT_EQ(RunCommand(Cli() + " convert --quiet " + src + " " + Quote(gltf)).exit_code, 0) << m.file;
    ASSERT_EQ(RunCommand(Cli() + " convert --quiet --draco --qp 14 " + src + " " + Quote(draco)).exit_code, 0) << m.file;

    const json exact = RunJson("compare --json --qp 14 " + src + " " + Quote(plain));
    EXPECT_LT(exact["hausdorff_rel"].get<double>(), 1e-9) << m.file;
    EXPECT_TRUE(exact["same_on_grid"].get<bool>()) << m.file;
    const json exact_gltf = RunJson("compare --json " + src + " " + Quote(gltf));
    EXPECT_LT(exact_gltf["hausdorff_rel"].get<double>(), 1e-9) << m.file;

    const json lossy = RunJson("compare --json --qp 14 " + src + " " + Quote(draco));
    EXPECT_TRUE(lossy["same_on_grid"].get<bool>()) << m.file << ": " << lossy.dump();
    // Within quantization: half a step of the 14-bit grid along each axis.
    EXPECT_LT(lossy["hausdorff_rel"].get<double>(), 1.0 / 16383) << m.file;
    EXPECT_GT(lossy["hausdorff"].get<double>(), 0.0) << m.file;

    for (const std::string& out : {plain, draco, gltf}) {
      const json report = Validate(out);
      EXPECT_EQ(report["errors"], 0) << out << ": " << report.dump();
    }
  }
}

TEST(CliConvert, GltfAssetsValidatePlainAndDraco) {
  TempDir dir;
  const std::vector<std::string> accepted = {"gltf/2CylinderEngine.glb", "gltf/BoxTextured.glb",
                                             "gltf/draco-2CylinderEngine/2CylinderEngine.gltf"};
  int n = 0;
  for (const std::string& rel : accepted) {
    for (const char* flags : {"", "--draco"}) {
      const std::string out = dir.File("asset" + std::to_string(n++) + ".glb");
      const auto r = RunCommand(Cli() + " convert --quiet " + flags + " " + Quote(ModelPath(rel)) + " " + Quote(out));
      ASSERT_EQ(r.exit_code, 0) << rel << " " << flags << ": " << r.err;
      const json report = Validate(out);
      EXPECT_EQ(report["errors"], 0) << rel << " " << flags << ": " << report.dump();
    }
  }
}

// Skinned and morphed assets are carried now: tests/cli/carry_cli_test.cc.

}  // namespace
}  // namespace meshstream

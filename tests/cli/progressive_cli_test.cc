// The CLI contract of `meshstream encode` and `meshstream decode` (issue 3),
// run as real processes on the shared models: lossless decoding on the grid
// (docs/design/design.md, "Lossless"), every level of detail with its vertex count, the JSON
// keys, attributes, the progressive .glb as valid glTF whose base any reader
// shows (property 9), a multi-primitive scene, and the exit codes.
#include <algorithm>
#include <string>
#include <vector>

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

uint64_t U(const json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_number_unsigned()) {
    ADD_FAILURE() << key << " is missing or not an unsigned number in " << j.dump();
    return 0;
  }
  return j[key].get<uint64_t>();
}

std::vector<uint64_t> LevelVertices(const json& encode) {
  if (!encode.contains("level_vertices") || !encode["level_vertices"].is_array()) return {};
  return encode["level_vertices"].get<std::vector<uint64_t>>();
}

// Every key of the contract, with values that agree with each other.
void CheckEncodeJson(const json& e, const std::string& what) {
  SCOPED_TRACE(what);
  for (const char* key : {"vertices", "faces", "levels", "level_vertices", "base_vertices", "base_bytes",
                          "reliable_bytes", "unreliable_bytes", "datagrams", "total_bytes", "reliable_bpv",
                          "unreliable_bpv", "total_bpv", "encode_ms", "profile", "level_bytes"}) {
    EXPECT_TRUE(e.contains(key)) << key << " is missing from " << e.dump();
  }
  const std::vector<uint64_t> levels = LevelVertices(e);
  ASSERT_FALSE(levels.empty()) << e.dump();
  const uint64_t vertices = U(e, "vertices");
  EXPECT_EQ(U(e, "levels"), levels.size() - 1);
  EXPECT_EQ(levels.back(), vertices);
  EXPECT_EQ(levels.front(), U(e, "base_vertices"));
  for (size_t i = 1; i < levels.size(); ++i) EXPECT_LT(levels[i - 1], levels[i]) << "level " << i;
  const uint64_t reliable = U(e, "reliable_bytes"), unreliable = U(e, "unreliable_bytes");
  EXPECT_EQ(U(e, "total_bytes"), reliable + unreliable);
  EXPECT_GT(U(e, "base_bytes"), 0u);
  EXPECT_LT(U(e, "base_bytes"), reliable);  // the base is part of the reliable bytes
  EXPECT_GT(U(e, "faces"), 0u);
  if (levels.size() > 1 && e.value("profile", "") != "reliable") {
    EXPECT_GT(U(e, "datagrams"), 0u);
    EXPECT_GT(unreliable, U(e, "datagrams"));  // every datagram has a header
  }
  if (e.value("profile", "") == "reliable") {
    EXPECT_EQ(U(e, "datagrams"), 0u) << "the reliable profile carries its splits in the control blocks";
    EXPECT_EQ(unreliable, 0u);
  }
  // level_bytes: the file's bytes a client needs per level, growing, the
  // last the whole file of one profile.
  const std::vector<uint64_t> bytes = e["level_bytes"].get<std::vector<uint64_t>>();
  ASSERT_EQ(bytes.size(), levels.size());
  for (size_t i = 1; i < bytes.size(); ++i) EXPECT_LT(bytes[i - 1], bytes[i]) << "level " << i;
  if (e.value("profile", "") != "both") {
    EXPECT_EQ(bytes.back(), U(e, "file_bytes"));
  }
  const double v = static_cast<double>(vertices);
  EXPECT_NEAR(e.value("reliable_bpv", -1.0), 8.0 * reliable / v, 1e-6);
  EXPECT_NEAR(e.value("unreliable_bpv", -1.0), 8.0 * unreliable / v, 1e-6);
  EXPECT_NEAR(e.value("total_bpv", -1.0), 8.0 * (reliable + unreliable) / v, 1e-6);
  EXPECT_GE(e.value("encode_ms", -1.0), 0.0);
}

void CheckDecodeJson(const json& d, const std::string& what) {
  SCOPED_TRACE(what);
  for (const char* key : {"vertices", "faces", "attributes", "levels_applied", "unreferenced_vertices",
                          "degenerate_faces", "nonmanifold_edges", "decode_ms"}) {
    EXPECT_TRUE(d.contains(key)) << key << " is missing from " << d.dump();
  }
  EXPECT_TRUE(d["attributes"].is_array());
  EXPECT_TRUE(d["decode_ms"].is_number());
  EXPECT_GE(d.value("decode_ms", -1.0), 0.0);
  // Unreferenced input vertices are not encoded; the decoder makes none.
  EXPECT_EQ(U(d, "unreferenced_vertices"), 0u);
}

struct ModelCase {
  const char* file;
  std::vector<std::string> attributes;
};

std::string Name(const ::testing::TestParamInfo<ModelCase>& info) {
  std::string name = info.param.file;
  name = name.substr(0, name.find('.'));
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

class ProgressiveCliModel : public ::testing::TestWithParam<ModelCase> {};

// On every shared model at qp 11 and 14 in both profiles (the loss-tolerant
// one in both packings): encode, decode
// every level, compare on the grid: the same triangles, with the model's
// attributes. For each model also a few levels of detail (0, 1, the middle,
// the last but one), the validator on every progressive .glb, and a plain
// glTF reader (convert) showing the base level.
TEST_P(ProgressiveCliModel, LosslessAtEveryQpAndPackingWithItsLevelsAndValidGlb) {
  const ModelCase& m = GetParam();
  const std::string src = ModelPath(m.file);
  TempDir dir;
  std::vector<std::string> glbs;
  for (int qp : {11, 14}) {
    for (const char* config : {"loss-tolerant split", "loss-tolerant bundled", "reliable split"}) {
      const std::string profile = std::string(config).substr(0, std::string(config).find(' '));
      const std::string packing = std::string(config).substr(std::string(config).find(' ') + 1);
      const std::string what = std::string(m.file) + " qp " + std::to_string(qp) + " " + config;
      SCOPED_TRACE(what);
      const std::string tag = std::to_string(qp) + profile + packing;
      const std::string glb = dir.File(tag + ".glb");
      const std::string ply = dir.File(tag + ".ply");
      const json e = RunJson("encode --json --qp " + std::to_string(qp) + " --profile " + profile + " --packing " +
                             packing + " " + Quote(src) + " -o " + Quote(glb));
      CheckEncodeJson(e, what);
      EXPECT_EQ(e.value("packing", ""), packing);
      EXPECT_EQ(e.value("profile", ""), profile);
      EXPECT_EQ(U(e, "datagrams") == 0, profile == "reliable") << "the reliable profile has no datagrams";
      glbs.push_back(glb);
      const std::vector<uint64_t> levels = LevelVertices(e);
      ASSERT_GE(levels.size(), 3u) << "the model should have several levels";

      const json d = RunJson("decode --json " + Quote(glb) + " -o " + Quote(ply));
      CheckDecodeJson(d, what);
      EXPECT_EQ(U(d, "vertices"), levels.back());
      EXPECT_EQ(U(d, "faces"), U(e, "faces"));
      EXPECT_EQ(U(d, "levels_applied"), levels.size() - 1);
      EXPECT_EQ(d["attributes"], json(m.attributes));

      const json c = RunJson("compare --json --samples 1000 --qp " + std::to_string(qp) + " " + Quote(src) + " " +
                             Quote(ply));
      EXPECT_TRUE(c.value("same_on_grid", false)) << c.dump();
      EXPECT_EQ(U(c, "grid_differing_faces"), 0u);
      // Only truly invalid faces may be cleaned up, and the encoder counts them.
      EXPECT_EQ(U(c, "faces_b"), U(c, "faces_a") - e.value("removed_faces", uint64_t{0}));
      EXPECT_EQ(U(c, "faces_b"), U(e, "faces"));

      if (qp == 11 && packing == "split") {
        const size_t n = levels.size() - 1;
        for (size_t k : {size_t{0}, size_t{1}, n / 2, n - 1}) {
          const json lod = RunJson("decode --json --lod " + std::to_string(k) + " " + Quote(glb) + " -o " +
                                   Quote(dir.File("lod.glb")));
          EXPECT_EQ(U(lod, "vertices"), levels[k]) << "lod " << k;
          EXPECT_EQ(U(lod, "levels_applied"), k);
          EXPECT_EQ(lod["attributes"], json(m.attributes)) << "lod " << k;
        }
        // A plain glTF reader shows the base level.
        const std::string base = dir.File("base.glb");
        ASSERT_EQ(RunCommand(Cli() + " convert --quiet " + Quote(glb) + " " + Quote(base)).exit_code, 0);
        const json info = RunJson("info --json " + Quote(base));
        EXPECT_EQ(U(info, "primitive_vertices"), levels.front());
        EXPECT_EQ(info["attributes"], json(m.attributes));
      }
    }
  }
  for (const json& report : test_util::ValidateGltf(glbs)) {
    EXPECT_EQ(report.value("errors", -1), 0) << report.dump();
  }
}

INSTANTIATE_TEST_SUITE_P(SharedModels, ProgressiveCliModel,
                         ::testing::Values(ModelCase{"stanford-bunny.obj", {"POSITION"}},
                                           ModelCase{"horse.ply", {"POSITION", "NORMAL"}},
                                           ModelCase{"fandisk.obj", {"POSITION"}},
                                           ModelCase{"rocker-arm.obj", {"POSITION"}},
                                           ModelCase{"spot.obj", {"POSITION", "TEXCOORD_0"}}),
                         Name);

TEST(ProgressiveCli, EveryLevelOfDetailHasItsVertexCount) {
  TempDir dir;
  const std::string glb = dir.File("fandisk.glb");
  const json e = RunJson("encode --json " + Quote(ModelPath("fandisk.obj")) + " -o " + Quote(glb));
  const std::vector<uint64_t> levels = LevelVertices(e);
  ASSERT_GE(levels.size(), 3u);
  for (size_t k = 0; k < levels.size(); ++k) {
    const json d = RunJson("decode --json --lod " + std::to_string(k) + " " + Quote(glb) + " -o " +
                           Quote(dir.File("lod.obj")));
    EXPECT_EQ(U(d, "vertices"), levels[k]) << "lod " << k;
    EXPECT_EQ(U(d, "levels_applied"), k);
    EXPECT_EQ(U(d, "degenerate_faces"), 0u) << "lod " << k;
    // A closed vertex split adds two triangles: the faces follow the vertices.
    EXPECT_EQ(U(d, "faces"), U(e, "faces") - 2 * (levels.back() - levels[k])) << "lod " << k;
  }
}

// --format-version 3, 2 and 1 write the previous formats (for decoders that
// predate version 4; loss-tolerant only): larger, and decoded to the same
// mesh as version 4 in either profile (the default: the reliable one).
TEST(ProgressiveCli, FormatVersionsOneToThreeAreWrittenOnRequestAndDecodeToTheSameMesh) {
  TempDir dir;
  const std::string src = Quote(ModelPath("fandisk.obj"));
  const json v4 = RunJson("encode --json " + src + " -o " + Quote(dir.File("v4.glb")));
  const json lt = RunJson("encode --json --profile loss-tolerant " + src + " -o " + Quote(dir.File("lt.glb")));
  const json v3 = RunJson("encode --json --format-version 3 " + src + " -o " + Quote(dir.File("v3.glb")));
  const json v2 = RunJson("encode --json --format-version 2 " + src + " -o " + Quote(dir.File("v2.glb")));
  const json v1 = RunJson("encode --json --format-version 1 " + src + " -o " + Quote(dir.File("v1.glb")));
  EXPECT_EQ(U(v4, "format_version"), 4u);
  EXPECT_EQ(v4["profile"], "reliable");
  EXPECT_EQ(lt["profile"], "loss-tolerant");
  EXPECT_EQ(U(v3, "format_version"), 3u);
  EXPECT_EQ(v3["profile"], "loss-tolerant") << "before version 4 every stream is";
  EXPECT_EQ(U(v2, "format_version"), 2u);
  EXPECT_EQ(U(v1, "format_version"), 1u);
  // Version 2 drops the tools version 3 added (--tools all is every tool of the version).
  EXPECT_EQ(v2["tools"], json::array({"geometry", "frame", "rank", "normals"})) << v2.dump();
  EXPECT_GT(U(v1, "total_bytes"), U(v2, "total_bytes") * 5 / 4);
  EXPECT_GT(U(v2, "total_bytes"), U(v3, "total_bytes"));
  EXPECT_EQ(U(lt, "total_bytes"), U(v3, "total_bytes") + 1) << "version 4's loss-tolerant profile: one byte more";
  EXPECT_LT(U(v4, "total_bytes"), U(v3, "total_bytes") * 95 / 100) << "the reliable profile: smaller";
  for (const json* other : {&lt, &v3, &v2, &v1}) EXPECT_EQ(LevelVertices(*other), LevelVertices(v4));
  for (const char* v : {"v1", "v2", "v3", "lt", "v4"}) {
    ASSERT_EQ(RunCommand(Cli() + " decode " + Quote(dir.File(std::string(v) + ".glb")) + " -o " +
                         Quote(dir.File(std::string(v) + ".obj"))).exit_code, 0) << v;
  }
  for (const char* v : {"v1", "v2", "v3", "lt"}) {
    const json c = RunJson("compare --json --qp 11 " + Quote(dir.File(std::string(v) + ".obj")) + " " +
                           Quote(dir.File("v4.obj")));
    EXPECT_EQ(c["same_on_grid"], true) << v << ": " << c.dump();
  }
  // The reliable profile needs version 4; --profile both carries both.
  EXPECT_EQ(RunCommand(Cli() + " encode --format-version 3 --profile reliable " + src + " -o " +
                       Quote(dir.File("x.glb"))).exit_code, 2);
  const json both = RunJson("encode --json --profile both " + src + " -o " + Quote(dir.File("both.glb")));
  EXPECT_EQ(both["profile"], "both");
  EXPECT_EQ(both["level_bytes"].size(), both["reliable_level_bytes"].size());
  EXPECT_LT(both["reliable_level_bytes"].back().get<uint64_t>(), both["level_bytes"].back().get<uint64_t>());
  const json lossy = RunJson("decode --json --loss 0.2 --seed 2 " + Quote(dir.File("both.glb")) + " -o " +
                             Quote(dir.File("lossy.obj")));
  EXPECT_GT(U(lossy, "datagrams"), 0u) << "a lossy decode reads the loss-tolerant stream";
  EXPECT_EQ(RunCommand(Cli() + " decode --loss 0.2 " + Quote(dir.File("v4.glb")) + " -o " + Quote(dir.File("x.obj")))
                .exit_code, 2) << "the reliable profile alone has no datagrams to lose";
  // decode --profile: auto takes the reliable stream when nothing is lost;
  // either one on request, the same mesh; the one a file lacks is an error.
  for (const char* p : {"auto", "reliable", "loss-tolerant"}) {
    const std::string obj = dir.File(std::string(p) + ".obj");
    const json d = RunJson("decode --json --profile " + std::string(p) + " " + Quote(dir.File("both.glb")) + " -o " +
                           Quote(obj));
    EXPECT_EQ(d["profile"], std::string(p) == "loss-tolerant" ? "loss-tolerant" : "reliable") << p;
    EXPECT_EQ(U(d, std::string(p) == "loss-tolerant" ? "loss_tolerant_streams" : "reliable_profile_streams"), 1u) << p;
    EXPECT_EQ(U(d, "datagrams") > 0, std::string(p) == "loss-tolerant") << p << ": " << d.dump();
    const json c = RunJson("compare --json --qp 11 " + Quote(obj) + " " + Quote(dir.File("v4.obj")));
    EXPECT_EQ(c["same_on_grid"], true) << p << ": " << c.dump();
  }
  EXPECT_EQ(RunJson("decode --json " + Quote(dir.File("lt.glb")) + " -o " + Quote(dir.File("x.obj")))["profile"],
            "loss-tolerant");
  const test_util::CommandResult missing =
      RunCommand(Cli() + " decode --profile loss-tolerant " + Quote(dir.File("v4.glb")) + " -o " + Quote(dir.File("x.obj")));
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.err.find("the file has no stream of the loss-tolerant profile"), std::string::npos) << missing.err;
  EXPECT_EQ(RunCommand(Cli() + " decode --profile fast " + Quote(dir.File("v4.glb")) + " -o " + Quote(dir.File("x.obj")))
                .exit_code, 2);
}

// The reliable cut from the CLI (docs/design/loss-tolerance.md, "The reliable cut"):
// encode records it within its share, decode --loss sends it reliably unless
// told otherwise, and both refuse a share outside [0, 1].
TEST(ProgressiveCli, TheReliableCutIsRecordedAndDecodeLossSendsIt) {
  test_util::TempDir dir;
  const std::string glb = dir.File("bunny.glb");
  const json e = RunJson("encode --json --profile loss-tolerant " + Quote(ModelPath("stanford-bunny.obj")) + " -o " +
                         Quote(glb));
  EXPECT_DOUBLE_EQ(e["reliable_share"].get<double>(), 0.10);
  EXPECT_GT(e["reliable_cut_bytes"].get<uint64_t>(), 0u);
  EXPECT_LE(e["reliable_cut_bytes"].get<double>(), 0.10 * e["total_bytes"].get<double>());
  const std::string loss = " --loss 0.12 --seed 3 " + Quote(glb) + " -o " + Quote(dir.File("x.ply"));
  const json cut = RunJson("decode --json" + loss);
  const json paper = RunJson("decode --json --reliable-share 0" + loss);
  const json wide = RunJson("decode --json --reliable-share 0.3" + loss);
  EXPECT_EQ(cut["reliable_datagram_bytes"], e["reliable_cut_bytes"]);
  EXPECT_EQ(paper["reliable_datagrams"], 0);
  EXPECT_GT(wide["reliable_datagram_bytes"].get<uint64_t>(), cut["reliable_datagram_bytes"].get<uint64_t>());
  EXPECT_LE(cut["lost_datagrams"].get<int>(), paper["lost_datagrams"].get<int>()) << "the same seed, fewer at risk";
  EXPECT_EQ(RunCommand(Cli() + " decode --reliable-share 1.5" + loss).exit_code, 2);
  EXPECT_EQ(RunCommand(Cli() + " encode --reliable-share -1 " + Quote(ModelPath("spot.obj")) + " -o " +
                       Quote(dir.File("s.glb"))).exit_code, 2);
}

// --tools chooses the coding tools (for measuring what each saves);
// --json reports the ones the stream was written with. Fewer tools: larger,
// and the same mesh.
TEST(ProgressiveCli, ToolsAreChosenReportedAndDecodeToTheSameMesh) {
  TempDir dir;
  const std::string src = Quote(ModelPath("fandisk.obj"));
  const json all = RunJson("encode --json " + src + " -o " + Quote(dir.File("all.glb")));
  const json none = RunJson("encode --json --tools none " + src + " -o " + Quote(dir.File("none.glb")));
  const json two = RunJson("encode --json --tools geometry,rank " + src + " -o " + Quote(dir.File("two.glb")));
  // fandisk has normals but no texture coordinates: no texcoords tool; the
  // reliable profile (the default) codes split bits and models its own way.
  EXPECT_EQ(all["tools"], json::array({"geometry", "frame", "rank", "normals", "predictor"})) << all.dump();
  const json lt = RunJson("encode --json --profile loss-tolerant " + src + " -o " + Quote(dir.File("lt.glb")));
  EXPECT_EQ(lt["tools"], json::array({"geometry", "frame", "rank", "normals", "splitbits", "models", "predictor"}))
      << lt.dump();
  EXPECT_EQ(none["tools"], json::array()) << none.dump();
  EXPECT_EQ(two["tools"], json::array({"geometry", "rank"})) << two.dump();
  // The ring predictor works in the local frame: without it, it is not used.
  const json lone = RunJson("encode --json --tools geometry,predictor " + src + " -o " + Quote(dir.File("lone.glb")));
  EXPECT_EQ(lone["tools"], json::array({"geometry"})) << lone.dump();
  EXPECT_EQ(RunCommand(Cli() + " encode --ring-term-bits -1 " + src + " -o " + Quote(dir.File("x.glb"))).exit_code, 2);
  // The crossings (version 4, not a default: docs/design/codec.md "Version 4")
  // order the rank tool's ranks: `all` takes them in both profiles, and
  // without `rank` they are not used.
  const json every = RunJson("encode --json --tools all " + src + " -o " + Quote(dir.File("every.glb")));
  EXPECT_EQ(every["tools"], json::array({"geometry", "frame", "rank", "normals", "predictor", "crossings"}))
      << every.dump();
  const json every_lt =
      RunJson("encode --json --tools all --profile loss-tolerant " + src + " -o " + Quote(dir.File("every_lt.glb")));
  EXPECT_EQ(every_lt["tools"],
            json::array({"geometry", "frame", "rank", "normals", "splitbits", "models", "predictor", "crossings"}))
      << every_lt.dump();
  const json no_rank = RunJson("encode --json --tools geometry,crossings " + src + " -o " + Quote(dir.File("nr.glb")));
  EXPECT_EQ(no_rank["tools"], json::array({"geometry"})) << no_rank.dump();
  const test_util::CommandResult v3 = RunCommand(Cli() + " encode --format-version 3 --tools crossings " + src + " -o " +
                                  Quote(dir.File("x.glb")));
  EXPECT_EQ(v3.exit_code, 2);
  EXPECT_NE(v3.err.find("crossings is not a tool of format version 3 (it needs --format-version 4)"),
            std::string::npos)
      << v3.err;
  EXPECT_EQ(U(none, "format_version"), 4u);
  EXPECT_GT(U(none, "total_bytes"), U(two, "total_bytes"));
  EXPECT_GT(U(two, "total_bytes"), U(all, "total_bytes"));
  for (const char* name : {"all", "none", "two"}) {
    const std::string glb = dir.File(std::string(name) + ".glb"), obj = dir.File(std::string(name) + ".obj");
    // decode --json reports the tools the file's streams were written with.
    const json d = RunJson("decode --json " + Quote(glb) + " -o " + Quote(obj));
    const json& e = std::string(name) == "all" ? all : std::string(name) == "none" ? none : two;
    EXPECT_EQ(d["tools"], e["tools"]) << name << ": " << d.dump();
  }
  // spot has UV seams: `all` collapses them (the seams tool), and a list
  // without `seams` keeps them in the base; both decode to spot.
  const std::string spot = Quote(ModelPath("spot.obj"));
  const json seams = RunJson("encode --json " + spot + " -o " + Quote(dir.File("seams.glb")));
  const json kept = RunJson("encode --json --tools geometry,frame,rank,texcoords " + spot + " -o " +
                            Quote(dir.File("kept.glb")));
  EXPECT_EQ(seams["tools"], json::array({"geometry", "frame", "rank", "normals", "texcoords", "seams", "predictor"}))
      << seams.dump();
  EXPECT_EQ(kept["tools"], json::array({"geometry", "frame", "rank", "texcoords"})) << kept.dump();
  EXPECT_LT(U(seams, "base_vertices") * 2, U(kept, "base_vertices"));
  EXPECT_LT(U(seams, "total_bytes"), U(kept, "total_bytes"));
  for (const char* name : {"seams", "kept"}) {
    const std::string glb = dir.File(std::string(name) + ".glb"), obj = dir.File(std::string(name) + ".obj");
    ASSERT_EQ(RunCommand(Cli() + " decode " + Quote(glb) + " -o " + Quote(obj)).exit_code, 0) << name;
    const json c = RunJson("compare --json --qp 11 " + spot + " " + Quote(obj));
    EXPECT_EQ(c["same_on_grid"], true) << name << ": " << c.dump();
  }
  for (const char* name : {"every", "every_lt"}) {
    const std::string glb = dir.File(std::string(name) + ".glb"), obj = dir.File(std::string(name) + ".obj");
    const json d = RunJson("decode --json " + Quote(glb) + " -o " + Quote(obj));
    EXPECT_EQ(d["tools"], (std::string(name) == "every" ? every : every_lt)["tools"]) << name << ": " << d.dump();
  }
  for (const char* name : {"none", "two", "every", "every_lt"}) {
    const json c = RunJson("compare --json --qp 11 " + Quote(dir.File("all.obj")) + " " +
                           Quote(dir.File(std::string(name) + ".obj")));
    EXPECT_EQ(c["same_on_grid"], true) << name << ": " << c.dump();
  }
}

// A multi-primitive glTF scene comes back with its nodes, meshes and
// primitives. Each primitive has its own grid, so the geometry is compared
// by distance over the whole scene rather than on one grid.
TEST(ProgressiveCli, SceneKeepsItsStructure) {
  TempDir dir;
  const std::string src = ModelPath("gltf/2CylinderEngine.glb");
  const std::string glb = dir.File("engine.glb");
  const std::string out = dir.File("engine-decoded.glb");
  const json e = RunJson("encode --json " + Quote(src) + " -o " + Quote(glb));
  CheckEncodeJson(e, "2CylinderEngine");
  EXPECT_EQ(U(e, "primitives"), 34u);
  const json d = RunJson("decode --json " + Quote(glb) + " -o " + Quote(out));
  CheckDecodeJson(d, "2CylinderEngine");
  EXPECT_EQ(U(d, "levels_applied"), U(e, "levels"));
  EXPECT_EQ(U(d, "faces"), U(e, "faces"));

  const json before = RunJson("info --json " + Quote(src));
  for (const std::string& file : {glb, out}) {
    const json after = RunJson("info --json " + Quote(file));
    for (const char* key : {"scenes", "nodes", "meshes", "primitives", "materials"}) {
      EXPECT_EQ(after[key], before[key]) << key << " of " << file;
    }
  }
  // The engine has triangles that repeat a vertex: the encoder removes them
  // (and counts them), and keeps every other one.
  EXPECT_EQ(U(e, "faces") + e.value("removed_faces", uint64_t{0}), U(before, "faces"));
  EXPECT_LE(e.value("removed_faces", uint64_t{0}), U(before, "degenerate_faces"));
  EXPECT_EQ(U(e, "vertices"), U(before, "primitive_vertices"));
  EXPECT_EQ(U(d, "vertices"), U(e, "vertices"));
  // compare flattens the node tree (meshes used by several nodes count each time).
  const json c = RunJson("compare --json --samples 20000 " + Quote(src) + " " + Quote(out));
  EXPECT_EQ(U(c, "vertices_b"), U(c, "vertices_a"));
  EXPECT_LE(U(c, "faces_b"), U(c, "faces_a"));
  EXPECT_LT(c.value("hausdorff_rel", 1.0), 1e-3) << c.dump();
  for (const json& report : test_util::ValidateGltf({glb, out})) EXPECT_EQ(report.value("errors", -1), 0) << report.dump();
}

// A .glb without our extension is its own base: it decodes unchanged with
// no level, and asking for a level it does not have is a usage error.
TEST(ProgressiveCli, PlainGlbDecodesUnchangedWithoutLevels) {
  TempDir dir;
  const std::string plain = dir.File("plain.glb");
  const std::string src = ModelPath("spot.obj");
  ASSERT_EQ(RunCommand(Cli() + " convert --quiet " + Quote(src) + " " + Quote(plain)).exit_code, 0);
  const json d = RunJson("decode --json " + Quote(plain) + " -o " + Quote(dir.File("out.glb")));
  EXPECT_EQ(U(d, "levels_applied"), 0u);
  EXPECT_EQ(U(d, "levels"), 0u);
  const json info = RunJson("info --json " + Quote(plain));
  EXPECT_EQ(U(d, "vertices"), U(info, "primitive_vertices"));
  EXPECT_EQ(U(d, "faces"), U(info, "faces"));
  const json c = RunJson("compare --json --samples 1000 --qp 14 " + Quote(plain) + " " + Quote(dir.File("out.glb")));
  EXPECT_TRUE(c.value("same_on_grid", false)) << c.dump();
  EXPECT_EQ(RunCommand(Cli() + " decode --lod 1 " + Quote(plain) + " -o " + Quote(dir.File("x.glb"))).exit_code, 2);
}

TEST(ProgressiveCli, UsageErrorsExitTwoAndBadInputExitsOne) {
  TempDir dir;
  const std::string src = Quote(ModelPath("spot.obj"));
  const std::string glb = dir.File("spot.glb");
  ASSERT_EQ(RunCommand(Cli() + " encode --levels 3 " + src + " -o " + Quote(glb)).exit_code, 0);

  struct Case {
    std::string args;
    int exit_code;
  };
  const std::vector<Case> cases = {
      {"encode " + src, 2},                                             // no -o
      {"encode " + src + " -o " + Quote(dir.File("x.obj")), 2},          // not a .glb
      {"encode --packing foo " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --qp 0 " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --packet-bytes 10 " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --format-version 5 " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --profile bogus " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --batch-rule matching --profile loss-tolerant " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --format-version 2 --tools geometry,splitbits " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --format-version 1 --tools geometry " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --format-version 0 " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --tools geometry,bogus " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode --bogus " + src + " -o " + Quote(dir.File("x.glb")), 2},
      {"decode " + Quote(glb), 2},                                       // no -o
      {"decode " + Quote(glb) + " -o " + Quote(dir.File("x.fbx")), 2},
      {"decode --lod 4 " + Quote(glb) + " -o " + Quote(dir.File("x.glb")), 2},  // beyond its 3 levels
      {"decode --lod -1 " + Quote(glb) + " -o " + Quote(dir.File("x.glb")), 2},
      {"decode --repeat 0 " + Quote(glb) + " -o " + Quote(dir.File("x.glb")), 2},
      {"encode /nonexistent/model.obj -o " + Quote(dir.File("x.glb")), 1},
      {"decode /nonexistent/model.glb -o " + Quote(dir.File("x.glb")), 1},
      {"decode " + src + " -o " + Quote(dir.File("x.glb")), 1},          // an OBJ is no progressive file
  };
  for (const Case& c : cases) {
    const auto r = RunCommand(Cli() + " " + c.args);
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find("meshstream"), std::string::npos) << c.args << ": " << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.File("x.glb")));
  // The last level is still accepted.
  EXPECT_EQ(RunCommand(Cli() + " decode --lod 3 " + Quote(glb) + " -o " + Quote(dir.File("y.glb"))).exit_code, 0);

  // A progressive file whose stream is damaged: a clear error, exit 1.
  std::string bytes = test_util::ReadText(glb);
  ASSERT_GT(bytes.size(), 200u);
  const std::string truncated = dir.File("truncated.glb");
  test_util::WriteText(truncated, bytes.substr(0, bytes.size() - 100));
  const auto cut = RunCommand(Cli() + " decode " + Quote(truncated) + " -o " + Quote(dir.File("x.glb")));
  EXPECT_EQ(cut.exit_code, 1) << cut.err;
  EXPECT_NE(cut.err.find("truncated.glb"), std::string::npos) << cut.err;
  EXPECT_EQ(std::count(cut.err.begin(), cut.err.end(), '\n'), 1) << cut.err;
}

// The refinements live at the end of the binary chunk; overwriting the last
// bytes damages the stream but not the GLB: decode fails with exit 1, and
// the file is still a glTF whose base level any reader shows.
// Damage at the end of the file hits the last refinement's datagrams: they
// are dropped as malformed and their splits predicted, so the decode succeeds
// with the full vertex count; damage in the reliable part is an error.
TEST(ProgressiveCli, DamagedStreamIsRecoveredOrAnErrorNotACrash) {
  TempDir dir;
  const std::string glb = dir.File("fandisk.glb");
  // The loss-tolerant profile: its last bytes are a datagram (the reliable
  // profile's are its last control block, reliable data: an error).
  const json e = RunJson("encode --json --profile loss-tolerant --levels 4 " + Quote(ModelPath("fandisk.obj")) +
                         " -o " + Quote(glb));
  std::string bytes = test_util::ReadText(glb);
  ASSERT_GT(bytes.size(), 64u);
  int recovered = 0;
  for (size_t back : {1, 5, 17, 40}) {
    std::string damaged = bytes;
    for (size_t i = damaged.size() - back - 8; i < damaged.size() - back; ++i) damaged[i] = static_cast<char>(0xFF);
    const std::string file = dir.File("damaged" + std::to_string(back) + ".glb");
    test_util::WriteText(file, damaged);
    const auto r = RunCommand(Cli() + " decode --json " + Quote(file) + " -o " + Quote(dir.File("x.glb")));
    EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.exit_code << " " << r.err;
    if (r.exit_code == 0) {
      const json d = json::parse(r.out);
      EXPECT_EQ(U(d, "vertices"), LevelVertices(e).back());
      if (U(d, "predicted_splits") > 0) ++recovered;
    }
    const json info = RunJson("info --json " + Quote(file));
    EXPECT_EQ(U(info, "primitive_vertices"), LevelVertices(e).front());
  }
  EXPECT_GT(recovered, 0);
}

// decode --loss: the seeded network repeats exactly, prediction keeps the
// lossless vertex count, LwoP abandons, and bad values are usage errors.
TEST(ProgressiveCli, LossyDecodeIsSeededAndRecovers) {
  TempDir dir;
  const std::string glb = dir.File("fandisk.glb");
  const json e = RunJson("encode --json --profile loss-tolerant --packet-bytes 200 " + Quote(ModelPath("fandisk.obj")) +
                         " -o " + Quote(glb));
  // Without parity, which would rebuild what the network lost.
  const std::string flags = " --no-parity --loss 0.2 --burst 2 --reorder 0.3 --duplicate 0.1 --seed 7";
  const json a = RunJson("decode --json " + Quote(glb) + " -o " + Quote(dir.File("a.ply")) + flags);
  const json b = RunJson("decode --json " + Quote(glb) + " -o " + Quote(dir.File("b.ply")) + flags);
  EXPECT_EQ(test_util::ReadText(dir.File("a.ply")), test_util::ReadText(dir.File("b.ply")));
  EXPECT_GT(U(a, "lost_datagrams"), 0u);
  EXPECT_EQ(U(a, "lost_datagrams"), U(b, "lost_datagrams"));
  EXPECT_GT(U(a, "predicted_splits"), 0u);
  EXPECT_GT(U(a, "predicted_vertices"), 0u);
  EXPECT_EQ(U(a, "vertices"), LevelVertices(e).back());
  EXPECT_EQ(U(a, "unreferenced_vertices"), 0u);
  EXPECT_EQ(U(a, "degenerate_faces"), 0u);
  EXPECT_EQ(U(a, "nonmanifold_edges"), 0u);
  const json other = RunJson("decode --json " + Quote(glb) + " -o " + Quote(dir.File("c.ply")) +
                             " --no-parity --loss 0.2 --burst 2 --seed 8");
  EXPECT_NE(test_util::ReadText(dir.File("a.ply")), test_util::ReadText(dir.File("c.ply")));
  const json lwop = RunJson("decode --json --recovery lwop " + Quote(glb) + " -o " + Quote(dir.File("d.ply")) + flags);
  EXPECT_GT(U(lwop, "abandoned_splits"), 0u);
  EXPECT_LT(U(lwop, "vertices"), LevelVertices(e).back());
  EXPECT_EQ(U(lwop, "unreferenced_vertices"), 0u);
  const json clean = RunJson("decode --json " + Quote(glb) + " -o " + Quote(dir.File("e.ply")));
  EXPECT_EQ(U(clean, "lost_datagrams"), 0u);
  EXPECT_EQ(U(clean, "predicted_vertices"), 0u);
  for (const char* bad : {" --loss 1.5", " --recovery guess", " --reorder -1"}) {
    const auto r = RunCommand(Cli() + " decode " + Quote(glb) + " -o " + Quote(dir.File("f.ply")) + bad);
    EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.err;
    EXPECT_FALSE(r.err.empty());
  }
}

// decode --threads: the same mesh, byte for byte, with and without loss; the
// splits decoded on the threads counted; 0 is one per core; refused beyond 64.
TEST(ProgressiveCli, DecodeThreadsGiveTheSameMesh) {
  TempDir dir;
  const std::string glb = dir.File("bunny.glb");
  RunJson("encode --json --profile both " + Quote(ModelPath("stanford-bunny.obj")) + " -o " + Quote(glb));
  // Without loss the reliable profile's stream, with it the loss-tolerant one's.
  for (const std::string loss : {"", " --loss 0.12 --seed 3"}) {
    SCOPED_TRACE(loss);
    const json one = RunJson("decode --json " + Quote(glb) + " -o " + Quote(dir.File("one.ply")) + loss);
    const json two = RunJson("decode --json --threads 2 " + Quote(glb) + " -o " + Quote(dir.File("two.ply")) + loss);
    const json all = RunJson("decode --json --threads 0 " + Quote(glb) + " -o " + Quote(dir.File("all.ply")) + loss);
    EXPECT_EQ(test_util::ReadText(dir.File("one.ply")), test_util::ReadText(dir.File("two.ply")));
    EXPECT_EQ(test_util::ReadText(dir.File("one.ply")), test_util::ReadText(dir.File("all.ply")));
    EXPECT_EQ(U(one, "threads"), 1u);
    EXPECT_EQ(U(two, "threads"), 2u);
    EXPECT_GE(U(all, "threads"), 1u);
    EXPECT_EQ(U(one, "parallel_splits"), 0u);
    EXPECT_GT(U(two, "parallel_splits"), 0u);
    EXPECT_EQ(U(one, "predicted_vertices"), U(two, "predicted_vertices"));
  }
  const auto r = RunCommand(Cli() + " decode --threads 65 " + Quote(glb) + " -o " + Quote(dir.File("x.ply")));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("threads"), std::string::npos) << r.err;
}

TEST(ProgressiveCli, EncodeAndDecodeHaveHelp) {
  for (const char* verb : {"encode", "decode"}) {
    const auto r = RunCommand(Cli() + " " + verb + " --help");
    EXPECT_EQ(r.exit_code, 0) << verb;
    EXPECT_NE(r.out.find(std::string("usage: meshstream ") + verb), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--json"), std::string::npos) << r.out;
  }
  const auto encode = RunCommand(Cli() + " encode --help");
  for (const char* flag : {"--qp", "--levels", "--base-ratio", "--packing", "--packet-bytes"}) {
    EXPECT_NE(encode.out.find(flag), std::string::npos) << flag;
  }
  const auto decode = RunCommand(Cli() + " decode --help");
  for (const char* flag : {"--lod", "--repeat", "--loss", "--seed", "--burst", "--reorder", "--duplicate", "--recovery"}) {
    EXPECT_NE(decode.out.find(flag), std::string::npos) << flag;
  }
  const auto top = RunCommand(Cli() + " --help");
  EXPECT_NE(top.out.find("encode"), std::string::npos);
  EXPECT_NE(top.out.find("decode"), std::string::npos);
}

}  // namespace
}  // namespace meshstream

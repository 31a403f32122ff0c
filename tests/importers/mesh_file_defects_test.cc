// Regression tests for two defects of the mesh-file importers:
// - a PLY header line that is neither a keyword nor a comment (old Blender
//   exporters write "Created by Blender3D 247 - www.blender.org, source
//   file: ..." as the third line) is ignored with a warning naming the line,
//   while broken element/property/format lines stay errors;
// - names taken from files (the file name becomes the mesh and node name)
//   are made valid UTF-8 with a warning, so the scene exports as GLB whose
//   JSON parses.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <stdlib.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "codec/core/utf8.h"
#include "importers/gltf_export.h"
#include "importers/import.h"

namespace meshstream {
namespace {

class MeshFileDefects : public ::testing::Test {
 protected:
  MeshFileDefects() {
    std::string pattern = (std::filesystem::temp_directory_path() / "meshstream-defects-XXXXXX").string();
    if (mkdtemp(pattern.data()) != nullptr) dir_ = pattern;
  }
  ~MeshFileDefects() override {
    std::error_code ec;
    if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
  }
  std::string Write(const std::string& name, const std::string& content) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }
  std::string dir_;
};

bool HasWarning(const Scene& s, const std::vector<std::string>& needles) {
  for (const std::string& w : s.warnings) {
    bool all = true;
    for (const std::string& n : needles) all = all && w.find(n) != std::string::npos;
    if (all) return true;
  }
  return false;
}

std::string Warnings(const Scene& s) {
  std::string out;
  for (const std::string& w : s.warnings) out += "\n  " + w;
  return out;
}

const std::string kBlenderLine = "Created by Blender3D 247 - www.blender.org, source file: 'cube.blend'";

std::string AsciiPly(const std::string& third_line) {
  return "ply\nformat ascii 1.0\n" + third_line +
         "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
         "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
}

// ------------------------------------------------------------ stray PLY lines

TEST_F(MeshFileDefects, AsciiPlyWithABlenderLineIsReadWithAWarning) {
  const std::string path = Write("blender.ply", AsciiPly(kBlenderLine + "\n"));
  auto scene = ImportFile(path);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  const Primitive& p = scene->meshes[0].primitives[0];
  EXPECT_EQ(p.positions.size(), 4u);
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_TRUE(HasWarning(*scene, {"PLY header line 3", "Created by Blender3D 247 - www.blender.org"}))
      << Warnings(*scene);
}

TEST_F(MeshFileDefects, CrLfPlyWithAStrayLineIsReadWithAWarning) {
  std::string text = AsciiPly(kBlenderLine + "\n");
  std::string crlf;
  for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  auto scene = ImportFile(Write("crlf.ply", crlf));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_TRUE(HasWarning(*scene, {"PLY header line 3", "cube.blend'"})) << Warnings(*scene);
  EXPECT_EQ(scene->total_faces(), 2u);
}

TEST_F(MeshFileDefects, BinaryPlyWithAStrayLineIsReadWithAWarning) {
  std::string s = "ply\nformat binary_little_endian 1.0\n" + kBlenderLine +
                  "\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                  "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const float v[9] = {0, 0, 0, 2, 0, 0, 0, 3, 0};
  s.append(reinterpret_cast<const char*>(v), sizeof v);
  s += '\3';
  const int32_t f[3] = {0, 1, 2};
  s.append(reinterpret_cast<const char*>(f), sizeof f);
  auto scene = ImportFile(Write("binary.ply", s));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  const Primitive& p = scene->meshes[0].primitives[0];
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {2, 0, 0}, {0, 3, 0}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_TRUE(HasWarning(*scene, {"PLY header line 3", "Created by Blender3D"})) << Warnings(*scene);
}

TEST_F(MeshFileDefects, ManyStrayLinesGiveBoundedWarnings) {
  std::string lines;
  for (int i = 0; i < 1000; ++i) lines += "stray line " + std::to_string(i) + "\n";
  auto scene = ImportFile(Write("many.ply", AsciiPly(lines)));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_LE(scene->warnings.size(), 10u) << Warnings(*scene);
  EXPECT_TRUE(HasWarning(*scene, {"PLY header line 3", "stray line 0"})) << Warnings(*scene);
  EXPECT_TRUE(HasWarning(*scene, {"995 more lines"})) << Warnings(*scene);
}

TEST_F(MeshFileDefects, StrayLineWithInvalidUtf8IsQuotedAsValidUtf8) {
  auto scene = ImportFile(Write("bytes.ply", AsciiPly("Cr\xe9\xff\x01 by hand\n")));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  ASSERT_TRUE(HasWarning(*scene, {"PLY header line 3", " by hand"})) << Warnings(*scene);
  for (const std::string& w : scene->warnings) EXPECT_TRUE(IsValidUtf8(w)) << w;
}

void ExpectRefused(const std::string& path, const std::vector<std::string>& needles) {
  auto scene = ImportFile(path);
  ASSERT_FALSE(scene.ok()) << path << " was accepted";
  EXPECT_EQ(scene.status().code(), StatusCode::kInvalidInput) << scene.status().ToString();
  const std::string& m = scene.status().message();
  EXPECT_EQ(m.rfind(path, 0), 0u) << m;
  for (const std::string& n : needles) EXPECT_NE(m.find(n), std::string::npos) << "'" << n << "' not in " << m;
}

TEST_F(MeshFileDefects, BrokenKeywordLinesStayErrorsNextToAStrayLine) {
  const std::string head = "ply\nformat ascii 1.0\n" + kBlenderLine + "\n";
  const std::string body = "property float x\nproperty float y\nproperty float z\n"
                           "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  ExpectRefused(Write("no-count.ply", head + "element vertex\n" + body),
                {"PLY header line 4", "element <name> <count>"});
  ExpectRefused(Write("bad-count.ply", head + "element vertex three\n" + body),
                {"PLY header line 4", "'three'"});
  ExpectRefused(Write("bad-property.ply", head + "element vertex 3\nproperty float\n" + body),
                {"PLY header line 5", "property <type> <name>"});
  ExpectRefused(Write("late-format.ply", head + "format ascii 1.0\nelement vertex 3\n" + body),
                {"PLY header line 4", "'format'"});
  ExpectRefused(Write("end-header-words.ply",
                      head + "element vertex 3\n" + body.substr(0, body.find("end_header")) + "end_header x\n"),
                {"end_header"});
  ExpectRefused(Write("stray-format-line.ply", "ply\n" + kBlenderLine + "\nformat ascii 1.0\n"),
                {"PLY header line 2", "format"});
}

// ------------------------------------------------------------ UTF-8 names

// The JSON chunk of a GLB, parsed (throws on invalid UTF-8).
nlohmann::json GlbJson(const std::vector<uint8_t>& glb) {
  uint32_t length = 0;
  std::memcpy(&length, glb.data() + 12, 4);
  const std::string text(reinterpret_cast<const char*>(glb.data()) + 20, length);
  return nlohmann::json::parse(text);
}

void ExpectExportsWithValidNames(const Scene& scene) {
  ASSERT_EQ(scene.meshes.size(), 1u);
  EXPECT_TRUE(IsValidUtf8(scene.meshes[0].name)) << scene.meshes[0].name;
  for (const Node& n : scene.nodes) EXPECT_TRUE(IsValidUtf8(n.name)) << n.name;
  for (const std::string& w : scene.warnings) EXPECT_TRUE(IsValidUtf8(w)) << w;
  StatusOr<std::vector<uint8_t>> glb = Internal("not run");
  ASSERT_NO_THROW(glb = ExportGlb(scene, ExportOptions{}));
  ASSERT_TRUE(glb.ok()) << glb.status().ToString();
  nlohmann::json json;
  ASSERT_NO_THROW(json = GlbJson(*glb));
  EXPECT_EQ(json["meshes"][0].value("name", ""), scene.meshes[0].name);
}

TEST_F(MeshFileDefects, FileNameWithInvalidUtf8BecomesAValidName) {
  for (const std::string ext : {".obj", ".ply", ".off", ".stl"}) {
    std::string content;
    if (ext == ".obj") content = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    if (ext == ".ply") content = AsciiPly("");
    if (ext == ".off") content = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    if (ext == ".stl") {
      content = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                "endloop\nendfacet\nendsolid t\n";
    }
    const std::string path = Write("bad\xff" "caf\xe9" + ext, content);
    auto scene = ImportFile(path);
    ASSERT_TRUE(scene.ok()) << ext << ": " << scene.status().ToString();
    EXPECT_EQ(scene->meshes[0].name, "bad\xEF\xBF\xBD" "caf\xEF\xBF\xBD") << ext;
    EXPECT_EQ(scene->nodes[0].name, scene->meshes[0].name) << ext;
    EXPECT_TRUE(HasWarning(*scene, {"not valid UTF-8", "bad\xEF\xBF\xBD"})) << ext << Warnings(*scene);
    ExpectExportsWithValidNames(*scene);
  }
}

TEST_F(MeshFileDefects, ValidUtf8FileNamesAreKeptWithoutAWarning) {
  auto scene = ImportFile(Write("caf\xc3\xa9 \xe2\x9c\x93.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(scene->meshes[0].name, "caf\xc3\xa9 \xe2\x9c\x93");
  EXPECT_TRUE(scene->warnings.empty()) << Warnings(*scene);
}

TEST_F(MeshFileDefects, ObjNamesWithInvalidUtf8NeverReachTheScene) {
  // o, g and usemtl names are not kept (obj_import.h); whatever the importer
  // keeps or warns about must be valid UTF-8 and export.
  const std::string path = Write("names.obj",
                                 "mtllib m\xff.mtl\no bad\xff\xfe" "object\ng gr\xc3oup other\xc0\n"
                                 "usemtl m\xe9tal\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
                                 "g \xed\xa0\x80surrogate\nusemtl \xf4\x90\x80\x80\nf 3 2 1\n");
  auto scene = ImportFile(path);
  ASSERT_TRUE(scene.ok()) << scene.status().ToString();
  EXPECT_EQ(scene->meshes[0].name, "names");
  EXPECT_EQ(scene->total_faces(), 2u);
  ExpectExportsWithValidNames(*scene);
}

}  // namespace
}  // namespace meshstream

// OBJ/PLY/OFF/STL import (importers/mesh_io.h): the shared models with their
// known counts, small synthetic files with exact expected arrays, and hostile
// files that must give a clear error instead of a crash, a hang or a huge
// allocation.
#include "importers/mesh_io.h"

#include <gtest/gtest.h>

#include <stdlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace meshstream {
namespace {

std::string ModelPath(const std::string& name) { return std::string(MESHSTREAM_MODELS_DIR) + "/" + name; }

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// A fresh folder under the system's temporary directory, removed at the end.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "meshstream-mesh-io-XXXXXX").string();
    if (mkdtemp(pattern.data()) != nullptr) path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string File(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

StatusOr<Scene> Import(const std::string& path, uint64_t max_bytes = kDefaultMaxInputBytes) {
  ImportOptions options;
  options.max_input_bytes = max_bytes;
  return ImportMeshFile(path, options);
}

Scene MustImport(const std::string& path) {
  auto scene = Import(path);
  EXPECT_TRUE(scene.ok()) << scene.status().ToString();
  return scene.ok() ? std::move(scene).value() : Scene{};
}

const Primitive& Only(const Scene& s) {
  static const Primitive empty;
  if (s.meshes.size() != 1 || s.meshes[0].primitives.size() != 1) {
    ADD_FAILURE() << "expected one mesh with one primitive";
    return empty;
  }
  return s.meshes[0].primitives[0];
}

// Asserts an error with `code` whose message names the file and contains
// every one of `needles`.
void ExpectError(const StatusOr<Scene>& result, StatusCode code, const std::string& path,
                 const std::vector<std::string>& needles) {
  ASSERT_FALSE(result.ok()) << "expected an error for " << path;
  EXPECT_EQ(result.status().code(), code) << result.status().ToString();
  const std::string& m = result.status().message();
  EXPECT_EQ(m.rfind(path, 0), 0u) << "message does not start with the file name: " << m;
  for (const std::string& needle : needles) {
    EXPECT_NE(m.find(needle), std::string::npos) << "'" << needle << "' not in: " << m;
  }
}

bool ModelsPresent() {
  return std::ifstream(ModelPath("stanford-bunny.obj")).good();
}

#define REQUIRE_MODELS()                                                           \
  do {                                                                             \
    ASSERT_TRUE(ModelsPresent()) << "shared models not found at " MESHSTREAM_MODELS_DIR; \
  } while (false)

// Little helper to write binary files.
struct Bytes {
  bool big_endian = false;
  std::string s;
  template <typename T>
  Bytes& put(T v) {
    char raw[sizeof(T)];
    std::memcpy(raw, &v, sizeof(T));
    if (big_endian) {
      for (size_t i = sizeof(T); i-- > 0;) s += raw[i];
    } else {
      s.append(raw, sizeof(T));
    }
    return *this;
  }
  Bytes& f32(float v) { return put(v); }
  Bytes& f64(double v) { return put(v); }
  Bytes& u8(uint8_t v) { return put(v); }
  Bytes& u16(uint16_t v) { return put(v); }
  Bytes& i32(int32_t v) { return put(v); }
  Bytes& u32(uint32_t v) { return put(v); }
};

// ------------------------------------------------------------ shared models

TEST(MeshIoModels, BunnyKeepsItsUnreferencedVertices) {
  REQUIRE_MODELS();
  const Scene s = MustImport(ModelPath("stanford-bunny.obj"));
  const Primitive& p = Only(s);
  EXPECT_EQ(p.vertex_count(), 35947u);
  EXPECT_EQ(s.source_vertices, 35947u);
  EXPECT_EQ(p.face_count(), 69451u);
  const std::set<uint32_t> referenced(p.indices.begin(), p.indices.end());
  EXPECT_EQ(referenced.size(), 34834u);
  EXPECT_TRUE(p.normals.empty());
  EXPECT_TRUE(p.texcoords.empty());
  EXPECT_TRUE(p.colors.empty());
  EXPECT_EQ(s.meshes[0].name, "stanford-bunny");
  EXPECT_TRUE(s.warnings.empty()) << s.warnings[0];
}

TEST(MeshIoModels, HorseIsABinaryPlyWithNormals) {
  REQUIRE_MODELS();
  const Scene s = MustImport(ModelPath("horse.ply"));
  const Primitive& p = Only(s);
  EXPECT_EQ(p.vertex_count(), 48485u);
  EXPECT_EQ(s.source_vertices, 48485u);
  EXPECT_EQ(p.face_count(), 96966u);
  ASSERT_EQ(p.normals.size(), 48485u);
  EXPECT_EQ(p.AttributeNames(), (std::vector<std::string>{"POSITION", "NORMAL"}));
  // The file stores scaled normals (lengths 0.05 to 13); they come back as
  // unit vectors in the same direction, with a warning.
  size_t unit = 0;
  for (const Vec3f& n : p.normals) {
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (std::fabs(len - 1.f) < 1e-5f) ++unit;
  }
  EXPECT_EQ(unit, p.normals.size());
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("normalized"), std::string::npos) << s.warnings[0];
  // The first records, read from the file independently (x y z nx ny nz as
  // little-endian floats after the header).
  std::ifstream in(ModelPath("horse.ply"), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t body = bytes.find("end_header\n") + 11;
  for (size_t v = 0; v < 50; ++v) {
    float r[6];
    std::memcpy(r, bytes.data() + body + 24 * v, sizeof r);
    EXPECT_EQ(p.positions[v], (Vec3f{r[0], r[1], r[2]})) << v;
    const float len = std::sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(p.normals[v][static_cast<size_t>(c)], r[3 + c] / len, 1e-6f) << v;
  }
  EXPECT_TRUE(p.texcoords.empty());
}

TEST(MeshIoModels, FandiskCounts) {
  REQUIRE_MODELS();
  const Scene s = MustImport(ModelPath("fandisk.obj"));
  EXPECT_EQ(Only(s).vertex_count(), 6475u);
  EXPECT_EQ(Only(s).face_count(), 12946u);
}

TEST(MeshIoModels, RockerArmCounts) {
  REQUIRE_MODELS();
  const Scene s = MustImport(ModelPath("rocker-arm.obj"));
  EXPECT_EQ(Only(s).vertex_count(), 10044u);
  EXPECT_EQ(Only(s).face_count(), 20088u);
}

TEST(MeshIoModels, SpotSplitsUvSeamsAndKeepsEveryCornersUv) {
  REQUIRE_MODELS();
  const std::string path = ModelPath("spot.obj");
  const Scene s = MustImport(path);
  const Primitive& p = Only(s);
  EXPECT_EQ(s.source_vertices, 2930u);
  EXPECT_EQ(p.face_count(), 5856u);
  ASSERT_EQ(p.texcoords.size(), 1u);
  EXPECT_EQ(p.AttributeNames(), (std::vector<std::string>{"POSITION", "TEXCOORD_0"}));
  EXPECT_GE(p.vertex_count(), 3225u);
  ASSERT_EQ(p.texcoords[0].size(), p.vertex_count());

  // The file's own v / vt / f, read independently.
  std::vector<Vec3f> v;
  std::vector<Vec2f> vt;
  std::vector<std::array<int, 6>> faces;  // v and vt index (1-based) of 3 corners
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    if (key == "v") {
      Vec3f x;
      ls >> x[0] >> x[1] >> x[2];
      v.push_back(x);
    } else if (key == "vt") {
      Vec2f t;
      ls >> t[0] >> t[1];
      vt.push_back(t);
    } else if (key == "f") {
      std::array<int, 6> f{};
      for (int c = 0; c < 3; ++c) {
        std::string corner;
        ls >> corner;
        ASSERT_EQ(std::sscanf(corner.c_str(), "%d/%d", &f[2 * c], &f[2 * c + 1]), 2) << corner;
      }
      faces.push_back(f);
    }
  }
  ASSERT_EQ(v.size(), 2930u);
  ASSERT_EQ(vt.size(), 3225u);
  ASSERT_EQ(faces.size(), p.face_count());
  auto close = [](float a, float b) { return std::fabs(a - b) <= 1e-6f * std::max(1.f, std::fabs(b)); };
  size_t mismatches = 0;
  for (size_t f = 0; f < faces.size(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const uint32_t index = p.indices[3 * f + static_cast<size_t>(c)];
      const Vec3f& pos = v[static_cast<size_t>(faces[f][2 * c] - 1)];
      const Vec2f& uv = vt[static_cast<size_t>(faces[f][2 * c + 1] - 1)];
      const bool same = close(p.positions[index][0], pos[0]) && close(p.positions[index][1], pos[1]) &&
                        close(p.positions[index][2], pos[2]) && close(p.texcoords[0][index][0], uv[0]) &&
                        close(p.texcoords[0][index][1], uv[1]);
      if (!same && mismatches++ < 5) ADD_FAILURE() << "face " << f << " corner " << c << " differs";
    }
  }
  EXPECT_EQ(mismatches, 0u);
  // The first 2930 vertices are the file's positions in file order.
  for (size_t i = 0; i < v.size(); i += 97) {
    EXPECT_TRUE(close(p.positions[i][0], v[i][0]) && close(p.positions[i][2], v[i][2])) << i;
  }
  // Every split vertex is a copy of a file position.
  for (size_t i = v.size(); i < p.vertex_count(); ++i) {
    bool found = false;
    for (const Vec3f& x : v) found = found || x == p.positions[i];
    if (!found) {
      ADD_FAILURE() << "split vertex " << i << " is not a file position";
      break;
    }
  }
}

// ---------------------------------------------------------------- synthetic

class MeshIoFiles : public ::testing::Test {
 protected:
  std::string Write(const std::string& name, const std::string& content) {
    const std::string path = dir_.File(name);
    WriteText(path, content);
    return path;
  }
  TempDir dir_;
};

TEST_F(MeshIoFiles, AsciiPlyWithNormalsColoursAndAQuad) {
  const std::string path = Write("quad.ply",
                                 "ply\n"
                                 "format ascii 1.0\n"
                                 "comment made by hand\n"
                                 "element vertex 5\n"
                                 "property float x\nproperty float y\nproperty float z\n"
                                 "property float nx\nproperty float ny\nproperty float nz\n"
                                 "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                                 "element face 2\n"
                                 "property list uchar int vertex_indices\n"
                                 "end_header\n"
                                 "0 0 0 0 0 1 255 0 0\n"
                                 "1 0 0 0 0 1 0 255 0\n"
                                 "1 1 0 0 0 1 0 0 255\n"
                                 "0 1 0 0 0 1 128 128 128\n"
                                 "5 5 5 1 0 0 0 0 0\n"
                                 "4 0 1 2 3\n"
                                 "3 0 2 3\n");
  const Scene s = MustImport(path);
  const Primitive& p = Only(s);
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {5, 5, 5}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 2, 3}));
  ASSERT_EQ(p.normals.size(), 5u);
  EXPECT_EQ(p.normals[0], (Vec3f{0, 0, 1}));
  EXPECT_EQ(p.normals[4], (Vec3f{1, 0, 0}));
  ASSERT_EQ(p.colors.size(), 5u);
  EXPECT_EQ(p.colors[0], (Vec4f{1, 0, 0, 1}));
  EXPECT_EQ(p.colors[2], (Vec4f{0, 0, 1, 1}));
  EXPECT_NEAR(p.colors[3][0], 0.2158605f, 1e-5f);  // sRGB 128 is linear 0.2158605
  EXPECT_EQ(s.source_vertices, 5u);  // the unreferenced vertex 4 stays
}

TEST_F(MeshIoFiles, AsciiPlyWithCrLfObjInfoAndTexcoords) {
  const std::string path = Write("crlf.ply",
                                 "ply\r\nformat ascii 1.0\r\nobj_info element property\r\n"
                                 "element vertex 3\r\nproperty double x\r\nproperty double y\r\n"
                                 "property double z\r\nproperty float u\r\nproperty float v\r\n"
                                 "element face 1\r\nproperty list uchar uint vertex_indices\r\n"
                                 "end_header\r\n"
                                 "0 0 0 0 0\r\n2 0 0 1 0\r\n0 2 0 0 1\r\n3 0 1 2\r\n");
  const Primitive p = Only(MustImport(path));
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2}));
  ASSERT_EQ(p.texcoords.size(), 1u);
  EXPECT_EQ(p.texcoords[0], (std::vector<Vec2f>{{0, 0}, {1, 0}, {0, 1}}));
}

std::string BinaryPlyHeader(const std::string& format, const std::string& vertex_props,
                            uint32_t vertices, const std::string& face_props, uint32_t faces,
                            const std::string& extra = "") {
  std::ostringstream h;
  h << "ply\nformat " << format << " 1.0\n"
    << "element vertex " << vertices << "\n" << vertex_props << "element face " << faces << "\n"
    << face_props << extra << "end_header\n";
  return h.str();
}

TEST_F(MeshIoFiles, BinaryLittleEndianPlyWithExtraProperties) {
  Bytes b;
  b.s = BinaryPlyHeader("binary_little_endian",
                        "property float x\nproperty float y\nproperty float z\nproperty float quality\n", 4,
                        "property list uchar int vertex_indices\nproperty int flags\n", 2,
                        "element edge 1\nproperty list uchar int vertex_pair\n");
  const float xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0.5f}};
  for (const auto& v : xyz) b.f32(v[0]).f32(v[1]).f32(v[2]).f32(42.f);
  b.u8(3).i32(0).i32(1).i32(2).i32(7);
  b.u8(4).i32(0).i32(1).i32(2).i32(3).i32(7);
  b.u8(2).i32(0).i32(1);  // the edge element after the faces
  const Primitive p = Only(MustImport(Write("le.ply", b.s)));
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0.5f}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 1, 2, 0, 2, 3}));
  EXPECT_TRUE(p.normals.empty());
}

TEST_F(MeshIoFiles, BinaryBigEndianPlyWithDoubles) {
  Bytes b;
  b.big_endian = true;
  b.s = BinaryPlyHeader("binary_big_endian", "property double x\nproperty double y\nproperty double z\n", 3,
                        "property list uint16 uint vertex_indices\n", 1);
  b.f64(1.5).f64(-2).f64(3).f64(4).f64(5).f64(6).f64(7).f64(8).f64(9.25);
  b.u16(3).u32(2).u32(1).u32(0);
  const Primitive p = Only(MustImport(Write("be.ply", b.s)));
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{1.5f, -2, 3}, {4, 5, 6}, {7, 8, 9.25f}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{2, 1, 0}));
}

// OpenMesh would start the binary data one byte late after a comment right
// before end_header; the header it reads is rewritten, so this file is read
// right.
TEST_F(MeshIoFiles, BinaryPlyWithCommentBeforeEndHeader) {
  Bytes b;
  b.s = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        "comment last line before end_header   \n\nend_header\n";
  b.f32(1).f32(2).f32(3).f32(4).f32(5).f32(6).f32(7).f32(8).f32(9);
  b.u8(3).i32(0).i32(1).i32(2);
  const Primitive p = Only(MustImport(Write("comment.ply", b.s)));
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{1, 2, 3}, {4, 5, 6}, {7, 8, 9}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2}));
}

// OpenMesh's PLY reader knows only 'vertex' and 'face' elements; the strips
// are read by mesh_io.cc and turned into triangles as glTF's TRIANGLE_STRIP.
const char kStripVertices5[] =
    "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n";
const char kStripBody5[] = "0 0 0\n1 0 0\n0 1 0\n1 1 0\n2 0 0\n";

TEST_F(MeshIoFiles, PlyTriangleStripBecomesTriangles) {
  const std::string path = Write("strip.ply", std::string(kStripVertices5) +
                                                  "element tristrips 1\nproperty list int int vertex_indices\n"
                                                  "end_header\n" + kStripBody5 + "5 0 1 2 3 4\n");
  const Primitive p = Only(MustImport(path));
  EXPECT_EQ(p.positions.size(), 5u);
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3, 2, 3, 4}));
}

TEST_F(MeshIoFiles, PlyTriangleStripRestartStartsANewRun) {
  // Two records: the first restarts after 3 entries; the second is its own
  // run, whose degenerate first triangle (1,1,2) is skipped.
  const std::string path = Write("restart.ply", std::string(kStripVertices5) +
                                                    "element tristrips 2\nproperty list uchar int "
                                                    "vertex_indices\nend_header\n" + kStripBody5 +
                                                    "7 0 1 2 -1 3 2 4\n4 1 1 2 3\n");
  const Primitive p = Only(MustImport(path));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 3, 2, 4, 2, 1, 3}));
}

TEST_F(MeshIoFiles, BinaryPlyWithVerticesAndStripsOnly) {
  Bytes b;
  b.s = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n";
  b.f32(0).f32(0).f32(0).f32(1).f32(0).f32(0).f32(0).f32(1).f32(0).f32(1).f32(1).f32(0);
  b.i32(5).i32(0).i32(1).i32(-1).i32(2).i32(3);
  const std::string path = Write("strip_le.ply", b.s);
  // Run [0 1] gives nothing; run [2 3] neither: no triangles.
  ExpectError(Import(path), StatusCode::kInvalidInput, path, {"no triangles"});

  Bytes c;
  c.s = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement tristrips 1\nproperty list uchar int vertex_indices\nend_header\n";
  c.f32(0).f32(0).f32(0).f32(1).f32(0).f32(0).f32(0).f32(1).f32(0).f32(1).f32(1).f32(0);
  c.u8(4).i32(0).i32(1).i32(2).i32(3);
  const Primitive p = Only(MustImport(Write("strip_le2.ply", c.s)));
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
}

TEST_F(MeshIoFiles, PlyFacesComeBeforeStripTriangles) {
  const std::string path = Write("both.ply", std::string(kStripVertices5) +
                                                 "element face 1\nproperty list uchar int vertex_indices\n"
                                                 "element tristrips 1\nproperty list int int vertex_indices\n"
                                                 "end_header\n" + kStripBody5 + "3 4 3 2\n4 0 1 2 3\n");
  const Primitive p = Only(MustImport(path));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{4, 3, 2, 0, 1, 2, 2, 1, 3}));
}

TEST_F(MeshIoFiles, BadPlyTriangleStripsAreRefused) {
  const std::string head = std::string(kStripVertices5) +
                           "element tristrips 2\nproperty list int int vertex_indices\nend_header\n" +
                           kStripBody5;
  const std::string range = Write("strip_range.ply", head + "3 0 1 2\n3 0 1 5\n");
  ExpectError(Import(range), StatusCode::kInvalidInput, range, {"tristrips 1 of 2", "entry 2", "vertex 5"});
  const std::string negative = Write("strip_negative.ply", head + "3 0 1 2\n3 0 -2 1\n");
  ExpectError(Import(negative), StatusCode::kInvalidInput, negative, {"tristrips 1 of 2", "-2"});
  const std::string truncated = Write("strip_short.ply", head + "3 0 1 2\n4 0 1 2\n");
  ExpectError(Import(truncated), StatusCode::kInvalidInput, truncated, {"truncated", "tristrips 1 of 2"});

  Bytes b;
  b.s = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n";
  b.f32(0).f32(0).f32(0).f32(1).f32(0).f32(0).f32(0).f32(1).f32(0);
  Bytes range_b = b;
  range_b.i32(3).i32(0).i32(1).i32(3);
  const std::string brange = Write("strip_range_b.ply", range_b.s);
  ExpectError(Import(brange), StatusCode::kInvalidInput, brange, {"tristrips 0 of 1", "vertex 3"});
  Bytes short_b = b;
  short_b.i32(4).i32(0).i32(1).i32(2);
  const std::string bshort = Write("strip_short_b.ply", short_b.s);
  ExpectError(Import(bshort), StatusCode::kInvalidInput, bshort, {"truncated", "tristrips 0 of 1"});
}

TEST_F(MeshIoFiles, PlyTriangleStripsOpenMeshCannotSkipAreRefused) {
  const std::string not_last = Write("strip_first.ply", std::string(kStripVertices5) +
                                                            "element tristrips 1\nproperty list int int "
                                                            "vertex_indices\nelement face 1\nproperty list "
                                                            "uchar int vertex_indices\nend_header\n" +
                                                            kStripBody5 + "3 0 1 2\n3 0 1 2\n");
  ExpectError(Import(not_last), StatusCode::kUnsupported, not_last, {"tristrips", "last"});
  const std::string extra = Write("strip_extra.ply", std::string(kStripVertices5) +
                                                         "element tristrips 1\nproperty list int int "
                                                         "vertex_indices\nproperty int flags\nend_header\n" +
                                                         kStripBody5 + "3 0 1 2 7\n");
  ExpectError(Import(extra), StatusCode::kUnsupported, extra, {"tristrips"});
}

TEST_F(MeshIoFiles, OffWithAQuad) {
  const std::string path = Write("quad.off",
                                 "OFF\n5 2 0\n"
                                 "0 0 0\n1 0 0\n1 1 0 \n0 1\n0\n9 9 9\n"
                                 "4 0 1 2 3\n3 3 2 4\n");
  const Scene s = MustImport(path);
  const Primitive& p = Only(s);
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {9, 9, 9}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 3, 2, 4}));
  EXPECT_TRUE(p.normals.empty());
  EXPECT_TRUE(p.colors.empty());
}

TEST_F(MeshIoFiles, OffWithNormalsAndColours) {
  const std::string noff = Write("n.off", "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 1 0\n0 1 0 1 0 0\n3 0 1 2\n");
  const Primitive n = Only(MustImport(noff));
  EXPECT_EQ(n.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_EQ(n.normals, (std::vector<Vec3f>{{0, 0, 1}, {0, 1, 0}, {1, 0, 0}}));

  const std::string coff = Write("c.off", "COFF\n3 1 0\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255 255\n"
                                          "3 0 1 2 10 20 30\n");
  const Primitive c = Only(MustImport(coff));
  EXPECT_EQ(c.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_EQ(c.colors, (std::vector<Vec4f>{{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}}));
  EXPECT_EQ(c.indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST_F(MeshIoFiles, AsciiStlMergesSharedCorners) {
  const std::string path = Write("two.stl",
                                 "solid two\n"
                                 "  facet normal 0 0 1\n    outer loop\n"
                                 "      vertex 0 0 0\n      vertex 1 0 0\n      vertex 1 1 0\n"
                                 "    endloop\n  endfacet\n"
                                 "  facet normal 0 0 1\n    outer loop\n"
                                 "      vertex 0 0 0\n      vertex 1 1 0\n      vertex 0 1 0\n"
                                 "    endloop\n  endfacet\n"
                                 "endsolid two\n");
  const Scene s = MustImport(path);
  const Primitive& p = Only(s);
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(s.source_vertices, 4u);
  EXPECT_TRUE(s.warnings.empty());
}

std::string BinaryStl(const std::vector<std::array<float, 9>>& triangles, int64_t declared = -1) {
  Bytes b;
  b.s = std::string(80, ' ');
  b.s.replace(0, 12, "solid binary");  // a header starting with "solid" is legal
  b.u32(static_cast<uint32_t>(declared < 0 ? static_cast<int64_t>(triangles.size()) : declared));
  for (const auto& t : triangles) {
    b.f32(0).f32(0).f32(1);
    for (float c : t) b.f32(c);
    b.put<uint16_t>(0);
  }
  return b.s;
}

TEST_F(MeshIoFiles, BinaryStlMergesSharedCornersAndWarnsOnDegenerateTriangles) {
  const std::string path = Write("two.stl", BinaryStl({{0, 0, 0, 1, 0, 0, 1, 1, 0},
                                                       {0, 0, 0, 1, 1, 0, 0, 1, 0},
                                                       {0, 0, 0, 0, 0, 0, 1, 0, 0}}));
  const Scene s = MustImport(path);
  const Primitive& p = Only(s);
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("dropped 1 of 3"), std::string::npos) << s.warnings[0];
}

TEST_F(MeshIoFiles, ObjQuadBecomesTwoTriangles) {
  const std::string path = Write("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  const Scene s = MustImport(path);
  const Primitive& p = Only(s);
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(s.source_vertices, 4u);
}

TEST_F(MeshIoFiles, ObjPentagonIsFannedAndUnreferencedVerticesStay) {
  const std::string path = Write("penta.obj",
                                 "# a pentagon and a lonely vertex\n"
                                 "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nv 7 7 7\n"
                                 "g part\nusemtl nothing\nf -6 -5 -4 -3 -2\n");
  const Primitive p = Only(MustImport(path));
  EXPECT_EQ(p.vertex_count(), 6u);
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
  EXPECT_EQ(p.positions[5], (Vec3f{7, 7, 7}));
}

TEST_F(MeshIoFiles, ObjSeamsAreSplitPerCorner) {
  // Two triangles share the edge 1-3; vertex 3 has a different uv in each
  // (a seam), vertex 1 the same uv; normals per face.
  const std::string path = Write("seam.obj",
                                 "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                 "vt 0 0\nvt 1 0\nvt 1 1\nvt 0.5 0.5\nvt 0 1\n"
                                 "vn 0 0 1\n"
                                 "f 1/1/1 2/2/1 3/3/1\n"
                                 "f 1/1/1 3/4/1 4/5/1\n");
  const Scene s = MustImport(path);
  const Primitive& p = Only(s);
  EXPECT_EQ(s.source_vertices, 4u);
  ASSERT_EQ(p.vertex_count(), 5u);  // vertex 3 (index 2) split once
  EXPECT_EQ(p.positions[4], (Vec3f{1, 1, 0}));
  EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 4, 3}));
  ASSERT_EQ(p.texcoords.size(), 1u);
  EXPECT_EQ(p.texcoords[0], (std::vector<Vec2f>{{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5f, 0.5f}}));
  EXPECT_EQ(p.normals, (std::vector<Vec3f>(5, Vec3f{0, 0, 1})));
}

TEST_F(MeshIoFiles, ObjVertexColours) {
  const std::string path = Write("col.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n");
  const Primitive p = Only(MustImport(path));
  EXPECT_EQ(p.colors, (std::vector<Vec4f>{{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}}));
}

TEST_F(MeshIoFiles, UppercaseExtensionsWork) {
  const std::string off = Write("tri.OFF", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(Only(MustImport(off)).face_count(), 1u);
  const std::string ply = Write("tri.PLY", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                           "property float y\nproperty float z\nelement face 1\n"
                                           "property list uchar int vertex_indices\nend_header\n"
                                           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(Only(MustImport(ply)).face_count(), 1u);
}

// OpenMesh's readers are global singletons; imports from several threads must
// still each get their own, correct result.
TEST_F(MeshIoFiles, ParallelImportsOfEveryFormat) {
  const std::vector<std::string> paths = {
      Write("p.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n"),
      Write("p.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                     "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"),
      Write("p.stl", BinaryStl({{0, 0, 0, 1, 0, 0, 1, 1, 0}, {0, 0, 0, 1, 1, 0, 0, 1, 0}})),
      Write("p.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"),
  };
  std::vector<std::thread> threads;
  std::vector<int> failures(8, 0);
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t]() {
      for (int round = 0; round < 25; ++round) {
        for (const std::string& path : paths) {
          auto s = Import(path);
          if (!s.ok() || s->total_vertices() != 4 || s->total_faces() != 2) ++failures[static_cast<size_t>(t)];
        }
      }
    });
  }
  for (std::thread& t : threads) t.join();
  for (int f : failures) EXPECT_EQ(f, 0);
}

// ------------------------------------------------------------------ hostile

TEST_F(MeshIoFiles, EmptyFilesAreRefused) {
  for (const char* name : {"e.obj", "e.ply", "e.off", "e.stl"}) {
    const std::string path = Write(name, "");
    ExpectError(Import(path), StatusCode::kInvalidInput, path, {"empty"});
  }
}

TEST_F(MeshIoFiles, MissingFileAndUnknownExtension) {
  const std::string missing = dir_.File("nope.ply");
  ExpectError(Import(missing), StatusCode::kNotFound, missing, {});
  const std::string other = Write("x.3ds", "whatever");
  ExpectError(Import(other), StatusCode::kUnsupported, other, {".3ds"});
}

TEST_F(MeshIoFiles, FilesAboveTheCapAreRefusedBeforeReading) {
  const std::string path = Write("big.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  ExpectError(Import(path, 10), StatusCode::kResourceExhausted, path, {"cap"});
}

TEST_F(MeshIoFiles, BinaryPlyClaimingHugeCountsIn300Bytes) {
  Bytes b;
  b.s = BinaryPlyHeader("binary_little_endian", "property float x\nproperty float y\nproperty float z\n",
                        400000000, "property list uchar int vertex_indices\n", 1);
  while (b.s.size() < 300) b.u8(0);
  const std::string path = Write("huge.ply", b.s);
  ::testing::internal::CaptureStderr();
  const auto result = Import(path);
  const std::string err = ::testing::internal::GetCapturedStderr();
  ExpectError(result, StatusCode::kInvalidInput, path, {"400000000", "vertex"});
  EXPECT_EQ(err, "");  // refused before OpenMesh saw it: nothing printed
}

TEST_F(MeshIoFiles, AsciiPlyClaimingHugeCounts) {
  const std::string path = Write("huge.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                             "property float y\nproperty float z\nelement face 4000000000\n"
                                             "property list uchar int vertex_indices\nend_header\n"
                                             "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  ExpectError(Import(path), StatusCode::kInvalidInput, path, {"4000000000", "face"});
}

TEST_F(MeshIoFiles, PlyCountsAbove32BitsAreRefused) {
  const std::string path = Write("wide.ply", "ply\nformat ascii 1.0\nelement vertex 4294967296\n"
                                             "property float x\nend_header\n");
  ExpectError(Import(path), StatusCode::kInvalidInput, path, {"4294967296"});
}

TEST_F(MeshIoFiles, PlyWithoutEndHeaderIsRefused) {
  // OpenMesh's header parser loops forever on this.
  const std::string path = Write("open.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  ExpectError(Import(path), StatusCode::kInvalidInput, path, {"end_header"});
}

TEST_F(MeshIoFiles, PlyHeaderMistakes) {
  const std::string not_ply = Write("a.ply", "plx\n");
  ExpectError(Import(not_ply), StatusCode::kInvalidInput, not_ply, {"not a PLY"});
  const std::string orphan = Write("b.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n");
  ExpectError(Import(orphan), StatusCode::kInvalidInput, orphan, {"property before any element"});
  const std::string int64 = Write("c.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty int64 x\nend_header\n");
  ExpectError(Import(int64), StatusCode::kUnsupported, int64, {"int64"});
  const std::string no_faces = Write("d.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                              "property float y\nproperty float z\nend_header\n0 0 0\n");
  ExpectError(Import(no_faces), StatusCode::kInvalidInput, no_faces, {"no triangles"});
}

TEST_F(MeshIoFiles, PlyWithZeroFacesHasNoTriangles) {
  const std::string path = Write("zero.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                             "property float y\nproperty float z\nelement face 0\n"
                                             "property list uchar int vertex_indices\nend_header\n"
                                             "0 0 0\n1 0 0\n0 1 0\n");
  ExpectError(Import(path), StatusCode::kInvalidInput, path, {"no triangles"});
}

TEST_F(MeshIoFiles, PlyPropertiesOpenMeshWouldMisread) {
  const std::string list = Write("l.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                          "property float y\nproperty float z\n"
                                          "property list uchar float weights\nelement face 0\n"
                                          "property list uchar int vertex_indices\nend_header\n0 0 0 0\n");
  ExpectError(Import(list), StatusCode::kUnsupported, list, {"weights", "list"});
  Bytes b;
  b.s = BinaryPlyHeader("binary_little_endian", "property int x\nproperty int y\nproperty int z\n", 3,
                        "property list uchar int vertex_indices\n", 1);
  for (int i = 0; i < 9; ++i) b.i32(i);
  b.u8(3).i32(0).i32(1).i32(2);
  const std::string ints = Write("i.ply", b.s);
  ExpectError(Import(ints), StatusCode::kUnsupported, ints, {"'x'", "float or double"});
  const std::string texlist = Write("t.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                             "property float y\nproperty float z\nelement face 1\n"
                                             "property list uchar int vertex_indices\n"
                                             "property list uchar float texcoord\nend_header\n"
                                             "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 6 0 0 1 0 0 1\n");
  ExpectError(Import(texlist), StatusCode::kUnsupported, texlist, {"texcoord"});
  // OpenMesh forgets face properties declared before the index list.
  Bytes f;
  f.s = BinaryPlyHeader("binary_little_endian", "property float x\nproperty float y\nproperty float z\n", 3,
                        "property int flags\nproperty list uchar int vertex_indices\n", 1);
  for (int i = 0; i < 9; ++i) f.f32(static_cast<float>(i));
  f.i32(7).u8(3).i32(0).i32(1).i32(2);
  const std::string flags = Write("f.ply", f.s);
  ExpectError(Import(flags), StatusCode::kUnsupported, flags, {"before 'vertex_indices'", "'flags'"});
}

std::string SmallBinaryPly() {
  Bytes b;
  b.s = BinaryPlyHeader("binary_little_endian", "property float x\nproperty float y\nproperty float z\n", 3,
                        "property list uchar int vertex_indices\n", 2);
  for (int i = 0; i < 9; ++i) b.f32(static_cast<float>(i));
  b.u8(3).i32(0).i32(1).i32(2);
  b.u8(3).i32(2).i32(1).i32(0);
  return b.s;
}

TEST_F(MeshIoFiles, TruncatedBinaryPly) {
  const std::string whole = SmallBinaryPly();
  EXPECT_EQ(Only(MustImport(Write("whole.ply", whole))).face_count(), 2u);
  for (size_t cut : {size_t{1}, size_t{5}, size_t{13}, size_t{30}}) {
    const std::string path = Write("cut" + std::to_string(cut) + ".ply", whole.substr(0, whole.size() - cut));
    ExpectError(Import(path), StatusCode::kInvalidInput, path, {});
    const std::string m = Import(path).status().message();
    EXPECT_TRUE(m.find("truncated") != std::string::npos || m.find("can hold") != std::string::npos) << m;
  }
}

TEST_F(MeshIoFiles, BinaryPlyListLengthsAreChecked) {
  // A face claiming 255 corners with 12 bytes left.
  std::string s = SmallBinaryPly();
  s[s.size() - 13] = static_cast<char>(255);
  const std::string long_list = Write("long.ply", s);
  ExpectError(Import(long_list), StatusCode::kInvalidInput, long_list, {"face 1 of 2", "255"});
  // An int length that is negative (OpenMesh would read it as 4 billion).
  Bytes b;
  b.s = BinaryPlyHeader("binary_little_endian", "property float x\nproperty float y\nproperty float z\n", 3,
                        "property list int int vertex_indices\n", 1);
  for (int i = 0; i < 9; ++i) b.f32(0);
  b.i32(-1).i32(0).i32(1).i32(2);
  const std::string negative = Write("neg.ply", b.s);
  ExpectError(Import(negative), StatusCode::kInvalidInput, negative, {"negative"});
  // Faces need three corners; refused before any array is built for them.
  std::string two = SmallBinaryPly();
  two[two.size() - 13] = 2;
  two.resize(two.size() - 4);
  const std::string two_corners = Write("two.ply", two);
  ExpectError(Import(two_corners), StatusCode::kInvalidInput, two_corners, {"face 1 of 2", "2 corners"});
}

TEST_F(MeshIoFiles, AsciiPlyHugeListLength) {
  const std::string path = Write("list.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                             "property float y\nproperty float z\nelement face 1\n"
                                             "property list int int vertex_indices\nend_header\n"
                                             "0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n");
  ExpectError(Import(path), StatusCode::kInvalidInput, path, {"truncated", "face 0 of 1"});
}

TEST_F(MeshIoFiles, PlyFaceIndexOutOfRange) {
  const std::string path = Write("range.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                              "property float y\nproperty float z\nelement face 2\n"
                                              "property list uchar int vertex_indices\nend_header\n"
                                              "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 3\n");
  ExpectError(Import(path), StatusCode::kInvalidInput, path, {"face 1", "vertex 3", "out of range"});
  std::string s = SmallBinaryPly();
  std::memset(&s[s.size() - 4], 0xff, 4);  // index -1 (0xffffffff)
  const std::string binary = Write("range-bin.ply", s);
  ExpectError(Import(binary), StatusCode::kInvalidInput, binary, {"face 1", "4294967295", "out of range"});
}

TEST_F(MeshIoFiles, NonFiniteCoordinates) {
  std::string s = SmallBinaryPly();
  const float nan = std::nanf("");
  const size_t body = s.find("end_header\n") + 11;
  std::memcpy(&s[body + 4 * 4], &nan, 4);  // vertex 1, y
  const std::string binary = Write("nan-bin.ply", s);
  ExpectError(Import(binary), StatusCode::kInvalidInput, binary, {"POSITION[1]", "not a finite number"});

  const std::string ascii = Write("nan.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                             "property float y\nproperty float z\nelement face 1\n"
                                             "property list uchar int vertex_indices\nend_header\n"
                                             "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
  ExpectError(Import(ascii), StatusCode::kInvalidInput, ascii, {"line 11", "vertex 1", "'nan'"});
  const std::string huge = Write("huge.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                             "property float y\nproperty float z\nelement face 1\n"
                                             "property list uchar int vertex_indices\nend_header\n"
                                             "0 0 0\n1 1e39 0\n0 1 0\n3 0 1 2\n");
  ExpectError(Import(huge), StatusCode::kInvalidInput, huge, {"'1e39'", "float range"});
}

TEST_F(MeshIoFiles, HostileOff) {
  const std::string huge = Write("huge.off", "OFF\n400000000 1 0\n0 0 0\n");
  ExpectError(Import(huge), StatusCode::kInvalidInput, huge, {"400000000"});
  const std::string range = Write("range.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 7\n");
  ExpectError(Import(range), StatusCode::kInvalidInput, range, {"face 1", "vertex 7", "out of range"});
  const std::string nan = Write("nan.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n");
  ExpectError(Import(nan), StatusCode::kInvalidInput, nan, {"vertex 2", "'nan'"});
  const std::string comment = Write("comment.off", "OFF\n# made by hand\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  ExpectError(Import(comment), StatusCode::kUnsupported, comment, {"line 2", "comment"});
  const std::string extra = Write("extra.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 255 0 0\n");
  ExpectError(Import(extra), StatusCode::kInvalidInput, extra, {"face 0", "COFF"});
  const std::string two = Write("two.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
  ExpectError(Import(two), StatusCode::kInvalidInput, two, {"face 0", "2 corners"});
  const std::string list = Write("list.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n");
  ExpectError(Import(list), StatusCode::kInvalidInput, list, {"truncated", "face 0"});
  const std::string truncated = Write("short.off", "OFF\n3 1 0\n0.000 0.000 0.000\n1.000 0.000 0.000\n");
  ExpectError(Import(truncated), StatusCode::kInvalidInput, truncated, {"truncated"});
  const std::string binary = Write("bin.off", "OFF BINARY\n");
  ExpectError(Import(binary), StatusCode::kUnsupported, binary, {"binary"});
  const std::string counts = Write("counts.off", "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  ExpectError(Import(counts), StatusCode::kInvalidInput, counts, {"counts"});
}

TEST_F(MeshIoFiles, HostileStl) {
  std::string whole = BinaryStl({{0, 0, 0, 1, 0, 0, 1, 1, 0}, {0, 0, 0, 1, 1, 0, 0, 1, 0}});
  whole[0] = 'x';  // not "solid": a truncated file cannot pass for ascii
  const std::string truncated = Write("cut.stl", whole.substr(0, whole.size() - 7));
  ExpectError(Import(truncated), StatusCode::kInvalidInput, truncated, {"2 triangles", "184"});
  const std::string lying = Write("lying.stl", BinaryStl({{0, 0, 0, 1, 0, 0, 1, 1, 0}}, 100000000));
  ExpectError(Import(lying), StatusCode::kInvalidInput, lying, {"100000000 triangles"});
  const std::string nan = Write("nan.stl", BinaryStl({{0, 0, 0, 1, std::nanf(""), 0, 1, 1, 0}}));
  ExpectError(Import(nan), StatusCode::kInvalidInput, nan, {"triangle 0", "corner 1", "finite"});
  const std::string ascii_nan = Write("nan-a.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                                                   "vertex 1 0 nan\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n");
  ExpectError(Import(ascii_nan), StatusCode::kInvalidInput, ascii_nan, {"line 5", "'nan'"});
  const std::string no_facets = Write("none.stl", "solid x\nendsolid x\n");
  ExpectError(Import(no_facets), StatusCode::kInvalidInput, no_facets, {"no triangles"});
  const std::string zero = Write("zero.stl", BinaryStl({}));
  ExpectError(Import(zero), StatusCode::kInvalidInput, zero, {"no triangles"});
}

TEST_F(MeshIoFiles, HostileObj) {
  const std::string nan = Write("nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
  ExpectError(Import(nan), StatusCode::kInvalidInput, nan, {"line 2", "'nan'"});
  const std::string inf = Write("inf.obj", "v 0 0 0\nv 1 0 0\r\nvn 0 0 -inf\nf 1 2 3\n");
  ExpectError(Import(inf), StatusCode::kInvalidInput, inf, {"line 3", "'-inf'"});
  const std::string range = Write("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n");
  ExpectError(Import(range), StatusCode::kInvalidInput, range, {"face 1", "vertex index 4", "out of range"});
  const std::string uv = Write("uv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/2\n");
  ExpectError(Import(uv), StatusCode::kInvalidInput, uv, {"face 0", "texture coordinate index 2"});
  const std::string zero = Write("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  ExpectError(Import(zero), StatusCode::kInvalidInput, zero, {"line 4"});
  const std::string tags = Write("tags.obj", "v 0 0 0\nt a 8192/8192/8192\n");
  ExpectError(Import(tags), StatusCode::kUnsupported, tags, {"line 2", "tag"});
  const std::string points = Write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  ExpectError(Import(points), StatusCode::kInvalidInput, points, {"no triangles"});
  const std::string garbage = Write("garbage.obj", "v 0 0 zero\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  ExpectError(Import(garbage), StatusCode::kInvalidInput, garbage, {"line 1", "'zero'"});
}

// None of the hostile files above may make a library print: everything is
// refused before, or reported through the Status.
TEST_F(MeshIoFiles, LibrariesStayQuietOnBadInput) {
  const std::vector<std::string> paths = {
      Write("q1.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                      "0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n"),
      Write("q2.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n"),
      Write("q3.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0 0 0\nvertex 0 0 0\n"
                      "endloop\nendfacet\nendsolid\n"),
  };
  for (const std::string& path : paths) {
    ::testing::internal::CaptureStderr();
    const auto result = Import(path);
    const std::string err = ::testing::internal::GetCapturedStderr();
    EXPECT_FALSE(result.ok()) << path;
    EXPECT_EQ(err, "") << path;
  }
}

}  // namespace
}  // namespace meshstream

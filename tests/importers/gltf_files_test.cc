// importers/gltf_files.h: the external files of a .gltf, as an uploader
// sends them: percent-decoded by CheckUri's one decoder, data: URIs left
// out, each file once, a URI that leaves the folder refused.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "importers/gltf_files.h"

namespace meshstream {
namespace {

StatusOr<std::vector<std::string>> FilesOf(const std::string& json) {
  return GltfExternalFiles(reinterpret_cast<const uint8_t*>(json.data()), json.size(), "scene.gltf");
}

TEST(GltfFiles, BuffersThenImagesDecodedOnceEach) {
  const auto files = FilesOf(R"({
    "buffers": [{"uri": "mesh%20data.bin", "byteLength": 4}, {"uri": "data:application/octet-stream;base64,AAAA"},
                {"uri": "mesh data.bin"}],
    "images": [{"uri": "textures/wood%2Ejpg"}, {"bufferView": 0}, {"uri": "mesh%20data.bin"}]
  })");
  ASSERT_TRUE(files.ok()) << files.status().ToString();
  EXPECT_EQ(files.value(), (std::vector<std::string>{"mesh data.bin", "textures/wood.jpg"}));
}

TEST(GltfFiles, AUriThatLeavesTheFolderIsRefusedNamingIt) {
  for (const char* uri : {"%2e%2e/secret.bin", "../secret.bin", "/etc/passwd", "http://x/y.bin", "a%zz.bin"}) {
    SCOPED_TRACE(uri);
    const auto files = FilesOf(std::string(R"({"images": [{"uri": "ok.png"}, {"uri": ")") + uri + R"("}]})");
    ASSERT_FALSE(files.ok());
    EXPECT_EQ(files.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(files.status().message().find("scene.gltf: images[1].uri"), std::string::npos) << files.status().ToString();
  }
}

TEST(GltfFiles, NotAJsonObjectIsInvalidInput) {
  EXPECT_EQ(FilesOf("[1, 2]").status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(FilesOf("{").status().code(), StatusCode::kInvalidInput);
  const auto none = FilesOf(R"({"asset": {"version": "2.0"}})");
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  EXPECT_EQ(GltfExternalFiles("/no/such/scene.gltf").status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace meshstream

// The file route's path and query (services/http_routes/asset_route.h,
// ParseAssetRequest): what is a request, what is 400, what is 404.
#include "services/http_routes/asset_route.h"

#include <gtest/gtest.h>

#include <string>

namespace meshstream {
namespace {

TEST(AssetRequest, Parses) {
  auto r = ParseAssetRequest("/v1/assets/bunny/versions/3/glb", "");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->asset, "bunny");
  EXPECT_EQ(r->version, 3);
  EXPECT_EQ(r->format, ExportFormat::kGlb);
  EXPECT_FALSE(r->lod.has_value());

  r = ParseAssetRequest("/v1/assets/my.asset_1-x/versions/latest/progressive", "");
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->version, 0);
  EXPECT_EQ(r->format, ExportFormat::kProgressiveGlb);

  r = ParseAssetRequest("/v1/assets/b%75nny/versions/9223372036854775807/draco", "lod=0");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->asset, "bunny");
  EXPECT_EQ(r->version, INT64_MAX);
  EXPECT_EQ(r->format, ExportFormat::kDracoGlb);
  EXPECT_EQ(r->lod, 0);

  EXPECT_EQ(ParseAssetRequest("/v1/assets/a/versions/1/obj", "lod=1048576")->lod, 1 << 20);
  EXPECT_EQ(ParseAssetRequest("/v1/assets/a/versions/1/ply", "")->format, ExportFormat::kPly);
  EXPECT_EQ(ParseAssetRequest("/v1/assets/a/versions/1/obj", "")->format, ExportFormat::kObj);
}

void ExpectRefused(const std::string& path, const std::string& query, StatusCode code, const std::string& words) {
  auto r = ParseAssetRequest(path, query);
  ASSERT_FALSE(r.ok()) << path << "?" << query;
  EXPECT_EQ(r.status().code(), code) << path << "?" << query << ": " << r.status().ToString();
  EXPECT_NE(r.status().message().find(words), std::string::npos) << r.status().message();
}

TEST(AssetRequest, BadVersions) {
  for (const char* v : {"0", "-1", "abc", "01", "+1", "1.0", "", "9223372036854775808", "99999999999999999999",
                        "LATEST", "1e3", "%31"}) {
    ExpectRefused(std::string("/v1/assets/a/versions/") + v + "/glb", "", StatusCode::kInvalidArgument, "version:");
  }
}

TEST(AssetRequest, BadFormats) {
  for (const char* f : {"gltf", "GLB", "", "glb.", "drc"}) {
    ExpectRefused(std::string("/v1/assets/a/versions/1/") + f, "", StatusCode::kInvalidArgument, "format:");
  }
}

TEST(AssetRequest, BadAssets) {
  ExpectRefused("/v1/assets/%2e%2e/versions/1/glb", "", StatusCode::kInvalidArgument, "asset:");
  ExpectRefused("/v1/assets/../versions/1/glb", "", StatusCode::kInvalidArgument, "asset:");
  ExpectRefused("/v1/assets/a%2fb/versions/1/glb", "", StatusCode::kInvalidArgument, "asset:");
  ExpectRefused("/v1/assets/a%00/versions/1/glb", "", StatusCode::kInvalidArgument, "asset:");
  ExpectRefused("/v1/assets/a%zz/versions/1/glb", "", StatusCode::kInvalidArgument, "asset:");
  ExpectRefused("/v1/assets/a%20b/versions/1/glb", "", StatusCode::kInvalidArgument, "asset:");
  ExpectRefused("/v1/assets/" + std::string(129, 'a') + "/versions/1/glb", "", StatusCode::kInvalidArgument,
                "asset:");
}

TEST(AssetRequest, BadQueries) {
  ExpectRefused("/v1/assets/a/versions/1/glb", "lod=-1", StatusCode::kInvalidArgument, "lod");
  ExpectRefused("/v1/assets/a/versions/1/glb", "lod=x", StatusCode::kInvalidArgument, "lod");
  ExpectRefused("/v1/assets/a/versions/1/glb", "lod=", StatusCode::kInvalidArgument, "lod");
  ExpectRefused("/v1/assets/a/versions/1/glb", "lod=1048577", StatusCode::kInvalidArgument, "lod");
  ExpectRefused("/v1/assets/a/versions/1/glb", "lod=1&lod=2", StatusCode::kInvalidArgument, "more than once");
  ExpectRefused("/v1/assets/a/versions/1/glb", "v=3", StatusCode::kInvalidArgument, "unknown parameter");
  ExpectRefused("/v1/assets/a/versions/1/glb", "lod=%zz", StatusCode::kInvalidArgument, "query");
  ExpectRefused("/v1/assets/a/versions/1/progressive", "lod=0", StatusCode::kInvalidArgument, "progressive");
}

TEST(AssetRequest, OtherShapesAreNotFound) {
  for (const char* path : {"/v1/assets/a", "/v1/assets/a/versions", "/v1/assets/a/versions/1",
                           "/v1/assets/a/versions/1/glb/", "/v1/assets/a/version/1/glb", "/v1/assets/a/versions/1/glb/x",
                           "/v1/assets/", "/v1/asset/a/versions/1/glb"}) {
    ExpectRefused(path, "", StatusCode::kNotFound, "no such route");
  }
}

TEST(AssetRequest, ContentTypes) {
  EXPECT_STREQ(InfoOf(ExportFormat::kGlb).content_type, "model/gltf-binary");
  EXPECT_STREQ(InfoOf(ExportFormat::kProgressiveGlb).content_type, "model/gltf-binary");
  EXPECT_STREQ(InfoOf(ExportFormat::kDracoGlb).content_type, "model/gltf-binary");
  EXPECT_STREQ(InfoOf(ExportFormat::kObj).content_type, "model/obj");
  EXPECT_STREQ(InfoOf(ExportFormat::kPly).content_type, "application/octet-stream");
}

}  // namespace
}  // namespace meshstream

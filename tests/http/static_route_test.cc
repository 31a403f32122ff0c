// The viewer's files (services/http_routes/static_route.h): what is served, and
// every way a path could try to leave the root.
#include "services/http_routes/static_route.h"

#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::TempDir;
using test_util::WriteText;

class StaticRouteTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = tmp_.File("web");
    std::filesystem::create_directories(root_ + "/js/sub");
    WriteText(root_ + "/index.html", "<html>index</html>");
    WriteText(root_ + "/js/app.mjs", "export {};");
    WriteText(root_ + "/js/sub/index.html", "sub");
    WriteText(root_ + "/decoder.wasm", "\0asm");
    WriteText(root_ + "/.secret", "hidden");
    WriteText(tmp_.File("outside.txt"), "SECRET-OUTSIDE-CONTENT");
    ASSERT_EQ(symlink(tmp_.File("outside.txt").c_str(), (root_ + "/escape.txt").c_str()), 0);
    ASSERT_EQ(symlink(tmp_.path().c_str(), (root_ + "/up").c_str()), 0);
    ASSERT_EQ(symlink((root_ + "/js/app.mjs").c_str(), (root_ + "/inside.mjs").c_str()), 0);
    auto route = StaticRoute::Open(root_, {});
    ASSERT_TRUE(route.ok()) << route.status().ToString();
    route_ = std::move(route).value();
  }

  HttpResponse Get(const std::string& path, const std::string& method = "GET",
                   std::vector<std::pair<std::string, std::string>> headers = {}) {
    HttpRequest r;
    r.method = method;
    r.target = r.path = path;
    r.headers = std::move(headers);
    return route_->Handle(r);
  }

  TempDir tmp_;
  std::string root_;
  std::unique_ptr<StaticRoute> route_;
};

TEST_F(StaticRouteTest, ServesFiles) {
  HttpResponse r = Get("/");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body(), "<html>index</html>");
  EXPECT_EQ(r.Header("Content-Type"), "text/html; charset=utf-8");
  EXPECT_EQ(r.Header("Cache-Control"), "no-cache");
  ASSERT_TRUE(r.Header("ETag"));
  EXPECT_EQ(r.Header("ETag")->size(), 66u);  // a quoted SHA-256

  r = Get("/js/app.mjs");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.Header("Content-Type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(Get("/decoder.wasm").Header("Content-Type"), "application/wasm");
  EXPECT_EQ(Get("/js/sub/").body(), "sub");
  EXPECT_EQ(Get("/j%73/app.mjs").status, 200);  // percent-encoded letters are letters
  EXPECT_EQ(Get("/inside.mjs").status, 200);     // a link that stays inside
  EXPECT_EQ(Get("/index.html", "HEAD").status, 200);
}

TEST_F(StaticRouteTest, ConditionalAndRanges) {
  const std::string etag = *Get("/").Header("ETag");
  EXPECT_EQ(Get("/", "GET", {{"if-none-match", etag}}).status, 304);
  HttpResponse r = Get("/", "GET", {{"range", "bytes=1-4"}});
  EXPECT_EQ(r.status, 206);
  EXPECT_EQ(r.body(), "html");
}

TEST_F(StaticRouteTest, MissingAndFolders) {
  EXPECT_EQ(Get("/nothing.js").status, 404);
  EXPECT_EQ(Get("/js").status, 404);  // a folder: never listed
  EXPECT_EQ(Get("/js/").status, 404);  // no index.html there
  EXPECT_EQ(Get("/.secret").status, 404);
  EXPECT_EQ(Get("/%2esecret").status, 404);
  EXPECT_EQ(Get("/", "POST").status, 405);
}

TEST_F(StaticRouteTest, NeverLeavesTheRoot) {
  // Refused by shape (400) or not found inside the root (404); never 200.
  for (const char* path : {"/../outside.txt", "/%2e%2e/outside.txt", "/%2E%2E/outside.txt", "/..%2foutside.txt",
                           "/..%2Foutside.txt", "/js/../../outside.txt", "/static/../../etc/passwd",
                           "/..\\outside.txt", "/%5c..%5coutside.txt", "/.%2e/outside.txt", "/js/%2e%2e/%2e%2e/outside.txt",
                           "/escape.txt", "/up/outside.txt", "/index.html%00.png",
                           "//etc/passwd", "/./index.html", "/%", "/%zz", "etc/passwd", ""}) {
    const HttpResponse r = Get(path);
    EXPECT_TRUE(r.status == 400 || r.status == 404) << path << " -> " << r.status;
    EXPECT_EQ(r.body().find("SECRET-OUTSIDE-CONTENT"), std::string::npos) << path;
    EXPECT_NE(r.body().find("\"error\""), std::string::npos) << path;
  }
  EXPECT_EQ(Get("/..%2foutside.txt").status, 400);
  EXPECT_EQ(Get("/%2e%2e/outside.txt").status, 400);
  EXPECT_EQ(Get("/escape.txt").status, 404);
}

TEST_F(StaticRouteTest, Resolve) {
  EXPECT_EQ(route_->Resolve("/").value(), route_->root() + "/index.html");
  EXPECT_EQ(route_->Resolve("/../x").status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(route_->Resolve("/escape.txt").status().code(), StatusCode::kNotFound);
}

TEST(StaticRoute, NoRoot) {
  auto route = StaticRoute::Open("", {"/a/share/meshstream/web", "/a/web"});
  ASSERT_TRUE(route.ok());
  HttpRequest r;
  r.method = "GET";
  r.target = r.path = "/";
  const HttpResponse response = (*route)->Handle(r);
  EXPECT_EQ(response.status, 404);
  EXPECT_NE(response.body().find("/a/share/meshstream/web, /a/web"), std::string::npos) << response.body();
  EXPECT_NE(response.body().find("--http-root"), std::string::npos);
}

TEST(StaticRoute, BadRoots) {
  TempDir tmp;
  WriteText(tmp.File("file"), "x");
  EXPECT_EQ(StaticRoute::Open(tmp.File("file"), {}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(StaticRoute::Open(tmp.File("missing"), {}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(StaticRoute::Open("/", {}).status().code(), StatusCode::kInvalidArgument);
}

TEST(StaticRoute, SizeLimit) {
  TempDir tmp;
  WriteText(tmp.File("big.bin"), std::string(2000, 'x'));
  auto route = StaticRoute::Open(tmp.path(), {}, 1000);
  ASSERT_TRUE(route.ok());
  HttpRequest r;
  r.method = "GET";
  r.target = r.path = "/big.bin";
  EXPECT_EQ((*route)->Handle(r).status, 500);
}

TEST(StaticRoute, ContentTypes) {
  EXPECT_STREQ(StaticContentType("a.HTML"), "text/html; charset=utf-8");
  EXPECT_STREQ(StaticContentType("a.cjs"), "text/javascript; charset=utf-8");
  EXPECT_STREQ(StaticContentType("a.json"), "application/json");
  EXPECT_STREQ(StaticContentType("a.css"), "text/css; charset=utf-8");
  EXPECT_STREQ(StaticContentType("a.png"), "image/png");
  EXPECT_STREQ(StaticContentType("a.glb"), "model/gltf-binary");
  EXPECT_STREQ(StaticContentType("x.d/noext"), "application/octet-stream");
}

}  // namespace
}  // namespace meshstream

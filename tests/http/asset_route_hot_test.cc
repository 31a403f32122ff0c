// The stored progressive file over HTTP served from the session host's hot
// artifacts (services/http_routes/asset_route.h): a real SQLite store, a
// version made by the real worker pool, the route called as the HTTP server
// calls it. Ranges are slices of the one copy sessions read: the store is
// read and the digest checked once per load, not once per request.
#include "services/http_routes/asset_route.h"

#include <atomic>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "importers/import.h"
#include "parallel/call_limit.h"
#include "services/auth/authenticator.h"
#include "services/store/open_store.h"
#include "services/streaming/session_host.h"
#include "testing/stored_version.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

HttpRequest Get(const std::string& path, const std::string& range = "") {
  HttpRequest r;
  r.method = "GET";
  r.target = path;
  r.path = path;
  if (!range.empty()) r.headers.push_back({"range", range});
  return r;
}

std::string HeaderOf(const HttpResponse& r, const std::string& name) {
  for (const auto& [key, value] : r.headers) {
    if (key == name) return value;
  }
  return "";
}

std::vector<uint8_t> BodyOf(const HttpResponse& r) {
  if (!r.data) return {};
  return std::vector<uint8_t>(r.data->begin() + static_cast<std::ptrdiff_t>(r.offset),
                              r.data->begin() + static_cast<std::ptrdiff_t>(r.offset + r.size));
}

class AssetRouteHot : public ::testing::Test {
 protected:
  void SetUp() override {
    auto store = OpenStore(dir_.path() + "/store");
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
    auto bytes = ReadFileBytes(test_util::ModelPath("fandisk.obj"), uint64_t{1} << 30);
    ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
    std::filesystem::create_directories(dir_.path() + "/work");
    auto version = test_util::StoreReadyVersion(*store_, kDefaultTenant, "fandisk", "fandisk.obj", bytes.value(),
                                                dir_.path() + "/work");
    ASSERT_TRUE(version.ok()) << version.status().ToString();
    auto stored = store_->GetBlob(version->artifact.artifact_sha256, uint64_t{1} << 30);
    ASSERT_TRUE(stored.ok()) << stored.status().ToString();
    stored_ = std::move(stored).value();
    auth_ = std::make_unique<Authenticator>(store_.get(), false);
    host_ = std::make_unique<SessionHost>(store_.get(), auth_.get(), SessionHostOptions(), &draining_);
  }

  test_util::TempDir dir_;
  std::unique_ptr<Store> store_;
  std::unique_ptr<Authenticator> auth_;
  std::atomic<bool> draining_{false};
  std::unique_ptr<SessionHost> host_;
  CallLimit exports_{2};
  std::vector<uint8_t> stored_;
};

TEST_F(AssetRouteHot, RangesAreSlicesOfOneLoad) {
  AssetRoute hot(store_.get(), auth_.get(), &exports_, AssetRouteOptions(), host_.get());
  AssetRoute cold(store_.get(), auth_.get(), &exports_, AssetRouteOptions());
  const std::string url = "/v1/assets/fandisk/versions/1/progressive";
  const size_t n = stored_.size();
  ASSERT_GT(n, 4096u);
  const std::vector<std::pair<size_t, size_t>> ranges = {{0, 1023}, {1024, n / 2}, {n / 2 + 1, n - 1}};
  for (const auto& [first, last] : ranges) {
    const std::string range = "bytes=" + std::to_string(first) + "-" + std::to_string(last);
    const HttpResponse a = hot.Handle(Get(url, range));
    const HttpResponse b = cold.Handle(Get(url, range));
    ASSERT_EQ(a.status, 206) << range;
    ASSERT_EQ(b.status, 206) << range;
    const std::vector<uint8_t> want(stored_.begin() + static_cast<std::ptrdiff_t>(first),
                                    stored_.begin() + static_cast<std::ptrdiff_t>(last + 1));
    EXPECT_EQ(BodyOf(a), want) << range;
    EXPECT_EQ(BodyOf(b), want) << range;
    EXPECT_EQ(HeaderOf(a, "Content-Range"), HeaderOf(b, "Content-Range")) << range;
    EXPECT_EQ(HeaderOf(a, "ETag"), HeaderOf(b, "ETag")) << range;
    EXPECT_EQ(HeaderOf(a, "Content-Type"), HeaderOf(b, "Content-Type")) << range;
  }
  // The whole file and `latest` (which names the version it resolved to).
  const HttpResponse whole = hot.Handle(Get("/v1/assets/fandisk/versions/latest/progressive"));
  ASSERT_EQ(whole.status, 200);
  EXPECT_EQ(BodyOf(whole), stored_);
  EXPECT_EQ(HeaderOf(whole, "Content-Location"), "/v1/assets/fandisk/versions/1/progressive");
  // One load (the store's read and digest) for the four requests.
  const HotArtifactsStats stats = host_->hot_artifacts();
  EXPECT_EQ(stats.loads, 1u);
  EXPECT_EQ(stats.hits, 3u);
  // Other formats still come from the export path.
  const HttpResponse glb = hot.Handle(Get("/v1/assets/fandisk/versions/1/glb", "bytes=0-3"));
  ASSERT_EQ(glb.status, 206);
  EXPECT_EQ(BodyOf(glb), std::vector<uint8_t>({'g', 'l', 'T', 'F'}));
  EXPECT_EQ(host_->hot_artifacts().loads, 1u);
}

TEST_F(AssetRouteHot, ALoadedFileIsNotReadAgainAndErrorsStayTheStores) {
  AssetRoute hot(store_.get(), auth_.get(), &exports_, AssetRouteOptions(), host_.get());
  ASSERT_EQ(hot.Handle(Get("/v1/assets/fandisk/versions/1/progressive", "bytes=0-9")).status, 206);
  // Unknown assets and versions answer as before, and load nothing.
  EXPECT_EQ(hot.Handle(Get("/v1/assets/nothing/versions/1/progressive")).status, 404);
  EXPECT_EQ(hot.Handle(Get("/v1/assets/fandisk/versions/7/progressive")).status, 404);
  // A limit below the file's size: the same refusal as the export path's.
  AssetRouteOptions small;
  small.max_export_bytes = 100;
  AssetRoute limited(store_.get(), auth_.get(), &exports_, small, host_.get());
  AssetRoute limited_cold(store_.get(), auth_.get(), &exports_, small);
  const HttpResponse over = limited.Handle(Get("/v1/assets/fandisk/versions/1/progressive", "bytes=0-9"));
  EXPECT_EQ(over.status, limited_cold.Handle(Get("/v1/assets/fandisk/versions/1/progressive", "bytes=0-9")).status);
  EXPECT_NE(over.status, 206);
  EXPECT_EQ(host_->hot_artifacts().loads, 1u);
}

}  // namespace
}  // namespace meshstream

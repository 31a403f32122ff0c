// The CORS policy (services/http/cors.h).
#include "services/http/cors.h"

#include <gtest/gtest.h>

namespace meshstream {
namespace {

HttpRequest WithOrigin(const std::string& origin, const std::string& method = "GET") {
  HttpRequest r;
  r.method = method;
  r.path = r.target = "/v1/assets";
  if (!origin.empty()) r.headers.emplace_back("origin", origin);
  return r;
}

TEST(Cors, OriginsAreChecked) {
  EXPECT_TRUE(CorsPolicy::Make({"https://viewer.example", "http://localhost:5173", "*", "http://[::1]:8080"}).ok());
  for (const char* bad : {"viewer.example", "https://viewer.example/", "https://viewer.example/app", "ftp://x",
                          "https://", "null", "NULL", "https://a b", "https://a,b"}) {
    auto p = CorsPolicy::Make({bad});
    ASSERT_FALSE(p.ok()) << bad;
    EXPECT_EQ(p.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(p.status().message().find("--http-cors-origin"), std::string::npos);
  }
}

TEST(Cors, NoneByDefault) {
  CorsPolicy none;
  HttpResponse r;
  none.Decorate(WithOrigin("https://a.example"), &r);
  EXPECT_TRUE(r.headers.empty());
  const HttpResponse pre = none.Preflight(WithOrigin("https://a.example", "OPTIONS"));
  EXPECT_EQ(pre.status, 204);
  EXPECT_FALSE(pre.Header("Access-Control-Allow-Origin"));
}

TEST(Cors, AllowedOrigin) {
  const CorsPolicy p = CorsPolicy::Make({"https://a.example"}).value();
  HttpResponse r;
  p.Decorate(WithOrigin("https://a.example"), &r);
  EXPECT_EQ(r.Header("Access-Control-Allow-Origin"), "https://a.example");
  EXPECT_EQ(r.Header("Vary"), "Origin");
  const std::string exposed = r.Header("Access-Control-Expose-Headers").value_or("");
  for (const char* h : {"Content-Range", "Content-Length", "ETag", "Accept-Ranges", "Content-Location"}) {
    EXPECT_NE(exposed.find(h), std::string::npos) << h;
  }
  const HttpResponse pre = p.Preflight(WithOrigin("https://a.example", "OPTIONS"));
  EXPECT_EQ(pre.status, 204);
  EXPECT_EQ(pre.Header("Access-Control-Allow-Origin"), "https://a.example");
  EXPECT_EQ(pre.Header("Access-Control-Allow-Methods"), "GET, HEAD");
  EXPECT_EQ(pre.Header("Access-Control-Allow-Headers"), "Authorization, Range, If-None-Match, If-Range");
}

TEST(Cors, OtherOriginGetsNoCorsHeader) {
  const CorsPolicy p = CorsPolicy::Make({"https://a.example"}).value();
  HttpResponse r;
  p.Decorate(WithOrigin("https://evil.example"), &r);
  EXPECT_FALSE(r.Header("Access-Control-Allow-Origin"));
  EXPECT_FALSE(r.Header("Access-Control-Expose-Headers"));
  EXPECT_EQ(r.Header("Vary"), "Origin");  // caches must still keep copies apart
  const HttpResponse pre = p.Preflight(WithOrigin("https://evil.example", "OPTIONS"));
  EXPECT_FALSE(pre.Header("Access-Control-Allow-Origin"));
  EXPECT_FALSE(pre.Header("Access-Control-Allow-Methods"));
  HttpResponse none;
  p.Decorate(WithOrigin(""), &none);
  EXPECT_FALSE(none.Header("Access-Control-Allow-Origin"));
}

TEST(Cors, Star) {
  const CorsPolicy p = CorsPolicy::Make({"*"}).value();
  HttpResponse r;
  p.Decorate(WithOrigin("https://anyone.example"), &r);
  EXPECT_EQ(r.Header("Access-Control-Allow-Origin"), "*");
}

TEST(Cors, VaryIsMerged) {
  const CorsPolicy p = CorsPolicy::Make({"https://a.example"}).value();
  HttpResponse r;
  r.SetHeader("Vary", "Authorization");
  p.Decorate(WithOrigin("https://a.example"), &r);
  p.Decorate(WithOrigin("https://a.example"), &r);
  EXPECT_EQ(r.Header("Vary"), "Authorization, Origin");
}

}  // namespace
}  // namespace meshstream

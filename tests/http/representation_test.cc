// Serving one representation (services/http/representation.h): 200, 206,
// 416, 304 and If-Range, with the headers each carries.
#include "services/http/representation.h"

#include <gtest/gtest.h>

#include <string>

namespace meshstream {
namespace {

Representation Rep(const std::string& body) {
  Representation r;
  r.bytes = std::make_shared<const std::vector<uint8_t>>(body.begin(), body.end());
  r.etag = "\"tag1\"";
  r.content_type = "model/gltf-binary";
  r.headers = {{"Cache-Control", "public, max-age=31536000, immutable"}};
  return r;
}

HttpRequest Get(std::vector<std::pair<std::string, std::string>> headers, const std::string& method = "GET") {
  HttpRequest r;
  r.method = method;
  r.path = r.target = "/x";
  r.headers = std::move(headers);
  return r;
}

TEST(Representation, Whole) {
  const HttpResponse r = ServeRepresentation(Get({}), Rep("0123456789"));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body(), "0123456789");
  EXPECT_EQ(r.Header("ETag"), "\"tag1\"");
  EXPECT_EQ(r.Header("Accept-Ranges"), "bytes");
  EXPECT_EQ(r.Header("Content-Type"), "model/gltf-binary");
  EXPECT_EQ(r.Header("Cache-Control"), "public, max-age=31536000, immutable");
  EXPECT_FALSE(r.Header("Content-Range"));
}

TEST(Representation, Range) {
  HttpResponse r = ServeRepresentation(Get({{"range", "bytes=2-4"}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 206);
  EXPECT_EQ(r.body(), "234");
  EXPECT_EQ(r.Header("Content-Range"), "bytes 2-4/10");
  EXPECT_EQ(r.Header("ETag"), "\"tag1\"");
  r = ServeRepresentation(Get({{"range", "bytes=-3"}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 206);
  EXPECT_EQ(r.body(), "789");
  EXPECT_EQ(r.Header("Content-Range"), "bytes 7-9/10");
}

TEST(Representation, Unsatisfiable) {
  const HttpResponse r = ServeRepresentation(Get({{"range", "bytes=10-"}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 416);
  EXPECT_EQ(r.Header("Content-Range"), "bytes */10");
  EXPECT_EQ(r.Header("Cache-Control"), "no-store");
  EXPECT_NE(r.body().find("\"error\""), std::string::npos);
}

TEST(Representation, SeveralRangesGetTheWhole) {
  const HttpResponse r = ServeRepresentation(Get({{"range", "bytes=0-1,3-4"}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body(), "0123456789");
}

TEST(Representation, HeadIgnoresRange) {
  const HttpResponse r = ServeRepresentation(Get({{"range", "bytes=0-1"}}, "HEAD"), Rep("0123456789"));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.size, 10u);  // the server leaves the body out, with its length
}

TEST(Representation, IfNoneMatch) {
  HttpResponse r = ServeRepresentation(Get({{"if-none-match", "\"x\", W/\"tag1\""}, {"range", "bytes=0-1"}}),
                                       Rep("0123456789"));
  EXPECT_EQ(r.status, 304);
  EXPECT_EQ(r.size, 0u);
  EXPECT_EQ(r.Header("ETag"), "\"tag1\"");
  EXPECT_EQ(r.Header("Cache-Control"), "public, max-age=31536000, immutable");
  EXPECT_FALSE(r.Header("Content-Type"));
  r = ServeRepresentation(Get({{"if-none-match", "\"other\""}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 200);
  // Two lines of the field are one list.
  r = ServeRepresentation(Get({{"if-none-match", "\"a\""}, {"if-none-match", "\"tag1\""}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 304);
}

TEST(Representation, IfRange) {
  HttpResponse r = ServeRepresentation(Get({{"range", "bytes=0-1"}, {"if-range", "\"tag1\""}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 206);
  EXPECT_EQ(r.body(), "01");
  r = ServeRepresentation(Get({{"range", "bytes=0-1"}, {"if-range", "\"old\""}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body(), "0123456789");
  r = ServeRepresentation(Get({{"range", "bytes=0-1"}, {"if-range", "W/\"tag1\""}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 200);
  // A mismatching If-Range also makes an unsatisfiable range a 200.
  r = ServeRepresentation(Get({{"range", "bytes=50-"}, {"if-range", "\"old\""}}), Rep("0123456789"));
  EXPECT_EQ(r.status, 200);
}

TEST(Representation, EmptyBody) {
  HttpResponse r = ServeRepresentation(Get({}), Rep(""));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.size, 0u);
  r = ServeRepresentation(Get({{"range", "bytes=0-"}}), Rep(""));
  EXPECT_EQ(r.status, 416);
  EXPECT_EQ(r.Header("Content-Range"), "bytes */0");
}

}  // namespace
}  // namespace meshstream

// Request targets (services/http/url.h): percent-decoding, segments, queries.
#include "services/http/url.h"

#include <gtest/gtest.h>

#include <string>

namespace meshstream {
namespace {

TEST(PercentDecode, Decodes) {
  EXPECT_EQ(PercentDecode("f", "abc").value(), "abc");
  EXPECT_EQ(PercentDecode("f", "a%20b").value(), "a b");
  EXPECT_EQ(PercentDecode("f", "%2e%2E").value(), "..");
  EXPECT_EQ(PercentDecode("f", "%2f").value(), "/");
  EXPECT_EQ(PercentDecode("f", "a+b").value(), "a+b");  // '+' is not a space in a path
  EXPECT_EQ(PercentDecode("f", "%00").value(), std::string(1, '\0'));
  EXPECT_EQ(PercentDecode("f", "%ff").value(), "\xff");
  EXPECT_EQ(PercentDecode("f", "").value(), "");
}

TEST(PercentDecode, RefusesBrokenEscapes) {
  for (const char* text : {"%", "%2", "a%", "%zz", "%2g", "%g2", "100%", "%%41"}) {
    auto r = PercentDecode("asset", text);
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(r.status().message().find("asset: '%' at character"), std::string::npos) << r.status().message();
  }
}

TEST(PathSegments, Splits) {
  EXPECT_EQ(PathSegments("/"), (std::vector<std::string_view>{""}));
  EXPECT_EQ(PathSegments("/v1/assets"), (std::vector<std::string_view>{"v1", "assets"}));
  EXPECT_EQ(PathSegments("/v1/assets/"), (std::vector<std::string_view>{"v1", "assets", ""}));
  EXPECT_EQ(PathSegments("/a//b"), (std::vector<std::string_view>{"a", "", "b"}));
}

TEST(ParseQuery, Pairs) {
  auto q = ParseQuery("lod=2&x&&y=%41");
  ASSERT_TRUE(q.ok());
  ASSERT_EQ(q->size(), 3u);
  EXPECT_EQ((*q)[0], (std::pair<std::string, std::string>{"lod", "2"}));
  EXPECT_EQ((*q)[1], (std::pair<std::string, std::string>{"x", ""}));
  EXPECT_EQ((*q)[2], (std::pair<std::string, std::string>{"y", "A"}));
  EXPECT_TRUE(ParseQuery("").value().empty());
}

TEST(ParseQuery, Limits) {
  std::string many;
  for (size_t i = 0; i <= kMaxQueryParameters; ++i) many += "a=1&";
  EXPECT_EQ(ParseQuery(many).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ParseQuery("a=%zz").status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshstream

// Entity tags of conditional requests (services/http/conditional.h).
#include "services/http/conditional.h"

#include <gtest/gtest.h>

namespace meshstream {
namespace {

const char kTag[] = "\"abc123\"";

TEST(IfNoneMatch, MatchesItsTag) {
  EXPECT_TRUE(IfNoneMatchMatches("\"abc123\"", kTag));
  EXPECT_TRUE(IfNoneMatchMatches("  \"abc123\"  ", kTag));
  EXPECT_FALSE(IfNoneMatchMatches("\"abc124\"", kTag));
  EXPECT_FALSE(IfNoneMatchMatches("\"ABC123\"", kTag));  // opaque tags compare exactly
}

TEST(IfNoneMatch, Star) {
  EXPECT_TRUE(IfNoneMatchMatches("*", kTag));
  EXPECT_TRUE(IfNoneMatchMatches(" * ", kTag));
  EXPECT_FALSE(IfNoneMatchMatches("*, \"x\"", kTag));
  EXPECT_FALSE(IfNoneMatchMatches("**", kTag));
}

TEST(IfNoneMatch, ListsAndWeakComparison) {
  EXPECT_TRUE(IfNoneMatchMatches("\"x\", \"abc123\"", kTag));
  EXPECT_TRUE(IfNoneMatchMatches("\"x\",\"abc123\",\"y\"", kTag));
  EXPECT_TRUE(IfNoneMatchMatches("W/\"abc123\"", kTag));
  EXPECT_TRUE(IfNoneMatchMatches("\"x\", W/\"abc123\"", kTag));
  EXPECT_TRUE(IfNoneMatchMatches("W/\"abc123\"", "W/\"abc123\""));
  EXPECT_TRUE(IfNoneMatchMatches(", ,\"abc123\",", kTag));  // empty list elements
  EXPECT_TRUE(IfNoneMatchMatches("\"a,b\", \"abc123\"", kTag));  // a comma inside a tag
  EXPECT_FALSE(IfNoneMatchMatches("\"x\", \"y\"", kTag));
}

TEST(IfNoneMatch, MalformedNeverMatches) {
  for (const char* header : {"", " ", ",", "abc123", "\"abc123", "abc123\"", "w/\"abc123\"", "W/abc123",
                             "\"abc123\" \"x\"", "\"abc123\";", "\"abc 123\"", "\"abc123\", x"}) {
    EXPECT_FALSE(IfNoneMatchMatches(header, kTag)) << header;
  }
  EXPECT_FALSE(IfNoneMatchMatches(std::string("\"abc\0123\"", 9), kTag));
  EXPECT_FALSE(IfNoneMatchMatches("\"abc123\"", "not a tag"));
}

TEST(IfRange, OnlyOurStrongTagKeepsTheRange) {
  EXPECT_TRUE(IfRangeMatches("\"abc123\"", kTag));
  EXPECT_TRUE(IfRangeMatches(" \"abc123\" ", kTag));
  EXPECT_FALSE(IfRangeMatches("W/\"abc123\"", kTag));
  EXPECT_FALSE(IfRangeMatches("\"abc123\"", "W/\"abc123\""));
  EXPECT_FALSE(IfRangeMatches("\"other\"", kTag));
  EXPECT_FALSE(IfRangeMatches("\"abc123\", \"x\"", kTag));
  // A date (our responses carry no Last-Modified), or anything else.
  EXPECT_FALSE(IfRangeMatches("Sun, 06 Nov 1994 08:49:37 GMT", kTag));
  EXPECT_FALSE(IfRangeMatches("", kTag));
  EXPECT_FALSE(IfRangeMatches("*", kTag));
}

TEST(EntityTag, Strong) { EXPECT_EQ(StrongEntityTag("00ff"), "\"00ff\""); }

}  // namespace
}  // namespace meshstream

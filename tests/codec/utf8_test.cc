// ToValidUtf8: the maximal-subpart replacement of the Unicode standard
// (section 3.9), on the ill-formed sequences it names.
#include "codec/core/utf8.h"

#include <gtest/gtest.h>

namespace meshstream {
namespace {

const std::string kFffd = "\xEF\xBF\xBD";

TEST(Utf8, WellFormedTextIsKept) {
  for (std::string s : {std::string(""), std::string("bunny_01.obj"), std::string("h\xC3\xA9llo"),
                        std::string("\xE2\x82\xAC"), std::string("\xF0\x9F\x90\xB0 rabbit"),
                        std::string("\xF4\x8F\xBF\xBF")}) {
    bool replaced = true;
    EXPECT_TRUE(IsValidUtf8(s)) << s;
    EXPECT_EQ(ToValidUtf8(s, &replaced), s);
    EXPECT_FALSE(replaced);
  }
}

TEST(Utf8, EachMaximalIllFormedSubpartBecomesOneReplacement) {
  struct Case {
    std::string in, out;
  };
  const Case cases[] = {
      {"bad\xFF.obj", "bad" + kFffd + ".obj"},
      {"\x80", kFffd},                              // lone continuation byte
      {"\xC0\xAF", kFffd + kFffd},                  // overlong: C0 never starts a sequence
      {"\xE0\x80\x80", kFffd + kFffd + kFffd},      // overlong three-byte form
      {"\xED\xA0\x80", kFffd + kFffd + kFffd},      // a surrogate
      {"\xF4\x90\x80\x80", kFffd + kFffd + kFffd + kFffd},  // above U+10FFFF
      {"\xE2\x82", kFffd},                          // truncated at the end: one subpart
      {"\xE2\x82" "A", kFffd + "A"},                // truncated before ASCII
      {"\xF0\x9F\x90", kFffd},
      {"\xF5", kFffd},
      {"a\xC3", "a" + kFffd},
  };
  for (const Case& c : cases) {
    bool replaced = false;
    EXPECT_FALSE(IsValidUtf8(c.in));
    const std::string out = ToValidUtf8(c.in, &replaced);
    EXPECT_EQ(out, c.out);
    EXPECT_TRUE(replaced);
    EXPECT_TRUE(IsValidUtf8(out));
  }
}

TEST(Utf8, AnyByteStringBecomesValid) {
  std::string all;
  for (int b = 0; b < 256; ++b) all.push_back(static_cast<char>(b));
  for (int b = 0; b < 256; ++b) all.push_back(static_cast<char>(255 - b));
  const std::string out = ToValidUtf8(all);
  EXPECT_TRUE(IsValidUtf8(out));
  EXPECT_LE(out.size(), 3 * all.size());
}

}  // namespace
}  // namespace meshstream

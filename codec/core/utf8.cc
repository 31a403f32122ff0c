#include "codec/core/utf8.h"

#include <cstddef>
#include <cstdint>

namespace meshstream {

namespace {

// Length of the well-formed sequence at s[i], or 0 with *subpart set to the
// length of the maximal ill-formed subpart there (the lead byte and the
// continuation bytes that were still allowed; at least 1).
size_t SequenceAt(std::string_view s, size_t i, size_t* subpart) {
  const auto byte = [&](size_t k) { return static_cast<uint8_t>(s[k]); };
  const uint8_t b0 = byte(i);
  *subpart = 1;
  if (b0 < 0x80) return 1;
  size_t length = 0;
  uint8_t lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    length = 2;
  } else if (b0 >= 0xE0 && b0 <= 0xEF) {
    length = 3;
    if (b0 == 0xE0) lo = 0xA0;  // no overlong forms
    if (b0 == 0xED) hi = 0x9F;  // no surrogates
  } else if (b0 >= 0xF0 && b0 <= 0xF4) {
    length = 4;
    if (b0 == 0xF0) lo = 0x90;  // no overlong forms
    if (b0 == 0xF4) hi = 0x8F;  // nothing above U+10FFFF
  } else {
    return 0;  // 0x80-0xC1 and 0xF5-0xFF never start a sequence
  }
  for (size_t k = 1; k < length; ++k) {
    if (i + k >= s.size()) return 0;
    const uint8_t b = byte(i + k);
    const bool ok = k == 1 ? (b >= lo && b <= hi) : (b >= 0x80 && b <= 0xBF);
    if (!ok) return 0;
    *subpart = k + 1;  // bytes 0..k may still start a valid sequence
  }
  return length;
}

}  // namespace

bool IsValidUtf8(std::string_view s) {
  size_t subpart = 0;
  for (size_t i = 0; i < s.size();) {
    const size_t n = SequenceAt(s, i, &subpart);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::string ToValidUtf8(std::string_view s, bool* replaced) {
  if (replaced) *replaced = false;
  if (IsValidUtf8(s)) return std::string(s);
  std::string out;
  out.reserve(s.size() + 8);
  size_t subpart = 0;
  for (size_t i = 0; i < s.size();) {
    const size_t n = SequenceAt(s, i, &subpart);
    if (n > 0) {
      out.append(s.substr(i, n));
      i += n;
    } else {
      out.append("\xEF\xBF\xBD");
      if (replaced) *replaced = true;
      i += subpart;
    }
  }
  return out;
}

}  // namespace meshstream

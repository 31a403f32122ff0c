#include "services/http/byte_range.h"

#include <limits>
#include <optional>

namespace meshstream {

namespace {

bool IsSpace(char c) { return c == ' ' || c == '\t'; }

std::string_view Trim(std::string_view s) {
  while (!s.empty() && IsSpace(s.front())) s.remove_prefix(1);
  while (!s.empty() && IsSpace(s.back())) s.remove_suffix(1);
  return s;
}

bool EqualsNoCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

// A run of one or more decimal digits, saturating at 2^64 - 1; nullopt for
// anything else (empty, a sign, a space, another character).
std::optional<uint64_t> Digits(std::string_view s) {
  if (s.empty()) return std::nullopt;
  constexpr uint64_t kMax = std::numeric_limits<uint64_t>::max();
  uint64_t value = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return std::nullopt;
    const uint64_t digit = static_cast<uint64_t>(c - '0');
    value = value > (kMax - digit) / 10 ? kMax : value * 10 + digit;
  }
  return value;
}

}  // namespace

HttpRange ParseByteRange(std::string_view header, uint64_t size) {
  HttpRange whole;  // kWhole
  header = Trim(header);
  const size_t equals = header.find('=');
  if (equals == std::string_view::npos) return whole;
  if (!EqualsNoCase(header.substr(0, equals), "bytes")) return whole;
  std::string_view set = header.substr(equals + 1);

  // The one non-empty element of the list, or kWhole for none or several.
  std::string_view spec;
  int elements = 0;
  while (true) {
    const size_t comma = set.find(',');
    const std::string_view element = Trim(set.substr(0, comma));
    if (!element.empty()) {
      if (++elements > 1) return whole;
      spec = element;
    }
    if (comma == std::string_view::npos) break;
    set.remove_prefix(comma + 1);
  }
  if (elements != 1) return whole;

  const size_t dash = spec.find('-');
  if (dash == std::string_view::npos) return whole;
  const std::string_view first_text = spec.substr(0, dash);
  const std::string_view last_text = spec.substr(dash + 1);

  HttpRange r;
  if (first_text.empty()) {
    // bytes=-N: the last N bytes.
    const std::optional<uint64_t> suffix = Digits(last_text);
    if (!suffix) return whole;
    if (*suffix == 0) {
      r.kind = HttpRange::Kind::kUnsatisfiable;
      return r;
    }
    if (size == 0) return whole;
    r.kind = HttpRange::Kind::kPartial;
    r.first = *suffix >= size ? 0 : size - *suffix;
    r.last = size - 1;
    return r;
  }
  const std::optional<uint64_t> first = Digits(first_text);
  if (!first) return whole;
  std::optional<uint64_t> last;
  if (!last_text.empty()) {
    last = Digits(last_text);
    if (!last || *last < *first) return whole;  // malformed, or B < A: an invalid spec
  }
  if (*first >= size) {
    r.kind = HttpRange::Kind::kUnsatisfiable;
    return r;
  }
  r.kind = HttpRange::Kind::kPartial;
  r.first = *first;
  r.last = last && *last < size - 1 ? *last : size - 1;
  return r;
}

}  // namespace meshstream

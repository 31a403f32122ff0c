#include "services/http/conditional.h"

#include <optional>

namespace meshstream {

namespace {

bool IsSpace(char c) { return c == ' ' || c == '\t'; }

void SkipSpace(std::string_view* s) {
  while (!s->empty() && IsSpace(s->front())) s->remove_prefix(1);
}

bool IsEtagChar(unsigned char c) { return c == 0x21 || (c >= 0x23 && c <= 0x7e) || c >= 0x80; }

struct EntityTag {
  bool weak = false;
  std::string_view opaque;  // without the quotes
};

// Reads one entity tag at the start of `s` and removes it; nullopt when
// there is none.
std::optional<EntityTag> ReadTag(std::string_view* s) {
  EntityTag tag;
  if (s->size() >= 2 && (*s)[0] == 'W' && (*s)[1] == '/') {
    tag.weak = true;
    s->remove_prefix(2);
  }
  if (s->empty() || s->front() != '"') return std::nullopt;
  size_t end = 1;
  while (end < s->size() && (*s)[end] != '"') {
    if (!IsEtagChar(static_cast<unsigned char>((*s)[end]))) return std::nullopt;
    ++end;
  }
  if (end >= s->size()) return std::nullopt;  // no closing quote
  tag.opaque = s->substr(1, end - 1);
  s->remove_prefix(end + 1);
  return tag;
}

std::optional<EntityTag> ParseOne(std::string_view text) {
  SkipSpace(&text);
  auto tag = ReadTag(&text);
  SkipSpace(&text);
  if (!tag || !text.empty()) return std::nullopt;
  return tag;
}

}  // namespace

std::string StrongEntityTag(std::string_view opaque) { return "\"" + std::string(opaque) + "\""; }

bool IfNoneMatchMatches(std::string_view header, std::string_view etag) {
  const auto ours = ParseOne(etag);
  if (!ours) return false;
  std::string_view s = header;
  SkipSpace(&s);
  if (!s.empty() && s.front() == '*') {
    s.remove_prefix(1);
    SkipSpace(&s);
    return s.empty();
  }
  bool matched = false;
  bool any = false;
  while (true) {
    SkipSpace(&s);
    if (s.empty()) break;
    if (s.front() == ',') {  // an empty element of the list
      s.remove_prefix(1);
      continue;
    }
    auto tag = ReadTag(&s);
    if (!tag) return false;  // malformed: the whole header is ignored
    any = true;
    if (tag->opaque == ours->opaque) matched = true;
    SkipSpace(&s);
    if (s.empty()) break;
    if (s.front() != ',') return false;
    s.remove_prefix(1);
  }
  return any && matched;
}

bool IfRangeMatches(std::string_view header, std::string_view etag) {
  const auto ours = ParseOne(etag);
  const auto theirs = ParseOne(header);
  if (!ours || !theirs) return false;  // a date, or malformed
  return !ours->weak && !theirs->weak && ours->opaque == theirs->opaque;
}

}  // namespace meshstream

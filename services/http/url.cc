#include "services/http/url.h"

namespace meshstream {

namespace {

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

StatusOr<std::string> PercentDecode(std::string_view field, std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '%') {
      out.push_back(text[i]);
      continue;
    }
    const int a = i + 2 < text.size() ? HexValue(text[i + 1]) : -1;
    const int b = i + 2 < text.size() ? HexValue(text[i + 2]) : -1;
    if (a < 0 || b < 0) {
      return InvalidArgument(std::string(field) + ": '%' at character " + std::to_string(i + 1) +
                             " is not followed by two hex digits");
    }
    out.push_back(static_cast<char>(a * 16 + b));
    i += 2;
  }
  return out;
}

std::vector<std::string_view> PathSegments(std::string_view path) {
  std::vector<std::string_view> segments;
  if (!path.empty() && path.front() == '/') path.remove_prefix(1);
  while (true) {
    const size_t slash = path.find('/');
    segments.push_back(path.substr(0, slash));
    if (slash == std::string_view::npos) break;
    path.remove_prefix(slash + 1);
  }
  return segments;
}

StatusOr<std::vector<std::pair<std::string, std::string>>> ParseQuery(std::string_view query) {
  std::vector<std::pair<std::string, std::string>> params;
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view element = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
    if (element.empty()) continue;
    if (params.size() >= kMaxQueryParameters) {
      return InvalidArgument("query: more than " + std::to_string(kMaxQueryParameters) + " parameters");
    }
    const size_t eq = element.find('=');
    auto name = PercentDecode("query", element.substr(0, eq));
    if (!name.ok()) return name.status();
    std::string value;
    if (eq != std::string_view::npos) {
      auto decoded = PercentDecode("query parameter " + name.value(), element.substr(eq + 1));
      if (!decoded.ok()) return decoded.status();
      value = std::move(decoded).value();
    }
    params.emplace_back(std::move(name).value(), std::move(value));
  }
  return params;
}

}  // namespace meshstream

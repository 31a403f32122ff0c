#include "cli/json_out.h"

#include <cstdio>

#include "codec/core/utf8.h"

namespace meshstream::cli {

std::string Utf8(std::string_view s) { return ToValidUtf8(s); }

std::vector<std::string> Utf8(const std::vector<std::string>& v) {
  std::vector<std::string> out;
  out.reserve(v.size());
  for (const std::string& s : v) out.push_back(ToValidUtf8(s));
  return out;
}

void PrintJson(const nlohmann::json& j) {
  const std::string text = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::puts(text.c_str());
}

}  // namespace meshstream::cli

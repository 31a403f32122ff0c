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

void MakeNamesValidUtf8(Scene& scene) {
  for (Mesh& m : scene.meshes) m.name = ToValidUtf8(m.name);
  for (Node& n : scene.nodes) n.name = ToValidUtf8(n.name);
  for (SceneRoot& s : scene.scenes) s.name = ToValidUtf8(s.name);
  for (Image& i : scene.images) {
    i.name = ToValidUtf8(i.name);
    i.mime_type = ToValidUtf8(i.mime_type);
  }
  for (std::string& e : scene.extensions_used) e = ToValidUtf8(e);
  for (std::string& w : scene.warnings) w = ToValidUtf8(w);
}

}  // namespace meshstream::cli

#include "importers/gltf_files.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "importers/gltf_limits.h"
#include "importers/import.h"

namespace meshstream {

StatusOr<std::vector<std::string>> GltfExternalFiles(const uint8_t* json, size_t size, const std::string& where) {
  const nlohmann::json doc = nlohmann::json::parse(json, json + size, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) return InvalidInput(where + ": not a glTF JSON document");
  std::vector<std::string> files;
  for (const char* array : {"buffers", "images"}) {
    const auto it = doc.find(array);
    if (it == doc.end() || !it->is_array()) continue;
    for (size_t i = 0; i < it->size(); ++i) {
      const nlohmann::json& entry = (*it)[i];
      if (!entry.is_object() || !entry.contains("uri") || !entry["uri"].is_string()) continue;
      const std::string field = where + ": " + array + "[" + std::to_string(i) + "].uri";
      MS_ASSIGN_OR_RETURN(const std::string name, CheckUri(entry["uri"].get<std::string>(), field));
      if (name.empty()) continue;  // a data: URI
      if (std::find(files.begin(), files.end(), name) == files.end()) files.push_back(name);
    }
  }
  return files;
}

StatusOr<std::vector<std::string>> GltfExternalFiles(const std::string& path) {
  MS_ASSIGN_OR_RETURN(const std::vector<uint8_t> bytes, ReadFileBytes(path, uint64_t{256} << 20));
  return GltfExternalFiles(bytes.data(), bytes.size(), path);
}

}  // namespace meshstream

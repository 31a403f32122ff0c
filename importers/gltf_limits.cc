#include "importers/gltf_limits.h"

#include <cstring>
#include <limits>
#include <vector>

namespace meshstream {

namespace {

uint32_t ReadU32(const uint8_t* p) {
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}

// Caps that keep every product below 2^63 and every allocation sane.
constexpr uint64_t kMaxCount = uint64_t{1} << 31;
constexpr uint64_t kMaxByteLength = uint64_t{1} << 40;

using json = nlohmann::json;

// A size, offset or count: a value above kMaxByteLength is ResourceExhausted.
StatusOr<uint64_t> GetUint(const json& obj, const char* key, uint64_t default_value,
                           bool required, const std::string& where) {
  auto it = obj.find(key);
  if (it == obj.end()) {
    if (required) return InvalidInput(where + ": missing '" + key + "'");
    return default_value;
  }
  if (!it->is_number_integer() || (!it->is_number_unsigned() && it->get<int64_t>() < 0)) {
    return InvalidInput(where + "." + key + " must be a non-negative integer");
  }
  const uint64_t v = it->get<uint64_t>();
  if (v > kMaxByteLength) {
    return ResourceExhausted(where + "." + key + " = " + std::to_string(v) + " is absurdly large");
  }
  return v;
}

// An index or an enum value: a huge one is simply not valid (InvalidInput).
StatusOr<uint64_t> GetId(const json& obj, const char* key, uint64_t default_value, bool required,
                         const std::string& where) {
  auto v = GetUint(obj, key, default_value, required, where);
  if (!v.ok() && v.status().code() == StatusCode::kResourceExhausted) {
    return InvalidInput(where + "." + key + " = " + obj.find(key)->dump() + " is not valid");
  }
  return v;
}

StatusOr<const json*> GetArray(const json& doc, const char* key) {
  auto it = doc.find(key);
  if (it == doc.end()) return static_cast<const json*>(nullptr);
  if (!it->is_array()) return InvalidInput(std::string("'") + key + "' must be an array");
  return &*it;
}

Status CheckObject(const json& v, const std::string& where) {
  if (!v.is_object()) return InvalidInput(where + " must be an object");
  return Status::Ok();
}

int ComponentSize(uint64_t component_type) {
  switch (component_type) {
    case 5120: case 5121: return 1;   // BYTE, UNSIGNED_BYTE
    case 5122: case 5123: return 2;   // SHORT, UNSIGNED_SHORT
    case 5125: case 5126: return 4;   // UNSIGNED_INT, FLOAT
    default: return 0;
  }
}

int ComponentCount(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4") return 4;
  if (type == "MAT2") return 4;
  if (type == "MAT3") return 9;
  if (type == "MAT4") return 16;
  return 0;
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

struct ViewInfo {
  uint64_t length = 0;
  uint64_t stride = 0;
};

}  // namespace

bool LooksLikeGlb(const uint8_t* data, size_t size) {
  return size >= 4 && ReadU32(data) == kGlbMagic;
}

StatusOr<GlbView> ParseGlb(const uint8_t* data, size_t size) {
  if (size < 20) return InvalidInput("GLB: " + std::to_string(size) + " bytes is too short for a GLB header");
  if (ReadU32(data) != kGlbMagic) return InvalidInput("GLB: bad magic");
  const uint32_t version = ReadU32(data + 4);
  if (version != 2) return Unsupported("GLB: version " + std::to_string(version) + " (only glTF 2.0 is supported)");
  const uint64_t length = ReadU32(data + 8);
  if (length > size) {
    return InvalidInput("GLB: header length " + std::to_string(length) + " is larger than the file (" +
                        std::to_string(size) + " bytes)");
  }
  if (length < 20) return InvalidInput("GLB: header length " + std::to_string(length) + " is too small");
  GlbView view;
  uint64_t offset = 12;
  int chunk_index = 0;
  while (offset < length) {
    if (length - offset < 8) {
      return InvalidInput("GLB: chunk " + std::to_string(chunk_index) + " header is truncated at byte " +
                          std::to_string(offset));
    }
    const uint64_t chunk_length = ReadU32(data + offset);
    const uint32_t chunk_type = ReadU32(data + offset + 4);
    const uint64_t body = offset + 8;
    if (chunk_length > length - body) {
      return InvalidInput("GLB: chunk " + std::to_string(chunk_index) + " claims " +
                          std::to_string(chunk_length) + " bytes but only " +
                          std::to_string(length - body) + " remain");
    }
    // Chunks are padded to 4 bytes. Only the last may be unpadded: a
    // misaligned chunk followed by another leaves where that one starts open
    // to interpretation (the glTF parser reads it unpadded).
    if (chunk_length % 4 != 0 && chunk_length < length - body) {
      return InvalidInput("GLB: chunk " + std::to_string(chunk_index) + " length " + std::to_string(chunk_length) +
                          " is not a multiple of 4 and more chunks follow");
    }
    if (chunk_index == 0) {
      if (chunk_type != kGlbChunkJson) return InvalidInput("GLB: the first chunk is not JSON");
      if (chunk_length == 0) return InvalidInput("GLB: the JSON chunk is empty");
      view.json = data + body;
      view.json_size = static_cast<size_t>(chunk_length);
    } else if (chunk_index == 1 && chunk_type == kGlbChunkBin) {
      view.bin = data + body;
      view.bin_size = static_cast<size_t>(chunk_length);
    } else if (chunk_type == kGlbChunkJson || chunk_type == kGlbChunkBin) {
      return InvalidInput("GLB: chunk " + std::to_string(chunk_index) + " repeats a JSON or BIN chunk");
    }
    // Unknown chunk types are skipped, as the specification requires.
    offset = body + chunk_length;
    // Chunks are padded to 4 bytes; tolerate writers that do not pad the last chunk.
    offset = (offset + 3) & ~uint64_t{3};
    ++chunk_index;
  }
  if (view.json == nullptr) return InvalidInput("GLB: no JSON chunk");
  return view;
}

StatusOr<std::string> CheckUri(const std::string& uri, const std::string& where) {
  if (uri.rfind("data:", 0) == 0) {
    // Only the forms the glTF parser decodes; anything else it would take for
    // a file name ("data:/../x.bin"), past the checks below.
    static const char* const kDataPrefixes[] = {
        "data:application/octet-stream;base64,", "data:application/gltf-buffer;base64,",
        "data:image/png;base64,", "data:image/jpeg;base64,", "data:image/bmp;base64,",
        "data:image/gif;base64,", "data:text/plain;base64,"};
    for (const char* prefix : kDataPrefixes) {
      if (uri.rfind(prefix, 0) == 0) return std::string();
    }
    return InvalidInput(where + ": data: URI '" + uri.substr(0, 48) + (uri.size() > 48 ? "..." : "") +
                        "' is not base64 with a supported media type");
  }
  // Percent-decode first so that "%2e%2e/" cannot hide a "..".
  std::string decoded;
  decoded.reserve(uri.size());
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%') {
      const int hi = i + 2 < uri.size() ? HexValue(uri[i + 1]) : -1;
      const int lo = i + 2 < uri.size() ? HexValue(uri[i + 2]) : -1;
      if (hi < 0 || lo < 0) return InvalidInput(where + ": malformed percent-escape in URI '" + uri + "'");
      decoded.push_back(static_cast<char>(hi * 16 + lo));
      i += 2;
    } else {
      decoded.push_back(uri[i]);
    }
  }
  if (decoded.empty()) return InvalidInput(where + ": empty URI");
  if (decoded.find('\0') != std::string::npos) return InvalidInput(where + ": URI contains a NUL byte");
  if (decoded.find('\\') != std::string::npos) {
    return InvalidInput(where + ": URI '" + uri + "' contains a backslash");
  }
  if (decoded[0] == '/') {
    return InvalidInput(where + ": URI '" + uri + "' is an absolute path; only files inside the asset's folder may be read");
  }
  const size_t colon = decoded.find(':');
  const size_t slash = decoded.find('/');
  if (colon != std::string::npos && (slash == std::string::npos || colon < slash)) {
    return InvalidInput(where + ": URI '" + uri + "' has a scheme; only data: URIs and relative paths are allowed");
  }
  size_t start = 0;
  while (start <= decoded.size()) {
    size_t end = decoded.find('/', start);
    if (end == std::string::npos) end = decoded.size();
    if (decoded.compare(start, end - start, "..") == 0) {
      return InvalidInput(where + ": URI '" + uri + "' leaves the asset's folder ('..')");
    }
    start = end + 1;
  }
  return decoded;
}

Status ValidateGltfDocument(const json& doc, bool is_glb, size_t glb_bin_size) {
  if (!doc.is_object()) return InvalidInput("the glTF JSON is not an object");
  auto asset = doc.find("asset");
  if (asset == doc.end() || !asset->is_object()) return InvalidInput("missing 'asset' object");
  auto version = asset->find("version");
  if (version == asset->end() || !version->is_string()) return InvalidInput("asset.version is missing");
  if (version->get<std::string>().rfind("2.", 0) != 0) {
    return Unsupported("asset.version " + version->get<std::string>() + " (only glTF 2.0 is supported)");
  }

  // buffers
  MS_ASSIGN_OR_RETURN(const json* buffers, GetArray(doc, "buffers"));
  std::vector<uint64_t> buffer_lengths;
  if (buffers) {
    for (size_t i = 0; i < buffers->size(); ++i) {
      const std::string where = "buffers[" + std::to_string(i) + "]";
      const json& b = (*buffers)[i];
      MS_RETURN_IF_ERROR(CheckObject(b, where));
      MS_ASSIGN_OR_RETURN(uint64_t len, GetUint(b, "byteLength", 0, true, where));
      if (len == 0) return InvalidInput(where + ".byteLength must be at least 1");
      auto uri = b.find("uri");
      if (uri != b.end()) {
        if (!uri->is_string()) return InvalidInput(where + ".uri must be a string");
        MS_RETURN_IF_ERROR(CheckUri(uri->get<std::string>(), where).status());
      } else {
        if (!is_glb || i != 0) {
          return InvalidInput(where + " has no uri (only the first buffer of a GLB may use the BIN chunk)");
        }
        if (len > glb_bin_size) {
          return InvalidInput(where + ".byteLength " + std::to_string(len) +
                              " is larger than the GLB BIN chunk (" + std::to_string(glb_bin_size) + " bytes)");
        }
      }
      buffer_lengths.push_back(len);
    }
  }

  // bufferViews
  MS_ASSIGN_OR_RETURN(const json* views, GetArray(doc, "bufferViews"));
  std::vector<ViewInfo> view_info;
  if (views) {
    for (size_t i = 0; i < views->size(); ++i) {
      const std::string where = "bufferViews[" + std::to_string(i) + "]";
      const json& v = (*views)[i];
      MS_RETURN_IF_ERROR(CheckObject(v, where));
      MS_ASSIGN_OR_RETURN(uint64_t buffer, GetId(v, "buffer", 0, true, where));
      MS_ASSIGN_OR_RETURN(uint64_t offset, GetUint(v, "byteOffset", 0, false, where));
      MS_ASSIGN_OR_RETURN(uint64_t length, GetUint(v, "byteLength", 0, true, where));
      if (length == 0) return InvalidInput(where + ".byteLength must be at least 1");
      MS_ASSIGN_OR_RETURN(uint64_t stride, GetId(v, "byteStride", 0, false, where));
      if (buffer >= buffer_lengths.size()) {
        return InvalidInput(where + ".buffer " + std::to_string(buffer) + " does not exist");
      }
      if (offset + length > buffer_lengths[buffer]) {  // both below 2^40: no overflow
        return InvalidInput(where + ": bytes " + std::to_string(offset) + "+" + std::to_string(length) +
                            " reach past buffers[" + std::to_string(buffer) + "] (" +
                            std::to_string(buffer_lengths[buffer]) + " bytes)");
      }
      if (v.contains("byteStride") && (stride < 4 || stride > 252)) {
        return InvalidInput(where + ".byteStride " + std::to_string(stride) + " is outside [4, 252]");
      }
      view_info.push_back({length, stride});
    }
  }

  auto check_view_range = [&](uint64_t view, uint64_t offset, uint64_t bytes,
                              const std::string& where) -> Status {
    if (view >= view_info.size()) {
      return InvalidInput(where + ": bufferView " + std::to_string(view) + " does not exist");
    }
    if (offset + bytes > view_info[view].length) {
      return InvalidInput(where + ": needs bytes up to " + std::to_string(offset + bytes) +
                          " but bufferViews[" + std::to_string(view) + "] has " +
                          std::to_string(view_info[view].length));
    }
    return Status::Ok();
  };

  // accessors
  MS_ASSIGN_OR_RETURN(const json* accessors, GetArray(doc, "accessors"));
  if (accessors) {
    for (size_t i = 0; i < accessors->size(); ++i) {
      const std::string where = "accessors[" + std::to_string(i) + "]";
      const json& a = (*accessors)[i];
      MS_RETURN_IF_ERROR(CheckObject(a, where));
      MS_ASSIGN_OR_RETURN(uint64_t count, GetUint(a, "count", 0, true, where));
      MS_ASSIGN_OR_RETURN(uint64_t component_type, GetId(a, "componentType", 0, true, where));
      MS_ASSIGN_OR_RETURN(uint64_t offset, GetUint(a, "byteOffset", 0, false, where));
      if (count == 0) return InvalidInput(where + ".count is 0");
      if (count > kMaxCount) {
        return ResourceExhausted(where + ".count " + std::to_string(count) + " is above the limit of " +
                                 std::to_string(kMaxCount));
      }
      const int csize = ComponentSize(component_type);
      if (csize == 0) {
        return InvalidInput(where + ".componentType " + std::to_string(component_type) + " is not valid");
      }
      auto type = a.find("type");
      if (type == a.end() || !type->is_string() || ComponentCount(type->get<std::string>()) == 0) {
        return InvalidInput(where + ".type is missing or not valid");
      }
      const uint64_t element = uint64_t(csize) * ComponentCount(type->get<std::string>());
      if (a.contains("bufferView")) {
        MS_ASSIGN_OR_RETURN(uint64_t view, GetId(a, "bufferView", 0, true, where));
        if (view >= view_info.size()) {
          return InvalidInput(where + ".bufferView " + std::to_string(view) + " does not exist");
        }
        const uint64_t stride = view_info[view].stride ? view_info[view].stride : element;
        if (stride < element) {
          return InvalidInput(where + ": byteStride " + std::to_string(stride) +
                              " is smaller than one element (" + std::to_string(element) + " bytes)");
        }
        MS_RETURN_IF_ERROR(check_view_range(view, offset, stride * (count - 1) + element, where));
      }
      auto sparse = a.find("sparse");
      if (sparse != a.end()) {
        const std::string sw = where + ".sparse";
        MS_RETURN_IF_ERROR(CheckObject(*sparse, sw));
        MS_ASSIGN_OR_RETURN(uint64_t scount, GetUint(*sparse, "count", 0, true, sw));
        if (scount == 0 || scount > count) {
          return InvalidInput(sw + ".count " + std::to_string(scount) + " is not in [1, " +
                              std::to_string(count) + "]");
        }
        auto indices = sparse->find("indices");
        auto values = sparse->find("values");
        if (indices == sparse->end() || values == sparse->end()) {
          return InvalidInput(sw + " needs 'indices' and 'values'");
        }
        MS_RETURN_IF_ERROR(CheckObject(*indices, sw + ".indices"));
        MS_RETURN_IF_ERROR(CheckObject(*values, sw + ".values"));
        MS_ASSIGN_OR_RETURN(uint64_t iview, GetId(*indices, "bufferView", 0, true, sw + ".indices"));
        MS_ASSIGN_OR_RETURN(uint64_t ioff, GetUint(*indices, "byteOffset", 0, false, sw + ".indices"));
        MS_ASSIGN_OR_RETURN(uint64_t itype, GetId(*indices, "componentType", 0, true, sw + ".indices"));
        if (itype != 5121 && itype != 5123 && itype != 5125) {
          return InvalidInput(sw + ".indices.componentType " + std::to_string(itype) + " is not an unsigned type");
        }
        MS_RETURN_IF_ERROR(check_view_range(iview, ioff, scount * ComponentSize(itype), sw + ".indices"));
        MS_ASSIGN_OR_RETURN(uint64_t vview, GetId(*values, "bufferView", 0, true, sw + ".values"));
        MS_ASSIGN_OR_RETURN(uint64_t voff, GetUint(*values, "byteOffset", 0, false, sw + ".values"));
        MS_RETURN_IF_ERROR(check_view_range(vview, voff, scount * element, sw + ".values"));
      }
    }
  }

  // images
  MS_ASSIGN_OR_RETURN(const json* images, GetArray(doc, "images"));
  if (images) {
    for (size_t i = 0; i < images->size(); ++i) {
      const std::string where = "images[" + std::to_string(i) + "]";
      const json& im = (*images)[i];
      MS_RETURN_IF_ERROR(CheckObject(im, where));
      auto uri = im.find("uri");
      if (uri != im.end()) {
        if (!uri->is_string()) return InvalidInput(where + ".uri must be a string");
        MS_RETURN_IF_ERROR(CheckUri(uri->get<std::string>(), where).status());
      } else {
        MS_ASSIGN_OR_RETURN(uint64_t view, GetId(im, "bufferView", 0, true, where));
        if (view >= view_info.size()) {
          return InvalidInput(where + ".bufferView " + std::to_string(view) + " does not exist");
        }
      }
    }
  }
  return Status::Ok();
}

}  // namespace meshstream

#include "importers/gltf_import.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <optional>
#include <set>

#include <sys/stat.h>

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include "codec/core/utf8.h"
#include "importers/draco_codec.h"
#include "importers/gltf_accessors.h"
#include "importers/gltf_carry.h"
#include "importers/gltf_limits.h"

namespace meshstream {

namespace {

using json = nlohmann::json;
namespace tg = tinygltf;
using gltf::Carrier;
using gltf::IsCarriedPrimitive;
using gltf::ReadCarriedPrimitive;
using gltf::ReadSkinsAndAnimations;
using gltf::DecodeBudget;
using gltf::ReadAccessor;
using gltf::ReadIndices;
using gltf::ViewBytes;

constexpr int kMaxJsonDepth = 64;
constexpr int kMaxTexcoordSets = 8;

// Extensions whose objects may stay inside carried-through materials,
// textures and samplers: they refer only to textures, images and samplers,
// whose indices we keep.
const std::set<std::string>& PassThroughExtensions() {
  static const std::set<std::string> names = {
      "KHR_materials_clearcoat", "KHR_materials_emissive_strength", "KHR_materials_ior",
      "KHR_materials_iridescence", "KHR_materials_sheen", "KHR_materials_specular",
      "KHR_materials_transmission", "KHR_materials_unlit", "KHR_materials_variants",
      "KHR_materials_volume", "KHR_materials_anisotropy", "KHR_texture_transform",
      "KHR_texture_basisu", "EXT_texture_webp", "EXT_texture_avif"};
  return names;
}

// Extensions meshstream itself understands when they are required.
bool IsConsumedExtension(const std::string& name) {
  return name == "KHR_draco_mesh_compression" || name == "KHR_mesh_quantization" || name == "KHR_lights_punctual";
}

// The "extras" of doc[array][index] as JSON text, "" when it has none.
// Extras belong to the application (Blender's custom properties, three.js's
// targetNames): carried as they are, never interpreted.
std::string ExtrasOf(const json& doc, const char* array, size_t index) {
  auto a = doc.find(array);
  if (a == doc.end() || !a->is_array() || index >= a->size()) return "";
  const json& object = (*a)[index];
  if (!object.is_object()) return "";
  auto extras = object.find("extras");
  return extras == object.end() ? "" : extras->dump();
}

// KHR_lights_punctual: the root's lights (checked: objects with a valid
// type) and each node's light index.
Status ReadLights(const json& doc, Scene& scene) {
  auto ext = doc.find("extensions");
  if (ext != doc.end() && ext->is_object()) {
    auto khr = ext->find("KHR_lights_punctual");
    if (khr != ext->end()) {
      if (!khr->is_object() || !khr->contains("lights") || !(*khr)["lights"].is_array()) {
        return InvalidInput("extensions.KHR_lights_punctual.lights must be an array");
      }
      const json& lights = (*khr)["lights"];
      for (size_t i = 0; i < lights.size(); ++i) {
        const json& light = lights[i];
        const std::string where = "extensions.KHR_lights_punctual.lights[" + std::to_string(i) + "]";
        if (!light.is_object() || !light.contains("type") || !light["type"].is_string()) {
          return InvalidInput(where + " has no type");
        }
        const std::string type = light["type"].get<std::string>();
        if (type != "directional" && type != "point" && type != "spot") {
          return InvalidInput(where + ".type \"" + type + "\" is not directional, point or spot");
        }
      }
      for (const json& light : lights) scene.lights.push_back(light.dump());
    }
  }
  auto nodes = doc.find("nodes");
  if (nodes == doc.end() || !nodes->is_array()) return Status::Ok();
  for (size_t i = 0; i < nodes->size() && i < scene.nodes.size(); ++i) {
    const json& node = (*nodes)[i];
    if (!node.is_object() || !node.contains("extensions") || !node["extensions"].is_object()) continue;
    auto khr = node["extensions"].find("KHR_lights_punctual");
    if (khr == node["extensions"].end()) continue;
    const std::string where = "nodes[" + std::to_string(i) + "].extensions.KHR_lights_punctual.light";
    if (!khr->is_object() || !khr->contains("light") || !(*khr)["light"].is_number_integer()) {
      return InvalidInput(where + " must be an integer");
    }
    const int64_t light = (*khr)["light"].get<int64_t>();
    if (light < 0 || static_cast<uint64_t>(light) >= scene.lights.size()) {
      return InvalidInput(where + " " + std::to_string(light) + " does not exist");
    }
    scene.nodes[i].light = static_cast<int32_t>(light);
  }
  return Status::Ok();
}

// Nesting depth of JSON text, counted outside strings. tinygltf converts
// extras and extensions recursively, so deep nesting must be refused first.
Status CheckJsonDepth(const uint8_t* data, size_t size) {
  int depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < size; ++i) {
    const char c = static_cast<char>(data[i]);
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '{' || c == '[') {
      if (++depth > kMaxJsonDepth) {
        return InvalidInput("JSON nests deeper than " + std::to_string(kMaxJsonDepth) +
                            " levels (byte " + std::to_string(i) + ")");
      }
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
  return Status::Ok();
}

// Filesystem callbacks for tinygltf: only regular files inside the asset's
// folder. tinygltf asks for "<base>/<uri>" and then for "./<uri>" (relative
// to the working directory); only the first is ever accepted.
struct FsContext {
  std::string base_real;  // realpath of the asset's folder, "" to refuse all files
  uint64_t max_bytes = 0;
  Status status;          // why the first refused file was refused
};

// "<asset's folder>/", what every path inside it starts with.
std::string BasePrefix(const FsContext& ctx) {
  return ctx.base_real == "/" ? "/" : ctx.base_real + "/";
}

// `path` shown relative to the asset's folder when it lies lexically inside.
std::string ShownPath(const FsContext& ctx, const std::string& path) {
  const std::string prefix = BasePrefix(ctx);
  if (!ctx.base_real.empty() && path.compare(0, prefix.size(), prefix) == 0) return path.substr(prefix.size());
  return path;
}

// Checks that `path` names a regular file whose real path (symlinks
// resolved) lies inside the asset's folder.
Status ResolveInsideBase(const FsContext& ctx, const std::string& path, std::string* real_out) {
  const std::string shown = ShownPath(ctx, path);
  if (ctx.base_real.empty()) return InvalidInput(shown + ": external files are not allowed here");
  const std::string prefix = BasePrefix(ctx);
  if (path.compare(0, prefix.size(), prefix) != 0) {
    return InvalidInput(shown + " is not a path inside the asset's folder");
  }
  char buf[PATH_MAX];
  if (realpath(path.c_str(), buf) == nullptr) return NotFound(shown + ": no such file");
  const std::string real(buf);
  if (real.compare(0, prefix.size(), prefix) != 0) {
    return InvalidInput(shown + " resolves to a file outside the asset's folder");
  }
  struct stat st;
  if (stat(real.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
    return InvalidInput(shown + " is not a regular file");
  }
  if (real_out) *real_out = real;
  return Status::Ok();
}

void Remember(FsContext& ctx, const Status& s) {
  if (ctx.status.ok()) ctx.status = s;
}

bool FsFileExists(const std::string& path, void* user) {
  FsContext& ctx = *static_cast<FsContext*>(user);
  const std::string prefix = BasePrefix(ctx);
  if (!ctx.base_real.empty() && path.compare(0, prefix.size(), prefix) != 0) {
    return false;  // tinygltf's second guess, relative to the working directory
  }
  Status s = ResolveInsideBase(ctx, path, nullptr);
  if (!s.ok()) Remember(ctx, s);
  return s.ok();
}

std::string FsExpandFilePath(const std::string& path, void*) { return path; }

bool FsReadWholeFile(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                     void* user) {
  FsContext& ctx = *static_cast<FsContext*>(user);
  std::string real;
  Status s = ResolveInsideBase(ctx, path, &real);
  if (s.ok()) {
    auto bytes = ReadFileBytes(real, ctx.max_bytes);
    if (bytes.ok()) {
      *out = std::move(bytes).value();
      return true;
    }
    s = bytes.status();
  }
  Remember(ctx, s);
  if (err) *err += s.message() + "\n";
  return false;
}

bool FsWriteWholeFile(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "writing is not allowed while importing\n";
  return false;
}

// Keeps image bytes as they are: meshstream never decodes images.
bool KeepImageBytes(tg::Image* image, const int, std::string*, std::string*, int, int,
                    const unsigned char* bytes, int size, void*) {
  if (size < 0) return false;
  image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

std::string Where(size_t mesh, size_t prim) {
  return "meshes[" + std::to_string(mesh) + "].primitives[" + std::to_string(prim) + "]";
}

template <size_t N>
std::vector<std::array<float, N>> ToVectors(const std::vector<double>& flat, size_t components) {
  std::vector<std::array<float, N>> out(flat.size() / components);
  for (size_t i = 0; i < out.size(); ++i) {
    std::array<float, N> v{};
    if (N == 4) v[3] = 1.0f;
    for (size_t c = 0; c < components && c < N; ++c) v[c] = static_cast<float>(flat[i * components + c]);
    out[i] = v;
  }
  return out;
}

// Triangle lists from any triangle mode; index triples that repeat a vertex
// (strip restarts) are dropped from strips and fans.
StatusOr<std::vector<uint32_t>> Triangulate(const std::vector<uint32_t>& v, int mode, const std::string& where) {
  std::vector<uint32_t> out;
  switch (mode) {
    case TINYGLTF_MODE_TRIANGLES:
      if (v.size() % 3 != 0) {
        return InvalidInput(where + ": " + std::to_string(v.size()) + " indices is not a multiple of 3");
      }
      return v;
    case TINYGLTF_MODE_TRIANGLE_STRIP:
      for (size_t i = 0; i + 2 < v.size(); ++i) {
        const uint32_t a = v[i], b = v[i + 1 + (i % 2)], c = v[i + 2 - (i % 2)];
        if (a == b || b == c || a == c) continue;
        out.insert(out.end(), {a, b, c});
      }
      return out;
    case TINYGLTF_MODE_TRIANGLE_FAN:
      for (size_t i = 1; i + 1 < v.size(); ++i) {
        const uint32_t a = v[i], b = v[i + 1], c = v[0];
        if (a == b || b == c || a == c) continue;
        out.insert(out.end(), {a, b, c});
      }
      return out;
    case TINYGLTF_MODE_POINTS:
    case TINYGLTF_MODE_LINE:
    case TINYGLTF_MODE_LINE_LOOP:
    case TINYGLTF_MODE_LINE_STRIP:  // carried (IsCarriedPrimitive), never triangulated
      return Internal(where + ": mode " + std::to_string(mode) + " is not a triangle mode");
    default:
      return InvalidInput(where + ": mode " + std::to_string(mode) + " is not a glTF primitive mode");
  }
}

bool IsKeptAttribute(const std::string& name) {
  if (name == "POSITION" || name == "NORMAL" || name == "COLOR_0") return true;
  return name.rfind("TEXCOORD_", 0) == 0;
}

// TEXCOORD_n for n = 0.. while present.
std::vector<std::string> TexcoordNames(const std::map<std::string, int>& attributes) {
  std::vector<std::string> names;
  for (int t = 0; t < kMaxTexcoordSets; ++t) {
    const std::string name = "TEXCOORD_" + std::to_string(t);
    if (!attributes.count(name)) break;
    names.push_back(name);
  }
  return names;
}

Status ReadDracoPrimitive(const tg::Model& model, const json& ext, const tg::Primitive& tp,
                          const std::string& where, DecodeBudget& budget, Primitive& out) {
  if (!ext.is_object() || !ext.contains("bufferView") || !ext["bufferView"].is_number_integer() ||
      !ext.contains("attributes") || !ext["attributes"].is_object()) {
    return InvalidInput(where + ": KHR_draco_mesh_compression needs an integer bufferView and an attributes object");
  }
  const int view = ext["bufferView"].get<int>();
  if (view < 0 || static_cast<size_t>(view) >= model.bufferViews.size()) {
    return InvalidInput(where + ": KHR_draco_mesh_compression.bufferView " + std::to_string(view) + " does not exist");
  }
  MS_ASSIGN_OR_RETURN(const uint8_t* bytes, ViewBytes(model, view, 0, model.bufferViews[view].byteLength, where));
  DracoAttributeIds ids;
  std::map<std::string, int> draco_attributes;
  for (auto it = ext["attributes"].begin(); it != ext["attributes"].end(); ++it) {
    if (!it.value().is_number_integer() || it.value().get<int64_t>() < 0 || it.value().get<int64_t>() > INT_MAX) {
      return InvalidInput(where + ": KHR_draco_mesh_compression.attributes." + it.key() + " is not a valid id");
    }
    draco_attributes[it.key()] = it.value().get<int>();
  }
  auto id_of = [&](const std::string& name) {
    auto it = draco_attributes.find(name);
    return (it != draco_attributes.end() && tp.attributes.count(name)) ? it->second : -1;
  };
  ids.position = id_of("POSITION");
  ids.normal = id_of("NORMAL");
  for (const std::string& name : TexcoordNames(tp.attributes)) {
    if (id_of(name) < 0) break;
    ids.texcoords.push_back(id_of(name));
  }
  ids.color = id_of("COLOR_0");
  // Decoding costs time in proportion to the stream even when it yields
  // little, and a bufferView may be shared by many primitives.
  MS_RETURN_IF_ERROR(budget.Spend(model.bufferViews[view].byteLength, where));
  auto decoded = DecodeDracoPrimitive(bytes, model.bufferViews[view].byteLength, ids);
  if (!decoded.ok()) return decoded.status().WithContext(where);
  out = std::move(decoded).value();
  uint64_t values = out.indices.size() + out.positions.size() * 3 + out.normals.size() * 3 + out.colors.size() * 4;
  for (const auto& uv : out.texcoords) values += uv.size() * 2;
  return budget.Spend(values, where);
}

Status ReadPrimitive(const tg::Model& model, const json& raw_prim, const tg::Primitive& tp,
                     const std::string& where, Scene& scene, DecodeBudget& budget, Primitive& out) {
  for (const auto& [name, index] : tp.attributes) {
    (void)index;
    if (!IsKeptAttribute(name)) {
      scene.warnings.push_back(where + ": attribute " + name + " dropped (meshstream keeps POSITION, NORMAL, TEXCOORD_n, COLOR_0)");
    }
  }
  if (!tp.attributes.count("POSITION")) return InvalidInput(where + " has no POSITION attribute");
  const int mode = tp.mode < 0 ? TINYGLTF_MODE_TRIANGLES : tp.mode;

  const json* draco = nullptr;
  if (raw_prim.is_object() && raw_prim.contains("extensions") && raw_prim["extensions"].is_object() &&
      raw_prim["extensions"].contains("KHR_draco_mesh_compression")) {
    draco = &raw_prim["extensions"]["KHR_draco_mesh_compression"];
  }
  if (draco) {
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP) {
      return InvalidInput(where + ": KHR_draco_mesh_compression requires triangles or triangle strips");
    }
    MS_RETURN_IF_ERROR(ReadDracoPrimitive(model, *draco, tp, where, budget, out));
  } else {
    MS_ASSIGN_OR_RETURN(std::vector<double> pos, ReadAccessor(model, tp.attributes.at("POSITION"), 3, where + ".POSITION", budget));
    out.positions = ToVectors<3>(pos, 3);
    const size_t n = out.positions.size();
    auto check_count = [&](size_t count, const std::string& name) -> Status {
      if (count != n) {
        return InvalidInput(where + ": " + name + " has " + std::to_string(count) + " elements but POSITION has " +
                            std::to_string(n));
      }
      return Status::Ok();
    };
    if (tp.attributes.count("NORMAL")) {
      MS_ASSIGN_OR_RETURN(std::vector<double> nrm, ReadAccessor(model, tp.attributes.at("NORMAL"), 3, where + ".NORMAL", budget));
      out.normals = ToVectors<3>(nrm, 3);
      MS_RETURN_IF_ERROR(check_count(out.normals.size(), "NORMAL"));
    }
    for (const std::string& name : TexcoordNames(tp.attributes)) {
      MS_ASSIGN_OR_RETURN(std::vector<double> uv, ReadAccessor(model, tp.attributes.at(name), 2, where + "." + name, budget));
      out.texcoords.push_back(ToVectors<2>(uv, 2));
      MS_RETURN_IF_ERROR(check_count(out.texcoords.back().size(), name));
    }
    if (tp.attributes.count("COLOR_0")) {
      const int color_index = tp.attributes.at("COLOR_0");
      if (color_index < 0 || static_cast<size_t>(color_index) >= model.accessors.size()) {
        return InvalidInput(where + ".COLOR_0: accessor " + std::to_string(color_index) + " does not exist");
      }
      const int components = model.accessors[color_index].type == TINYGLTF_TYPE_VEC3 ? 3 : 4;
      MS_ASSIGN_OR_RETURN(std::vector<double> col, ReadAccessor(model, color_index, components, where + ".COLOR_0", budget));
      out.colors = ToVectors<4>(col, components);
      MS_RETURN_IF_ERROR(check_count(out.colors.size(), "COLOR_0"));
    }
    std::vector<uint32_t> vertex_list;
    if (tp.indices >= 0) {
      MS_ASSIGN_OR_RETURN(vertex_list, ReadIndices(model, tp.indices, where, budget));
    } else {
      MS_RETURN_IF_ERROR(budget.Spend(n, where));
      vertex_list.resize(n);
      for (size_t i = 0; i < n; ++i) vertex_list[i] = static_cast<uint32_t>(i);
    }
    for (size_t i = 0; i < vertex_list.size(); ++i) {
      if (vertex_list[i] >= n) {
        return InvalidInput(where + ": index " + std::to_string(vertex_list[i]) + " at position " + std::to_string(i) +
                            " is out of range (" + std::to_string(n) + " vertices)");
      }
    }
    MS_ASSIGN_OR_RETURN(out.indices, Triangulate(vertex_list, mode, where));
  }
  for (size_t t = out.texcoords.size(); t < TexcoordNames(tp.attributes).size(); ++t) {
    scene.warnings.push_back(where + ": TEXCOORD_" + std::to_string(t) + " missing from the Draco stream, dropped");
  }
  if (tp.material >= 0) {
    if (static_cast<size_t>(tp.material) >= model.materials.size()) {
      return InvalidInput(where + ".material " + std::to_string(tp.material) + " does not exist");
    }
    out.material = tp.material;
  }
  return ValidatePrimitive(out).WithContext(where);
}

// Removes extensions outside the pass-through list from every object of a
// carried-through array, with a warning for each.
json FilterExtensions(const json& array, const std::string& what, Scene& scene,
                      std::set<std::string>& used) {
  json out = array.is_array() ? array : json::array();
  for (size_t i = 0; i < out.size(); ++i) {
    std::vector<json*> stack = {&out[i]};
    while (!stack.empty()) {
      json* obj = stack.back();
      stack.pop_back();
      if (obj->is_object()) {
        auto ext = obj->find("extensions");
        if (ext != obj->end() && ext->is_object()) {
          for (auto it = ext->begin(); it != ext->end();) {
            if (PassThroughExtensions().count(it.key())) {
              used.insert(it.key());
              ++it;
            } else {
              scene.warnings.push_back(what + "[" + std::to_string(i) + "]: extension " + it.key() + " dropped");
              it = ext->erase(it);
            }
          }
        }
        for (auto& [key, value] : obj->items()) {
          (void)key;
          if (value.is_object() || value.is_array()) stack.push_back(&value);
        }
      } else if (obj->is_array()) {
        for (json& value : *obj) stack.push_back(&value);
      }
    }
  }
  return out;
}

std::string GuessMimeType(const std::string& uri, const std::vector<uint8_t>& bytes) {
  if (bytes.size() >= 8 && bytes[0] == 0x89 && bytes[1] == 'P' && bytes[2] == 'N' && bytes[3] == 'G') return "image/png";
  if (bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF) return "image/jpeg";
  const std::string ext = FileExtension(uri);
  if (ext == ".png") return "image/png";
  if (ext == ".jpg" || ext == ".jpeg") return "image/jpeg";
  if (ext == ".webp") return "image/webp";
  if (ext == ".ktx2") return "image/ktx2";
  return "application/octet-stream";
}

// Every node has at most one parent and the hierarchy has no cycle. Linear
// time: each node is walked towards its root once, since a walk stops at the
// first node an earlier walk already cleared.
Status CheckNodeForest(const Scene& scene) {
  const size_t n = scene.nodes.size();
  std::vector<int64_t> parent(n, -1);
  for (size_t i = 0; i < n; ++i) {
    for (int32_t c : scene.nodes[i].children) {
      if (parent[c] != -1 || static_cast<size_t>(c) == i) {
        return InvalidInput("nodes[" + std::to_string(c) + "] has more than one parent or is its own child");
      }
      parent[c] = static_cast<int64_t>(i);
    }
  }
  enum : uint8_t { kUnseen, kOnWalk, kCleared };
  std::vector<uint8_t> state(n, kUnseen);
  std::vector<size_t> walk;
  for (size_t i = 0; i < n; ++i) {
    walk.clear();
    int64_t p = static_cast<int64_t>(i);
    while (p != -1 && state[p] == kUnseen) {
      state[p] = kOnWalk;
      walk.push_back(static_cast<size_t>(p));
      p = parent[p];
    }
    if (p != -1 && state[p] == kOnWalk) {
      return InvalidInput("nodes[" + std::to_string(p) + "] is part of a cycle in the node hierarchy");
    }
    for (size_t w : walk) state[w] = kCleared;
  }
  return Status::Ok();
}

// Texture references inside the carried-through materials: every object
// under a key ending in "Texture" (baseColorTexture, normalTexture,
// clearcoatTexture, ...) with an "index" must name an existing texture.
// "extras" belong to the application and are not interpreted.
Status CheckMaterialTextures(const json& materials, size_t texture_count) {
  for (size_t i = 0; i < materials.size(); ++i) {
    std::vector<const json*> stack = {&materials[i]};
    while (!stack.empty()) {
      const json* obj = stack.back();
      stack.pop_back();
      if (obj->is_array()) {
        for (const json& v : *obj) stack.push_back(&v);
        continue;
      }
      if (!obj->is_object()) continue;
      for (auto it = obj->begin(); it != obj->end(); ++it) {
        const std::string& key = it.key();
        const bool texture_info = key.size() >= 7 && key.compare(key.size() - 7, 7, "Texture") == 0;
        if (texture_info && it->is_object() && it->contains("index")) {
          const json& index = (*it)["index"];
          if (!index.is_number_integer() || index.get<int64_t>() < 0 ||
              static_cast<uint64_t>(index.get<int64_t>()) >= texture_count) {
            return InvalidInput("materials[" + std::to_string(i) + "]: " + key + " names texture " + index.dump() +
                                ", which does not exist");
          }
        }
        if ((it->is_object() || it->is_array()) && key != "extras") stack.push_back(&*it);
      }
    }
  }
  return Status::Ok();
}

StatusOr<Scene> Convert(const tg::Model& model, const json& doc, const std::string& base_dir,
                        const ImportOptions& options, uint64_t input_bytes) {
  Scene scene;
  DecodeBudget budget(input_bytes);
  Carrier carrier(model, scene, budget);
  for (const std::string& ext : model.extensionsRequired) {
    if (!IsConsumedExtension(ext) && !PassThroughExtensions().count(ext)) {
      return Unsupported("required extension " + ext + " is not supported");
    }
  }
  std::set<std::string> used;
  for (const std::string& ext : model.extensionsUsed) {
    if (!IsConsumedExtension(ext) && !PassThroughExtensions().count(ext)) {
      scene.warnings.push_back("optional extension " + ext + " is not supported and was dropped");
    }
  }

  const json empty_array = json::array();
  const json& raw_meshes = doc.contains("meshes") ? doc["meshes"] : empty_array;
  for (size_t m = 0; m < model.meshes.size(); ++m) {
    Mesh mesh;
    mesh.name = model.meshes[m].name;
    mesh.weights = model.meshes[m].weights;
    mesh.extras_json = ExtrasOf(doc, "meshes", m);
    for (size_t k = 0; k < model.meshes[m].primitives.size(); ++k) {
      const json* raw_prim = &empty_array;
      if (raw_meshes.is_array() && m < raw_meshes.size() && raw_meshes[m].contains("primitives") &&
          raw_meshes[m]["primitives"].is_array() && k < raw_meshes[m]["primitives"].size()) {
        raw_prim = &raw_meshes[m]["primitives"][k];
      }
      if (IsCarriedPrimitive(model.meshes[m].primitives[k])) {
        CarriedPrimitive carried;
        carried.slot = static_cast<uint32_t>(k);
        MS_RETURN_IF_ERROR(ReadCarriedPrimitive(model, *raw_prim, model.meshes[m].primitives[k], Where(m, k), carrier, carried));
        if (raw_prim->is_object() && raw_prim->contains("extras")) carried.extras_json = (*raw_prim)["extras"].dump();
        mesh.carried.push_back(std::move(carried));
        continue;
      }
      Primitive prim;
      MS_RETURN_IF_ERROR(ReadPrimitive(model, *raw_prim, model.meshes[m].primitives[k], Where(m, k), scene, budget, prim));
      if (raw_prim->is_object() && raw_prim->contains("extras")) {
        scene.warnings.push_back(Where(m, k) + ": extras of a refined primitive dropped (its mesh's extras are kept)");
      }
      scene.source_vertices += prim.vertex_count();
      mesh.primitives.push_back(std::move(prim));
    }
    scene.meshes.push_back(std::move(mesh));
  }

  const int32_t camera_count = doc.contains("cameras") && doc["cameras"].is_array()
                                   ? static_cast<int32_t>(doc["cameras"].size()) : 0;
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const tg::Node& tn = model.nodes[i];
    const std::string where = "nodes[" + std::to_string(i) + "]";
    Node node;
    node.name = tn.name;
    node.extras_json = ExtrasOf(doc, "nodes", i);
    node.mesh = tn.mesh;
    if (tn.mesh < -1 || tn.mesh >= static_cast<int>(scene.meshes.size())) {
      return InvalidInput(where + ".mesh " + std::to_string(tn.mesh) + " does not exist");
    }
    if (tn.camera < -1 || tn.camera >= camera_count) {
      return InvalidInput(where + ".camera " + std::to_string(tn.camera) + " does not exist");
    }
    node.camera = tn.camera;
    for (int c : tn.children) {
      if (c < 0 || static_cast<size_t>(c) >= model.nodes.size()) {
        return InvalidInput(where + ".children names node " + std::to_string(c) + ", which does not exist");
      }
      node.children.push_back(c);
    }
    if (!tn.matrix.empty()) {
      if (tn.matrix.size() != 16) return InvalidInput(where + ".matrix must have 16 numbers");
      node.has_matrix = true;
      std::copy(tn.matrix.begin(), tn.matrix.end(), node.matrix.begin());
    }
    if (!tn.translation.empty()) {
      if (tn.translation.size() != 3) return InvalidInput(where + ".translation must have 3 numbers");
      std::copy(tn.translation.begin(), tn.translation.end(), node.translation.begin());
    }
    if (!tn.rotation.empty()) {
      if (tn.rotation.size() != 4) return InvalidInput(where + ".rotation must have 4 numbers");
      std::copy(tn.rotation.begin(), tn.rotation.end(), node.rotation.begin());
    }
    if (!tn.scale.empty()) {
      if (tn.scale.size() != 3) return InvalidInput(where + ".scale must have 3 numbers");
      std::copy(tn.scale.begin(), tn.scale.end(), node.scale.begin());
    }
    for (double v : node.matrix) if (!std::isfinite(v)) return InvalidInput(where + ".matrix is not finite");
    scene.nodes.push_back(std::move(node));
  }
  MS_RETURN_IF_ERROR(CheckNodeForest(scene));
  MS_RETURN_IF_ERROR(ReadLights(doc, scene));
  MS_RETURN_IF_ERROR(ReadSkinsAndAnimations(model, carrier, scene));
  for (size_t k = 0; k < scene.skins.size(); ++k) scene.skins[k].extras_json = ExtrasOf(doc, "skins", k);
  for (size_t k = 0; k < scene.animations.size(); ++k) {
    scene.animations[k].extras_json = ExtrasOf(doc, "animations", k);
  }
  for (size_t k = 0; k < model.scenes.size(); ++k) {
    const tg::Scene& ts = model.scenes[k];
    SceneRoot root;
    root.name = ts.name;
    root.extras_json = ExtrasOf(doc, "scenes", k);
    for (int n : ts.nodes) {
      if (n < 0 || static_cast<size_t>(n) >= scene.nodes.size()) {
        return InvalidInput("scenes names node " + std::to_string(n) + ", which does not exist");
      }
      root.nodes.push_back(n);
    }
    scene.scenes.push_back(std::move(root));
  }
  scene.default_scene = model.defaultScene;
  if (scene.default_scene < -1 || scene.default_scene >= static_cast<int32_t>(scene.scenes.size())) {
    return InvalidInput("scene " + std::to_string(scene.default_scene) + " does not exist");
  }

  // Images, as bytes.
  for (size_t i = 0; i < model.images.size(); ++i) {
    const tg::Image& ti = model.images[i];
    Image image;
    image.name = ti.name;
    if (!ti.uri.empty() && ti.uri.rfind("data:", 0) != 0) {
      MS_ASSIGN_OR_RETURN(std::string relative, CheckUri(ti.uri, "images[" + std::to_string(i) + "]"));
      if (base_dir.empty()) return InvalidInput("images[" + std::to_string(i) + "] names an external file, which is not allowed here");
      FsContext ctx;
      char buf[PATH_MAX];
      if (realpath(base_dir.c_str(), buf) == nullptr) return IoError(base_dir + ": cannot resolve the asset's folder");
      ctx.base_real = buf;
      ctx.max_bytes = options.max_input_bytes;
      std::vector<unsigned char> bytes;
      const std::string path = BasePrefix(ctx) + relative;
      if (!FsReadWholeFile(&bytes, nullptr, path, &ctx)) {
        return ctx.status.WithContext("images[" + std::to_string(i) + "]");
      }
      image.bytes = std::move(bytes);
    } else {
      image.bytes = ti.image;
    }
    if (image.bytes.empty()) return InvalidInput("images[" + std::to_string(i) + "] has no bytes");
    image.mime_type = ti.mimeType.empty() ? GuessMimeType(ti.uri, image.bytes) : ti.mimeType;
    scene.images.push_back(std::move(image));
  }

  // Carried-through JSON, with cross references checked.
  auto array_of = [&](const char* key) { return doc.contains(key) ? doc[key] : json::array(); };
  const json materials = FilterExtensions(array_of("materials"), "materials", scene, used);
  const json textures = FilterExtensions(array_of("textures"), "textures", scene, used);
  const json samplers = FilterExtensions(array_of("samplers"), "samplers", scene, used);
  const json cameras = FilterExtensions(array_of("cameras"), "cameras", scene, used);
  for (size_t t = 0; t < textures.size(); ++t) {
    const json& tex = textures[t];
    for (const char* key : {"source", "sampler"}) {
      if (!tex.is_object() || !tex.contains(key)) continue;
      const size_t limit = std::string(key) == "source" ? scene.images.size() : samplers.size();
      if (!tex[key].is_number_integer() || tex[key].get<int64_t>() < 0 ||
          static_cast<uint64_t>(tex[key].get<int64_t>()) >= limit) {
        return InvalidInput("textures[" + std::to_string(t) + "]." + key + " does not exist");
      }
    }
  }
  MS_RETURN_IF_ERROR(CheckMaterialTextures(materials, textures.size()));
  scene.materials_json = materials.dump();
  scene.textures_json = textures.dump();
  scene.samplers_json = samplers.dump();
  scene.cameras_json = cameras.dump();
  scene.extensions_used.assign(used.begin(), used.end());
  MS_RETURN_IF_ERROR(ValidateScene(scene));
  return scene;
}

// A copy of `doc` without the "indices" of Draco-compressed primitives, or
// nothing when there is none to remove.
std::optional<json> WithoutDracoIndices(const json& doc) {
  std::optional<json> out;
  auto meshes = doc.find("meshes");
  if (meshes == doc.end() || !meshes->is_array()) return out;
  for (size_t m = 0; m < meshes->size(); ++m) {
    const json& mesh = (*meshes)[m];
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
    for (size_t k = 0; k < mesh["primitives"].size(); ++k) {
      const json& prim = mesh["primitives"][k];
      if (!prim.is_object() || !prim.contains("indices") || !prim.contains("extensions") ||
          !prim["extensions"].is_object() || !prim["extensions"].contains("KHR_draco_mesh_compression")) {
        continue;
      }
      if (!out) out = doc;
      (*out)["meshes"][m]["primitives"][k].erase("indices");
    }
  }
  return out;
}

void AppendU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}

std::vector<uint8_t> RebuildGlb(std::string text, const GlbView& glb) {
  while (text.size() % 4) text.push_back(' ');
  const size_t bin_padded = (glb.bin_size + 3) & ~size_t{3};
  std::vector<uint8_t> out;
  AppendU32(out, kGlbMagic);
  AppendU32(out, 2);
  AppendU32(out, static_cast<uint32_t>(12 + 8 + text.size() + (glb.bin ? 8 + bin_padded : 0)));
  AppendU32(out, static_cast<uint32_t>(text.size()));
  AppendU32(out, kGlbChunkJson);
  out.insert(out.end(), text.begin(), text.end());
  if (glb.bin) {
    AppendU32(out, static_cast<uint32_t>(bin_padded));
    AppendU32(out, kGlbChunkBin);
    out.insert(out.end(), glb.bin, glb.bin + glb.bin_size);
    out.resize(out.size() + (bin_padded - glb.bin_size), 0);
  }
  return out;
}

}  // namespace

StatusOr<Scene> ImportGltfBytes(const std::vector<uint8_t>& bytes, const std::string& base_dir,
                                const std::string& name, const ImportOptions& options) {
  return ImportGltfBytes(bytes, base_dir, name, options, nullptr);
}

StatusOr<Scene> ImportGltfBytes(const std::vector<uint8_t>& bytes, const std::string& base_dir,
                                const std::string& name, const ImportOptions& options, json* document) {
  auto fail = [&](const Status& s) { return s.WithContext(name); };
  if (bytes.size() > options.max_input_bytes) {
    return fail(ResourceExhausted(std::to_string(bytes.size()) + " bytes is above the input cap"));
  }
  const bool is_glb = LooksLikeGlb(bytes.data(), bytes.size());
  GlbView glb;
  const uint8_t* json_data = bytes.data();
  size_t json_size = bytes.size();
  if (is_glb) {
    auto parsed = ParseGlb(bytes.data(), bytes.size());
    if (!parsed.ok()) return fail(parsed.status());
    glb = parsed.value();
    json_data = glb.json;
    json_size = glb.json_size;
  }
  if (json_size == 0) return fail(InvalidInput("empty file"));
  if (Status s = CheckJsonDepth(json_data, json_size); !s.ok()) return fail(s);
  // nlohmann (and so tinygltf) refuses the whole document when a string holds
  // invalid UTF-8. Bytes outside strings that are not ASCII make the JSON
  // invalid anyway, so repairing the whole text only touches strings: names,
  // extras, URIs. The repaired text is what both parsers see.
  std::string repaired;
  const bool bad_utf8 = !IsValidUtf8(std::string_view(reinterpret_cast<const char*>(json_data), json_size));
  if (bad_utf8) {
    repaired = ToValidUtf8(std::string_view(reinterpret_cast<const char*>(json_data), json_size));
    json_data = reinterpret_cast<const uint8_t*>(repaired.data());
    json_size = repaired.size();
  }
  json doc = json::parse(json_data, json_data + json_size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return fail(InvalidInput("the glTF JSON does not parse"));
  if (Status s = ValidateGltfDocument(doc, is_glb, glb.bin_size); !s.ok()) return fail(s);

  // tinygltf 2.7, built without Draco, refuses an indices accessor without a
  // bufferView, which is what every KHR_draco_mesh_compression primitive has.
  // Such primitives take their indices from the Draco stream, so tinygltf is
  // given a copy of the document without them.
  std::vector<uint8_t> rewritten;
  const std::vector<uint8_t>* parser_bytes = &bytes;
  std::optional<json> stripped = WithoutDracoIndices(doc);
  if (stripped.has_value() || bad_utf8) {
    std::string text = stripped.has_value() ? stripped->dump() : repaired;
    if (is_glb) {
      rewritten = RebuildGlb(text, glb);
    } else {
      rewritten.assign(text.begin(), text.end());
    }
    parser_bytes = &rewritten;
  }
  if (parser_bytes->size() > UINT32_MAX) {
    return fail(ResourceExhausted(std::to_string(parser_bytes->size()) + " bytes is more than the glTF parser takes (4 GiB)"));
  }

  FsContext ctx;
  ctx.max_bytes = options.max_input_bytes;
  if (!base_dir.empty()) {
    char buf[PATH_MAX];
    if (realpath(base_dir.c_str(), buf) == nullptr) return fail(IoError(base_dir + ": cannot resolve the asset's folder"));
    ctx.base_real = buf;
  }
  tg::TinyGLTF loader;
  loader.SetImageLoader(&KeepImageBytes, nullptr);
  tg::FsCallbacks callbacks{&FsFileExists, &FsExpandFilePath, &FsReadWholeFile, &FsWriteWholeFile, &ctx};
  loader.SetFsCallbacks(callbacks);
  tg::Model model;
  std::string err, warn;
  bool loaded = false;
  try {
    if (is_glb) {
      loaded = loader.LoadBinaryFromMemory(&model, &err, &warn, parser_bytes->data(),
                                           static_cast<unsigned int>(parser_bytes->size()), ctx.base_real);
    } else {
      loaded = loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(parser_bytes->data()),
                                          static_cast<unsigned int>(parser_bytes->size()), ctx.base_real);
    }
  } catch (const std::exception& e) {
    return fail(InvalidInput(std::string("glTF parser failed: ") + e.what()));
  } catch (...) {
    return fail(InvalidInput("glTF parser failed"));
  }
  if (!loaded) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    for (char& c : err) if (c == '\n') c = ';';
    if (!ctx.status.ok()) return fail(ctx.status);
    return fail(InvalidInput(err.empty() ? "glTF parser failed" : err));
  }
  try {
    auto scene = Convert(model, doc, base_dir, options, bytes.size());
    if (!scene.ok()) return fail(scene.status());
    if (bad_utf8) {
      scene->warnings.insert(scene->warnings.begin(),
                             "the glTF JSON holds strings (names, extras) that are not valid UTF-8; "
                             "ill-formed bytes were replaced by U+FFFD");
    }
    if (document) *document = std::move(doc);
    return scene;
  } catch (const std::exception& e) {
    return fail(Internal(std::string("unexpected error: ") + e.what()));
  }
}

StatusOr<Scene> ImportGltfFile(const std::string& path, const ImportOptions& options) {
  MS_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, ReadFileBytes(path, options.max_input_bytes));
  const size_t slash = path.find_last_of('/');
  const std::string base_dir = slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
  return ImportGltfBytes(bytes, base_dir, path, options);
}

}  // namespace meshstream

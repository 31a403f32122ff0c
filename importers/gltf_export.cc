#include "importers/gltf_export.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include <nlohmann/json.hpp>

#include "codec/mesh/quantization.h"
#include "importers/gltf_accessors.h"
#include "importers/gltf_limits.h"
#include "importers/import.h"
#include "importers/exception_boundary.h"

namespace meshstream {

namespace {

using json = nlohmann::json;

constexpr int kFloat = 5126;
constexpr int kUnsignedShort = 5123;
constexpr int kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

// Sets object["extras"] from carried JSON text ("" when there were none;
// text that does not parse, which only a hand-built Scene could hold, is left out).
void SetExtras(json& object, const std::string& extras_json) {
  if (extras_json.empty()) return;
  json extras = json::parse(extras_json, nullptr, false);
  if (!extras.is_discarded()) object["extras"] = std::move(extras);
}

// Builds the document and the single binary buffer.
class DocumentBuilder {
 public:
  explicit DocumentBuilder(const ExportOptions& options) : options_(options) {}

  StatusOr<json> Build(const Scene& scene);
  std::vector<uint8_t>& bin() { return bin_; }

 private:
  // Appends bytes (4-aligned) and returns the new bufferView's index.
  int AddView(const void* data, size_t size, int target) {
    while (bin_.size() % 4) bin_.push_back(0);
    json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}};
    if (target) view["target"] = target;
    const uint8_t* p = static_cast<const uint8_t*>(data);
    bin_.insert(bin_.end(), p, p + size);
    views_.push_back(view);
    return static_cast<int>(views_.size()) - 1;
  }

  // A bufferView whose bytes go after everything else in the buffer
  // (PlaceDeferredViews): a progressive primitive's refinements, so that the
  // file up to its first refinement holds every base mesh, the scene and its
  // images (docs/spec/progressive-format.md, "Layout"). `bytes` outlives Build.
  // `late`: after every other deferred view (a file with both profiles puts
  // the reliable profile's blobs first, which a viewer reading ranges needs,
  // and the loss-tolerant ones last).
  int AddDeferredView(const std::vector<uint8_t>* bytes, bool late = false) {
    views_.push_back({{"buffer", 0}, {"byteOffset", 0}, {"byteLength", bytes->size()}});
    (late ? deferred_late_ : deferred_).emplace_back(static_cast<int>(views_.size()) - 1, bytes);
    return static_cast<int>(views_.size()) - 1;
  }
  void PlaceDeferredViews() {
    for (auto* list : {&deferred_, &deferred_late_}) {
      for (const auto& [view, bytes] : *list) {
        while (bin_.size() % 4) bin_.push_back(0);
        views_[view]["byteOffset"] = bin_.size();
        bin_.insert(bin_.end(), bytes->begin(), bytes->end());
      }
      list->clear();
    }
  }

  int AddAccessor(json accessor) {
    accessors_.push_back(std::move(accessor));
    return static_cast<int>(accessors_.size()) - 1;
  }

  template <size_t N>
  int AddFloatAttribute(const std::vector<std::array<float, N>>& values, bool with_bounds) {
    static const char* kTypes[] = {"", "SCALAR", "VEC2", "VEC3", "VEC4"};
    const int view = AddView(values.data(), values.size() * sizeof(float) * N, kArrayBuffer);
    json accessor = {{"bufferView", view}, {"componentType", kFloat}, {"count", values.size()}, {"type", kTypes[N]}};
    if (with_bounds) AddBounds(accessor, values);
    return AddAccessor(std::move(accessor));
  }

  template <size_t N>
  static void AddBounds(json& accessor, const std::vector<std::array<float, N>>& values) {
    const ComponentBounds<N> b = BoundsOf(values);
    accessor["min"] = b.lo;
    accessor["max"] = b.hi;
  }

  int AddIndices(const std::vector<uint32_t>& indices, size_t vertex_count) {
    json accessor = {{"count", indices.size()}, {"type", "SCALAR"}};
    if (vertex_count < 0xFFFF) {
      std::vector<uint16_t> narrow(indices.begin(), indices.end());
      accessor["bufferView"] = AddView(narrow.data(), narrow.size() * 2, kElementArrayBuffer);
      accessor["componentType"] = kUnsignedShort;
    } else {
      accessor["bufferView"] = AddView(indices.data(), indices.size() * 4, kElementArrayBuffer);
      accessor["componentType"] = kUnsignedInt;
    }
    return AddAccessor(std::move(accessor));
  }

  // The output accessor of carried accessor `id`, written on first use.
  int CarriedAccessorIndex(const Scene& scene, int32_t id);
  json CarriedAttributesJson(const Scene& scene, const CarriedAttributes& attributes);
  json CarriedPrimitiveJson(const Scene& scene, const CarriedPrimitive& p);
  std::vector<int> carried_out_;  // carried accessor -> output accessor, -1: not yet

  StatusOr<json> PlainPrimitive(const Primitive& p);
  StatusOr<json> DracoPrimitive(const Primitive& p);
  json DracoJson(const DracoEncoded& encoded, const Primitive& decoded);
  json PrecodedJson(const PrecodedPrimitive& pre);
  bool used_precoded_ = false;
  std::vector<std::string> extra_extensions_;

 public:
  bool used_precoded() const { return used_precoded_; }
  const std::vector<std::string>& extra_extensions() const { return extra_extensions_; }

 private:

  const ExportOptions& options_;
  std::vector<uint8_t> bin_;
  std::vector<std::pair<int, const std::vector<uint8_t>*>> deferred_;  // AddDeferredView
  std::vector<std::pair<int, const std::vector<uint8_t>*>> deferred_late_;
  json views_ = json::array();
  json accessors_ = json::array();
};

std::vector<Vec3f> UnitNormals(const std::vector<Vec3f>& normals) {
  std::vector<Vec3f> out(normals.size());
  for (size_t i = 0; i < normals.size(); ++i) {
    const Vec3f& n = normals[i];
    const double len = std::sqrt(double(n[0]) * n[0] + double(n[1]) * n[1] + double(n[2]) * n[2]);
    if (!(len > 0) || !std::isfinite(len)) {
      out[i] = {0, 0, 1};
    } else {
      out[i] = {float(n[0] / len), float(n[1] / len), float(n[2] / len)};
    }
  }
  return out;
}

std::vector<Vec4f> ClampedColors(const std::vector<Vec4f>& colors) {
  std::vector<Vec4f> out(colors);
  for (Vec4f& c : out)
    for (float& v : c) v = std::min(1.0f, std::max(0.0f, v));
  return out;
}

// The attribute set the writer emits: normals unit length, colours clamped.
Primitive Normalized(const Primitive& p) {
  Primitive out = p;
  out.normals = UnitNormals(p.normals);
  out.colors = ClampedColors(p.colors);
  return out;
}

StatusOr<json> DocumentBuilder::PlainPrimitive(const Primitive& source) {
  const Primitive p = Normalized(source);
  json attributes = json::object();
  attributes["POSITION"] = AddFloatAttribute<3>(p.positions, true);
  if (!p.normals.empty()) attributes["NORMAL"] = AddFloatAttribute<3>(p.normals, false);
  for (size_t t = 0; t < p.texcoords.size(); ++t) {
    attributes["TEXCOORD_" + std::to_string(t)] = AddFloatAttribute<2>(p.texcoords[t], false);
  }
  if (!p.colors.empty()) attributes["COLOR_0"] = AddFloatAttribute<4>(p.colors, false);
  json prim = {{"attributes", attributes}, {"mode", 4}};
  prim["indices"] = AddIndices(p.indices, p.vertex_count());
  return prim;
}

StatusOr<json> DocumentBuilder::DracoPrimitive(const Primitive& source) {
  const Primitive p = Normalized(source);
  MS_ASSIGN_OR_RETURN(DracoEncoded encoded, EncodeDracoPrimitive(p, options_.draco_options));
  // Decode what we wrote: the accessors must describe the decoded data
  // (Draco may reorder and drop points), and this proves the stream decodes.
  MS_ASSIGN_OR_RETURN(Primitive decoded,
                      DecodeDracoPrimitive(encoded.bytes.data(), encoded.bytes.size(), encoded.ids));
  return DracoJson(encoded, decoded);
}

json DocumentBuilder::DracoJson(const DracoEncoded& encoded, const Primitive& decoded) {
  const int view = AddView(encoded.bytes.data(), encoded.bytes.size(), 0);
  json attributes = json::object();
  json draco_attributes = json::object();
  json position = {{"componentType", kFloat}, {"count", decoded.vertex_count()}, {"type", "VEC3"}};
  AddBounds(position, decoded.positions);
  attributes["POSITION"] = AddAccessor(position);
  draco_attributes["POSITION"] = encoded.ids.position;
  if (encoded.ids.normal >= 0) {
    attributes["NORMAL"] = AddAccessor({{"componentType", kFloat}, {"count", decoded.vertex_count()}, {"type", "VEC3"}});
    draco_attributes["NORMAL"] = encoded.ids.normal;
  }
  for (size_t t = 0; t < encoded.ids.texcoords.size(); ++t) {
    const std::string name = "TEXCOORD_" + std::to_string(t);
    attributes[name] = AddAccessor({{"componentType", kFloat}, {"count", decoded.vertex_count()}, {"type", "VEC2"}});
    draco_attributes[name] = encoded.ids.texcoords[t];
  }
  if (encoded.ids.color >= 0) {
    attributes["COLOR_0"] = AddAccessor({{"componentType", kFloat}, {"count", decoded.vertex_count()}, {"type", "VEC4"}});
    draco_attributes["COLOR_0"] = encoded.ids.color;
  }
  json indices = {{"componentType", decoded.vertex_count() < 0xFFFF ? kUnsignedShort : kUnsignedInt},
                  {"count", decoded.indices.size()}, {"type", "SCALAR"}};
  json prim = {{"attributes", attributes}, {"mode", 4}, {"indices", AddAccessor(indices)}};
  prim["extensions"]["KHR_draco_mesh_compression"] = {{"bufferView", view}, {"attributes", draco_attributes}};
  return prim;
}

json DocumentBuilder::PrecodedJson(const PrecodedPrimitive& pre) {
  used_precoded_ = true;
  DracoEncoded encoded;
  encoded.bytes = pre.draco_bytes;
  encoded.ids = pre.ids;
  json prim = DracoJson(encoded, pre.decoded);
  if (!pre.extension_name.empty()) {
    const bool both = !pre.reliable_bytes.empty();
    const int reliable = both ? AddDeferredView(&pre.reliable_bytes) : -1;
    const int view = AddDeferredView(&pre.extension_bytes, both);
    json ext = {{"bufferView", view}, {"version", pre.extension_version}};
    if (both) ext["reliable"] = reliable;
    if (!pre.extension_fields.empty()) {
      const json fields = json::parse(pre.extension_fields);  // kept alive: items() refers into it
      for (const auto& item : fields.items()) ext[item.key()] = item.value();
    }
    prim["extensions"][pre.extension_name] = std::move(ext);
    if (std::find(extra_extensions_.begin(), extra_extensions_.end(), pre.extension_name) == extra_extensions_.end()) {
      extra_extensions_.push_back(pre.extension_name);
    }
  }
  return prim;
}

// Per-component min and max of packed little-endian elements, as the glTF
// accessor's raw component values (floats as floats, integers as integers).
void CarriedBounds(const CarriedAccessor& a, json& accessor) {
  const size_t csize = a.ComponentBytes(), n = a.Components();
  std::vector<double> lo(n, std::numeric_limits<double>::infinity()), hi(n, -std::numeric_limits<double>::infinity());
  for (uint64_t i = 0; i < a.count; ++i) {
    for (size_t c = 0; c < n; ++c) {
      const double v = gltf::ReadComponent(a.bytes.data() + (i * n + c) * csize, a.component_type, false);
      lo[c] = std::min(lo[c], v);
      hi[c] = std::max(hi[c], v);
    }
  }
  json jlo = json::array(), jhi = json::array();
  for (size_t c = 0; c < n; ++c) {
    if (a.component_type == 5126) {
      jlo.push_back(lo[c]);
      jhi.push_back(hi[c]);
    } else {
      jlo.push_back(static_cast<int64_t>(lo[c]));
      jhi.push_back(static_cast<int64_t>(hi[c]));
    }
  }
  accessor["min"] = jlo;
  accessor["max"] = jhi;
}

int DocumentBuilder::CarriedAccessorIndex(const Scene& scene, int32_t id) {
  if (carried_out_.size() < scene.carried_accessors.size()) carried_out_.resize(scene.carried_accessors.size(), -1);
  if (carried_out_[id] >= 0) return carried_out_[id];
  const CarriedAccessor& a = scene.carried_accessors[id];
  const size_t element = a.ElementBytes();
  int view;
  if (a.use == CarriedAccessor::Use::kVertex && element % 4 != 0) {
    // Vertex attribute elements must start on 4-byte boundaries: pad them.
    const size_t stride = (element + 3) & ~size_t{3};
    std::vector<uint8_t> padded(a.count * stride, 0);
    for (uint64_t i = 0; i < a.count; ++i) std::memcpy(padded.data() + i * stride, a.bytes.data() + i * element, element);
    padded.resize(padded.size() - (stride - element));  // the last element needs no padding
    view = AddView(padded.data(), padded.size(), kArrayBuffer);
    views_[view]["byteStride"] = stride;
  } else {
    const int target = a.use == CarriedAccessor::Use::kVertex ? kArrayBuffer
                       : a.use == CarriedAccessor::Use::kIndex ? kElementArrayBuffer : 0;
    view = AddView(a.bytes.data(), a.bytes.size(), target);
  }
  json accessor = {{"bufferView", view}, {"componentType", a.component_type}, {"count", a.count}, {"type", a.type}};
  if (a.normalized) accessor["normalized"] = true;
  if (!a.name.empty()) accessor["name"] = a.name;
  CarriedBounds(a, accessor);
  carried_out_[id] = AddAccessor(std::move(accessor));
  return carried_out_[id];
}

json DocumentBuilder::CarriedAttributesJson(const Scene& scene, const CarriedAttributes& attributes) {
  json out = json::object();
  for (const auto& [name, id] : attributes) out[name] = CarriedAccessorIndex(scene, id);
  return out;
}

json DocumentBuilder::CarriedPrimitiveJson(const Scene& scene, const CarriedPrimitive& p) {
  json prim = {{"attributes", CarriedAttributesJson(scene, p.attributes)}, {"mode", p.mode}};
  if (p.indices >= 0) prim["indices"] = CarriedAccessorIndex(scene, p.indices);
  if (!p.targets.empty()) {
    json targets = json::array();
    for (const CarriedAttributes& t : p.targets) targets.push_back(CarriedAttributesJson(scene, t));
    prim["targets"] = std::move(targets);
  }
  if (p.material >= 0) prim["material"] = p.material;
  SetExtras(prim, p.extras_json);
  return prim;
}

json ParseCarried(const std::string& text) {
  json v = json::parse(text, nullptr, false);
  return v.is_array() ? v : json::array();
}

StatusOr<json> DocumentBuilder::Build(const Scene& scene) {
  MS_RETURN_IF_ERROR(ValidateScene(scene));
  json doc = {{"asset", {{"version", "2.0"}, {"generator", "meshstream"}}}};

  json meshes = json::array();
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    json out = {{"primitives", json::array()}};
    if (!mesh.name.empty()) out["name"] = mesh.name;
    for (const Mesh::Ref& ref : mesh.Order()) {
      if (ref.carried) {
        out["primitives"].push_back(CarriedPrimitiveJson(scene, mesh.carried[ref.index]));
        continue;
      }
      const size_t k = ref.index;
      const Primitive& p = mesh.primitives[k];
      static const std::vector<const PrecodedPrimitive*> kNone;
      const std::vector<const PrecodedPrimitive*>& pre =
          (m < options_.precoded.size() && k < options_.precoded[m].size()) ? options_.precoded[m][k] : kNone;
      // A precoded primitive is written from its codings (its arrays may be
      // released: EncodeProgressiveGlbReleasing).
      if (pre.empty() && p.face_count() == 0) continue;
      for (size_t part = 0; part < std::max<size_t>(pre.size(), 1); ++part) {
        auto prim = !pre.empty()   ? StatusOr<json>(PrecodedJson(*pre[part]))
                    : options_.draco ? DracoPrimitive(p)
                                     : PlainPrimitive(p);
        if (!prim.ok()) {
          return prim.status().WithContext("meshes[" + std::to_string(m) + "].primitives[" + std::to_string(k) + "]");
        }
        if (p.material >= 0) prim.value()["material"] = p.material;
        out["primitives"].push_back(std::move(prim).value());
      }
    }
    if (out["primitives"].empty()) {
      return InvalidInput("meshes[" + std::to_string(m) + "] has no primitive to write");
    }
    if (!mesh.weights.empty()) out["weights"] = mesh.weights;
    SetExtras(out, mesh.extras_json);
    meshes.push_back(std::move(out));
  }

  json nodes = json::array();
  for (const Node& node : scene.nodes) {
    json out = json::object();
    if (!node.name.empty()) out["name"] = node.name;
    if (node.mesh >= 0) out["mesh"] = node.mesh;
    if (node.camera >= 0) out["camera"] = node.camera;
    if (node.skin >= 0) out["skin"] = node.skin;
    if (!node.weights.empty()) out["weights"] = node.weights;
    if (!node.children.empty()) out["children"] = node.children;
    if (node.has_matrix) {
      out["matrix"] = node.matrix;
    } else {
      if (node.translation != Vec3d{0, 0, 0}) out["translation"] = node.translation;
      if (node.rotation != std::array<double, 4>{0, 0, 0, 1}) out["rotation"] = node.rotation;
      if (node.scale != Vec3d{1, 1, 1}) out["scale"] = node.scale;
    }
    if (node.light >= 0) out["extensions"]["KHR_lights_punctual"] = {{"light", node.light}};
    SetExtras(out, node.extras_json);
    nodes.push_back(std::move(out));
  }

  json images = json::array();
  for (const Image& image : scene.images) {
    json out = {{"bufferView", AddView(image.bytes.data(), image.bytes.size(), 0)}, {"mimeType", image.mime_type}};
    if (!image.name.empty()) out["name"] = image.name;
    images.push_back(std::move(out));
  }

  json scenes = json::array();
  for (const SceneRoot& root : scene.scenes) {
    json out = {{"nodes", root.nodes}};
    if (!root.name.empty()) out["name"] = root.name;
    SetExtras(out, root.extras_json);
    scenes.push_back(std::move(out));
  }

  json skins = json::array();
  for (const Skin& skin : scene.skins) {
    json out = {{"joints", skin.joints}};
    if (skin.inverse_bind_matrices >= 0) out["inverseBindMatrices"] = CarriedAccessorIndex(scene, skin.inverse_bind_matrices);
    if (skin.skeleton >= 0) out["skeleton"] = skin.skeleton;
    if (!skin.name.empty()) out["name"] = skin.name;
    SetExtras(out, skin.extras_json);
    skins.push_back(std::move(out));
  }

  json animations = json::array();
  for (const Animation& anim : scene.animations) {
    json samplers = json::array(), channels = json::array();
    for (const AnimationSampler& s : anim.samplers) {
      samplers.push_back({{"input", CarriedAccessorIndex(scene, s.input)},
                          {"output", CarriedAccessorIndex(scene, s.output)},
                          {"interpolation", s.interpolation}});
    }
    for (const AnimationChannel& c : anim.channels) {
      json target = {{"path", c.path}};
      if (c.node >= 0) target["node"] = c.node;
      channels.push_back({{"sampler", c.sampler}, {"target", target}});
    }
    json out = {{"samplers", samplers}, {"channels", channels}};
    if (!anim.name.empty()) out["name"] = anim.name;
    SetExtras(out, anim.extras_json);
    animations.push_back(std::move(out));
  }

  if (!scenes.empty()) doc["scenes"] = scenes;
  if (scene.default_scene >= 0) doc["scene"] = scene.default_scene;
  if (!nodes.empty()) doc["nodes"] = nodes;
  if (!meshes.empty()) doc["meshes"] = meshes;
  for (const auto& [key, text] : {std::pair<const char*, const std::string&>{"materials", scene.materials_json},
                                  {"textures", scene.textures_json},
                                  {"samplers", scene.samplers_json},
                                  {"cameras", scene.cameras_json}}) {
    json carried = ParseCarried(text);
    if (!carried.empty()) doc[key] = std::move(carried);
  }
  if (!skins.empty()) doc["skins"] = skins;
  if (!animations.empty()) doc["animations"] = animations;
  if (!images.empty()) doc["images"] = images;
  if (!accessors_.empty()) doc["accessors"] = accessors_;
  PlaceDeferredViews();
  if (!views_.empty()) doc["bufferViews"] = views_;
  while (bin_.size() % 4) bin_.push_back(0);
  if (!bin_.empty()) doc["buffers"] = json::array({{{"byteLength", bin_.size()}}});

  std::vector<std::string> used = scene.extensions_used;
  used.insert(used.end(), extra_extensions_.begin(), extra_extensions_.end());
  if (!scene.lights.empty()) {
    json lights = json::array();
    for (const std::string& light : scene.lights) {
      json parsed = json::parse(light, nullptr, false);  // only a hand-built Scene holds text that fails
      lights.push_back(parsed.is_object() ? std::move(parsed) : json::object());
    }
    doc["extensions"]["KHR_lights_punctual"] = {{"lights", lights}};
    used.push_back("KHR_lights_punctual");
  }
  if (options_.draco || used_precoded_) {
    used.push_back("KHR_draco_mesh_compression");
    doc["extensionsRequired"] = json::array({"KHR_draco_mesh_compression"});
  }
  if (!used.empty()) doc["extensionsUsed"] = used;
  return doc;
}

void AppendU32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}

StatusOr<std::vector<uint8_t>> ExportGlbUnguarded(const Scene& scene, const ExportOptions& options) {
  DocumentBuilder builder(options);
  MS_ASSIGN_OR_RETURN(json doc, builder.Build(scene));
  std::string text = doc.dump(-1, ' ', false, json::error_handler_t::replace);
  while (text.size() % 4) text.push_back(' ');
  const std::vector<uint8_t>& bin = builder.bin();
  const uint64_t total = 12 + 8 + text.size() + (bin.empty() ? 0 : 8 + bin.size());
  if (total > 0xFFFFFFFFull) return ResourceExhausted("the GLB would be larger than 4 GiB");
  std::vector<uint8_t> out;
  out.reserve(total);
  AppendU32(out, kGlbMagic);
  AppendU32(out, 2);
  AppendU32(out, static_cast<uint32_t>(total));
  AppendU32(out, static_cast<uint32_t>(text.size()));
  AppendU32(out, kGlbChunkJson);
  out.insert(out.end(), text.begin(), text.end());
  if (!bin.empty()) {
    AppendU32(out, static_cast<uint32_t>(bin.size()));
    AppendU32(out, kGlbChunkBin);
    out.insert(out.end(), bin.begin(), bin.end());
  }
  return out;
}

Status ExportGltfFileUnguarded(const Scene& scene, const std::string& path, const ExportOptions& options) {
  const std::string ext = FileExtension(path);
  if (ext == ".glb") {
    auto bytes = ExportGlb(scene, options);
    if (!bytes.ok()) return bytes.status().WithContext(path);
    return WriteFileBytes(path, bytes.value());
  }
  if (ext != ".gltf") {
    return InvalidArgument(path + ": output must end in .gltf or .glb");
  }
  DocumentBuilder builder(options);
  auto doc = builder.Build(scene);
  if (!doc.ok()) return doc.status().WithContext(path);
  const size_t slash = path.find_last_of('/');
  const std::string file = slash == std::string::npos ? path : path.substr(slash + 1);
  const std::string stem = file.substr(0, file.size() - ext.size());
  if (!builder.bin().empty()) {
    const std::string bin_name = stem + ".bin";
    doc.value()["buffers"][0]["uri"] = bin_name;
    const std::string bin_path = (slash == std::string::npos ? "" : path.substr(0, slash + 1)) + bin_name;
    MS_RETURN_IF_ERROR(WriteFileBytes(bin_path, builder.bin()));
  }
  const std::string text = doc.value().dump(2, ' ', false, json::error_handler_t::replace);
  return WriteFileBytes(path, std::vector<uint8_t>(text.begin(), text.end()));
}

}  // namespace

StatusOr<std::vector<uint8_t>> ExportGlb(const Scene& scene, const ExportOptions& options) {
  return CatchExceptions("glTF export", [&] { return ExportGlbUnguarded(scene, options); });
}

Status ExportGltfFile(const Scene& scene, const std::string& path, const ExportOptions& options) {
  return CatchExceptions(path, [&] { return ExportGltfFileUnguarded(scene, path, options); });
}

}  // namespace meshstream

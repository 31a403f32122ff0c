#include "codec/mesh/mesh.h"

#include <cmath>

#include "codec/core/fnv.h"

namespace meshstream {

uint64_t PrimitiveHash(const Primitive& p) {
  Fnv1a h;
  h.AddVector(p.positions);
  h.AddVector(p.normals);
  const uint64_t sets = p.texcoords.size();
  h.Add(&sets, sizeof sets);
  for (const auto& t : p.texcoords) h.AddVector(t);
  h.AddVector(p.colors);
  h.AddVector(p.indices);
  return h.value;
}

std::vector<std::string> Primitive::AttributeNames() const {
  std::vector<std::string> names;
  if (!positions.empty()) names.push_back("POSITION");
  if (!normals.empty()) names.push_back("NORMAL");
  for (size_t i = 0; i < texcoords.size(); ++i) {
    names.push_back("TEXCOORD_" + std::to_string(i));
  }
  if (!colors.empty()) names.push_back("COLOR_0");
  return names;
}

size_t CarriedAccessor::ComponentBytes() const {
  switch (component_type) {
    case 5120: case 5121: return 1;
    case 5122: case 5123: return 2;
    case 5125: case 5126: return 4;
    default: return 0;
  }
}

size_t CarriedAccessor::Components() const {
  static const std::pair<const char*, size_t> kTypes[] = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                                                          {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
  for (const auto& [name, n] : kTypes) {
    if (type == name) return n;
  }
  return 0;
}

std::vector<Mesh::Ref> Mesh::Order() const {
  std::vector<Ref> out;
  out.reserve(primitives.size() + carried.size());
  size_t refined = 0, kept = 0;
  while (refined < primitives.size() || kept < carried.size()) {
    const bool take_carried = kept < carried.size() && (refined == primitives.size() || carried[kept].slot <= out.size());
    if (take_carried) {
      out.push_back({true, kept++});
    } else {
      out.push_back({false, refined++});
    }
  }
  return out;
}

size_t Scene::total_vertices() const {
  size_t n = 0;
  for (const Mesh& m : meshes)
    for (const Primitive& p : m.primitives) n += p.vertex_count();
  return n;
}

size_t Scene::total_faces() const {
  size_t n = 0;
  for (const Mesh& m : meshes)
    for (const Primitive& p : m.primitives) n += p.face_count();
  return n;
}

size_t Scene::total_primitives() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.primitives.size();
  return n;
}

namespace {

template <typename V>
Status CheckAttribute(const std::vector<V>& values, size_t vertex_count, const char* name) {
  if (!values.empty() && values.size() != vertex_count) {
    return InvalidInput(std::string(name) + " has " + std::to_string(values.size()) +
                        " values for " + std::to_string(vertex_count) + " vertices");
  }
  for (size_t i = 0; i < values.size(); ++i) {
    for (float c : values[i]) {
      if (!std::isfinite(c)) {
        return InvalidInput(std::string(name) + "[" + std::to_string(i) +
                            "] is not a finite number");
      }
    }
  }
  return Status::Ok();
}

}  // namespace

Status ValidatePrimitive(const Primitive& p) {
  const size_t n = p.positions.size();
  MS_RETURN_IF_ERROR(CheckAttribute(p.positions, n, "POSITION"));
  MS_RETURN_IF_ERROR(CheckAttribute(p.normals, n, "NORMAL"));
  for (size_t t = 0; t < p.texcoords.size(); ++t) {
    const std::string name = "TEXCOORD_" + std::to_string(t);
    if (p.texcoords[t].size() != n) {
      return InvalidInput(name + " has " + std::to_string(p.texcoords[t].size()) +
                          " values for " + std::to_string(n) + " vertices");
    }
    MS_RETURN_IF_ERROR(CheckAttribute(p.texcoords[t], n, name.c_str()));
  }
  MS_RETURN_IF_ERROR(CheckAttribute(p.colors, n, "COLOR_0"));
  if (p.indices.size() % 3 != 0) {
    return InvalidInput("index count " + std::to_string(p.indices.size()) +
                        " is not a multiple of 3");
  }
  for (size_t i = 0; i < p.indices.size(); ++i) {
    if (p.indices[i] >= n) {
      return InvalidInput("indices[" + std::to_string(i) + "] = " +
                          std::to_string(p.indices[i]) + " is out of range (" +
                          std::to_string(n) + " vertices)");
    }
  }
  return Status::Ok();
}

namespace {

Status CheckCarriedAttributes(const CarriedAttributes& attributes, size_t accessor_count, const std::string& where) {
  for (const auto& [name, index] : attributes) {
    if (index < 0 || static_cast<size_t>(index) >= accessor_count) {
      return InvalidInput(where + "." + name + ": carried accessor " + std::to_string(index) + " does not exist");
    }
  }
  return Status::Ok();
}

Status ValidateCarried(const Scene& scene) {
  const size_t accessors = scene.carried_accessors.size();
  const int32_t node_count = static_cast<int32_t>(scene.nodes.size());
  auto accessor_ok = [&](int32_t index) { return index >= 0 && static_cast<size_t>(index) < accessors; };
  for (size_t i = 0; i < accessors; ++i) {
    const CarriedAccessor& a = scene.carried_accessors[i];
    const std::string where = "carried accessor " + std::to_string(i);
    if (a.ElementBytes() == 0) return InvalidInput(where + ": componentType or type is not valid");
    if (a.count == 0 || a.count > (uint64_t{1} << 32) || a.bytes.size() != a.count * a.ElementBytes()) {
      return InvalidInput(where + ": holds " + std::to_string(a.bytes.size()) + " bytes for " +
                          std::to_string(a.count) + " elements");
    }
  }
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    for (size_t k = 0; k < mesh.carried.size(); ++k) {
      const CarriedPrimitive& p = mesh.carried[k];
      const std::string where = "meshes[" + std::to_string(m) + "].carried[" + std::to_string(k) + "]";
      if (k > 0 && p.slot <= mesh.carried[k - 1].slot) return InvalidInput(where + ": slots are not ascending");
      if (p.mode < 0 || p.mode > 6) return InvalidInput(where + ": mode " + std::to_string(p.mode) + " is not valid");
      MS_RETURN_IF_ERROR(CheckCarriedAttributes(p.attributes, accessors, where));
      if (p.indices != -1 && !accessor_ok(p.indices)) return InvalidInput(where + ".indices does not exist");
      for (size_t t = 0; t < p.targets.size(); ++t) {
        MS_RETURN_IF_ERROR(CheckCarriedAttributes(p.targets[t], accessors, where + ".targets[" + std::to_string(t) + "]"));
      }
    }
  }
  for (size_t i = 0; i < scene.nodes.size(); ++i) {
    const int32_t light = scene.nodes[i].light;
    if (light < -1 || (light >= 0 && static_cast<size_t>(light) >= scene.lights.size())) {
      return InvalidInput("nodes[" + std::to_string(i) + "].extensions.KHR_lights_punctual.light " +
                          std::to_string(light) + " does not exist");
    }
    const int32_t skin = scene.nodes[i].skin;
    if (skin < -1 || skin >= static_cast<int32_t>(scene.skins.size())) {
      return InvalidInput("nodes[" + std::to_string(i) + "].skin " + std::to_string(skin) + " does not exist");
    }
  }
  for (size_t s = 0; s < scene.skins.size(); ++s) {
    const Skin& skin = scene.skins[s];
    const std::string where = "skins[" + std::to_string(s) + "]";
    if (skin.inverse_bind_matrices != -1 && !accessor_ok(skin.inverse_bind_matrices)) {
      return InvalidInput(where + ".inverseBindMatrices does not exist");
    }
    if (skin.skeleton < -1 || skin.skeleton >= node_count) return InvalidInput(where + ".skeleton does not exist");
    if (skin.joints.empty()) return InvalidInput(where + ".joints is empty");
    for (size_t j = 0; j < skin.joints.size(); ++j) {
      if (skin.joints[j] < 0 || skin.joints[j] >= node_count) {
        return InvalidInput(where + ".joints[" + std::to_string(j) + "] names node " + std::to_string(skin.joints[j]) +
                            ", which does not exist");
      }
    }
  }
  for (size_t a = 0; a < scene.animations.size(); ++a) {
    const Animation& anim = scene.animations[a];
    const std::string where = "animations[" + std::to_string(a) + "]";
    for (size_t s = 0; s < anim.samplers.size(); ++s) {
      if (!accessor_ok(anim.samplers[s].input) || !accessor_ok(anim.samplers[s].output)) {
        return InvalidInput(where + ".samplers[" + std::to_string(s) + "]: input or output does not exist");
      }
    }
    for (size_t c = 0; c < anim.channels.size(); ++c) {
      const AnimationChannel& ch = anim.channels[c];
      const std::string w = where + ".channels[" + std::to_string(c) + "]";
      if (ch.sampler < 0 || static_cast<size_t>(ch.sampler) >= anim.samplers.size()) {
        return InvalidInput(w + ".sampler " + std::to_string(ch.sampler) + " does not exist");
      }
      if (ch.node < -1 || ch.node >= node_count) {
        return InvalidInput(w + ".target.node " + std::to_string(ch.node) + " does not exist");
      }
    }
  }
  return Status::Ok();
}

}  // namespace

Status ValidateScene(const Scene& scene) {
  MS_RETURN_IF_ERROR(ValidateCarried(scene));
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    for (size_t k = 0; k < scene.meshes[m].primitives.size(); ++k) {
      MS_RETURN_IF_ERROR(ValidatePrimitive(scene.meshes[m].primitives[k])
                             .WithContext("meshes[" + std::to_string(m) + "].primitives[" +
                                          std::to_string(k) + "]"));
    }
  }
  const int32_t node_count = static_cast<int32_t>(scene.nodes.size());
  for (size_t i = 0; i < scene.nodes.size(); ++i) {
    const Node& node = scene.nodes[i];
    if (node.mesh >= static_cast<int32_t>(scene.meshes.size())) {
      return InvalidInput("nodes[" + std::to_string(i) + "].mesh " +
                          std::to_string(node.mesh) + " does not exist");
    }
    for (int32_t c : node.children) {
      if (c < 0 || c >= node_count) {
        return InvalidInput("nodes[" + std::to_string(i) + "].children names node " +
                            std::to_string(c) + ", which does not exist");
      }
    }
  }
  for (size_t s = 0; s < scene.scenes.size(); ++s) {
    for (int32_t n : scene.scenes[s].nodes) {
      if (n < 0 || n >= node_count) {
        return InvalidInput("scenes[" + std::to_string(s) + "].nodes names node " +
                            std::to_string(n) + ", which does not exist");
      }
    }
  }
  return Status::Ok();
}

Scene SceneFromPrimitive(Primitive primitive, std::string name) {
  Scene scene;
  Mesh mesh;
  mesh.name = name;
  mesh.primitives.push_back(std::move(primitive));
  scene.source_vertices = mesh.primitives[0].vertex_count();
  scene.meshes.push_back(std::move(mesh));
  Node node;
  node.name = std::move(name);
  node.mesh = 0;
  scene.nodes.push_back(node);
  SceneRoot root;
  root.nodes = {0};
  scene.scenes.push_back(std::move(root));
  scene.default_scene = 0;
  return scene;
}

}  // namespace meshstream

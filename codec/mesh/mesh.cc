#include "codec/mesh/mesh.h"

#include <cmath>

namespace meshstream {

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

Status ValidateScene(const Scene& scene) {
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
  scene.scenes.push_back(SceneRoot{"", {0}});
  scene.default_scene = 0;
  return scene;
}

}  // namespace meshstream

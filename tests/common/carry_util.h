// Helpers for the tests of carried glTF data (tests/importers/gltf_carry_test.cc,
// tests/cli/carry_cli_test.cc): a scene file with points, lines and a
// refinable triangle primitive in one mesh, and a summary of everything a
// Scene carries with accessor indices resolved to their bytes, so that two
// scenes can be compared whatever their accessor numbering.
#ifndef MESHSTREAM_TESTS_COMMON_CARRY_UTIL_H_
#define MESHSTREAM_TESTS_COMMON_CARRY_UTIL_H_

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "codec/mesh/mesh.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

inline nlohmann::json CarriedAccessorSummary(const Scene& scene, int32_t id) {
  if (id < 0 || static_cast<size_t>(id) >= scene.carried_accessors.size()) return nullptr;
  const CarriedAccessor& a = scene.carried_accessors[id];
  return {{"componentType", a.component_type}, {"type", a.type}, {"normalized", a.normalized},
          {"count", a.count}, {"name", a.name}, {"bytes", a.bytes}};
}

inline nlohmann::json CarriedAttributesSummary(const Scene& scene, const CarriedAttributes& attributes) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [name, id] : attributes) out[name] = CarriedAccessorSummary(scene, id);
  return out;
}

// Everything carried: primitives with their data, mesh and node weights,
// node skins, skins with their matrices, animations with their keyframes.
inline nlohmann::json CarriedSummary(const Scene& scene) {
  using nlohmann::json;
  json meshes = json::array();
  for (const Mesh& mesh : scene.meshes) {
    json prims = json::array();
    for (const CarriedPrimitive& p : mesh.carried) {
      json targets = json::array();
      for (const CarriedAttributes& t : p.targets) targets.push_back(CarriedAttributesSummary(scene, t));
      prims.push_back({{"slot", p.slot}, {"mode", p.mode}, {"material", p.material},
                       {"attributes", CarriedAttributesSummary(scene, p.attributes)},
                       {"indices", CarriedAccessorSummary(scene, p.indices)}, {"targets", targets}});
    }
    meshes.push_back({{"carried", prims}, {"weights", mesh.weights}, {"refined", mesh.primitives.size()}});
  }
  json nodes = json::array();
  for (const Node& n : scene.nodes) nodes.push_back({{"skin", n.skin}, {"weights", n.weights}, {"mesh", n.mesh}});
  json skins = json::array();
  for (const Skin& s : scene.skins) {
    skins.push_back({{"name", s.name}, {"joints", s.joints}, {"skeleton", s.skeleton},
                     {"inverseBindMatrices", CarriedAccessorSummary(scene, s.inverse_bind_matrices)}});
  }
  json animations = json::array();
  for (const Animation& a : scene.animations) {
    json samplers = json::array(), channels = json::array();
    for (const AnimationSampler& s : a.samplers) {
      samplers.push_back({{"input", CarriedAccessorSummary(scene, s.input)},
                          {"output", CarriedAccessorSummary(scene, s.output)}, {"interpolation", s.interpolation}});
    }
    for (const AnimationChannel& c : a.channels) channels.push_back({{"sampler", c.sampler}, {"node", c.node}, {"path", c.path}});
    animations.push_back({{"name", a.name}, {"samplers", samplers}, {"channels", channels}});
  }
  return {{"meshes", meshes}, {"nodes", nodes}, {"skins", skins}, {"animations", animations}};
}

// Appends `bytes` to `bin` (4-aligned) as a new bufferView of `doc`.
inline int AddTestView(nlohmann::json& doc, std::vector<uint8_t>& bin, const void* data, size_t size, int target) {
  while (bin.size() % 4) bin.push_back(0);
  nlohmann::json view = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", size}};
  if (target) view["target"] = target;
  const uint8_t* p = static_cast<const uint8_t*>(data);
  bin.insert(bin.end(), p, p + size);
  doc["bufferViews"].push_back(view);
  return static_cast<int>(doc["bufferViews"].size()) - 1;
}

inline int AddTestAccessor(nlohmann::json& doc, nlohmann::json accessor) {
  doc["accessors"].push_back(std::move(accessor));
  return static_cast<int>(doc["accessors"].size()) - 1;
}

inline int AddTestPositions(nlohmann::json& doc, std::vector<uint8_t>& bin, const std::vector<float>& xyz) {
  std::vector<float> lo(3, 1e30f), hi(3, -1e30f);
  for (size_t i = 0; i < xyz.size(); ++i) {
    lo[i % 3] = std::min(lo[i % 3], xyz[i]);
    hi[i % 3] = std::max(hi[i % 3], xyz[i]);
  }
  const int view = AddTestView(doc, bin, xyz.data(), xyz.size() * 4, 34962);
  return AddTestAccessor(doc, {{"bufferView", view}, {"componentType", 5126}, {"count", xyz.size() / 3},
                               {"type", "VEC3"}, {"min", lo}, {"max", hi}});
}

// Writes `dir`/points_lines.gltf (with points_lines.bin): one mesh whose
// primitives are, in this order, points with colours, a closed UV sphere of
// triangles (refinable), lines with byte indices, and a line strip sharing the
// lines' positions. Returns the .gltf path.
inline std::string WritePointsLinesScene(const std::string& dir) {
  using nlohmann::json;
  json doc = {{"asset", {{"version", "2.0"}}}, {"bufferViews", json::array()}, {"accessors", json::array()}};
  std::vector<uint8_t> bin;
  // Points: five positions and normalized byte colours.
  const int point_pos = AddTestPositions(doc, bin, {0, 0, 2, 1, 0, 2, 0, 1, 2, 1, 1, 2, 0.5f, 0.5f, 3});
  const std::vector<uint8_t> colors = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 10, 20, 30, 40, 255, 255, 255, 128};
  const int color_view = AddTestView(doc, bin, colors.data(), colors.size(), 34962);
  const int point_col = AddTestAccessor(doc, {{"bufferView", color_view}, {"componentType", 5121}, {"normalized", true},
                                              {"count", 5}, {"type", "VEC4"}});
  // A UV sphere: poles plus rings, closed and manifold.
  const int rings = 8, segments = 12;
  std::vector<float> sphere = {0, 0, 1};
  for (int r = 1; r < rings; ++r) {
    const double theta = M_PI * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double phi = 2 * M_PI * s / segments;
      sphere.insert(sphere.end(), {float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                                   float(std::cos(theta))});
    }
  }
  sphere.insert(sphere.end(), {0, 0, -1});
  const uint16_t south = static_cast<uint16_t>(1 + (rings - 1) * segments);
  auto ring = [&](int r, int s) { return static_cast<uint16_t>(1 + (r - 1) * segments + (s % segments)); };
  std::vector<uint16_t> tris;
  for (int s = 0; s < segments; ++s) {
    tris.insert(tris.end(), {0, ring(1, s), ring(1, s + 1)});
    tris.insert(tris.end(), {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
    for (int r = 1; r + 1 < rings; ++r) {
      tris.insert(tris.end(), {ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
      tris.insert(tris.end(), {ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
    }
  }
  const int sphere_pos = AddTestPositions(doc, bin, sphere);
  const int tri_view = AddTestView(doc, bin, tris.data(), tris.size() * 2, 34963);
  const int sphere_idx = AddTestAccessor(doc, {{"bufferView", tri_view}, {"componentType", 5123}, {"count", tris.size()},
                                               {"type", "SCALAR"}});
  // Lines: a square with byte indices; the strip reuses its positions.
  const int line_pos = AddTestPositions(doc, bin, {3, 0, 0, 4, 0, 0, 4, 1, 0, 3, 1, 0});
  const std::vector<uint8_t> lines = {0, 1, 1, 2, 2, 3, 3, 0};
  const int line_view = AddTestView(doc, bin, lines.data(), lines.size(), 34963);
  const int line_idx = AddTestAccessor(doc, {{"bufferView", line_view}, {"componentType", 5121}, {"count", 8},
                                             {"type", "SCALAR"}});
  doc["meshes"] = json::array({{{"name", "helpers"},
                                {"primitives",
                                 json::array({{{"mode", 0}, {"attributes", {{"POSITION", point_pos}, {"COLOR_0", point_col}}}},
                                              {{"attributes", {{"POSITION", sphere_pos}}}, {"indices", sphere_idx}},
                                              {{"mode", 1}, {"attributes", {{"POSITION", line_pos}}}, {"indices", line_idx}},
                                              {{"mode", 3}, {"attributes", {{"POSITION", line_pos}}}}})}}});
  doc["nodes"] = json::array({{{"mesh", 0}, {"name", "helpers"}}});
  doc["scenes"] = json::array({{{"nodes", {0}}}});
  doc["scene"] = 0;
  while (bin.size() % 4) bin.push_back(0);
  doc["buffers"] = json::array({{{"byteLength", bin.size()}, {"uri", "points_lines.bin"}}});
  const std::string path = dir + "/points_lines.gltf";
  WriteText(dir + "/points_lines.bin", std::string(bin.begin(), bin.end()));
  WriteText(path, doc.dump(2));
  return path;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_CARRY_UTIL_H_

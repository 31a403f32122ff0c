// The mesh model of meshstream: indexed triangle primitives, meshes of several
// primitives, a node hierarchy, and the parts of a glTF asset that meshstream
// carries through without interpreting them (materials, textures, samplers,
// cameras, images).
//
// Contract: plain value types, no I/O. A Primitive is valid when every
// attribute array is empty or has exactly `positions.size()` entries, the index
// count is a multiple of three and every index is below `positions.size()`
// (ValidatePrimitive checks this). Vertex attributes are per vertex, as in
// glTF; importers of formats with per-corner attributes (OBJ) split vertices
// where attributes differ and record the file's own position count in
// Scene::source_vertices.
// Thread safety: values; concurrent reads are safe.
#ifndef MESHSTREAM_CODEC_MESH_MESH_H_
#define MESHSTREAM_CODEC_MESH_MESH_H_

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "codec/core/vec.h"

namespace meshstream {


struct Primitive {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;                // empty or one per vertex
  std::vector<std::vector<Vec2f>> texcoords; // TEXCOORD_0, TEXCOORD_1, ...
  std::vector<Vec4f> colors;                 // COLOR_0 as linear RGBA, or empty
  std::vector<uint32_t> indices;             // three per triangle
  int32_t material = -1;                     // index into Scene's materials, -1: none

  size_t vertex_count() const { return positions.size(); }
  size_t face_count() const { return indices.size() / 3; }
  // glTF attribute names present, in a fixed order: POSITION, NORMAL,
  // TEXCOORD_n..., COLOR_0.
  std::vector<std::string> AttributeNames() const;
};

struct Mesh {
  std::string name;
  std::vector<Primitive> primitives;
};

struct Node {
  std::string name;
  int32_t mesh = -1;
  int32_t camera = -1;
  std::vector<int32_t> children;
  bool has_matrix = false;
  std::array<double, 16> matrix = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  Vec3d translation = {0, 0, 0};
  std::array<double, 4> rotation = {0, 0, 0, 1};  // quaternion x, y, z, w
  Vec3d scale = {1, 1, 1};
};

struct SceneRoot {
  std::string name;
  std::vector<int32_t> nodes;
};

// An image carried as bytes; meshstream never decodes images.
struct Image {
  std::string name;
  std::string mime_type;  // "image/png", "image/jpeg", ...
  std::vector<uint8_t> bytes;
};

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Node> nodes;
  std::vector<SceneRoot> scenes;
  int32_t default_scene = -1;

  // Carried through untouched: the glTF JSON arrays of these objects, as text
  // ("[]" when absent). Textures refer to `images` and samplers by index.
  std::string materials_json = "[]";
  std::string textures_json = "[]";
  std::string samplers_json = "[]";
  std::string cameras_json = "[]";
  std::vector<Image> images;
  // Extensions used by the carried-through JSON (e.g. KHR_materials_*).
  std::vector<std::string> extensions_used;

  // Positions the source file defines (for OBJ, before seams were split).
  uint64_t source_vertices = 0;
  // Things the importer changed or dropped, one line each, for the user.
  std::vector<std::string> warnings;

  size_t total_vertices() const;
  size_t total_faces() const;
  size_t total_primitives() const;
};

// Checks the invariants listed at the top of this file; the message names the
// offending array and index.
Status ValidatePrimitive(const Primitive& primitive);
Status ValidateScene(const Scene& scene);

// A scene with one mesh of one primitive, placed by one node.
Scene SceneFromPrimitive(Primitive primitive, std::string name);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_MESH_MESH_H_

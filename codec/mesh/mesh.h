// The mesh model of meshstream: indexed triangle primitives, meshes of several
// primitives, a node hierarchy, and the parts of a glTF asset that meshstream
// carries through without interpreting them (materials, textures, samplers,
// cameras, images; points and lines primitives, skinned or morphed primitives,
// skins and animations, whose data is held as raw accessors).
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
#include <utility>
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

// FNV-1a (codec/core/fnv.h) over a primitive's arrays: positions, normals,
// the number of texture coordinate sets and each set, colours, indices (each
// array as its length and its bytes). Equal decodes, equal hashes: what the
// tests and benchmarks compare (not the material).
uint64_t PrimitiveHash(const Primitive& p);

// The data of one glTF accessor, carried unchanged: its elements tightly
// packed (count * ElementBytes(), little-endian, sparse substitution already
// applied). Writers recompute min/max from the bytes.
struct CarriedAccessor {
  enum class Use : uint8_t { kOther, kVertex, kIndex };  // decides bufferView target and alignment
  int32_t component_type = 5126;  // glTF componentType code (5120..5126)
  std::string type = "SCALAR";    // glTF accessor type: SCALAR, VEC2..4, MAT2..4
  bool normalized = false;
  uint64_t count = 0;
  std::string name;
  Use use = Use::kOther;
  std::vector<uint8_t> bytes;

  // Bytes per component (0 for an unknown code), components per element (0
  // for an unknown type), bytes per element.
  size_t ComponentBytes() const;
  size_t Components() const;
  size_t ElementBytes() const { return ComponentBytes() * Components(); }
};

// A (name, carried accessor index) pair of a carried primitive or target.
using CarriedAttributes = std::vector<std::pair<std::string, int32_t>>;

// A primitive meshstream does not refine (points, lines, or triangles with
// skinning attributes or morph targets), carried with all its attributes.
// `slot` is its position among the mesh's primitives in the file: carried
// primitives are stored by ascending slot and Mesh::Order() interleaves them
// with the refined ones.
struct CarriedPrimitive {
  uint32_t slot = 0;
  int32_t mode = 4;                        // glTF primitive mode 0..6
  CarriedAttributes attributes;            // indices into Scene::carried_accessors
  int32_t indices = -1;                    // carried accessor, -1: none
  std::vector<CarriedAttributes> targets;  // morph targets
  int32_t material = -1;
  std::string extras_json;                 // its glTF "extras" as JSON text, empty when none
};

struct Mesh {
  std::string name;
  std::vector<Primitive> primitives;       // refined: triangle lists
  std::vector<CarriedPrimitive> carried;   // carried through, ascending slots
  std::vector<double> weights;             // default morph target weights
  std::string extras_json;                 // glTF "extras" (e.g. targetNames) as JSON text, empty when none

  struct Ref {
    bool carried;
    size_t index;  // into primitives or carried
  };
  // Every primitive in file order: carried ones at their slot (or after the
  // last refined one when the slot is beyond), refined ones filling the gaps.
  std::vector<Ref> Order() const;
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
  int32_t skin = -1;            // index into Scene::skins
  std::vector<double> weights;  // morph weights of its mesh's targets, or empty
  int32_t light = -1;           // KHR_lights_punctual: index into Scene::lights, -1: none
  std::string extras_json;      // glTF "extras" as JSON text, empty when none
};

struct Skin {
  std::string name;
  int32_t inverse_bind_matrices = -1;  // carried accessor (MAT4), -1: identity
  int32_t skeleton = -1;               // node, -1: none
  std::vector<int32_t> joints;         // nodes
  std::string extras_json;             // glTF "extras" as JSON text, empty when none
};

struct AnimationSampler {
  int32_t input = -1;   // carried accessor: keyframe times
  int32_t output = -1;  // carried accessor: values
  std::string interpolation = "LINEAR";
};

struct AnimationChannel {
  int32_t sampler = -1;
  int32_t node = -1;    // target node, -1: none (an extension would name it)
  std::string path;     // translation, rotation, scale, weights
};

struct Animation {
  std::string name;
  std::vector<AnimationSampler> samplers;
  std::vector<AnimationChannel> channels;
  std::string extras_json;  // glTF "extras" as JSON text, empty when none
};

struct SceneRoot {
  std::string name;
  std::vector<int32_t> nodes;
  std::string extras_json;  // glTF "extras" as JSON text, empty when none
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
  // KHR_lights_punctual: the root extension's lights, each as the JSON text
  // of its object; nodes name them by index (Node::light).
  std::vector<std::string> lights;
  std::vector<Image> images;
  // Carried through with their raw data; objects refer to them by index.
  std::vector<CarriedAccessor> carried_accessors;
  std::vector<Skin> skins;
  std::vector<Animation> animations;
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

// Checks the invariants listed at the top of this file, and for carried data:
// accessor byte sizes, every index (accessor, node, skin, sampler) in range,
// carried slots ascending. The message names the offending array and index.
Status ValidatePrimitive(const Primitive& primitive);
Status ValidateScene(const Scene& scene);

// A scene with one mesh of one primitive, placed by one node.
Scene SceneFromPrimitive(Primitive primitive, std::string name);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_MESH_MESH_H_

// Writing a Scene as glTF 2.0: .gltf (JSON plus one .bin beside it) or .glb,
// optionally with every primitive compressed by KHR_draco_mesh_compression.
//
// What the writer normalizes, so that the Khronos validator reports no error:
// normals are made unit length (a zero normal becomes +Z), colours are clamped
// to [0, 1] and written as RGBA floats, indices use the smallest unsigned type
// that cannot hit the restart value. With Draco, positions are quantized on
// the grid of the brief (see draco_codec.h), so `meshstream compare --qp N`
// of a `--qp N` export against its source says same_on_grid.
// Materials, textures, samplers, cameras and images are written back as they
// were imported; carried primitives, skins and animations too, their
// accessors re-packed one bufferView each with min/max recomputed
// (docs/spec/gltf-support.md, "Carried through"). Strings that are not valid
// UTF-8 are written with U+FFFD, never thrown on.
//
// Contract: refuses scenes that fail ValidateScene and meshes with no
// primitive left to write. Writes the output atomically (temporary file, then rename).
#ifndef MESHSTREAM_IMPORTERS_GLTF_EXPORT_H_
#define MESHSTREAM_IMPORTERS_GLTF_EXPORT_H_

#include <cstdint>
#include <string>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"
#include "importers/draco_codec.h"

namespace meshstream {

// A primitive whose Draco coding is already done (the base mesh of a
// progressive stream), plus an optional extension of ours on the primitive
// that points at a bufferView of extra bytes.
struct PrecodedPrimitive {
  std::vector<uint8_t> draco_bytes;
  DracoAttributeIds ids;
  Primitive decoded;                    // what the Draco bytes decode to
  std::string extension_name;           // empty: none
  std::vector<uint8_t> extension_bytes; // referenced as {"bufferView": n}
  // A second blob of the extension's, referenced as {"reliable": n} (the
  // reliable profile's stream when a file carries both; empty: none). The
  // binary chunk holds every such blob before every extension_bytes.
  std::vector<uint8_t> reliable_bytes;
  int extension_version = 1;
  // A JSON object (text) whose members are added to the extension's object
  // beside "bufferView" and "version"; empty: none.
  std::string extension_fields;
};

struct ExportOptions {
  bool draco = false;
  DracoEncodeOptions draco_options;
  // [mesh][primitive]: the codings written in the primitive's place, in
  // order (one, or the spatial parts it was cut into: codec/mesh/
  // spatial_parts.h), each a primitive of its own with the primitive's
  // material; an empty list (or a short table) means: encode as usual.
  // Precoded primitives make the asset require KHR_draco_mesh_compression;
  // their own extension is listed in extensionsUsed only. Of a precoded
  // primitive only the material is read (its arrays may be empty).
  std::vector<std::vector<std::vector<const PrecodedPrimitive*>>> precoded;
};

// By the extension of `path`: .glb or .gltf (the buffer goes to <stem>.bin).
Status ExportGltfFile(const Scene& scene, const std::string& path, const ExportOptions& options);

// The whole .glb in memory.
StatusOr<std::vector<uint8_t>> ExportGlb(const Scene& scene, const ExportOptions& options);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_GLTF_EXPORT_H_

// glTF 2.0 (.gltf with external or data: buffers and images, .glb) into a Scene.
//
// Refined: triangle lists, strips and fans (strips and fans become lists);
// KHR_draco_mesh_compression (decoded with the Draco library) and
// KHR_mesh_quantization; sparse accessors. Carried through unchanged:
// materials, textures, samplers, cameras and images; points and lines
// primitives and triangles with skinning attributes or morph targets (as raw
// accessors, Scene::carried_accessors); skins; animations; morph weights.
// Refused with an error naming the feature: extensions in extensionsRequired
// that we do not know, Draco-compressed skinned or morphed primitives.
// Dropped with a warning in Scene::warnings: attributes other than POSITION,
// NORMAL, TEXCOORD_n and COLOR_0 (TANGENT, _CUSTOM, ...) of refined
// primitives and optional extensions we do not know. JSON text that is not
// valid UTF-8 is repaired (ToValidUtf8) with a warning. docs/spec/gltf-support.md
// explains why.
//
// Contract: safe on untrusted input (see import.h). URIs may only name files
// inside the asset's own folder: no scheme but data:, no absolute path, no "..".
#ifndef MESHSTREAM_IMPORTERS_GLTF_IMPORT_H_
#define MESHSTREAM_IMPORTERS_GLTF_IMPORT_H_

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"
#include "importers/import.h"

namespace meshstream {

StatusOr<Scene> ImportGltfFile(const std::string& path, const ImportOptions& options);

// `bytes` is a .glb when it starts with the GLB magic, else glTF JSON.
// External URIs are resolved inside `base_dir`; an empty `base_dir` refuses
// every external URI (only data: URIs and the GLB binary chunk are used).
// `name` is used in error messages.
StatusOr<Scene> ImportGltfBytes(const std::vector<uint8_t>& bytes, const std::string& base_dir,
                                const std::string& name, const ImportOptions& options);

// The same, also handing back the checked glTF JSON, for readers of our own
// extensions (the progressive container), so that nobody parses it twice.
StatusOr<Scene> ImportGltfBytes(const std::vector<uint8_t>& bytes, const std::string& base_dir,
                                const std::string& name, const ImportOptions& options,
                                nlohmann::json* document);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_GLTF_IMPORT_H_

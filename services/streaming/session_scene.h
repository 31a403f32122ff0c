// The scene a session's client builds on (SessionStart.scene_glb,
// docs/spec/streaming-protocol.md "Sessions"): the asset's glTF at level 0, as a
// plain .glb: nodes, materials, textures, skins, animations, the carried
// primitives, and every refined primitive as a one-triangle stand-in
// (its first three base vertices with their attributes, so the primitive
// keeps its material and attribute set) at the same mesh and primitive
// index. The base meshes themselves travel once, Draco-coded, in the
// PrimitiveStarts; the client puts what it decodes in the stand-ins, so
// that an export of the session is the asset's scene.
//
// Made by decoding the stored progressive .glb at lod 0 (no refinement is
// touched) and exporting it; the cache of hot artifacts (hot_artifacts.h)
// keeps it with its artifact, since every session of a version needs the
// same bytes.
//
// Thread safety: pure.
#ifndef MESHSTREAM_SERVICES_STREAMING_SESSION_SCENE_H_
#define MESHSTREAM_SERVICES_STREAMING_SESSION_SCENE_H_

#include <cstdint>
#include <utility>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

// `refined`: the (glTF mesh, primitive index) of every refined primitive.
StatusOr<std::vector<uint8_t>> MakeSessionScene(const std::vector<uint8_t>& artifact,
                                                const std::vector<std::pair<uint32_t, uint32_t>>& refined);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_SESSION_SCENE_H_

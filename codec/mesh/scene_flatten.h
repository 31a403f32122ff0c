// Flattening a scene into one triangle primitive in world space: every
// primitive reached from the default scene (or, without scenes, every mesh
// once with no transform) is transformed by its node's world matrix and
// appended. Used to compare and measure whole assets.
//
// Contract: pure; O(total vertices + nodes). Node hierarchies must be forests
// (the importers check this); cycles are not followed. Normals are
// transformed by the inverse-transpose and renormalized; UVs, colours and
// materials are dropped (the result carries geometry only).
#ifndef MESHSTREAM_CODEC_MESH_SCENE_FLATTEN_H_
#define MESHSTREAM_CODEC_MESH_SCENE_FLATTEN_H_

#include <array>

#include "codec/mesh/mesh.h"

namespace meshstream {

using Mat4d = std::array<double, 16>;  // column-major, as glTF

Mat4d NodeLocalMatrix(const Node& node);
Mat4d Multiply(const Mat4d& a, const Mat4d& b);

Primitive FlattenScene(const Scene& scene);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_MESH_SCENE_FLATTEN_H_

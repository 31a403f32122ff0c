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
#include <functional>
#include <vector>

#include "codec/mesh/mesh.h"

namespace meshstream {

using Mat4d = std::array<double, 16>;  // column-major, as glTF

Mat4d NodeLocalMatrix(const Node& node);
Mat4d Multiply(const Mat4d& a, const Mat4d& b);

// Calls `visit` for every mesh instance reached from the default scene (the
// first scene without a default; every mesh once, with the identity, when
// there is no scene), with its node's world matrix; `identity`: that matrix
// is the identity.
void ForEachMeshInstance(const Scene& scene,
                         const std::function<void(int32_t mesh, const Mat4d& world, bool identity)>& visit);

Primitive FlattenScene(const Scene& scene);

// Per mesh, the largest scale any of its instances gets from its node's
// world matrix (the largest norm of the matrix's first three columns); 0 for
// a mesh no node of the scene shows.
std::vector<double> MeshScales(const Scene& scene);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_MESH_SCENE_FLATTEN_H_

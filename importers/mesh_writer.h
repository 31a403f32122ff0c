// Writing a scene as OBJ or PLY (binary little-endian): the whole scene
// flattened into world space, positions, normals and the first UV set.
// Materials and hierarchy are not kept (use .gltf/.glb for that).
#ifndef MESHSTREAM_IMPORTERS_MESH_WRITER_H_
#define MESHSTREAM_IMPORTERS_MESH_WRITER_H_

#include <string>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"

namespace meshstream {

// By extension: .obj or .ply. Written atomically.
Status WriteMeshFile(const Scene& scene, const std::string& path);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_MESH_WRITER_H_

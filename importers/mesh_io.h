// OBJ, PLY (ascii and binary), OFF and STL through OpenMesh's readers and
// tinyobjloader, into a one-primitive Scene.
//
// Contract: safe on untrusted input. Header counts are checked against the
// file's size before the file is handed to a library (a PLY header claiming
// 4e8 vertices in 300 bytes is refused, not allocated), and every exception a
// library throws is caught here. Faces with more than three corners are
// fanned into triangles; per-corner attributes (OBJ's vt/vn indices) are
// unified by splitting vertices, and Scene::source_vertices keeps the file's
// own position count.
#ifndef MESHSTREAM_IMPORTERS_MESH_IO_H_
#define MESHSTREAM_IMPORTERS_MESH_IO_H_

#include <string>

#include "codec/mesh.h"
#include "codec/status.h"
#include "importers/import.h"

namespace meshstream {

StatusOr<Scene> ImportMeshFile(const std::string& path, const ImportOptions& options);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_MESH_IO_H_

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
// PLY triangle strips (a last element 'tristrips' with a 'vertex_indices'
// list, -1 restarting a strip) are read by this file, not OpenMesh, and
// become triangles as in glTF's TRIANGLE_STRIP, after the PLY's faces.
// A file with vertices but no faces is refused ("no triangles", InvalidInput).
// Kept: every vertex (unreferenced ones too) in file order; faces in file
// order. Normals are scaled to unit length (with a warning); colours are
// converted from sRGB to linear; texture coordinates are kept as in the file
// (no V flip). STL corners with equal positions are merged by OpenMesh, and
// triangles that become degenerate are dropped with a warning.
// Errors name the file, and the face (0-based) when a face is at fault.
// OBJ is read by tinyobjloader (no material file is ever opened); PLY, OFF and
// STL by OpenMesh's readers into our own BaseImporter, under one mutex because
// OpenMesh's readers are shared singletons.
#ifndef MESHSTREAM_IMPORTERS_MESH_IO_H_
#define MESHSTREAM_IMPORTERS_MESH_IO_H_

#include <string>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"
#include "importers/import.h"

namespace meshstream {

StatusOr<Scene> ImportMeshFile(const std::string& path, const ImportOptions& options);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_MESH_IO_H_

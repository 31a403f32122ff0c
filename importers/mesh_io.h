// OBJ, PLY (ascii and binary), OFF and STL files into a one-primitive Scene:
// the mesh-file half of ImportFile (import.h).
//
// ImportMeshFile reads the file (refusing files above
// ImportOptions::max_input_bytes before reading, and empty files), hands its
// bytes to the format's importer by extension, case-insensitive
// (obj_import.h, ply_import.h, off_import.h, stl_import.h: each states what
// it keeps and refuses), then assembles the scene: one mesh of one primitive
// on one node, named after the file's stem made valid UTF-8 (a warning says
// when bytes were replaced), normals scaled to unit length (one warning says
// how many were not), Scene::source_vertices the file's own position count
// (for OBJ, before seams were split) and the importers' warnings, all valid
// UTF-8. A file with vertices but no faces is refused ("no triangles",
// InvalidInput).
//
// Contract: errors start with the file's path and name the line, record or
// face (0-based) at fault. Safe on untrusted input: header counts are checked
// against the bytes present before a library sees the file (a PLY header
// claiming 4e8 vertices in 300 bytes is refused, not allocated), and no
// exception escapes (OpenMesh, tinyobjloader and allocation failures become
// a Status; bad_alloc is ResourceExhausted).
// Thread safety: OpenMesh's readers (PLY, OFF, STL) run under one process-wide
// mutex (openmesh_reader.h); OBJ imports run fully in parallel.
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

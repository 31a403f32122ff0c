// PLY (ascii, binary little- and big-endian) into a Primitive.
//
// Our own header check (ply_header.h) and a walk over the body prove that
// every declared count and list length fits in the bytes present and that
// every number OpenMesh will parse with `>>` is a finite decimal in float
// range; then OpenMesh's PLY reader reads a canonical copy of the header
// followed by the file's own body bytes (two_part_streambuf.h) into a
// MeshRecorder (openmesh_reader.h).
//
// Contract: kept are every vertex in file order (unreferenced ones too),
// faces in file order fanned into triangles, vertex normals, colours (sRGB
// to linear) and texture coordinates. Triangle strips (a last element
// 'tristrips' with one integer list 'vertex_indices', -1 restarting a strip)
// are read here, not by OpenMesh, and become triangles as glTF's
// TRIANGLE_STRIP does, after the faces; triangles repeating a vertex are
// skipped. Stray header lines are ignored with a warning (ply_header.h).
// PLY comments and obj_info lines are not kept.
// Errors (InvalidInput; Unsupported for layouts OpenMesh cannot read) start
// with `path` and name the header line, or the record ("face 3 of 10") and
// the body line for ascii.
// Safe on untrusted input: nothing is allocated per declared record before
// the body walk proved the records are present (a header claiming 4e8
// vertices in 300 bytes is refused); every exception of OpenMesh is caught.
// Thread safety: the OpenMesh read runs under the OpenMesh lock.
#ifndef MESHSTREAM_IMPORTERS_PLY_IMPORT_H_
#define MESHSTREAM_IMPORTERS_PLY_IMPORT_H_

#include <string>
#include <string_view>
#include <vector>

#include "codec/core/status.h"
#include "codec/mesh/mesh.h"

namespace meshstream {
namespace mesh_io {

// `data` is the whole file; warnings are appended to `warnings`.
StatusOr<Primitive> ImportPly(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings);

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_PLY_IMPORT_H_

// OFF (ascii; OFF, COFF, NOFF and CNOFF) into a Primitive.
//
// CheckOff mirrors OpenMesh's ascii OFF reader token by token and proves the
// file is what that reader reads correctly; then OpenMesh reads it by file
// name (its reader takes the NOFF/COFF variant only from can_u_read(path))
// into a MeshRecorder (openmesh_reader.h).
//
// Contract: kept are every vertex in file order, faces in file order fanned
// into triangles, vertex normals (NOFF) and vertex colours (COFF, sRGB to
// linear). Unsupported: binary OFF, comments after the first line, STOFF,
// 4OFF, nOFF. Errors start with `path` and name the line and the vertex or
// face (0-based).
// Safe on untrusted input: the counts are checked against the file's size
// before anything is allocated, and MeshRecorder refuses more vertices,
// faces or corners than were validated, so a file replaced between the
// check and the read cannot grow our arrays. Every exception is caught.
// Thread safety: the OpenMesh read runs under the OpenMesh lock.
#ifndef MESHSTREAM_IMPORTERS_OFF_IMPORT_H_
#define MESHSTREAM_IMPORTERS_OFF_IMPORT_H_

#include <string>
#include <string_view>
#include <vector>

#include "codec/core/status.h"
#include "codec/mesh/mesh.h"

namespace meshstream {
namespace mesh_io {

// `data` is the whole file, as read from `path` (which OpenMesh reads again).
StatusOr<Primitive> ImportOff(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings);

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_OFF_IMPORT_H_

// STL (ascii and binary) into a Primitive.
//
// CheckStl decides binary or ascii as OpenMesh does (binary when the size is
// exactly 84 + 50 n for the declared n), proves every coordinate is a finite
// number, and counts the facets; then OpenMesh's STL reader reads the bytes
// (two_part_streambuf.h) into a MeshRecorder (openmesh_reader.h).
//
// Contract: OpenMesh merges corners with equal positions into one vertex and
// drops the triangles that become degenerate by it; the count of dropped
// triangles is a warning. Facet normals and the binary attribute bytes are
// not kept. Errors start with `path` and name the facet (0-based) and, for
// ascii, the line.
// Safe on untrusted input: the triangle count is proven by the file's size
// (binary) or by counting facets (ascii) before OpenMesh reads; the recorder
// refuses more. Every exception is caught.
// Thread safety: the OpenMesh read runs under the OpenMesh lock.
#ifndef MESHSTREAM_IMPORTERS_STL_IMPORT_H_
#define MESHSTREAM_IMPORTERS_STL_IMPORT_H_

#include <string>
#include <string_view>
#include <vector>

#include "codec/core/status.h"
#include "codec/mesh/mesh.h"

namespace meshstream {
namespace mesh_io {

// `data` is the whole file; warnings are appended to `warnings`.
StatusOr<Primitive> ImportStl(const std::string& path, std::string_view data,
                              std::vector<std::string>* warnings);

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_STL_IMPORT_H_

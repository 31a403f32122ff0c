// OBJ into a Primitive, read by tinyobjloader behind our own prescan.
//
// Contract: kept are every position in file order (unreferenced ones too),
// faces in file order fanned into triangles (c0, ci, ci+1), texture
// coordinates, normals and vertex colours (sRGB to linear; only when every
// vertex has one). Per-corner attributes are unified per vertex by
// splitting: vertex i < *source_vertices is the file's position i with the
// attributes of its first corner; other (position, uv, normal) combinations
// are appended in order of first use. Negative (relative) indices are
// resolved by tinyobjloader. Object, group and material names (o, g,
// usemtl) are not kept and no material file is ever opened (mtllib is
// ignored); tinyobjloader's warnings that still matter are kept, made valid
// UTF-8. Refused: non-finite or out-of-float-range numbers, tag lines ('t',
// Unsupported), indices out of range (the message names the face and corner,
// 0-based), faces with more than 255 corners (Unsupported).
// Errors start with `path`.
// Safe on untrusted input: the prescan refuses what tinyobjloader does not
// guard (it reads "nan" as 0; each 't' line allocates ~300 KiB whatever its
// length); every exception of tinyobjloader is caught (bad_alloc becomes
// ResourceExhausted).
// Thread safety: no shared state; OBJ imports run fully in parallel.
#ifndef MESHSTREAM_IMPORTERS_OBJ_IMPORT_H_
#define MESHSTREAM_IMPORTERS_OBJ_IMPORT_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "codec/core/status.h"
#include "codec/mesh/mesh.h"

namespace meshstream {
namespace mesh_io {

// `data` is the whole file; *source_vertices receives the file's position
// count (before seams were split); warnings are appended to `warnings`.
StatusOr<Primitive> ImportObj(const std::string& path, std::string_view data, uint64_t* source_vertices,
                              std::vector<std::string>* warnings);

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_OBJ_IMPORT_H_

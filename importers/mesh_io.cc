// OBJ, PLY, OFF and STL into a one-primitive Scene (see importers/mesh_io.h):
// reads the file, hands its bytes to the format's importer (obj_import.h,
// ply_import.h, off_import.h, stl_import.h) and assembles the scene.
#include "importers/mesh_io.h"

#include <cmath>
#include <cstdint>
#include <exception>
#include <new>
#include <string_view>
#include <utility>
#include <vector>

#include "codec/core/utf8.h"
#include "importers/obj_import.h"
#include "importers/off_import.h"
#include "importers/ply_import.h"
#include "importers/stl_import.h"
#include "importers/text_scan.h"
#include "importers/exception_boundary.h"
#include "importers/import.h"

namespace meshstream {
namespace {

using mesh_io::Bad;
using mesh_io::Num;

// glTF normals are unit vectors; files (horse.ply) may store them scaled.
void NormalizeNormals(Primitive* prim, std::vector<std::string>* warnings) {
  uint64_t scaled = 0, zero = 0;
  for (Vec3f& n : prim->normals) {
    const double length = std::sqrt(static_cast<double>(n[0]) * n[0] + static_cast<double>(n[1]) * n[1] +
                                     static_cast<double>(n[2]) * n[2]);
    if (!(length > 0)) {
      ++zero;  // zero (or NaN, which ValidateScene refuses)
      continue;
    }
    if (std::fabs(length - 1.0) <= 1e-6) continue;
    for (float& c : n) c = static_cast<float>(c / length);
    ++scaled;
  }
  if (scaled > 0) warnings->push_back("normalized " + Num(scaled) + " normals that were not unit length");
  if (zero > 0) warnings->push_back(Num(zero) + " normals have zero length");
}

// The file's stem as the mesh and node name, made valid UTF-8 (names reach
// JSON writers); a replacement is reported in `warnings`.
std::string NameFromPath(const std::string& path, std::vector<std::string>* warnings) {
  bool replaced = false;
  std::string name = ToValidUtf8(FileStem(path), &replaced);
  if (replaced) {
    warnings->push_back("the file name is not valid UTF-8; the mesh is named '" + name +
                        "' (each invalid byte sequence replaced by U+FFFD)");
  }
  return name;
}

// The format's importer for `ext` (one of .obj .ply .off .stl).
StatusOr<Primitive> ImportByFormat(const std::string& path, const std::string& ext, std::string_view data,
                                   uint64_t* source_vertices, bool* have_source_vertices,
                                   std::vector<std::string>* warnings) {
  if (ext == ".obj") {
    *have_source_vertices = true;
    return mesh_io::ImportObj(path, data, source_vertices, warnings);
  }
  if (ext == ".ply") return mesh_io::ImportPly(path, data, warnings);
  if (ext == ".off") return mesh_io::ImportOff(path, data, warnings);
  return mesh_io::ImportStl(path, data, warnings);
}

}  // namespace

StatusOr<Scene> ImportMeshFile(const std::string& path, const ImportOptions& options) {
  const std::string ext = FileExtension(path);
  if (ext != ".obj" && ext != ".ply" && ext != ".off" && ext != ".stl") {
    return Unsupported(path + ": not an OBJ, PLY, OFF or STL file (extension '" + ext + "')");
  }
  // The importer boundary: everything below may allocate (the file itself up
  // to max_input_bytes) or call a library that throws; bad_alloc and every
  // other exception become a Status naming the file.
  return CatchExceptions(path, [&]() -> StatusOr<Scene> {
    MS_ASSIGN_OR_RETURN(std::vector<uint8_t> bytes, ReadFileBytes(path, options.max_input_bytes));
    if (bytes.empty()) return Bad(path, "empty file");
    const std::string_view data(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    std::vector<std::string> warnings;
    uint64_t source_vertices = 0;
    bool have_source_vertices = false;
    MS_ASSIGN_OR_RETURN(Primitive prim,
                        ImportByFormat(path, ext, data, &source_vertices, &have_source_vertices, &warnings));
    if (prim.indices.empty()) {
      return Bad(path, "no triangles: the file has " + Num(prim.positions.size()) + " vertices but no faces");
    }
    if (!have_source_vertices) source_vertices = prim.positions.size();
    NormalizeNormals(&prim, &warnings);
    const std::string name = NameFromPath(path, &warnings);
    Scene scene = SceneFromPrimitive(std::move(prim), name);
    scene.source_vertices = source_vertices;
    scene.warnings = std::move(warnings);
    const Status valid = ValidateScene(scene);
    if (!valid.ok()) return valid.WithContext(path);
    return scene;
  });
}

}  // namespace meshstream

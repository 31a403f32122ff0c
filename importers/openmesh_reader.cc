// OpenMesh glue for the PLY, OFF and STL importers (see openmesh_reader.h).
#include "importers/openmesh_reader.h"

#include <utility>

namespace meshstream {
namespace mesh_io {

std::mutex& OpenMeshMutex() {
  static std::mutex mutex;
  return mutex;
}

StatusOr<Primitive> PrimitiveFromRecorder(const std::string& path, MeshRecorder& rec,
                                          std::vector<std::string>* warnings) {
  Primitive prim;
  const size_t n = rec.positions.size();
  prim.positions = std::move(rec.positions);
  uint64_t triangles = 0;
  for (size_t f = 0; f < rec.face_starts.size(); ++f) {
    const size_t k = rec.face_corner_count(f);
    if (k < 3) {
      return Bad(path, "face " + Num(f) + " has " + Num(k) + " corners (a face needs at least 3)");
    }
    triangles += k - 2;
  }
  prim.indices.reserve(static_cast<size_t>(triangles * 3));
  for (size_t f = 0; f < rec.face_starts.size(); ++f) {
    const size_t begin = rec.face_starts[f];
    const size_t k = rec.face_corner_count(f);
    for (size_t c = 0; c < k; ++c) {
      const int index = rec.corners[begin + c];
      if (index < 0 || static_cast<size_t>(index) >= n) {
        // OpenMesh hands indices over as int; above 2^31 they arrive negative.
        const uint64_t shown = static_cast<uint32_t>(index);
        return Bad(path, "face " + Num(f) + ": corner " + Num(c) + " names vertex " + Num(shown) +
                             ", out of range (the file has " + Num(n) + " vertices)");
      }
    }
    const uint32_t c0 = static_cast<uint32_t>(rec.corners[begin]);
    for (size_t c = 1; c + 1 < k; ++c) {
      prim.indices.push_back(c0);
      prim.indices.push_back(static_cast<uint32_t>(rec.corners[begin + c]));
      prim.indices.push_back(static_cast<uint32_t>(rec.corners[begin + c + 1]));
    }
  }
  auto take = [&](auto& attribute, const char* name, auto* out) {
    if (attribute.count == 0) return;
    if (attribute.count != n) {
      warnings->push_back(std::string("dropped ") + name + ": only " + Num(attribute.count) + " of " +
                          Num(n) + " vertices have one");
      return;
    }
    attribute.values.resize(n);
    *out = std::move(attribute.values);
  };
  take(rec.normals, "normals", &prim.normals);
  take(rec.colors, "colours", &prim.colors);
  std::vector<Vec2f> uv;
  take(rec.texcoords, "texture coordinates", &uv);
  if (!uv.empty()) prim.texcoords.push_back(std::move(uv));
  return prim;
}

}  // namespace mesh_io
}  // namespace meshstream

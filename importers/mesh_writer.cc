#include "importers/mesh_writer.h"

#include <cstdio>
#include <cstring>

#include "codec/mesh/scene_flatten.h"
#include "importers/import.h"
#include "importers/exception_boundary.h"

namespace meshstream {

namespace {

// Flattening keeps positions and normals; the first UV set is kept when the
// scene has a single primitive (UVs do not change under node transforms).
Primitive Flatten(const Scene& scene) {
  Primitive flat = FlattenScene(scene);
  if (scene.total_primitives() == 1) {
    const Primitive* only = nullptr;
    for (const Mesh& m : scene.meshes)
      for (const Primitive& p : m.primitives) only = &p;
    if (!only->texcoords.empty() && only->vertex_count() == flat.vertex_count()) {
      flat.texcoords.push_back(only->texcoords[0]);
    }
  }
  return flat;
}

std::vector<uint8_t> Obj(const Primitive& p) {
  std::string out = "# written by meshstream\n";
  char line[160];
  for (const Vec3f& v : p.positions) {
    std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", v[0], v[1], v[2]);
    out += line;
  }
  const bool uv = !p.texcoords.empty();
  const bool n = !p.normals.empty();
  if (uv) for (const Vec2f& t : p.texcoords[0]) { std::snprintf(line, sizeof line, "vt %.9g %.9g\n", t[0], t[1]); out += line; }
  if (n) for (const Vec3f& v : p.normals) { std::snprintf(line, sizeof line, "vn %.9g %.9g %.9g\n", v[0], v[1], v[2]); out += line; }
  for (size_t f = 0; f < p.face_count(); ++f) {
    out += "f";
    for (int k = 0; k < 3; ++k) {
      const unsigned i = p.indices[3 * f + k] + 1;
      if (uv && n) std::snprintf(line, sizeof line, " %u/%u/%u", i, i, i);
      else if (uv) std::snprintf(line, sizeof line, " %u/%u", i, i);
      else if (n) std::snprintf(line, sizeof line, " %u//%u", i, i);
      else std::snprintf(line, sizeof line, " %u", i);
      out += line;
    }
    out += "\n";
  }
  return std::vector<uint8_t>(out.begin(), out.end());
}

std::vector<uint8_t> Ply(const Primitive& p) {
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by meshstream\n";
  header += "element vertex " + std::to_string(p.vertex_count()) + "\nproperty float x\nproperty float y\nproperty float z\n";
  const bool n = !p.normals.empty();
  const bool uv = !p.texcoords.empty();
  if (n) header += "property float nx\nproperty float ny\nproperty float nz\n";
  if (uv) header += "property float s\nproperty float t\n";
  header += "element face " + std::to_string(p.face_count()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  std::vector<uint8_t> out(header.begin(), header.end());
  auto put = [&out](const void* data, size_t size) {
    const uint8_t* b = static_cast<const uint8_t*>(data);
    out.insert(out.end(), b, b + size);
  };
  for (size_t v = 0; v < p.vertex_count(); ++v) {
    put(p.positions[v].data(), 12);
    if (n) put(p.normals[v].data(), 12);
    if (uv) put(p.texcoords[0][v].data(), 8);
  }
  for (size_t f = 0; f < p.face_count(); ++f) {
    const uint8_t three = 3;
    put(&three, 1);
    for (int k = 0; k < 3; ++k) {
      const int32_t i = static_cast<int32_t>(p.indices[3 * f + k]);
      put(&i, 4);
    }
  }
  return out;
}

}  // namespace

namespace {

Status WriteMeshFileUnguarded(const Scene& scene, const std::string& path) {
  const std::string ext = FileExtension(path);
  if (ext != ".obj" && ext != ".ply") return InvalidArgument(path + ": output must end in .obj or .ply");
  const Primitive flat = Flatten(scene);
  return WriteFileBytes(path, ext == ".obj" ? Obj(flat) : Ply(flat));
}

}  // namespace

Status WriteMeshFile(const Scene& scene, const std::string& path) {
  return CatchExceptions(path, [&] { return WriteMeshFileUnguarded(scene, path); });
}

}  // namespace meshstream

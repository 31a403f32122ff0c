// The glue between OpenMesh's PLY, OFF and STL readers and our Primitive.
//
// MeshRecorder is our own OpenMesh::IO::BaseImporter: it only appends what a
// reader delivers to plain arrays (no half-edge structure, so non-manifold
// faces stay and vertices are never duplicated or dropped) and refuses,
// by throwing RecorderLimit, more vertices, faces or corners than our own
// check of the file validated. RunOpenMeshReader runs one read under the
// process-wide OpenMesh lock with OpenMesh's log streams silenced and turns
// every exception (RecorderLimit, bad_alloc, anything else) into a Status
// naming the file. PrimitiveFromRecorder fans the recorded faces into
// triangles, checking every index.
//
// Contract: errors start with the file's path; faces are named 0-based in
// file order. Attributes set on only some vertices are dropped with a
// warning. Colours delivered by OpenMesh are converted from sRGB to linear.
// Safe on untrusted input: the recorder never allocates beyond the limits
// it was given (reserve() is clamped too), and no exception leaves
// RunOpenMeshReader.
// Thread safety: OpenMesh's readers are shared singletons with mutable state
// and its log streams are global, so every read runs under one mutex
// (OpenMeshMutex); a MeshRecorder belongs to one read.
#ifndef MESHSTREAM_IMPORTERS_OPENMESH_READER_H_
#define MESHSTREAM_IMPORTERS_OPENMESH_READER_H_

#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cstdint>
#include <exception>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "codec/mesh/mesh.h"
#include "importers/srgb.h"
#include "importers/text_scan.h"
#include "importers/exception_boundary.h"

namespace meshstream {
namespace mesh_io {

// Thrown by MeshRecorder to stop a library that delivers more than was
// validated; caught at the importer boundary.
struct RecorderLimit {
  std::string message;
};

// Records what an OpenMesh reader delivers into plain arrays. Never builds
// connectivity, so it keeps every vertex and every face exactly as read.
class MeshRecorder final : public OpenMesh::IO::BaseImporter {
 public:
  using VertexHandle = OpenMesh::VertexHandle;
  using HalfedgeHandle = OpenMesh::HalfedgeHandle;
  using EdgeHandle = OpenMesh::EdgeHandle;
  using FaceHandle = OpenMesh::FaceHandle;

  MeshRecorder(uint64_t max_vertices, uint64_t max_faces, uint64_t max_corners)
      : max_vertices_(max_vertices), max_faces_(max_faces), max_corners_(max_corners) {}

  template <typename T>
  struct Attribute {
    std::vector<T> values;
    std::vector<uint8_t> set;
    size_t count = 0;
    void Set(size_t vertex, const T& value, size_t vertex_count) {
      if (vertex >= vertex_count) return;
      if (values.size() < vertex_count) {
        values.resize(vertex_count);
        set.resize(vertex_count, 0);
      }
      values[vertex] = value;
      if (!set[vertex]) {
        set[vertex] = 1;
        ++count;
      }
    }
  };

  std::vector<Vec3f> positions;
  Attribute<Vec3f> normals;
  Attribute<Vec4f> colors;  // linear RGBA
  Attribute<Vec2f> texcoords;
  std::vector<size_t> face_starts;  // into corners; face i is [starts[i], starts[i+1])
  std::vector<int> corners;

  size_t face_corner_count(size_t f) const {
    const size_t end = f + 1 < face_starts.size() ? face_starts[f + 1] : corners.size();
    return end - face_starts[f];
  }

  // --- vertices
  VertexHandle add_vertex(const OpenMesh::Vec3f& p) override {
    if (positions.size() >= max_vertices_) {
      throw RecorderLimit{"the reader delivered more than the " + Num(max_vertices_) +
                          " vertices that were validated"};
    }
    positions.push_back({p[0], p[1], p[2]});
    return VertexHandle(static_cast<int>(positions.size() - 1));
  }
  VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
    return add_vertex(OpenMesh::Vec3f(static_cast<float>(p[0]), static_cast<float>(p[1]),
                                      static_cast<float>(p[2])));
  }
  VertexHandle add_vertex() override { return add_vertex(OpenMesh::Vec3f(0.f, 0.f, 0.f)); }
  void set_point(VertexHandle vh, const OpenMesh::Vec3f& p) override {
    if (Valid(vh)) positions[static_cast<size_t>(vh.idx())] = {p[0], p[1], p[2]};
  }
  void set_normal(VertexHandle vh, const OpenMesh::Vec3f& n) override {
    if (Valid(vh)) normals.Set(static_cast<size_t>(vh.idx()), {n[0], n[1], n[2]}, positions.size());
  }
  void set_normal(VertexHandle vh, const OpenMesh::Vec3d& n) override {
    set_normal(vh, OpenMesh::Vec3f(static_cast<float>(n[0]), static_cast<float>(n[1]),
                                   static_cast<float>(n[2])));
  }
  void set_color(VertexHandle vh, const OpenMesh::Vec3uc& c) override {
    SetColor(vh, c[0] / 255.f, c[1] / 255.f, c[2] / 255.f, 1.f);
  }
  void set_color(VertexHandle vh, const OpenMesh::Vec4uc& c) override {
    SetColor(vh, c[0] / 255.f, c[1] / 255.f, c[2] / 255.f, c[3] / 255.f);
  }
  void set_color(VertexHandle vh, const OpenMesh::Vec3f& c) override { SetColor(vh, c[0], c[1], c[2], 1.f); }
  void set_color(VertexHandle vh, const OpenMesh::Vec4f& c) override {
    SetColor(vh, c[0], c[1], c[2], c[3]);
  }
  void set_texcoord(VertexHandle vh, const OpenMesh::Vec2f& t) override {
    if (Valid(vh)) texcoords.Set(static_cast<size_t>(vh.idx()), {t[0], t[1]}, positions.size());
  }
  void set_texcoord(VertexHandle vh, const OpenMesh::Vec3f& t) override {
    set_texcoord(vh, OpenMesh::Vec2f(t[0], t[1]));
  }

  // --- faces
  FaceHandle add_face(const VHandles& handles) override {
    if (face_starts.size() >= max_faces_) {
      throw RecorderLimit{"the reader delivered more than the " + Num(max_faces_) +
                          " faces that were validated"};
    }
    if (corners.size() + handles.size() > max_corners_) {
      throw RecorderLimit{"the reader delivered more than the " + Num(max_corners_) +
                          " face corners that were validated"};
    }
    face_starts.push_back(corners.size());
    for (const VertexHandle& h : handles) corners.push_back(h.idx());
    return FaceHandle(static_cast<int>(face_starts.size() - 1));
  }

  // --- what the PLY/OFF/STL readers never call for our options (the OM and
  // OBJ readers do): accepted and ignored.
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override { return HalfedgeHandle(); }
  FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec2f>&) override {}
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec3f>&) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_status(VertexHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec2f&) override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec3f&) override {}
  void set_status(HalfedgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3f&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4f&) override {}
  void set_status(EdgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3d&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_color(FaceHandle, const OpenMesh::Vec4f&) override {}
  void set_status(FaceHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}

  // Reserves no more than was validated, whatever the reader asks for.
  void reserve(unsigned int vertices, unsigned int, unsigned int faces) override {
    positions.reserve(std::min<uint64_t>(vertices, max_vertices_));
    face_starts.reserve(std::min<uint64_t>(faces, max_faces_));
  }

  size_t n_vertices() const override { return positions.size(); }
  size_t n_faces() const override { return face_starts.size(); }
  size_t n_edges() const override { return 0; }

 private:
  bool Valid(VertexHandle vh) const {
    return vh.idx() >= 0 && static_cast<size_t>(vh.idx()) < positions.size();
  }
  void SetColor(VertexHandle vh, float r, float g, float b, float a) {
    if (!Valid(vh)) return;
    colors.Set(static_cast<size_t>(vh.idx()), {SrgbToLinear(r), SrgbToLinear(g), SrgbToLinear(b), a},
               positions.size());
  }

  uint64_t max_vertices_;
  uint64_t max_faces_;
  uint64_t max_corners_;
};

// Silences OpenMesh's global log streams for the lifetime of the object.
class OpenMeshQuiet {
 public:
  OpenMeshQuiet()
      : err_(omerr().is_enabled()), log_(omlog().is_enabled()), out_(omout().is_enabled()) {
    omerr().disable();
    omlog().disable();
    omout().disable();
  }
  ~OpenMeshQuiet() {
    if (err_) omerr().enable();
    if (log_) omlog().enable();
    if (out_) omout().enable();
  }
  OpenMeshQuiet(const OpenMeshQuiet&) = delete;
  OpenMeshQuiet& operator=(const OpenMeshQuiet&) = delete;

 private:
  bool err_, log_, out_;
};

// The one lock of every OpenMesh read in the process.
std::mutex& OpenMeshMutex();

// Runs `read` (a call into an OpenMesh reader returning its bool) under the
// OpenMesh lock. A RecorderLimit (our importer refusing what the library
// reads) names the file; every other exception goes through the importers'
// one boundary (exception_boundary.h).
template <typename ReadFn>
Status RunOpenMeshReader(const std::string& path, const char* format, ReadFn read) {
  return CatchExceptions(path + ": OpenMesh's " + format + " reader", [&]() -> Status {
    try {
      std::lock_guard<std::mutex> lock(OpenMeshMutex());
      OpenMeshQuiet quiet;
      if (!read()) return Bad(path, std::string("OpenMesh's ") + format + " reader could not read the file");
    } catch (const RecorderLimit& e) {
      return Bad(path, e.message + " (the file changed while it was read, or the library read it "
                                   "differently from our check)");
    }
    return Status::Ok();
  });
}

// Faces of the recorder fanned into triangles, every index checked; moves
// the recorder's arrays out.
StatusOr<Primitive> PrimitiveFromRecorder(const std::string& path, MeshRecorder& rec,
                                          std::vector<std::string>* warnings);

}  // namespace mesh_io
}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_OPENMESH_READER_H_

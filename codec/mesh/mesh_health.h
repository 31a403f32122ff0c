// Health statistics of a triangle primitive: bounding box, unreferenced
// vertices, degenerate faces and non-manifold edges.
//
// Definitions (also in docs/architecture.md):
// - unreferenced vertex: no triangle uses it;
// - degenerate face: two of its three indices are equal, or its three
//   positions are collinear (the cross product of two edges is exactly zero);
// - non-manifold edge: an undirected edge used by more than two triangles.
// Contract: pure; O(F log F) time; safe on any valid Primitive (see mesh.h).
#ifndef MESHSTREAM_CODEC_MESH_MESH_HEALTH_H_
#define MESHSTREAM_CODEC_MESH_MESH_HEALTH_H_

#include <cstdint>
#include <vector>

#include "codec/mesh/mesh.h"

namespace meshstream {

struct BoundingBox {
  Vec3d min = {0, 0, 0};
  Vec3d max = {0, 0, 0};
  bool empty = true;

  void Extend(const Vec3f& p);
  void Extend(const BoundingBox& other);
  double Diagonal() const;
};

struct MeshHealth {
  uint64_t vertices = 0;
  uint64_t faces = 0;
  uint64_t unreferenced_vertices = 0;
  uint64_t degenerate_faces = 0;
  uint64_t nonmanifold_edges = 0;
  BoundingBox bbox;           // of all vertices
  BoundingBox referenced_bbox;  // of referenced vertices only

  void Add(const MeshHealth& other);
};

MeshHealth ComputeHealth(const Primitive& primitive);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_MESH_MESH_HEALTH_H_

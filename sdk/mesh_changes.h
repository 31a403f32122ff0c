// Which vertices and triangles of a primitive's mesh changed between two
// reads by the host: what a renderer uploads to its GPU buffers after a level
// instead of the whole mesh (docs/spec/c-api.md, "Changes";
// docs/engine-integration.md, "Buffers by range").
//
// A split of the progressive decoder appends its new vertex and two
// triangles, moves the vertex it splits and renumbers one index of some of
// that vertex's triangles (docs/spec/progressive-format.md, "Vertex split"), so a level
// changes a tail of new elements and old ones scattered over the mesh; a
// decode again (a repair, parity) changes predicted positions and their
// flags. MeshChanges does not rely on any of that: it compares the new read
// element by element with a copy of the last one it keeps (quantized
// integers, so exact), whatever changed it.
//
// Cost per Update: one pass over the vertices and triangles (reads), writes
// only where something changed; memory: one quantized copy of the mesh.
// Contract: pure; no thread safety (one host thread per session, as the
// session itself).
#ifndef MESHSTREAM_SDK_MESH_CHANGES_H_
#define MESHSTREAM_SDK_MESH_CHANGES_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/vec.h"
#include "codec/mesh/quantized_mesh.h"

namespace meshstream::sdk {

// Elements [first, first + count).
struct Range {
  uint32_t first = 0;
  uint32_t count = 0;
};

class MeshChanges {
 public:
  // Compares `mesh` and `exact` (per vertex 1 where its position is the
  // loss-free decode's; a vertex past its end counts as exact) with the last
  // Update's, sets the ranges, and keeps this read as the last. The first
  // Update (and one whose attribute layout differs) is everything.
  void Update(const QuantizedMesh& mesh, const std::vector<uint8_t>& exact);

  // True when the last Update had nothing to compare with: every vertex and
  // triangle is in the ranges.
  bool everything() const { return everything_; }
  // Vertices whose position, attributes or predicted flag differ from the
  // read before, or that are new: ascending, disjoint, never adjacent.
  const std::vector<Range>& vertices() const { return vertices_; }
  // Indices that differ, or that are new: a split renumbers one index of
  // each triangle it moves, so runs of single indices, not whole triangles.
  const std::vector<Range>& indices() const { return indices_ranges_; }
  uint64_t changed_vertices() const { return changed_vertices_; }
  uint64_t changed_indices() const { return changed_indices_; }
  // The counts of the read compared with (0 for everything).
  size_t previous_vertex_count() const { return previous_vertices_; }
  size_t previous_index_count() const { return previous_indices_; }
  // The last read's flags: 1 where the vertex's position is predicted.
  const std::vector<uint8_t>& predicted() const { return predicted_; }

 private:
  bool everything_ = false;
  bool has_last_ = false;
  int channels_ = 0;
  std::vector<Vec3i> positions_;
  std::vector<int32_t> attributes_;
  std::vector<uint32_t> indices_;
  std::vector<uint8_t> predicted_;
  std::vector<Range> vertices_, indices_ranges_;
  uint64_t changed_vertices_ = 0, changed_indices_ = 0;
  size_t previous_vertices_ = 0, previous_indices_ = 0;
};

// Merges the ranges nearest each other (the smallest gaps first) until at
// most `max` remain; 0 means no limit. The gaps merged count as changed: a
// host that uploads fewer, larger ranges uploads a little more.
void LimitRanges(std::vector<Range>& ranges, size_t max);

// The elements the ranges cover.
uint64_t RangeElements(const std::vector<Range>& ranges);

}  // namespace meshstream::sdk

#endif  // MESHSTREAM_SDK_MESH_CHANGES_H_

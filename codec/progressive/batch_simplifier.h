// Simplification of a quantized mesh in batches of edge collapses: the
// encoder side of the progressive codec (paper, section 3 and 4.5; docs/design.md,
// "Batches").
//
// Each batch picks edges by a quadric error metric evaluated at the
// collapsed vertex's position, the integer midpoint floor((u + v) / 2), and
// accepts them greedily in order of cost under the strict rule of the brief:
// the vertices that collapses produce are pairwise non-adjacent in the coarser
// mesh (after a collapse of (u, v), u, v and all their neighbours are closed
// for the rest of the batch). That rule implies the paper's (collapsed edges
// share no vertex) and makes every split of a refinement independent of the
// others. A collapse is legal when both ends are interior manifold vertices
// that are not locked, the link condition holds (u and v share exactly the two
// wing vertices), the valences stay in [3, max_valence], and no surviving
// triangle flips or becomes degenerate.
//
// Locked, never collapsed: boundary vertices (so UV and normal seams, which
// are boundaries of a glTF primitive, stay crack-free at every level),
// vertices that are not one closed fan (non-manifold), and vertices of
// duplicated triangles. Triangles that repeat a vertex index are removed
// before simplification (the documented clean-up: they have no area and no
// glTF or Draco encoding keeps them).
//
// Contract: pure; O(F log F) per batch. The observer may cancel.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_BATCH_SIMPLIFIER_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_BATCH_SIMPLIFIER_H_

#include <cstdint>
#include <functional>
#include <vector>

#include "codec/mesh/quantized_mesh.h"
#include "codec/progressive/midpoint.h"
#include "codec/progressive/split_connectivity.h"
#include "codec/core/status.h"

namespace meshstream {

enum class BatchRule {
  kStrict,  // split vertices pairwise non-adjacent in the coarser mesh (the codec's rule)
  kPaper,   // only: collapsed edges share no vertex (the paper's minimum). The
            // progressive codec does not accept hierarchies built with it; it
            // exists to measure batch sizes against the strict rule.
};

struct SimplifyOptions {
  BatchRule rule = BatchRule::kStrict;
  double base_ratio = 0.02;     // stop when at most this share of the vertices is left
  uint32_t max_levels = 40;     // stop after this many batches
  int max_valence = 14;         // of a collapsed vertex
  // Called after every batch with (batch index, vertices left); return false
  // to cancel (the result is then an error).
  std::function<bool(int, size_t)> observer;
};

// One collapse, in the ids of the input mesh. u survives (at the midpoint), v
// disappears; a and b are the third vertices of the triangles (u, v, a) and
// (v, u, b). pos_* and attributes are the values before the collapse.
struct Collapse {
  uint32_t u = 0, v = 0, a = 0, b = 0;
  Vec3i pos_u{}, pos_v{};
};

struct CollapseBatch {
  std::vector<Collapse> collapses;
  std::vector<int32_t> attr_u;  // channels per collapse, values of u before
  std::vector<int32_t> attr_v;  // channels per collapse, values of v before
};

struct Hierarchy {
  std::vector<CollapseBatch> batches;  // batches[0] is applied first, to the full mesh
  std::vector<uint8_t> in_base;        // per input vertex
  std::vector<Vec3i> positions;        // per input vertex: its position in the base mesh
  std::vector<int32_t> attributes;     // per input vertex: its channels in the base mesh
  std::vector<uint32_t> base_indices;  // triangles of the base mesh, input ids
  std::vector<uint32_t> input_indices; // triangles of the input after clean-up
  uint64_t removed_faces = 0;          // triangles that repeated an index
  uint64_t locked_vertices = 0;
};

StatusOr<Hierarchy> SimplifyInBatches(const QuantizedMesh& mesh, const SimplifyOptions& options);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_BATCH_SIMPLIFIER_H_

// Simplification of a quantized mesh in batches of edge collapses: the
// encoder side of the progressive codec (paper, section 3 and 4.5; docs/design/design.md,
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
// Seams (SimplifyOptions::collapse_seams): a UV or normal seam is a boundary
// of a glTF primitive whose two sides hold the same positions. A boundary
// vertex with exactly one copy elsewhere, also on a boundary, is a seam
// twin; a boundary edge between two twinned vertices whose twins share a
// boundary edge too, in the opposite direction, collapses together with
// that edge in one batch (both to the same midpoint), so the seam stays
// crack-free at every level. Each side must be legal on its own: one
// triangle on the edge, the wing a the only common neighbour, not both of
// (u, a) and (v, a) on the boundary, valences in [2, max_valence], no
// flips. The quadrics of twins are summed (the seam is one surface).
//
// Locked, never collapsed: other boundary vertices (open boundaries, seam
// corners with three copies or more, and every seam without collapse_seams,
// so that seams stay crack-free at every level),
// vertices that are not one closed fan (non-manifold), and vertices of
// duplicated triangles. Triangles that repeat a vertex index are removed
// before simplification (the documented clean-up: they have no area and no
// glTF or Draco encoding keeps them).
//
// Contract: pure; O(F log F) once, then O(F + k log k) per batch of k
// collapses (the candidate edges stay sorted by cost between batches and
// only the edges at collapsed vertices are evaluated again). The observer may
// cancel.
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
  kStrict,    // split vertices pairwise non-adjacent in the coarser mesh (the
              // loss-tolerant profile's rule)
  kPaper,     // only: collapsed edges share no vertex (the paper's minimum). The
              // progressive codec does not accept hierarchies built with it; it
              // exists to measure batch sizes against the strict rule.
  kMatching,  // the reliable profile's (format version 4): collapsed edges share
              // no vertex, each collapse applied at once and checked on the mesh
              // the earlier ones of its batch left (legal in that order); seams
              // collapse on both sides together as under kStrict. The decoder
              // applies a refinement's splits one after the other in split-bit
              // order, each on the mesh the earlier ones left
              // (docs/spec/progressive-format.md, "Version 4").
};

struct SimplifyOptions {
  BatchRule rule = BatchRule::kStrict;
  double base_ratio = 0.02;     // stop when at most this share of the vertices is left
  uint32_t max_levels = 40;     // stop after this many batches
  // Stop, before it, at a batch that would collapse fewer than
  // min_batch_collapses and less than min_batch_share of the vertices left:
  // a level costs its control block and datagram headers (about 130 bytes
  // on spot) whatever its size, more than a few base vertices cost in Draco
  // (docs/design/codec.md, "The base").
  double min_batch_share = 0.05;
  uint32_t min_batch_collapses = 16;
  int max_valence = 14;         // of a collapsed vertex
  // kMatching: a batch takes at most this share of the vertices left (1:
  // every legal collapse, in order of cost).
  double max_batch_share = 1.0;
  bool collapse_seams = false;  // collapse seam edges on both sides together (format version 2's seams tool)
  // Tests: before every batch, compare the candidate list kept up to date
  // since the last batch with one evaluated and sorted from scratch, and fail
  // (kInternal) when they differ. O(F log F) per batch.
  bool check_candidates = false;
  // Called after every batch with (batch index, vertices left); return false
  // to cancel (the result is then an error).
  std::function<bool(int, size_t)> observer;
};

// One collapse, in the ids of the input mesh. u survives (at the midpoint), v
// disappears; a and b are the third vertices of the triangles (u, v, a) and
// (v, u, b). delta = u's position - v's before the collapse (both on the
// grid, so it fits 32 bits); u's collapsed position is their midpoint.
// A seam collapse has b = kNoWing, `twin` the index of the other side's
// collapse in the batch, and `uva` whether its triangle was (u, v, a) in
// cyclic order (else (v, u, a)).
constexpr uint32_t kNoWing = UINT32_MAX;
struct Collapse {
  uint32_t u = 0, v = 0, a = 0, b = 0;
  Vec3i delta{};
  uint32_t twin = UINT32_MAX;
  bool uva = false;
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
  uint64_t input_faces = 0;            // triangles of the input after clean-up
  uint64_t removed_faces = 0;          // triangles that repeated an index
  uint64_t locked_vertices = 0;
  std::vector<uint32_t> twin;          // per input vertex: its seam twin (UINT32_MAX if none)
};

// Works in the mesh's own arrays: pass std::move(mesh) to give them up (the
// encoder does, so that the input is not held twice at the peak), or a copy.
StatusOr<Hierarchy> SimplifyInBatches(QuantizedMesh mesh, const SimplifyOptions& options);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_BATCH_SIMPLIFIER_H_

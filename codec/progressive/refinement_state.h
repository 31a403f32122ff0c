// The state a decoder refines, level by level: the connectivity of the
// current mesh, the values of its vertices on the grids, and per vertex the
// flags that say what of it may differ from the lossless decode.
//
// This header applies splits whose structure and geometry are both known
// (the lossless path, and case 1 of the paper under loss). What happens to a
// split whose data was lost lives in recovery/recover_split.h; both keep the
// vertex numbering of the split bits (docs/design/design.md, "Canonical order").
//
// Contract: pure; errors leave the state valid. Reserve* grow storage only
// by the splits really applied, never to a size a header merely claims.
// Thread safety: none.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_REFINEMENT_STATE_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_REFINEMENT_STATE_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/status.h"
#include "codec/core/vec.h"
#include "codec/mesh/quantized_mesh.h"
#include "codec/progressive/refinement.h"
#include "codec/progressive/seam_twins.h"
#include "codec/progressive/split_connectivity.h"

namespace meshstream {

// Per-vertex flags of a decoder's state (docs/design/loss-tolerance.md).
enum VertexFlag : uint8_t {
  kRingInexact = 1,      // its ring may differ from the lossless decode's
  kPositionInexact = 2,  // its values may differ from the lossless decode's
  kAbsent = 4,           // LwoP never created it (no faces)
};

struct RefinementState {
  SplitConnectivity connectivity;
  std::vector<uint32_t> scratch_ring;
  std::vector<Vec3i> positions;
  std::vector<int32_t> attributes;
  std::vector<uint8_t> reliable;  // per vertex: 1 when flags are 0 (bitstream/reader.h)
  std::vector<uint8_t> flags;     // per vertex: VertexFlag bits
  // While both are false every flag is 0: only a prediction (any_inexact)
  // and an abandoned split (any_absent) set flags (recover_split.h).
  bool any_absent = false;
  bool any_inexact = false;  // some split was predicted
  int channels = 0;
  // Per vertex: its seam twin or kNoTwin (seam_twins.h); reliable data.
  std::vector<uint32_t> twin;
  // Between BeginSplits(r) and EndSplits(r): the vertices that are stable
  // while r is applied, whatever the order of its splits (older than r and
  // not split by it; ring_predictor.h). None outside.
  uint32_t stable_below = 0;
  std::vector<uint8_t> splitting;  // per vertex below stable_below: 1 when r splits it
  bool Stable(uint32_t v) const { return v < stable_below && splitting[v] == 0; }
  void BeginSplits(const Refinement& r);
  void EndSplits(const Refinement& r);

  // Resets to `base` with no seam twins; SetTwins then gives the base's.
  Status Reset(const QuantizedMesh& base);
  Status SetTwins(const std::vector<std::array<uint32_t, 2>>& pairs);
  // Applies split j of `r` (all data present). Errors leave the state valid.
  Status ApplySplit(const Refinement& r, size_t j);
  // The same right after connectivity.CyclicRing(w, scratch_ring) and with
  // the wings' ring positions resolved; returns the new vertex.
  uint32_t ApplySplitAt(const Refinement& r, size_t j, size_t a_at, size_t b_at);
  // The seam split j of `r` (w has a twin) right after
  // connectivity.OpenRing(w, scratch_ring), with the wing at ring position
  // a_at: the primary's new vertex takes the tail of w's fan, the
  // secondary's the head, and the secondary makes the two new vertices
  // twins. Returns the new vertex.
  uint32_t ApplySeamSplitAt(const Refinement& r, size_t j, size_t a_at);
  // The vertex a new vertex of split j takes its twin from: for the
  // secondary of a seam pair, the primary's new vertex; else kNoTwin.
  uint32_t NewTwin(const Refinement& r, size_t j) const;
  // Appends the new vertex of split j's twin entry (after its values).
  void PushTwin(const Refinement& r, size_t j);
  Status ApplyRefinement(const Refinement& r);
  // Cache hints for the splits after split j of `r` (ApplySplitAt issues
  // them; no effect on the state).
  void PrefetchSplits(const Refinement& r, size_t j) const;
  static constexpr size_t kPrefetchDistance = 2;
  // The values of w and its new vertex n from split j's deltas; pushes n's
  // position, values, flags and reliability.
  void SetPair(const Refinement& r, size_t j, uint32_t w, uint32_t n);
  // Channels [first, first + count) of split j of w into (w, n), applied
  // with their coded residuals as the differences, get the predicted
  // differences p[0..count) added: each pair of values is made again from
  // its coarse midpoint with the sum, which is written to split j of
  // `decoded` (when not null) as the difference now applied.
  void AddPredictedDeltas(size_t j, uint32_t w, uint32_t n, size_t first, const int32_t* p, size_t count,
                          Refinement* decoded);
  // Sets flag bits of v and keeps reliable[v] in step with them.
  void Mark(uint32_t v, uint8_t bits) {
    flags[v] |= bits;
    reliable[v] = flags[v] == 0;
  }
  // Room for `splits` more vertices, grown geometrically (never to a size a
  // header merely claims: only by the splits really being applied).
  void ReserveSplits(size_t splits);
  // Room for this many vertices, so that splits do not reallocate.
  void Reserve(uint32_t final_vertices);
  QuantizedMesh Snapshot(const QuantizedMesh& base_layout) const;
  // The same into `out`, reusing its arrays' capacity (a caller that takes
  // a snapshot per level allocates, and faults pages in, only once).
  void SnapshotInto(const QuantizedMesh& base_layout, QuantizedMesh& out) const;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_REFINEMENT_STATE_H_

// The progressive representation of one primitive, in memory: a base mesh in
// canonical vertex order and a list of refinements from coarse to fine.
// Serialization (progressive_bitstream.h) and packetization (packetizer.h)
// turn it into bytes; this header is the contract between encoder and
// decoder.
//
// Canonical order (BRIEF, property 2): the base mesh's vertices are numbered
// in the order in which its decoder (Draco) returns them. Refinement i splits
// the vertices whose split bit is 1, in ascending id order; the j-th split
// creates vertex `vertices_before + j`. Ids therefore follow from the split
// bits alone.
//
// Structure of a split: the wing a, as an index into the split vertex's
// neighbours sorted by id, and the wing b, as the number of steps from a to
// b around the split vertex's ring in the direction of its triangles (1 to
// degree - 1); both refer to the coarser mesh before the refinement, so the
// order of splits does not matter. The encoder orients every split so that
// this offset is at most half the degree. Geometry: the
// differences u - v of positions and attribute channels of the two vertices
// after the split, where the coarser vertex holds floor((u + v) / 2).
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_MESH_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_MESH_H_

#include <array>
#include <cstdint>
#include <vector>

#include "codec/quantized_mesh.h"
#include "codec/split_mesh.h"
#include "codec/split_prediction.h"
#include "codec/status.h"

namespace meshstream {

struct Refinement {
  uint32_t vertices_before = 0;
  std::vector<uint32_t> split_vertices;       // ascending canonical ids
  std::vector<std::array<uint16_t, 2>> wings; // per split: a's index among sorted neighbours, ring offset to b
  std::vector<Vec3i> position_delta;          // per split: u - v
  std::vector<int32_t> attribute_delta;       // per split: channels of u - v
  size_t split_count() const { return split_vertices.size(); }
};

struct ProgressiveMesh {
  QuantizedMesh base;  // canonical order
  std::vector<Refinement> refinements;
  std::vector<uint32_t> level_vertices() const;
};

// The coded structure of a split of w, given w's cyclic ring
// (SplitMesh::CyclicRing) and the ring positions of its wings a and b:
// {rank of a among the ring's ids, ring steps from a to b}. Encoder and
// decoder both go through these two functions.
std::array<uint16_t, 2> WingsOf(const std::vector<uint32_t>& ring, size_t a_at, size_t b_at);
// The inverse; false when the coded wings do not fit this ring.
bool WingPositions(const std::vector<uint32_t>& ring, const std::array<uint16_t, 2>& wings, size_t* a_at,
                   size_t* b_at);

enum class Recovery : uint8_t {
  kPredict = 0,  // predict lost structure and/or geometry (the default)
  kLwop = 1,     // loss without prediction: abandon lost splits and their dependants
};

// What became of the splits of the refinements finished so far.
struct RecoveryStats {
  uint64_t exact = 0;               // case 1: both arrived and applied as coded
  uint64_t predicted_both = 0;      // case 2: both lost, both predicted
  uint64_t predicted_structure = 0; // case 3: structure lost (or did not fit the ring), geometry arrived
  uint64_t predicted_geometry = 0;  // case 4: geometry lost, structure arrived
  uint64_t structure_fallbacks = 0; // arrived structure that did not fit the ring the decoder has
  uint64_t structure_distrusted = 0; // arrived structure on a changed ring, replaced by case 3
  uint64_t abandoned = 0;           // kLwop: splits not applied
  uint64_t predicted() const { return predicted_both + predicted_structure + predicted_geometry; }
  void Add(const RecoveryStats& o);
};

// Per-vertex flags of a decoder's state (docs/loss-tolerance.md).
enum VertexFlag : uint8_t {
  kRingInexact = 1,      // its ring may differ from the lossless decode's
  kPositionInexact = 2,  // its values may differ from the lossless decode's
  kAbsent = 4,           // LwoP never created it (no faces)
};

// The state a decoder refines: connectivity plus values on the grids.
struct RefinementState {
  SplitMesh connectivity;
  std::vector<uint32_t> scratch_ring;
  // Reused by RecoverSplit so that predicting a split allocates nothing.
  struct PredictionScratch {
    std::vector<Vec3i> ring_positions;
    std::vector<int32_t> values, u_channels, v_channels;
    RingFrame frame;
    PredictedGeometry geometry;
  } prediction;
  std::vector<Vec3i> positions;
  std::vector<int32_t> attributes;
  std::vector<uint8_t> reliable;  // per vertex: 1 when flags are 0 (stream_reader.h)
  std::vector<uint8_t> flags;     // per vertex: VertexFlag bits
  bool any_absent = false;
  bool any_inexact = false;  // some split was predicted
  int channels = 0;

  Status Reset(const QuantizedMesh& base);
  // Applies split j of `r` (all data present). Errors leave the state valid.
  Status ApplySplit(const Refinement& r, size_t j);
  // The same right after connectivity.CyclicRing(w, scratch_ring) and with
  // the wings' ring positions resolved; returns the new vertex.
  uint32_t ApplySplitAt(const Refinement& r, size_t j, size_t a_at, size_t b_at);
  Status ApplyRefinement(const Refinement& r);
  // Split j of `r` with only the parts that arrived; the rest is predicted
  // or, with kLwop, the split is abandoned (split_recovery.cc). Keeps the
  // vertex numbering: an abandoned split still takes its id (kAbsent).
  Status RecoverSplit(const Refinement& r, size_t j, bool has_structure, bool has_geometry, Recovery recovery,
                      RecoveryStats* stats);
  // How many triangles of v are collinear on the grid.
  int Degenerate(uint32_t v) const;
  // After a split of w into w and n: moves n (else w) by a grid step or
  // three when a triangle of theirs is collinear; true when something moved.
  bool AvoidDegenerateFaces(uint32_t w, uint32_t n);
  // Room for `splits` more vertices, grown geometrically (never to a size a
  // header merely claims: only by the splits really being applied).
  void ReserveSplits(size_t splits);
  // Room for this many vertices, so that splits do not reallocate.
  void Reserve(uint32_t final_vertices);
  QuantizedMesh Snapshot(const QuantizedMesh& base_layout) const;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_MESH_H_

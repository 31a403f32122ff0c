// The progressive representation of one primitive, in memory: a base mesh in
// canonical vertex order and a list of refinements from coarse to fine.
// bitstream/writer.h turns it into bytes and datagrams, bitstream/reader.h
// back; this header is the contract between encoder and decoder.
//
// Canonical order (docs/design/design.md, "Canonical order"): the base mesh's vertices are numbered
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
//
// A seam split (the split vertex has a seam twin, seam_twins.h) has one
// wing: wings[j] = {a's position in w's open ring (SplitConnectivity::
// OpenRing), 0}; its split vector is coded as it is (no tool predicts it),
// and both splits of the pair carry the same one.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_REFINEMENT_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_REFINEMENT_H_

#include <array>
#include <cstdint>
#include <vector>

#include "codec/mesh/quantized_mesh.h"
#include "codec/core/status.h"

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
  std::vector<std::array<uint32_t, 2>> base_twins;  // seam twins of the base, (smaller, larger) canonical ids
  std::vector<Refinement> refinements;
  std::vector<uint32_t> level_vertices() const;
};

// The coded structure of a split of w, given w's cyclic ring
// (SplitConnectivity::CyclicRing) and the ring positions of its wings a and b:
// {rank of a among the ring's ids, ring steps from a to b}. Encoder and
// decoder both go through these two functions.
std::array<uint16_t, 2> WingsOf(const std::vector<uint32_t>& ring, size_t a_at, size_t b_at);
// The inverse; false when the coded wings do not fit this ring.
bool WingPositions(const std::vector<uint32_t>& ring, const std::array<uint16_t, 2>& wings, size_t* a_at,
                   size_t* b_at);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_REFINEMENT_H_

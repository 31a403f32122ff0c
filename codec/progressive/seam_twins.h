// Seam twins: the two copies of a vertex on a UV or normal seam, which a
// glTF primitive keeps as two vertices with one position (docs/design/codec.md,
// "Seams"; docs/spec/progressive-format.md, "Seam split"). With the seams tool a
// seam edge is collapsed on both sides in one batch, so the decoder splits
// both copies in one refinement, with one split vector, and both sides stay
// crack-free at every level.
//
// The twin relation is reliable data: the stream header lists the base
// mesh's pairs, and the seam split of w (twin w') with new vertex n and of
// w' with new vertex n' makes n and n' twins. The split of the twin with
// the smaller id is the pair's primary: its datagram unit carries both
// sides' data, and the secondary's unit is empty.
//
// Contract: pure, O(splits log splits), safe on any input (errors name the
// vertex). Thread safety: none.
#ifndef MESHSTREAM_CODEC_PROGRESSIVE_SEAM_TWINS_H_
#define MESHSTREAM_CODEC_PROGRESSIVE_SEAM_TWINS_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

constexpr uint32_t kNoTwin = UINT32_MAX;
// A seam split's wing is its position in the open ring, sent as raw bits:
// a seam vertex has fewer than 2^kSeamWingBits neighbours when it splits.
constexpr int kSeamWingBits = 4;
constexpr size_t kMaxSeamValence = (size_t{1} << kSeamWingBits);

// A refinement's seam pairs: partner[j] is the index of the split of
// split_vertices[j]'s twin, or kNoTwin for an interior split. Fails when a
// split vertex has a twin that does not split in the same refinement.
// `split_vertices` ascending; `twin` per vertex of the coarser mesh.
Status SeamPartners(const std::vector<uint32_t>& split_vertices, const std::vector<uint32_t>& twin,
                    std::vector<uint32_t>* partner);

// Per vertex of a mesh of `vertex_count` vertices: its twin or kNoTwin.
// Fails when a pair names a vertex beyond the mesh, or a vertex twice.
Status TwinTable(const std::vector<std::array<uint32_t, 2>>& pairs, uint32_t vertex_count,
                 std::vector<uint32_t>* twin);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_PROGRESSIVE_SEAM_TWINS_H_

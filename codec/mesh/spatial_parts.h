// Spatial parts of one mesh: a large quantized mesh is cut into parts that
// each become an independent progressive stream (docs/design/codec.md,
// "Spatial parts"; docs/spec/progressive-format.md, section 1, "Parts").
//
// The cut: a k-d split of the triangles by their centroids (the sum of their
// three integer grid positions, exact): the triangles are split at the
// median of the longest axis of their centroids' box, each half again, until
// there are `parts` groups (a group of n parts is split n/2 : n - n/2 in
// proportion). Ties are broken by triangle index, so the cut is one and the
// same on every machine. A part holds its triangles (input order) and the
// vertices they reference (input order), on the grids of the whole mesh:
// a vertex on the border between parts is in each of them with the same grid
// values, so it dequantizes to the same floats in every part.
//
// No crack at any combination of levels: the simplifier locks every boundary
// vertex (progressive/batch_simplifier.h), and a cut makes the border a
// boundary of each part, so border vertices and border edges are in every
// part's base and never move.
//
// Contract: pure, O(F log F); the parts' triangles are exactly the mesh's
// triangles (none lost, none twice), each part has at least one triangle
// when `parts` <= triangles. `parts` is clamped to [1, triangles].
#ifndef MESHSTREAM_CODEC_MESH_SPATIAL_PARTS_H_
#define MESHSTREAM_CODEC_MESH_SPATIAL_PARTS_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "codec/mesh/quantized_mesh.h"

namespace meshstream {

// Above this many referenced vertices a mesh is cut (docs/design/codec.md,
// "Spatial parts", has the measurement behind it).
constexpr uint64_t kDefaultPartVertices = 262144;
// The most parts a mesh is cut into.
constexpr size_t kMaxParts = 4096;

// How many parts a mesh of `vertices` referenced vertices is cut into: 1 when
// part_vertices is 0 or vertices <= part_vertices, else the smallest power
// of two of at least vertices / part_vertices (at most kMaxParts): halves
// of a k-d tree, whose parts are alike in size and share 2, 4, 8 ... cores
// evenly.
size_t PartCount(uint64_t vertices, uint64_t part_vertices);

// The parts, in the order of the k-d tree's leaves (lower half first);
// RepairBowties has run on the cut (8 rounds).
std::vector<QuantizedMesh> SplitIntoParts(const QuantizedMesh& mesh, size_t parts);

// A vertex's triangles of one part must be one fan (connected through edges
// at the vertex): a cut through a vertex that leaves a part two fans there
// (a bowtie) makes the part's base non-manifold, Draco's edgebreaker splits
// such a vertex, and the encoder's match of the decoded base refuses it (it
// then falls back to a base coding about 2.5 x larger). Each round visits
// every vertex: the smallest fan there that is not its part's largest moves
// to the part of a triangle beside it (sharing an edge at the vertex; else
// any other part there). `part_of_triangle` holds a part per triangle and is
// changed in place; stops after `rounds` rounds or a round without a move;
// returns the vertices that still have a fan to move.
size_t RepairBowties(const QuantizedMesh& mesh, std::vector<uint32_t>& part_of_triangle, int rounds);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_MESH_SPATIAL_PARTS_H_

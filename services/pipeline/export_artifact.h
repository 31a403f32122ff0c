// A version's artifact in the format a client asks for (the Export RPC),
// at a level of detail.
//
// Rules (docs/design/pipeline.md, "Export"):
//   kProgressiveGlb  the artifact's bytes unchanged. A lod is refused
//                    (InvalidArgument "lod: not supported for the progressive
//                    format (it holds every level)"): cutting levels would
//                    mean a re-encode, a different artifact than the one
//                    the version names.
//   kGlb, kDracoGlb  DecodeProgressiveGlb at `lod` refinements (unset: all;
//                    outside [0, levels]: InvalidArgument "lod: K is outside
//                    [0, L]"), then ExportGlb, as `meshstream decode -o x.glb`
//                    writes it; kDracoGlb compresses every primitive with
//                    Draco at the artifact's own quantization bits (qp, qn,
//                    qt, qc of its streams), so that at full lod the export
//                    is same_on_grid with the source at that qp (the grid of
//                    `meshstream convert --draco --qp N`).
//   kObj, kPly       the decoded scene flattened into one mesh in world space
//                    (importers/mesh_writer.h: positions, normals, the first
//                    UV set when there is one primitive), as `meshstream
//                    decode -o x.obj` writes it; materials and hierarchy are
//                    not kept.
// Streams are decoded without loss (no simulated network).
//
// Contract: the artifact bytes are treated as untrusted (the decoder checks
// them). OBJ and PLY go through a private temporary folder (the writers
// write files), removed before returning. No exception escapes.
// Thread safety: calls are independent.
#ifndef MESHSTREAM_SERVICES_PIPELINE_EXPORT_ARTIFACT_H_
#define MESHSTREAM_SERVICES_PIPELINE_EXPORT_ARTIFACT_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "proto/export_formats.h"

namespace meshstream {

// `temp_parent`: where OBJ/PLY are written on the way ("" = the system's
// temporary folder).
StatusOr<std::vector<uint8_t>> ExportArtifact(const std::vector<uint8_t>& progressive_glb, ExportFormat format,
                                              std::optional<int> lod, const std::string& temp_parent = "");

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_PIPELINE_EXPORT_ARTIFACT_H_

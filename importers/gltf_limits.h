// Validation of a glTF document's raw JSON and GLB framing, done before any
// library touches the data: GLB chunk lengths (overflow-checked), URIs that
// would leave the asset's folder, bufferViews that reach past their buffer.
//
// Contract: safe on untrusted input; never allocates more than the size of
// the input. Errors name the JSON path ("bufferViews[3]: ...").
#ifndef MESHSTREAM_IMPORTERS_GLTF_LIMITS_H_
#define MESHSTREAM_IMPORTERS_GLTF_LIMITS_H_

#include <cstddef>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "codec/core/status.h"

namespace meshstream {

constexpr uint32_t kGlbMagic = 0x46546C67;       // "glTF"
constexpr uint32_t kGlbChunkJson = 0x4E4F534A;   // "JSON"
constexpr uint32_t kGlbChunkBin = 0x004E4942;    // "BIN\0"

struct GlbView {
  const uint8_t* json = nullptr;
  size_t json_size = 0;
  const uint8_t* bin = nullptr;  // nullptr when the GLB has no BIN chunk
  size_t bin_size = 0;
};

bool LooksLikeGlb(const uint8_t* data, size_t size);

// Splits a GLB into its JSON and BIN chunks, checking the header, the version
// (2), the total length and every chunk length against the bytes present.
StatusOr<GlbView> ParseGlb(const uint8_t* data, size_t size);

// A URI is acceptable if it is a data: URI, or a relative path (after
// percent-decoding) with no scheme, no leading '/', no '\\', no ".." segment
// and no NUL. Returns the decoded relative path ("" for data: URIs).
StatusOr<std::string> CheckUri(const std::string& uri, const std::string& where);

// Checks the document's buffers, bufferViews and accessors against each
// other and against declared byteLengths, and every buffer/image URI.
// `glb_bin_size` is the size of the GLB's BIN chunk (0 when absent or not GLB).
Status ValidateGltfDocument(const nlohmann::json& doc, bool is_glb, size_t glb_bin_size);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_GLTF_LIMITS_H_

// The files of a .gltf on disk besides the .gltf itself: the buffers and
// images it names by a relative URI. An uploader sends them with the .gltf
// (sdk/asset_client.h); the importer reads them from the same folder.
//
// Contract: safe on untrusted input. Every URI goes through CheckUri
// (gltf_limits.h), the one percent-decoder and path check of the importers,
// so a name listed here is one the importer would accept and read.
// Thread safety: pure (reads the file named, nothing else).
#ifndef MESHSTREAM_IMPORTERS_GLTF_FILES_H_
#define MESHSTREAM_IMPORTERS_GLTF_FILES_H_

#include <cstdint>
#include <string>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

// The decoded relative paths of the external files of the glTF JSON document
// `json` (buffers[], then images[]; data: URIs are not files), each once, in
// document order. InvalidInput when the document is not a JSON object or a
// URI is refused (the error names it: "scene.gltf: images[2].uri: ...").
// `where` names the document in errors.
StatusOr<std::vector<std::string>> GltfExternalFiles(const uint8_t* json, size_t size, const std::string& where);

// The same for the .gltf file at `path` (read whole, at most 256 MiB).
StatusOr<std::vector<std::string>> GltfExternalFiles(const std::string& path);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_GLTF_FILES_H_

// Reading any supported file into a Scene, and writing a Scene as glTF.
//
// Contract: safe on untrusted input. Sizes and counts are checked against the
// bytes really present before anything is allocated; no file outside the
// asset's own folder is opened because a URI says so; no exception escapes.
// Errors name the file and what is wrong ("model.glb: accessors[2]: ...").
// Thread safety: the functions keep no state; distinct calls may run in
// parallel.
#ifndef MESHSTREAM_IMPORTERS_IMPORT_H_
#define MESHSTREAM_IMPORTERS_IMPORT_H_

#include <cstdint>
#include <string>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/core/status.h"

namespace meshstream {

// Inputs above this size are refused (ResourceExhausted) before they are read.
constexpr uint64_t kDefaultMaxInputBytes = uint64_t{1} << 30;  // 1 GiB

struct ImportOptions {
  uint64_t max_input_bytes = kDefaultMaxInputBytes;
};

// Chooses the reader by extension (case-insensitive): .gltf .glb .obj .ply .off .stl
StatusOr<Scene> ImportFile(const std::string& path, const ImportOptions& options = {});

// Reads a whole file, refusing files above `max_bytes`.
StatusOr<std::vector<uint8_t>> ReadFileBytes(const std::string& path, uint64_t max_bytes);
Status WriteFileBytes(const std::string& path, const std::vector<uint8_t>& bytes);

// Lower-case extension of `path` including the dot ("" when there is none).
std::string FileExtension(const std::string& path);
// The file name of `path`: what follows its last '/' (all of it without one).
std::string FileBaseName(const std::string& path);
// The folder of `path` with its trailing '/' ("" without one), so that
// FileFolder(path) + FileBaseName(path) == path.
std::string FileFolder(const std::string& path);
// The file name without its extension (the last '.' and what follows); a
// name that starts with its only dot is all stem (".obj" stays ".obj").
std::string FileStem(const std::string& path);

}  // namespace meshstream

#endif  // MESHSTREAM_IMPORTERS_IMPORT_H_

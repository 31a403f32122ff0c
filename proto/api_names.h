// The names clients give, checked the same way by the server (services/),
// the SDK and the CLI before a request leaves: names of assets, tenants and
// ids, and the names of the files of an upload before any becomes a path on
// disk.
//
// Names: assets, tenants, upload ids, job ids and token ids are
// [A-Za-z0-9._-]{1,128}, and not "." or ".." (they would name folders);
// refusals are InvalidArgument starting with the field's name and never quote
// the value.
//
// A resource (an external file of a .gltf: its .bin, its images) is named by
// a relative path inside the upload and nothing else: the materializer
// (services/pipeline/materialize.h) writes it under the job's work folder by that path, so a
// name that could leave the folder, or mean different files on different
// systems, is refused here. The main file is a plain file name whose
// extension chooses the importer (importers/import.h).
//
// Contract: names are untrusted bytes; the checks are pure and allocate
// little. Messages quote the name made printable (valid UTF-8, control
// characters as '?', at most 64 bytes) and say what is wrong:
// "resource name '../x': '..' segments are not allowed".
// Thread safety: pure functions.
#ifndef MESHSTREAM_PROTO_API_NAMES_H_
#define MESHSTREAM_PROTO_API_NAMES_H_

#include <cstddef>
#include <string>

#include "codec/core/status.h"

namespace meshstream {

constexpr size_t kMaxNameBytes = 128;
bool IsValidName(const std::string& name);
// InvalidArgument naming `field` when `name` is not valid.
Status CheckName(const std::string& field, const std::string& name);

constexpr size_t kMaxResourceNameBytes = 512;
constexpr size_t kMaxMainFilenameBytes = 255;  // one path component on common file systems

// OK when `name` is a relative path inside the upload: non-empty, at most
// kMaxResourceNameBytes, valid UTF-8, no NUL or other control character, no
// backslash, not absolute, no drive letter ("C:" first), segments separated
// by single '/' none of which is empty, "." or "..". InvalidArgument otherwise.
Status CheckResourceName(const std::string& name);

// OK when `filename` is a plain file name (the rules above, and no '/') with
// an extension ImportFile reads: .gltf .glb .obj .ply .off .stl, in any case.
// InvalidArgument "filename 'x': ..." otherwise.
Status CheckMainFilename(const std::string& filename);

// The printable form of an untrusted name used in the messages above.
std::string PrintableName(const std::string& name);

}  // namespace meshstream

#endif  // MESHSTREAM_PROTO_API_NAMES_H_

// Export of a stored version in a format: what the Export RPC and
// `meshstream export` deliver. Full-detail exports are cached as blobs (the
// artifact cache keyed by artifact digest, format and exporter revision), so
// the second export of the same version and format costs one verified blob
// read; exports at a level of detail are made each time. An export larger
// than `max_bytes` is ResourceExhausted.
//
// Contract: tenant, asset and version come from the request (untrusted);
// version 0 is the latest READY version; a version that is not READY is
// FailedPrecondition naming its state (and the job's message when FAILED).
// Thread safety: stateless; callable from any thread.
#ifndef MESHSTREAM_SERVICES_EXPORT_EXPORT_VERSION_H_
#define MESHSTREAM_SERVICES_EXPORT_EXPORT_VERSION_H_

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "codec/core/status.h"
#include "services/pipeline/export_artifact.h"
#include "services/store/ready_version.h"
#include "services/store/store.h"

namespace meshstream {

// Bumped when an export format's output changes (the export cache key holds it).
constexpr int kExporterRevision = 1;

struct ExportedVersion {
  VersionRecord version;
  std::vector<uint8_t> bytes;
  std::string sha256;
  bool cached = false;  // served from the export cache
};

// `before_decode`, when set, runs only when the export must decode (not for
// the stored progressive file, nor for a hit in the export cache); an error
// from it ends the export with that status (the service takes a slot of its
// limit on concurrent decodes there).
StatusOr<ExportedVersion> ExportVersion(Store& store, const std::string& tenant, const std::string& asset,
                                        int64_t version, ExportFormat format, std::optional<int> lod,
                                        uint64_t max_bytes, const std::function<Status()>& before_decode = {});

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_EXPORT_EXPORT_VERSION_H_
